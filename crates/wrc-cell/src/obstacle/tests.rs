use super::*;
use crate::stations::Stations;
use crate::transfer::{plan, Step, TransferKind};
use wrc_motion::{MotionSettings, Period, VelocityGenerator};
use wrc_robot::{Pose, Posture};

fn demo() -> (Robot, Stations, CellModel) {
    let robot = Robot::paper_default();
    let stations = Stations::embedded_demo();
    let model = stations.model(&robot).unwrap();
    (robot, stations, model)
}

const HAND: [BladeLoad; 1] = [BladeLoad {
    z_offset_mm: 0.0,
    wafer: false,
}];
const LOADED: [BladeLoad; 1] = [BladeLoad {
    z_offset_mm: 0.0,
    wafer: true,
}];

fn at(robot: &Robot, pose: Pose) -> Joints {
    robot.inverse(&pose, Posture::Right, None).unwrap()
}

fn contact(model: &CellModel, robot: &Robot, q: &Joints, blades: &[BladeLoad]) -> Option<Contact> {
    let bodies = robot.bodies(q, blades);
    model.contact(&bodies, blades, &LineTolerance::WORLD, 0.0)
}

#[test]
fn the_demo_boxes_begin_where_the_hands_wafer_at_the_approach_pose_leaves_room() {
    let (robot, stations, _) = demo();
    let lp1 = stations.get("LP1").unwrap();
    let v = lp1.volume(150.0);
    // 220 mm approach: the wafer's edge at the approach pose is 70 mm before the seat,
    // and the box begins 25 mm further in.
    assert_eq!(
        (v.mouth_mm, v.depth_mm, v.width_mm, v.bottom_mm, v.top_mm),
        (45.0, 235.0, 310.0, 10.0, 280.0)
    );
    // A station with a long approach holds its whole wafer.
    let far = Station {
        approach_mm: 400.0,
        ..lp1.clone()
    };
    assert_eq!(far.volume(150.0).mouth_mm, 155.0);
    // Every station's approach pose, lowered and lifted, with a wafer: clear of every box
    // by the margin that the entry keeps.
    let model = stations.model(&robot).unwrap();
    for s in &stations {
        for slot in [1, s.slots] {
            for lifted in [false, true] {
                let q = s
                    .approach_joints(&robot, slot, lifted, &robot.home())
                    .unwrap();
                let bodies = robot.bodies(&q, &LOADED);
                let mut clear = [0.0; MAX_SOLIDS];
                model.clearances(&bodies, &LOADED, &LineTolerance::WORLD, &mut clear);
                let i = stations.index_of(s.name.as_str()).unwrap();
                // Its own station: on its line, passing the opening.
                assert_eq!(clear[i], f64::INFINITY, "{} {slot}", s.name);
                for (j, d) in clear[..model.len()].iter().enumerate() {
                    assert!(*d >= 5.0, "{} {slot}: {:?} at {d}", s.name, model.name(j));
                }
            }
        }
    }
}

#[test]
fn a_hand_on_the_line_passes_the_opening_and_off_it_touches() {
    let (robot, stations, model) = demo();
    let lp1 = stations.get("LP1").unwrap();
    for slot in [1, 10, 25] {
        let seat = lp1.seated_pose(slot, true).unwrap();
        let q = at(&robot, seat);
        assert_eq!(contact(&model, &robot, &q, &LOADED), None, "slot {slot}");
        // 3 mm to the side.
        let (s, c) = lp1.pose.yaw.to_radians().sin_cos();
        let aside = Pose {
            x: seat.x - 3.0 * s,
            y: seat.y + 3.0 * c,
            ..seat
        };
        let hit = contact(&model, &robot, &at(&robot, aside), &HAND).unwrap();
        assert_eq!(hit.name.as_str(), "LP1");
        assert_eq!(hit.kind, SolidKind::Station);
        // Turned 3 degrees.
        let turned = Pose {
            yaw: seat.yaw + 3.0,
            ..seat
        };
        assert!(contact(&model, &robot, &at(&robot, turned), &HAND).is_some());
        // On the line but between slots above the top one's lift: not a transfer height.
        let above = Pose { z: 275.0, ..seat };
        assert!(contact(&model, &robot, &at(&robot, above), &HAND).is_some());
    }
    // Within the controller's tolerance, but the controller's margin: inside its own
    // station the hand is on the line, so nothing it may not enter is near.
    let seat = lp1.seated_pose(5, false).unwrap();
    let bodies = robot.bodies(&at(&robot, seat), &LOADED);
    assert_eq!(
        model.contact(&bodies, &LOADED, &LineTolerance::CONTROLLER, 2.0),
        None
    );
}

