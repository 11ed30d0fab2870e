//! Bad, truncated and foreign files are refused with the path and the problem; a board
//! restarting on its own file gets a new epoch.

use std::fs;

use wrc_board::layout::{header, Header, LAYOUT_SIZE};
use wrc_board::{DpramBoard, Expect, OpenError};

use crate::sim_on;

fn open_err(path: &std::path::Path) -> String {
    let e = DpramBoard::open(path, Expect::default()).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains(&path.display().to_string()),
        "does not name the path: {text}"
    );
    text
}

#[test]
fn missing_truncated_and_foreign_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.dpram");
    assert!(open_err(&missing).contains("cannot open"));

    let short = dir.path().join("short.dpram");
    fs::write(&short, vec![0u8; 100]).unwrap();
    let e = open_err(&short);
    assert!(e.contains("truncated") && e.contains("100 bytes"), "{e}");

    let foreign = dir.path().join("foreign.bin");
    let mut bytes = vec![0x5Au8; LAYOUT_SIZE + 10];
    bytes[0..4].copy_from_slice(b"\x7fELF");
    fs::write(&foreign, &bytes).unwrap();
    let e = open_err(&foreign);
    assert!(e.contains("not a wrc DPRAM") && e.contains("magic"), "{e}");

    let zeros = dir.path().join("zeros.dpram");
    fs::write(&zeros, vec![0u8; LAYOUT_SIZE]).unwrap();
    let e = DpramBoard::open(&zeros, Expect::default()).unwrap_err();
    assert!(e.is_not_ready(), "{e}");
    assert!(e.to_string().contains("not initialised"), "{e}");

    let e = open_err(dir.path());
    assert!(e.contains("cannot"), "{e}");
}

#[test]
fn other_versions_and_bad_fields_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = vec![0u8; LAYOUT_SIZE];
    Header {
        board_id: 0,
        axis_count: 4,
        period_us: 10_000,
        fifo_depth: 8,
        epoch: 1,
    }
    .encode(&mut bytes);
    let path = dir.path().join("v1.dpram");
    let mut v1 = bytes.clone();
    v1[header::VERSION] = 1;
    fs::write(&path, &v1).unwrap();
    let e = open_err(&path);
    assert!(e.contains("version 1"), "{e}");

    let mut depth = bytes.clone();
    depth[header::FIFO_DEPTH..header::FIFO_DEPTH + 4].copy_from_slice(&300u32.to_le_bytes());
    fs::write(&path, &depth).unwrap();
    let e = open_err(&path);
    assert!(e.contains("fifo_depth") && e.contains("300"), "{e}");

    fs::write(&path, &bytes).unwrap();
    let e = DpramBoard::open(
        &path,
        Expect {
            period_us: Some(1_000),
            ..Expect::default()
        },
    )
    .unwrap_err();
    assert!(matches!(e, OpenError::Mismatch { .. }), "{e}");
    assert!(
        e.to_string().contains("period_us = 10000") && e.to_string().contains("1000"),
        "{e}"
    );
}

#[test]
fn the_simulated_board_refuses_to_overwrite_a_foreign_file() {
    let dir = tempfile::tempdir().unwrap();
    let config = wrc_config::Config::embedded_default();
    let settings = wrc_board_sim::SimSettings::from_config(&config, &config.boards[0]);
    let foreign = dir.path().join("notes.txt");
    fs::write(&foreign, "x".repeat(LAYOUT_SIZE)).unwrap();
    let e = wrc_board_sim::SimBoard::create(&foreign, &settings)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("notes.txt") && e.contains("refusing to overwrite"),
        "{e}"
    );
    assert_eq!(
        fs::read_to_string(&foreign).unwrap(),
        "x".repeat(LAYOUT_SIZE)
    );
    let short = dir.path().join("short.txt");
    fs::write(&short, "hello").unwrap();
    let e = wrc_board_sim::SimBoard::create(&short, &settings)
        .unwrap_err()
        .to_string();
    assert!(e.contains("short.txt") && e.contains("truncated"), "{e}");
    assert_eq!(fs::read_to_string(&short).unwrap(), "hello");
}

#[test]
fn layout_round_trips_through_a_file_and_restarts_bump_the_epoch() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("board0.dpram");
    let first = sim_on(&path);
    assert_eq!(fs::metadata(&path).unwrap().len(), LAYOUT_SIZE as u64);
    let bytes = fs::read(&path).unwrap();
    let parsed = Header::parse(&bytes).unwrap();
    assert_eq!(parsed, *first.dpram().header());
    assert_eq!(
        (
            parsed.axis_count,
            parsed.period_us,
            parsed.fifo_depth,
            parsed.epoch
        ),
        (4, 10_000, 256, 1)
    );
    drop(first);
    let second = sim_on(&path);
    assert_eq!(second.dpram().header().epoch, 2);
    let host = DpramBoard::open(&path, Expect::default()).unwrap();
    assert_eq!(host.header().epoch, 2);
}

