//! Error Check's overrun policy: a stall of a watched (motion-path) task longer than the
//! buffer after it covers stops a motion, shorter ones (at any rate) do not, stalls at rest
//! stop nothing, and without watched tasks (not real-time) nothing does. A fault the urgent
//! queue has no room for is reported when it has.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

use wrc_board::{DpramBoard, Expect, Fault, Mapping};
use wrc_board_sim::{SimBoard, SimSettings};
use wrc_config::Config;
use wrc_controller::error_check::{ErrorCheck, Limits, Watched};
use wrc_controller::messages::{SourceId, Urgent};
use wrc_controller::shared::{RobotState, Shared};
use wrc_protocol::Code;
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::stats::CycleSample;
use wrc_rt::StatsCell;

struct Rig {
    sim: SimBoard,
    ec: ErrorCheck<DpramBoard>,
    shared: Arc<Shared>,
    urgent: Arc<MessageQueue<Urgent>>,
    cell: Arc<StatsCell>,
    owner_lost: Arc<AtomicBool>,
}

fn rig(watched: bool) -> Rig {
    let config = Config::embedded_default();
    let settings = SimSettings::from_config(&config, &config.boards[0]);
    let mapping = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(mapping.share(), &settings, 1).unwrap();
    sim.step();
    let board = DpramBoard::attach(mapping, Expect::default()).unwrap();
    let shared = Arc::new(Shared::default());
    let urgent = Arc::new(MessageQueue::new(8));
    let cell = Arc::new(StatsCell::new());
    let stats = Arc::new(OnceLock::new());
    if watched {
        // A 10 ms task whose buffer covers 20 ms (the Pulse Generator's look-ahead).
        let _ = stats.set(vec![Watched {
            cell: cell.clone(),
            period_ns: 10_000_000,
            tolerance_ns: 20_000_000,
        }]);
    }
    let owner_lost = Arc::new(AtomicBool::new(false));
    let ec = ErrorCheck::new(
        board,
        config.robot.axes().len(),
        shared.clone(),
        urgent.clone(),
        Arc::new(Semaphore::new(0)),
        Limits::for_robot(&config.robot),
        owner_lost.clone(),
        stats,
    );
    Rig {
        sim,
        ec,
        shared,
        urgent,
        cell,
        owner_lost,
    }
}

impl Rig {
    /// `times` late cycles, each skipping `missed` periods.
    fn overrun(&self, times: usize, missed: u64) {
        for _ in 0..times {
            self.cell.record(&CycleSample {
                overrun: true,
                missed_periods: missed,
                ..Default::default()
            });
        }
    }

    /// Fill the urgent queue, as a burst of STOP lines from the hosts would before the
    /// urgent path takes them.
    fn fill_urgent(&self) {
        let stop = Urgent::Stop(SourceId::NONE, Default::default());
        while self.urgent.try_send(stop).is_ok() {}
    }

    /// Empty the urgent queue (the urgent path took everything); what was on it.
    fn drain_urgent(&self) -> Vec<Urgent> {
        std::iter::from_fn(|| self.urgent.try_recv().ok()).collect()
    }

    fn fault(&self) -> Option<u16> {
        match self.urgent.try_recv() {
            Ok(Urgent::Fault(code)) => Some(code),
            Ok(_) => panic!("Error Check sent something else than a fault"),
            Err(_) => None,
        }
    }
}

#[test]
fn a_stall_of_a_watched_task_longer_than_its_buffer_during_a_motion_is_fault_207() {
    let mut r = rig(true);
    r.shared.set_state(RobotState::Moving);
    r.ec.step();
    assert_eq!(r.fault(), None, "no overrun yet");
    // Many short stalls within one check (at 1 kHz a VM's jitter gives several): each is
    // covered by the look-ahead, so none starves the motors.
    r.overrun(8, 1);
    r.overrun(1, 2);
    r.ec.step();
    assert_eq!(r.fault(), None, "2 periods skipped are 20 ms: covered");
    // One stall of 3 periods (30 ms) outlasts the 20 ms the buffer covers.
    r.overrun(1, 3);
    r.ec.step();
    assert_eq!(r.fault(), Some(Code::TaskOverrun.number()));
}

#[test]
fn stalls_at_rest_stop_nothing_and_do_not_count_later() {
    let mut r = rig(true);
    r.shared.set_state(RobotState::Idle);
    r.overrun(1, 10);
    r.ec.step();
    assert_eq!(r.fault(), None, "the robot stands: nothing to stop");
    // The stall at rest is not carried into the next motion.
    r.shared.set_state(RobotState::Moving);
    r.ec.step();
    assert_eq!(r.fault(), None);
    r.shared.set_state(RobotState::Stopping);
    r.overrun(1, 3);
    r.ec.step();
    assert_eq!(
        r.fault(),
        Some(Code::TaskOverrun.number()),
        "a stop is a motion too"
    );
}

#[test]
fn without_real_time_overruns_are_no_fault() {
    let mut r = rig(false);
    r.shared.set_state(RobotState::Moving);
    r.overrun(50, 10);
    r.ec.step();
    assert_eq!(r.fault(), None);
}

/// Pins the bug where a fault found while the urgent queue was full was marked reported
/// and dropped: the E-stop input pressed during a burst of STOPs, whose brake had made the
/// state STOPPING, went unreported until that brake had ended.
#[test]
fn the_estop_input_found_while_the_urgent_queue_is_full_is_reported_next_period() {
    let mut r = rig(false);
    r.shared.set_state(RobotState::Moving);
    r.fill_urgent();
    r.sim.apply_fault(Fault::Estop { on: true });
    r.sim.step();
    r.ec.step();
    // The burst is taken and stops the robot; the fault had no room.
    r.shared.set_state(RobotState::Stopping);
    let burst = r.drain_urgent();
    assert!(
        burst.iter().all(|u| matches!(u, Urgent::Stop(..))),
        "{burst:?}"
    );
    r.ec.step();
    assert_eq!(r.fault(), Some(Code::EstopInput.number()));
}

/// The same bug for a lost controlling client, whose flag the check had already cleared.
#[test]
fn a_lost_controlling_client_found_while_the_urgent_queue_is_full_is_reported_next_period() {
    let mut r = rig(false);
    r.shared.set_state(RobotState::Moving);
    r.fill_urgent();
    r.owner_lost.store(true, Ordering::Release);
    r.ec.step();
    r.drain_urgent();
    r.ec.step();
    assert_eq!(r.fault(), Some(Code::ClientLost.number()));
}
