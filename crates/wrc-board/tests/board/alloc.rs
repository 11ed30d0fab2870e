//! The real-time path allocates nothing: a counting global allocator (per thread, so other
//! tests running in parallel do not disturb the count) watches push, feedback, I/O,
//! watchdog and commands on the host side and the board's step.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use wrc_board::driver::Mapping;
use wrc_board::sim::SimBoard;
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard, MultiBoard};
use wrc_config::Config;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator unchanged; only counts calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

#[test]
fn host_calls_and_board_step_allocate_nothing() {
    let config = Config::embedded_default();
    let settings = wrc_board::sim::SimSettings::from_config(&config, &config.boards[0]);
    let map = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(map.share(), &settings, 1).unwrap();
    let host = DpramBoard::attach(map, Expect::default()).unwrap();
    let mut multi = MultiBoard::new(vec![host], &[(0, 0), (0, 1), (0, 2), (0, 3)]).unwrap();
    let mut feedback = Feedback::default();
    let mut increments = [0i64; 16];
    let before = allocations();
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
    assert_eq!(allocations() - before, 0);
    assert_eq!(feedback.axes[0].alarm, 0);
}
