//! Stopping times and distances (`wrc bench stop`), in the form of ISO 10218-1 Annex B: for
//! every axis alone and for a straight line of the TCP, at several speed overrides, a stop
//! requested at the moment of peak acceleration (mid-acceleration) and in cruise (at full
//! speed), with ESTOP (full limits) and STOP (the move's limits), measured from the
//! generator's output pulses and compared with the one-dimensional time-optimal
//! jerk-limited brake ([`Brake1d`]) from the state at the request. Not used by the
//! controller; this module allocates.

use wrc_robot::{Joints, Pose, Robot, MAX_AXES};

use crate::brake::Brake1d;
use crate::error::PlanError;
use crate::generator::{BrakeLimits, Period, Status, VelocityGenerator};
use crate::path::LinePath;
use crate::settings::LineLimits;

use super::LineCase;

/// What is stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Subject {
    /// One axis alone (a jog across its range), by index.
    Axis(usize),
    /// A straight line of the TCP.
    Line(LineCase),
}

/// When the stop is requested.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopPhase {
    /// At the moment of peak acceleration (mid-acceleration).
    Acceleration,
    /// In cruise, at full speed (half-way through the move).
    Cruise,
}

impl StopPhase {
    /// A short name for tables.
    pub fn name(&self) -> &'static str {
        match self {
            StopPhase::Acceleration => "accel",
            StopPhase::Cruise => "cruise",
        }
    }
}

/// One measured stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopRow {
    /// What was stopped.
    pub subject: Subject,
    /// Speed override [%].
    pub speed_pct: f64,
    /// When the stop was requested.
    pub phase: StopPhase,
    /// With which limits.
    pub limits: BrakeLimits,
    /// Periods produced before the request.
    pub request_period: u64,
    /// Speed at the request [unit/s; mm/s for a line].
    pub speed: f64,
    /// Acceleration at the request [unit/s²; mm/s² for a line].
    pub acceleration: f64,
    /// From the request to the last period with a pulse, in whole periods [s].
    pub time_s: f64,
    /// Travel after the request, from the pulses [unit; mm of TCP path for a line].
    pub distance: f64,
    /// The one-dimensional time-optimal jerk-limited brake from the same state, with the
    /// axis's limits, scaled by the override for STOP: its duration [s]. A line: the longest
    /// of the TCP's brake with the Cartesian line limits and every joint's own brake from
    /// its velocity and acceleration at the request with its limits — each coordinate must
    /// stop, and none can stop sooner than its own optimum, so no motion along the line
    /// stops sooner (a lower bound).
    pub ref_time_s: f64,
    /// Its distance [unit; mm]. A line: the longest of the TCP's brake distance and, for each
    /// joint, the path to the first point where that joint has travelled its own brake's
    /// distance (a lower bound too).
    pub ref_distance: f64,
    /// Which brake gives the reference time.
    pub ref_time_by: RefBy,
    /// Which brake gives the reference distance.
    pub ref_distance_by: RefBy,
}

/// Which brake a reference figure comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefBy {
    /// The 1-D brake of the axis, or of a line's TCP with the Cartesian limits.
    OneD,
    /// A line's path brake with every joint's limits ([`line_brake_reference`]).
    Path,
}

impl StopRow {
    /// Measured time over the reference's (NaN for a reference of no duration).
    pub fn time_ratio(&self) -> f64 {
        self.time_s / self.ref_time_s
    }

    /// Measured distance over the reference's.
    pub fn distance_ratio(&self) -> f64 {
        self.distance / self.ref_distance
    }
}

/// The straight line the table uses for a robot unless told otherwise: a chord at 62.5 % of
/// the arm's reach, from y = −62.5 % to +62.5 % of it, at the Z axis's lowest point, yaw 0
/// (for the default robot 500 mm at x = 250 mm: long enough to cruise at 500 mm/s).
pub fn default_line(robot: &Robot) -> LineCase {
    let arm = robot.arm();
    let r = 0.625 * (arm.link1_mm + arm.link2_mm);
    let z = arm.z.map_or(0.0, |z| robot.axes()[z].min.max(0.0));
    LineCase {
        start: Pose {
            x: r,
            y: -r,
            z,
            yaw: 0.0,
        },
        posture: wrc_robot::Posture::Right,
        target: Pose {
            x: r,
            y: r,
            z,
            yaw: 0.0,
        },
    }
}

