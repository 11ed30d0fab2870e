//! `wrc board-sim` as a separate process: the driver in this test process pushes motion
//! through the shared DPRAM file, injects a fault with the CLI, and lets the host watchdog
//! trip; with the simulated cell, a GET through the DPRAM moves a wafer in the world file.
//! The board process is always killed (guard on drop).

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};

use common::{wait_until, PATIENCE};

use wrc_board::layout::{alarm, board_status};
use wrc_board::wrc_cell::{SlotCode, Stations, World};
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard};
use wrc_robot::{Pose, Posture};

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

/// Poll fresh feedback until `done` holds (refreshing the host watchdog meanwhile if
/// `refresh`).
fn until(host: &mut DpramBoard, refresh: bool, done: impl Fn(&Feedback) -> bool) -> Feedback {
    let mut f = Feedback::default();
    wait_until("the awaited board feedback", || {
        if refresh {
            host.refresh_watchdog();
        }
        if host.read_feedback(&mut f).is_ok() && done(&f) {
            Ok(f)
        } else {
            Err(format!("{f:?}"))
        }
    })
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
        PATIENCE,
    )
    .expect("board came up");
    assert_eq!(host.axis_count(), 4);

    // 20 periods of +500 pulses on j2.
    let mut increments = [0i64; 16];
    increments[1] = 500;
    for k in 0..21 {
        // Then a period at rest, as a host streams (a moving axis that runs dry is braked).
        let period = if k < 20 { increments } else { [0; 16] };
        wait_until("room in the board's FIFO", || {
            host.refresh_watchdog();
            host.push(&period).map_err(|e| e.to_string())
        });
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
    std::fs::write(&foreign, vec![0xFFu8; 32_768]).unwrap();
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
    // A FIFO deeper than the DPRAM layout's 256 slots: refused before anything is mapped.
    let dpram = dir.path().join("deep.dpram");
    let out = Command::new(WRC)
        .args([
            "board-sim",
            "--periods",
            "1",
            "--fifo-depth",
            "257",
            "--dpram",
        ])
        .arg(&dpram)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("--fifo-depth 257") && err.contains("expected 1 to 256 periods"),
        "{err}"
    );
    assert!(!dpram.exists(), "a refused board made its DPRAM");
}

/// The demo stations file shipped with wrc.
fn demo_stations() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/stations.toml")
}

fn read_world(path: &Path) -> World {
    let stations = Stations::load(&demo_stations()).unwrap();
    World::from_text(&std::fs::read_to_string(path).unwrap(), &stations).unwrap()
}

/// Start `wrc board-sim` with the demo cell, its log in `DIR/board.log`.
fn start_cell(dir: &Path) -> Board {
    let log = std::fs::File::create(dir.join("board.log")).unwrap();
    let child = Command::new(WRC)
        .args(["board-sim", "--fifo-depth", "16", "--dpram"])
        .arg(dir.join("board0.dpram"))
        .arg("--stations")
        .arg(demo_stations())
        .arg("--world")
        .arg(dir.join("world.toml"))
        .stderr(log)
        .spawn()
        .expect("spawn wrc board-sim");
    Board(child)
}

/// Send SIGTERM and wait for a clean exit.
fn terminate(board: &mut Board) {
    // SAFETY: kill with the pid of a child we spawned and have not reaped.
    unsafe {
        libc::kill(board.0.id() as libc::pid_t, libc::SIGTERM);
    }
    let status = wait_until("board-sim to stop on SIGTERM", || {
        board
            .0
            .try_wait()
            .unwrap()
            .ok_or_else(|| "running".to_string())
    });
    assert!(status.success(), "board-sim exited with {status}");
}

/// Push a joint move to `pose` (right elbow), at most 1 500 pulses a period per axis, and
/// wait until the axes have arrived and settled.
fn drive_to(host: &mut DpramBoard, robot: &wrc_robot::Robot, pose: Pose) {
    let mut f = until(host, false, |f| f.axes[0].fifo_level == 0);
    let mut end = [0i64; 16];
    for (e, a) in end.iter_mut().zip(&f.axes[..4]) {
        *e = a.commanded;
    }
    let joints = robot
        .inverse(&pose, Posture::Right, Some(&robot.pulses_to_joints(&end)))
        .unwrap();
    let target = robot.joints_to_pulses(&joints);
    while end != target {
        let mut inc = [0i64; 16];
        for ((i, e), t) in inc.iter_mut().zip(end.iter_mut()).zip(&target) {
            *i = (t - *e).clamp(-1_500, 1_500);
            *e += *i;
        }
        wait_until("room in the board's FIFO", || {
            host.push(&inc).map_err(|e| e.to_string())
        });
    }
    // A period at rest behind the move, as a host streams: an axis that is still moving
    // when its FIFO runs dry is braked by the board.
    wait_until("room in the board's FIFO", || {
        host.push(&[0; 16]).map_err(|e| e.to_string())
    });
    f = until(host, false, |f| {
        f.axes[..4]
            .iter()
            .zip(&target)
            .all(|(a, t)| a.encoder == *t && a.fifo_level == 0)
    });
    assert_eq!(f.axes[0].alarm, 0);
}

