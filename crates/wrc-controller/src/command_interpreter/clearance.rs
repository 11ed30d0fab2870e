//! The cell as an obstacle for every motion (docs/motion.md, "The cell as an obstacle"):
//! before a motion is accepted, the Command Interpreter plays it on its own copy of the
//! Velocity Generator, period by period as the board will move the axes, and checks the
//! arm's bodies against the cell's solids ([`wrc_cell::obstacle`]) along it and along the
//! brake of a stop in any of its periods where that brake would leave the path. A PTP that
//! would touch goes round through the travel height ([`wrc_cell::obstacle::travel_routes`]),
//! a jog stops short, anything else is refused (`NAK 117`).
//!
//! Real-time: the generator's copy and the model's mailbox are made at start-up; a check
//! plans and plays the motion on them without allocating, blocking or printing. Its cost is
//! counted in joint vectors evaluated ([`CheckFigures`]) and measured by `make bench`.

use wrc_cell::obstacle::{CellModel, Contact, LineTolerance, Sweep, SweepContact};
use wrc_cell::MAX_BLADES;
use wrc_motion::{BrakeLimits, Period, VelocityGenerator as Generator};
use wrc_robot::{BladeLoad, Joints, Robot, MAX_AXES};
use wrc_rt::ipc::mailbox::MailboxReader;

use crate::messages::cell_job::CellView;
use crate::messages::MoveOrder;
use crate::velocity_generator::plan_order;

/// Where a motion would touch the cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    /// What touches what.
    pub contact: Contact,
    /// Where the arm is then [deg, mm].
    pub joints: Joints,
    /// How far into the motion, as a share of its periods (0 to 1).
    pub fraction: f64,
    /// On the brake of a stop at that point, not on the motion itself.
    pub brake: bool,
    /// Found walking the path's geometry ahead of period `fraction` (the walk's steps so
    /// far), not playing it; the fraction is made right at the end.
    walked: Option<u32>,
}

/// What the checks have cost so far.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CheckFigures {
    /// Motions checked (each leg of a route, each try of a shortened jog).
    pub checks: u64,
    /// Joint vectors evaluated against the cell (periods, bisections, brakes).
    pub evaluations: u64,
    /// The most in one check.
    pub max_evaluations: u64,
}

/// The Command Interpreter's cell check: a generator to play motions on and the cell it
/// reads from the cell service.
pub struct CellCheck {
    generator: Box<Generator>,
    view: MailboxReader<CellView>,
    offsets: [f64; MAX_BLADES],
    blades: usize,
    figures: CheckFigures,
}

/// The longest a checked motion may run, in periods (a guard against a plan that does not
/// end: 20 minutes at 10 ms).
const MAX_PERIODS: u64 = 120_000;

/// The steps of the TCP in which the geometry of a line or path is walked [mm]; the sweep
/// halves them where the arm comes near the cell.
const PATH_STEP_MM: f64 = 5.0;

impl CellCheck {
    /// A check playing motions on `generator` (a copy of the Velocity Generator's, same robot
    /// and settings) against the cell `view` publishes, for a hand with blades at `offsets`
    /// [mm] (the hand's, 0, first).
    pub fn new(generator: Generator, view: MailboxReader<CellView>, offsets: &[f64]) -> CellCheck {
        let mut o = [0.0; MAX_BLADES];
        for (d, s) in o.iter_mut().zip(offsets) {
            *d = *s;
        }
        CellCheck {
            generator: Box::new(generator),
            view,
            offsets: o,
            blades: offsets.len().clamp(1, MAX_BLADES),
            figures: CheckFigures::default(),
        }
    }

    /// What the checks have cost so far.
    pub fn figures(&self) -> CheckFigures {
        self.figures
    }

    /// The height the arm travels at through the cell, if any [mm].
    pub fn travel_z(&mut self, robot: &Robot, sensed: [bool; MAX_BLADES]) -> Option<f64> {
        let n = self.blades;
        let (view, blades) = read(&mut self.view, &self.offsets, n, sensed);
        view.model.travel_z(robot, &blades[..n])
    }

