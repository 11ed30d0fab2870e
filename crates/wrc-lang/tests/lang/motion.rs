//! Motion options per statement: SPEED, ACCEL, BLEND; APPRO/APPROS and DEPART/DEPARTS
//! along the hand; ARC; relative moves in the tool frame and user frames; their
//! compile-time checks.

use wrc_lang::{compile, Blend, Motion, MoveOptions, Request};
use wrc_robot::Pose;

use crate::common::{program, robot, run_with, Io};

fn pose(x: f64, y: f64, z: f64, yaw: f64) -> Pose {
    Pose { x, y, z, yaw }
}

fn close(a: &Pose, b: &Pose) -> bool {
    (a.x - b.x).abs() < 1e-9
        && (a.y - b.y).abs() < 1e-9
        && (a.z - b.z).abs() < 1e-9
        && (a.yaw - b.yaw).abs() < 1e-9
}

/// The motions a program asks for, with their options; HERE() is `here`.
fn motions(source: &str, here: Pose) -> Vec<(Motion, MoveOptions)> {
    let io = Io { inputs: 0, here };
    let r = run_with(&program(source), io, Default::default());
    assert_eq!(r.fault, None, "{}", r.error_text);
    r.requests
        .iter()
        .filter_map(|q| match q {
            Request::Move(m, o) => Some((*m, *o)),
            _ => None,
        })
        .collect()
}

#[test]
fn speed_accel_and_blend_ride_on_each_motion() {
    let m = motions(
        "\
MOVEJ JOINTS(0, 90, 0, 10) SPEED 50 BLEND
MOVEP POSE(300, 0, 0, 0), L ACCEL 20 SPEED 30
MOVEL POSE(300, 50, 0, 0) BLEND 5
MOVEL POSE(250, 50, 0, 0) SPEED 20
HOME ACCEL 50
JOG J1, 100 SPEED 10
",
        Pose::default(),
    );
    let opts: Vec<_> = m.iter().map(|(_, o)| *o).collect();
    assert_eq!(
        opts,
        [
            MoveOptions {
                speed_pct: Some(50.0),
                accel_pct: None,
                blend: Blend::Pass
            },
            MoveOptions {
                speed_pct: Some(30.0),
                accel_pct: Some(20.0),
                blend: Blend::Stop
            },
            MoveOptions {
                speed_pct: None,
                accel_pct: None,
                blend: Blend::Zone(5.0)
            },
            MoveOptions {
                speed_pct: Some(20.0),
                ..MoveOptions::default()
            },
            MoveOptions {
                accel_pct: Some(50.0),
                ..MoveOptions::default()
            },
            MoveOptions {
                speed_pct: Some(10.0),
                ..MoveOptions::default()
            },
        ]
    );
    assert!(matches!(
        m[1].0,
        Motion::Pose(_, Some(wrc_robot::Posture::Left))
    ));
}

#[test]
fn appro_and_depart_move_back_along_the_hand() {
    // The hand at yaw 90° points along +y: back along it is -y.
    let here = pose(200.0, 100.0, 10.0, 90.0);
    let m = motions(
        "\
P = POSE(300, 0, 5, 0)
APPRO P, 50
APPROS P, 20 SPEED 10
DEPART 30
DEPARTS -15
MOVEL RELTOOL(P, 10, 5, -2)
MOVEP INFRAME(POSE(100, 100, 0, 90), POSE(10, 0, 0, 0))
",
        here,
    );
    let targets: Vec<(&str, Pose)> = m
        .iter()
        .map(|(mo, _)| match mo {
            Motion::Pose(p, _) => ("ptp", *p),
            Motion::Line(p) => ("line", *p),
            other => panic!("{other:?}"),
        })
        .collect();
    let want = [
        ("ptp", pose(250.0, 0.0, 5.0, 0.0)),
        ("line", pose(280.0, 0.0, 5.0, 0.0)),
        ("ptp", pose(200.0, 70.0, 10.0, 90.0)),
        ("line", pose(200.0, 115.0, 10.0, 90.0)),
        ("line", pose(310.0, 5.0, 3.0, 0.0)),
        ("ptp", pose(100.0, 110.0, 0.0, 90.0)),
    ];
    for ((kind, got), (wkind, w)) in targets.iter().zip(want) {
        assert_eq!(*kind, wkind);
        assert!(close(got, &w), "{got:?} vs {w:?}");
    }
}

