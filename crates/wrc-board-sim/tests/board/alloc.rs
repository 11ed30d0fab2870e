//! The real-time path allocates nothing: a counting global allocator (per thread, so other
//! tests running in parallel do not disturb the count) watches push, feedback, I/O,
//! watchdog, commands and the mapping latch on the host side and the board's step, with and
//! without the simulated cell.

use wrc_alloc_count::{heap_calls, CountingAllocator};

use wrc_board::driver::Mapping;
use wrc_board::wrc_cell::{SlotContent, Stations};
use wrc_board::{DpramBoard, Expect, Feedback, MappingScan, MotionBoard, MultiBoard};
use wrc_board_sim::cell::SimCell;
use wrc_board_sim::{SimBoard, SimSettings};
use wrc_config::Config;
use wrc_robot::{Pose, Posture, Robot, MAX_AXES};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn host_calls_and_board_step_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let config = Config::embedded_default();
    let settings = wrc_board_sim::SimSettings::from_config(&config, &config.boards[0]);
    let map = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(map.share(), &settings, 1).unwrap();
    let host = DpramBoard::attach(map, Expect::default()).unwrap();
    let mut multi = MultiBoard::new(vec![host], &[(0, 0), (0, 1), (0, 2), (0, 3)]).unwrap();
    let mut feedback = Feedback::default();
    let mut increments = [0i64; 16];
    let before = heap_calls().allocations;
    for k in 0..1_000i64 {
        increments[0] = (k % 7) - 3;
        multi.refresh_watchdog();
        let _ = multi.push(&increments);
        sim.step();
        multi.read_feedback(&mut feedback).unwrap();
        let inputs = multi.read_inputs(0);
        multi.write_outputs(0, inputs & 1);
        if k % 100 == 0 {
            let _ = multi.clear_alarms(0b1111);
        }
    }
    assert_eq!(heap_calls().allocations - before, 0);
    assert_eq!(feedback.axes[0].alarm, 0);
}

/// One planned board period: increments, outputs, and whether the host clears the latch.
type Period = ([i64; MAX_AXES], u32, bool);

/// Periods of a joint move from `end` to `pose` (right elbow), at most 1 500 pulses a period
/// per axis (below every motor limit), then `settle` periods holding; `end` moves along.
fn plan(
    robot: &Robot,
    end: &mut [i64; MAX_AXES],
    pose: Pose,
    outputs: u32,
    settle: usize,
) -> Vec<Period> {
    let joints = robot
        .inverse(&pose, Posture::Right, Some(&robot.pulses_to_joints(end)))
        .unwrap();
    let target = robot.joints_to_pulses(&joints);
    let mut periods = Vec::new();
    while *end != target {
        let mut inc = [0i64; MAX_AXES];
        for ((i, e), t) in inc.iter_mut().zip(end.iter_mut()).zip(&target) {
            *i = (t - *e).clamp(-1_500, 1_500);
            *e += *i;
        }
        periods.push((inc, outputs, false));
    }
    periods.extend(std::iter::repeat_n(([0; MAX_AXES], outputs, false), settle));
    periods
}

/// Periods of a straight TCP line from `end` to `pose` (as the controller moves inside a
/// station: a joint move from the approach pose to the seat would swing the hand into the
/// station's side), a millimetre a period; `end` moves along.
fn line(robot: &Robot, end: &mut [i64; MAX_AXES], pose: Pose, outputs: u32) -> Vec<Period> {
    let mut joints = robot.pulses_to_joints(end);
    let from = robot.forward(&joints);
    let n = (pose.x - from.x).hypot(pose.y - from.y).ceil().max(1.0) as u32;
    let mut periods = Vec::new();
    for i in 1..=n {
        let u = f64::from(i) / f64::from(n);
        let at = Pose {
            x: from.x + u * (pose.x - from.x),
            y: from.y + u * (pose.y - from.y),
            ..pose
        };
        joints = robot.inverse(&at, Posture::Right, Some(&joints)).unwrap();
        let target = robot.joints_to_pulses(&joints);
        let mut inc = [0i64; MAX_AXES];
        for ((i, e), t) in inc.iter_mut().zip(end.iter_mut()).zip(&target) {
            *i = t - *e;
            *e = *t;
        }
        periods.push((inc, outputs, false));
    }
    periods
}

#[test]
fn a_step_with_the_cell_simulated_allocates_nothing() {
    wrc_alloc_count::assert_installed();
    let config = Config::embedded_default();
    let board = &config.boards[0];
    let settings = SimSettings::from_config(&config, board);
    let map = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(map.share(), &settings, 1).unwrap();
    let stations = Stations::embedded_demo();
    let lp1 = stations.get("LP1").unwrap().clone();
    sim.attach_cell(SimCell::new(&config, board, stations).unwrap())
        .unwrap();
    let host = DpramBoard::attach(map, Expect::default()).unwrap();
    let mut multi = MultiBoard::new(vec![host], &[(0, 0), (0, 1), (0, 2), (0, 3)]).unwrap();

    // Map LP1 (Z sweep at the approach pose with the sensor on), then GET its slot 5.
    let (sensor, valve) = (
        1u32 << config.hand.mapping_output,
        1u32 << config.hand.vacuum_output,
    );
    let robot = &config.robot;
    let mut end = [0i64; MAX_AXES];
    for (e, s) in end.iter_mut().zip(&settings.axes) {
        *e = s.initial;
    }
    let mut periods = plan(robot, &mut end, lp1.approach_pose(1, false).unwrap(), 0, 10);
    let sweep = periods.len();
    periods.extend(plan(
        robot,
        &mut end,
        lp1.approach_pose(25, true).unwrap(),
        sensor,
        10,
    ));
    periods[sweep].2 = true;
    periods.extend(plan(
        robot,
        &mut end,
        lp1.approach_pose(5, false).unwrap(),
        0,
        0,
    ));
    periods.extend(line(robot, &mut end, lp1.seated_pose(5, false).unwrap(), 0));
    periods.extend(plan(
        robot,
        &mut end,
        lp1.seated_pose(5, false).unwrap(),
        valve,
        5,
    ));
    periods.extend(plan(
        robot,
        &mut end,
        lp1.seated_pose(5, true).unwrap(),
        valve,
        10,
    ));

    let mut feedback = Feedback::default();
    let mut scan = MappingScan::default();
    let mut events = 0;
    let before = heap_calls().allocations;
    for &(increments, outputs, clear) in &periods {
        if clear {
            multi.clear_mapping();
        }
        multi.write_outputs(0, outputs);
        multi.push(&increments).unwrap();
        sim.step();
        // What the runner loop does after every step.
        events += usize::from(sim.take_cell_event().is_some());
        multi.read_feedback(&mut feedback).unwrap();
        multi.read_mapping(&mut scan).unwrap();
    }
    assert_eq!(heap_calls().allocations - before, 0);

    // The paths that could allocate were taken: a scan, a pick, the vacuum sensor.
    assert!(scan.cleared);
    assert_eq!((scan.station, scan.seen), (1, (1u64 << 25) - 1));
    assert_eq!(scan.codes[..25], [1u8; 25]);
    let world = sim.cell().unwrap().world();
    assert_eq!(world.hand(), Some(5));
    assert_eq!(world.slot("LP1", 5).unwrap(), SlotContent::Empty);
    assert_eq!(events, 1, "{}", world.to_text());
    assert_eq!(world.faults(), 0);
    assert!(feedback.boards[0].inputs & (1 << config.hand.vacuum_input) != 0);
    assert_eq!(feedback.axes[0].alarm, 0);
}
