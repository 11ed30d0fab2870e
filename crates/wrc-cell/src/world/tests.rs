use super::*;
use crate::station::parse_station_name;
use crate::transfer::{plan, Step, TransferKind};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;

fn demo() -> Stations {
    Stations::embedded_demo()
}

/// The demo stations with LP2's simulated slots set from `codes` (25 characters).
fn demo_with_lp2(codes: &str) -> Stations {
    let mut list = demo().as_slice().to_vec();
    list[1].sim = Some(crate::StationSim {
        wafers: crate::parse_slot_codes(codes).unwrap(),
    });
    Stations::from_list(list).unwrap()
}

fn seated(stations: &Stations, name: &str, slot: u16, lifted: bool) -> Pose {
    stations
        .get(name)
        .unwrap()
        .seated_pose(slot, lifted)
        .unwrap()
}

fn name(s: &str) -> StationName {
    parse_station_name(s).unwrap()
}

#[test]
fn the_demo_world_holds_the_configured_wafers() {
    let stations = demo_with_lp2("2X100 00000 00000 00000 00000");
    let world = World::new(&stations);
    assert_eq!(
        world.map_station("lp1").unwrap(),
        vec![SlotCode::Present; 25]
    );
    let lp2 = world.map_station("LP2").unwrap();
    assert_eq!(
        &lp2[..4],
        [
            SlotCode::Double,
            SlotCode::Cross,
            SlotCode::Present,
            SlotCode::Absent
        ]
    );
    assert_eq!(world.slot("LP1", 1).unwrap(), SlotContent::Wafer(1));
    assert_eq!(world.slot("LP2", 1).unwrap(), SlotContent::Double(26, 27));
    assert_eq!(world.slot("LP2", 2).unwrap(), SlotContent::Cross(28));
    assert_eq!(world.slot("LP2", 3).unwrap(), SlotContent::Wafer(29));
    assert_eq!(world.tags(), (1..=29).collect::<Vec<_>>());
    assert_eq!(world.map_station("PM1").unwrap(), [SlotCode::Absent]);
    assert!(world.map_station("PM3").is_err());
    assert!(matches!(
        world.slot("AL", 2),
        Err(WorldError::NoSuchSlot { slots: 1, .. })
    ));
    assert!(!world.vacuum_sensor());
}

#[test]
fn a_wafer_is_picked_rising_through_its_support_with_vacuum() {
    let stations = demo();
    let mut world = World::new(&stations);
    let low = seated(&stations, "LP1", 4, false);
    let high = seated(&stations, "LP1", 4, true);
    assert_eq!(world.step(low, false), None);
    assert_eq!(world.step(low, true), None);
    assert!(!world.vacuum_sensor(), "no wafer on the hand yet");
    let mid = Pose {
        z: (low.z + high.z) / 2.0 - 0.5,
        ..low
    };
    assert_eq!(world.step(mid, true), None);
    assert_eq!(
        world.step(high, true),
        Some(WorldEvent::Picked {
            station: name("LP1"),
            slot: 4,
            tag: 4
        })
    );
    assert!(world.vacuum_sensor());
    assert_eq!(world.hand(), Some(4));
    assert_eq!(world.slot("LP1", 4).unwrap(), SlotContent::Empty);
    assert_eq!(world.faults(), 0);
}

#[test]
fn no_pick_outside_the_seating_tolerance() {
    let stations = demo();
    let low = seated(&stations, "LP1", 4, false);
    let high = seated(&stations, "LP1", 4, true);
    for off in [
        Pose {
            x: low.x + 2.5,
            ..low
        },
        Pose {
            y: low.y - 2.1,
            ..low
        },
        Pose {
            yaw: low.yaw + 1.5,
            ..low
        },
    ] {
        let mut world = World::new(&stations);
        world.step(off, true);
        let up = Pose { z: high.z, ..off };
        assert_eq!(world.step(up, true), None, "{off:?}");
        assert_eq!(world.hand(), None);
    }
    // Within tolerance: 1.5 mm and 0.8 deg off still picks.
    let mut world = World::new(&stations);
    let near = Pose {
        x: low.x + 1.5,
        yaw: low.yaw - 0.8,
        ..low
    };
    world.step(near, true);
    assert!(matches!(
        world.step(Pose { z: high.z, ..near }, true),
        Some(WorldEvent::Picked { .. })
    ));
}

