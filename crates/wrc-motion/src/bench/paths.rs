//! Arcs, blended paths and PTP blends for `wrc bench motion`: random reachable arcs and
//! paths of lines and arcs with blended corners (fixed seed), each planned and run as the
//! controller runs it, its duration compared with the lower bounds of
//! [`crate::reference::path_bound`], the limits it used and the TCP's distance from the path
//! checked from the output pulses, and the planning costs timed; and the PTP blends (into a
//! path, out of one, through a via point) against the same moves at rest between them. Not
//! used by the controller; this module allocates.

use std::time::Instant;

use wrc_robot::{Joints, Pose, Posture, Robot};

use crate::curve::Curve;
use crate::error::{PathPlace, PlanError};
use crate::generator::{EntryRule, MoveEnd, Period, Status, VelocityGenerator};
use crate::geometry::check_path;
use crate::path_spec::{PathSegment, PathSpec};
use crate::reference::{path_bound, LineBound};
use crate::search::SearchStats;

use super::{limit_use, LimitUse, Lines};

/// The geometry of a composite path, to measure how far the TCP is from it.
#[derive(Debug, Clone)]
pub struct PathProbe {
    curve: Curve,
    spec: PathSpec,
}

/// How far a TCP pose is from a path ([`PathProbe::distance`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathDistance {
    /// Distance from the nearest point of the path, in x, y and z [mm].
    pub off_mm: f64,
    /// Where that point is: a segment, or the blend after it.
    pub place: PathPlace,
    /// The path's parameter there, 0 to 1 (close to the fraction of its length).
    pub u: f64,
    /// In a blend: the pose's distance from that blend's corner point (the end of the
    /// segment before it), in x, y and z [mm].
    pub from_corner_mm: Option<f64>,
}

impl PathProbe {
    /// The path of `spec` for `robot` (refused as the generator refuses it).
    pub fn new(robot: &Robot, spec: &PathSpec) -> Result<PathProbe, PlanError> {
        Ok(PathProbe {
            curve: Curve::build(spec, robot.arm().wrist.is_some())?,
            spec: *spec,
        })
    }

    /// How far `p` is from the path.
    pub fn distance(&self, p: &Pose) -> PathDistance {
        let (off_mm, u) = self.curve.nearest(p);
        let place = self.curve.place(u);
        let from_corner_mm = place.blend.then(|| {
            let c = self.spec.segments[usize::from(place.segment) - 1].to();
            (p.x - c.x).hypot(p.y - c.y).hypot(p.z - c.z)
        });
        PathDistance {
            off_mm,
            place,
            u,
            from_corner_mm,
        }
    }

    /// The pose at the path's parameter u in [0, 1] (close to the fraction of its length).
    pub fn pose_at(&self, u: f64) -> Pose {
        self.curve.pose_at(u)
    }

    /// The path's length along its parameter [mm] (the arc length on lines and arcs, close
    /// to it on blends).
    pub fn length_mm(&self) -> f64 {
        self.curve.total()
    }
}

/// A path to try: `spec`, from its start reached with `posture`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathCase {
    /// The path.
    pub spec: PathSpec,
    /// Elbow posture at its start (kept along it).
    pub posture: Posture,
}

impl Lines {
    /// The next random arc the planner accepts: a circle centred within 70 % of the reach,
    /// of 30 to 200 mm radius, swept 30° to 300° either way, the via point between a
    /// quarter and three quarters of the sweep, a random Z at each end, a random yaw that
    /// turns up to 90°, a random posture. `refused` is told why a candidate is refused.
    pub fn next_arc(&mut self, robot: &Robot, mut refused: impl FnMut(&PlanError)) -> PathCase {
        let arm = robot.arm();
        let reach = arm.link1_mm + arm.link2_mm;
        loop {
            let (cx, cy) = loop {
                let (x, y) = (
                    self.uniform(-0.7 * reach, 0.7 * reach),
                    self.uniform(-0.7 * reach, 0.7 * reach),
                );
                if x.hypot(y) <= 0.7 * reach {
                    break (x, y);
                }
            };
            let r = self.uniform(30.0, 200.0);
            let th0 = self.uniform(-180.0f64, 180.0).to_radians();
            let sweep = self.uniform(30.0f64, 300.0).to_radians()
                * if self.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
            let at = |th: f64, z: f64, yaw: f64| Pose {
                x: cx + r * th.cos(),
                y: cy + r * th.sin(),
                z,
                yaw,
            };
            let (z0, z1) = (self.z(robot), self.z(robot));
            let yaw0 = self.uniform(-180.0, 180.0);
            let yaw1 = yaw0 + self.uniform(-90.0, 90.0);
            let start = at(th0, z0, yaw0);
            let via = at(th0 + sweep * self.uniform(0.25, 0.75), z0, yaw0);
            let mut spec = PathSpec::new(start);
            let _ = spec.push(PathSegment::Arc {
                via,
                to: at(th0 + sweep, z1, yaw1),
                blend_mm: 0.0,
            });
            let posture = self.posture();
            if let Some(case) = accept_path(robot, spec, posture, &mut refused) {
                return case;
            }
        }
    }

