//! Straight lines (the paper's Table 2): the TCP stays within 0.01 mm of the segment, the
//! pulses end exactly on the target's, joints stay within their limits, and segments that
//! leave the workspace or cross a singularity are refused before any pulse.

use proptest::prelude::*;
use wrc_motion::{MotionSettings, PathProblem, PlanError, Profile, VelocityGenerator};
use wrc_robot::{Pose, Posture, Robot};

use crate::common::*;

/// Distance of point p from the segment a–b in the xy plane and in z [mm].
fn distance_to_segment(p: &Pose, a: &Pose, b: &Pose) -> f64 {
    let (dx, dy, dz) = (b.x - a.x, b.y - a.y, b.z - a.z);
    let len2 = dx * dx + dy * dy + dz * dz;
    let t = if len2 == 0.0 {
        0.0
    } else {
        (((p.x - a.x) * dx + (p.y - a.y) * dy + (p.z - a.z) * dz) / len2).clamp(0.0, 1.0)
    };
    let (cx, cy, cz) = (a.x + t * dx - p.x, a.y + t * dy - p.y, a.z + t * dz - p.z);
    (cx * cx + cy * cy + cz * cz).sqrt()
}

fn polar(r: f64, phi: f64, z: f64, yaw: f64) -> Pose {
    Pose {
        x: r * phi.to_radians().cos(),
        y: r * phi.to_radians().sin(),
        z,
        yaw,
    }
}

fn start_at(vg: &mut VelocityGenerator, pose: &Pose, posture: Posture) -> bool {
    match vg.robot().inverse(pose, posture, None) {
        Ok(j) => {
            let p = vg.robot().joints_to_pulses(&j);
            vg.set_position_pulses(&p).unwrap();
            true
        }
        Err(_) => false,
    }
}

/// Check a finished line: on the segment at every period, on the target at the end.
fn check_line(vg: &VelocityGenerator, run: &Run, a: &Pose, target: &Pose, tol_mm: f64) {
    let robot = vg.robot();
    let mut pulses = robot.joints_to_pulses(&run.start);
    for (k, p) in run.periods.iter().enumerate() {
        for (q, d) in pulses.iter_mut().zip(p.pulses.iter()) {
            *q += d;
        }
        let tcp = robot.forward(&robot.pulses_to_joints(&pulses));
        let dev = distance_to_segment(&tcp, a, target);
        assert!(
            dev <= tol_mm,
            "period {k}: TCP {tcp:?} is {dev} mm off the line"
        );
    }
    assert_eq!(&pulses, vg.position_pulses());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn lines_stay_on_the_segment(
        r0 in 20.0f64..390.0, phi0 in -180.0f64..180.0, z0 in 0.0f64..300.0, yaw0 in -180.0f64..180.0,
        r1 in 20.0f64..390.0, phi1 in -180.0f64..180.0, z1 in 0.0f64..300.0, yaw1 in -180.0f64..180.0,
        left in any::<bool>(), paper in any::<bool>(), fast in any::<bool>(), pct in 5.0f64..100.0,
    ) {
        let profile = if paper { Profile::Paper { mask_len: 10 } } else { Profile::Fir };
        let ts = if fast { 0.001 } else { 0.01 };
        let mut vg = generator(profile, ts, pct);
        let posture = if left { Posture::Left } else { Posture::Right };
        let start = polar(r0, phi0, z0, yaw0);
        prop_assume!(start_at(&mut vg, &start, posture));
        let target = polar(r1, phi1, z1, yaw1);
        let a = vg.pose();
        let before = *vg.position_pulses();
        match vg.plan_line(&target) {
            Ok(info) => {
                // Paths within a few mm of the folded arm crawl (the path limits are constant
                // along a segment); keep the test's run time bounded.
                prop_assume!(info.periods < 200_000);
                let run = run(&mut vg);
                // 0.01 mm: pulse quantisation (1000 pulse/deg) gives at most ~0.005 mm here.
                check_line(&vg, &run, &a, &target, 0.01);
                let end = vg.pose();
                prop_assert!((end.x - target.x).abs() < 0.01 && (end.y - target.y).abs() < 0.01);
                prop_assert!((end.z - target.z).abs() < 0.001);
                // Joints within their limits (exact positions; sampled path derivatives carry
                // a 5 % margin, so no tolerance beyond floating point is needed).
                assert_within_limits(&vg, &run, 1e-6, if paper { 1.0 } else { 0.0 });
                let sums = pulse_sums(&run);
                for ax in 0..4 {
                    prop_assert_eq!(before[ax] + sums[ax], vg.position_pulses()[ax]);
                }
            }
            Err(PlanError::PathLeavesWorkspace { reason, fraction_pct, .. }) => {
                // The refusal must be real: sample the segment and find the problem.
                let robot = vg.robot();
                let arm = robot.arm();
                let path = wrc_motion::LinePath::new(robot, a, target, posture);
                let u = fraction_pct / 100.0;
                let r = robot.wrist_radius(&path.pose_at(u));
                match reason {
                    PathProblem::Stretched => prop_assert!(r >= arm.link1_mm + arm.link2_mm - arm.singularity_margin_mm - 0.5, "r {}", r),
                    PathProblem::Folded => prop_assert!(r <= arm.singularity_margin_mm + 0.5, "r {}", r),
                    _ => {}
                }
                prop_assert_eq!(*vg.position_pulses(), before);
                prop_assert!(!vg.is_moving());
            }
            Err(PlanError::Kinematics(_)) | Err(PlanError::PostureChange) => {
                prop_assert_eq!(*vg.position_pulses(), before);
                prop_assert!(!vg.is_moving());
            }
            Err(other) => prop_assert!(false, "unexpected {}", other),
        }
    }
}

