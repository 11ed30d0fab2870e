//! Velocity Generator → pulse ring → Pulse Generator → board FIFO → simulated board(s),
//! stepped by hand on one thread (10 ms Pulse Generator periods, Velocity Generator every
//! 5th).

use std::sync::Arc;

use crate::motion::{sim_board, Motion};
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard, MultiBoard};
use wrc_board_sim::SimBoard;
use wrc_config::Config;
use wrc_controller::messages::{MoveDone, MoveKind, MoveOrder, MoveOutcome};
use wrc_controller::pulse_generator::PulseGenerator;
use wrc_controller::shared::{Shared, StopKind, StopTally};
use wrc_controller::velocity_generator::VelocityGenerator;
use wrc_robot::Joints;
use wrc_rt::ipc::MessageQueue;

struct Rig {
    sims: Vec<SimBoard>,
    host: MultiBoard<DpramBoard>,
    pg: PulseGenerator<MultiBoard<DpramBoard>>,
    vg: VelocityGenerator,
    orders: Arc<MessageQueue<MoveOrder>>,
    done: Arc<MessageQueue<MoveDone>>,
    shared: Arc<Shared>,
    k: u64,
    increments: Vec<[i64; 16]>,
}

impl Rig {
    /// The robot on the configuration's one board.
    fn new() -> Rig {
        let config = Config::embedded_default();
        let board = config.boards[0].clone();
        Rig::on_boards(&config, &[board])
    }

    /// The robot on two boards, two axes each: a flush cannot be armed on both at once.
    fn on_two_boards() -> Rig {
        let config = Config::embedded_default();
        let mut first = config.boards[0].clone();
        let mut second = first.clone();
        first.axes = vec![0, 1];
        second.id = 1;
        second.axes = vec![2, 3];
        Rig::on_boards(&config, &[first, second])
    }

    /// The robot on the configuration's one board, the Pulse Generator keeping `periods`
    /// queued while moving.
    fn with_lookahead(periods: usize) -> Rig {
        let mut rig = Rig::new();
        rig.pg = rig.pg.with_lookahead(periods);
        rig
    }

    fn on_boards(config: &Config, boards: &[wrc_config::BoardConfig]) -> Rig {
        let mut sims = Vec::new();
        let (mut pg_boards, mut host_boards) = (Vec::new(), Vec::new());
        let mut axis_map = vec![(0, 0); config.robot.axis_count()];
        for (b, board) in boards.iter().enumerate() {
            let (sim, mapping) = sim_board(config, board);
            sims.push(sim);
            pg_boards.push(DpramBoard::attach(mapping.share(), Expect::default()).unwrap());
            host_boards.push(DpramBoard::attach(mapping, Expect::default()).unwrap());
            for (channel, &axis) in board.axes.iter().enumerate() {
                axis_map[axis] = (b, channel);
            }
        }
        let pg_board = MultiBoard::new(pg_boards, &axis_map).unwrap();
        let host = MultiBoard::new(host_boards, &axis_map).unwrap();
        let Motion {
            pg,
            vg,
            shared,
            orders,
            done,
        } = Motion::at_rest(config, pg_board);
        Rig {
            sims,
            host,
            pg,
            vg,
            orders,
            done,
            shared,
            k: 0,
            increments: Vec::new(),
        }
    }

    /// Move to `target` (ticket 1), STOP it in cruise after 60 periods, between two periods
    /// (as from the Command Interpreter's urgent path), run to its end and 10 periods more:
    /// J1's cruise increment, the period the stop came before, the end, and J1's increment
    /// in every period [pulse].
    fn stop_in_cruise(&mut self, target: Joints) -> (i64, usize, MoveDone, Vec<i64>) {
        self.order(1, MoveKind::Joints(target));
        for _ in 0..60 {
            self.period();
        }
        let cruise = self.increments.last().unwrap()[0];
        assert!(cruise > 1000, "cruising at {cruise} pulse/period");
        let stop_at = self.increments.len();
        self.shared.request_stop(StopKind::Stop);
        let done = self.run_until_done(500);
        for _ in 0..10 {
            self.period();
        }
        let inc = self.increments.iter().map(|i| i[0]).collect();
        (cruise, stop_at, done, inc)
    }

    /// One 10 ms period: the Velocity Generator every 5th, then the Pulse Generator, then
    /// the board.
    fn period(&mut self) {
        if self.k % 5 == 0 {
            self.vg.step();
        }
        self.pg.step();
        let before = self.feedback();
        for sim in &mut self.sims {
            sim.step();
        }
        let after = self.feedback();
        let mut inc = [0i64; 16];
        for (i, v) in inc.iter_mut().enumerate().take(4) {
            *v = after.axes[i].commanded - before.axes[i].commanded;
        }
        self.increments.push(inc);
        self.k += 1;
    }