    /// The next random path of 2 to 5 segments the planner accepts, from a random start:
    /// each a line (70 %) or an arc (30 %) to a point 80 to 250 mm away in a random
    /// direction (an arc's via point off its chord by 20 to 70 % of it, either side), a
    /// random Z, the yaw turning up to 60° per segment, every corner blended over 2 to 40 mm.
    pub fn next_path(&mut self, robot: &Robot, mut refused: impl FnMut(&PlanError)) -> PathCase {
        loop {
            let posture = self.posture();
            let start = self.pose(robot);
            let mut spec = PathSpec::new(start);
            let n = 2 + (self.next_u64() % 4) as usize;
            let mut at = start;
            for _ in 0..n {
                let dir = self.uniform(-180.0f64, 180.0).to_radians();
                let len = self.uniform(80.0, 250.0);
                let to = Pose {
                    x: at.x + len * dir.cos(),
                    y: at.y + len * dir.sin(),
                    z: self.z(robot),
                    yaw: at.yaw + self.uniform(-60.0, 60.0),
                };
                let blend_mm = self.uniform(2.0, 40.0);
                let segment = if self.uniform(0.0, 1.0) < 0.3 {
                    let off = self.uniform(0.2, 0.7)
                        * len
                        * if self.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
                    PathSegment::Arc {
                        via: Pose {
                            x: 0.5 * (at.x + to.x) - off * dir.sin(),
                            y: 0.5 * (at.y + to.y) + off * dir.cos(),
                            ..to
                        },
                        to,
                        blend_mm,
                    }
                } else {
                    PathSegment::Line { to, blend_mm }
                };
                let _ = spec.push(segment);
                at = to;
            }
            if let Some(case) = accept_path(robot, spec, posture, &mut refused) {
                return case;
            }
        }
    }

    /// A Z uniform over the robot's range (0 without a Z axis).
    fn z(&mut self, robot: &Robot) -> f64 {
        match robot.arm().z {
            Some(z) => {
                let a = &robot.axes()[z];
                self.uniform(a.min, a.max)
            }
            None => 0.0,
        }
    }
}

/// The path if the planner accepts it from its start with `posture`; `refused` is told why
/// it does not (nothing when the start itself is out of reach).
fn accept_path(
    robot: &Robot,
    spec: PathSpec,
    posture: Posture,
    refused: &mut impl FnMut(&PlanError),
) -> Option<PathCase> {
    let joints = robot.inverse(&spec.start, posture, None).ok()?;
    match check_path(robot, &joints, &spec) {
        Ok(_) => Some(PathCase { spec, posture }),
        Err(e) => {
            refused(&e);
            None
        }
    }
}

/// One path, planned and run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathRun {
    /// The path.
    pub case: PathCase,
    /// Its length along its parameter [mm].
    pub length_mm: f64,
    /// The planned duration [s].
    pub duration_s: f64,
    /// Wall time of `plan_path` (the check and the whole law run ahead) [s].
    pub plan_s: f64,
    /// Wall time of `start_path`, what the controller's Velocity Generator pays before the
    /// first pulse: the path built, every point checked, the derivative table [s].
    pub start_s: f64,
    /// The longest `next_period` of the run [s].
    pub period_max_s: f64,
    /// All `next_period` calls of the run together [s].
    pub periods_total_s: f64,
    /// Lower bounds at the same speed [s] (scaled by the override).
    pub bound: LineBound,
    /// Limits used (every joint's; from the exact positions and from the pulses).
    pub limits: LimitUse,
    /// Largest distance of the TCP from the path over the periods, from the pulses [mm].
    pub deviation_mm: f64,
    /// Largest distance of the TCP from a blend's corner point while in that blend, over
    /// the blend's zone (≤ 1: within the zone; 0 without blends).
    pub zone_use: f64,
    /// Whether the pulses ended exactly on the path's end joints.
    pub exact_end: bool,
}

impl PathRun {
    /// Duration over the lower bound, max(TOPP-RA v/a, TCP 1-D jerk-limited).
    pub fn ratio(&self) -> f64 {
        self.duration_s / self.bound.lower_bound_s()
    }
}

/// A generator like `generator` (robot and settings) standing at the joints `at`.
fn standing(generator: &VelocityGenerator, at: &Joints) -> VelocityGenerator {
    let mut vg = generator.clone();
    vg.abandon_at(&vg.robot().joints_to_pulses(at));
    vg
}

