//! Error handling: TRY … CATCH … ENDTRY, ERR / ERRMSG$ / ERRLINE, RETRY, RAISE, errors the
//! host reports (a failed transfer, a refused move, a WAIT that timed out), errors passed
//! on to an outer TRY, and the statements that need a CATCH.

use wrc_lang::{
    compile, Motion, Request, Resume, RuntimeErrorKind, Step, TransferKind, Vm, VmLimits,
};

use crate::common::{answer, printed, program, robot, run, Io};

/// Run `source`, answering with [`answer`] except that the requests `fail` picks (by
/// their order, from 0) fail with its code and text. Returns what was printed and the
/// fault's code, if any.
fn run_failing(source: &str, fail: &[(usize, u16, &str)]) -> (Vec<String>, Option<u16>) {
    let p = program(source);
    let mut vm = Vm::new(VmLimits::default());
    vm.load(&p).unwrap();
    let io = Io::default();
    let mut printed = Vec::new();
    let mut n = 0;
    for _ in 0..100_000 {
        match vm.run(&p, 50, &mut io.clone()) {
            Step::Budget => {}
            Step::Done => return (printed, None),
            Step::Fault(e) => return (printed, Some(e.kind.code())),
            Step::Break(at) => panic!("stopped at {at:?}"),
            Step::Yield(r) => {
                if r == Request::Print {
                    printed.push(vm.print_text().to_string());
                }
                match fail.iter().find(|(k, ..)| *k == n) {
                    Some((_, code, text)) => vm.fail(*code, text),
                    None => vm.resume(answer(&r, &io)),
                }
                n += 1;
            }
        }
    }
    panic!("did not end");
}

#[test]
fn a_catch_takes_the_errors_of_its_codes_and_the_program_goes_on_after_endtry() {
    let src = "\
TRY
  GET \"LP1\", 1
  PRINT \"not reached\"
CATCH 131, 136
  PRINT \"skip\", ERR, ERRMSG$, ERRLINE
CATCH 212
  PRINT \"vacuum\"
ENDTRY
PRINT \"after\", ERR
";
    // Request 0 is the GET: it fails as an empty slot.
    let (out, fault) = run_failing(src, &[(0, 131, "the slot is empty")]);
    assert_eq!(out, ["skip 131 the slot is empty 2", "after 0"]);
    assert_eq!(fault, None);
    let (out, _) = run_failing(src, &[(0, 212, "wafer not sensed")]);
    assert_eq!(out, ["vacuum", "after 0"]);
    // Without an error the CATCHes do not run.
    let (out, _) = run_failing(src, &[]);
    assert_eq!(out, ["not reached", "after 0"]);
}

#[test]
fn an_error_no_catch_takes_goes_on_to_the_outer_try_or_ends_the_program() {
    let src = "\
TRY
  TRY
    MAP \"LP1\"
  CATCH 131
    PRINT \"inner\"
  ENDTRY
CATCH
  PRINT \"outer\", ERR, ERRLINE
ENDTRY
MAP \"LP2\"
PRINT \"not reached\"
";
    let (out, fault) = run_failing(src, &[(0, 135, "interlock closed"), (2, 135, "closed")]);
    assert_eq!(out, ["outer 135 3"]);
    assert_eq!(fault, Some(135), "the MAP after the TRY is not caught");
}

#[test]
fn retry_runs_the_failed_statement_again_with_the_try_in_force() {
    let src = "\
TRIES = 0
TRY
  PRINT \"start\"
  GET \"LP1\", 1
  PRINT \"got it after\", TRIES
CATCH 212
  TRIES = TRIES + 1
  IF TRIES < 3 THEN
    RETRY
  ENDIF
  PRINT \"giving up\"
ENDTRY
";
    // Requests: 0 PRINT start, 1 GET (fails), 2 GET (fails), 3 GET (ok), 4 PRINT.
    let (out, _) = run_failing(src, &[(1, 212, "miss"), (2, 212, "miss")]);
    assert_eq!(
        out,
        ["start", "got it after 2"],
        "RETRY does not run PRINT start again"
    );
    let (out, fault) = run_failing(src, &[(1, 212, "miss"), (2, 212, "miss"), (3, 212, "miss")]);
    assert_eq!(out, ["start", "giving up"]);
    assert_eq!(fault, None);
}