#[test]
fn arc_passes_its_via_pose_and_tool_and_user_frames_invert() {
    let m = motions(
        "ARC POSE(300, 50, 0, 0), POSE(250, 100, 0, 0) BLEND 2\nF = POSE(100, 50, 10, 30)\nQ = TOFRAME(F, INFRAME(F, POSE(5, 6, 7, 8)))\nPRINT DIST(Q, POSE(5, 6, 7, 8)) < 0.000001\n",
        Pose::default(),
    );
    assert_eq!(
        m[0],
        (
            Motion::Arc {
                via: pose(300.0, 50.0, 0.0, 0.0),
                to: pose(250.0, 100.0, 0.0, 0.0)
            },
            MoveOptions {
                blend: Blend::Zone(2.0),
                ..MoveOptions::default()
            }
        )
    );
    let printed = crate::common::printed(
        "F = POSE(100, 50, 10, 30)\nQ = TOFRAME(F, INFRAME(F, POSE(5, 6, 7, 8)))\nPRINT DIST(Q, POSE(5, 6, 7, 8)) < 0.000001\n",
    );
    assert_eq!(printed, ["TRUE"]);
}

#[test]
fn here_prints_without_rounding_noise() {
    // Forward kinematics leave 1e-14 mm of noise; HERE() rounds to the nanometre.
    let here = pose(300.000_000_000_000_06, 1.421_085_471_520_2e-14, 0.0, -2e-15);
    let io = Io { inputs: 0, here };
    let r = run_with(&program("PRINT HERE()\n"), io, Default::default());
    assert_eq!(r.printed, ["POSE(300, 0, 0, 0)"]);
}

#[test]
fn motion_option_mistakes_are_compile_errors() {
    let src = "\
MOVEL POSE(300, 0, 0, 0) SPEED 150
MOVEL POSE(300, 0, 0, 0) BLEND
MOVEP POSE(300, 0, 0, 0) BLEND 5
MOVEJ JOINTS(0, 90, 0, 0) SPEED 10 SPEED 20
HOME BLEND
MOVEL POSE(300, 0, 0, 0) BLEND -1
APPRO POSE(395, 0, 0, 0), -20
MOVEL POSE(300, 0, 0, 0) ACCEL 0
MOVEL POSE(300, 0, 0, 0) FAST
";
    let c = compile(src, "t.wrl", &robot());
    let msgs: Vec<String> = c
        .diagnostics
        .iter()
        .map(|d| format!("{}:{} {}", d.line, d.col, d.message))
        .collect();
    assert_eq!(
        msgs,
        [
            "1:32 SPEED 150 is out of range; SPEED takes 1 to 100 [%]",
            "2:26 BLEND needs the corner zone [mm] on MOVEL: BLEND 5 rounds the corner within 5 mm",
            "3:32 BLEND on MOVEP takes no distance: a PTP motion passes its target moving",
            "4:36 SPEED is given twice",
            "5:6 expected the end of the line or an option (SPEED pct or ACCEL pct), found 'BLEND'; the syntax is HOME [SPEED pct] [ACCEL pct]",
            "6:32 a BLEND zone is 0 or more mm (at most 1000), got -1",
            "7:7 unreachable approach: -20 mm back along the hand from the pose is x=415.000 y=0.000: target x=415.000 y=0.000 mm is out of reach: its wrist point is 415.000 mm from the shoulder, the arm reaches at most 400.000 mm (minus a 2.000 mm singularity margin)",
            "8:32 ACCEL 0 is out of range; ACCEL takes 1 to 100 [%]",
            "9:26 expected the end of the line or an option (SPEED pct, ACCEL pct or BLEND mm), found 'FAST'; the syntax is MOVEL pose [SPEED pct] [ACCEL pct] [BLEND mm]",
        ]
    );
}
