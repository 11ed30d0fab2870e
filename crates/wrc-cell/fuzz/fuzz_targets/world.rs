//! Fuzz the simulated cell's world file (`wrc board-sim --world FILE`, read by
//! `wrc_board_sim::world_file::load` as UTF-8 and then `World::from_text` against the
//! stations): any text gives a world or an error, never a panic. An accepted world writes
//! back (`to_text`) to text that reads as the same world; every station maps and every slot
//! reads; and the hand then takes LP1 slot 1 and puts it into LP2 slot 1 step by step as a
//! GET and a PUT move it — wafers may fall or stack, but none appears or vanishes, and the
//! fault count only grows.
#![no_main]

use std::sync::LazyLock;

use libfuzzer_sys::fuzz_target;
use wrc_cell::{plan, Stations, Step, TransferKind, World};
use wrc_robot::Pose;

/// The demo cell, parsed once.
static DEMO: LazyLock<Stations> = LazyLock::new(Stations::embedded_demo);

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let stations = &*DEMO;
    let world = match World::from_text(text, stations) {
        Ok(world) => world,
        Err(e) => {
            let _ = e.to_string();
            return;
        }
    };
    let written = world.to_text();
    let back = World::from_text(&written, stations)
        .unwrap_or_else(|e| panic!("to_text does not read back: {e}\n{written}"));
    assert_eq!(
        back.to_text(),
        written,
        "to_text does not read back as the same world"
    );

    for s in stations {
        let name = s.name.as_str();
        let codes = world.map_station(name).expect("every station maps");
        assert_eq!(codes.len(), usize::from(s.slots));
        for slot in 1..=s.slots {
            world.slot(name, slot).expect("every slot reads");
        }
    }

    let mut world = world;
    let wafers = world.tags().len() + world.lost().len();
    let faults = world.faults();
    let mut pose = Pose::default();
    let mut vacuum = world.vacuum();
    for (kind, station) in [(TransferKind::Get, "LP1"), (TransferKind::Put, "LP2")] {
        let station = stations.get(station).expect("a demo station");
        for step in plan(kind, station, 1).expect("slot 1 exists") {
            match step {
                Step::Ptp(p, _) | Step::Line(p) | Step::Z(p) => pose = p,
                Step::Vacuum(on) => vacuum = on,
                _ => {}
            }
            let _ = world.step(pose, vacuum);
            assert_eq!(
                world.tags().len() + world.lost().len(),
                wafers,
                "a wafer appeared or vanished"
            );
            assert!(world.faults() >= faults);
        }
    }
    World::from_text(&world.to_text(), stations).expect("the world after the moves reads back");
});