#[test]
fn retry_of_an_error_inside_a_sub_runs_the_call_again() {
    let src = "\
N = 0
CALLS = 0
TRY
  CALL pick(3)
CATCH
  N = N + 1
  IF N = 1 THEN
    RETRY
  ENDIF
ENDTRY
PRINT \"calls\", CALLS, \"errors\", N
END
SUB pick(slot)
  CALLS = CALLS + 1
  GET \"LP1\", slot
ENDSUB
";
    let (out, _) = run_failing(src, &[(0, 212, "miss")]);
    assert_eq!(out, ["calls 2 errors 1"]);
}

#[test]
fn raise_makes_a_users_error_that_a_catch_or_the_host_sees() {
    let out = printed(
        "\
TRY
  RAISE 1001, \"no wafer in \" + \"LP1\"
CATCH 1001
  PRINT ERR, ERRMSG$
ENDTRY
TRY
  RAISE 1002
CATCH
  PRINT ERR, ERRMSG$
ENDTRY
",
    );
    assert_eq!(
        out,
        [
            "1001 no wafer in LP1",
            "1002 error 1002 raised by the program"
        ]
    );
    let r = run(&program(
        "RAISE 1003, \"operator must check the cassette\"\n",
    ));
    let e = r.fault.expect("RAISE ends the program");
    assert_eq!(e.kind, RuntimeErrorKind::Raised { code: 1003 });
    assert_eq!(r.error_text, "operator must check the cassette");
}

#[test]
fn raise_err_passes_the_error_on_unchanged() {
    let (out, fault) = run_failing(
        "TRY\n  GET \"LP1\", 2\nCATCH\n  PRINT \"log\", ERR\n  RAISE ERR, ERRMSG$\nENDTRY\n",
        &[(0, 131, "the slot is empty")],
    );
    assert_eq!(out, ["log 131"]);
    assert_eq!(fault, Some(131));
}

#[test]
fn program_errors_are_caught_with_code_210_and_wait_timeouts_with_211() {
    let out = printed(
        "\
Z = 1
Z = 0
TRY
  X = 1 / Z
CATCH 210
  PRINT ERR, ERRMSG$
ENDTRY
",
    );
    assert_eq!(out, ["210 division by zero"]);
    let p = program(
        "TRY\n  WAIT IN(3) = 1 TIMEOUT 1\nCATCH 211\n  PRINT \"timeout\", ERRLINE\nENDTRY\n",
    );
    let mut vm = Vm::new(VmLimits::default());
    vm.load(&p).unwrap();
    let mut io = Io::default();
    assert!(matches!(
        vm.run(&p, 100, &mut io),
        Step::Yield(Request::WaitInput { .. })
    ));
    vm.resume(Resume::Failed(RuntimeErrorKind::WaitTimeout));
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(Request::Print));
    assert_eq!(vm.print_text(), "timeout 2");
}

#[test]
fn exit_and_return_leave_a_try_without_keeping_its_handler() {
    // After EXIT FOR left the TRY, an error outside any TRY must end the program, not jump
    // into the loop's old CATCH.
    let (out, fault) = run_failing(
        "\
FOR i = 1 TO 3
  TRY
    EXIT FOR
  CATCH
    PRINT \"wrong catch\"
  ENDTRY
NEXT
PRINT f()
MAP \"LP1\"
END
FUNCTION f()
  TRY
    RETURN 7
  CATCH
    PRINT \"wrong catch\"
  ENDTRY
ENDFUNCTION
",
        &[(1, 135, "closed")],
    );
    assert_eq!(out, ["7"]);
    assert_eq!(fault, Some(135));
}

#[test]
fn an_error_inside_a_catch_goes_to_the_outer_try() {
    let (out, _) = run_failing(
        "\
TRY
  TRY
    MAP \"LP1\"
  CATCH
    MAP \"LP2\"
  ENDTRY
CATCH 133
  PRINT \"outer got\", ERR
ENDTRY
",
        &[(0, 131, "empty"), (1, 133, "hand full")],
    );
    assert_eq!(out, ["outer got 133"]);
}

