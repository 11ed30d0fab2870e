//! VM semantics: arithmetic, control flow, SUBs, poses, PRINT formatting, run-time errors
//! and their lines, budgets, resume, abort and load limits.

use wrc_lang::{
    LoadError, Request, Resume, RuntimeError, RuntimeErrorKind, Step, Vm, VmLimits, PRINT_CAPACITY,
};
use wrc_robot::Pose;

use crate::common::{printed, program, run, run_with, Io};

fn fault(source: &str) -> RuntimeError {
    run(&program(source)).fault.expect("a fault")
}

#[test]
fn arithmetic_follows_precedence_and_folds_like_the_vm_computes() {
    // A is assigned twice, so nothing about it is folded at compile time.
    let out = printed(
        "A = 0\nA = 7\nPRINT 1 + 2 * 3, (1 + 2) * 3, A / 2, -A + 1, 2 - -3, A * 1.5 - 0.5\n\
         PRINT SQRT(A + 9), ABS(-A), MIN(A, 3), MAX(A, 3), SIN(30), COS(60), ATAN2(1, 1)\n\
         PRINT A > 3 AND A < 10, A = 7 OR FALSE, NOT A <> 7, A >= 8, A <= 7\n",
    );
    assert_eq!(
        out,
        [
            "7 9 3.5 -6 5 10",
            "4 7 3 7 0.5 0.5 45",
            "TRUE TRUE TRUE FALSE TRUE"
        ]
    );
}

#[test]
fn if_elseif_else_takes_the_first_true_branch() {
    let src = "FOR i = 1 TO 4\n  IF i = 1 THEN\n    PRINT \"one\"\n  ELSEIF i < 3 THEN\n    PRINT \"few\"\n  ELSEIF i = 3\n    PRINT \"three\"\n  ELSE\n    PRINT \"many\"\n  ENDIF\nNEXT\n";
    assert_eq!(printed(src), ["one", "few", "three", "many"]);
    // Without ELSE, no branch runs when nothing matches.
    let src = "X = 0\nX = 5\nIF X < 0 THEN\n  PRINT \"neg\"\nELSEIF X = 0 THEN\n  PRINT \"zero\"\nENDIF\nPRINT \"end\"\n";
    assert_eq!(printed(src), ["end"]);
}

#[test]
fn while_loops_until_its_condition_is_false() {
    let src = "N = 0\nS = 0\nWHILE N < 5\n  N = N + 1\n  S = S + N\nENDWHILE\nPRINT N, S\n";
    assert_eq!(printed(src), ["5 15"]);
}

#[test]
fn for_counts_down_with_a_negative_step_and_leaves_the_counter_past_the_end() {
    let src = "FOR i = 10 TO 1 STEP -3\n  PRINT i\nNEXT i\nPRINT \"after\", i\n";
    assert_eq!(printed(src), ["10", "7", "4", "1", "after -2"]);
    let src = "FOR x = 0 TO 1 STEP 0.25\n  PRINT x\nNEXT\n";
    assert_eq!(printed(src), ["0", "0.25", "0.5", "0.75", "1"]);
    // The limit and step are evaluated once, when the loop starts.
    let src = "L = 0\nL = 3\nFOR i = 1 TO L\n  L = 10\n  PRINT i\nNEXT\n";
    assert_eq!(printed(src), ["1", "2", "3"]);
}

#[test]
fn a_step_of_zero_at_run_time_is_a_fault_on_the_for_line() {
    let e = fault("S = 1\nS = 0\nFOR i = 1 TO 3 STEP S\n  PRINT i\nNEXT\n");
    assert!(matches!(e.kind, RuntimeErrorKind::BadArgument(_)), "{e}");
    assert_eq!(e.line, 3);
}

#[test]
fn nested_sub_calls_return_to_the_caller() {
    let src = "PRINT \"main\"\nCALL a\nPRINT \"main again\"\nEND\nSUB a\n  PRINT \"a in\"\n  CALL b\n  PRINT \"a out\"\nENDSUB\nSUB b\n  PRINT \"b\"\nENDSUB\n";
    assert_eq!(printed(src), ["main", "a in", "b", "a out", "main again"]);
}

#[test]
fn sub_recursion_is_bounded_and_faults_at_the_call() {
    let src = "N = 0\nCALL down\nEND\nSUB down\n  N = N + 1\n  IF N < 1000 THEN\n    CALL down\n  ENDIF\nENDSUB\n";
    let limits = VmLimits {
        call_depth: 16,
        ..VmLimits::default()
    };
    let r = run_with(&program(src), Io::default(), limits);
    let e = r.fault.expect("too deep");
    assert_eq!(e.kind, RuntimeErrorKind::CallTooDeep);
    assert_eq!((e.line, e.col), (7, 5));
    assert_eq!(
        e.to_string(),
        "line 7: SUB calls nested too deep (a SUB calling itself without end?)"
    );
    // A bounded recursion within the limit finishes.
    let src = "N = 0\nCALL down\nPRINT N\nEND\nSUB down\n  N = N + 1\n  IF N < 10 THEN\n    CALL down\n  ENDIF\nENDSUB\n";
    assert_eq!(printed(src), ["10"]);
}

