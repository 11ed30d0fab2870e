//! Counting allocator: `load`, `run` and `resume` allocate nothing, over a program with
//! loops, SUB calls, pose arithmetic, PRINT and every kind of request, and over wafer
//! transfers that succeed, fail at the host, and fail on a bad slot or station name.

use wrc_alloc_count::{heap_calls, CountingAllocator};
use wrc_lang::{Request, Resume, RuntimeErrorKind, Step, Vm, VmLimits};
use wrc_robot::Pose;

use crate::common::{program, Io};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

const PROGRAM: &str = "\
SPEED 50
HOME
BASE = POSE(300, -50, 20, 0)
UP = POSE(0, 0, 30, 0)
COUNT = 0
LOADER = \"LP1\"
MAP LOADER
FOR i = 1 TO 5
  GET LOADER, i
  PUT \"LP2\", 6 - i
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
    wrc_alloc_count::assert_installed();
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
    let mut transfers = 0;
    let mut print_bytes = 0;
    let before = heap_calls().allocations;
    for _round in 0..3 {
        vm.load(&program).unwrap();
        loop {
            match vm.run(&program, 7, &mut io) {
                Step::Budget => {}
                Step::Done => break,
                Step::Fault(e) => panic!("{e}"),
                Step::Break(at) => panic!("stopped at {at:?}"),
                Step::Yield(r) => {
                    requests += 1;
                    if r == Request::Print {
                        prints += 1;
                        print_bytes += vm.print_text().len();
                    }
                    if matches!(r, Request::Transfer { .. } | Request::Map { .. }) {
                        transfers += 1;
                    }
                    if let Request::WaitInput { n, .. } = r {
                        io.inputs |= 1 << n;
                    }
                    vm.resume(Resume::Ok);
                }
            }
        }
    }
    let after = heap_calls().allocations;
    assert_eq!(after - before, 0, "load, run and resume allocated");
    // The run did the work the program describes.
    // Per round: 5 grips, slots 4 and 5, slot 3 (HERE), done.
    assert_eq!(prints, 3 * (5 + 2 + 1 + 1));
    assert!(requests > 3 * 40, "{requests}");
    assert_eq!(transfers, 3 * (1 + 5 + 5));
    assert!(print_bytes > 500, "{print_bytes}");
}

/// Moves wafers slot by slot, computing the slot and choosing the station from variables;
/// the host fails the 4th GET of round 2, and rounds 3 and 4 end on a bad slot or name.
const TRANSFERS: &str = "\
SRC = \"LP1\"
DST = \"LP2\"
LAST = 6
BAD = \"LP3\"
MAP SRC
MAP DST
FOR slot = 1 TO LAST
  GET SRC, slot
  PRINT \"wafer\", slot, \"from\", SRC, \"to\", DST
  PUT DST, LAST + 1 - slot
NEXT slot
IF LAST > 5 THEN
  LAST = 70000
  BAD = \"not a station!\"
ENDIF
";

#[test]
fn wafer_transfers_and_their_failures_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let good = program(TRANSFERS);
    let bad_slot = program(&format!("{TRANSFERS}GET SRC, LAST\n"));
    let bad_name = program(&format!("{TRANSFERS}MAP BAD\n"));
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    let mut transfers = 0;
    let mut faults = Vec::with_capacity(4); // pushing must not allocate below
    let mut printed = 0;
    let before = heap_calls().allocations;
    for (round, p) in [&good, &good, &bad_slot, &bad_name].into_iter().enumerate() {
        vm.load(p).unwrap();
        let mut gets = 0;
        loop {
            match vm.run(p, 5, &mut io) {
                Step::Budget => {}
                Step::Break(at) => panic!("stopped at {at:?}"),
                Step::Done => break,
                Step::Fault(e) => {
                    faults.push((round, e));
                    break;
                }
                Step::Yield(r) => {
                    let answer = Resume::Ok;
                    match r {
                        Request::Transfer { kind, station, .. } => {
                            transfers += 1;
                            if kind == wrc_lang::TransferKind::Get && station.as_str() == "LP1" {
                                gets += 1;
                                if round == 1 && gets == 4 {
                                    vm.fail(131, "the slot is empty");
                                    continue;
                                }
                            }
                        }
                        Request::Map { .. } => transfers += 1,
                        Request::Print => printed += vm.print_text().len(),
                        _ => {}
                    }
                    vm.resume(answer);
                }
            }
        }
    }
    let after = heap_calls().allocations;
    assert_eq!(after - before, 0, "wafer transfers allocated");
    // Round 1: 2 maps + 12 transfers; round 2 stops at the 4th GET (2 + 3 * 2 + 1);
    // rounds 3 and 4 run everything, then fault.
    assert_eq!(transfers, 14 + 9 + 14 + 14);
    assert!(printed > 20 * 6, "{printed}");
    let lines: Vec<_> = faults.iter().map(|(round, e)| (*round, e.line)).collect();
    assert_eq!(lines, [(1, 8), (2, 16), (3, 16)]);
    assert!(matches!(
        faults[0].1.kind,
        RuntimeErrorKind::Host { code: 131 }
    ));
    assert!(matches!(faults[1].1.kind, RuntimeErrorKind::BadArgument(_)));
    assert!(matches!(faults[2].1.kind, RuntimeErrorKind::BadArgument(_)));
}

