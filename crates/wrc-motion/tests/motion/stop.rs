//! Controlled stop from any state, STOP (the move's override-scaled limits) and ESTOP
//! (every axis's full limits): from the emitted periods, no axis exceeds the limits it
//! brakes with, a joint move takes the time-optimal jerk-limited brake from the exact state
//! (Ruckig's, computed here), a phase-synchronised move stays on its joint-space line and a
//! straight line on its line, and no pulse of bookkeeping is lost.

use proptest::prelude::*;
use wrc_motion::bench::distance_to_segment;
use wrc_motion::bench::stop::line_brake_reference;
use wrc_motion::{
    BrakeLimits, DoubleS, Goal, LinePath, MoveEnd, Period, Profile, Sync, VelocityGenerator,
};
use wrc_robot::{Joints, Pose, Posture, Robot, MAX_AXES};

use crate::common::*;
use crate::ruckig::ruckig_brake;

const STOP: BrakeLimits = BrakeLimits::Override;
const ESTOP: BrakeLimits = BrakeLimits::Full;

/// Run the planned move, requesting a stop with `limits` after `k` periods.
fn run_stopped(vg: &mut VelocityGenerator, k: usize, limits: BrakeLimits) -> Run {
    run_with(vg, 1_000_000, |vg, i| {
        if i == k {
            vg.stop(limits)
        }
    })
}

/// The plan of a joint move of `d` units per axis at `pct`, as the generator makes it: its
/// synchronisation and every axis's double-S (an oracle for the exact state at any time; the
/// test checks it against the generator's exact positions).
fn joint_plan(robot: &Robot, d: &[f64], pct: f64) -> (Sync, Vec<DoubleS>) {
    let s = pct / 100.0;
    let moving: Vec<usize> = (0..d.len()).filter(|&i| d[i] != 0.0).collect();
    let lim = |i: usize| {
        let l = &robot.axes()[i].limits;
        (
            l.max_velocity * s,
            l.max_acceleration * s * s,
            l.max_jerk * s * s * s,
        )
    };
    let mut own = vec![DoubleS::REST; d.len()];
    let (mut t_sync, mut vn, mut an, mut jn) = (0.0f64, f64::MAX, f64::MAX, f64::MAX);
    for &i in &moving {
        let (v, a, j) = lim(i);
        let di = d[i].abs();
        own[i] = DoubleS::time_optimal(di, v, a, j);
        t_sync = t_sync.max(own[i].duration());
        (vn, an, jn) = (vn.min(v / di), an.min(a / di), jn.min(j / di));
    }
    if moving.len() == 1 {
        return (Sync::Single, own);
    }
    let common = DoubleS::time_optimal(1.0, vn, an, jn);
    if common.duration() <= t_sync * (1.0 + 1e-9) {
        let mut p = vec![DoubleS::REST; d.len()];
        for &i in &moving {
            p[i] = common;
        }
        (Sync::Phase, p)
    } else {
        (
            Sync::Time,
            own.iter().map(|p| p.stretched_to(t_sync)).collect(),
        )
    }
}

/// What a joint-move stop did, measured from its periods, and the time-optimal reference.
#[derive(Debug)]
struct JointStop {
    /// From the request to the last period of the move [s].
    time_s: f64,
    /// Ruckig's time-optimal brake from the same state [s] (the slowest axis's).
    ref_time_s: f64,
    /// Travel after the request per axis, exact [units].
    distance: [f64; MAX_AXES],
    /// Ruckig's per axis [units].
    ref_distance: [f64; MAX_AXES],
}