#[test]
fn pose_arithmetic_fields_and_here() {
    let src = "P = POSE(300, -100, 0, 10)\nQ = P + POSE(0, 0, 10, 0) - POSE(50, 0, 0, 5)\nPRINT Q, Q.X, Q.Y, Q.Z, Q.YAW\nPRINT -Q\nJ = JOINTS(1, 2, 3, 4) + JOINTS(10, 20, 30, 40)\nPRINT J, J.J1, J.J4\nH = HERE()\nPRINT H.X, HERE().Y\n";
    let io = Io {
        inputs: 0,
        here: Pose {
            x: 123.5,
            y: -4.0,
            z: 0.0,
            yaw: 0.0,
        },
    };
    let r = run_with(&program(src), io, VmLimits::default());
    assert_eq!(r.fault, None);
    assert_eq!(
        r.printed,
        [
            "POSE(250, -100, 10, 5) 250 -100 10 5",
            "POSE(-250, 100, -10, -5)",
            "JOINTS(11, 22, 33, 44) 11 44",
            "123.5 -4"
        ]
    );
}

#[test]
fn print_formats_every_type_and_cuts_long_text() {
    let out =
        printed("B = TRUE\nPRINT \"say \"\"hi\"\"\", 1 / 3, 1e20, 0.000001, -0.5, B, 2 > 3\n");
    assert_eq!(out, ["say \"hi\" 0.333333 1e20 1e-6 -0.5 TRUE FALSE"]);
    // The example in docs/language.md.
    let out = printed("P = POSE(300, -100, 0, 0)\nPRINT \"at\", P, \"x =\", P.X, 1 / 3, 2 > 1\n");
    assert_eq!(out, ["at POSE(300, -100, 0, 0) x = 300 0.333333 TRUE"]);
    let long = "é".repeat(200); // 400 bytes
    let out = printed(&format!("PRINT \"{long}\", 1\n"));
    assert_eq!(out[0].len(), PRINT_CAPACITY);
    assert!(long.starts_with(&out[0]));
}

#[test]
fn runtime_errors_carry_the_line_and_column_of_the_operation() {
    let e = fault("X = 1\nFOR i = 0 TO 1\n  X = X / i\nNEXT\n");
    assert_eq!(e.kind, RuntimeErrorKind::DivisionByZero);
    assert_eq!((e.line, e.col), (3, 9));
    assert_eq!(e.to_string(), "line 3: division by zero");

    let e = fault("X = 1\nX = -4\nPRINT SQRT(X)\n");
    assert_eq!(
        e.kind,
        RuntimeErrorKind::BadArgument("SQRT of a negative number")
    );
    assert_eq!(e.line, 3);

    let e = fault("X = 1\nX = 1e300\nY = X * X\nPRINT Y\n");
    assert_eq!(e.kind, RuntimeErrorKind::NotFinite);
    assert_eq!((e.line, e.col), (3, 7));

    let e = fault("FOR n = 30 TO 40\n  OUT n, 1\nNEXT\n");
    assert!(matches!(e.kind, RuntimeErrorKind::BadArgument(_)));
    assert_eq!(e.line, 2);

    let e = fault("S = 50\nS = 150\nSPEED S\n");
    assert!(matches!(e.kind, RuntimeErrorKind::BadArgument(_)));
    assert_eq!(e.line, 3);

    let e = fault("FOR i = 1 TO 2\n  JOG J1, i / 2\nNEXT\n");
    assert!(matches!(e.kind, RuntimeErrorKind::BadArgument(_)));
    assert_eq!(e.line, 2);
}

#[test]
fn a_refused_move_faults_at_the_move_on_the_next_run() {
    let p = program("HOME\nMOVEP POSE(300, 0, 0, 0)\nPRINT \"not reached\"\n");
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    vm.load(&p).unwrap();
    assert!(matches!(vm.run(&p, 100, &mut io), Step::Yield(_)));
    vm.resume(Resume::Ok);
    let step = vm.run(&p, 100, &mut io);
    assert!(matches!(step, Step::Yield(Request::Move(..))), "{step:?}");
    assert!(vm.is_waiting());
    assert_eq!(vm.position(&p).map(|p| p.line), Some(2));
    vm.fail(111, "target out of reach");
    let Step::Fault(e) = vm.run(&p, 100, &mut io) else {
        panic!("a fault")
    };
    assert_eq!(e.line, 2);
    assert_eq!(e.kind.code(), 111);
    assert_eq!(vm.error_text(), "target out of reach");
    // The fault is sticky until the next load.
    assert!(matches!(vm.run(&p, 100, &mut io), Step::Fault(_)));
    vm.load(&p).unwrap();
    assert!(matches!(vm.run(&p, 100, &mut io), Step::Yield(_)));
}

