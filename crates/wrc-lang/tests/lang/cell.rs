//! Cell data in programs: the wafer map and station questions the host answers, named
//! points from the points file (with the compiler's checks), TEACH, INCLUDE and CALL
//! PROGRAM through `wrc_lang::Sources`.

use wrc_lang::{
    compile_with, Answer, CellInfo, CompileOptions, Compiled, Request, Resume, Step, Vm, VmLimits,
};
use wrc_robot::Pose;

use crate::common::{answer, robot, Io, Store};

fn compile_in(store: &Store, name: &str, source: &str) -> Compiled {
    compile_with(
        source,
        &format!("{name}.wrl"),
        &robot(),
        &CompileOptions {
            name,
            sources: Some(store),
        },
    )
}

/// Messages of `c`'s errors, `file:line:col message`.
fn errors(c: &Compiled) -> Vec<String> {
    c.diagnostics
        .iter()
        .filter(|d| d.is_error())
        .map(|d| {
            format!(
                "{}:{}:{} {}",
                d.file.as_deref().unwrap_or("main"),
                d.line,
                d.col,
                d.message
            )
        })
        .collect()
}

/// Run a compiled program to its end with the test cell; what it printed and asked.
fn run_compiled(c: &Compiled) -> (Vec<String>, Vec<Request>) {
    let p = c.program.as_ref().expect("compiles");
    let mut vm = Vm::new(VmLimits::default());
    vm.load(p).unwrap();
    let io = Io {
        inputs: 0,
        here: Pose {
            x: 250.0,
            y: 10.0,
            z: 5.0,
            yaw: 45.0,
        },
    };
    let (mut printed, mut asked) = (Vec::new(), Vec::new());
    loop {
        match vm.run(p, 100, &mut io.clone()) {
            Step::Budget => {}
            Step::Done => return (printed, asked),
            Step::Fault(e) => panic!("{e}: {}", vm.error_text()),
            Step::Break(at) => panic!("{at:?}"),
            Step::Yield(r) => {
                if r == Request::Print {
                    printed.push(vm.print_text().to_string());
                }
                asked.push(r);
                vm.resume(answer(&r, &io));
            }
        }
    }
}