/// Plan a PTP move from `from` to `to` at `pct` with period `ts`, stop it with `limits` after
/// `k` periods, and check everything a stop promises; returns the figures.
fn check_joint_stop(
    from: &Joints,
    to: &Joints,
    pct: f64,
    ts: f64,
    k: usize,
    limits: BrakeLimits,
    expect: Sync,
) -> JointStop {
    let mut vg = generator(Profile::Fir, ts, pct);
    let robot = vg.robot().clone();
    let n = robot.axis_count();
    vg.set_position_pulses(&robot.joints_to_pulses(from))
        .unwrap();
    let start = *vg.position_pulses();
    let info = vg.plan_ptp(to).unwrap();
    assert_eq!(info.sync, expect);
    let goal = match vg.goal() {
        Some(Goal::Joints(g)) => g,
        other => panic!("{other:?}"),
    };
    let d_pulses: Vec<i64> = (0..n).map(|i| goal[i] - start[i]).collect();
    let d: Vec<f64> = (0..n)
        .map(|i| d_pulses[i] as f64 / robot.axes()[i].pulses_per_unit)
        .collect();
    let (sync, plan) = joint_plan(&robot, &d, pct);
    assert_eq!(sync, info.sync);
    let run = run_stopped(&mut vg, k, limits);
    let what = format!("{sync:?} at {pct} %, {limits:?} after {k} periods of {ts} s");
    let start_units = robot.pulses_to_joints(&start);
    // The oracle is the generator's plan: its exact positions up to the request.
    for (j, p) in run.periods.iter().take(k).enumerate() {
        for i in 0..n {
            let want = start_units[i] + d[i] * plan[i].fraction((j + 1) as f64 * ts);
            assert!((p.exact[i] - want).abs() < 1e-9, "{what}: oracle off");
        }
    }
    // The reference: Ruckig's time-optimal brake from the exact state, with the limits the
    // stop brakes with.
    let t = k as f64 * ts;
    let s = match limits {
        BrakeLimits::Override => pct / 100.0,
        BrakeLimits::Full => 1.0,
    };
    let axis_lim = |i: usize| {
        let l = &robot.axes()[i].limits;
        (l.max_acceleration * s * s, l.max_jerk * s * s * s)
    };
    let mut ref_distance = [0.0; MAX_AXES];
    let mut ref_time_s = 0.0f64;
    let moving: Vec<usize> = (0..n).filter(|&i| d[i] != 0.0).collect();
    match sync {
        Sync::Phase | Sync::Single => {
            // One brake of the common fraction with the slowest axis's limits.
            let (mut a, mut j) = (f64::MAX, f64::MAX);
            for &i in &moving {
                a = a.min(axis_lim(i).0 / d[i].abs());
                j = j.min(axis_lim(i).1 / d[i].abs());
            }
            let (_, v0, a0) = plan[moving[0]].state(t);
            let (time, dist) = ruckig_brake(v0, a0, a, j);
            ref_time_s = time;
            for &i in &moving {
                ref_distance[i] = d[i] * dist;
            }
        }
        Sync::Time => {
            for &i in &moving {
                let (_, v0, a0) = plan[i].state(t);
                let (a, j) = axis_lim(i);
                let (time, dist) = ruckig_brake(d[i] * v0, d[i] * a0, a, j);
                ref_time_s = ref_time_s.max(time);
                ref_distance[i] = dist;
            }
        }
    }
    let at = if k == 0 {
        run.start
    } else {
        run.periods[k - 1].exact
    };
    let last = run.periods.last().unwrap();
    let mut distance = [0.0; MAX_AXES];
    for i in 0..n {
        distance[i] = last.exact[i] - at[i];
    }
    let time_s = (run.periods.len() - k) as f64 * ts;

    // (a) Limits, from every period's exact position: the velocity never above the move's
    // (the brake starts inside its envelope), acceleration and jerk within the limits braked
    // with (a fortiori before the stop, at the override).
    assert_within_scaled(&vg, &run, (pct / 100.0, s), 1e-6, 0.0);
    // … and from the integer pulses, less what their rounding can add.
    let mut pulse_run = Run {
        periods: run.periods.clone(),
        end: run.end,
        start: start_units,
    };
    let mut position = start;
    for p in pulse_run.periods.iter_mut() {
        for (x, d) in position.iter_mut().zip(&p.pulses).take(n) {
            *x += d;
        }
        p.exact = robot.pulses_to_joints(&position);
    }
    assert_within_scaled(&vg, &pulse_run, (pct / 100.0, s), 1e-6, 1.0);
    // (b) The time-optimal brake: the time to rest is Ruckig's rounded up to whole periods,
    // the distance Ruckig's (1e-6 of a unit plus 1e-6 relative: the closed forms agree to
    // ~1e-12; the state is exact). The 5 % the contract allows is not needed.
    assert!(
        time_s >= ref_time_s - 1e-9 && time_s <= ref_time_s + ts + 1e-9,
        "{what}: {time_s} s vs ruckig {ref_time_s} s"
    );
    assert!(time_s <= 1.05 * ref_time_s + ts + 1e-9);
    for i in 0..n {
        assert!(
            (distance[i] - ref_distance[i]).abs() <= 1e-6 + 1e-6 * ref_distance[i].abs(),
            "{what}: axis {i} travels {} vs ruckig {}",
            distance[i],
            ref_distance[i]
        );
    }
    // (c) On the joint-space line: every axis at the same fraction of its distance, exactly
    // (1e-9 units) and in pulses (half a pulse of rounding).
    if sync != Sync::Time {
        let big = *moving
            .iter()
            .max_by(|&&a, &&b| d[a].abs().total_cmp(&d[b].abs()))
            .unwrap();
        let mut position = start;
        for p in &run.periods {
            let f = (p.exact[big] - start_units[big]) / d[big];
            for &i in &moving {
                position[i] += p.pulses[i];
                assert!((p.exact[i] - start_units[i] - d[i] * f).abs() < 1e-9);
                let off = (position[i] - start[i]) as f64 - d_pulses[i] as f64 * f;
                assert!(off.abs() <= 0.5 + 1e-6, "{what}: {off} pulses off the line");
            }
        }
    }
    // Bookkeeping, and how it ended.
    let sums = pulse_sums(&run);
    for i in 0..n {
        assert_eq!(vg.position_pulses()[i], start[i] + sums[i]);
    }
    let reached = (0..n).all(|i| vg.position_pulses()[i] == goal[i]);
    assert_eq!(
        run.end,
        if reached {
            MoveEnd::Completed
        } else {
            MoveEnd::Stopped
        },
        "{what}"
    );
    if t < plan.iter().map(|p| p.t0).fold(0.0, f64::max) {
        assert_eq!(
            run.end,
            MoveEnd::Stopped,
            "{what}: stopped before decelerating"
        );
    }
    JointStop {
        time_s,
        ref_time_s,
        distance,
        ref_distance,
    }
}

