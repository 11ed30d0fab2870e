//! Robot-language programs on a running controller: upload, diagnostics, run, print, pause,
//! runtime errors with their source line, STOP, and programs kept on disk; `wrc run` of an
//! example in real time, and every example under `wrc sim` (virtual time), the 25-wafer
//! cycle and its return in one state directory.

use std::path::{Path, PathBuf};

use super::up::{Client, Controller, STILL_PERIODS};
use super::wafer_cycle::truth_codes;
use super::{text, wrc};

/// Upload `source` as `name`; returns every line up to and including the final ACK/NAK.
fn upload(c: &mut Client, id: u32, name: &str, source: &str) -> Vec<String> {
    let mut bytes = format!("{id} UPLOAD {name}\n");
    for l in source.lines() {
        bytes.push_str(l);
        bytes.push('\n');
    }
    bytes.push_str(".\n");
    c.send_raw(bytes.as_bytes());
    let mut lines = Vec::new();
    loop {
        let l = c.line();
        let done = l.starts_with("ACK") || l.starts_with("NAK");
        lines.push(l);
        if done {
            return lines;
        }
    }
}

/// Lines until the final reply to `id` (INF or ABS), events included.
fn until_final(c: &mut Client, id: u32) -> Vec<String> {
    let mut lines = Vec::new();
    loop {
        let l = c.line();
        let done = l.starts_with(&format!("INF {id}")) || l.starts_with(&format!("ABS {id}"));
        lines.push(l);
        if done {
            return lines;
        }
    }
}

#[test]
fn an_uploaded_program_runs_prints_and_ends_with_inf() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    let source = "' a loop with a SUB and a pose offset\n\
                  HOME\n\
                  P = POSE(300, 0, 0, 0)\n\
                  FOR I = 1 TO 2\n\
                  \x20 MOVEP P + POSE(0, 20 * I, 0, 0)\n\
                  \x20 CALL SHOW\n\
                  NEXT I\n\
                  END\n\
                  SUB SHOW\n\
                  \x20 PRINT \"at\", HERE().Y\n\
                  ENDSUB\n";
    let up = upload(&mut host, 1, "loop", source);
    assert!(up.last().unwrap().starts_with("ACK 1 name=loop"), "{up:?}");
    assert_eq!(host.ask("PROGRAMS"), "ACK programs=loop");
    assert_eq!(host.ask("2 RUN loop"), "ACK 2");
    let lines = until_final(&mut host, 2);
    assert_eq!(lines.last().unwrap(), "INF 2", "{lines:?}");
    let prints: Vec<&String> = lines
        .iter()
        .filter(|l| l.starts_with("EVT PRINT"))
        .collect();
    assert_eq!(prints.len(), 2, "{lines:?}");
    assert!(prints[0].starts_with("EVT PRINT at 20"), "{prints:?}");
    assert!(prints[1].starts_with("EVT PRINT at 40"), "{prints:?}");
    assert!(lines
        .iter()
        .any(|l| l == "EVT PROGRAM loop RUNNING files=loop"));
    let (_, x, y) = host.where_();
    assert!(
        (x - 300.0).abs() < 0.05 && (y - 40.0).abs() < 0.05,
        "{x} {y}"
    );
}

#[test]
fn a_program_that_does_not_compile_is_refused_with_diagnostics_and_nothing_is_stored() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert!(upload(&mut host, 1, "p", "HOME\n")
        .last()
        .unwrap()
        .starts_with("ACK 1"));
    let up = upload(&mut host, 2, "p", "HOME\nIF 1 THEN\nMOVEJ JOINTS(1, 2)\n");
    let last = up.last().unwrap();
    assert!(last.starts_with("NAK 2 126 p: "), "{up:?}");
    assert!(
        up.iter().any(|l| l.starts_with("EVT DIAG p.wrl:3:")),
        "a diagnostic names line 3: {up:?}"
    );
    // The older program of that name is kept, and runs.
    assert_eq!(host.ask("3 RUN p"), "ACK 3");
    assert_eq!(until_final(&mut host, 3).last().unwrap(), "INF 3");
    assert!(host.ask("RUN nothere").starts_with("NAK 125"));
    assert!(host.ask("RUN ../etc").starts_with("NAK 106"));
    // Garbage after the upload is a normal request again.
    assert!(host.ask("FOO").starts_with("NAK 100"));
}