/// Push a straight-line move of the hand to `pose` (right elbow), in steps of at most a
/// millimetre, as the controller moves inside a station (a joint move there swings the hand
/// through the station's side), and wait until the axes have arrived and settled.
fn drive_straight_to(host: &mut DpramBoard, robot: &wrc_robot::Robot, pose: Pose) {
    let f = until(host, false, |f| f.axes[0].fifo_level == 0);
    let mut end = [0i64; 16];
    for (e, a) in end.iter_mut().zip(&f.axes[..4]) {
        *e = a.commanded;
    }
    let from = robot.forward(&robot.pulses_to_joints(&end));
    let length =
        ((pose.x - from.x).powi(2) + (pose.y - from.y).powi(2) + (pose.z - from.z).powi(2)).sqrt();
    let steps = length.ceil().max(1.0) as usize;
    let mut joints = robot.pulses_to_joints(&end);
    for k in 1..=steps {
        let t = k as f64 / steps as f64;
        let at = Pose {
            x: from.x + (pose.x - from.x) * t,
            y: from.y + (pose.y - from.y) * t,
            z: from.z + (pose.z - from.z) * t,
            yaw: from.yaw + (pose.yaw - from.yaw) * t,
        };
        joints = robot.inverse(&at, Posture::Right, Some(&joints)).unwrap();
        let target = robot.joints_to_pulses(&joints);
        let mut inc = [0i64; 16];
        for ((i, e), t) in inc.iter_mut().zip(end.iter_mut()).zip(&target) {
            *i = t - *e;
            *e = *t;
        }
        wait_until("room in the board's FIFO", || {
            host.push(&inc).map_err(|e| e.to_string())
        });
    }
    drive_to(host, robot, pose);
}

#[test]
fn the_simulated_cell_keeps_its_world_file_as_the_ground_truth() {
    let dir = tempfile::tempdir().unwrap();
    let world_path = dir.path().join("world.toml");
    let mut board = start_cell(dir.path());
    let mut host = DpramBoard::open_waiting(
        &dir.path().join("board0.dpram"),
        Expect::default(),
        PATIENCE,
    )
    .expect("board came up");
    // Created from the stations' [station.sim] tables before the board came up.
    let world = read_world(&world_path);
    assert_eq!(
        world.map_station("LP1").unwrap(),
        vec![SlotCode::Present; 25]
    );
    assert_eq!(
        world.map_station("LP2").unwrap(),
        vec![SlotCode::Absent; 25]
    );
    assert_eq!(world.hand(), None);

    // GET LP1 1 through the DPRAM, as the controller would: the file follows the pick
    // while the board runs.
    let config = wrc_config::Config::embedded_default();
    let stations = Stations::load(&demo_stations()).unwrap();
    let lp1 = stations.get("LP1").unwrap();
    let valve = 1u32 << config.hand.vacuum_output;
    drive_to(
        &mut host,
        &config.robot,
        lp1.approach_pose(1, false).unwrap(),
    );
    drive_straight_to(&mut host, &config.robot, lp1.seated_pose(1, false).unwrap());
    host.write_outputs(0, valve);
    drive_to(&mut host, &config.robot, lp1.seated_pose(1, true).unwrap());
    until(&mut host, false, |f| {
        f.boards[0].inputs & (1 << config.hand.vacuum_input) != 0
    });
    wait_until("the pick in the world file", || {
        read_world(&world_path)
            .hand()
            .ok_or_else(|| "no wafer on the hand".to_string())
    });
    let world = read_world(&world_path);
    assert_eq!(world.hand(), Some(1));
    assert_eq!(world.map_station("LP1").unwrap()[0], SlotCode::Absent);

    // SIGTERM: the final state (vacuum still on) is written before the board exits.
    terminate(&mut board);
    let world = read_world(&world_path);
    assert!(world.vacuum() && world.hand() == Some(1), "{world:?}");
    let log = std::fs::read_to_string(dir.path().join("board.log")).unwrap();
    assert!(
        log.contains("picked wafer T1 from LP1 slot 1") && !log.contains("panicked"),
        "{log}"
    );

    // `board-sim world` prints the file.
    let out = Command::new(WRC)
        .args(["board-sim", "world", "--world"])
        .arg(&world_path)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("LP1 01111 11111 11111 11111 11111\n"),
        "{text}"
    );
    assert!(
        text.contains("hand T1 (vacuum on)") && text.contains("faults 0"),
        "{text}"
    );

    // A restart reads the same ground truth back (on a fresh DPRAM, so the wait below is
    // for the new process).
    std::fs::remove_file(dir.path().join("board0.dpram")).unwrap();
    let mut board = start_cell(dir.path());
    DpramBoard::open_waiting(
        &dir.path().join("board0.dpram"),
        Expect::default(),
        PATIENCE,
    )
    .unwrap();
    terminate(&mut board);
    // Slot 1 is still empty: the world was read back, not made again from the stations.
    // (The restarted board's axes power on at home with the outputs off, so the wafer that
    // was on the hand has left it; see docs/dpram.md.)
    assert_eq!(
        read_world(&world_path).map_station("LP1").unwrap()[0],
        SlotCode::Absent
    );
    let log = std::fs::read_to_string(dir.path().join("board.log")).unwrap();
    assert!(log.contains("ground truth read from"), "{log}");
}

