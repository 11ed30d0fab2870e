//! Zero allocation in the per-cycle path: the driver's step (sleep or wait, cycle,
//! statistics, overrun event), the waiters and notifiers, and the IPC a cycle uses, with real
//! and mock clocks.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use wrc_rt::ipc::{self, MessageQueue, Semaphore};
use wrc_rt::wake::{FdWake, Waiter, Wake};
use wrc_rt::{
    Clock, CycleContext, MockClock, MonotonicClock, Release, StatsCell, Step, TaskDriver,
};

use wrc_alloc_count::allocations_in;

#[test]
fn driver_steps_allocate_nothing_with_the_real_clock() {
    wrc_alloc_count::assert_installed();
    // Everything a cycle may touch is created here, before counting starts.
    let sem = Arc::new(Semaphore::new(0));
    let queue = Arc::new(MessageQueue::<[u64; 4]>::new(8));
    let (mut spsc_tx, mut spsc_rx) = ipc::spsc::channel::<[i32; 4]>(8);
    let (mut mb_w, mut mb_r) = ipc::mailbox([0i64; 4]);
    let task = {
        let (sem, queue) = (sem.clone(), queue.clone());
        move |ctx: &CycleContext| {
            sem.post();
            assert!(sem.try_wait());
            let _ = queue.try_send([ctx.cycle; 4]);
            let _ = queue.try_recv();
            let _ = spsc_tx.try_send([1, 2, 3, 4]);
            let _ = spsc_rx.try_recv();
            mb_w.write([ctx.cycle as i64; 4]);
            std::hint::black_box(mb_r.read());
        }
    };
    let stats = Arc::new(StatsCell::new());
    let (tx, _rx) = rtrb::RingBuffer::new(4);
    let clock = MonotonicClock;
    let mut driver = TaskDriver::new(
        clock,
        task,
        clock.now_ns() + 1_000_000,
        200_000,
        stats.clone(),
        tx,
        Arc::new(AtomicBool::new(false)),
    );
    let (n, ()) = allocations_in(|| {
        for _ in 0..300 {
            assert_eq!(driver.step(), Step::Ran);
        }
    });
    assert_eq!(n.total(), 0, "{n:?} in 300 cycles");
    assert_eq!(stats.snapshot().cycles, 300);
}

#[test]
fn overruns_and_a_full_event_queue_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let clock = MockClock::new(0);
    let c = clock.clone();
    // Every cycle overruns; the event queue (capacity 2) fills up after two.
    let task = move |_: &CycleContext| c.advance_ns(2_500);
    let stats = Arc::new(StatsCell::new());
    let (tx, _rx) = rtrb::RingBuffer::new(2);
    let mut driver = TaskDriver::new(
        clock,
        task,
        1_000,
        1_000,
        stats.clone(),
        tx,
        Arc::new(AtomicBool::new(false)),
    );
    let (n, ()) = allocations_in(|| {
        for _ in 0..1000 {
            driver.step();
        }
    });
    assert_eq!(n.total(), 0, "{n:?}");
    let s = stats.snapshot();
    assert_eq!((s.overruns, s.missed_periods), (1000, 2000));
}

#[test]
fn event_released_steps_and_their_notifications_allocate_nothing() {
    use std::io::{Read, Write};
    use std::os::unix::net::UnixStream;
    wrc_alloc_count::assert_installed();
    // A task released by its period (200 µs) or by a message or a readable socket: each
    // cycle sends itself a message through a notifying queue every other cycle, and the test
    // writes a byte on the socket that the cycle reads back.
    let wake = FdWake::new(1).unwrap();
    let registry = wake.registry();
    let (mut peer, mut socket) = UnixStream::pair().unwrap();
    socket.set_nonblocking(true).unwrap();
    registry.register(&socket, 0).unwrap();
    let queue = Arc::new(MessageQueue::with_notify(8, wake.notifier()));
    let mut futex = Wake::new();
    let futex_notifier = futex.notifier();
    let task = {
        let queue = queue.clone();
        move |ctx: &CycleContext| {
            while queue.try_recv().is_ok() {}
            if registry.take_ready(0) {
                let mut byte = [0u8; 1];
                let _ = socket.read(&mut byte);
            }
            if ctx.release == Release::Period && ctx.cycle % 2 == 0 {
                let _ = queue.try_send(ctx.cycle);
            }
            // A futex wake event, notified and consumed on the same thread.
            futex_notifier.notify();
            assert!(futex.wait_until_ns(0));
        }
    };
    let stats = Arc::new(StatsCell::new());
    let (tx, _rx) = rtrb::RingBuffer::new(4);
    let clock = MonotonicClock;
    let mut driver = TaskDriver::new(
        clock,
        task,
        clock.now_ns() + 1_000_000,
        200_000,
        stats.clone(),
        tx,
        Arc::new(AtomicBool::new(false)),
    )
    .with_waiter(wake);
    let (n, ()) = allocations_in(|| {
        for i in 0..300 {
            if i % 3 == 0 {
                peer.write_all(b"x").unwrap();
            }
            assert_eq!(driver.step(), Step::Ran);
        }
    });
    assert_eq!(n.total(), 0, "{n:?} in 300 steps");
    let s = stats.snapshot();
    assert_eq!(s.cycles + s.event_cycles, 300);
    assert!(s.event_cycles > 0, "{s:?}");
}