/// `wrc board-sim --power-up`: on the file of a board that ran, the axes start where its
/// encoders stood with every output off and the next epoch; a missing file is a first
/// start; a file that cannot be used (another layout version, axis count or board, garbage,
/// too short) is replaced by a first start, and the outlook said so beforehand.
#[test]
fn a_power_up_resumes_at_the_old_encoders_or_starts_fresh_and_says_why() {
    use wrc_board::MotionBoard;
    use wrc_board_sim::{power_up_outlook, PowerUp, SimBoard, SimSettings, Unusable};

    let dir = tempfile::tempdir().unwrap();
    let config = wrc_config::Config::embedded_default();
    let settings = SimSettings::from_config(&config, &config.boards[0]);
    let home: Vec<i64> = settings.axes.iter().map(|a| a.initial).collect();
    let path = dir.path().join("board0.dpram");
    let encoders =
        |sim: &SimBoard| -> Vec<i64> { (0..4).map(|c| sim.axis(c).unwrap().encoder()).collect() };
    let power_up = |settings: &SimSettings| {
        let outlook = power_up_outlook(&path, settings).unwrap();
        let (sim, how) = SimBoard::power_up_file(&path, settings).unwrap();
        assert_eq!(outlook, how);
        (sim, how)
    };

    // Nothing there yet: a first start at home.
    let (mut sim, how) = power_up(&settings);
    assert_eq!(how, PowerUp::Fresh);
    assert_eq!(sim.dpram().header().epoch, 1);
    assert_eq!(encoders(&sim), home);

    // The host moves every axis and opens two valves; then the power goes.
    let mut host = DpramBoard::open(&path, Expect::default()).unwrap();
    let mut inc = [0i64; 16];
    inc[..4].copy_from_slice(&[500, -300, 200, 100]);
    for _ in 0..20 {
        host.refresh_watchdog();
        let _ = host.push(&inc);
        sim.step();
    }
    for _ in 0..10 {
        host.refresh_watchdog();
        let _ = host.push(&[0; 16]);
        sim.step();
    }
    host.write_outputs(0, 0b101);
    sim.step();
    let moved = encoders(&sim);
    assert_ne!(moved, home);
    assert_eq!(
        sim.dpram().load(wrc_board::layout::io::OUTPUTS_APPLIED),
        0b101
    );
    drop((sim, host));

    let (sim, how) = power_up(&settings);
    assert_eq!(how, PowerUp::Resumed { epoch: 2 });
    assert_eq!(encoders(&sim), moved);
    let host = DpramBoard::open(&path, Expect::default()).unwrap();
    assert_eq!(host.header().epoch, 2);
    assert_eq!(host.outputs(0), 0);
    let mut f = wrc_board::Feedback::default();
    host.read_feedback(&mut f).unwrap();
    assert_eq!(f.axes[1].encoder, moved[1]);
    assert_eq!(f.axes[1].commanded, moved[1]);
    assert_eq!(f.boards[0].outputs, 0);
    drop((sim, host));

    // Unusable contents: each replaced by a first start at home, saying why.
    let three = SimSettings {
        axes: settings.axes[..3].to_vec(),
        ..settings.clone()
    };
    let (sim, how) = power_up(&three);
    assert_eq!(
        how,
        PowerUp::Replaced(Unusable::AxisCount {
            found: 4,
            expected: 3
        })
    );
    assert_eq!(sim.dpram().header().epoch, 1);
    assert!(how.to_string().contains("4 axes"), "{how}");
    drop(sim);
    let other_board = SimSettings {
        board_id: 1,
        ..three.clone()
    };
    let (sim, how) = power_up(&other_board);
    assert!(
        matches!(
            how,
            PowerUp::Replaced(Unusable::BoardId {
                found: 0,
                expected: 1
            })
        ),
        "{how}"
    );
    drop(sim);

    let (sim, _) = power_up(&settings);
    drop(sim);
    let mut bytes = fs::read(&path).unwrap();
    bytes[header::VERSION..header::VERSION + 4].copy_from_slice(&99u32.to_le_bytes());
    fs::write(&path, &bytes).unwrap();
    let (sim, how) = power_up(&settings);
    assert!(
        matches!(how, PowerUp::Replaced(Unusable::Layout(_))) && how.to_string().contains("99"),
        "{how}"
    );
    assert_eq!(encoders(&sim), home);
    drop(sim);

    fs::write(&path, vec![0x5Au8; LAYOUT_SIZE]).unwrap();
    let (sim, how) = power_up(&settings);
    assert!(how.to_string().contains("not a wrc DPRAM"), "{how}");
    assert_eq!(encoders(&sim), home);
    drop(sim);

    fs::write(&path, "hello").unwrap();
    let (sim, how) = power_up(&settings);
    assert_eq!(how, PowerUp::Replaced(Unusable::Truncated { len: 5 }));
    assert_eq!(fs::metadata(&path).unwrap().len(), LAYOUT_SIZE as u64);
    assert_eq!(encoders(&sim), home);
    DpramBoard::open(&path, Expect::default()).unwrap();
    drop(sim);

    // Not a regular file: refused, not replaced.
    let e = SimBoard::power_up_file(dir.path(), &settings).unwrap_err();
    assert!(e.to_string().contains("Is a directory"), "{e}");
}
