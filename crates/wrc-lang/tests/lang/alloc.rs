//! Counting allocator: `load`, `run` and `resume` allocate nothing, over a program with
//! loops, SUB calls, pose arithmetic, PRINT and every kind of request.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use wrc_lang::{Request, Resume, Step, Vm, VmLimits};
use wrc_robot::Pose;

use crate::common::{program, Io};

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: delegates to the system allocator; the thread-local counter is const-initialised,
// so touching it never allocates or recurses into the allocator.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as our caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as our caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

const PROGRAM: &str = "\
SPEED 50
HOME
BASE = POSE(300, -50, 20, 0)
UP = POSE(0, 0, 30, 0)
COUNT = 0
FOR i = 1 TO 5
  TARGET = BASE + POSE(0, 20 * i, 0, 5 * i)
  MOVEP TARGET + UP, R
  MOVEL TARGET
  CALL grip
  MOVEJ JOINTS(10 * i, 60, -90, 50)
  JOG J1, 1000 * i
  IF TARGET.Y > 0 AND i <> 3 THEN
    PRINT \"slot\", i, \"at\", TARGET, \"yaw\", TARGET.YAW, 1 / 3, TRUE, JOINTS(1, 2, 3, 4)
  ELSEIF i = 3 THEN
    PRINT \"here\", HERE(), SQRT(i) * SIN(45) + ATAN2(1, i)
  ELSE
    DELAY 0.1
  ENDIF
NEXT i
WHILE COUNT < 20
  COUNT = COUNT + 1
ENDWHILE
PRINT \"done\", COUNT
END

SUB grip
  OUT 0, 1
  WAIT IN(0) = 1 TIMEOUT 2
  CALL note
ENDSUB

SUB note
  PRINT \"held at\", HERE().X
ENDSUB
";

#[test]
fn load_run_and_resume_allocate_nothing() {
    let program = program(PROGRAM);
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io {
        inputs: 0,
        here: Pose {
            x: 300.0,
            y: -80.0,
            z: 20.0,
            yaw: 0.0,
        },
    };
    let mut prints = 0;
    let mut requests = 0;
    let mut print_bytes = 0;
    let before = allocations();
    for _round in 0..3 {
        vm.load(&program).unwrap();
        loop {
            match vm.run(&program, 7, &mut io) {
                Step::Budget => {}
                Step::Done => break,
                Step::Fault(e) => panic!("{e}"),
                Step::Yield(r) => {
                    requests += 1;
                    if r == Request::Print {
                        prints += 1;
                        print_bytes += vm.print_text().len();
                    }
                    if let Request::WaitInput { n, .. } = r {
                        io.inputs |= 1 << n;
                    }
                    vm.resume(Resume::Ok);
                }
            }
        }
    }
    let after = allocations();
    assert_eq!(after - before, 0, "load, run and resume allocated");
    // The run did the work the program describes.
    // Per round: 5 grips, slots 4 and 5, slot 3 (HERE), done.
    assert_eq!(prints, 3 * (5 + 2 + 1 + 1));
    assert!(requests > 3 * 40, "{requests}");
    assert!(print_bytes > 500, "{print_bytes}");
}
