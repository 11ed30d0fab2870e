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