#[test]
fn a_line_through_the_shoulder_is_refused() {
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    assert!(start_at(
        &mut vg,
        &Pose {
            x: 200.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0
        },
        Posture::Right
    ));
    let err = vg
        .plan_line(&Pose {
            x: -200.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        })
        .unwrap_err();
    // Folding the arm that far needs J2 beyond its 165° limit before the wrist reaches the
    // shoulder's singular point; either refusal names where along the line it happens.
    assert!(
        matches!(
            err,
            PlanError::PathLeavesWorkspace {
                reason: PathProblem::JointLimit | PathProblem::Folded,
                ..
            }
        ),
        "{err}"
    );
    let msg = err.to_string();
    assert!(
        msg.contains("% of its length") && msg.contains("x=52.000"),
        "{msg}"
    );
    assert!(!vg.is_moving());

    // Without the elbow limit, the folded singularity itself refuses the line.
    let mut axes = Robot::paper_default().axes().to_vec();
    axes[1].min = -180.0;
    axes[1].max = 180.0;
    let robot = Robot::new("no-elbow-limit", axes, 200.0, 200.0, 0.0, 2.0).unwrap();
    let mut vg = VelocityGenerator::new(robot, MotionSettings::default()).unwrap();
    assert!(start_at(
        &mut vg,
        &Pose {
            x: 200.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0
        },
        Posture::Right
    ));
    let err = vg
        .plan_line(&Pose {
            x: -200.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        })
        .unwrap_err();
    assert!(
        matches!(
            err,
            PlanError::PathLeavesWorkspace {
                reason: PathProblem::Folded,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn a_hand_offset_can_swing_the_wrist_past_the_stretched_arm() {
    // With a 150 mm hand, turning the hand while moving swings the wrist point outward.
    let paper = Robot::paper_default();
    let robot = Robot::new("hand", paper.axes().to_vec(), 200.0, 200.0, 150.0, 2.0).unwrap();
    let mut vg = VelocityGenerator::new(robot, MotionSettings::default()).unwrap();
    assert!(start_at(
        &mut vg,
        &Pose {
            x: 540.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0
        },
        Posture::Right
    ));
    let err = vg
        .plan_line(&Pose {
            x: 540.0,
            y: 10.0,
            z: 0.0,
            yaw: -90.0,
        })
        .unwrap_err();
    assert!(
        matches!(
            err,
            PlanError::PathLeavesWorkspace {
                reason: PathProblem::Stretched,
                ..
            }
        ) || matches!(err, PlanError::Kinematics(_)),
        "{err}"
    );
}

#[test]
fn joint_speeds_stay_limited_near_the_stretched_arm() {
    // A line passing 4 mm inside the stretched limit: joint velocities grow like 1/sin θ2,
    // so the path speed must drop; limits hold anyway.
    let mut vg = generator(Profile::Fir, 0.001, 100.0);
    assert!(start_at(
        &mut vg,
        &Pose {
            x: 394.0,
            y: -25.0,
            z: 0.0,
            yaw: 0.0
        },
        Posture::Right
    ));
    let a = vg.pose();
    let target = Pose {
        x: 394.0,
        y: 25.0,
        z: 0.0,
        yaw: 0.0,
    };
    vg.plan_line(&target).unwrap();
    let run = run(&mut vg);
    check_line(&vg, &run, &a, &target, 0.01);
    assert_within_limits(&vg, &run, 1e-6, 0.0);
}

#[test]
fn pure_rotation_of_the_hand() {
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    assert!(start_at(
        &mut vg,
        &Pose {
            x: 250.0,
            y: 0.0,
            z: 10.0,
            yaw: 0.0
        },
        Posture::Right
    ));
    let target = Pose {
        x: 250.0,
        y: 0.0,
        z: 10.0,
        yaw: 120.0,
    };
    vg.plan_line(&target).unwrap();
    let a = vg.pose();
    let run = run(&mut vg);
    check_line(&vg, &run, &a, &target, 0.01);
    assert!((vg.pose().yaw - 120.0).abs() < 0.002);
}
