//! Velocity Generator task (Table 1: priority 30, 50 ms): takes move orders from the Command
//! Interpreter, plans them with `wrc-motion` (PTP, straight line, path, the blends between
//! PTP and Cartesian moves, jog; accel/decel at the order's speed and acceleration
//! overrides, IK for lines and paths) and fills the per-period pulse ring for the Pulse
//! Generator, a little more than one of its own periods ahead. After a stop it drops its plan and resumes from the state the
//! Pulse Generator brought to rest.
//!
//! Real-time promise: planning and producing periods do not allocate (`wrc-motion`
//! guarantees it); the cycle does not block or print. A straight line costs its check
//! before the first pulse and its timing law as the periods are produced (docs/motion.md
//! gives both budgets, measured by `wrc bench motion`).

use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_motion::{
    EntryRule, MotionState, Period, PlanError, Status, VelocityGenerator as Generator,
};
use wrc_robot::KinematicsError;
use wrc_rt::ipc::mailbox::MailboxReader;
use wrc_rt::ipc::queue::MessageQueue;
use wrc_rt::ipc::spsc::SpscSender;
use wrc_rt::{CycleContext, Task};

use crate::messages::{Batch, MoveDone, MoveKind, MoveOrder, MoveOutcome};
use crate::shared::Shared;

/// Protocol code numbers for moves refused at planning time (see docs/protocol.md).
pub mod refusal {
    /// Target out of reach.
    pub const OUT_OF_REACH: u16 = 111;
    /// A joint would leave its limits.
    pub const JOINT_LIMIT: u16 = 112;
    /// The straight line or path leaves the workspace, needs a posture change, is
    /// malformed (an arc on a line, a sharp corner without a blend zone, …) or does not
    /// start where the robot is.
    pub const PATH: u16 = 113;
    /// Any other planning failure.
    pub const OTHER: u16 = 199;
}

/// Map a planning error to a protocol code number.
pub fn refusal_code(err: &PlanError) -> u16 {
    match err {
        PlanError::Kinematics(KinematicsError::JointLimit { .. })
        | PlanError::JogBeyondLimit { .. } => refusal::JOINT_LIMIT,
        PlanError::Kinematics(_) => refusal::OUT_OF_REACH,
        PlanError::PathLeavesWorkspace { .. }
        | PlanError::SegmentLeavesWorkspace { .. }
        | PlanError::PostureChange
        | PlanError::ApproachCrossesEntry
        | PlanError::Untimed { .. }
        | PlanError::PathSegments { .. }
        | PlanError::Arc { .. }
        | PlanError::SegmentTooShort { .. }
        | PlanError::BlendZone { .. }
        | PlanError::SharpCorner { .. }
        | PlanError::CornerTurnsBack { .. }
        | PlanError::NotOnPath { .. } => refusal::PATH,
        _ => refusal::OTHER,
    }
}

/// Plan `order` on `g` from where it stands, as the Velocity Generator task does (the
/// Command Interpreter's cell check plays the same on its own copy): whether anything moves.
/// A line's timing law is computed as its periods are produced (wrc-motion's `start_line`),
/// not all before the first one. Allocation-free.
pub fn plan_order(g: &mut Generator, order: &MoveOrder) -> Result<bool, PlanError> {
    g.set_speed_pct(order.speed_pct)?;
    g.set_accel_pct(order.accel_pct)?;
    match order.kind {
        MoveKind::Joints(j) => g.plan_ptp(&j).map(|i| i.periods > 0),
        MoveKind::Pose(p, posture) => g.plan_ptp_pose(&p, posture).map(|i| i.periods > 0),
        MoveKind::Line(p) => g.start_line(&p),
        MoveKind::Approach { via, to, line_pct } => g.plan_approach(&via, &to, line_pct),
        MoveKind::Path(path) => g.start_path(&path),
        MoveKind::PtpToPath {
            via,
            path,
            path_pct,
        } => g.plan_ptp_into(&via, &path, path_pct, EntryRule::Free),
        MoveKind::Depart { path, to, path_pct } => g.plan_depart(&path, &to, path_pct),
        MoveKind::Via { start, via, to } => g.plan_ptp_via(&start, &via, &to),
        MoveKind::Jog { axis, pulses } => g.plan_jog(axis, pulses).map(|i| i.periods > 0),
    }
}

