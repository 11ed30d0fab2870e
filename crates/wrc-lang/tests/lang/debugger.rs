//! The VM's debugger: breakpoints before a statement, single steps into, over and out of a
//! call, a motion statement stepped as one, the call stack and the variables in scope.

use wrc_lang::{Program, Request, Resume, SourcePos, Step, StepMode, Vm, VmLimits};

use crate::common::{answer, program, Io};

const SRC: &str = "\
X = 1
CALL work(2)
X = X + 10
MOVEJ JOINTS(0, 90, 0, 0)
PRINT X
END
SUB work(n)
  LOCAL k = n * 3
  X = X + k
  PRINT \"work\", k
ENDSUB
";

/// Run until a break, the end or a fault, answering requests; the line it stopped at
/// (`None`: the end) and the requests answered on the way.
fn until_break(vm: &mut Vm, p: &Program) -> (Option<u32>, Vec<Request>) {
    let io = Io::default();
    let mut asked = Vec::new();
    loop {
        match vm.run(p, 1000, &mut io.clone()) {
            Step::Budget => {}
            Step::Break(SourcePos { line, .. }) => return (Some(line), asked),
            Step::Done => return (None, asked),
            Step::Fault(e) => panic!("{e}"),
            Step::Yield(r) => {
                asked.push(r);
                vm.resume(answer(&r, &io));
            }
        }
    }
}

fn line_pc(p: &Program, line: u32) -> u32 {
    p.statement_at_line(0, line).expect("a statement").0
}

#[test]
fn a_breakpoint_stops_before_its_statement_every_time_it_is_reached() {
    let p = program("FOR i = 1 TO 3\n  PRINT i\nNEXT\nPRINT \"end\"\n");
    let mut vm = Vm::new(VmLimits::default());
    vm.set_breakpoints(&[line_pc(&p, 2)]);
    vm.load(&p).unwrap();
    let mut stops = 0;
    loop {
        let (line, asked) = until_break(&mut vm, &p);
        match line {
            Some(l) => {
                assert_eq!(l, 2);
                // Nothing of the statement ran yet: its PRINT comes after going on.
                assert_eq!(asked.len(), usize::from(stops > 0));
                stops += 1;
            }
            None => break,
        }
    }
    assert_eq!(stops, 3);
    // A breakpoint on a line without a statement moves to the next statement.
    let p = program("X = 1\n\n' a comment\nPRINT X\n");
    assert_eq!(p.statement_at_line(0, 2).map(|(_, l)| l), Some(4));
    assert_eq!(p.statement_at_line(0, 9), None);
}

#[test]
fn step_into_over_and_out_follow_the_calls() {
    let p = program(SRC);
    let mut vm = Vm::new(VmLimits::default());
    vm.set_breakpoints(&[line_pc(&p, 1)]);
    vm.load(&p).unwrap();
    assert_eq!(until_break(&mut vm, &p).0, Some(1));
    vm.set_breakpoints(&[]);
    // Into: line 2 (CALL), then the SUB's first statement.
    vm.step(StepMode::Into);
    assert_eq!(until_break(&mut vm, &p).0, Some(2));
    vm.step(StepMode::Into);
    assert_eq!(until_break(&mut vm, &p).0, Some(8));
    // Locals of the running call are in scope, before the globals.
    let mut seen = Vec::new();
    for v in vm.variables(&p) {
        let mut text = String::new();
        vm.write_variable(&p, &v, None, &mut text).unwrap();
        seen.push(format!(
            "{}{}={text}",
            if v.local { "local " } else { "" },
            v.name
        ));
    }
    assert_eq!(seen, ["local n=2", "local k=0", "X=1"]);
    let stack: Vec<_> = vm
        .call_stack(&p)
        .map(|(r, at)| (p.routines()[r as usize].name.clone(), at.line))
        .collect();
    assert_eq!(stack, [("work".to_string(), 2)]);
    // Out: back in the main program, after the CALL.
    vm.step(StepMode::Out);
    let (line, asked) = until_break(&mut vm, &p);
    assert_eq!(line, Some(3));
    assert_eq!(asked, [Request::Print], "the SUB's PRINT ran");
    assert_eq!(vm.print_text(), "work 6");
    let x = vm.variable(&p, "x").unwrap();
    let mut text = String::new();
    vm.write_variable(&p, &x, None, &mut text).unwrap();
    assert_eq!(text, "7");
    // Over a motion statement: it runs whole (the host answers it) and stops after it.
    vm.step(StepMode::Over);
    assert_eq!(until_break(&mut vm, &p).0, Some(4));
    vm.step(StepMode::Over);
    let (line, asked) = until_break(&mut vm, &p);
    assert_eq!(line, Some(5));
    assert!(matches!(asked[..], [Request::Move(..)]), "{asked:?}");
    // Going on without a step runs to the end.
    assert_eq!(until_break(&mut vm, &p).0, None);
}

#[test]
fn step_over_a_call_runs_it_whole() {
    let p = program(SRC);
    let mut vm = Vm::new(VmLimits::default());
    vm.set_breakpoints(&[line_pc(&p, 2)]);
    vm.load(&p).unwrap();
    assert_eq!(until_break(&mut vm, &p).0, Some(2));
    vm.set_breakpoints(&[]);
    vm.step(StepMode::Over);
    let (line, asked) = until_break(&mut vm, &p);
    assert_eq!(line, Some(3));
    assert_eq!(asked, [Request::Print]);
    // Breakpoints are kept across load; a step is not.
    vm.set_breakpoints(&[line_pc(&p, 9)]);
    vm.load(&p).unwrap();
    assert!(!vm.stepping());
    assert_eq!(until_break(&mut vm, &p).0, Some(9));
}

#[test]
fn arrays_and_strings_show_as_the_debugger_writes_them() {
    let p = program(
        "DIM A[3]\nA[1] = 2.5\nS$ = \"say \"\"hi\"\"\"\nP = POSE(1, 2, 3, 4)\nPRINT A[0], S$, P\n",
    );
    let mut vm = Vm::new(VmLimits::default());
    vm.load(&p).unwrap();
    let mut io = Io::default();
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(Request::Print));
    let show = |name: &str, index: Option<u32>| {
        let v = vm.variable(&p, name).unwrap();
        let mut text = String::new();
        vm.write_variable(&p, &v, index, &mut text).unwrap();
        text
    };
    assert_eq!(show("A", None), "0,2.5,0");
    assert_eq!(show("A", Some(1)), "2.5");
    assert_eq!(show("A", Some(7)), "(index out of range)");
    assert_eq!(show("S$", None), "\"say \"\"hi\"\"\"");
    assert_eq!(show("P", None), "POSE(1, 2, 3, 4)");
    vm.resume(Resume::Ok);
}
