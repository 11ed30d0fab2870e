//! Every request a program makes reaches the host with the right values.

use wrc_lang::{Motion, MoveOptions, Request, TransferKind};
use wrc_robot::{InlineName, Pose, Posture, MAX_AXES};

use crate::common::{program, run};

fn pose(x: f64, y: f64, z: f64, yaw: f64) -> Pose {
    Pose { x, y, z, yaw }
}

fn joints(values: &[f64]) -> [f64; MAX_AXES] {
    let mut j = [0.0; MAX_AXES];
    j[..values.len()].copy_from_slice(values);
    j
}

#[test]
fn every_request_kind_carries_its_values() {
    let src = "\
HOME
MOVEJ JOINTS(30, 60, -90, 100)
P = POSE(300, -100, 0, 0)
MOVEP P
MOVEP P + POSE(0, 0, 10, 0), L
movep p, right
MOVEL POSE(300, 150, 0, 0)
JOG J2, -2500
JOG 4, 1000
jog z, 7
SPEED 35.5
DELAY 0.25
OUT 3, 1
OUT 4, FALSE
WAIT IN(0) = 1
WAIT IN(5) = 0 TIMEOUT 2.5
PRINT \"x\", P.X
MAP \"LP1\"
GET \"LP1\", 3
PUT \"PM_2\", 1
";
    let r = run(&program(src));
    assert_eq!(r.fault, None);
    assert_eq!(
        r.requests,
        [
            Request::Move(Motion::Home, MoveOptions::default()),
            Request::Move(
                Motion::Joints(joints(&[30.0, 60.0, -90.0, 100.0])),
                MoveOptions::default()
            ),
            Request::Move(
                Motion::Pose(pose(300.0, -100.0, 0.0, 0.0), None),
                MoveOptions::default()
            ),
            Request::Move(
                Motion::Pose(pose(300.0, -100.0, 10.0, 0.0), Some(Posture::Left)),
                MoveOptions::default()
            ),
            Request::Move(
                Motion::Pose(pose(300.0, -100.0, 0.0, 0.0), Some(Posture::Right)),
                MoveOptions::default()
            ),
            Request::Move(
                Motion::Line(pose(300.0, 150.0, 0.0, 0.0)),
                MoveOptions::default()
            ),
            Request::Move(
                Motion::Jog {
                    axis: 1,
                    pulses: -2500
                },
                MoveOptions::default()
            ),
            Request::Move(
                Motion::Jog {
                    axis: 3,
                    pulses: 1000
                },
                MoveOptions::default()
            ),
            Request::Move(Motion::Jog { axis: 3, pulses: 7 }, MoveOptions::default()),
            Request::Speed { pct: 35.5 },
            Request::Delay { seconds: 0.25 },
            Request::Out { n: 3, on: true },
            Request::Out { n: 4, on: false },
            Request::WaitInput {
                n: 0,
                value: true,
                timeout_s: None
            },
            Request::WaitInput {
                n: 5,
                value: false,
                timeout_s: Some(2.5)
            },
            Request::Print,
            Request::Map {
                station: InlineName::new("LP1").unwrap()
            },
            Request::Transfer {
                kind: TransferKind::Get,
                station: InlineName::new("LP1").unwrap(),
                slot: 3,
                blade_b: false
            },
            Request::Transfer {
                kind: TransferKind::Put,
                station: InlineName::new("PM_2").unwrap(),
                slot: 1,
                blade_b: false
            },
        ]
    );
    assert_eq!(r.printed, ["x 300"]);
}

#[test]
fn computed_arguments_are_evaluated_at_run_time() {
    let src =
        "FOR i = 1 TO 3\n  MOVEJ JOINTS(10 * i, 0, 0, i)\n  OUT i, i = 2\n  DELAY i / 10\nNEXT\n";
    let r = run(&program(src));
    assert_eq!(r.fault, None);
    let moves: Vec<_> = r
        .requests
        .iter()
        .filter_map(|q| match q {
            Request::Move(Motion::Joints(j), _) => Some((j[0], j[3])),
            _ => None,
        })
        .collect();
    assert_eq!(moves, [(10.0, 1.0), (20.0, 2.0), (30.0, 3.0)]);
    let outs: Vec<_> = r
        .requests
        .iter()
        .filter_map(|q| match q {
            Request::Out { n, on } => Some((*n, *on)),
            _ => None,
        })
        .collect();
    assert_eq!(outs, [(1, false), (2, true), (3, false)]);
    assert!(r.requests.contains(&Request::Delay { seconds: 0.3 }));
}