/// The joints of `case`'s start.
fn start_joints(robot: &Robot, case: &PathCase) -> Result<Joints, PlanError> {
    Ok(robot.inverse(&case.spec.start, case.posture, None)?)
}

/// Plan and run `case` with a copy of `generator` (its robot and settings).
pub fn run_path(generator: &VelocityGenerator, case: &PathCase) -> Result<PathRun, PlanError> {
    let (robot, settings) = (generator.robot(), generator.settings());
    let start = start_joints(robot, case)?;
    let mut vg = standing(generator, &start);
    let from = vg.joints();
    let spec = &case.spec;
    let mut ahead = vg.clone();
    let began = Instant::now();
    let info = ahead.plan_path(spec)?;
    let plan_s = began.elapsed().as_secs_f64();
    let began = Instant::now();
    vg.start_path(spec)?;
    let start_s = began.elapsed().as_secs_f64();
    let bound = path_bound(robot, &settings.line, &from, spec)?;
    let s = settings.speed_pct / 100.0;
    let bound = LineBound {
        topp_va_s: bound.topp_va_s / s,
        cartesian_jerk_s: bound.cartesian_jerk_s / s,
        joint_jerk_s: bound.joint_jerk_s / s,
    };
    let probe = PathProbe::new(robot, spec)?;
    let start_pulses = *vg.position_pulses();
    let (mut deviation, mut zone_use) = (0.0f64, 0.0f64);
    let played = super::play(&mut vg, from, start_pulses, |tcp| {
        let d = probe.distance(tcp);
        deviation = deviation.max(d.off_mm);
        if let Some(c) = d.from_corner_mm {
            let zone = spec.segments[usize::from(d.place.segment) - 1].blend_mm();
            let zone = if zone > 0.0 {
                zone
            } else {
                crate::curve::TANGENT_ZONE_MM
            };
            zone_use = zone_use.max(c / zone);
        }
    });
    let target = robot.joints_to_pulses(&check_path(robot, &from, spec)?.end_joints);
    Ok(PathRun {
        case: *case,
        length_mm: probe.length_mm(),
        duration_s: info.duration_s,
        plan_s,
        start_s,
        period_max_s: played.period_max_s,
        periods_total_s: played.periods_total_s,
        bound,
        limits: limit_use(robot, settings, &played.exact, &played.pulses),
        deviation_mm: deviation,
        zone_use,
        exact_end: played.ended_at(&target, info.periods),
    })
}

/// How the controller's Velocity Generator produces a move's periods: planning and
/// `first` periods in the cycle that takes the order (it fills the pulse ring), then `then`
/// periods in each of its later cycles (one of its periods' worth).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cycles {
    /// Periods produced in the cycle that plans the move.
    pub first: usize,
    /// Periods produced in each later cycle.
    pub then: usize,
}

/// A blended move against the same moves at rest between them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlendRun {
    /// The blended move's duration, from its periods [s].
    pub blended_s: f64,
    /// The moves at rest between them, from their periods [s].
    pub apart_s: f64,
    /// Wall time of planning the blended move (every candidate before the first pulse) [s].
    pub plan_s: f64,
    /// Wall time of the busiest Velocity Generator cycle of the move ([`Cycles`]): planning
    /// and the first periods, or a later cycle's periods (one of them may decide how a path
    /// leaves for a PTP) [s].
    pub cycle_max_s: f64,
    /// Wall time of the longest single period [s].
    pub period_max_s: f64,
    /// Wall time of the period in which a search ran, if one did after planning (a path
    /// into a PTP deciding at its junction how it leaves) [s].
    pub search_period_s: Option<f64>,
    /// What the blend's search did: its work and whether it ran out of its budget.
    pub search: SearchStats,
    /// Whether it ended exactly on its target's pulses, within every limit.
    pub exact_end: bool,
    /// Limits used.
    pub limits: LimitUse,
}

impl BlendRun {
    /// Blended over apart.
    pub fn ratio(&self) -> f64 {
        self.blended_s / self.apart_s
    }
}

/// A move run to its end ([`play`]).
struct Played {
    /// Periods it took.
    periods: u64,
    /// The exact joints and the pulses of each period (the start first).
    exact: Vec<Joints>,
    pulses: Vec<[i64; wrc_robot::MAX_AXES]>,
    /// Whether it completed.
    completed: bool,
    /// Wall time of each period [s].
    took: Vec<f64>,
    /// Wall time of the last period in which the generator's blend search ran [s].
    search_period: Option<f64>,
}

