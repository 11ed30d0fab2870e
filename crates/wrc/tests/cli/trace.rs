//! `wrc trace info` and `wrc trace plot` on a trace written with wrc-trace, and the one
//! sentence (exit 2) for a missing, corrupt or newer-format file and an empty window.

use std::path::{Path, PathBuf};

use wrc_trace::{ClockKind, Direction, Message, Meta, Sample, TraceFile, SOURCE_HOST};

use crate::{text, wrc};

/// A 3-axis trace of 1 s at 10 ms: J1 and Z move, the state goes IDLE → MOVING → IDLE,
/// input 2 rises, two requests and their replies.
fn write_trace(dir: &Path) -> PathBuf {
    let mut meta = Meta::new(
        "TRACE SAVE",
        10_000_000,
        &["Theta", "Reach", "Zeta"],
        &["IDLE", "MOVING", "STOPPING", "ERROR", "ESTOP", "HELD"],
    );
    meta.wrc_version = "0.1.0".into();
    meta.clock = ClockKind::Virtual;
    meta.saved_at_ns = 2_000_000_000;
    let samples = (0..100u64)
        .map(|k| {
            let mut s = Sample {
                t_ns: 1_000_000_000 + k * 10_000_000,
                state: u8::from((20..80).contains(&k)),
                inputs: if k > 50 { 1 << 2 } else { 0 },
                outputs: 1,
                ..Sample::default()
            };
            let moved = (k.clamp(20, 80) - 20) as i64;
            s.commanded[0] = moved * 1_000;
            s.actual[0] = moved * 1_000 - 40;
            s.commanded[2] = -moved * 200;
            s.actual[2] = -moved * 200;
            s
        })
        .collect();
    let messages = vec![
        Message::new(
            1_195_000_000,
            Direction::Request,
            SOURCE_HOST,
            1,
            b"1 MOVE J1 60\n",
        ),
        Message::new(1_196_000_000, Direction::Reply, SOURCE_HOST, 1, b"ACK 1\n"),
        Message::new(
            1_500_000_000,
            Direction::Request,
            SOURCE_HOST,
            1,
            b"2 STATUS\n",
        ),
        Message::new(
            1_501_000_000,
            Direction::Reply,
            SOURCE_HOST,
            1,
            b"ACK 2 state=MOVING\n",
        ),
    ];
    let trace = TraceFile {
        meta,
        samples,
        messages,
    };
    let path = dir.join("session.wrctrace");
    trace.save(&path).unwrap();
    path
}

#[test]
fn info_prints_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_trace(dir.path());
    let out = wrc(&["trace", "info", path.to_str().unwrap()]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    for expected in [
        "reason:   TRACE SAVE",
        "period:   10 ms, 3 axes (Theta, Reach, Zeta)",
        "duration: 0.990 s (t = 1.000 s to 1.990 s)",
        "samples:  100",
        "messages: 4 (2 requests, 2 replies)",
        "states:   IDLE, MOVING",
    ] {
        assert!(stdout.contains(expected), "{expected:?} in\n{stdout}");
    }
}

#[test]
fn plot_draws_every_axis_state_and_bit_into_an_svg_next_to_the_trace() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_trace(dir.path());
    let out = wrc(&["trace", "plot", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out).1);
    let svg = std::fs::read_to_string(dir.path().join("session.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("polyline"));
    for expected in [
        "Theta commanded",
        "Reach actual",
        "Zeta",
        "MOVING",
        "HELD",
        "in 2",
        "out 0",
        "time [s]",
        "position [pulse]",
        "commanded velocity [pulse/s]",
    ] {
        assert!(svg.contains(expected), "{expected:?} in the SVG");
    }

    // A window and an output path of one's own.
    let custom = dir.path().join("plots/window.svg");
    std::fs::create_dir(dir.path().join("plots")).unwrap();
    let out = wrc(&[
        "trace",
        "plot",
        path.to_str().unwrap(),
        "--out",
        custom.to_str().unwrap(),
        "--from",
        "1.2",
        "--to",
        "1.5",
    ]);
    let (_, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("plot of 31 samples"), "{stderr}");
    assert!(custom.exists());
}

/// Exit code 2 and one `wrc: error:` sentence containing `expected`.
fn refused(args: &[&str], expected: &str) {
    let out = wrc(args);
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(stderr.starts_with("wrc: error: "), "{stderr}");
    assert!(stderr.contains(expected), "{expected:?} in {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn bad_files_and_windows_are_refused_with_one_clear_sentence() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_trace(dir.path());
    let good = std::fs::read(&path).unwrap();

    let corrupt = dir.path().join("corrupt.wrctrace");
    let mut bytes = good.clone();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0xff;
    std::fs::write(&corrupt, &bytes).unwrap();
    let corrupt = corrupt.to_str().unwrap();
    for action in ["info", "plot"] {
        refused(
            &["trace", action, corrupt],
            &format!("{corrupt} is corrupt: its samples section fails its CRC-32 check"),
        );
    }

    let newer = dir.path().join("newer.wrctrace");
    let mut bytes = good.clone();
    bytes[8..12].copy_from_slice(&(wrc_trace::FORMAT_VERSION + 1).to_le_bytes());
    std::fs::write(&newer, &bytes).unwrap();
    let newer = newer.to_str().unwrap();
    refused(
        &["trace", "info", newer],
        &format!(
            "{newer} was written by a newer wrc (trace format 3); this wrc reads trace format 2"
        ),
    );

    let cut = dir.path().join("cut.wrctrace");
    std::fs::write(&cut, &good[..good.len() - 10]).unwrap();
    refused(&["trace", "info", cut.to_str().unwrap()], "is truncated");

    let missing = dir.path().join("missing.wrctrace");
    refused(
        &["trace", "info", missing.to_str().unwrap()],
        "cannot read trace ",
    );

    refused(
        &[
            "trace",
            "plot",
            path.to_str().unwrap(),
            "--from",
            "5",
            "--to",
            "6",
        ],
        "no samples between 5 s and 6 s: the trace covers 1.000 s to 1.990 s",
    );
}