/// Periods after which a stop falls in the middle of each phase of `p` (jerk up, constant
/// acceleration, jerk down, cruise, then the same three of the deceleration), skipping
/// phases of no length.
fn phase_midpoints(p: &DoubleS, ts: f64) -> Vec<(&'static str, usize)> {
    let (t0, t1, t2) = (p.t0, p.t1, p.t2);
    [
        ("jerk up", 0.0, t2),
        ("constant acceleration", t2, t1),
        ("jerk down", t1, t1 + t2),
        ("cruise", t1 + t2, t0),
        ("deceleration jerk", t0, t0 + t2),
        ("constant deceleration", t0 + t2, t0 + t1),
        ("deceleration release", t0 + t1, t0 + t1 + t2),
    ]
    .into_iter()
    .filter(|(_, a, b)| b - a > 2.0 * ts)
    .map(|(name, a, b)| (name, (0.5 * (a + b) / ts).round() as usize))
    .collect()
}

fn joints(robot: &Robot, q: [f64; 4]) -> Joints {
    robot.joints_from_slice(&q).unwrap()
}

/// Stops in every phase of a single-axis, a phase-synchronised and a time-synchronised joint
/// move, at 20, 50 and 100 %, STOP and ESTOP: limits, time-optimality, the line, the end.
#[test]
fn joint_stops_in_every_phase_are_the_time_optimal_brake() {
    let robot = Robot::paper_default();
    let home = [-75.0, 150.0, -75.0, 0.0];
    let cases = [
        // A long J1 move: cruise at 180 deg/s at 100 %.
        ([175.0, 150.0, -75.0, 0.0], Sync::Single),
        // J1, J2 and Z: one shape (J1's acceleration and jerk, Z's velocity).
        ([100.0, 30.0, -75.0, 100.0], Sync::Phase),
        // J1 100° and Z 125 mm: Z limits the velocity, J1 the acceleration; one shape would
        // be slower than the slowest axis, so each axis is stretched.
        ([25.0, 150.0, -75.0, 125.0], Sync::Time),
    ];
    let mut runs = 0;
    for (to, sync) in cases {
        for pct in [20.0, 50.0, 100.0] {
            for ts in [0.01, 0.001] {
                if ts == 0.001 && pct != 50.0 {
                    continue;
                }
                let from = joints(&robot, home);
                let to = joints(&robot, to);
                let d: Vec<f64> = (0..4).map(|i| to[i] - from[i]).collect();
                let (_, plan) = joint_plan(&robot, &d, pct);
                // The phases of the longest axis's profile.
                let longest = plan
                    .iter()
                    .max_by(|a, b| a.duration().total_cmp(&b.duration()))
                    .unwrap();
                for (phase, k) in phase_midpoints(longest, ts) {
                    for limits in [STOP, ESTOP] {
                        let r = check_joint_stop(&from, &to, pct, ts, k, limits, sync);
                        runs += 1;
                        if std::env::var_os("WRC_PRINT").is_some() {
                            eprintln!(
                                "{sync:?} {pct} % {limits:?} {phase}: {:.0} ms (ref {:.1}), J1 {:.3} (ref {:.3})",
                                r.time_s * 1e3,
                                r.ref_time_s * 1e3,
                                r.distance[0],
                                r.ref_distance[0]
                            );
                        }
                    }
                }
            }
        }
    }
    assert!(runs >= 3 * 3 * 2 * 5, "{runs} runs");
}

