//! Many-thread IPC stress: semaphore ping-pong between real threads and a queue that keeps
//! every message under contention with timeouts in play.

use std::sync::Arc;
use std::time::Duration;

use wrc_rt::ipc::{MessageQueue, RecvError, Semaphore, TrySendError};

#[test]
fn semaphore_ping_pong_never_loses_a_wake_up() {
    let (ping, pong) = (Arc::new(Semaphore::new(0)), Arc::new(Semaphore::new(0)));
    let rounds = 20_000;
    let partner = {
        let (ping, pong) = (ping.clone(), pong.clone());
        std::thread::spawn(move || {
            for _ in 0..rounds {
                assert!(ping.wait_timeout(Duration::from_secs(10)), "lost a ping");
                pong.post();
            }
        })
    };
    for _ in 0..rounds {
        ping.post();
        assert!(pong.wait_timeout(Duration::from_secs(10)), "lost a pong");
    }
    partner.join().unwrap();
}

#[test]
fn a_full_queue_returns_the_message_under_contention() {
    let q = Arc::new(MessageQueue::new(2));
    let senders: Vec<_> = (0..4u32)
        .map(|s| {
            let q = q.clone();
            std::thread::spawn(move || {
                let (mut sent, mut returned) = (0u32, 0u32);
                for i in 0..5_000 {
                    match q.try_send(s * 100_000 + i) {
                        Ok(()) => sent += 1,
                        Err(TrySendError::Full(m)) => {
                            assert_eq!(m, s * 100_000 + i, "a different message came back");
                            returned += 1;
                        }
                    }
                }
                (sent, returned)
            })
        })
        .collect();
    let receiver = {
        let q = q.clone();
        std::thread::spawn(move || {
            let mut got = 0u32;
            loop {
                match q.recv_timeout(Duration::from_millis(300)) {
                    Ok(_) => got += 1,
                    Err(RecvError::Timeout) => return got,
                    Err(e) => panic!("{e}"),
                }
            }
        })
    };
    let (sent, returned) = senders
        .into_iter()
        .map(|s| s.join().unwrap())
        .fold((0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    assert_eq!(sent + returned, 20_000);
    assert_eq!(receiver.join().unwrap(), sent);
}