#[test]
fn heights_count_the_arm_passes_under_a_station() {
    let (robot, _, model) = demo();
    // The example: MOVP 250 -150 100 0 ends in front of LP1's seat, off its line.
    let q = at(
        &robot,
        Pose {
            x: 250.0,
            y: -150.0,
            z: 100.0,
            yaw: 0.0,
        },
    );
    let hit = contact(&model, &robot, &q, &HAND).unwrap();
    assert_eq!(hit.name.as_str(), "LP1", "{hit}");
    assert!(hit.to_string().contains("would touch station LP1"), "{hit}");
    // The same at the bottom of the Z axis passes under LP1 (its box begins 10 mm up).
    let mut low = q;
    low[3] = 0.0;
    assert_eq!(contact(&model, &robot, &low, &LOADED), None);
    // A wafer 9 mm up is still under it; 10 mm up touches it.
    low[3] = 9.0;
    assert_eq!(contact(&model, &robot, &low, &LOADED), None);
    low[3] = 10.0;
    assert!(contact(&model, &robot, &low, &LOADED).is_some());
}

/// Run `g` to its target; the joints after each period.
fn periods(g: &mut VelocityGenerator) -> Vec<Joints> {
    let mut out = vec![g.joints()];
    let mut p = Period::default();
    while g.is_moving() {
        g.next_period(&mut p);
        out.push(g.joints());
    }
    out
}

/// The joints of every period of the demo cell's transfer `kind` at `station` `slot`, from
/// `from`, as the controller's steps (PTP, lines, Z) run one after the other.
fn transfer(
    robot: &Robot,
    stations: &Stations,
    kind: TransferKind,
    name: &str,
    slot: u16,
    from: Joints,
) -> Vec<Joints> {
    let s = stations.get(name).unwrap();
    let mut g = VelocityGenerator::new(robot.clone(), MotionSettings::default()).unwrap();
    g.set_position_pulses(&robot.joints_to_pulses(&from))
        .unwrap();
    let approach = s
        .approach_joints(robot, slot, kind == TransferKind::Put, &from)
        .unwrap();
    let mut out = Vec::new();
    let blades: &[BladeLoad] = if kind == TransferKind::Put {
        &LOADED
    } else {
        &HAND
    };
    for step in plan(kind, s, slot).unwrap() {
        match step {
            Step::Ptp(..) => {
                out.extend(routed_ptp(robot, stations, blades, &mut g, &approach));
                continue;
            }
            Step::Line(p) | Step::Z(p) => {
                g.plan_line(&p).unwrap();
            }
            _ => continue,
        }
        out.extend(periods(&mut g));
    }
    out
}

/// The periods of a PTP from where `g` stands to `to`, as the controller moves it: straight
/// if that keeps clear of the cell, else by the first travel route whose every leg does.
fn routed_ptp(
    robot: &Robot,
    stations: &Stations,
    blades: &[BladeLoad],
    g: &mut VelocityGenerator,
    to: &Joints,
) -> Vec<Joints> {
    let model = stations.model(robot).unwrap();
    let start = g.state();
    let from = g.joints();
    g.plan_ptp(to).unwrap();
    let direct = periods(g);
    if sweep_all(&model, robot, blades, &direct).is_ok() {
        return direct;
    }
    let z = model.travel_z(robot, blades).unwrap();
    for route in travel_routes(robot, &from, to, z).into_iter().flatten() {
        g.restore(&start);
        let mut out = Vec::new();
        for q in route.via().iter().chain([to]) {
            g.plan_ptp(q).unwrap();
            out.extend(periods(g));
        }
        if sweep_all(&model, robot, blades, &out).is_ok() {
            return out;
        }
    }
    panic!("no route from {from:?} to {to:?}");
}

#[allow(clippy::result_large_err)]
fn sweep_all(
    model: &CellModel,
    robot: &Robot,
    blades: &[BladeLoad],
    qs: &[Joints],
) -> Result<u64, SweepContact> {
    let mut sweep = Sweep::new(model, robot, blades, LineTolerance::CONTROLLER, 2.0);
    for q in qs {
        sweep.to(q)?;
    }
    Ok(sweep.evaluations())
}