/// Measure one stop with a copy of `generator` (its robot and settings; the speed override
/// is set to `speed_pct`).
pub fn measure(
    generator: &VelocityGenerator,
    subject: Subject,
    speed_pct: f64,
    phase: StopPhase,
    limits: BrakeLimits,
) -> Result<StopRow, PlanError> {
    let mut vg = generator.clone();
    vg.set_speed_pct(speed_pct)?;
    let robot = vg.robot().clone();
    let ts = vg.settings().period_s;
    let s = speed_pct / 100.0;
    let brake_scale = match limits {
        BrakeLimits::Override => s,
        BrakeLimits::Full => 1.0,
    };
    // Plan the move; `scale` turns the path state into units, `limits_1d` are the
    // reference's (acceleration, jerk).
    let mut vg_start = *vg.position_pulses();
    let (scale, limits_1d) = match subject {
        Subject::Axis(i) => {
            let axis = robot
                .axes()
                .get(i)
                .ok_or(PlanError::NoSuchAxis {
                    index: i,
                    count: robot.axis_count(),
                })?
                .clone();
            // Across the range, 1 % of it from either end, the other axes at home.
            let margin = 0.01 * (axis.max - axis.min);
            let mut home: Joints = robot.home();
            home[i] = axis.min + margin;
            vg.set_position_pulses(&robot.joints_to_pulses(&home))?;
            let from = vg.position_pulses()[i];
            let to = axis.units_to_pulses(axis.max - margin);
            vg.plan_jog(i, to - from)?;
            let units = (to - from) as f64 / axis.pulses_per_unit;
            let l = &axis.limits;
            (
                units,
                (
                    l.max_acceleration * brake_scale * brake_scale,
                    l.max_jerk * brake_scale.powi(3),
                ),
            )
        }
        Subject::Line(case) => {
            let start = robot.inverse(&case.start, case.posture, None)?;
            vg.set_position_pulses(&robot.joints_to_pulses(&start))?;
            vg_start = *vg.position_pulses();
            let a = vg.pose();
            vg.start_line(&case.target)?;
            let length = ((case.target.x - a.x).powi(2)
                + (case.target.y - a.y).powi(2)
                + (case.target.z - a.z).powi(2))
            .sqrt();
            let line = vg.settings().line;
            (
                length,
                (
                    line.max_accel_mm_s2 * brake_scale * brake_scale,
                    line.max_jerk_mm_s3 * brake_scale.powi(3),
                ),
            )
        }
    };
    // The unstopped motion's path states, to find the moment of the request.
    let states = {
        let mut probe = vg.clone();
        let mut out = Vec::new();
        let mut p = Period::default();
        while probe.is_moving() {
            probe.next_period(&mut p);
            out.push(probe.path_state().unwrap_or((1.0, 0.0, 0.0)));
        }
        out
    };
    let k = request_period(&states, phase);
    let mut p = Period::default();
    let mut position = *vg.position_pulses();
    let mut tcp_before = robot.forward(&robot.pulses_to_joints(&position));
    for _ in 0..k {
        vg.next_period(&mut p);
    }
    position = *vg.position_pulses();
    tcp_before = if k == 0 {
        tcp_before
    } else {
        robot.forward(&robot.pulses_to_joints(&position))
    };
    let (_, v, a) = vg.path_state().unwrap_or((0.0, 0.0, 0.0));
    let (speed, acceleration) = (v * scale, a * scale);
    let reference = Brake1d::new(
        0.0,
        speed.abs(),
        acceleration * speed.signum(),
        limits_1d.0,
        limits_1d.1,
    );
    let mut bound = Bound {
        time_s: reference.duration(),
        distance: reference.stop_position(),
        time_by: RefBy::OneD,
        distance_by: RefBy::OneD,
    };
    if let (Subject::Line(case), Some(state)) = (subject, vg.path_state()) {
        let start = robot.forward(&robot.pulses_to_joints(&vg_start));
        let path = LinePath::new(&robot, start, case.target, case.posture);
        let at = robot.pulses_to_joints(&position);
        path_bound(
            &robot,
            &path,
            &at,
            state,
            &vg.settings().line,
            brake_scale,
            &mut bound,
        );
    }
    vg.stop(limits);
    let (mut last_pulse, mut distance) = (0u64, 0.0f64);
    let mut i = 0u64;
    loop {
        i += 1;
        let status = vg.next_period(&mut p);
        let moved = p.pulses.iter().any(|&x| x != 0);
        if moved {
            last_pulse = i;
        }
        for (x, d) in position.iter_mut().zip(&p.pulses).take(MAX_AXES) {
            *x += d;
        }
        distance += match subject {
            Subject::Axis(ax) => (p.pulses[ax] as f64 / robot.axes()[ax].pulses_per_unit).abs(),
            Subject::Line(_) => {
                let tcp = robot.forward(&robot.pulses_to_joints(&position));
                let step = ((tcp.x - tcp_before.x).powi(2)
                    + (tcp.y - tcp_before.y).powi(2)
                    + (tcp.z - tcp_before.z).powi(2))
                .sqrt();
                tcp_before = tcp;
                step
            }
        };
        match status {
            Status::Working => {}
            Status::Finished(_) | Status::Idle => break,
        }
    }
    Ok(StopRow {
        subject,
        speed_pct,
        phase,
        limits,
        request_period: k,
        speed: speed.abs(),
        acceleration: acceleration * speed.signum(),
        time_s: last_pulse as f64 * ts,
        distance,
        ref_time_s: bound.time_s,
        ref_distance: bound.distance,
        ref_time_by: bound.time_by,
        ref_distance_by: bound.distance_by,
    })
}

