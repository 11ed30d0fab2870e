//! Fuzz the wafer map loader: any text (the file is read as UTF-8) → `WaferMap::from_text`
//! gives a map that keeps the map's rules, or an error that names the file, never a panic.
//! An accepted map is written back by `to_text` to a file that reads as the same map, and
//! goes through the controller's start-up: adopt the demo cell's stations, reconcile with
//! the vacuum sensors (input length bits 0 and 1 stand for blades A and B; bit 2 makes the
//! robot dual-blade), then a GET and a PUT as a job makes them. After every step the map
//! still keeps its rules and still reads back; the `WAFERS` lines are single lines.
#![no_main]

use std::sync::LazyLock;

use libfuzzer_sys::fuzz_target;
use wrc_cell::{Stations, TransferKind, WaferMap};

const FILE: &str = "fuzz-wafers.toml";

/// The demo cell, parsed once.
static DEMO: LazyLock<Stations> = LazyLock::new(Stations::embedded_demo);

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let mut map = match WaferMap::from_text(text, FILE) {
        Ok(map) => map,
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.contains(FILE),
                "the error does not name the file: {message}"
            );
            return;
        }
    };
    check(&map);

    let stations = &*DEMO;
    if map.adopt_stations(stations).is_err() {
        return;
    }
    check(&map);
    map.set_dual(data.len() & 4 != 0);
    let _ = map.reconcile([data.len() & 1 != 0, data.len() & 2 != 0]);
    check(&map);
    for (kind, station) in [(TransferKind::Get, "LP1"), (TransferKind::Put, "LP2")] {
        let Ok(transfer) = map.prepare(kind, station, 1) else {
            continue;
        };
        map.begin(transfer).expect("a prepared transfer begins");
        check(&map);
        map.commit().expect("a begun transfer commits");
        check(&map);
    }
});

fn check(map: &WaferMap) {
    map.verify().expect("the map keeps its rules");
    let written = map.to_text();
    let back = WaferMap::from_text(&written, FILE)
        .unwrap_or_else(|e| panic!("to_text does not read back: {e}\n{written}"));
    // `dual` is the robot's, not the file's.
    let mut expected = map.clone();
    expected.set_dual(false);
    assert_eq!(back, expected, "to_text does not read back as the same map");
    for line in map.wafers_lines() {
        assert!(!line.contains('\n'), "a WAFERS line holds an LF");
    }
}
