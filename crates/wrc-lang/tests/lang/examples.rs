//! Every program in examples/ compiles for the default robot without errors or warnings
//! (with the libraries next to it), and runs to its end against a host that answers every
//! request; a library (`*_lib.wrl`) asks for nothing on its own.

use std::path::PathBuf;

use wrc_lang::{compile_with, CompileOptions, DirSources, Motion, Request};

use crate::common::{robot, run};

fn examples() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "wrl"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_example_compiles_cleanly_and_runs_to_the_end() {
    let files = examples();
    assert!(files.len() >= 3, "{files:?}");
    for path in files {
        let source = std::fs::read_to_string(&path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let sources = DirSources {
            dir: path.parent().unwrap().to_path_buf(),
        };
        let options = CompileOptions {
            name: &stem,
            sources: Some(&sources),
        };
        let compiled = compile_with(&source, &name, &robot(), &options);
        assert!(
            compiled.diagnostics.is_empty(),
            "{}",
            compiled.render(&name, &source)
        );
        let program = compiled.program.expect("a program");
        let r = run(&program);
        assert_eq!(r.fault, None, "{name}");
        assert_eq!(r.requests.is_empty(), stem.ends_with("_lib"), "{name}");
    }
}

#[test]
fn the_paper_figures_ask_for_the_papers_moves() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let fig7 = std::fs::read_to_string(dir.join("fig7_ptp.wrl")).unwrap();
    let r = run(&crate::common::program(&fig7));
    let moves: Vec<_> = r
        .requests
        .iter()
        .filter_map(|q| match q {
            Request::Move(m, _) => Some(*m),
            _ => None,
        })
        .collect();
    assert_eq!(moves[0], Motion::Home);
    let Motion::Joints(j) = moves[1] else {
        panic!("{moves:?}")
    };
    // The paper's joints; Z stays at 0 under the demo cell's stations (the paper's 100 mm
    // would swing the hand through LP2: the controller refuses it, NAK 117).
    assert_eq!(&j[..4], &[30.0, 60.0, -90.0, 0.0]);

    let fig8 = std::fs::read_to_string(dir.join("fig8_line.wrl")).unwrap();
    let r = run(&crate::common::program(&fig8));
    let lines: Vec<_> = r
        .requests
        .iter()
        .filter_map(|q| match q {
            Request::Move(Motion::Pose(p, _), _) => Some(("ptp", p.x, p.y)),
            Request::Move(Motion::Line(p), _) => Some(("line", p.x, p.y)),
            _ => None,
        })
        .collect();
    assert_eq!(lines, [("ptp", 300.0, -100.0), ("line", 300.0, 150.0)]);
}

#[test]
fn pick_place_switches_the_vacuum_and_waits_for_its_sensor() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let src = std::fs::read_to_string(dir.join("pick_place.wrl")).unwrap();
    let r = run(&crate::common::program(&src));
    let io: Vec<_> = r
        .requests
        .iter()
        .filter_map(|q| match q {
            Request::Out { n, on } => Some(format!("out{n}={}", u8::from(*on))),
            Request::WaitInput { n, value, .. } => Some(format!("in{n}={}", u8::from(*value))),
            _ => None,
        })
        .collect();
    assert_eq!(io.len(), 12);
    assert_eq!(&io[..4], ["out0=1", "in0=1", "out0=0", "in0=0"]);
    assert_eq!(r.printed.len(), 3);
    assert_eq!(r.printed[2], "wafer 3 placed in LP2 slot 3");
}
