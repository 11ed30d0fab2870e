//! `wrc bench soak`, briefly: a few seconds of random valid and invalid requests from three
//! clients while the robot moves, against a real `wrc up`. The full run is `make soak`.

use std::process::Command;

/// `wrc bench soak` with `args` and `--json`: whether it succeeded, its standard output, and
/// its JSON report (a missing report fails with what the run printed).
fn soak(args: &[&str]) -> (bool, String, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("soak.json");
    let out = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args(["bench", "soak"])
        .args(args)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&json).unwrap_or_else(|e| panic!("{e}: {stdout}\n{stderr}")),
    )
    .unwrap();
    (out.status.success(), stdout, report)
}

#[test]
fn a_short_soak_answers_every_request_and_leaves_nothing_behind() {
    let (success, stdout, report) =
        soak(&["--seconds", "8", "--clients", "3", "--no-rt", "--seed", "7"]);
    assert!(success, "{stdout}\n{report:#}");
    assert_eq!(report["pass"], true, "{report:#}");
    assert_eq!(report["alive"], true);
    assert_eq!(report["unanswered"], 0, "{report:#}");
    assert!(report["requests"].as_u64().unwrap() > 100, "{report:#}");
    assert_eq!(report["requests"], report["replies"]);
    assert!(report["invalid_lines"].as_u64().unwrap() > 10, "{report:#}");
    assert!(report["motions"].as_u64().unwrap() > 0, "{report:#}");
    // The random moves, and the brakes of the other clients' HOLDs and STOPs, kept clear of
    // the cell: its ground truth counted no touch.
    assert_eq!(report["side_collisions"], 0, "{report:#}");
    assert!(
        report["fds_after"].as_u64().unwrap() <= report["fds_before"].as_u64().unwrap(),
        "{report:#}"
    );
}

/// At 1 kHz (`--period-ms 1`): the servo table has its rows, the counts are numbers, and at
/// rest the board has executed exactly the pulses the controller commanded on every axis —
/// whatever the timing was on this machine, which the test does not judge.
#[test]
fn a_short_soak_at_one_millisecond_reports_the_servo_loop_and_loses_no_pulse() {
    let (_, stdout, report) = soak(&[
        "--period-ms",
        "1",
        "--seconds",
        "6",
        "--clients",
        "3",
        "--no-rt",
        "--seed",
        "11",
    ]);
    for row in [
        "| servo period [ms]",
        "| underruns: controller (TASKS) / boards",
        "| watchdog trips: TASKS / alarms 206",
        "| following-error trips (alarms 203)",
        "| overruns (missed periods): pulse_generator",
        "| overruns (missed periods): simulator_manager",
        "| PG wake-up latency p50 / p99 / max [µs]",
        "| cyclictest",
        "| deepest FIFO drain",
        "| lost pulses: j1",
        "| lost pulses: z",
    ] {
        assert!(stdout.contains(row), "no row {row:?}:\n{stdout}");
    }
    let servo = &report["servo"];
    assert_eq!(servo["period_ms"], 1.0, "{servo:#}");
    // The default look-ahead, 100 ms: 100 periods at 1 ms.
    assert_eq!(servo["fifo"]["lookahead_periods"], 100, "{servo:#}");
    for count in ["underruns", "watchdog_trips", "following_error_trips"] {
        assert!(servo[count].is_u64(), "{count}: {servo:#}");
    }
    let axes = servo["pulses"]
        .as_array()
        .expect("the pulse counts were compared");
    assert_eq!(axes.len(), 4, "{servo:#}");
    for a in axes {
        assert_eq!(a["host_pulses"], a["board_pulses"], "pulses lost: {a}");
        assert_eq!(a["lost_pulses"], 0, "{a}");
    }
    assert_eq!(servo["lost_pulses"], 0, "{servo:#}");
    assert_eq!(report["alive"], true, "{stdout}");
}

/// `--load` where stress-ng cannot run: a clear refusal before anything runs, never a soak
/// reported as loaded that ran idle.
#[test]
fn a_loaded_soak_without_stress_ng_refuses_to_run() {
    let empty = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args(["bench", "soak", "--load", "--seconds", "5", "--no-rt"])
        .env("PATH", empty.path())
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(!out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stderr.contains("--load needs stress-ng") && stderr.contains("leave --load out"),
        "{stderr}"
    );
    assert!(!stdout.contains("verdict"), "{stdout}");
}