#[test]
fn a_runtime_error_ends_the_program_with_abs_and_its_line() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    let up = upload(
        &mut host,
        1,
        "div",
        "HOME\nA = HERE().Z\nPRINT \"ok\"\nB = 1 / A\n",
    );
    assert!(up.last().unwrap().starts_with("ACK 1"), "{up:?}");
    assert_eq!(host.ask("2 RUN div"), "ACK 2");
    let lines = until_final(&mut host, 2);
    let last = lines.last().unwrap();
    assert!(last.starts_with("ABS 2 210 div line 4:"), "{lines:?}");
    assert!(last.contains("division by zero"), "{last}");
    assert!(
        host.status().starts_with("ACK state=IDLE"),
        "no RESET needed"
    );

    // A computed pose out of reach: the motion's refusal code and the line.
    let up = upload(
        &mut host,
        3,
        "far",
        "HOME\nR = 500 + HERE().Z\nMOVEP POSE(R, 0, 0, 0)\n",
    );
    assert!(up.last().unwrap().starts_with("ACK 3"), "{up:?}");
    assert_eq!(host.ask("4 RUN far"), "ACK 4");
    let lines = until_final(&mut host, 4);
    assert!(
        lines.last().unwrap().starts_with("ABS 4 111 far line 3:"),
        "{lines:?}"
    );
}

#[test]
fn stop_aborts_a_running_program_and_other_sources_cannot_move_meanwhile() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    let mut other = c.client();
    // Back and forth with the arm folded (J2 150°, as up::LONG_MOVE): clear of the cell at
    // any height, every MOVEJ goes straight.
    let source =
        "HOME\nWHILE TRUE\nMOVEJ JOINTS(170, 150, 0, 250)\nMOVEJ JOINTS(-100, 150, 0, 0)\nENDWHILE\n";
    assert!(upload(&mut host, 1, "forever", source)
        .last()
        .unwrap()
        .starts_with("ACK 1"));
    assert_eq!(host.ask("2 RUN forever"), "ACK 2");
    // The program is in its loop, on the way from home (j1 -75) to j1 170.
    other.wait_moving("the program's first MOVEJ under way", |j, _, _| {
        j[0] > -65.0
    });
    assert!(other.ask("MOVJ 0 90 0 0").starts_with("NAK 127"));
    assert!(other.ask("RUN forever").starts_with("NAK 127"));
    assert_eq!(other.ask("PAUSE"), "ACK");
    assert_eq!(other.ask("CONTINUE"), "ACK");
    assert_eq!(other.ask("3 STOP"), "ACK 3");
    let lines = until_final(&mut host, 2);
    let last = lines.last().unwrap();
    assert!(last.starts_with("ABS 2 200 forever line "), "{lines:?}");
    assert_eq!(host.motion(4, "WAIT"), "INF 4");
    let board = c.board();
    board.wait_at_rest();
    let a = host.where_().0;
    board.wait_periods(STILL_PERIODS);
    assert_eq!(host.where_().0, a, "nothing moves after the stop");
    assert!(host.ask("ABORT").starts_with("NAK 128"));
    assert!(host.ask("PAUSE").starts_with("NAK 128"));
    c.stop_clear_of_the_cell();
}

#[test]
fn programs_are_kept_on_disk_across_restarts_and_can_be_deleted() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert!(upload(&mut host, 1, "keep", "HOME\n")
        .last()
        .unwrap()
        .starts_with("ACK 1"));
    drop(host);
    let c = c.restart();
    assert_eq!(
        std::fs::read_to_string(c.dir_path().join("programs/keep.wrl")).unwrap(),
        "HOME\n"
    );
    let mut host = c.client();
    assert_eq!(host.ask("PROGRAMS"), "ACK programs=keep");
    assert_eq!(host.ask("5 RUN keep"), "ACK 5");
    assert_eq!(until_final(&mut host, 5).last().unwrap(), "INF 5");
    assert_eq!(host.ask("DELETE keep"), "ACK");

    assert!(upload(&mut host, 1, "a", "HOME\n")
        .last()
        .unwrap()
        .starts_with("ACK 1"));
    assert!(upload(&mut host, 2, "b", "HOME\n")
        .last()
        .unwrap()
        .starts_with("ACK 2"));
    assert_eq!(host.ask("PROGRAMS"), "ACK programs=a,b");
    assert_eq!(host.ask("DELETE a"), "ACK");
    assert_eq!(host.ask("PROGRAMS"), "ACK programs=b");
    assert!(host.ask("DELETE a").starts_with("NAK 125"));
    assert!(!c.dir_path().join("programs/a.wrl").exists());
}