/// ESTOP below 100 % brakes with the full limits: much sooner than STOP, which brakes with
/// the override's (acceleration p², jerk p³).
#[test]
fn estop_ignores_the_override() {
    let robot = Robot::paper_default();
    let from = joints(&robot, [-75.0, 150.0, -75.0, 0.0]);
    let to = joints(&robot, [175.0, 150.0, -75.0, 0.0]);
    // 20 %, 150 ms after the start (accelerating).
    let stop = check_joint_stop(&from, &to, 20.0, 0.01, 15, STOP, Sync::Single);
    let estop = check_joint_stop(&from, &to, 20.0, 0.01, 15, ESTOP, Sync::Single);
    assert!(estop.time_s * 5.0 < stop.time_s, "{estop:?} vs {stop:?}");
    // Regression: the stop this replaces (velocity held to the end of the acceleration,
    // then the override's limits) took 1.8 s and 7.2° here.
    assert!(stop.time_s < 0.5 && stop.distance[0] < 0.4, "{stop:?}");
    assert!(
        estop.time_s <= 0.03 + 1e-9 && estop.distance[0] < 0.01,
        "{estop:?}"
    );
}

/// The figures of the report that asked for this brake, from a long J1 MOVJ at 100 %. Its
/// "~110 ms and 0.7°" are the time-optimal brake from J1 at 4.9 deg/s and 266 deg/s² (37 ms
/// into the move at a 1 ms period; the report measured at the controller, whose command
/// path adds the rest of its "100 ms"); in cruise at 180 deg/s the brake takes 350 ms and
/// 31.5° (the report's ~375 ms and 36° include 25 ms of that path at 180 deg/s). The
/// generator's own 100 ms after the start (36 deg/s, 720 deg/s²) brakes in 300 ms and
/// 13.2°. Tolerances: one period on the time, 1e-6° on the distance (closed forms).
#[test]
fn the_reported_stops_are_time_optimal() {
    let robot = Robot::paper_default();
    let from = joints(&robot, [-75.0, 150.0, -75.0, 0.0]);
    let to = joints(&robot, [175.0, 150.0, -75.0, 0.0]);
    // Accelerating, at a 1 ms period: ≈ 110 ms and ≈ 0.7°.
    let r = check_joint_stop(&from, &to, 100.0, 0.001, 37, ESTOP, Sync::Single);
    assert!((r.ref_time_s - 0.111).abs() < 0.001, "{r:?}");
    assert!(
        r.time_s <= 0.110 * 1.02 + 0.001 && r.time_s >= 0.105,
        "{r:?}"
    );
    assert!((r.distance[0] - 0.7).abs() < 0.05, "{r:?}");
    // 100 ms after the start at the default 10 ms period.
    let r = check_joint_stop(&from, &to, 100.0, 0.01, 10, ESTOP, Sync::Single);
    assert!((r.time_s - 0.300).abs() < 1e-9, "{r:?}");
    assert!((r.distance[0] - 13.2).abs() < 1e-6, "{r:?}");
    // Cruise at 180 deg/s: 350 ms (≤ the report's 375 ms + 1 period) and 31.5°.
    for limits in [STOP, ESTOP] {
        let r = check_joint_stop(&from, &to, 100.0, 0.01, 100, limits, Sync::Single);
        assert!(r.time_s <= 0.375 + 0.01 + 1e-9, "{r:?}");
        assert!((r.time_s - 0.350).abs() < 1e-9, "{r:?}");
        assert!((r.distance[0] - 31.5).abs() < 1e-6, "{r:?}");
    }
}

/// What a line's stop did, from its periods, and the TCP's 1-D reference.
#[derive(Debug)]
struct LineStop {
    /// From the request to the last period of the move [s].
    time_s: f64,
    /// The TCP's travel after the request [mm].
    distance_mm: f64,
    /// Ruckig's time-optimal brake of the TCP along the line with the Cartesian limits only,
    /// from the same state: a lower bound on the time (every joint's limits come on top) [s].
    tcp_time_s: f64,
    /// Its distance [mm].
    tcp_distance_mm: f64,
    /// The time-optimal brake of the line's path parameter with every joint's limits too
    /// (`wrc_motion::bench::stop::line_brake_reference`), or the TCP's if it is longer [s].
    ref_time_s: f64,
    /// Its distance [mm] (the longer of the two).
    ref_distance_mm: f64,
    /// TCP speed at the request [mm/s].
    speed_mm_s: f64,
    /// How the move ended.
    end: MoveEnd,
}