#[test]
fn a_program_reads_the_wafer_map_and_the_stations_from_the_host() {
    let store = Store::default();
    let c = compile_in(
        &store,
        "scan",
        "\
FOR n = 1 TO 2
  IF SLOT(\"LP1\", n) = 1 THEN
    PRINT n, WAFER$(\"LP1\", n)
  ENDIF
NEXT
PRINT \"[\" + HAND$() + \"]\", \"[\" + HAND$(B) + \"]\", SLOTS(\"LP2\"), PITCH(\"LP2\"), APPROACH(\"AL\"), STATION(\"PM1\").X
slot = 4
PRINT slot
",
    );
    assert!(errors(&c).is_empty(), "{:?}", errors(&c));
    let (out, asked) = run_compiled(&c);
    assert_eq!(out, ["1 W1", "2 W2", "[] [] 25 10 200 300", "4"]);
    let infos: Vec<_> = asked
        .iter()
        .filter_map(|r| match r {
            Request::Cell(q) => Some((q.info, q.station.as_str().to_string(), q.slot, q.blade_b)),
            _ => None,
        })
        .collect();
    assert_eq!(infos[0], (CellInfo::SlotState, "LP1".to_string(), 1, false));
    assert_eq!(infos[1], (CellInfo::SlotWafer, "LP1".to_string(), 1, false));
    assert_eq!(infos[4].0, CellInfo::HandWafer);
    assert!(infos[5].3, "HAND$(B) asks for blade B");
    assert_eq!(infos.len(), 10);
}

#[test]
fn a_host_that_cannot_answer_fails_the_question_and_a_try_catches_it() {
    let store = Store::default();
    let c = compile_in(
        &store,
        "q",
        "TRY\n  N = SLOTS(\"XX\")\nCATCH 130\n  PRINT \"no station\", ERRMSG$\nENDTRY\n",
    );
    let p = c.program.unwrap();
    let mut vm = Vm::new(VmLimits::default());
    vm.load(&p).unwrap();
    let mut io = Io::default();
    assert!(matches!(
        vm.run(&p, 100, &mut io),
        Step::Yield(Request::Cell(_))
    ));
    vm.fail(130, "no such station XX");
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(Request::Print));
    assert_eq!(vm.print_text(), "no station no such station XX");
    // An answer of the wrong type is the host's bug, reported as such.
    vm.load(&p).unwrap();
    assert!(matches!(
        vm.run(&p, 100, &mut io),
        Step::Yield(Request::Cell(_))
    ));
    vm.resume(Resume::Value(Answer::Pose(Pose::default())));
    let Step::Fault(e) = vm.run(&p, 100, &mut io) else {
        panic!("a wrong answer is an internal error, not caught")
    };
    assert_eq!(e.kind.code(), 301);
}

#[test]
fn cell_question_mistakes_are_compile_errors() {
    let store = Store::default();
    let c = compile_in(
        &store,
        "q",
        "A = SLOT(\"L P1\", 1)\nB = SLOT(\"LP1\", 0)\nC = SLOT(3, 1)\nD$ = HAND$(C)\nE = SLOTS()\n",
    );
    assert_eq!(
        errors(&c),
        [
            "main:1:10 \"L P1\" is not a station name; station names are 1 to 16 letters, digits, '_' or '-' (like \"LP1\")",
            "main:2:17 slot 0 does not exist; slots are whole numbers from 1 to 65535",
            "main:3:10 SLOT takes a station name in quotes (like \"LP1\"), got a number",
            "main:4:12 HAND$ takes a blade, A or B (as written, no quotes)",
            "main:5:5 SLOTS takes 1 argument (SLOTS(station)), got 0",
        ]
    );
}

#[test]
fn named_points_are_constants_the_compiler_checks_and_teach_stores_them() {
    let mut store = Store::default();
    store.points.insert(
        "cell".into(),
        "[points]\nSAFE = { x = 250, y = 0, z = 20, yaw = 0 }\nFAR = { x = 900, y = 0, z = 0, yaw = 0 }\nPARK = { joints = [-75, 150, -75, 0] }\n"
            .into(),
    );
    // FAR is out of reach: a compile error at its use, as for a constant POSE.
    let c = compile_in(&store, "cell", "MOVEP SAFE\nMOVEP FAR\nMOVEJ PARK\n");
    assert_eq!(errors(&c).len(), 1, "{:?}", errors(&c));
    assert!(
        errors(&c)[0].starts_with("main:2:7 unreachable pose"),
        "{:?}",
        errors(&c)
    );
    // A point cannot be assigned; TEACH stores it; a new name becomes a new point.
    let c = compile_in(&store, "cell", "SAFE = POSE(1, 2, 3, 4)\n");
    assert!(
        errors(&c)[0].contains("SAFE is a named point"),
        "{:?}",
        errors(&c)
    );
    let c = compile_in(
        &store,
        "cell",
        "PRINT SAFE.X\nTEACH SAFE\nPRINT SAFE.X\nTEACH NEWPT\nPRINT NEWPT.Y\nTEACH PARK\nPRINT PARK.J1\nX = 1\nTEACH X\n",
    );
    assert_eq!(
        errors(&c),
        ["main:9:7 X is a variable of the program, not a named point; TEACH stores points of the points file (choose a name the program does not assign)"]
    );
    let c = compile_in(
        &store,
        "cell",
        "PRINT SAFE.X\nTEACH SAFE\nPRINT SAFE.X\nTEACH NEWPT\nPRINT NEWPT.Y\nTEACH PARK\nPRINT PARK.J1\n",
    );
    let (out, asked) = run_compiled(&c);
    assert_eq!(out, ["250", "250", "10", "0"]);
    let taught: Vec<_> = asked
        .iter()
        .filter_map(|r| match r {
            Request::Teach { point, joints, .. } => Some((point.as_str().to_string(), *joints)),
            _ => None,
        })
        .collect();
    assert_eq!(
        taught,
        [
            ("SAFE".to_string(), false),
            ("NEWPT".to_string(), false),
            ("PARK".to_string(), true)
        ]
    );
    // The editor learns the points with their values.
    let safe = c.symbols.iter().find(|s| s.name == "SAFE").unwrap();
    assert_eq!((safe.kind, safe.ty), ("point", "pose"));
    assert_eq!(safe.detail, "POSE(250, 0, 20, 0)");
}

#[test]
fn a_bad_points_file_is_an_error_that_names_it() {
    let mut store = Store::default();
    store
        .points
        .insert("cell".into(), "[points]\nA = { x = 1 }\n".into());
    let c = compile_in(&store, "cell", "PRINT 1\n");
    assert_eq!(
        errors(&c),
        ["main:1:1 the points file cell.points.toml cannot be read: point A: y is missing (a pose has x, y, z and yaw)"]
    );
}

#[test]
fn include_brings_a_librarys_subs_and_functions_and_reports_their_errors_in_their_file() {
    let mut store = Store::default();
    store.programs.insert(
        "cell_lib".into(),
        "' shared steps\nDIM COUNTS[3]\nFUNCTION next_slot(st AS STRING)\n  COUNTS[0] = COUNTS[0] + 1\n  RETURN COUNTS[0]\nENDFUNCTION\nINCLUDE \"more\"\n"
            .into(),
    );
    store.programs.insert(
        "more".into(),
        "SUB hello(who AS STRING)\n  PRINT \"hello\", who\nENDSUB\n".into(),
    );
    let c = compile_in(
        &store,
        "main",
        "INCLUDE \"cell_lib\"\nINCLUDE \"cell_lib\"\nCALL hello(\"LP1\")\nPRINT next_slot(\"LP1\"), next_slot(\"LP1\")\n",
    );
    assert!(errors(&c).is_empty(), "{:?}", errors(&c));
    assert_eq!(
        c.sources
            .iter()
            .map(|s| s.name.as_str())
            .collect::<Vec<_>>(),
        ["main.wrl", "cell_lib", "more"]
    );
    let (out, _) = run_compiled(&c);
    assert_eq!(out, ["hello LP1", "1 2"]);
    // Errors in a library name its file and line.
    store.programs.insert(
        "broken".into(),
        "SUB s\n  MOVEJ POSE(1, 2, 3, 4)\nENDSUB\nPRINT \"loose\"\n".into(),
    );
    let c = compile_in(
        &store,
        "main",
        "INCLUDE \"broken\"\nCALL s\nINCLUDE \"nothere\"\n",
    );
    assert_eq!(
        errors(&c),
        [
            "main:3:9 library \"nothere\" cannot be read: there is no stored program named nothere",
            "broken:2:9 MOVEJ needs joints (JOINTS(...)) here, got a pose",
            "broken:4:1 library broken may hold only SUBs, FUNCTIONs, DIMs and INCLUDEs: its statements would never run",
        ]
    );
    let rendered = c.render(
        "main.wrl",
        "INCLUDE \"broken\"\nCALL s\nINCLUDE \"nothere\"\n",
    );
    assert!(rendered.contains("--> broken:2:9"), "{rendered}");
    assert!(
        rendered.contains("2 |   MOVEJ POSE(1, 2, 3, 4)"),
        "{rendered}"
    );
}

#[test]
fn a_name_defined_in_the_program_and_in_a_library_cites_the_other_file_by_name() {
    let mut store = Store::default();
    store.programs.insert(
        "lib".into(),
        "DIM COUNT AS NUMBER\nSUB place(st AS STRING)\n  PRINT st\nENDSUB\n".into(),
    );
    // Found by fuzzing the upload: the message said "first at another file, 2:5".
    let c = compile_in(
        &store,
        "main",
        "SUB place(st AS STRING)\n  PRINT st\nENDSUB\nDIM COUNT AS NUMBER\nINCLUDE \"lib\"\n",
    );
    assert_eq!(
        errors(&c),
        [
            "lib:1:5 COUNT is declared twice (first at main.wrl:4:5)",
            "lib:2:5 SUB place is defined twice (first at main.wrl:1:5)",
        ]
    );
    // In the same file, only line and column.
    let c = compile_in(&store, "main", "SUB a\nENDSUB\nSUB a\nENDSUB\nCALL a\n");
    assert_eq!(
        errors(&c),
        ["main:3:5 SUB a is defined twice (first at 1:5)"]
    );
}

#[test]
fn call_program_runs_another_stored_program_with_its_own_variables() {
    let mut store = Store::default();
    store.programs.insert(
        "sub_prog".into(),
        "N = 100\nPRINT \"in sub_prog\", N\nIF N > 5 THEN\n  END\nENDIF\nPRINT \"not reached\"\n"
            .into(),
    );
    let c = compile_in(
        &store,
        "main",
        "N = 1\nCALL PROGRAM \"sub_prog\"\nPRINT \"back\", N\nCALL PROGRAM \"sub_prog\"\n",
    );
    assert!(errors(&c).is_empty(), "{:?}", errors(&c));
    let (out, _) = run_compiled(&c);
    assert_eq!(out, ["in sub_prog 100", "back 1", "in sub_prog 100"]);
    // A loop of calls is found at compile time.
    store
        .programs
        .insert("a".into(), "CALL PROGRAM \"b\"\n".into());
    store
        .programs
        .insert("b".into(), "CALL PROGRAM \"a\"\n".into());
    let c = compile_in(&store, "a", "CALL PROGRAM \"b\"\n");
    assert_eq!(errors(&c), ["b:1:14 CALL PROGRAM loop: a → b → a"]);
    // Without sources (a program on its own) INCLUDE says why it cannot work.
    let c = wrc_lang::compile("INCLUDE \"lib\"\n", "solo.wrl", &robot());
    assert!(
        errors(&c)[0].contains("cannot be read here"),
        "{:?}",
        errors(&c)
    );
}
