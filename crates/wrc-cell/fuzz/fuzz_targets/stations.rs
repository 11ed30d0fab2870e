//! Fuzz the stations file loader: any text (the file is read as UTF-8) → `Stations::parse`
//! gives stations or an error that names the file, never a panic. Accepted stations are
//! what the controller then works with: `to_toml` (what `TEACH` saves) parses back to the
//! same stations; the check against the paper robot, every `STN` line (one line each),
//! the steps of GET and PUT for the first, the last and two missing slots (refused exactly
//! when the slot does not exist), and a new wafer map and simulated cell of them (every
//! station mapped, the map's file read back) all work without panicking.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wrc_cell::{plan_get, plan_put, stn_line, Stations, WaferMap, World};
use wrc_robot::Robot;

const FILE: &str = "fuzz-stations.toml";

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let stations = match Stations::parse(text, FILE) {
        Ok(stations) => stations,
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.contains(FILE),
                "the error does not name the file: {message}"
            );
            return;
        }
    };
    let written = stations.to_toml();
    let back = Stations::parse(&written, "written.toml")
        .unwrap_or_else(|e| panic!("to_toml does not parse back: {e}\n{written}"));
    assert_eq!(
        back, stations,
        "to_toml does not parse back to the same stations"
    );

    let robot = Robot::paper_default();
    let _ = stations.validate(&robot);
    for s in &stations {
        assert!(s.check().is_ok(), "a parsed station fails its own check");
        assert!(!stn_line(s, 150.0).contains('\n'), "an STN line holds an LF");
        for slot in [0, 1, s.slots, s.slots.saturating_add(1)] {
            assert_eq!(plan_get(s, slot).is_ok(), s.has_slot(slot), "GET {slot}");
            assert_eq!(plan_put(s, slot).is_ok(), s.has_slot(slot), "PUT {slot}");
        }
    }

    let map = WaferMap::new(&stations);
    map.verify().expect("a new map keeps the rules");
    let _ = map.wafers_lines();
    let back = WaferMap::from_text(&map.to_text(), "wafers.toml").expect("a new map reads back");
    assert_eq!(back, map);
    let world = World::new(&stations);
    for s in &stations {
        let codes = world
            .map_station(s.name.as_str())
            .expect("every station maps");
        assert_eq!(codes.len(), usize::from(s.slots));
    }
    World::from_text(&world.to_text(), &stations).expect("a new cell reads back");
});
