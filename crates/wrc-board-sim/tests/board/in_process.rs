//! Driver and simulated board in one process on a real DPRAM file mapped twice, the board
//! on its own thread at its board clock, as `wrc board-sim` runs it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use wrc_board::layout::board_status;
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard};
use wrc_board_sim::runner::{self, MonotonicClock};

use crate::sim_on;

#[test]
fn host_and_board_threads_share_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("board0.dpram");
    let mut sim = sim_on(&path);
    let mut host = DpramBoard::open(
        &path,
        Expect {
            board_id: Some(0),
            axis_count: Some(4),
            period_us: Some(10_000),
        },
    )
    .unwrap();
    let stop = AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| runner::run(&mut sim, &MonotonicClock, &stop, None));
        // 50 periods of +200 pulses on j1 and +100 on z, pushed whenever there is room.
        let mut increments = [0i64; 16];
        increments[0] = 200;
        increments[3] = 100;
        let mut pushed = 0;
        let mut feedback = Feedback::default();
        let deadline = Instant::now() + Duration::from_secs(30);
        while Instant::now() < deadline {
            host.refresh_watchdog();
            if pushed < 50 && host.push(&increments).is_ok() {
                pushed += 1;
                continue;
            }
            // Then a host streams zero periods at rest (a moving axis that finds its FIFO
            // empty is braked by the board).
            if pushed == 50 {
                let _ = host.push(&[0; 16]);
            }
            host.read_feedback(&mut feedback).unwrap();
            if pushed == 50
                && feedback.axes[0].commanded == -75_000 + 50 * 200
                && feedback.axes[0].increment == 0
            {
                break;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        stop.store(true, Ordering::Relaxed);
        assert_eq!(feedback.axes[0].commanded, -75_000 + 50 * 200);
        assert_eq!(feedback.axes[3].commanded, 50 * 100);
        assert_eq!(feedback.axes[1].commanded, 150_000);
        assert!(feedback.boards[0].status & board_status::RUNNING != 0);
        assert!(feedback.boards[0].status & board_status::WATCHDOG_ARMED != 0);
        assert!(feedback.boards[0].period_count >= 50);
        assert_eq!(feedback.axes[0].alarm, 0);
        // Underruns depend on scheduling on a loaded machine; they are counted, not asserted.
    });
}

/// A FIFO flush skips exactly the entries the board has not executed, only if no board
/// period began since the host read the position, and a flush the board cannot honour is a
/// sequence alarm, not a silent jump.
#[test]
fn a_flush_skips_the_queued_entries_or_is_refused() {
    use wrc_board::layout::{axis, axis_base};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("board0.dpram");
    let mut sim = sim_on(&path);
    let mut host = DpramBoard::open(&path, Expect::default()).unwrap();
    for k in 1..=4 {
        host.push(&[k; 16]).unwrap();
    }
    sim.step(); // executes entry 0 (increment 1)
    let at = host
        .fifo_position()
        .expect("between periods, nothing pending");
    assert_eq!((at.read, at.write), (1, 4));
    // A board period begins before the host arms the flush: refused, nothing asked.
    sim.step(); // executes entry 1 (increment 2)
    assert!(!host.flush_queued(&at, at.write));
    let at = host.fifo_position().unwrap();
    assert_eq!((at.read, at.write), (2, 4));
    assert!(host.flush_queued(&at, at.write));
    assert!(host.fifo_position().is_none(), "a flush is pending");
    host.push(&[-5; 16]).unwrap(); // the first entry after the flushed stretch
    let before = feedback(&host).axes[0].commanded;
    sim.step(); // skips entries 2 and 3, executes -5
    let fb = feedback(&host);
    assert_eq!(fb.axes[0].commanded - before, -5);
    assert_eq!(fb.axes[0].alarm, 0);
    let dpram = host.dpram();
    assert_eq!(dpram.load(axis_base(0) + axis::DISCARDED), 2);
    assert!(host.fifo_position().is_some(), "the flush was acknowledged");
    // A flush whose stretch starts at an entry the board has passed: a sequence alarm.
    host.push(&[1; 16]).unwrap();
    let at = host.fifo_position().unwrap();
    let stale = wrc_board::FifoPosition {
        read: at.read.wrapping_sub(1),
        ..at
    };
    assert!(host.flush_queued(&stale, at.write));
    sim.step();
    assert_ne!(feedback(&host).axes[0].alarm, 0);
}

fn feedback(host: &DpramBoard) -> Feedback {
    let mut fb = Feedback::default();
    host.read_feedback(&mut fb).unwrap();
    fb
}
