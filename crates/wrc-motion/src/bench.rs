//! Measurements for `wrc bench`: straight lines (`wrc bench motion`) — random reachable lines
//! of a robot, each planned and run to its end as the controller runs it, its duration
//! compared with the lower bounds of [`crate::reference`], its limits and its accuracy
//! checked from the output pulses — arcs, blended paths and PTP blends the same way
//! ([`paths`]), and stopping times and distances ([`stop`], `wrc bench stop`). Not used by
//! the controller; this module allocates.

pub mod paths;
pub mod stop;

pub use paths::{PathDistance, PathProbe};

use std::time::Instant;

use wrc_robot::{Joints, Pose, Posture, Robot, MAX_AXES};

use crate::error::PlanError;
use crate::generator::{MoveEnd, Period, Status, VelocityGenerator};
use crate::path::check_line;
use crate::reference::{line_bound, LineBound};
use crate::settings::MotionSettings;

/// A straight line to try: from `start` (reached with `posture`) to `target`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineCase {
    /// Start pose [mm, mm, mm, deg].
    pub start: Pose,
    /// Elbow posture at the start (kept along the line).
    pub posture: Posture,
    /// Target pose.
    pub target: Pose,
}

/// A fixed-seed pseudo-random generator (SplitMix64): the same lines on every machine.
#[derive(Debug, Clone)]
pub struct Lines {
    state: u64,
}

impl Lines {
    /// Lines from `seed`.
    pub fn new(seed: u64) -> Lines {
        Lines { state: seed }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }

    /// A pose uniform over the disc the arm could reach, its Z range and every yaw.
    fn pose(&mut self, robot: &Robot) -> Pose {
        let arm = robot.arm();
        let reach = arm.link1_mm + arm.link2_mm + arm.hand_mm;
        let (zlo, zhi) = arm
            .z
            .map_or((0.0, 0.0), |z| (robot.axes()[z].min, robot.axes()[z].max));
        loop {
            let (x, y) = (self.uniform(-reach, reach), self.uniform(-reach, reach));
            if x.hypot(y) <= reach {
                return Pose {
                    x,
                    y,
                    z: if zhi > zlo {
                        self.uniform(zlo, zhi)
                    } else {
                        zlo
                    },
                    yaw: self.uniform(-180.0, 180.0),
                };
            }
        }
    }

    /// The next random *long* line, of 700 mm or more: a chord of the reachable disc passing
    /// 55 to 100 mm from the shoulder, in a random direction, with a random Z and yaw at
    /// each end and a random posture; one the planner accepts.
    pub fn next_long_line(
        &mut self,
        robot: &Robot,
        mut refused: impl FnMut(&PlanError),
    ) -> LineCase {
        let arm = robot.arm();
        let reach = arm.link1_mm + arm.link2_mm - arm.singularity_margin_mm - 1.0;
        let (zlo, zhi) = arm
            .z
            .map_or((0.0, 0.0), |z| (robot.axes()[z].min, robot.axes()[z].max));
        loop {
            let d = self.uniform(55.0, 100.0);
            let theta = self.uniform(-180.0f64, 180.0).to_radians();
            let half = (reach * reach - d * d).sqrt();
            let (nx, ny) = (theta.cos(), theta.sin());
            let end = |s: f64, z: f64, yaw: f64| Pose {
                x: d * nx - s * ny,
                y: d * ny + s * nx,
                z,
                yaw,
            };
            let mut z = || {
                if zhi > zlo {
                    self.uniform(zlo, zhi)
                } else {
                    zlo
                }
            };
            let (z0, z1) = (z(), z());
            let start = end(-half, z0, self.uniform(-180.0, 180.0));
            let target = end(half, z1, self.uniform(-180.0, 180.0));
            let posture = self.posture();
            if let Some(case) = accept(robot, start, posture, target, &mut refused) {
                return case;
            }
        }
    }

    /// The next random line: both ends uniform (see [`Lines::pose`]), a random posture.
    /// `refused` is called with every candidate the planner refuses (an end out of reach or
    /// a point of the line beyond a limit); the line returned is one it accepts.
    pub fn next_line(&mut self, robot: &Robot, mut refused: impl FnMut(&PlanError)) -> LineCase {
        loop {
            let posture = self.posture();
            let start = self.pose(robot);
            let target = self.pose(robot);
            if let Some(case) = accept(robot, start, posture, target, &mut refused) {
                return case;
            }
        }
    }

    /// A posture, either with even odds.
    fn posture(&mut self) -> Posture {
        if self.next_u64() & 1 == 0 {
            Posture::Right
        } else {
            Posture::Left
        }
    }
}

