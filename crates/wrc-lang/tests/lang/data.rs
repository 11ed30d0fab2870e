//! Data and procedures: arrays, SUBs and FUNCTIONs with parameters, locals and return
//! values, recursion, strings and number formatting, SELECT CASE, DO … LOOP, EXIT.

use wrc_lang::{compile, RuntimeErrorKind};

use crate::common::{printed, program, robot, run};

/// The errors of `source`, which must not compile: `line:col message` each.
fn errors(source: &str) -> Vec<String> {
    let c = compile(source, "t.wrl", &robot());
    assert!(c.program.is_none(), "compiled: {source}");
    c.diagnostics
        .iter()
        .filter(|d| d.is_error())
        .map(|d| format!("{}:{} {}", d.line, d.col, d.message))
        .collect()
}

#[test]
fn arrays_of_numbers_poses_and_strings_hold_their_elements() {
    let out = printed(
        "\
DIM N[5]
DIM P[3] AS POSE
DIM S$[2] AS STRING
DIM M[2, 3]
FOR i = 0 TO 4
  N[i] = i * i
NEXT
P[1] = POSE(1, 2, 3, 4)
S$[0] = \"LP\" + \"1\"
FOR r = 0 TO 1
  FOR c = 0 TO 2
    M[r, c] = 10 * r + c
  NEXT
NEXT
PRINT N[0], N[4], P[1].Y, P[0].X, S$[0], S$[1] = \"\", M[1, 2], M[0, 1]
",
    );
    assert_eq!(out, ["0 16 2 0 LP1 TRUE 12 1"]);
}

#[test]
fn an_index_outside_the_array_is_a_run_time_error_that_names_it() {
    let r = run(&program("DIM A[3]\nI = 0\nI = 3\nA[I] = 1\n"));
    let e = r.fault.expect("a fault");
    assert_eq!((e.kind, e.line), (RuntimeErrorKind::IndexOutOfRange, 4));
    assert_eq!(r.error_text, "array index 3 is outside 0 to 2");
    // Two dimensions are each checked: [0, 5] of a 2x3 array is not element 5.
    let r = run(&program("DIM M[2, 3]\nJ = 0\nJ = 5\nPRINT M[0, J]\n"));
    assert_eq!(r.error_text, "array index 5 is outside 0 to 2");
    let r = run(&program("DIM A[3]\nI = 0\nI = 0.5\nPRINT A[I]\n"));
    assert_eq!(r.error_text, "array index 0.5 is outside 0 to 2");
}

#[test]
fn array_mistakes_are_compile_errors() {
    let e = errors("DIM A[3]\nA[3] = 1\nPRINT A\nB = 1\nB[0] = 2\nDIM C[0]\nDIM D[2]\nD[0] = \"x\"\nPRINT A[1, 2]\n");
    assert_eq!(
        e,
        [
            "2:3 index 3 is outside A[3]: indexes go from 0 to 2",
            "3:7 A is an array of 3 numbers[3]: use one element, A[i]",
            "5:1 B is not an array; declare one with DIM B[size]",
            "6:7 an array's size must be a constant whole number from 1 to 65536",
            "8:8 D holds numbers; an element cannot be assigned a string",
            "9:7 A has 1 dimension (A[3]), got 2 indexes",
        ]
    );
}