#[test]
fn a_fresh_world_has_lp1_full_and_the_world_command_prints_it() {
    let dir = tempfile::tempdir().unwrap();
    let world_path = dir.path().join("world.toml");
    let out = Command::new(WRC)
        .args(["board-sim", "--periods", "3", "--dpram"])
        .arg(dir.path().join("b.dpram"))
        .arg("--stations")
        .arg(demo_stations())
        .arg("--world")
        .arg(&world_path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let world = read_world(&world_path);
    assert_eq!(
        world.map_station("LP1").unwrap(),
        vec![SlotCode::Present; 25]
    );
    assert_eq!((world.hand(), world.faults()), (None, 0));

    let out = Command::new(WRC)
        .args(["board-sim", "world", "--world"])
        .arg(&world_path)
        .arg("--stations")
        .arg(demo_stations())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && text.is_ascii(), "{text}");
    assert!(
        text.starts_with("LP1 11111 11111 11111 11111 11111\nLP2 00000"),
        "{text}"
    );
    assert!(
        text.contains("hand - (vacuum off)\nlost -\nfaults 0\n"),
        "{text}"
    );

    // `status` shows the (empty) mapping latch.
    let out = Command::new(WRC)
        .args(["board-sim", "status", "--dpram"])
        .arg(dir.path().join("b.dpram"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("mapping station 0 seen 0 codes -"), "{text}");
}

#[test]
fn an_unusable_world_file_or_a_world_without_stations_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken-world.toml");
    std::fs::write(&bad, "version = 1\nwafers = 'many'\n").unwrap();
    let dpram = dir.path().join("b.dpram");
    let run = |args: &[&std::ffi::OsStr]| {
        let out = Command::new(WRC)
            .args(["board-sim", "--periods", "3", "--dpram"])
            .arg(&dpram)
            .args(args)
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let stations = demo_stations();
    let (code, err) = run(&[
        "--stations".as_ref(),
        stations.as_os_str(),
        "--world".as_ref(),
        bad.as_os_str(),
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("broken-world.toml")
            && err.contains("does not replace it")
            && !err.contains("panicked"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&bad).unwrap(),
        "version = 1\nwafers = 'many'\n",
        "the bad file is left as it was"
    );
    assert!(!dpram.exists(), "the board did not start");

    let (code, err) = run(&["--world".as_ref(), bad.as_os_str()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("--world") && err.contains("needs --stations"),
        "{err}"
    );

    let out = Command::new(WRC)
        .args(["board-sim", "world", "--world"])
        .arg(dir.path().join("none.toml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("none.toml") && err.contains("cannot read"),
        "{err}"
    );
}

/// The scheduling policy of each thread of process `pid` (field 41 of
/// `/proc/PID/task/TID/stat`: 0 normal, 1 SCHED_FIFO).
fn thread_policies(pid: u32) -> Vec<u32> {
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return Vec::new();
    };
    tasks
        .flatten()
        .filter_map(|t| {
            let stat = std::fs::read_to_string(t.path().join("stat")).ok()?;
            // Fields after the command name, which is in parentheses: state is field 3.
            let rest = stat.rsplit_once(')')?.1;
            rest.split_whitespace().nth(41 - 3)?.parse().ok()
        })
        .collect()
}

/// Regression: under SCHED_FIFO the controller declares a board dead when its heartbeat
/// stands for 3 periods (30 ms), but `wrc up` stepped its simulated boards on normal
/// scheduling, so a busy machine (a build on 2 cores) stalled a board that long and a
/// healthy board was reported lost (ABS 300 in the middle of a MAP, found by `wrc bench
/// faults`). `--realtime` steps the board at SCHED_FIFO, and `wrc up` passes it whenever it
/// runs real-time.
#[test]
fn a_realtime_board_steps_at_sched_fifo_where_allowed() {
    let allowed = std::thread::spawn(|| wrc_rt::sched_policy::set_current_thread_fifo(1).is_ok())
        .join()
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("board0.dpram");
    let child = Command::new(WRC)
        .args(["board-sim", "--realtime", "--dpram"])
        .arg(&path)
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn wrc board-sim");
    let pid = child.id();
    let _board = Board(child);
    DpramBoard::open_waiting(&path, Expect::default(), PATIENCE).expect("board came up");
    let policies = wait_until("the board's stepping thread scheduled", || {
        let p = thread_policies(pid);
        if !allowed || p.contains(&1) {
            Ok(p)
        } else {
            Err(format!("{p:?}"))
        }
    });
    if allowed {
        assert!(policies.contains(&1), "{policies:?}");
    } else {
        assert!(policies.iter().all(|&p| p == 0), "{policies:?}");
    }
}
