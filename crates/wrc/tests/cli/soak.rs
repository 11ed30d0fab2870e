//! `wrc bench soak`, briefly: a few seconds of random valid and invalid requests from three
//! clients while the robot moves, against a real `wrc up`. The full run is `make soak`.

use std::process::Command;

#[test]
fn a_short_soak_answers_every_request_and_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("soak.json");
    let out = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args([
            "bench",
            "soak",
            "--seconds",
            "8",
            "--clients",
            "3",
            "--no-rt",
            "--seed",
            "7",
        ])
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(out.status.success(), "{stdout}\n{report:#}");
    assert_eq!(report["pass"], true, "{report:#}");
    assert_eq!(report["alive"], true);
    assert_eq!(report["unanswered"], 0, "{report:#}");
    assert!(report["requests"].as_u64().unwrap() > 100, "{report:#}");
    assert_eq!(report["requests"], report["replies"]);
    assert!(report["invalid_lines"].as_u64().unwrap() > 10, "{report:#}");
    assert!(report["motions"].as_u64().unwrap() > 0, "{report:#}");
    assert!(
        report["fds_after"].as_u64().unwrap() <= report["fds_before"].as_u64().unwrap(),
        "{report:#}"
    );
}