#[test]
fn subs_and_functions_take_parameters_by_value_and_keep_locals_per_call() {
    let out = printed(
        "\
X = 1
depth = 0
CALL bump(X)
PRINT X, twice(21), hyp(3, 4), name$(\"LP\", 2)
PRINT fact(10), depth
END

SUB bump(n)
  n = n + 100         ' the caller's X is not changed
  PRINT \"bumped\", n
ENDSUB

FUNCTION twice(v)
  RETURN v * 2
ENDFUNCTION

FUNCTION hyp(a, b)
  LOCAL sq = a * a + b * b
  RETURN SQRT(sq)
ENDFUNCTION

FUNCTION name$(s AS STRING, n) AS STRING
  RETURN s + STR$(n)
ENDFUNCTION

FUNCTION fact(n)
  depth = depth + 1   ' a global, shared
  IF n <= 1 THEN
    RETURN 1
  ENDIF
  RETURN n * fact(n - 1)
ENDFUNCTION
",
    );
    assert_eq!(out, ["bumped 101", "1 42 5 LP2", "3628800 10"]);
}

#[test]
fn a_name_that_ends_in_a_dollar_is_a_string_where_no_as_says_otherwise() {
    let out = printed(
        "\
CALL greet(\"cell\")
PRINT label$(3)
END
SUB greet(who$)
  LOCAL text$ = \"hello \" + who$
  DIM parts$[2]
  parts$[1] = text$
  PRINT parts$[1]
ENDSUB
FUNCTION label$(n)
  RETURN \"slot \" + STR$(n)
ENDFUNCTION
",
    );
    assert_eq!(out, ["hello cell", "slot 3"]);
    let e = errors("CALL greet(1)\nEND\nSUB greet(who$)\n  PRINT who$\nENDSUB\n");
    assert_eq!(
        e,
        ["1:12 argument 1 of greet must be a string, got a number"]
    );
}

#[test]
fn a_function_in_an_expression_can_move_the_robot() {
    // The expression's values wait on the stack while the FUNCTION's motion runs.
    let r = run(&program(
        "X = 1 + reach(POSE(300, 0, 0, 0)) * 10\nPRINT X\nEND\nFUNCTION reach(p AS POSE)\n  MOVEL p\n  RETURN p.X\nENDFUNCTION\n",
    ));
    assert_eq!(r.fault, None);
    assert_eq!(r.printed, ["3001"]);
    assert!(matches!(r.requests[0], wrc_lang::Request::Move(..)));
}

#[test]
fn procedure_mistakes_are_compile_errors() {
    let e = errors(
        "\
CALL s(1, 2)
Y = f(\"x\")
Z = s(1)
CALL nothere
PRINT g()
END
SUB s(a)
  RETURN 5
ENDSUB
FUNCTION f(n)
  RETURN \"text\"
ENDFUNCTION
FUNCTION g()
  PRINT 1
ENDFUNCTION
",
    );
    assert_eq!(
        e,
        [
            "1:1 SUB s takes 1 argument, got 2",
            "2:7 argument 1 of f must be a number, got a string",
            "3:5 s is a SUB and returns no value: run it with CALL s(…)",
            "4:6 unknown SUB nothere; the SUBs and FUNCTIONs are s, f, g",
            "8:10 SUB s returns no value; make it a FUNCTION to return one",
            "11:10 FUNCTION f returns a number, got a string",
            "13:10 FUNCTION g never returns a value: end it with RETURN value",
        ]
    );
}

#[test]
fn a_function_that_falls_off_its_end_is_a_run_time_error() {
    let r = run(&program(
        "PRINT f(1)\nEND\nFUNCTION f(n)\n  IF n > 5 THEN\n    RETURN 1\n  ENDIF\nENDFUNCTION\n",
    ));
    assert_eq!(r.fault.map(|e| e.kind), Some(RuntimeErrorKind::NoReturn));
    assert_eq!(r.error_text, "FUNCTION f ended without RETURN");
}

#[test]
fn deep_recursion_is_a_catchable_error_not_a_crash() {
    let out = printed(
        "\
TRY
  CALL down(0)
CATCH 210
  PRINT \"caught\", ERR, ERRMSG$
ENDTRY
END
SUB down(n)
  CALL down(n + 1)
ENDSUB
",
    );
    assert_eq!(
        out,
        ["caught 210 SUB calls nested too deep (a SUB calling itself without end?)"]
    );
}

#[test]
fn strings_concatenate_format_and_slice() {
    let out = printed(
        "\
S$ = \"wafer \" + STR$(3) + \" of \" + FORMAT$(25, \"000\")
PRINT S$, LEN(S$), LEFT$(S$, 5), RIGHT$(S$, 3), MID$(S$, 7, 1)
PRINT FORMAT$(3.14159, \"0.00\"), FORMAT$(-0.5, \"0.0\"), STR$(1 / 3), VAL(\"12.5\") * 2
PRINT UCASE$(\"lp1\"), LCASE$(\"PM\"), INSTR(\"LP1,LP2\", \"LP2\"), INSTR(\"a\", \"z\")
PRINT ROUND(2.5), ROUND(-2.5), ROUND(1.23456, 2), INT(-1.5), SGN(-3), 7 MOD 3, -7 MOD 3
",
    );
    assert_eq!(
        out,
        [
            "wafer 3 of 025 14 wafer 025 3",
            "3.14 -0.5 0.333333 25",
            "LP1 pm 5 0",
            "3 -3 1.23 -2 -1 1 2",
        ]
    );
}

#[test]
fn a_string_too_long_or_a_bad_val_is_a_run_time_error() {
    let r = run(&program(
        "S$ = \"x\"\nFOR i = 1 TO 8\n  S$ = S$ + S$\nNEXT\n",
    ));
    assert_eq!(
        r.error_text,
        "a string built while the program runs is limited to 126 bytes"
    );
    assert_eq!(r.fault.map(|e| e.line), Some(3));
    let r = run(&program("T$ = \"12a\"\nX = VAL(T$)\n"));
    assert_eq!(r.error_text, "VAL of a string that is not a number");
}

#[test]
fn string_mistakes_are_compile_errors() {
    let e = errors("A$ = 1\nB = \"n\" + 1\nC = FORMAT$(1, 2)\n");
    assert_eq!(
        e,
        [
            "1:6 A$ ends in $, so it holds a string; it cannot be assigned a number",
            "2:9 cannot add a string and a number: to put a number into a string write STR$(x) or FORMAT$(x, \"0.0\")",
            "3:16 FORMAT$ takes a string here, got a number",
        ]
    );
    let r = run(&program("X$ = FORMAT$(1, \"#.##\")\nPRINT X$\n"));
    assert_eq!(
        r.error_text,
        "a FORMAT$ pattern is 0s with an optional point, like \"0.00\" or \"000\""
    );
}

#[test]
fn select_case_takes_the_first_matching_case() {
    let src = "\
FOR n = 0 TO 6
  SELECT CASE n
    CASE 0
      PRINT n, \"zero\"
    CASE 1, 2
      PRINT n, \"one or two\"
    CASE 3 TO 4
      PRINT n, \"three to four\"
    CASE ELSE
      PRINT n, \"many\"
  ENDSELECT
NEXT
S$ = \"PM1\"
SELECT CASE S$
  CASE \"LP1\", \"LP2\"
    PRINT \"port\"
  CASE \"PM1\"
    PRINT \"module\"
END SELECT
";
    assert_eq!(
        printed(src),
        [
            "0 zero",
            "1 one or two",
            "2 one or two",
            "3 three to four",
            "4 three to four",
            "5 many",
            "6 many",
            "module"
        ]
    );
    let e = errors("SELECT CASE POSE(1, 2, 3, 4)\n  CASE 1\nENDSELECT\nX = 1\nSELECT CASE X\n  CASE \"a\"\n  CASE ELSE\n  CASE 2\nENDSELECT\n");
    assert_eq!(
        e,
        [
            "1:13 SELECT CASE tests a number or a string, got a pose",
            "6:8 CASE compares with a number, got a string",
            "8:3 CASE after CASE ELSE; CASE ELSE must be the last",
        ]
    );
}

#[test]
fn do_loops_test_before_or_after_and_exit_leaves_the_innermost_loop() {
    let out = printed(
        "\
N = 0
DO
  N = N + 1
LOOP UNTIL N >= 3
PRINT \"until\", N
DO WHILE N > 0
  N = N - 1
LOOP
PRINT \"while\", N
DO
  N = N + 1
  IF N = 5 THEN
    EXIT DO
  ENDIF
LOOP
PRINT \"exit do\", N
FOR i = 1 TO 10
  FOR j = 1 TO 10
    IF j = 2 THEN
      EXIT FOR
    ENDIF
  NEXT
  IF i = 3 THEN
    EXIT FOR
  ENDIF
NEXT
PRINT \"exit for\", i, j
W = 0
WHILE TRUE
  W = W + 1
  IF W > 4 THEN
    EXIT WHILE
  ENDIF
ENDWHILE
PRINT \"exit while\", W
CALL early(1)
CALL early(9)
END
SUB early(x)
  IF x > 5 THEN
    EXIT SUB
  ENDIF
  PRINT \"not early\", x
ENDSUB
",
    );
    assert_eq!(
        out,
        [
            "until 3",
            "while 0",
            "exit do 5",
            "exit for 3 2",
            "exit while 5",
            "not early 1"
        ]
    );
    let e = errors("EXIT FOR\nDO\nLOOP WHILE 1\nDO WHILE TRUE\nLOOP UNTIL TRUE\n");
    assert_eq!(
        e,
        [
            "1:1 EXIT FOR outside a FOR (END ends the program)",
            "3:12 WHILE needs a condition that is TRUE or FALSE (a comparison like X > 0), got a number",
            "5:12 a DO loop has one condition: after DO or after LOOP, not both",
        ]
    );
}

#[test]
fn locals_are_fresh_in_every_call_and_recursion_keeps_them_apart() {
    let out = printed(
        "\
PRINT sum(4)
END
FUNCTION sum(n)
  DIM parts[2]
  LOCAL total = 0
  parts[0] = n
  IF n > 0 THEN
    parts[1] = sum(n - 1)
  ENDIF
  FOR k = 0 TO 1
    total = total + parts[k]
  NEXT
  RETURN total
ENDFUNCTION
",
    );
    assert_eq!(out, ["10"]);
}

#[test]
fn a_program_with_errors_still_reports_the_names_it_defines() {
    let c = compile(
        "COUNT = 1\nlabel$ = \"x\"\nCALL tick(COUNT)\nPRINT nothere + 1\nEND\nSUB tick(n)\n  LOCAL k = n\n  PRINT k\nENDSUB\n",
        "p.wrl",
        &robot(),
    );
    assert!(c.program.is_none());
    assert!(c.errors() > 0);
    let kinds: Vec<(&str, &str, &str)> = c
        .symbols
        .iter()
        .map(|s| (s.name.as_str(), s.kind, s.ty))
        .collect();
    for want in [
        ("COUNT", "variable", "number"),
        ("label$", "variable", "string"),
        ("tick", "sub", ""),
        ("n", "parameter", "number"),
        ("k", "local", "number"),
    ] {
        assert!(kinds.contains(&want), "{want:?} in {kinds:?}");
    }
}

#[test]
fn case_is_compares_the_subject_and_mixes_with_values_and_ranges() {
    let src = "\
FOR n = 0 TO 7
  SELECT CASE n
    CASE IS < 1
      PRINT n, \"none\"
    CASE 2, IS >= 6
      PRINT n, \"two or six up\"
    CASE 3 TO 4, IS = 1
      PRINT n, \"one, three or four\"
    CASE IS <> 5
      PRINT n, \"not five\"
    CASE ELSE
      PRINT n, \"five\"
  ENDSELECT
NEXT
S$ = \"PM1\"
SELECT CASE S$
  CASE IS = \"LP1\"
    PRINT \"port\"
  CASE IS <> \"AL\"
    PRINT \"not the aligner\"
ENDSELECT
";
    assert_eq!(
        printed(src),
        [
            "0 none",
            "1 one, three or four",
            "2 two or six up",
            "3 one, three or four",
            "4 one, three or four",
            "5 five",
            "6 two or six up",
            "7 two or six up",
            "not the aligner"
        ]
    );
    let e = errors(
        "S$ = \"a\"\nSELECT CASE S$\n  CASE IS < \"b\"\nENDSELECT\nSELECT CASE 1\n  CASE IS > \"b\"\nENDSELECT\n",
    );
    assert_eq!(
        e,
        [
            "3:13 CASE IS < compares numbers; strings compare with CASE IS = or CASE IS <>",
            "6:13 CASE IS compares with a number, got a string",
        ]
    );
}

#[test]
fn a_single_line_if_runs_one_statement_and_an_optional_else_without_endif() {
    let src = "\
FOR n = 1 TO 4
  IF n = 2 THEN PRINT n, \"two\"
  IF n > 2 THEN PRINT n, \"big\" ELSE PRINT n, \"small\"
  IF n = 4 THEN EXIT FOR
NEXT
x = 0
IF x = 0 THEN x = 10 ELSE x = 20
PRINT x
IF x > 5 THEN
  PRINT \"block\"
ENDIF
";
    assert_eq!(
        printed(src),
        ["1 small", "2 two", "2 small", "3 big", "4 big", "10", "block"]
    );
    let e = errors("IF 1 > 0 THEN WHILE 1 > 0\nIF 1 > 0 THEN\nENDIF\nIF 1 > 0 THEN PRINT 1 ELSE\nIF 1 > 0 THEN x = \nPRINT 2\n");
    assert_eq!(
        e,
        [
            "1:15 after THEN on the same line only a simple statement may follow, not WHILE; put a block on the lines below IF … THEN and close it with ENDIF",
            "4:27 expected a statement after ELSE, found the end of the line",
            "5:19 expected a value, found the end of the line",
        ]
    );
}