    fn feedback(&self) -> Feedback {
        let mut fb = Feedback::default();
        self.host.read_feedback(&mut fb).unwrap();
        fb
    }

    fn order(&self, ticket: u32, kind: MoveKind) {
        self.order_at(ticket, kind, 100.0);
    }

    fn order_at(&self, ticket: u32, kind: MoveKind, speed_pct: f64) {
        let epoch = self
            .shared
            .stop_epoch
            .load(std::sync::atomic::Ordering::Acquire);
        self.orders
            .try_send(MoveOrder {
                ticket,
                epoch,
                speed_pct,
                accel_pct: 100.0,
                kind,
            })
            .unwrap();
    }

    fn run_until_done(&mut self, limit: u64) -> MoveDone {
        for _ in 0..limit {
            self.period();
            if let Ok(d) = self.done.try_recv() {
                return d;
            }
        }
        panic!("no move ended within {limit} periods");
    }
}

/// A look-ahead (20 periods) longer than what the pulse ring holds at a move's start (12
/// batches, the Velocity Generator refilling it every 5th period): the Pulse Generator
/// queues what the plan has and tops the FIFO up as it comes, and never pads a motion with
/// zero periods (once it did: "the plan is late", 8 zero periods after the first 12, so the
/// axes stopped dead for 80 ms and went on).
#[test]
fn a_move_whose_plan_comes_in_slower_than_the_look_ahead_is_never_padded_with_zeros() {
    let mut rig = Rig::with_lookahead(20);
    let mut target = Config::embedded_default().robot.home();
    target[0] = 60.0;
    rig.order(3, MoveKind::Joints(target));
    let done = rig.run_until_done(1000);
    assert_eq!(done.outcome, MoveOutcome::Completed);
    let j1: Vec<i64> = rig.increments.iter().map(|i| i[0]).collect();
    let first = j1.iter().position(|v| *v != 0).unwrap();
    let last = j1.iter().rposition(|v| *v != 0).unwrap();
    assert!(
        j1[first..=last].iter().all(|v| *v > 0),
        "J1 stopped inside its motion: {:?}",
        &j1[first..=last]
    );
    assert_eq!(rig.feedback().underruns(), 0);
    // The FIFO filled to the look-ahead once the plan caught up.
    let fifo = rig.shared.fifo.read();
    assert_eq!(fifo.lookahead, 20);
    assert!(fifo.min_level.is_some(), "{fifo:?}");
}

/// A move's start that finds the Velocity Generator still producing it (fewer periods in
/// the ring than the look-ahead) waits for the rest instead of queuing a few a stall of
/// the Pulse Generator would run dry mid-start; once the generator is done it starts with
/// all there is, and runs to its end without a pause.
#[test]
fn a_moves_start_waits_while_the_plan_is_still_being_produced() {
    use std::sync::atomic::Ordering;
    let mut rig = Rig::with_lookahead(20); // the ring holds 12: never a whole look-ahead
    let mut target = Config::embedded_default().robot.home();
    target[0] = 60.0;
    rig.order(4, MoveKind::Joints(target));
    rig.vg.step();
    let depth = rig.host.fifo_free();
    // The generator preempted in the middle of its cycle: its flag still up.
    rig.shared.vg_filling.store(true, Ordering::Release);
    rig.pg.step();
    assert_eq!(
        rig.host.fifo_free(),
        depth,
        "nothing queued while the plan comes in"
    );
    rig.pg.step();
    assert_eq!(rig.host.fifo_free(), depth);
    // Its cycle over: the move starts with what the ring holds.
    rig.shared.vg_filling.store(false, Ordering::Release);
    rig.pg.step();
    assert_eq!(depth - rig.host.fifo_free(), 12);
    let done = rig.run_until_done(1000);
    assert_eq!(done.outcome, MoveOutcome::Completed);
    let j1: Vec<i64> = rig.increments.iter().map(|i| i[0]).collect();
    let first = j1.iter().position(|v| *v != 0).unwrap();
    let last = j1.iter().rposition(|v| *v != 0).unwrap();
    assert!(j1[first..=last].iter().all(|v| *v > 0), "{j1:?}");
    assert_eq!(rig.feedback().underruns(), 0);
}