#[test]
fn lifting_without_vacuum_or_into_a_faulty_slot_is_a_fault() {
    let stations = demo_with_lp2("2X000 00000 00000 00000 00000");
    let mut world = World::new(&stations);
    let low = seated(&stations, "LP1", 1, false);
    world.step(low, false);
    let e = world
        .step(seated(&stations, "LP1", 1, true), false)
        .unwrap();
    assert_eq!(
        e,
        WorldEvent::UnclampedLift {
            station: name("LP1"),
            slot: 1
        }
    );
    assert!(e.is_fault());
    assert_eq!(world.slot("LP1", 1).unwrap(), SlotContent::Wafer(1));

    for slot in [1, 2] {
        world.step(seated(&stations, "LP2", slot, false), true);
        let e = world
            .step(seated(&stations, "LP2", slot, true), true)
            .unwrap();
        assert_eq!(
            e,
            WorldEvent::Collision {
                station: name("LP2"),
                slot
            }
        );
    }
    assert_eq!(world.faults(), 3);
    assert_eq!(world.hand(), None);
}

#[test]
fn a_wafer_is_placed_when_the_vacuum_goes_off_above_an_empty_slot() {
    let stations = demo();
    let mut world = World::new(&stations);
    // Pick LP1.1.
    world.step(seated(&stations, "LP1", 1, false), true);
    world.step(seated(&stations, "LP1", 1, true), true);
    assert_eq!(world.hand(), Some(1));
    // Put it into LP2.7.
    let high = seated(&stations, "LP2", 7, true);
    world.step(high, true);
    assert_eq!(
        world.step(high, false),
        Some(WorldEvent::Placed {
            station: name("LP2"),
            slot: 7,
            tag: 1
        })
    );
    assert!(!world.vacuum_sensor());
    // Going down through the support leaves it there.
    assert_eq!(world.step(seated(&stations, "LP2", 7, false), false), None);
    assert_eq!(world.slot("LP2", 7).unwrap(), SlotContent::Wafer(1));
    assert_eq!(world.map_station("LP2").unwrap()[6], SlotCode::Present);
    assert_eq!(world.faults(), 0);
}

#[test]
fn releasing_onto_a_wafer_stacks_and_elsewhere_loses_it() {
    let stations = demo();
    let mut world = World::new(&stations);
    world.step(seated(&stations, "LP1", 1, false), true);
    world.step(seated(&stations, "LP1", 1, true), true);
    // Rising from slot 1 to slot 2 while seated would hit wafer 2: go out and back in.
    let above2 = seated(&stations, "LP1", 2, true);
    let out2 = stations.get("LP1").unwrap().approach_pose(2, true).unwrap();
    world.step(out2, true);
    world.step(above2, true);
    // Release above LP1.2, which holds wafer 2: a double.
    assert_eq!(
        world.step(above2, false),
        Some(WorldEvent::Stacked {
            station: name("LP1"),
            slot: 2,
            tag: 1
        })
    );
    assert_eq!(world.slot("LP1", 2).unwrap(), SlotContent::Double(2, 1));
    assert_eq!(world.map_station("LP1").unwrap()[1], SlotCode::Double);

    // Pick LP1.3 and switch the vacuum off in mid-air: lost.
    world.step(seated(&stations, "LP1", 3, false), true);
    world.step(seated(&stations, "LP1", 3, true), true);
    let outside = stations.get("LP1").unwrap().approach_pose(3, true).unwrap();
    world.step(outside, true);
    assert_eq!(
        world.step(outside, false),
        Some(WorldEvent::Lost { tag: 3 })
    );
    assert_eq!(world.lost(), [3]);
    assert_eq!(world.faults(), 2);
    assert!(!world.tags().contains(&3));

    // Too high above the support (more than one stroke): lost too.
    world.step(seated(&stations, "LP1", 4, false), true);
    world.step(seated(&stations, "LP1", 4, true), true);
    let pm = seated(&stations, "PM1", 1, true);
    world.step(
        Pose {
            z: pm.z + 30.0,
            ..pm
        },
        true,
    );
    assert_eq!(
        world.step(
            Pose {
                z: pm.z + 30.0,
                ..pm
            },
            false
        ),
        Some(WorldEvent::Lost { tag: 4 })
    );
}

#[test]
fn rising_into_the_next_wafer_while_carrying_one_is_a_collision() {
    let stations = demo();
    let mut world = World::new(&stations);
    world.step(seated(&stations, "LP1", 1, false), true);
    world.step(seated(&stations, "LP1", 1, true), true);
    let e = world.step(seated(&stations, "LP1", 2, true), true).unwrap();
    assert_eq!(
        e,
        WorldEvent::Collision {
            station: name("LP1"),
            slot: 2
        }
    );
    assert_eq!((world.hand(), world.faults()), (Some(1), 1));
}

#[test]
fn nonsense_poses_do_nothing() {
    let stations = demo();
    let mut world = World::new(&stations);
    let nan = Pose {
        x: f64::NAN,
        y: f64::NAN,
        z: f64::NAN,
        yaw: f64::NAN,
    };
    assert_eq!(world.step(nan, true), None);
    assert_eq!(world.step(seated(&stations, "LP1", 1, true), true), None);
    assert_eq!(world.step(nan, false), None);
    assert_eq!(world.tags().len(), 25);
}

