//! `wrc compile`: a clean program gets a one-line summary (or its listing / JSON), a broken
//! one gets rustc-like diagnostics on stderr and exit code 2.

use std::path::PathBuf;

use crate::{text, wrc};

fn example(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name)
        .display()
        .to_string()
}

#[test]
fn a_good_program_prints_a_summary_and_exits_0() {
    let file = example("pick_place.wrl");
    let out = wrc(&["compile", &file]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    assert_eq!(stderr, "");
    assert!(
        stdout.starts_with(&format!("{file}: ok, "))
            && stdout.ends_with(" variables, 0 warnings\n"),
        "{stdout}"
    );
}

#[test]
fn emit_prints_the_listing_or_json() {
    let file = example("fig7_ptp.wrl");
    let out = wrc(&["compile", &file, "--emit", "bytecode"]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("MOVEJ"), "{stdout}");
    assert!(stdout.contains("JOINTS   4"), "{stdout}");

    let out = wrc(&["compile", &file, "--emit", "json"]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("JSON on stdout");
    assert_eq!(json["axes"], 4);
    assert!(json["code"].as_array().is_some_and(|c| !c.is_empty()));
}

#[test]
fn a_bad_program_gets_diagnostics_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.wrl");
    std::fs::write(&file, "SPEED 150\nMOVEP POSE(900, 0, 0, 0)\nIF TRUE THEN\n").unwrap();
    let file = file.display().to_string();
    let out = wrc(&["compile", &file]);
    let (stdout, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stdout, "");
    assert!(
        stderr.contains(&format!(
            "error: SPEED 150 is out of range; SPEED takes 1 to 100 [%]\n --> {file}:1:7\n  |\n1 | SPEED 150\n  |       ^~~\n"
        )),
        "{stderr}"
    );
    assert!(stderr.contains("unreachable pose"), "{stderr}");
    assert!(
        stderr.contains("expected ENDIF to close IF at 3:1"),
        "{stderr}"
    );
    assert!(
        stderr.ends_with("3 errors, 0 warnings; nothing compiled\n"),
        "{stderr}"
    );
}

#[test]
fn a_missing_file_is_one_sentence_and_exit_2() {
    let out = wrc(&["compile", "/nonexistent/cell.wrl"]);
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr.starts_with("wrc: error: cannot read the program /nonexistent/cell.wrl"),
        "{stderr}"
    );
}