#[test]
fn error_handling_mistakes_are_compile_errors() {
    let c = compile(
        "RETRY\nTRY\n  X = 1\nENDTRY\nTRY\nCATCH\nCATCH 5\nENDTRY\nTRY\nCATCH LEN(\"ab\")\nENDTRY\nRAISE 0\nPRINT ERR\n",
        "t.wrl",
        &robot(),
    );
    let msgs: Vec<String> = c
        .diagnostics
        .iter()
        .filter(|d| d.is_error() || d.message.starts_with("ERR"))
        .map(|d| format!("{}:{} {}", d.line, d.col, d.message))
        .collect();
    assert_eq!(
        msgs,
        [
            "1:1 RETRY outside a CATCH block: it runs the failed statement of a TRY again",
            "2:1 TRY needs at least one CATCH: TRY … CATCH [codes] … ENDTRY",
            "7:1 this CATCH never runs: the CATCH at 6:1 (without codes) catches every error",
            "10:7 a CATCH code is a constant whole number from 1 to 65535 (docs/protocol.md lists the controller's; RAISE makes your own)",
            "12:7 RAISE takes a code that is a whole number from 1 to 65535 (use 1000 and up for your own), got 0",
            "13:7 ERR is only meaningful inside a CATCH block (it is 0 or \"\" elsewhere)",
        ]
    );
}

#[test]
fn alarm_and_the_operator_reach_the_host_and_the_answer_is_read_back() {
    let p = program(
        "ALARM 1001, \"vacuum miss at \" + \"LP1 3\"\nWAIT OPERATOR \"check LP1, then CONTINUE RETRY or SKIP\"\nPRINT OPERATOR$\nWAIT OPERATOR\nPRINT \"[\" + OPERATOR$ + \"]\"\n",
    );
    let mut vm = Vm::new(VmLimits::default());
    vm.load(&p).unwrap();
    let mut io = Io::default();
    assert_eq!(
        vm.run(&p, 100, &mut io),
        Step::Yield(Request::Alarm { code: 1001 })
    );
    assert_eq!(vm.print_text(), "vacuum miss at LP1 3");
    vm.resume(Resume::Ok);
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(Request::Operator));
    assert_eq!(vm.print_text(), "check LP1, then CONTINUE RETRY or SKIP");
    vm.resume(Resume::Value(wrc_lang::Answer::Text(
        wrc_lang::Text::new("SKIP").unwrap(),
    )));
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(Request::Print));
    assert_eq!(vm.print_text(), "SKIP");
    vm.resume(Resume::Ok);
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(Request::Operator));
    assert_eq!(vm.print_text(), "");
    vm.resume(Resume::Ok);
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(Request::Print));
    assert_eq!(vm.print_text(), "[]");
}

#[test]
fn a_refused_move_is_caught_with_the_hosts_code() {
    let (out, _) = run_failing(
        "TRY\n  MOVEP POSE(300, 0, 0, 0)\nCATCH 111, 112, 113\n  PRINT \"refused\", ERR, ERRMSG$\nENDTRY\n",
        &[(0, 113, "the straight line leaves the workspace")],
    );
    assert_eq!(out, ["refused 113 the straight line leaves the workspace"]);
}

#[test]
fn the_transfer_kinds_reach_the_host_inside_a_try() {
    let r = run(&program(
        "TRY\n  GET \"LP1\", 1\n  PUT \"LP2\", 1\nCATCH\nENDTRY\n",
    ));
    let kinds: Vec<_> = r
        .requests
        .iter()
        .filter_map(|q| match q {
            Request::Transfer { kind, .. } => Some(*kind),
            _ => None,
        })
        .collect();
    assert_eq!(kinds, [TransferKind::Get, TransferKind::Put]);
    assert!(!r
        .requests
        .iter()
        .any(|q| matches!(q, Request::Move(Motion::Home, _))));
}