#[test]
fn a_wait_timeout_from_the_host_is_a_fault_at_the_wait() {
    let p = program("OUT 0, 1\nWAIT IN(0) = 1 TIMEOUT 0.5\n");
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    vm.load(&p).unwrap();
    assert_eq!(
        vm.run(&p, 100, &mut io),
        Step::Yield(Request::Out { n: 0, on: true })
    );
    vm.resume(Resume::Ok);
    assert_eq!(
        vm.run(&p, 100, &mut io),
        Step::Yield(Request::WaitInput {
            n: 0,
            value: true,
            timeout_s: Some(0.5)
        })
    );
    vm.resume(Resume::Failed(RuntimeErrorKind::WaitTimeout));
    assert_eq!(
        vm.run(&p, 100, &mut io),
        Step::Fault(RuntimeError {
            kind: RuntimeErrorKind::WaitTimeout,
            line: 2,
            col: 1,
            file: 0,
        })
    );
}

#[test]
fn run_repeats_a_request_until_resumed_and_resume_is_ignored_otherwise() {
    let p = program("DELAY 1.5\n");
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    vm.resume(Resume::Ok); // nothing loaded: ignored
    vm.load(&p).unwrap();
    vm.resume(Resume::Ok); // not waiting: ignored
    let delay = Step::Yield(Request::Delay { seconds: 1.5 });
    assert_eq!(vm.run(&p, 10, &mut io), delay);
    assert_eq!(vm.run(&p, 10, &mut io), delay);
    vm.resume(Resume::Ok);
    assert_eq!(vm.run(&p, 10, &mut io), Step::Done);
    assert_eq!(vm.run(&p, 10, &mut io), Step::Done);
}

#[test]
fn the_budget_bounds_each_run_and_execution_continues_where_it_stopped() {
    let p = program("N = 0\nWHILE N < 100\n  N = N + 1\nENDWHILE\nPRINT N\n");
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    vm.load(&p).unwrap();
    let mut rounds = 0;
    loop {
        match vm.run(&p, 10, &mut io) {
            Step::Budget => rounds += 1,
            Step::Yield(Request::Print) => break,
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(vm.print_text(), "100");
    // About 8 instructions per iteration: the loop needs many rounds of 10.
    assert!(rounds > 50, "{rounds}");
    assert_eq!(vm.run(&p, 0, &mut io), Step::Yield(Request::Print));
}

#[test]
fn abort_ends_the_program() {
    let p = program("WHILE TRUE\n  DELAY 1\nENDWHILE\n");
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    vm.load(&p).unwrap();
    assert!(matches!(vm.run(&p, 10, &mut io), Step::Yield(_)));
    vm.abort();
    assert!(!vm.is_waiting());
    assert_eq!(vm.run(&p, 10, &mut io), Step::Done);
}

#[test]
fn load_checks_the_limits_and_run_checks_the_program() {
    let p = program("A = 1\nA = 2\nX = ((((A + 2) * 3) - 4) / 5)\nY = X\nZ = Y + X\nPRINT Z\n");
    let mut vm = Vm::new(VmLimits {
        stack: 1,
        variables: 16,
        call_depth: 4,
        ..VmLimits::default()
    });
    assert_eq!(
        vm.load(&p),
        Err(LoadError::StackTooSmall {
            needed: p.max_stack(),
            limit: 1
        })
    );
    let mut vm = Vm::new(VmLimits {
        stack: 16,
        variables: 2,
        call_depth: 4,
        ..VmLimits::default()
    });
    assert_eq!(
        vm.load(&p),
        Err(LoadError::TooManyVariables {
            needed: 4,
            limit: 2
        })
    );
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    let Step::Fault(e) = vm.run(&p, 10, &mut io) else {
        panic!("nothing loaded")
    };
    assert_eq!(e.kind, RuntimeErrorKind::NotLoaded);
    vm.load(&p).unwrap();
    let other = program("PRINT 1\n");
    let Step::Fault(e) = vm.run(&other, 10, &mut io) else {
        panic!("another program")
    };
    assert_eq!(e.kind, RuntimeErrorKind::NotLoaded);
    // A clone is the same program.
    let clone = p.clone();
    assert_eq!(vm.run(&clone, 100, &mut io), Step::Yield(Request::Print));
}

#[test]
fn variables_are_shared_with_subs_and_reset_by_load() {
    let p = program("CALL setup\nPRINT N\nN = N + 1\nPRINT N\nEND\nSUB setup\n  N = 41\nENDSUB\n");
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    for _ in 0..2 {
        vm.load(&p).unwrap();
        let mut texts = Vec::new();
        loop {
            match vm.run(&p, 100, &mut io) {
                Step::Yield(Request::Print) => {
                    texts.push(vm.print_text().to_string());
                    vm.resume(Resume::Ok);
                }
                Step::Done => break,
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(texts, ["41", "42"]);
    }
}

#[test]
fn inputs_are_read_through_the_host() {
    let p = program(
        "IF IN(3) AND NOT IN(4) THEN\n  PRINT \"ready\"\nELSE\n  PRINT \"not ready\"\nENDIF\n",
    );
    let ready = Io {
        inputs: 1 << 3,
        ..Io::default()
    };
    assert_eq!(run_with(&p, ready, VmLimits::default()).printed, ["ready"]);
    assert_eq!(run(&p).printed, ["not ready"]);
}
