//! `wrc board-sim` as a separate process: the driver in this test process pushes motion
//! through the shared DPRAM file, injects a fault with the CLI, and lets the host watchdog
//! trip. The board process is always killed (guard on drop).

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use wrc_board::layout::{alarm, board_status};
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard};

const WRC: &str = env!("CARGO_BIN_EXE_wrc");

/// Kills the board process when the test ends, passed or failed.
struct Board(Child);

impl Drop for Board {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start(path: &Path) -> Board {
    let child = Command::new(WRC)
        .args(["board-sim", "--dpram"])
        .arg(path)
        .args(["--watchdog-periods", "5", "--fifo-depth", "16"])
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn wrc board-sim");
    Board(child)
}

/// Poll `done` on fresh feedback for up to 20 s (generous on a loaded machine).
fn until(host: &mut DpramBoard, refresh: bool, done: impl Fn(&Feedback) -> bool) -> Feedback {
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut f = Feedback::default();
    loop {
        if refresh {
            host.refresh_watchdog();
        }
        if host.read_feedback(&mut f).is_ok() && done(&f) {
            return f;
        }
        assert!(Instant::now() < deadline, "timed out; last feedback {f:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn driver_and_board_process_share_the_dpram() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("board0.dpram");
    let _board = start(&path);
    let mut host = DpramBoard::open_waiting(
        &path,
        Expect {
            board_id: Some(0),
            ..Expect::default()
        },
        Duration::from_secs(20),
    )
    .expect("board came up");
    assert_eq!(host.axis_count(), 4);

    // 20 periods of +500 pulses on j2.
    let mut increments = [0i64; 16];
    increments[1] = 500;
    let mut pushed = 0;
    while pushed < 20 {
        host.refresh_watchdog();
        if host.push(&increments).is_ok() {
            pushed += 1;
        } else {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    let f = until(&mut host, true, |f| {
        f.axes[1].commanded == 150_000 + 20 * 500 && f.axes[1].fifo_level == 0
    });
    assert_eq!(f.axes[0].commanded, -75_000);
    assert!(f.boards[0].status & board_status::WATCHDOG_ARMED != 0);

    // Fault injection through the CLI reaches the board process.
    let out = Command::new(WRC)
        .args(["board-sim", "inject", "--dpram"])
        .arg(&path)
        .args(["alarm", "2"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let f = until(&mut host, true, |f| f.axes[2].alarm != 0);
    assert_eq!(f.axes[2].alarm, alarm::AMPLIFIER);

    // The host goes quiet: the board trips its watchdog and says so.
    let f = until(&mut host, false, |f| {
        f.boards[0].status & board_status::WATCHDOG_TRIPPED != 0
    });
    assert_eq!(f.boards[0].watchdog_trips, 1);

    // `status` reads the same board.
    let out = Command::new(WRC)
        .args(["board-sim", "status", "--dpram"])
        .arg(&path)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("watchdog-tripped") && text.contains("amplifier"),
        "{text}"
    );
}

#[test]
fn bad_paths_and_faults_fail_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let foreign = dir.path().join("photo.jpg");
    std::fs::write(&foreign, vec![0xFFu8; 8192]).unwrap();
    for args in [
        vec!["board-sim", "status", "--dpram", foreign.to_str().unwrap()],
        vec![
            "board-sim",
            "--periods",
            "1",
            "--dpram",
            foreign.to_str().unwrap(),
        ],
    ] {
        let out = Command::new(WRC).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("photo.jpg")
                && err.contains("not a wrc DPRAM")
                && !err.contains("panicked"),
            "{err}"
        );
    }
    let out = Command::new(WRC)
        .args(["board-sim", "inject", "--dpram", "/nonexistent/x", "smoke"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(err.contains("unknown fault \"smoke\""), "{err}");
}