/// The reference of a stop: the longest of the one-dimensional brakes.
struct Bound {
    time_s: f64,
    distance: f64,
    time_by: RefBy,
    distance_by: RefBy,
}

/// The time-optimal jerk-limited brake of a straight line's path parameter u from the path
/// state `(u, u̇, ü)` [1, 1/s, 1/s², real time] at the joints `at`, with every joint's
/// acceleration and jerk limit and the Cartesian ones (`line`), all scaled by `scale` (the
/// override for STOP, 1 for ESTOP): its duration [s] and TCP distance [mm]. `None` at rest,
/// for a line of no length, or where the kinematics fail.
///
/// Along the line q̈ = q′ü + q″u̇² and q⃛ = q′u⃛ + 3q″u̇ü + q‴u̇³, so at each state the limits
/// bound ü and u⃛ to intervals that move with the state. The TCP's own 1-D brake (Ruckig's,
/// with the Cartesian limits) ignores that, and can ask a joint for more jerk than it has
/// (1.5× J2's on the default table line while accelerating): it is a lower bound no motion
/// reaches. This brake keeps them all: the bang-bang structure of a time-optimal
/// jerk-limited brake, the most negative jerk the state allows (the deceleration held on its
/// bound once there) until a switching time, then the most positive, so that ü and u̇ reach
/// zero together, with the switching time found by bisection on a simulation in steps of
/// 0.1 ms. An independent reference: it shares the line's kinematics with the controller's
/// brake (`line_profile.rs`), not its algorithm, tables or margins.
pub fn line_brake_reference(
    robot: &Robot,
    path: &LinePath,
    at: &Joints,
    (u0, v0, a0): (f64, f64, f64),
    line: &LineLimits,
    scale: f64,
) -> Option<(f64, f64)> {
    let length = path.length_mm();
    if length <= 0.0 || v0 <= 0.0 {
        return None;
    }
    let limits = PathBrakeLimits {
        cart: (
            line.max_accel_mm_s2 * scale * scale / length,
            line.max_jerk_mm_s3 * scale.powi(3) / length,
        ),
        joints: std::array::from_fn(|k| {
            robot
                .axes()
                .get(k)
                .map_or((f64::INFINITY, f64::INFINITY), |a| {
                    (
                        a.limits.max_acceleration * scale * scale,
                        a.limits.max_jerk * scale.powi(3),
                    )
                })
        }),
    };
    let run = |switch: f64| simulate_path_brake(robot, path, at, (u0, v0, a0), &limits, switch);
    // Released at 60 s, a brake has stopped long before (or the line ended).
    let (mut early, mut late) = (0.0, 60.0);
    let mut best = match run(late) {
        shot @ Shot::Late { .. } => shot,
        Shot::Early | Shot::Failed => return None,
    };
    for _ in 0..48 {
        let mid = 0.5 * (early + late);
        match run(mid) {
            Shot::Early => early = mid,
            shot @ Shot::Late { .. } => {
                late = mid;
                best = shot;
            }
            Shot::Failed => return None,
        }
    }
    match best {
        Shot::Late { time_s, u } => Some((time_s, (u - u0) * length)),
        Shot::Early | Shot::Failed => None,
    }
}