/// Error handling, procedures with locals and recursion, arrays, strings built at run
/// time, cell questions and the debugger's stops and reads.
const SEQUENCE: &str = "\
DIM IDS$[25] AS STRING
DIM DONE[25]
TRIES = 0
FOR n = 1 TO 25
  IF SLOT(\"LP1\", n) = 1 THEN
    TRY
      GET \"LP1\", n
      PUT \"LP2\", n
      IDS$[n - 1] = WAFER$(\"LP1\", n) + \"@\" + FORMAT$(n, \"00\")
      DONE[n - 1] = fact(5)
    CATCH 212
      TRIES = TRIES + 1
      IF TRIES MOD 2 = 1 THEN
        RETRY
      ENDIF
      ALARM 1001, \"vacuum miss at LP1 slot \" + STR$(n)
      WAIT OPERATOR \"check the hand\"
    CATCH
      PRINT \"skipped\", n, ERR, ERRMSG$
    ENDTRY
  ENDIF
  SELECT CASE n MOD 3
    CASE 0
      X$ = LEFT$(\"abcdef\", 2) + MID$(\"wafer\", 2, 3)
    CASE ELSE
      X$ = UCASE$(\"lp\")
  ENDSELECT
NEXT
DO
  TRIES = TRIES - 1
LOOP UNTIL TRIES <= 0
PRINT \"done\", IDS$[4], DONE[4], X$
END
FUNCTION fact(k)
  LOCAL acc = 1
  IF k > 1 THEN
    acc = k * fact(k - 1)
  ENDIF
  RETURN acc
ENDFUNCTION
";

#[test]
fn errors_procedures_arrays_strings_and_the_debugger_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let p = program(SEQUENCE);
    let mut vm = Vm::new(VmLimits::default());
    let io = Io::default();
    let get_line = p
        .statement_on_line(7)
        .unwrap_or_else(|| panic!("line 7 has a statement"));
    let mut transfers = 0;
    let mut stops = 0;
    let mut printed = 0;
    let mut watched = 0;
    let before = heap_calls().allocations;
    for round in 0..2 {
        let breaks = [get_line];
        vm.set_breakpoints(if round == 1 { &breaks } else { &[] });
        vm.load(&p).unwrap();
        loop {
            match vm.run(&p, 37, &mut io.clone()) {
                Step::Budget => {}
                Step::Done => break,
                Step::Fault(e) => panic!("{e}"),
                Step::Break(_) => {
                    stops += 1;
                    if let Some(v) = vm.variable(&p, "TRIES") {
                        let mut text = wrc_lang::Text::EMPTY;
                        let _ = vm.write_variable(&p, &v, None, &mut text);
                        watched += text.as_str().len();
                    }
                    if stops % 3 == 0 {
                        vm.step(wrc_lang::StepMode::Over);
                    }
                }
                Step::Yield(r) => {
                    if let Request::Transfer { slot, .. } = r {
                        transfers += 1;
                        // Every fifth GET misses its wafer.
                        if slot % 5 == 0 {
                            vm.fail(212, "wafer not sensed");
                            continue;
                        }
                    }
                    if r == Request::Print {
                        printed += vm.print_text().len();
                    }
                    vm.resume(crate::common::answer(&r, &io));
                }
            }
        }
    }
    let after = heap_calls().allocations;
    assert_eq!(after - before, 0, "the sequence allocated");
    assert!(transfers > 2 * 45, "{transfers}");
    assert!(stops >= 25, "{stops}");
    assert!(watched > 0 && printed > 0);
    let _ = RuntimeErrorKind::NoReturn;
    let _ = Resume::Ok;
}