#[test]
fn the_text_form_round_trips_and_is_checked() {
    let stations = demo_with_lp2("2X100 00000 00000 00000 00000");
    let mut world = World::new(&stations);
    world.step(seated(&stations, "LP1", 1, false), true);
    world.step(seated(&stations, "LP1", 1, true), true);
    let text = world.to_text();
    assert_eq!(World::from_text(&text, &stations).unwrap(), world);

    let bad = |t: &str| World::from_text(t, &stations).unwrap_err().to_string();
    assert!(bad("").contains("unusable"));
    assert!(bad(&text.replace("\"T2\"", "\"T3\"")).contains("twice"));
    assert!(bad(&text.replace("\"T2\"", "\"T99\"")).contains("next_tag"));
    assert!(bad(&text.replace("\"T2\"", "\"Q\"")).contains("\"Q\""));
    assert!(bad(&text.replace("name = \"AL\"", "name = \"AX\"")).contains("AX"));
    assert!(bad(&text.replace("version = 1", "version = 3")).contains("version 3"));
    let fewer = Stations::from_list(demo().as_slice()[..4].to_vec()).unwrap();
    assert!(World::from_text(&text, &fewer)
        .unwrap_err()
        .to_string()
        .contains("4 configured"));
    assert_eq!(parse_content_token("D1+2"), Some(SlotContent::Double(1, 2)));
    assert_eq!(parse_content_token("D1+"), None);
    assert_eq!(parse_content_token("T-1"), None);
}

#[test]
fn tracking_binds_ids_to_tags_and_reports_differences() {
    let stations = demo();
    let mut world = World::new(&stations);
    let mut map = WaferMap::new(&stations);
    let mut tracking = Tracking::new();
    // Unknown slots against wafers: not tracked.
    let m = tracking.check(&map, &world);
    assert_eq!(m.len(), 25, "{m:?}");
    assert!(
        m[0].to_string()
            .contains("LP1.1: the map says ?, the cell has T1"),
        "{}",
        m[0]
    );

    for s in ["LP1", "LP2", "AL", "PM1", "PM2"] {
        map.apply_mapping(s, &world.map_station(s).unwrap())
            .unwrap();
    }
    assert_eq!(tracking.check(&map, &world), []);
    assert_eq!(tracking.tag_of(WaferId(5)), Some(5));

    // Physically swap LP1.1 and LP1.2 behind the map's back: identity mismatches.
    world.stations[0].slots.swap(0, 1);
    let m = tracking.check(&map, &world);
    assert_eq!(m.len(), 2, "{m:?}");
    assert!(matches!(
        m[0],
        Mismatch::Identity {
            wafer: WaferId(1),
            tag: 2,
            ..
        }
    ));
    assert!(
        m[0].to_string()
            .contains("LP1.1: the map's W1 (physical tag 1) is where tag 2 (tracked as W2) is"),
        "{}",
        m[0]
    );
    world.stations[0].slots.swap(0, 1);

    // A pending transfer is reported; a wafer on the hand the map does not know too.
    let t = map.prepare(TransferKind::Get, "LP1", 1).unwrap();
    map.begin(t).unwrap();
    world.step(seated(&stations, "LP1", 1, false), true);
    world.step(seated(&stations, "LP1", 1, true), true);
    let m = tracking.check(&map, &world);
    assert!(m.contains(&Mismatch::Pending(t)), "{m:?}");
    assert!(
        m.iter().any(|x| matches!(
            x,
            Mismatch::Occupancy {
                location: Location::HAND,
                ..
            }
        )),
        "{m:?}"
    );
    assert_eq!(
        map.reconcile([world.vacuum_sensor(), false]),
        crate::Reconciled::Committed(t)
    );
    assert_eq!(tracking.check(&map, &world), []);

    // A station missing from the world.
    let fewer = Stations::from_list(demo().as_slice()[..4].to_vec()).unwrap();
    let small = World::new(&fewer);
    let m = tracking.check(&map, &small);
    assert!(
        m.iter()
            .any(|x| matches!(x, Mismatch::Station { name } if name == "PM2")),
        "{m:?}"
    );
}

// ---- end to end: the controller's transfers against the world, killed at random -------

/// Stand-in for the controller (its map is volatile, its saved text is the file) and the
/// board (the world, the hand's pose and the vacuum output), which survives the controller.
struct Cell {
    stations: Stations,
    world: World,
    map: WaferMap,
    saved: String,
    pose: Pose,
    vacuum: bool,
    /// The transfer's station and slot while the hand may be inside a station.
    inside: Option<(StationName, u16)>,
    events: u64,
    crash_at: Vec<u64>,
    crashes: u32,
}