/// The Velocity Generator.
pub struct VelocityGenerator {
    generator: Generator,
    orders: Arc<MessageQueue<MoveOrder>>,
    ring: SpscSender<Batch>,
    shared: Arc<Shared>,
    done: Arc<MessageQueue<MoveDone>>,
    resume: MailboxReader<MotionState>,
    epoch: u32,
    resyncing: bool,
    ticket: u32,
    held: Option<MoveOrder>,
}

impl VelocityGenerator {
    /// A Velocity Generator starting from `generator`'s state.
    pub fn new(
        generator: Generator,
        orders: Arc<MessageQueue<MoveOrder>>,
        ring: SpscSender<Batch>,
        shared: Arc<Shared>,
        done: Arc<MessageQueue<MoveDone>>,
        resume: MailboxReader<MotionState>,
    ) -> Self {
        let epoch = shared.stop_epoch.load(Ordering::Acquire);
        VelocityGenerator {
            generator,
            orders,
            ring,
            shared,
            done,
            resume,
            epoch,
            resyncing: false,
            ticket: 0,
            held: None,
        }
    }

    fn report(&self, ticket: u32, outcome: MoveOutcome) {
        let _ = self.done.try_send(MoveDone { ticket, outcome });
    }

    /// Start the next order, if any; false when there is none.
    fn start_next(&mut self) -> bool {
        loop {
            let Some(order) = self.held.take().or_else(|| self.orders.try_recv().ok()) else {
                return false;
            };
            let age = self.epoch.wrapping_sub(order.epoch) as i32;
            if age > 0 {
                continue; // ordered before a stop that cancelled it
            }
            if age < 0 {
                // Ordered after a stop this task has not seen yet: keep it for the cycle
                // that has resynchronised with the Pulse Generator.
                self.held = Some(order);
                return false;
            }
            let planned = plan_order(&mut self.generator, &order);
            match planned {
                Ok(false) => self.report(order.ticket, MoveOutcome::Completed),
                Ok(true) => {
                    self.ticket = order.ticket;
                    return true;
                }
                Err(e) => self.report(order.ticket, MoveOutcome::Refused(refusal_code(&e))),
            }
        }
    }

    /// One cycle (public for tests that step the task by hand).
    pub fn step(&mut self) {
        let epoch = self.shared.stop_epoch.load(Ordering::Acquire);
        if epoch != self.epoch {
            // A stop: the Pulse Generator decelerates from where it is; wait for it.
            self.epoch = epoch;
            self.resyncing = true;
            self.ticket = 0;
        }
        if self.resyncing {
            if self.shared.stopped_epoch.load(Ordering::Acquire) != self.epoch {
                return;
            }
            let state = *self.resume.read();
            self.generator.restore(&state);
            self.resyncing = false;
        }
        let mut period = Period::default();
        // Before the first batch: a Pulse Generator that sees one sees this too.
        self.shared.vg_filling.store(true, Ordering::Relaxed);
        while self.ring.free_slots() > 0 {
            if !self.generator.is_moving() && !self.start_next() {
                break;
            }
            let status = self.generator.next_period(&mut period);
            let batch = Batch {
                pulses: period.pulses,
                epoch: self.epoch,
                ticket: self.ticket,
                last: matches!(status, Status::Finished(_)),
                after: self.generator.state(),
            };
            // free_slots() > 0 was checked, and this task is the ring's only producer.
            let _ = self.ring.try_send(batch);
        }
        self.shared.vg_filling.store(false, Ordering::Release);
    }
}

impl Task for VelocityGenerator {
    /// Released by its period or by a new order (the order queue notifies it), so a motion
    /// is planned at once and its first pulse goes out in the next Pulse Generator period.
    fn cycle(&mut self, _ctx: &CycleContext) {
        self.step();
    }
}
