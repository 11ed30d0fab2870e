//! Driver and simulated board in one process on a real DPRAM file mapped twice, the board
//! on its own thread at its board clock, as `wrc board-sim` runs it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use wrc_board::layout::board_status;
use wrc_board::sim::runner::{self, SystemClock};
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard};

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
        s.spawn(|| runner::run(&mut sim, &SystemClock::default(), &stop, None));
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
            host.read_feedback(&mut feedback).unwrap();
            if pushed == 50 && feedback.axes[0].fifo_level == 0 && feedback.axes[0].increment == 0 {
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