struct Crashed;

impl Cell {
    fn new(stations: Stations) -> Cell {
        let world = World::new(&stations);
        let mut map = WaferMap::new(&stations);
        for s in &stations {
            map.apply_mapping(
                s.name.as_str(),
                &world.map_station(s.name.as_str()).unwrap(),
            )
            .unwrap();
        }
        let saved = map.to_text();
        Cell {
            stations,
            world,
            map,
            saved,
            pose: Pose {
                x: 100.0,
                y: 0.0,
                z: 0.0,
                yaw: 0.0,
            },
            vacuum: false,
            inside: None,
            events: 0,
            crash_at: Vec::new(),
            crashes: 0,
        }
    }

    /// Count an event; the controller dies before the events listed in `crash_at`.
    fn tick(&mut self) -> Result<(), Crashed> {
        self.events += 1;
        if self.crash_at.contains(&self.events) {
            Err(Crashed)
        } else {
            Ok(())
        }
    }

    fn hand_at(&mut self, pose: Pose, vacuum: bool) -> Result<(), Crashed> {
        self.tick()?;
        self.pose = pose;
        self.vacuum = vacuum;
        if let Some(e) = self.world.step(pose, vacuum) {
            assert!(!e.is_fault(), "{e:?}");
        }
        Ok(())
    }

    /// A straight move in 8 board periods.
    fn move_to(&mut self, to: Pose) -> Result<(), Crashed> {
        let from = self.pose;
        for i in 1..=8 {
            let u = f64::from(i) / 8.0;
            let p = Pose {
                x: from.x + u * (to.x - from.x),
                y: from.y + u * (to.y - from.y),
                z: from.z + u * (to.z - from.z),
                yaw: from.yaw + u * (to.yaw - from.yaw),
            };
            self.hand_at(p, self.vacuum)?;
        }
        Ok(())
    }

    fn save(&mut self) -> Result<(), Crashed> {
        self.tick()?;
        self.saved = self.map.to_text();
        Ok(())
    }

    /// GET from the n-th occupied slot when the hand is empty, else PUT into the n-th empty
    /// slot (as the map sees them).
    fn transfer(&mut self, n: usize) -> Result<(), Crashed> {
        let kind = if self.map.hand().is_some() {
            TransferKind::Put
        } else {
            TransferKind::Get
        };
        let mut places = Vec::new();
        for st in self.map.station_names() {
            for (i, s) in self.map.slots(st.as_str()).unwrap().iter().enumerate() {
                let fits = match kind {
                    TransferKind::Get => matches!(s, SlotState::Wafer(_)),
                    TransferKind::Put => *s == SlotState::Empty,
                };
                if fits {
                    places.push((st, i as u16 + 1));
                }
            }
        }
        if places.is_empty() {
            return Ok(());
        }
        let (st, slot) = places[n % places.len()];
        let t = self.map.prepare(kind, st.as_str(), slot).unwrap();
        self.map.begin(t).unwrap();
        self.save()?;
        self.inside = Some((st, slot));
        let station = self.stations.get(st.as_str()).unwrap().clone();
        for step in plan(kind, &station, slot).unwrap() {
            match step {
                // PTP paths run between approach poses, outside every station: one jump.
                Step::Ptp(p, _) => self.hand_at(p, self.vacuum)?,
                Step::Line(p) | Step::Z(p) => self.move_to(p)?,
                Step::Vacuum(on) => self.hand_at(self.pose, on)?,
                Step::CheckVacuum { expect } => {
                    assert_eq!(self.world.vacuum_sensor(), expect, "{step} in {t}")
                }
                Step::CommitMap => {
                    self.map.commit().unwrap();
                    self.save()?;
                }
                Step::RequireInput(_) | Step::Speed(_) | Step::RestoreSpeed => {}
            }
        }
        self.inside = None;
        Ok(())
    }