    /// What a body of the arm at `end` touches, of what it did not touch at `start` already
    /// (a motion may take the arm out of what a fault left it touching).
    pub fn target_touch(
        &mut self,
        robot: &Robot,
        start: &Joints,
        end: &Joints,
        sensed: [bool; MAX_BLADES],
    ) -> Option<Contact> {
        let n = self.blades;
        let (view, loads) = read(&mut self.view, &self.offsets, n, sensed);
        let blades = &loads[..n];
        let margin = view.model.settings().clearance_mm;
        let tol = LineTolerance::CONTROLLER;
        let (at_start, at_end) = (robot.bodies(start, blades), robot.bodies(end, blades));
        (0..view.model.len()).find_map(|i| {
            let c = view.model.contact_with(i, &at_end, blades, &tol, margin)?;
            let before = view.model.contact_with(i, &at_start, blades, &tol, margin);
            before.is_none().then_some(c)
        })
    }

    /// The way straight out of the station the hand at `pose` is inside, if it is inside
    /// one ([`CellView::retract_from`]).
    pub fn retract_from(
        &mut self,
        pose: &wrc_robot::Pose,
        careful: bool,
    ) -> Option<crate::messages::cell_job::RetractPlan> {
        self.view.read().retract_from(pose, careful)
    }

    /// Whether there is a cell to check against.
    pub fn active(&mut self) -> bool {
        !self.view.read().model.is_empty()
    }

    /// Play `order` from rest at `start` [pulse] and check it (see the module docs): `Ok`
    /// with the joints where it ends, or where it would first touch the cell. A motion the
    /// generator refuses to plan is let through (the Velocity Generator refuses it with its
    /// own code). Solids the arm touches already at `start` are not held against it: a
    /// motion may take out an arm a fault (or a board that braked on its own) left touching
    /// something, as an operator must.
    // The touch is returned by value on purpose: boxing it would allocate.
    #[allow(clippy::result_large_err)]
    pub fn check(
        &mut self,
        robot: &Robot,
        order: &MoveOrder,
        start: &[i64; MAX_AXES],
        sensed: [bool; MAX_BLADES],
    ) -> Result<Joints, Touch> {
        let n = self.blades;
        let (view, loads) = read(&mut self.view, &self.offsets, n, sensed);
        let blades = &loads[..n];
        let model: &CellModel = &view.model;
        let start_joints = robot.pulses_to_joints(start);
        if model.is_empty() {
            return Ok(start_joints);
        }
        let margin = model.settings().clearance_mm;
        let tol = LineTolerance::CONTROLLER;
        let g = &mut self.generator;
        g.abandon_at(start);
        let mut sweep = Sweep::new(model, robot, blades, tol, margin);
        let mut evaluations = 0u64;
        let result = (|| {
            if sweep.to(&start_joints).is_err() {
                sweep.ignore_touched();
            }
            match plan_order(g, order) {
                Ok(true) => {}
                Ok(false) | Err(_) => return Ok(start_joints),
            }
            let levers = *model.levers();
            let (mut before, mut last) = (start_joints, start_joints);
            let mut period = Period::default();
            let mut k = 0u64;
            let period_s = g.settings().period_s;
            while g.is_moving() && k < MAX_PERIODS {
                // What is left of a line or a path with nothing after it is its geometry
                // alone: walked in steps of the TCP, not played period by period.
                let mut found = None;
                let mut walked = 0u32;
                let walk = g.walk_path_ahead(PATH_STEP_MM, &mut |q| {
                    walked += 1;
                    match sweep.to(q) {
                        Ok(()) => {
                            last = *q;
                            true
                        }
                        Err(c) => {
                            found = Some(c);
                            false
                        }
                    }
                });
                match (walk, found) {
                    (Some(_), Some(c)) => {
                        let mut t = touch(c, k as f64, false);
                        t.walked = Some(walked);
                        return Err(t);
                    }
                    (Some(_), None) => return Ok(last),
                    (None, _) => {}
                }
                // A stop in this period brakes from the state after the last one.
                if !g.state().brakes_on_path() {
                    let room = sweep.min_clearance() - margin;
                    let reach = brake_reach(robot, &levers, &before, &last, period_s);
                    if room <= reach {
                        let at = g.state();
                        // STOP's brake is ESTOP's at full speed.
                        let kinds = if order.speed_pct >= 100.0 { 1 } else { 2 };
                        for limits in [BrakeLimits::Full, BrakeLimits::Override]
                            .into_iter()
                            .take(kinds)
                        {
                            let mut brake = sweep;
                            let base = brake.evaluations();
                            brake.restart();
                            let _ = brake.to(&last);
                            g.stop(limits);
                            let mut n = 0;
                            while g.is_moving() && n < MAX_PERIODS {
                                g.next_period(&mut period);
                                n += 1;
                                if let Err(c) = brake.to(&g.joints()) {
                                    evaluations += brake.evaluations() - base;
                                    g.restore(&at);
                                    return Err(touch(c, k as f64, true));
                                }
                            }
                            evaluations += brake.evaluations() - base;
                            g.restore(&at);
                        }
                    }
                }
                g.next_period(&mut period);
                k += 1;
                before = last;
                last = g.joints();
                if let Err(c) = sweep.to(&last) {
                    return Err(touch(c, k as f64, false));
                }
            }
            Ok(last)
        })();
        evaluations += sweep.evaluations();
        // The share of the motion: the periods so far over the motion's whole.
        let result = result.map_err(|mut t| {
            let done = t.fraction;
            let mut period = Period::default();
            let mut total = done as u64;
            while self.generator.is_moving() && total < MAX_PERIODS {
                self.generator.next_period(&mut period);
                total += 1;
            }
            t.fraction = if total == 0 {
                0.0
            } else if let Some(steps) = t.walked {
                // How far along the walk, of the periods left when it began.
                let mut rest = 0u32;
                self.generator.abandon_at(start);
                let _ = plan_order(&mut self.generator, order);
                for _ in 0..done as u64 {
                    self.generator.next_period(&mut period);
                }
                let _ = self.generator.walk_path_ahead(PATH_STEP_MM, &mut |_| {
                    rest += 1;
                    true
                });
                let share = f64::from(steps) / f64::from(rest.max(1));
                (done + share * (total as f64 - done)) / total as f64
            } else {
                done / total as f64
            };
            t
        });
        self.generator.abandon_at(start);
        let f = &mut self.figures;
        f.checks += 1;
        f.evaluations += evaluations;
        f.max_evaluations = f.max_evaluations.max(evaluations);
        result
    }
}