/// While the next move's plan comes in, the FIFO drains the end of the move before: that
/// is no drain of the look-ahead (once it was counted as one: a 51-period "drain" in a
/// soak with the Pulse Generator on time).
#[test]
fn the_end_of_a_move_draining_while_the_next_is_planned_is_no_look_ahead_drain() {
    use std::sync::atomic::Ordering;
    let mut target = Config::embedded_default().robot.home();
    target[0] = 60.0;
    let mut whole = Rig::with_lookahead(10);
    whole.order(3, MoveKind::Joints(target));
    whole.run_until_done(1000);
    let j1: Vec<i64> = whole.increments.iter().map(|i| i[0]).collect();
    let end = j1.iter().rposition(|v| *v != 0).unwrap();

    let mut rig = Rig::with_lookahead(10);
    rig.order(3, MoveKind::Joints(target));
    // Its last period pushed, 8 of the motion still queued (the ring holds 12: the FIFO
    // streams at 10).
    for _ in 0..end - 8 {
        rig.period();
    }
    // The generator busy planning the next move, the board draining the end.
    rig.shared.vg_filling.store(true, Ordering::Release);
    for _ in 0..25 {
        rig.pg.step();
        for sim in &mut rig.sims {
            sim.step();
        }
    }
    rig.shared.vg_filling.store(false, Ordering::Release);
    let fifo = rig.shared.fifo.read();
    // The lowest level seen is one of the motion (this rig's generator, every 5th period
    // with a ring of 12, lets it sag a little), not the end's tail run down to 0.
    assert!(fifo.min_moving && fifo.min_level.unwrap() > 0, "{fifo:?}");
    assert_eq!(rig.feedback().underruns(), 0);
}

/// A stop in a move's last look-ahead (its last period already pushed, the board still
/// executing its deceleration) brakes from where the board is and ends the move stopped;
/// once it let the planned end play out and reported the move completed.
#[test]
fn an_estop_while_the_board_executes_the_end_of_a_move_brakes_it_from_there() {
    let mut target = Config::embedded_default().robot.home();
    target[0] = 60.0;
    // The whole move first: where its motion ends.
    // At 30 % the move decelerates gently (time scaled: acceleration ×0.09); an ESTOP
    // brakes with the axes' full limits.
    let mut whole = Rig::with_lookahead(20);
    whole.order_at(3, MoveKind::Joints(target), 30.0);
    whole.run_until_done(1000);
    let j1: Vec<i64> = whole.increments.iter().map(|i| i[0]).collect();
    let end = j1.iter().rposition(|v| *v != 0).unwrap();

    // The same move, and an ESTOP 15 periods before its motion ends (all of it pushed).
    let mut rig = Rig::with_lookahead(20);
    rig.order_at(3, MoveKind::Joints(target), 30.0);
    for _ in 0..end - 15 {
        rig.period();
    }
    let v0 = rig.increments.last().unwrap()[0];
    assert!(v0 > 0, "J1 is still moving");
    rig.shared.request_stop(StopKind::Estop);
    let done = rig.run_until_done(500);
    assert_eq!(done.ticket, 3);
    assert_eq!(
        done.outcome,
        MoveOutcome::Stopped,
        "the planned end played out"
    );
    assert_eq!(rig.shared.stops.read().flushed, 1);
    // The brake took over in the board's next period: from there J1 never speeds up.
    let at = rig.increments.len() - 1;
    let j1: Vec<i64> = rig.increments.iter().map(|i| i[0]).collect();
    assert!(j1[at..].windows(2).all(|w| w[1] <= w[0]), "{:?}", &j1[at..]);
    let stopped_at = rig.feedback().axes[0].commanded;
    assert!(stopped_at < 60_000, "J1 reached its target: {stopped_at}");
    assert_eq!(rig.feedback().underruns(), 0);
}

#[test]
fn a_ptp_move_reaches_the_board_exactly() {
    let mut rig = Rig::new();
    let home = rig.feedback().axes[0].commanded;
    let mut target = Config::embedded_default().robot.home();
    target[0] = 30.0;
    target[3] = 50.0;
    rig.order(7, MoveKind::Joints(target));
    let done = rig.run_until_done(1000);
    assert_eq!(
        done,
        MoveDone {
            ticket: 7,
            outcome: MoveOutcome::Completed
        }
    );
    for _ in 0..5 {
        rig.period();
    }
    let fb = rig.feedback();
    assert_eq!(fb.axes[0].commanded, 30_000);
    assert_eq!(fb.axes[3].commanded, 50_000);
    assert_eq!(rig.shared.commanded_pulses()[0], 30_000);
    assert_eq!(
        fb.underruns(),
        0,
        "the Pulse Generator streams every period"
    );
    assert!(home != 30_000);
    assert_eq!(fb.axes[0].alarm, 0);
}