/// Run the move planned in `vg` to its end.
fn play(vg: &mut VelocityGenerator) -> Played {
    let mut out = Period::default();
    let (mut exact, mut pulses) = (vec![vg.joints()], vec![*vg.position_pulses()]);
    let mut completed = true;
    let mut took = Vec::new();
    let mut search_period = None;
    while vg.is_moving() {
        let searches = vg.search_stats().searches;
        let began = Instant::now();
        let status = vg.next_period(&mut out);
        let elapsed = began.elapsed().as_secs_f64();
        took.push(elapsed);
        if vg.search_stats().searches != searches {
            search_period = Some(elapsed);
        }
        if let Status::Finished(end) = status {
            completed = end == MoveEnd::Completed;
        }
        exact.push(out.exact);
        pulses.push(*vg.position_pulses());
    }
    Played {
        periods: (pulses.len() - 1) as u64,
        exact,
        pulses,
        completed,
        took,
        search_period,
    }
}

/// Which PTP blend [`run_blend`] measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Blend {
    /// From the joints `from`, a PTP into the case's path (`plan_ptp_into`, no station rule),
    /// against the PTP to its start and the path.
    Into {
        /// Where the PTP starts.
        from: Joints,
    },
    /// The case's path into a PTP to the joints `to` (`plan_depart`), against the path and
    /// the PTP.
    Depart {
        /// Where the PTP ends.
        to: Joints,
    },
    /// From the case's start, a PTP through the joints `via` to the joints `to`
    /// (`plan_ptp_via`), against the two PTPs.
    Via {
        /// The via point.
        via: Joints,
        /// Where it ends.
        to: Joints,
    },
}

/// Plan and run a PTP blend on `case` with a copy of `generator` (its robot, settings and
/// [`crate::BlendSearch`]), its periods produced in the Velocity Generator's `cycles`, and
/// the same moves at rest between them.
pub fn run_blend(
    generator: &VelocityGenerator,
    case: &PathCase,
    blend: Blend,
    cycles: Cycles,
) -> Result<BlendRun, PlanError> {
    let robot = generator.robot();
    let ts = generator.settings().period_s;
    let pct = generator.speed_pct();
    let start = start_joints(robot, case)?;
    let spec = &case.spec;
    let (mut vg, mut apart) = match blend {
        Blend::Into { from } => (standing(generator, &from), standing(generator, &from)),
        Blend::Depart { .. } | Blend::Via { .. } => {
            (standing(generator, &start), standing(generator, &start))
        }
    };
    let began = Instant::now();
    let target = match blend {
        Blend::Into { .. } => {
            vg.plan_ptp_into(&start, spec, pct, EntryRule::Free)?;
            None
        }
        Blend::Depart { to } => {
            vg.plan_depart(spec, &to, pct)?;
            Some(to)
        }
        Blend::Via { via, to } => {
            let here = vg.joints();
            vg.plan_ptp_via(&here, &via, &to)?;
            Some(to)
        }
    };
    let plan_s = began.elapsed().as_secs_f64();
    let played = play(&mut vg);
    let end = *vg.position_pulses();
    let first = played.took.len().min(cycles.first);
    let cycle_max_s = played.took[first..]
        .chunks(cycles.then.max(1))
        .map(|c| c.iter().sum::<f64>())
        .fold(plan_s + played.took[..first].iter().sum::<f64>(), f64::max);
    // The same moves, one after the other, from rest to rest.
    let mut apart_periods = 0;
    let steps = match blend {
        Blend::Into { .. } => [MoveStep::Ptp(start), MoveStep::Path],
        Blend::Depart { to } => [MoveStep::Path, MoveStep::Ptp(to)],
        Blend::Via { via, to } => [MoveStep::Ptp(via), MoveStep::Ptp(to)],
    };
    for step in steps {
        match step {
            MoveStep::Ptp(q) => {
                apart.plan_ptp(&q)?;
            }
            MoveStep::Path => {
                apart.start_path(spec)?;
            }
        }
        apart_periods += play(&mut apart).periods;
    }
    let exact_end = played.completed
        && end == *apart.position_pulses()
        && target.is_none_or(|t| end == robot.joints_to_pulses(&t));
    Ok(BlendRun {
        blended_s: played.periods as f64 * ts,
        apart_s: apart_periods as f64 * ts,
        plan_s,
        cycle_max_s,
        period_max_s: played.took.iter().copied().fold(0.0, f64::max),
        search_period_s: played.search_period,
        search: vg.search_stats(),
        exact_end,
        limits: limit_use(robot, generator.settings(), &played.exact, &played.pulses),
    })
}

/// One of the moves a blend is compared with.
#[derive(Debug, Clone, Copy)]
enum MoveStep {
    Ptp(Joints),
    Path,
}

/// Random joints of a reachable pose with `posture` (for the other end of a blend).
pub fn random_joints(lines: &mut Lines, robot: &Robot, posture: Posture) -> Joints {
    loop {
        let pose = lines.pose(robot);
        if let Ok(q) = robot.inverse(&pose, posture, None) {
            return q;
        }
    }
}