/// The line from `start` (with `posture`) to `target` if the planner accepts it; `refused`
/// is told why it does not (nothing when the start itself is out of reach).
fn accept(
    robot: &Robot,
    start: Pose,
    posture: Posture,
    target: Pose,
    refused: &mut impl FnMut(&PlanError),
) -> Option<LineCase> {
    let joints = robot.inverse(&start, posture, None).ok()?;
    match check_line(robot, &joints, &target) {
        Ok(_) => Some(LineCase {
            start,
            posture,
            target,
        }),
        Err(e) => {
            refused(&e);
            None
        }
    }
}

/// The largest velocity, acceleration and jerk of each axis as a fraction of its limit
/// (scaled by the speed override): from the exact commanded positions, and from the output
/// pulses after allowing for their rounding.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LimitUse {
    /// max over axes of |v|/V, |a|/A, |j|/J from the unrounded positions.
    pub exact: [f64; 3],
    /// The same from the integer pulses, each difference reduced by the most its rounding
    /// can add (1, 2 and 4 pulses per period for v, a and j).
    pub pulses: [f64; 3],
}

impl LimitUse {
    /// Whether every figure is at most 1 (plus `tol`).
    pub fn within(&self, tol: f64) -> bool {
        self.exact
            .iter()
            .chain(&self.pulses)
            .all(|&x| x <= 1.0 + tol)
    }
}

/// One line, planned and run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineRun {
    /// The line.
    pub case: LineCase,
    /// Its length [mm].
    pub length_mm: f64,
    /// The planned duration [s].
    pub duration_s: f64,
    /// Periods it took.
    pub periods: u64,
    /// Wall time of `plan_line`, which checks the line and runs its timing law to the end
    /// (what `wrc plan` does) [s].
    pub plan_s: f64,
    /// Wall time of `start_line`, what the controller's Velocity Generator pays before the
    /// first pulse: the check of every point and the derivative table [s].
    pub start_s: f64,
    /// The longest `next_period` of the run (the law advancing as it runs) [s].
    pub period_max_s: f64,
    /// All `next_period` calls of the run together [s].
    pub periods_total_s: f64,
    /// Lower bounds at the same speed [s] (scaled by the override).
    pub bound: LineBound,
    /// Limits used.
    pub limits: LimitUse,
    /// Largest distance of the TCP from the segment over the periods, from the pulses [mm].
    pub deviation_mm: f64,
    /// Whether the pulses ended exactly on the target's.
    pub exact_end: bool,
}

impl LineRun {
    /// Duration over the lower bound of docs/motion.md, max(TOPP-RA v/a, TCP 1-D
    /// jerk-limited).
    pub fn ratio(&self) -> f64 {
        self.duration_s / self.bound.lower_bound_s()
    }
}

/// Plan and run `case` with a copy of `generator` (its robot and settings, any state); the
/// planner's error if it refuses the line.
pub fn run_line(generator: &VelocityGenerator, case: &LineCase) -> Result<LineRun, PlanError> {
    let mut vg = generator.clone();
    let (robot, settings) = (generator.robot(), generator.settings());
    let start = robot.inverse(&case.start, case.posture, None)?;
    let start_pulses = robot.joints_to_pulses(&start);
    vg.set_position_pulses(&start_pulses)?;
    // The line as the generator sees it: from the pulse-exact start.
    let from: Joints = robot.pulses_to_joints(&start_pulses);
    let a = robot.forward(&from);
    // Planned ahead (for the duration), on a copy; then started and run as the controller
    // does, timing each period.
    let mut ahead = vg.clone();
    let began = Instant::now();
    let info = ahead.plan_line(&case.target)?;
    let plan_s = began.elapsed().as_secs_f64();
    let began = Instant::now();
    vg.start_line(&case.target)?;
    let start_s = began.elapsed().as_secs_f64();
    let bound = line_bound(robot, &settings.line, &from, &case.target)?;
    let s = settings.speed_pct / 100.0;
    let bound = LineBound {
        topp_va_s: bound.topp_va_s / s,
        cartesian_jerk_s: bound.cartesian_jerk_s / s,
        joint_jerk_s: bound.joint_jerk_s / s,
    };
    let mut deviation = 0.0f64;
    let played = play(&mut vg, from, start_pulses, |tcp| {
        deviation = deviation.max(distance_to_segment(tcp, &a, &case.target));
    });
    // The target's pulses: the line's end joints, followed continuously from the start.
    let (_, check) = check_line(robot, &from, &case.target)?;
    let target = robot.joints_to_pulses(&check.end_joints);
    let exact_end = played.ended_at(&target, info.periods);
    let limits = limit_use(robot, settings, &played.exact, &played.pulses);
    let (period_max_s, periods_total_s) = (played.period_max_s, played.periods_total_s);
    Ok(LineRun {
        case: *case,
        length_mm: ((case.target.x - a.x).powi(2)
            + (case.target.y - a.y).powi(2)
            + (case.target.z - a.z).powi(2))
        .sqrt(),
        duration_s: info.duration_s,
        periods: info.periods,
        plan_s,
        start_s,
        period_max_s,
        periods_total_s,
        bound,
        limits,
        deviation_mm: deviation,
        exact_end,
    })
}