/// A straight line stopped at `frac` of its duration with `limits`: limits (joints and TCP)
/// from the exact positions, on the line from the pulses, how it ended, and the figures.
fn check_line_stop(
    a: &Pose,
    b: &Pose,
    pct: f64,
    ts: f64,
    frac: f64,
    limits: BrakeLimits,
) -> LineStop {
    let mut vg = generator(Profile::Fir, ts, pct);
    let robot = vg.robot().clone();
    let start = robot.inverse(a, Posture::Right, None).unwrap();
    vg.set_position_pulses(&robot.joints_to_pulses(&start))
        .unwrap();
    let a = vg.pose();
    let info = vg.plan_line(b).unwrap();
    let k = ((info.periods as f64 * frac) as usize).max(1);
    // Distance of the TCP from the start [mm].
    let along = |q: &Joints| {
        let p = robot.forward(q);
        ((p.x - a.x).powi(2) + (p.y - a.y).powi(2) + (p.z - a.z).powi(2)).sqrt()
    };
    // The TCP's state at the request, from the unstopped motion: central differences of the
    // exact positions (errors of J·Ts²/6 in the speed, none in the acceleration while the
    // jerk is constant).
    let (unstopped, at) = {
        let mut probe = vg.clone();
        let mut p = Period::default();
        let mut x = vec![along(&probe.joints())];
        let mut at = probe.joints();
        for i in 0..=k {
            probe.next_period(&mut p);
            x.push(along(&p.exact));
            if i + 1 == k {
                at = p.exact;
            }
        }
        (x, at)
    };
    let (xm, x0, xp) = (unstopped[k - 1], unstopped[k], unstopped[k + 1]);
    let (speed, accel) = ((xp - xm) / (2.0 * ts), (xp - 2.0 * x0 + xm) / (ts * ts));
    let run = run_stopped(&mut vg, k, limits);
    let what = format!("line at {pct} %, {limits:?} at {frac} of it");
    let s = match limits {
        BrakeLimits::Override => pct / 100.0,
        BrakeLimits::Full => 1.0,
    };
    // (a) Every joint within the limits braked with.
    assert_within_scaled(&vg, &run, (s, s), 1e-6, 0.0);
    // … and the TCP within the Cartesian ones.
    let line = vg.settings().line;
    let path: Vec<f64> = std::iter::once(run.start)
        .chain(run.periods.iter().map(|p| p.exact))
        .map(|q| along(&q))
        .collect();
    assert!(
        (path[k] - x0).abs() < 1e-9,
        "{what}: the probe is not the run"
    );
    let (v, acc, j) = derivative_peaks(&path, ts);
    assert!(
        v <= line.max_speed_mm_s * s * (1.0 + 1e-6),
        "{what}: {v} mm/s"
    );
    assert!(
        acc <= line.max_accel_mm_s2 * s * s * (1.0 + 1e-6),
        "{what}: {acc} mm/s²"
    );
    assert!(
        j <= line.max_jerk_mm_s3 * s * s * s * (1.0 + 1e-6),
        "{what}: {j} mm/s³"
    );
    // (c) On the line, from the pulses (forward kinematics): within 0.01 mm.
    let mut position = robot.joints_to_pulses(&start);
    for p in &run.periods {
        for (x, d) in position.iter_mut().zip(&p.pulses) {
            *x += d;
        }
        let tcp = robot.forward(&robot.pulses_to_joints(&position));
        let off = distance_to_segment(&tcp, &a, b);
        assert!(off <= 0.01, "{what}: {off} mm off the line");
    }
    let (tcp_time_s, tcp_distance_mm) = ruckig_brake(
        speed,
        accel,
        line.max_accel_mm_s2 * s * s,
        line.max_jerk_mm_s3 * s * s * s,
    );
    let segment = LinePath::new(&robot, a, *b, Posture::Right);
    let length = segment.length_mm();
    let state = (x0 / length, speed / length, accel / length);
    let (path_time_s, path_distance_mm) =
        line_brake_reference(&robot, &segment, &at, state, &line, s)
            .unwrap_or_else(|| panic!("{what}: no path brake from {state:?}"));
    LineStop {
        time_s: (run.periods.len() - k) as f64 * ts,
        distance_mm: path.last().unwrap() - x0,
        tcp_time_s,
        tcp_distance_mm,
        ref_time_s: path_time_s.max(tcp_time_s),
        ref_distance_mm: path_distance_mm.max(tcp_distance_mm),
        speed_mm_s: speed,
        end: run.end,
    }
}