    /// kill -9 and restart: only the saved map survives; the board keeps the hand's pose and
    /// the vacuum output. Reconcile from the sensor, then back out of the station.
    fn restart(&mut self) {
        self.crashes += 1;
        self.map = WaferMap::from_text(&self.saved, "wafers.toml").unwrap();
        let sensed = self.world.vacuum_sensor();
        let r = self.map.reconcile([sensed, false]);
        assert!(r.is_consistent(), "{r:?}");
        self.saved = self.map.to_text();
        // Recovery (no crash injected here): hold a sensed wafer, release the valve
        // otherwise, and retract straight out at the current height.
        self.world.step(self.pose, sensed);
        self.vacuum = sensed;
        if let Some((st, slot)) = self.inside.take() {
            let station = self.stations.get(st.as_str()).unwrap();
            let out = Pose {
                z: self.pose.z,
                ..station.approach_pose(slot, false).unwrap()
            };
            let from = self.pose;
            for i in 1..=8 {
                let u = f64::from(i) / 8.0;
                let p = Pose {
                    x: from.x + u * (out.x - from.x),
                    y: from.y + u * (out.y - from.y),
                    ..from
                };
                assert_eq!(self.world.step(p, self.vacuum), None);
            }
            self.pose = out;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 96,
        rng_seed: RngSeed::Fixed(0x8_0008),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// The CLI's crash test (`wafer_cycle.rs`) in miniature: transfers between the demo stations, the
    /// controller killed at random events (between board periods, before a save), restarted
    /// from its saved map and reconciled. After every restart and at the end the map matches
    /// the world place by place and wafer by wafer, and nothing was dropped.
    #[test]
    fn killing_the_controller_at_any_moment_never_loses_or_duplicates_a_wafer(
        lp2 in "[0-1]{20}[0-2X]{5}",
        requests in proptest::collection::vec(0usize..100, 1..25),
        crash_at in proptest::collection::vec(1u64..700, 0..8),
    ) {
        let mut cell = Cell::new(demo_with_lp2(&lp2));
        cell.crash_at = crash_at;
        let mut tracking = Tracking::new();
        prop_assert_eq!(tracking.check(&cell.map, &cell.world), []);
        let all = cell.world.tags();
        for n in requests {
            if cell.transfer(n).is_err() {
                cell.restart();
                let m = tracking.check(&cell.map, &cell.world);
                prop_assert!(m.is_empty(), "after restart {}: {:?}", cell.crashes, m);
            }
        }
        cell.restart();
        let m = tracking.check(&cell.map, &cell.world);
        prop_assert!(m.is_empty(), "{:?}", m);
        prop_assert_eq!(cell.world.faults(), 0);
        prop_assert_eq!(cell.world.tags(), all);
        cell.map.verify().unwrap();
    }
}

/// Blade B is a hand of its own: it picks and places with its own pose and vacuum, its wafer
/// survives the text form, and it is compared with the map's `hand.B`.
#[test]
fn blade_b_picks_and_places_on_its_own() {
    let stations = demo();
    let mut world = World::new(&stations);
    let (low, high) = (
        seated(&stations, "LP1", 2, false),
        seated(&stations, "LP1", 2, true),
    );
    // Blade A stays far away with its vacuum off; blade B lifts W2 with its vacuum on.
    let away = Pose { z: 250.0, ..low };
    assert_eq!(world.step_blade(Blade::B, low, true), None);
    assert_eq!(world.step(away, false), None);
    assert_eq!(
        world.step_blade(Blade::B, high, true),
        Some(WorldEvent::Picked {
            station: name("LP1"),
            slot: 2,
            tag: 2
        })
    );
    assert_eq!(world.hand_of(Blade::B), Some(2));
    assert_eq!(world.hand(), None);
    assert!(world.vacuum_sensor_of(Blade::B) && !world.vacuum_sensor());
    // The text form keeps blade B's wafer, valve and height.
    let back = World::from_text(&world.to_text(), &stations).unwrap();
    assert_eq!(back, world);
    assert_eq!(world.tags().len(), 25);
    // The map with W2 on blade B agrees with the cell; with W2 on the hand it does not.
    let mut map = WaferMap::new(&stations);
    map.apply_mapping("LP1", &world.map_station("LP1").unwrap())
        .unwrap();
    let mut tracking = Tracking::new();
    let mut with_b = map.clone();
    with_b.place(Location::Hand(Blade::B), WaferId(26)).unwrap();
    assert!(tracking.check(&with_b, &world).is_empty());
    let mut with_a = map.clone();
    with_a.place(Location::HAND, WaferId(26)).unwrap();
    assert_eq!(Tracking::new().check(&with_a, &world).len(), 2);
    // Blade B releases W2 into the empty slot 2 (vacuum off just above its support).
    assert_eq!(
        world.step_blade(Blade::B, high, false),
        Some(WorldEvent::Placed {
            station: name("LP1"),
            slot: 2,
            tag: 2
        })
    );
    assert_eq!(world.hand_of(Blade::B), None);
}

// ---- collisions with the cell -------------------------------------------------------

/// `from` + `u`·(`to` − `from`) in x, y, z and yaw.
fn lerp(from: Pose, to: Pose, u: f64) -> Pose {
    Pose {
        x: from.x + u * (to.x - from.x),
        y: from.y + u * (to.y - from.y),
        z: from.z + u * (to.z - from.z),
        yaw: from.yaw + u * (to.yaw - from.yaw),
    }
}

/// `pose` moved `along` into the station and `side` to its left (of the hand direction
/// `yaw`) [mm].
fn offset(pose: Pose, yaw: f64, along: f64, side: f64) -> Pose {
    let (s, c) = yaw.to_radians().sin_cos();
    Pose {
        x: pose.x + along * c - side * s,
        y: pose.y + along * s + side * c,
        ..pose
    }
}

fn robot() -> wrc_robot::Robot {
    wrc_robot::Robot::paper_default()
}

/// A world of `stations` that checks the paper robot's arm (the hand only).
fn armed(stations: &Stations) -> World {
    let mut world = World::new(stations);
    world.set_arm(&robot(), stations, &[0.0]);
    world
}

/// The joints of `pose` with the right elbow (the left one where the right cannot), near
/// `near`.
fn joints(pose: Pose, near: Option<&Joints>) -> Joints {
    let robot = robot();
    let posture = near
        .and_then(|q| wrc_robot::Posture::of(&robot, q))
        .unwrap_or(wrc_robot::Posture::Right);
    robot
        .inverse(&pose, posture, near)
        .or_else(|_| robot.inverse(&pose, wrc_robot::Posture::Left, near))
        .unwrap()
}

/// Move the arm through `poses` (each reached in one call, along a straight joint-space
/// segment): every event.
fn visit(world: &mut World, poses: &[Pose]) -> Vec<WorldEvent> {
    let mut last: Option<Joints> = None;
    let mut events = Vec::new();
    for p in poses {
        let q = joints(*p, last.as_ref());
        events.extend(world.touch(&q));
        last = Some(q);
    }
    events
}

/// The poses from `from` to `to` in `n` equal steps (`from` left out).
fn line(from: Pose, to: Pose, n: u32) -> Vec<Pose> {
    (1..=n)
        .map(|i| lerp(from, to, f64::from(i) / f64::from(n)))
        .collect()
}

/// Every transfer's straight lines of the demo cell, in 1 mm steps, with both blades and
/// with the vacuum as a GET has it: in, the stroke, out; nothing touches the cell, and the
/// wafer picked is carried out.
#[test]
fn straight_lines_in_and_out_never_touch_the_cell() {
    let stations = demo();
    for s in &stations {
        for slot in [1, s.slots] {
            let mut world = World::new(&stations);
            world.set_arm(&robot(), &stations, &[0.0, -30.0]);
            let (out_low, in_low) = (
                s.approach_pose(slot, false).unwrap(),
                s.seated_pose(slot, false).unwrap(),
            );
            let (out_high, in_high) = (
                s.approach_pose(slot, true).unwrap(),
                s.seated_pose(slot, true).unwrap(),
            );
            let n = s.approach_mm.ceil() as u32;
            let first = s
                .approach_joints(&robot(), slot, false, &robot().home())
                .unwrap();
            let mut events: Vec<WorldEvent> = world.touch(&first).into_iter().collect();
            let mut path = line(out_low, in_low, n);
            path.extend(line(in_low, in_high, 20));
            path.extend(line(in_high, out_high, n));
            let mut last = first;
            for p in path {
                let q = joints(p, Some(&last));
                events.extend(world.touch(&q));
                events.extend(world.step(p, true));
                last = q;
            }
            assert!(
                events
                    .iter()
                    .all(|e| !matches!(e, WorldEvent::SideCollision { .. })),
                "{} slot {slot}: {events:?}",
                s.name
            );
            assert_eq!(world.faults(), 0, "{} slot {slot}: {events:?}", s.name);
            assert_eq!(world.last_side_collision(), None);
        }
    }
}

/// A PTP that swings the arm about the shoulder from the seat (or from halfway in) moves
/// the hand sideways through the cassette's side: one collision, at the station it was in;
/// one that goes on to the aligner's approach pose hits more on its way.
#[test]
fn a_ptp_sweep_from_inside_hits_the_side() {
    let stations = demo();
    let lp1 = stations.get("LP1").unwrap();
    let seat = lp1.seated_pose(4, false).unwrap();
    let halfway = offset(seat, lp1.pose.yaw, -0.5 * lp1.approach_mm, 0.0);
    for from in [seat, halfway] {
        // The shoulder turns 15 degrees: the hand swings sideways, still in front of LP1.
        let mut world = armed(&stations);
        let a = joints(from, None);
        let mut b = a;
        b[0] += 15.0;
        assert_eq!(world.touch(&a), None);
        let mut events: Vec<WorldEvent> = world.touch(&b).into_iter().collect();
        events.extend(world.touch(&b));
        assert_eq!(events.len(), 1, "from {from:?}: {events:?}");
        assert!(
            matches!(events[0], WorldEvent::SideCollision { station, .. } if station == name("LP1")),
            "{events:?}"
        );
        assert_eq!((world.faults(), world.side_collisions()), (1, 1));
        assert_eq!(world.last_side_collision(), Some(name("LP1")));
        assert_eq!(world.touching(), [name("LP1")]);
        assert_eq!(world.tags().len(), 25, "nothing moved");

        // Straight to the aligner's approach pose: out through LP1's side and on, sweeping
        // the stretched arm through LP2 on its way.
        let mut world = armed(&stations);
        let al = stations.get("AL").unwrap().approach_pose(1, false).unwrap();
        let b = joints(al, Some(&a));
        world.touch(&a);
        let mut events = Vec::new();
        for i in 1..=200 {
            let u = f64::from(i) / 200.0;
            let mut q = a;
            for (k, v) in q.iter_mut().enumerate() {
                *v = a[k] + u * (b[k] - a[k]);
            }
            events.extend(world.touch(&q));
        }
        assert!(
            matches!(events.first(), Some(WorldEvent::SideCollision { station, .. }) if *station == name("LP1")),
            "from {from:?}: {events:?}"
        );
        assert_eq!(
            events
                .iter()
                .filter(|e| matches!(e, WorldEvent::SideCollision { station, .. } if *station == name("LP1")))
                .count(),
            1
        );
    }
}

#[test]
fn moving_sideways_inside_hits_the_side_once_per_entry() {
    let stations = demo();
    let lp1 = stations.get("LP1").unwrap();
    let yaw = lp1.pose.yaw;
    let seat = lp1.seated_pose(2, false).unwrap();
    let mut world = armed(&stations);
    assert_eq!(visit(&mut world, &[seat]), []);
    // 1.9 mm sideways is within the tolerance; 2.1 mm is not.
    assert_eq!(visit(&mut world, &[offset(seat, yaw, 0.0, 1.9)]), []);
    assert_eq!(visit(&mut world, &[offset(seat, yaw, -100.0, -1.9)]), []);
    let hit = visit(&mut world, &[offset(seat, yaw, -100.0, -2.1)]);
    assert!(
        matches!(hit[..], [WorldEvent::SideCollision { station, .. }] if station == name("LP1")),
        "{hit:?}"
    );
    // Still touching: not reported again, wherever it goes in there, across the line too.
    for s in [-2.1, -50.0, 0.0, 20.0] {
        assert_eq!(visit(&mut world, &[offset(seat, yaw, -100.0, s)]), []);
    }
    // Out of the station along its line: clear; in again off the line: a new collision.
    let out = offset(seat, yaw, -lp1.approach_mm, 0.0);
    assert_eq!(
        visit(&mut world, &[offset(seat, yaw, -100.0, 0.0), out]),
        []
    );
    assert_eq!(world.touching(), []);
    assert_eq!(visit(&mut world, &[offset(seat, yaw, -60.0, 5.0)]).len(), 1);
    assert_eq!((world.faults(), world.side_collisions()), (2, 2));
    // The text form keeps the contact (and the counts): read back, the arm is still known
    // to touch LP1, and no new collision is reported.
    let text = world.to_text();
    assert!(text.contains("touching = [\"LP1\"]"), "{text}");
    let mut back = World::from_text(&text, &stations).unwrap();
    assert_eq!(back.touching(), [name("LP1")]);
    back.set_arm(&robot(), &stations, &[0.0]);
    assert_eq!(visit(&mut back, &[offset(seat, yaw, -60.0, 9.0)]), []);
}

#[test]
fn turning_inside_hits_the_side() {
    let stations = demo();
    let pm2 = stations.get("PM2").unwrap();
    let seat = pm2.seated_pose(1, true).unwrap();
    let mut world = armed(&stations);
    let turned = |deg: f64| Pose {
        yaw: seat.yaw + deg,
        ..seat
    };
    assert_eq!(visit(&mut world, &[seat, turned(1.9), turned(-1.9)]), []);
    assert_eq!(visit(&mut world, &[turned(2.5)]).len(), 1);
    assert_eq!(world.faults(), 1);
}

/// Heights count: under a station the arm may swing; at the station's heights it may not.
#[test]
fn the_arm_passes_under_a_station() {
    let stations = demo();
    let lp1 = stations.get("LP1").unwrap();
    let yaw = lp1.pose.yaw;
    // From beside the seat to the other side of it, 100 mm in front of the seat: through
    // LP1's box (and on into LP2's) at 100 mm, under them at 0.
    for z in [0.0, 100.0] {
        let mut world = armed(&stations);
        let at = |side: f64| Pose {
            z,
            ..offset(lp1.pose, yaw, -100.0, side)
        };
        let events = visit(&mut world, &[at(-200.0), at(200.0)]);
        let lp1_hit = events.iter().any(
            |e| matches!(e, WorldEvent::SideCollision { station, .. } if *station == name("LP1")),
        );
        assert_eq!(lp1_hit, z > 0.0, "z {z}: {events:?}");
        if z == 0.0 {
            assert_eq!(events, [], "under every station");
        }
    }
}

/// Sideways motion and turning where the hand is outside every station: at LP1's approach
/// pose, behind it, and beyond LP1's back, where the arm does not reach the box.
#[test]
fn moving_sideways_or_turning_outside_a_station_is_no_collision() {
    let stations = demo();
    let lp1 = stations.get("LP1").unwrap();
    let yaw = lp1.pose.yaw;
    let seat = lp1.seated_pose(1, false).unwrap();
    let mut world = armed(&stations);
    let mut events = Vec::new();
    let p = offset(seat, yaw, -lp1.approach_mm, 0.0);
    events.extend(visit(&mut world, &[p]));
    events.extend(visit(
        &mut world,
        &line(
            p,
            Pose {
                yaw: yaw + 90.0,
                ..p
            },
            30,
        ),
    ));
    events.extend(visit(
        &mut world,
        &line(offset(p, yaw, 0.0, -20.0), offset(p, yaw, 0.0, 20.0), 40),
    ));
    let behind = offset(seat, yaw, -lp1.approach_mm - 10.0, 0.0);
    events.extend(visit(
        &mut world,
        &line(
            offset(behind, yaw, 0.0, -30.0),
            offset(behind, yaw, 0.0, 30.0),
            30,
        ),
    ));
    assert_eq!(events, [], "{}", world.to_text());
    assert_eq!(world.faults(), 0);
}

/// A fixed obstacle is never entered; it is named in the event and the text form.
#[test]
fn an_obstacle_is_touched_by_the_body_that_reaches_it() {
    let column = crate::obstacle::Obstacle {
        name: name("column"),
        shape: crate::obstacle::ObstacleShape::Cylinder {
            x_mm: 0.0,
            y_mm: 250.0,
            radius_mm: 20.0,
        },
        bottom_mm: -500.0,
        top_mm: 600.0,
    };
    let stations = demo().with_obstacles(vec![column]).unwrap();
    let mut world = World::new(&stations);
    world.set_arm(&robot(), &stations, &[0.0]);
    let hit = visit(
        &mut world,
        &[
            Pose {
                x: 250.0,
                y: 0.0,
                z: 0.0,
                yaw: 90.0,
            },
            Pose {
                x: 0.0,
                y: 250.0,
                z: 0.0,
                yaw: 90.0,
            },
        ],
    );
    assert_eq!(hit.len(), 1, "{hit:?}");
    assert!(
        matches!(hit[0], WorldEvent::SideCollision { station, .. } if station == name("column")),
        "{hit:?}"
    );
    let text = world.to_text();
    assert!(text.contains("last_side_collision = \"column\""), "{text}");
    assert!(World::from_text(&text, &stations).is_ok());
}

#[test]
fn the_text_form_checks_the_collision_state() {
    let stations = demo();
    let mut world = armed(&stations);
    let seat = seated(&stations, "PM1", 1, false);
    visit(
        &mut world,
        &[
            seat,
            Pose {
                x: seat.x + 5.0,
                ..seat
            },
        ],
    );
    let text = world.to_text();
    assert!(text.contains("touching = [\"PM1\"]"), "{text}");
    assert!(text.contains("last_side_collision = \"PM1\""), "{text}");
    let back = World::from_text(&text, &stations).unwrap();
    assert_eq!(back.touching(), world.touching());
    assert_eq!(back.to_text(), text);
    let bad = |t: &str| World::from_text(t, &stations).unwrap_err().to_string();
    let other = text.replace(
        "last_side_collision = \"PM1\"",
        "last_side_collision = \"PM9\"",
    );
    assert!(
        bad(&other).contains("\"PM9\" is not a station or obstacle"),
        "{}",
        bad(&other)
    );
    assert!(
        bad(&text.replace("touching = [\"PM1\"]", "touching = [\"XX\"]"))
            .contains("touching \"XX\" is not a station or obstacle")
    );
    // The text of an older build: a station's side hit by blade A.
    let old = text.replace("touching = [\"PM1\"]\n", "").replace(
        "name = \"PM1\"\nslots = [\"-\"]",
        "name = \"PM1\"\nslots = [\"-\"]\nside_hit = [\"A\"]",
    );
    assert_ne!(old, text);
    assert_eq!(
        World::from_text(&old, &stations).unwrap().touching(),
        [name("PM1")]
    );
    assert!(bad(&old.replace("[\"A\"]", "[\"C\"]")).contains("\"C\" is not a blade"));
    // A world without any reads as none.
    let clean = World::new(&stations);
    assert!(!clean.to_text().contains("side") && !clean.to_text().contains("touching"));
}