/// Raise `bound` (the TCP's brake) to the line's own: [`line_brake_reference`].
fn path_bound(
    robot: &Robot,
    path: &LinePath,
    at: &Joints,
    state: (f64, f64, f64),
    line: &LineLimits,
    scale: f64,
    bound: &mut Bound,
) {
    if let Some((time_s, distance)) = line_brake_reference(robot, path, at, state, line, scale) {
        if time_s > bound.time_s {
            bound.time_s = time_s;
            bound.time_by = RefBy::Path;
        }
        if distance > bound.distance {
            bound.distance = distance;
            bound.distance_by = RefBy::Path;
        }
    }
}

/// Step of the reference path brake's simulation [s].
const REF_STEP_S: f64 = 1e-4;

/// The limits of the reference path brake: the Cartesian (acceleration, jerk) in u units and
/// every joint's.
struct PathBrakeLimits {
    cart: (f64, f64),
    joints: [(f64, f64); MAX_AXES],
}

/// How a simulated path brake ends.
#[derive(Debug, Clone, Copy)]
enum Shot {
    /// The deceleration was released too early: ü is back at zero with u̇ > 0.
    Early,
    /// Released too late (or on time): u̇ reached zero, at `time_s` and path point `u`.
    Late { time_s: f64, u: f64 },
    /// The kinematics failed (the line's end or a singular point).
    Failed,
}

/// Narrow [lo, hi] to the x with |k·x + c| ≤ limit (k ≠ 0).
fn narrow(lo: &mut f64, hi: &mut f64, limit: f64, c: f64, k: f64) {
    let (x, y) = ((-limit - c) / k, (limit - c) / k);
    *lo = lo.max(x.min(y));
    *hi = hi.min(x.max(y));
}

/// Brake with the most negative admissible jerk until `switch` [s], then the most positive.
fn simulate_path_brake(
    robot: &Robot,
    path: &LinePath,
    at: &Joints,
    (mut u, mut v, mut a): (f64, f64, f64),
    limits: &PathBrakeLimits,
    switch: f64,
) -> Shot {
    let mut q = *at;
    let mut t = 0.0;
    let n = robot.axis_count();
    while t < 60.0 {
        let Ok(jets) = path.jets_at(robot, u.min(1.0), &q) else {
            return Shot::Failed;
        };
        for (k, x) in q.iter_mut().enumerate().take(n) {
            *x = jets.joints[k].d[0];
        }
        // The admissible jerk and acceleration of u at this state.
        let (mut jlo, mut jhi) = (-limits.cart.1, limits.cart.1);
        let (mut alo, mut ahi) = (-limits.cart.0, limits.cart.0);
        for k in 0..n {
            let d = jets.joints[k].d;
            if d[1].abs() < 1e-12 {
                continue;
            }
            let (am, jm) = limits.joints[k];
            let c = 3.0 * d[2] * v * a + d[3] * v * v * v;
            narrow(&mut jlo, &mut jhi, jm, c, d[1]);
            narrow(&mut alo, &mut ahi, am, d[2] * v * v, d[1]);
        }
        // A step ends at the switch, so where the brake ends is continuous in the switch
        // time and the bisection converges on the brake whose ü and u̇ reach 0 together.
        let step = if t < switch {
            REF_STEP_S.min(switch - t)
        } else {
            REF_STEP_S
        };
        let next_a = if t < switch {
            (a + jlo * step).max(alo.min(a))
        } else {
            (a + jhi.max(0.0) * step).min(ahi.max(a))
        };
        let next_v = v + 0.5 * (a + next_a) * step;
        let dt = if next_v < 0.0 && v > next_v {
            step * v / (v - next_v)
        } else {
            step
        };
        u += v * dt + (2.0 * a + next_a) / 6.0 * dt * dt;
        t += dt;
        if next_v <= 0.0 {
            return Shot::Late { time_s: t, u };
        }
        if t >= switch && next_a >= 0.0 {
            return Shot::Early;
        }
        (v, a) = (next_v, next_a);
    }
    Shot::Failed
}