/// Every transfer of the demo cell (the first and last slot of every station, a GET with an
/// empty hand and a PUT with a wafer, from home and from every station's approach pose)
/// passes the controller's check, straight or by a travel route (BF1, entered with the
/// left elbow, from anywhere the right elbow stands: the elbow's turn swings the stretched
/// arm through the stations at their heights): the cell's model and its transfers agree.
#[test]
fn every_demo_transfer_keeps_clear_of_the_cell() {
    let (robot, stations, model) = demo();
    let mut froms = vec![robot.home()];
    for s in &stations {
        froms.push(
            s.approach_joints(&robot, s.slots, true, &robot.home())
                .unwrap(),
        );
    }
    for s in &stations {
        for slot in [1, s.slots] {
            for (kind, blades) in [(TransferKind::Get, &HAND), (TransferKind::Put, &LOADED)] {
                for from in &froms {
                    let qs = transfer(&robot, &stations, kind, s.name.as_str(), slot, *from);
                    if let Err(c) = sweep_all(&model, &robot, blades, &qs) {
                        panic!(
                            "{kind} {} {slot} from {from:?}: {} at {:?} ({:?})",
                            s.name,
                            c.contact,
                            robot.forward(&c.joints),
                            c.joints
                        );
                    }
                }
            }
        }
    }
}

/// A joint move whose two ends are clear but that swings the stretched arm through a
/// column is caught between its ends, at the same place a fine sampling first touches.
#[test]
fn a_sweep_finds_what_lies_between_two_clear_ends() {
    let robot = Robot::paper_default();
    let column = Obstacle {
        name: StationName::new("column").unwrap(),
        shape: ObstacleShape::Cylinder {
            x_mm: 330.0,
            y_mm: 60.0,
            radius_mm: 20.0,
        },
        bottom_mm: -500.0,
        top_mm: 800.0,
    };
    let model = CellModel::new(&robot, &[], &[column], CellSettings::default()).unwrap();
    // The arm stretched along -y, then along +y: it sweeps through +x.
    let mut a = robot.home();
    a[..4].copy_from_slice(&[-90.0, 5.0, 0.0, 0.0]);
    let mut b = a;
    b[0] = 90.0;
    let clear = |q: &Joints| {
        model.contact(
            &robot.bodies(q, &HAND),
            &HAND,
            &LineTolerance::CONTROLLER,
            2.0,
        )
    };
    assert_eq!(clear(&a), None);
    assert_eq!(clear(&b), None);
    let mut sweep = Sweep::new(&model, &robot, &HAND, LineTolerance::CONTROLLER, 2.0);
    sweep.to(&a).unwrap();
    let found = sweep.to(&b).unwrap_err();
    // The same path in 4,000 steps: the first step that touches.
    let mut first = None;
    for i in 0..=4000 {
        let t = f64::from(i) / 4000.0;
        let mut q = a;
        for (k, v) in q.iter_mut().enumerate() {
            *v = a[k] + t * (b[k] - a[k]);
        }
        if let Some(c) = clear(&q) {
            first = Some((t, c));
            break;
        }
    }
    let (t, c) = first.expect("the fine sampling touches too");
    assert_eq!((found.contact.name, found.contact.body), (c.name, c.body));
    let t_found = (found.joints[0] - a[0]) / (b[0] - a[0]);
    // Within the sweep's resolution (0.5 mm of travel of the farthest point).
    assert!((t_found - t).abs() < 0.002, "{t_found} vs {t}");
    assert!(sweep.evaluations() < 100, "{}", sweep.evaluations());
    // Where nothing is near, the two ends are enough.
    let mut quick = Sweep::new(&model, &robot, &HAND, LineTolerance::CONTROLLER, 2.0);
    let mut c = a;
    c[0] = -100.0;
    quick.to(&a).unwrap();
    quick.to(&c).unwrap();
    assert_eq!(quick.evaluations(), 2);
}

#[test]
fn fixed_obstacles_are_never_entered() {
    let robot = Robot::paper_default();
    let column = Obstacle {
        name: StationName::new("column").unwrap(),
        shape: ObstacleShape::Cylinder {
            x_mm: 250.0,
            y_mm: -60.0,
            radius_mm: 30.0,
        },
        bottom_mm: -500.0,
        top_mm: 800.0,
    };
    let wall = Obstacle {
        name: StationName::new("wall").unwrap(),
        shape: ObstacleShape::Box {
            x_mm: 0.0,
            y_mm: -480.0,
            yaw_deg: 0.0,
            depth_mm: 1000.0,
            width_mm: 20.0,
        },
        bottom_mm: -500.0,
        top_mm: 800.0,
    };
    let model = CellModel::new(&robot, &[], &[column, wall], CellSettings::default()).unwrap();
    let q = robot
        .inverse(
            &Pose {
                x: 250.0,
                y: 100.0,
                z: 0.0,
                yaw: 0.0,
            },
            Posture::Left,
            None,
        )
        .unwrap();
    assert_eq!(contact(&model, &robot, &q, &HAND), None);
    // The wafer reaches the column 150 mm around.
    let hit = contact(&model, &robot, &q, &LOADED).unwrap();
    assert_eq!(
        (hit.name.as_str(), hit.body),
        ("column", BodyKind::Wafer(0))
    );
    let q = at(
        &robot,
        Pose {
            x: 0.0,
            y: -360.0,
            z: 0.0,
            yaw: -90.0,
        },
    );
    assert_eq!(
        contact(&model, &robot, &q, &HAND).map(|c| c.name.to_string()),
        Some("wall".into())
    );
    // Nothing to pass under: the arm travels at the bottom of its Z axis.
    assert_eq!(model.travel_z(&robot, &HAND), Some(0.0));
}