fn touch(c: SweepContact, fraction: f64, brake: bool) -> Touch {
    Touch {
        contact: c.contact,
        joints: c.joints,
        fraction,
        brake,
        walked: None,
    }
}

/// How far any point of the arm may go in a stop from the state at `last` (after `before`,
/// one period of `period_s` [s] earlier) with every axis's full limits [mm]: a bound on each
/// axis's jerk-limited stopping distance from its velocity and acceleration, times its lever.
fn brake_reach(
    robot: &Robot,
    levers: &[f64; MAX_AXES],
    before: &Joints,
    last: &Joints,
    period_s: f64,
) -> f64 {
    robot
        .axes()
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let (amax, jmax) = (a.limits.max_acceleration, a.limits.max_jerk);
            // The period's mean velocity lags the state's by up to a period of full
            // acceleration, and the brake's first jerk ramp adds up to amax²/2J more before
            // it decelerates; from there a full brake with its two jerk ramps.
            let v = ((last[i] - before[i]) / period_s).abs()
                + amax * period_s
                + amax * amax / (2.0 * jmax);
            let t = 2.0 * amax / jmax + v / amax;
            v * t * levers[i]
        })
        .sum()
}

/// The cell as published and the blades as the checks see them (the first `n`, at heights
/// `offsets`): a wafer where the map has one (certain or not) or the vacuum sensor senses
/// one. One read: the blades and the solids come from the same publication.
fn read<'a>(
    view: &'a mut MailboxReader<CellView>,
    offsets: &[f64; MAX_BLADES],
    n: usize,
    sensed: [bool; MAX_BLADES],
) -> (&'a CellView, [BladeLoad; MAX_BLADES]) {
    let view = view.read();
    let mut out = [BladeLoad::default(); MAX_BLADES];
    for (b, blade) in out.iter_mut().enumerate().take(n) {
        *blade = BladeLoad {
            z_offset_mm: offsets[b],
            wafer: view.wafers[b] || sensed[b],
        };
    }
    (view, out)
}