/// A move played period by period to its end, as the Pulse Generator takes it.
pub(crate) struct Played {
    /// The exact joints of each period, the start first.
    pub exact: Vec<Joints>,
    /// The pulse position after each period, the start first.
    pub pulses: Vec<[i64; MAX_AXES]>,
    /// How the move ended.
    pub end: MoveEnd,
    /// Wall time of the longest period and of all of them [s].
    pub period_max_s: f64,
    pub periods_total_s: f64,
}

impl Played {
    /// Completed exactly on `target`'s pulses in the `periods` it was planned to take.
    pub fn ended_at(&self, target: &[i64; MAX_AXES], periods: u64) -> bool {
        self.end == MoveEnd::Completed
            && self.pulses.last() == Some(target)
            && (self.pulses.len() - 1) as u64 == periods
    }
}

/// Run `vg`'s move under way to its end from `start_pulses` (the joints `from`), timing each
/// period; `each` sees the TCP after every period (from the pulses).
pub(crate) fn play(
    vg: &mut VelocityGenerator,
    from: Joints,
    start_pulses: [i64; MAX_AXES],
    mut each: impl FnMut(&Pose),
) -> Played {
    let robot = vg.robot().clone();
    let n = robot.axis_count();
    let mut played = Played {
        exact: vec![from],
        pulses: vec![start_pulses],
        end: MoveEnd::Completed,
        period_max_s: 0.0,
        periods_total_s: 0.0,
    };
    let mut period = Period::default();
    let mut position = start_pulses;
    while vg.is_moving() {
        let began = Instant::now();
        let status = vg.next_period(&mut period);
        let took = began.elapsed().as_secs_f64();
        played.period_max_s = played.period_max_s.max(took);
        played.periods_total_s += took;
        for (p, d) in position.iter_mut().zip(&period.pulses).take(n) {
            *p += d;
        }
        played.exact.push(period.exact);
        played.pulses.push(position);
        each(&robot.forward(&robot.pulses_to_joints(&position)));
        if let Status::Finished(e) = status {
            played.end = e;
        }
    }
    played
}

/// Distance of `p` from the segment a–b, in x, y and z [mm].
pub fn distance_to_segment(p: &Pose, a: &Pose, b: &Pose) -> f64 {
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

/// The limits used by a run, from its exact joint positions and its pulse positions (one
/// entry per period, the start first; rest before and after).
pub fn limit_use(
    robot: &Robot,
    settings: &MotionSettings,
    exact: &[Joints],
    pulses: &[[i64; MAX_AXES]],
) -> LimitUse {
    let ts = settings.period_s;
    let s = settings.speed_pct / 100.0;
    let mut out = LimitUse::default();
    for (ax, axis) in robot.axes().iter().enumerate() {
        let l = &axis.limits;
        let lim = [
            l.max_velocity * s,
            l.max_acceleration * s * s,
            l.max_jerk * s * s * s,
        ];
        let ppu = axis.pulses_per_unit;
        let exact_x: Vec<f64> = exact.iter().map(|q| q[ax]).collect();
        let pulse_x: Vec<f64> = pulses.iter().map(|p| p[ax] as f64 / ppu).collect();
        for (x, allowance, use_) in [
            (&exact_x, [0.0; 3], &mut out.exact),
            (&pulse_x, [1.0 / ppu, 2.0 / ppu, 4.0 / ppu], &mut out.pulses),
        ] {
            let peaks = derivative_peaks(x, ts);
            for k in 0..3 {
                let excess = (peaks[k] - allowance[k] / ts.powi(k as i32 + 1)).max(0.0);
                use_[k] = use_[k].max(excess / lim[k]);
            }
        }
    }
    out
}

/// Largest |first|, |second|, |third| finite difference of `x` (sampled every `ts` [s],
/// at rest before and after), per time unit.
fn derivative_peaks(x: &[f64], ts: f64) -> [f64; 3] {
    let first = *x.first().unwrap_or(&0.0);
    let last = *x.last().unwrap_or(&0.0);
    let mut padded = vec![first; 3];
    padded.extend_from_slice(x);
    padded.extend([last; 3]);
    let diff = |s: &[f64]| s.windows(2).map(|w| (w[1] - w[0]) / ts).collect::<Vec<_>>();
    let v = diff(&padded);
    let a = diff(&v);
    let j = diff(&a);
    let peak = |s: &[f64]| s.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    [peak(&v), peak(&a), peak(&j)]
}

/// Median and largest of `values` (NaN when empty).
pub fn median_max(values: &[f64]) -> (f64, f64) {
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let mid = v.len() / 2;
    let median = if v.len() % 2 == 0 {
        0.5 * (v[mid - 1] + v[mid])
    } else {
        v[mid]
    };
    (median, v[v.len() - 1])
}