#[test]
fn a_stop_decelerates_in_the_boards_next_period_and_keeps_the_books() {
    let mut rig = Rig::new();
    let mut target = Config::embedded_default().robot.home();
    target[0] = 170.0; // long cruise on J1
    let (cruise, stop_at, done, inc) = rig.stop_in_cruise(target);
    assert_eq!(
        done,
        MoveDone {
            ticket: 1,
            outcome: MoveOutcome::Stopped
        }
    );
    // The board skips what was queued before the stop (a FIFO flush) and decelerates in its
    // very next period, from the period it had reached, and never speeds up again.
    assert!(
        inc[stop_at] < cruise,
        "no deceleration in the board's next period: {:?}",
        &inc[stop_at - 2..stop_at + 6]
    );
    assert!(
        inc[stop_at - 1..].windows(2).all(|w| w[1] <= w[0]),
        "{:?}",
        &inc[stop_at - 1..]
    );
    // Here the board runs right after the Pulse Generator: one period was queued ahead.
    assert_eq!(
        fb_discarded(&rig),
        wrc_controller::pulse_generator::FIFO_LEAD as u32 - 1,
        "the board skipped the periods queued ahead"
    );
    assert_eq!(
        rig.shared.stops.read(),
        StopTally {
            flushed: 1,
            behind_queue: 0
        },
        "counted as a stop braked with a flush"
    );
    assert!(inc[inc.len() - 1] == 0);
    // Books: the board's commanded position equals everything the Pulse Generator pushed.
    let fb = rig.feedback();
    assert_eq!(fb.axes[0].commanded, rig.shared.commanded_pulses()[0]);
    assert!(fb.axes[0].commanded < 170_000);
    assert_eq!(fb.underruns(), 0);
    // A new move after the stop starts from where the robot came to rest.
    let mut back = Config::embedded_default().robot.home();
    back[0] = 0.0;
    let epoch = rig
        .shared
        .stop_epoch
        .load(std::sync::atomic::Ordering::Acquire);
    rig.orders
        .try_send(MoveOrder {
            ticket: 2,
            epoch,
            speed_pct: 100.0,
            accel_pct: 100.0,
            kind: MoveKind::Joints(back),
        })
        .unwrap();
    assert_eq!(rig.run_until_done(1000).outcome, MoveOutcome::Completed);
    for _ in 0..5 {
        rig.period();
    }
    assert_eq!(rig.feedback().axes[0].commanded, 0);
}

#[test]
fn on_two_boards_a_stop_brakes_behind_the_queued_periods_and_is_counted() {
    let mut rig = Rig::on_two_boards();
    let mut target = Config::embedded_default().robot.home();
    target[0] = 170.0; // long cruise on J1 (board 0)
    target[3] = 250.0; // and Z (board 1)
    let (cruise, stop_at, done, inc) = rig.stop_in_cruise(target);
    assert_eq!(done.outcome, MoveOutcome::Stopped);
    // No flush: the board executes the period queued ahead (here one: it runs right after
    // the Pulse Generator), then the brake, which never speeds up again.
    assert_eq!(fb_discarded(&rig), 0, "nothing was skipped");
    assert!(
        inc[stop_at] >= cruise - 1 && inc[stop_at + 1] < cruise,
        "{:?}",
        &inc[stop_at - 2..stop_at + 6]
    );
    assert!(inc[stop_at..].windows(2).all(|w| w[1] <= w[0]));
    assert_eq!(
        rig.shared.stops.read(),
        StopTally {
            flushed: 0,
            behind_queue: 1
        },
        "counted as a stop braked behind the queue"
    );
    // Books: both boards executed everything the Pulse Generator pushed.
    let fb = rig.feedback();
    let commanded = rig.shared.commanded_pulses();
    for (axis, (a, c)) in fb.axes.iter().zip(commanded).take(4).enumerate() {
        assert_eq!(a.commanded, c, "axis {axis}");
    }
    assert_eq!(fb.underruns(), 0);
}

/// Periods the board skipped on axis 0 (a flush).
fn fb_discarded(rig: &Rig) -> u32 {
    rig.host.boards()[0]
        .dpram()
        .load(wrc_board::layout::axis_base(0) + wrc_board::layout::axis::DISCARDED)
}

#[test]
fn an_unreachable_line_is_refused_without_moving() {
    let mut rig = Rig::new();
    let before = rig.feedback().axes[0].commanded;
    let far = wrc_robot::Pose {
        x: 500.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
    };
    rig.order(3, MoveKind::Line(far));
    let done = rig.run_until_done(20);
    assert_eq!(done.ticket, 3);
    assert!(matches!(done.outcome, MoveOutcome::Refused(111)));
    assert_eq!(rig.feedback().axes[0].commanded, before);
}
