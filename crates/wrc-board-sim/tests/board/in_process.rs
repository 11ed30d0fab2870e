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
    assert!(!host.flush_queued(&at, at.write, &[[-5; 16]]));
    let at = host.fifo_position().unwrap();
    assert_eq!((at.read, at.write), (2, 4));
    assert_eq!(host.fifo_free(), 254);
    // The first entry after the flushed stretch comes with the flush.
    assert!(host.flush_queued(&at, at.write, &[[-5; 16]]));
    assert!(host.fifo_position().is_none(), "a flush is pending");
    assert_eq!(host.fifo_free(), 253, "queued behind the skipped ones");
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
    assert!(host.flush_queued(&stale, at.write, &[]));
    sim.step();
    assert_ne!(feedback(&host).axes[0].alarm, 0);
}

/// The brake's first entries travel with the flush: a host preempted right after it asked
/// (the entries written, the flush armed, not yet published) still has its board execute
/// them from its next period on, not run dry; the host's own publication afterwards changes
/// nothing, and pushing goes on behind them.
#[test]
fn a_flush_publishes_the_entries_it_carries_even_if_the_host_stalls_after_asking() {
    use wrc_board::layout::{axis, axis_base};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("board0.dpram");
    let mut sim = sim_on(&path);
    let mut host = DpramBoard::open(&path, Expect::default()).unwrap();
    for _ in 0..3 {
        host.push(&[40; 16]).unwrap();
    }
    sim.step(); // moving: +40
    let dpram = host.dpram();
    let at = host.fifo_position().unwrap();
    assert_eq!((at.read, at.write), (1, 3));
    // What `flush_queued` does, stopped before its publication: two entries staged.
    for channel in 0..4 {
        dpram.fifo_stage(channel, 0, -7);
        dpram.fifo_stage(channel, 1, -3);
    }
    assert!(dpram.flush_arm(&at, at.write, at.write + 2));
    assert_eq!(
        dpram.load(axis_base(0) + axis::FIFO_WRITE),
        3,
        "not published"
    );
    let start = feedback(&host);
    let before = start.axes[0].commanded;
    sim.step(); // skips 1 and 2, executes -7
    let fb = feedback(&host);
    assert_eq!(fb.axes[0].commanded - before, -7);
    assert_eq!(fb.axes[0].underruns, 0);
    assert_eq!(fb.boards[0].status & board_status::BOARD_BRAKE, 0);
    assert_eq!(
        dpram.load(axis_base(0) + axis::FIFO_WRITE),
        5,
        "published by the board"
    );
    // The host's publication, late: a no-op; pushing goes on behind.
    dpram.fifo_publish_to(0, 5);
    for channel in 0..4 {
        dpram.fifo_push(channel, 0);
    }
    sim.step(); // -3
    sim.step(); // 0
    let fb = feedback(&host);
    assert_eq!(fb.axes[0].commanded - before, -10);
    assert_eq!(fb.axes[3].commanded - start.axes[3].commanded, -10);
    assert_eq!((fb.axes[0].underruns, fb.axes[0].alarm), (0, 0));
    assert_eq!(dpram.load(axis_base(0) + axis::DISCARDED), 2);
}

/// The board executes a record, an entry of every axis, or none: a record the host is
/// still publishing (axis after axis) is not started on one axis alone, which would leave
/// that axis a period ahead of the others for the rest of the move.
#[test]
fn a_record_half_published_waits_for_its_last_axis() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("board0.dpram");
    let mut sim = sim_on(&path);
    let host = DpramBoard::open(&path, Expect::default()).unwrap();
    let dpram = host.dpram();
    let start = feedback(&host);
    dpram.fifo_push(0, 25);
    dpram.fifo_push(1, 25);
    sim.step(); // axes 2 and 3 have no entry yet: nobody moves
    let fb = feedback(&host);
    for a in 0..4 {
        assert_eq!(fb.axes[a].commanded, start.axes[a].commanded, "axis {a}");
        assert_eq!(fb.axes[a].underruns, 0, "axis {a}");
    }
    dpram.fifo_push(2, 25);
    dpram.fifo_push(3, 25);
    sim.step(); // whole: every axis moves together
    let fb = feedback(&host);
    for a in 0..4 {
        assert_eq!(
            fb.axes[a].commanded - start.axes[a].commanded,
            25,
            "axis {a}"
        );
    }
}

fn feedback(host: &DpramBoard) -> Feedback {
    let mut fb = Feedback::default();
    host.read_feedback(&mut fb).unwrap();
    fb
}