#[test]
fn wrc_run_runs_an_example_on_the_real_time_controller() {
    let c = Controller::start(&[]);
    let addr = format!("127.0.0.1:{}", c.port);
    let fig7 = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/fig7_ptp.wrl");
    let out = wrc(&["run", fig7.to_str().unwrap(), "--addr", &addr]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("Fig. 7 PTP done at POSE("), "{stdout}");
    assert!(stdout.trim_end().ends_with("INF 2"), "{stdout}");
}

/// `wrc sim` of `program` in `state` (stdout, stderr); it must succeed.
fn sim_ok(program: &Path, state: &Path) -> String {
    sim_ok_with(program, state, &[])
}

/// `wrc sim` of `program` in `state` with more arguments (`--config …`); it must succeed,
/// and the simulated cell must have felt no touch of the arm.
fn sim_ok_with(program: &Path, state: &Path, more: &[&str]) -> String {
    let mut args = vec![
        "sim",
        program.to_str().unwrap(),
        "--state-dir",
        state.to_str().unwrap(),
    ];
    args.extend_from_slice(more);
    let out = wrc(&args);
    let (stdout, stderr) = text(&out);
    assert!(
        out.status.success(),
        "{}: {stdout}{stderr}",
        program.display()
    );
    assert!(stdout.trim_end().ends_with("INF 2"), "{stdout}");
    assert!(stderr.contains("s of virtual time in"), "{stderr}");
    let (collisions, latest) = crate::side_collisions(state);
    assert_eq!(
        collisions,
        0,
        "{}: side collisions in the simulated cell, the latest at {latest:?}",
        program.display()
    );
    stdout
}

#[test]
fn every_example_runs_on_the_simulated_robot_and_the_wafer_programs_go_there_and_back() {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut files: Vec<_> = std::fs::read_dir(&examples)
        .expect("examples/ exists")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "wrl"))
        .collect();
    files.sort();
    let named =
        |p: &&PathBuf, prefix: &str| p.file_name().unwrap().to_string_lossy().starts_with(prefix);
    let (dual, files): (Vec<_>, Vec<_>) = files.iter().partition(|p| named(p, "dual_blade"));
    let (wafer, single): (Vec<_>, Vec<_>) = files.into_iter().partition(|p| named(p, "wafer_"));
    // The dual-blade robot's programs on its configuration.
    let config = examples.join("../config/dual-blade.toml");
    for path in &dual {
        let state = tempfile::tempdir().unwrap();
        let out = sim_ok_with(path, state.path(), &["--config", config.to_str().unwrap()]);
        assert!(out.contains("wafer 10 is in PM1"), "{out}");
        let world = state.path().join("world.toml");
        assert_eq!(
            truth_codes(&world, "LP2"),
            format!("{}{}", "1".repeat(9), "0".repeat(16))
        );
        assert_eq!(truth_codes(&world, "PM1"), "1");
    }
    assert_eq!(dual.len(), 1, "examples/dual_blade_swap.wrl");
    // Each on a fresh cell, virtual time (the real-time path: the test above).
    for path in &single {
        let state = tempfile::tempdir().unwrap();
        sim_ok(path, state.path());
    }
    assert!(single.len() >= 3, "fig7, fig8 and pick-and-place at least");
    // The 25-wafer cycle, then the program that moves them back, in one state directory:
    // the second run starts from the wafer map and the cell the first one left.
    let state = tempfile::tempdir().unwrap();
    let there = examples.join("wafer_cycle.wrl");
    let back = examples.join("wafer_return.wrl");
    assert_eq!(wafer, [&there, &back], "the wafer programs");
    let out = sim_ok(&there, state.path());
    assert!(out.contains("all 25 wafers are in LP2"), "{out}");
    let world = state.path().join("world.toml");
    assert_eq!(truth_codes(&world, "LP2"), "1".repeat(25));
    let out = sim_ok(&back, state.path());
    assert!(out.contains("all 25 wafers are back in LP1"), "{out}");
    assert_eq!(truth_codes(&world, "LP1"), "1".repeat(25));
    assert_eq!(truth_codes(&world, "LP2"), "0".repeat(25));
}

#[test]
fn wrc_run_refuses_a_program_that_does_not_compile_before_sending_it() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.wrl");
    std::fs::write(&bad, "MOVEJ JOINTS(1, 2\n").unwrap();
    // No controller at this address: it must not even try to connect.
    let out = wrc(&["run", bad.to_str().unwrap(), "--addr", "127.0.0.1:9"]);
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad.wrl:1:"), "{stderr}");
    assert!(stderr.contains("does not compile"), "{stderr}");
}