#[test]
fn the_travel_height_is_below_every_station() {
    let (robot, stations, model) = demo();
    // LP1 and LP2 begin 10 mm up: the wafer's top 2 mm below that.
    let z = model.travel_z(&robot, &LOADED).unwrap();
    assert!((z - (10.0 - 2.0 - 0.775)).abs() < 1e-9, "{z}");
    let declared = stations.with_cell(CellSettings {
        travel_z_mm: Some(3.0),
        ..CellSettings::default()
    });
    assert_eq!(
        declared.model(&robot).unwrap().travel_z(&robot, &LOADED),
        Some(3.0)
    );
}

#[test]
fn the_stations_file_reads_and_writes_the_cell() {
    let text = format!(
        "{}\n[cell]\ntravel_z_mm = 4.0\nclearance_mm = 3.0\n\n[[obstacle]]\nname = \"column\"\nkind = \"cylinder\"\nx_mm = -300.0\ny_mm = 0.0\nradius_mm = 40.0\nbottom_mm = -400.0\ntop_mm = 600.0\n",
        crate::DEMO_TOML.replace(
            "[station.sim]\nwafers = \"0\"\n\n[[station]]\nname = \"PM1\"",
            "[station.sim]\nwafers = \"0\"\n\n[station.volume]\ntop_mm = 200.0\n\n[[station]]\nname = \"PM1\""
        )
    );
    let stations = Stations::parse(&text, "cell.toml").unwrap();
    assert_eq!(
        *stations.cell(),
        CellSettings {
            travel_z_mm: Some(4.0),
            clearance_mm: 3.0
        }
    );
    assert_eq!(stations.obstacles().len(), 1);
    assert_eq!(stations.get("AL").unwrap().volume(150.0).top_mm, 200.0);
    let back = Stations::parse(&stations.to_toml(), "back.toml").unwrap();
    assert_eq!(back, stations);
    assert_eq!(
        obstacle_line(&stations.obstacles()[0]),
        "column kind=cylinder x=-300 y=0 radius=40 bottom=-400 top=600"
    );
    let bad = |snippet: &str| {
        let text = format!("{}\n{snippet}", crate::DEMO_TOML);
        Stations::parse(&text, "bad.toml").unwrap_err().to_string()
    };
    let e = bad("[[obstacle]]\nname = \"c\"\nkind = \"cone\"\nx_mm = 0.0\ny_mm = 0.0\nbottom_mm = 0.0\ntop_mm = 1.0\n");
    assert!(
        e.contains("\"cone\" is not an obstacle kind") && e.contains("bad.toml"),
        "{e}"
    );
    let e = bad("[[obstacle]]\nname = \"c\"\nkind = \"cylinder\"\nx_mm = 0.0\ny_mm = 0.0\nbottom_mm = 0.0\ntop_mm = 1.0\n");
    assert!(
        e.contains("radius_mm is needed by an obstacle of kind cylinder"),
        "{e}"
    );
    let e = bad("[[obstacle]]\nname = \"LP1\"\nkind = \"cylinder\"\nx_mm = 0.0\ny_mm = 0.0\nradius_mm = 5.0\nbottom_mm = 0.0\ntop_mm = 1.0\n");
    assert!(e.contains("is used by a station"), "{e}");
    let e = bad("[[obstacle]]\nname = \"c\"\nkind = \"box\"\nx_mm = 0.0\ny_mm = 0.0\ndepth_mm = 5.0\nwidth_mm = 5.0\nbottom_mm = 2.0\ntop_mm = 1.0\n");
    assert!(e.contains("top_mm must be above bottom_mm"), "{e}");
    let e = bad("[cell]\nclearance_mm = -1.0\n");
    assert!(e.contains("cell.clearance_mm must be 0 to 100 mm"), "{e}");
}