/// The period after which to request the stop: the middle of the periods at the peak path
/// acceleration (within 0.1 % of it: the constant-acceleration phase of a double-S) before
/// the peak speed, or half-way through the move (in cruise, for a long move).
fn request_period(states: &[(f64, f64, f64)], phase: StopPhase) -> u64 {
    match phase {
        StopPhase::Acceleration => {
            let peak_speed = states
                .iter()
                .enumerate()
                .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
                .map_or(0, |(k, _)| k);
            let rising = &states[..states.len().min(peak_speed + 1)];
            let peak = rising.iter().map(|s| s.2).fold(f64::NEG_INFINITY, f64::max);
            let near: Vec<usize> = (0..rising.len())
                .filter(|&k| rising[k].2 >= peak - 1e-3 * peak.abs())
                .collect();
            near.get(near.len() / 2).map_or(0, |&k| k as u64 + 1)
        }
        StopPhase::Cruise => states.len() as u64 / 2,
    }
}

/// The whole table: every axis, then `line` (if given), at every speed of `speeds` [%], the
/// stop at peak acceleration and in cruise, ESTOP then STOP.
pub fn table(
    generator: &VelocityGenerator,
    speeds: &[f64],
    line: Option<LineCase>,
) -> Result<Vec<StopRow>, PlanError> {
    let subjects = (0..generator.robot().axis_count())
        .map(Subject::Axis)
        .chain(line.map(Subject::Line));
    let mut rows = Vec::new();
    for subject in subjects {
        for &pct in speeds {
            for phase in [StopPhase::Acceleration, StopPhase::Cruise] {
                for limits in [BrakeLimits::Full, BrakeLimits::Override] {
                    rows.push(measure(generator, subject, pct, phase, limits)?);
                }
            }
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::MotionSettings;

    fn generator() -> VelocityGenerator {
        VelocityGenerator::new(Robot::paper_default(), MotionSettings::default()).unwrap()
    }

    #[test]
    fn an_axis_stop_is_measured_from_its_pulses() {
        let vg = generator();
        // J1 in cruise at 180 deg/s: 350 ms and 31.5° (A = 720 deg/s², J = 7200 deg/s³).
        let r = measure(
            &vg,
            Subject::Axis(0),
            100.0,
            StopPhase::Cruise,
            BrakeLimits::Full,
        )
        .unwrap();
        assert!(
            (r.speed - 180.0).abs() < 1e-9 && r.acceleration.abs() < 1e-9,
            "{r:?}"
        );
        assert!((r.time_s - 0.35).abs() < 1e-9, "{r:?}");
        assert!((r.ref_time_s - 0.35).abs() < 1e-12, "{r:?}");
        assert!((r.distance - 31.5).abs() <= 1e-3 && (r.ref_distance - 31.5).abs() < 1e-9);
        // At peak acceleration: on the constant-acceleration phase, A = 720 deg/s².
        let r = measure(
            &vg,
            Subject::Axis(0),
            100.0,
            StopPhase::Acceleration,
            BrakeLimits::Full,
        )
        .unwrap();
        assert!((r.acceleration - 720.0).abs() < 1e-6, "{r:?}");
        assert!((r.distance - r.ref_distance).abs() <= 1e-3, "{r:?}");
        assert!(
            r.time_s <= r.ref_time_s + vg.settings().period_s + 1e-9,
            "{r:?}"
        );
    }

    #[test]
    fn the_table_has_every_axis_and_the_line() {
        let vg = generator();
        let rows = table(&vg, &[50.0], Some(default_line(vg.robot()))).unwrap();
        assert_eq!(rows.len(), (4 + 1) * 2 * 2);
        // ESTOP then STOP of the same stop: at 50 % STOP brakes with a quarter of the full
        // acceleration and an eighth of the jerk, so it takes longer and goes further.
        for pair in rows.chunks(2) {
            let (estop, stop) = (&pair[0], &pair[1]);
            assert_eq!(
                (estop.limits, stop.limits),
                (BrakeLimits::Full, BrakeLimits::Override)
            );
            assert_eq!(estop.request_period, stop.request_period);
            assert!(estop.time_s > 0.0 && estop.distance > 0.0, "{estop:?}");
            assert!(
                stop.time_s > estop.time_s && stop.distance > estop.distance,
                "{stop:?}"
            );
        }
        let line_cruise_estop = rows
            .iter()
            .find(|r| {
                matches!(r.subject, Subject::Line(_))
                    && r.phase == StopPhase::Cruise
                    && r.limits == BrakeLimits::Full
            })
            .unwrap();
        assert!(
            line_cruise_estop.distance_ratio() < 1.02,
            "{line_cruise_estop:?}"
        );
    }
}
