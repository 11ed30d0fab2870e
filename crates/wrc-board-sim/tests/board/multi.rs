//! Several boards behind one MotionBoard: axis mapping, all-or-none pushes, I/O per board.

use wrc_board::driver::Mapping;
use wrc_board::{DpramBoard, Expect, Feedback, Full, MotionBoard, MultiBoard, MultiError};
use wrc_board_sim::servo::ServoSettings;
use wrc_board_sim::{io::IoSettings, SimBoard, SimSettings};

fn settings(board_id: u32, axes: usize, fifo_depth: u32) -> SimSettings {
    let axis = ServoSettings {
        max_velocity_pps: 1e6,
        stop_deceleration_pps2: 1e7,
        stop_jerk_pps3: 1e9,
        lag_s: 0.0,
        following_error_limit: 10_000,
        limit_pos: i64::MAX / 2,
        limit_neg: i64::MIN / 2,
        initial: 0,
    };
    SimSettings {
        board_id,
        period_us: 1_000,
        fifo_depth,
        watchdog_periods: 100,
        substeps: 1,
        axes: vec![axis; axes],
        io: IoSettings::default(),
    }
}

fn board(board_id: u32, axes: usize, fifo_depth: u32) -> (SimBoard, DpramBoard) {
    let map = Mapping::anonymous().unwrap();
    let sim = SimBoard::new(map.share(), &settings(board_id, axes, fifo_depth), 1).unwrap();
    (sim, DpramBoard::attach(map, Expect::default()).unwrap())
}

#[test]
fn axes_map_onto_boards_and_push_all_or_none() {
    let (mut sim0, host0) = board(0, 4, 2);
    let (mut sim1, host1) = board(1, 2, 3);
    // Controller axes: 0-3 on board 0 reversed, 4-5 on board 1.
    let mut multi = MultiBoard::new(
        vec![host0, host1],
        &[(0, 3), (0, 2), (0, 1), (0, 0), (1, 0), (1, 1)],
    )
    .unwrap();
    assert_eq!(
        (multi.axis_count(), multi.board_count(), multi.period_us()),
        (6, 2, 1_000)
    );
    let increments: [i64; 16] = std::array::from_fn(|i| (i as i64 + 1) * 10);
    multi.push(&increments).unwrap();
    multi.push(&increments).unwrap();
    // Board 0 is full (depth 2): nothing goes to board 1 either.
    assert_eq!(multi.push(&increments), Err(Full));
    assert_eq!(multi.boards()[1].fifo_free(), 1);
    sim0.step();
    sim1.step();
    let mut f = Feedback::default();
    multi.read_feedback(&mut f).unwrap();
    let commanded: Vec<i64> = f.axes[..6].iter().map(|a| a.commanded).collect();
    assert_eq!(commanded, [10, 20, 30, 40, 50, 60]);
    assert_eq!(f.board_count, 2);
    multi.write_outputs(1, 0b101);
    sim1.step();
    multi.read_feedback(&mut f).unwrap();
    assert_eq!((f.boards[1].outputs, f.boards[0].outputs), (0b101, 0));
}

#[test]
fn bad_maps_are_refused() {
    let (_s0, h0) = board(0, 2, 2);
    let e = MultiBoard::new(vec![h0], &[(0, 0), (0, 2)]).unwrap_err();
    assert_eq!(
        e,
        MultiError::NoSuchChannel {
            axis: 1,
            board: 0,
            channel: 2
        }
    );
    let (_s0, h0) = board(0, 2, 2);
    let e = MultiBoard::new(vec![h0], &[(0, 1), (0, 1)]).unwrap_err();
    assert!(
        matches!(
            e,
            MultiError::SharedChannel {
                first: 0,
                second: 1,
                ..
            }
        ),
        "{e}"
    );
    let e = MultiBoard::<DpramBoard>::new(vec![], &[]).unwrap_err();
    assert_eq!(e, MultiError::BoardCount(0));
}