/// Lines stopped while accelerating, cruising and decelerating, at 20, 50 and 100 %, STOP and
/// ESTOP: within the limits braked with (joints and TCP), on the line; ESTOP below 100 %
/// brakes in real time with the full limits, much sooner than STOP.
///
/// Against the time-optimal brake of the line's path with every joint's limits and the
/// Cartesian ones (`line_brake_reference`, or the TCP's own 1-D brake where that is longer):
/// within 5 % of its time and distance, plus one period, from every phase, the line's final
/// deceleration included. The TCP's 1-D brake alone is a
/// lower bound: the stop never beats it (within the discretisation); accelerating or
/// decelerating the elbow's jerk (its term 3q″u̇ü) binds where the Cartesian bound knows
/// nothing of it, so no motion along the line reaches it there.
#[test]
fn line_stops_keep_the_limits_and_the_line() {
    let a = Pose {
        x: 250.0,
        y: -250.0,
        z: 0.0,
        yaw: 0.0,
    };
    for b in [
        Pose {
            x: 250.0,
            y: 250.0,
            z: 100.0,
            yaw: 40.0,
        },
        Pose {
            x: 250.0,
            y: 250.0,
            z: 0.0,
            yaw: 0.0,
        },
    ] {
        for pct in [20.0, 50.0, 100.0] {
            for frac in [0.05, 0.15, 0.5, 0.9] {
                let ts = 0.001;
                let stop = check_line_stop(&a, &b, pct, ts, frac, STOP);
                let estop = check_line_stop(&a, &b, pct, ts, frac, ESTOP);
                let print = std::env::var_os("WRC_PRINT").is_some();
                for (limits, r) in [(STOP, &stop), (ESTOP, &estop)] {
                    let what = format!("{pct} % at {frac}, {limits:?}: {r:?}");
                    if print {
                        eprintln!("{what}");
                    }
                    assert!(r.time_s >= r.tcp_time_s - 1e-3, "{what}");
                    assert!(r.distance_mm >= r.tcp_distance_mm - 1e-3, "{what}");
                    // Measured within 1.022x of the path brake's time and 1.019x its
                    // distance (plus one period) from every phase, the line's final
                    // deceleration included; the goal is 1.05x.
                    let (kt, kd) = (1.05, 1.05);
                    assert!(r.time_s <= kt * r.ref_time_s + ts + 1e-9, "{what}");
                    assert!(
                        r.distance_mm <= kd * r.ref_distance_mm + r.speed_mm_s * ts,
                        "{what}"
                    );
                    if frac < 0.5 {
                        assert_eq!(r.end, MoveEnd::Stopped, "{what}");
                    }
                }
                assert!(
                    estop.time_s <= stop.time_s + 1e-9
                        && estop.distance_mm <= stop.distance_mm + 1e-6,
                    "{pct} % at {frac}: ESTOP {estop:?}, STOP {stop:?}"
                );
                if pct <= 50.0 {
                    assert!(estop.time_s * 2.0 < stop.time_s, "{pct} % at {frac}");
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn stop_keeps_limits_and_bookkeeping(
        stop_at in 0usize..300, paper in any::<bool>(), line in any::<bool>(), full in any::<bool>(),
        pct in prop_oneof![Just(100.0), 10.0f64..100.0],
    ) {
        let profile = if paper { Profile::Paper { mask_len: 20 } } else { Profile::Fir };
        let limits = if full { ESTOP } else { STOP };
        let mut vg = generator(profile, 0.01, pct);
        if line {
            let start = vg.robot().inverse(&Pose { x: 300.0, y: -150.0, z: 0.0, yaw: 0.0 }, Posture::Right, None).unwrap();
            vg.set_position_pulses(&vg.robot().joints_to_pulses(&start)).unwrap();
            vg.plan_line(&Pose { x: 300.0, y: 150.0, z: 100.0, yaw: 45.0 }).unwrap();
        } else {
            let mut t = vg.joints();
            t[0] = 120.0;
            t[1] = 30.0;
            t[3] = 250.0;
            vg.plan_ptp(&t).unwrap();
        }
        let start = *vg.position_pulses();
        let a = vg.pose();
        let full_run = {
            let mut probe = vg.clone();
            run(&mut probe).periods.len()
        };
        let run = run_stopped(&mut vg, stop_at, limits);
        // Bookkeeping: the position is the start plus every pulse emitted.
        let sums = pulse_sums(&run);
        for ax in 0..4 {
            prop_assert_eq!(vg.position_pulses()[ax], start[ax] + sums[ax]);
        }
        // Before the planned deceleration (at most 0.6 s at 100 %, 0.6/p s at p) a stop ends
        // short of the target, and sooner.
        let decel_periods = (60.0 * 100.0 / pct).ceil() as usize;
        if stop_at < full_run.saturating_sub(decel_periods) {
            prop_assert_eq!(run.end, MoveEnd::Stopped);
            prop_assert!(run.periods.len() < full_run);
        }
        // The limits braked with: the paper profile keeps its own stop at the override.
        let s = if full && !paper { 1.0 } else { pct / 100.0 };
        assert_within_scaled(&vg, &run, (s, s), 1e-6, if paper { 1.0 } else { 0.0 });
        if line {
            // Still on the line.
            let target = Pose { x: 300.0, y: 150.0, z: 100.0, yaw: 45.0 };
            let cross = distance_to_segment(&vg.pose(), &a, &target);
            prop_assert!(cross < 0.01, "{} mm off the line", cross);
        }
    }
}

#[test]
fn stop_when_idle_does_nothing() {
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    let p = *vg.position_pulses();
    vg.stop(ESTOP);
    vg.stop(STOP);
    assert!(!vg.is_moving());
    assert_eq!(*vg.position_pulses(), p);
    assert_eq!(vg.goal(), None);
}

#[test]
fn stop_during_cruise_decelerates_at_once() {
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    let mut t = vg.joints();
    t[0] = 175.0; // 250 deg at 180 deg/s: a long cruise
    vg.plan_ptp(&t).unwrap();
    let run = run_stopped(&mut vg, 100, STOP);
    let speeds: Vec<i64> = run.periods.iter().map(|p| p.pulses[0]).collect();
    // Cruising before the stop; slower in the very next period.
    assert_eq!(speeds[98], speeds[99]);
    assert!(speeds[100] < speeds[99], "{:?}", &speeds[95..105]);
    assert_eq!(run.end, MoveEnd::Stopped);
}

/// A stop with the same limits again changes nothing; ESTOP after STOP brakes harder from
/// where the STOP's brake is; STOP after ESTOP does not weaken it.
#[test]
fn a_second_stop_only_strengthens_the_brake() {
    let plan = || {
        let mut vg = generator(Profile::Fir, 0.01, 30.0);
        let mut t = vg.joints();
        t[0] = 175.0;
        vg.plan_ptp(&t).unwrap();
        vg
    };
    let once = |limits| {
        let mut vg = plan();
        let r = run_stopped(&mut vg, 100, limits);
        (r.periods.len(), *vg.position_pulses())
    };
    let twice = |first, then| {
        let mut vg = plan();
        let r = run_with(&mut vg, 100_000, |vg, k| {
            if k == 100 {
                vg.stop(first)
            }
            if k == 110 {
                vg.stop(then)
            }
        });
        assert_within_scaled(&vg, &r, (0.3, 1.0), 1e-6, 0.0);
        (r.periods.len(), *vg.position_pulses())
    };
    assert_eq!(twice(STOP, STOP), once(STOP));
    assert_eq!(twice(ESTOP, STOP), once(ESTOP));
    assert_eq!(twice(ESTOP, ESTOP), once(ESTOP));
    let (stop, _) = once(STOP);
    let (escalated, _) = twice(STOP, ESTOP);
    let (estop, _) = once(ESTOP);
    assert!(
        escalated < stop && escalated > estop,
        "{escalated} {stop} {estop}"
    );
}

#[test]
fn a_stop_can_restart_from_an_earlier_state() {
    // The controller keeps a state per queued period and stops from the one the Pulse
    // Generator reached: the result equals stopping a generator that ran only that far.
    for limits in [STOP, ESTOP] {
        let mut ahead = generator(Profile::Fir, 0.01, 60.0);
        let mut t = ahead.joints();
        t[0] = 150.0;
        ahead.plan_ptp(&t).unwrap();
        let mut states = Vec::new();
        let mut p = Period::default();
        for _ in 0..60 {
            states.push(ahead.state());
            ahead.next_period(&mut p);
        }
        let mut reference = generator(Profile::Fir, 0.01, 60.0);
        reference.plan_ptp(&t).unwrap();
        for _ in 0..40 {
            reference.next_period(&mut p);
        }
        ahead.restore(&states[40]);
        assert_eq!(ahead.position_pulses(), reference.position_pulses());
        ahead.stop(limits);
        reference.stop(limits);
        let a = run(&mut ahead);
        let b = run(&mut reference);
        assert_eq!(a.end, MoveEnd::Stopped);
        assert_eq!(pulse_sums(&a), pulse_sums(&b));
        assert_eq!(ahead.position_pulses(), reference.position_pulses());
    }
}

/// HOLD and RESUME: a held PTP move resumed to its goal in pulses ends exactly on the
/// original target; a held line resumed to its goal pose ends on the line's end pulses.
#[test]
fn a_held_move_resumes_to_its_goal_exactly() {
    let mut vg = generator(Profile::Fir, 0.01, 70.0);
    let mut t = vg.joints();
    t[0] = 33.3333;
    t[1] = 12.3456;
    t[3] = 123.4567;
    vg.plan_ptp(&t).unwrap();
    let target = vg.robot().joints_to_pulses(&t);
    assert_eq!(vg.goal(), Some(Goal::Joints(target)));
    let mut p = Period::default();
    for _ in 0..30 {
        vg.next_period(&mut p);
    }
    vg.stop(STOP);
    // HOLD keeps the goal of the move it stops (the state of any queued period knows it).
    let Some(Goal::Joints(goal)) = vg.state().goal() else {
        panic!("{:?}", vg.goal())
    };
    assert_eq!(goal, target);
    assert_eq!(run(&mut vg).end, MoveEnd::Stopped);
    assert_eq!(vg.goal(), None);
    vg.plan_ptp_pulses(&goal).unwrap();
    run(&mut vg);
    assert_eq!(*vg.position_pulses(), target);

    let start = vg
        .robot()
        .inverse(
            &Pose {
                x: 300.0,
                y: -150.0,
                z: 0.0,
                yaw: 0.0,
            },
            Posture::Right,
            None,
        )
        .unwrap();
    vg.set_position_pulses(&vg.robot().joints_to_pulses(&start))
        .unwrap();
    let end = Pose {
        x: 300.0,
        y: 150.0,
        z: 100.0,
        yaw: 45.0,
    };
    vg.plan_line(&end).unwrap();
    let Some(Goal::Line { pose, pulses }) = vg.goal() else {
        panic!("{:?}", vg.goal())
    };
    assert!((pose.x - end.x).abs() < 1e-9 && (pose.y - end.y).abs() < 1e-9);
    assert!((pose.z - end.z).abs() < 1e-9 && (pose.yaw - end.yaw).abs() < 1e-9);
    let held = run_stopped(&mut vg, 40, STOP);
    assert_eq!(held.end, MoveEnd::Stopped);
    vg.plan_line(&pose).unwrap();
    let resumed = run(&mut vg);
    assert_eq!(resumed.end, MoveEnd::Completed);
    assert_eq!(*vg.position_pulses(), pulses);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    // The controller's Pulse Generator stops a line from the state of the period it has
    // reached, in a generator of its own (which computes the line's derivatives itself):
    // the stop keeps every limit, stays on the line, ends short of the target, and lands
    // within a pulse of where the planning generator's own stop lands (both choose the
    // brake with the exact derivatives; a feedback brake then follows the planner's table).
    #[test]
    fn a_line_stopped_by_another_generator_keeps_its_limits(
        stop_at in 1usize..120, pct in 10.0f64..100.0, fast in any::<bool>(), full in any::<bool>(),
    ) {
        let ts = if fast { 0.001 } else { 0.01 };
        let stop_at = if fast { stop_at * 10 } else { stop_at };
        let limits = if full { ESTOP } else { STOP };
        let mut planner = generator(Profile::Fir, ts, pct);
        let start = planner.robot().inverse(&Pose { x: 320.0, y: -180.0, z: 20.0, yaw: -30.0 }, Posture::Right, None).unwrap();
        planner.set_position_pulses(&planner.robot().joints_to_pulses(&start)).unwrap();
        let a = planner.pose();
        let target = Pose { x: 80.0, y: 250.0, z: 120.0, yaw: 60.0 };
        let info = planner.plan_line(&target).unwrap();
        prop_assume!((stop_at as u64) < info.periods.saturating_sub(2));
        let first = planner.joints();
        let mut before = Vec::new();
        for _ in 0..stop_at {
            let mut p = Period::default();
            planner.next_period(&mut p);
            before.push(p);
        }
        let state = planner.state();
        let mut stopper = generator(Profile::Fir, ts, pct);
        stopper.restore(&state);
        stopper.stop(limits);
        planner.stop(limits);
        let own = run(&mut planner);
        let other = run(&mut stopper);
        // Stopped short of the target, unless the stop came during the line's last brake,
        // which ends on the target anyway.
        prop_assert_eq!(other.end, own.end);
        if (stop_at as u64) < info.periods / 2 {
            prop_assert_eq!(other.end, MoveEnd::Stopped);
        }
        // The whole motion, from rest to rest: the periods before the stop, then the stop's.
        let whole = Run {
            periods: before.iter().chain(&other.periods).copied().collect(),
            end: other.end,
            start: first,
        };
        let s = if full { 1.0 } else { pct / 100.0 };
        assert_within_scaled(&stopper, &whole, (s, s), 1e-6, 0.0);
        for (x, y) in stopper.position_pulses().iter().zip(planner.position_pulses()).take(4) {
            prop_assert!((x - y).abs() <= 1, "{:?} vs {:?}", stopper.position_pulses(), planner.position_pulses());
        }
        let cross = distance_to_segment(&stopper.pose(), &a, &target);
        prop_assert!(cross < 0.01, "{} mm off the line", cross);
        prop_assert!(other.periods.len() < (info.periods as usize - stop_at) + 2);
    }
}
