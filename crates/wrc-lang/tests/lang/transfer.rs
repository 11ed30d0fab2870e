//! Wafer handling: `GET station, slot`, `PUT station, slot` and `MAP station` yield
//! [`Request::Transfer`] and [`Request::Map`] with checked values; a failed transfer ends the
//! program at its line; bad names and slots are compile errors when the compiler sees them
//! and run-time errors otherwise.

use wrc_lang::{
    compile, Request, Resume, RuntimeError, RuntimeErrorKind, Step, TransferKind, Vm, VmLimits,
};
use wrc_robot::InlineName;

use crate::common::{program, robot, run, Io};

fn station(name: &str) -> InlineName<16> {
    InlineName::new(name).unwrap()
}

fn get(name: &str, slot: u16) -> Request {
    Request::Transfer {
        kind: TransferKind::Get,
        station: station(name),
        slot,
        blade_b: false,
    }
}

fn put(name: &str, slot: u16) -> Request {
    Request::Transfer {
        kind: TransferKind::Put,
        station: station(name),
        slot,
        blade_b: false,
    }
}

fn map(name: &str) -> Request {
    Request::Map {
        station: station(name),
    }
}

const MOVE_THREE: &str = "\
MAP \"LP1\"
FOR I = 1 TO 3
  GET \"LP1\", I
  PUT \"LP2\", I
NEXT
";

#[test]
fn a_transfer_loop_yields_map_then_get_and_put_per_slot_in_order() {
    let r = run(&program(MOVE_THREE));
    assert_eq!(r.fault, None);
    assert_eq!(
        r.requests,
        [
            map("LP1"),
            get("LP1", 1),
            put("LP2", 1),
            get("LP1", 2),
            put("LP2", 2),
            get("LP1", 3),
            put("LP2", 3),
        ]
    );
}

#[test]
fn stations_come_from_variables_and_slots_from_expressions() {
    let src = "\
SRC = \"load_port-1\"
DST = \"BUF\"
IF SRC = \"load_port-1\" THEN
  DST = \"ALIGNER\"
ENDIF
map src
N = 12
get SRC, N * 2 + 1
Put DST, 65535
GET \"ABCDEFGHIJKLMNOP\", 1
";
    let r = run(&program(src));
    assert_eq!(r.fault, None);
    assert_eq!(
        r.requests,
        [
            map("load_port-1"),
            get("load_port-1", 25),
            put("ALIGNER", 65535),
            get("ABCDEFGHIJKLMNOP", 1),
        ]
    );
    // The host sees the name as written (station names are matched by the host).
    let Request::Transfer { station, .. } = r.requests[2] else {
        panic!("{:?}", r.requests[2])
    };
    assert_eq!(station.as_str(), "ALIGNER");
    assert_eq!(TransferKind::Get.as_str(), "GET");
    assert_eq!(TransferKind::Put.as_str(), "PUT");
}

#[test]
fn a_failed_transfer_ends_the_program_with_the_hosts_fault_at_the_get_line() {
    let p = program(MOVE_THREE);
    let mut vm = Vm::new(VmLimits::default());
    let mut io = Io::default();
    vm.load(&p).unwrap();
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(map("LP1")));
    vm.resume(Resume::Ok);
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(get("LP1", 1)));
    // The request repeats until the host answers.
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(get("LP1", 1)));
    assert_eq!(vm.position(&p).map(|pos| pos.line), Some(3));
    let empty = RuntimeErrorKind::Host { code: 131 };
    vm.fail(131, "the slot is empty");
    let fault = RuntimeError {
        kind: empty,
        line: 3,
        col: 3,
        file: 0,
    };
    assert_eq!(vm.run(&p, 100, &mut io), Step::Fault(fault));
    assert_eq!(vm.error_text(), "the slot is empty");
    assert_eq!(fault.kind.code(), 131);
    // Nothing after the failed GET runs (no PUT); the fault is sticky until the next load.
    assert_eq!(vm.run(&p, 100, &mut io), Step::Fault(fault));
    assert!(!vm.is_waiting());

    // A failure of a later PUT and of a MAP points at their lines too.
    vm.load(&p).unwrap();
    for _ in 0..4 {
        // MAP, GET 1, PUT 1, GET 2
        assert!(matches!(vm.run(&p, 100, &mut io), Step::Yield(_)));
        vm.resume(Resume::Ok);
    }
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(put("LP2", 2)));
    vm.fail(132, "the slot is occupied");
    let Step::Fault(e) = vm.run(&p, 100, &mut io) else {
        panic!("a fault")
    };
    assert_eq!((e.line, e.col), (4, 3));
    vm.load(&p).unwrap();
    assert_eq!(vm.run(&p, 100, &mut io), Step::Yield(map("LP1")));
    vm.fail(201, "E-stop");
    let Step::Fault(e) = vm.run(&p, 100, &mut io) else {
        panic!("a fault")
    };
    assert_eq!((e.kind, e.line), (RuntimeErrorKind::Host { code: 201 }, 1));
    assert_eq!(vm.error_text(), "E-stop");
}

/// The rendered diagnostics of `source`, which must not compile.
fn errors(source: &str) -> Vec<(u32, u32, String)> {
    let compiled = compile(source, "t.wrl", &robot());
    assert!(compiled.program.is_none(), "{source}");
    compiled
        .diagnostics
        .iter()
        .map(|d| (d.line, d.col, d.message.clone()))
        .collect()
}

#[test]
fn compile_errors_point_at_the_bad_argument() {
    assert_eq!(
        errors("MAP \"LP1\"\nGET \"LP1\"\n"),
        [(
            2,
            10,
            "expected ',' and the next argument, found the end of the line; the syntax is GET station, slot[, A|B]".to_string()
        )]
    );
    assert_eq!(
        errors("GET \"L P1\", 1\n"),
        [(
            1,
            5,
            "\"L P1\" is not a station name; station names are 1 to 16 letters, digits, '_' or '-' (like \"LP1\")".to_string()
        )]
    );
    assert_eq!(
        errors("X = 1\nMAP 3\nPUT X, 1\n"),
        [
            (
                2,
                5,
                "MAP needs a station name in quotes (like \"LP1\") here, got a number".to_string()
            ),
            (
                3,
                5,
                "PUT needs a station name in quotes (like \"LP1\") here, got a number".to_string()
            ),
        ]
    );
    let slots =
        errors("GET \"LP1\", 0\nPUT \"LP1\", 1.5\nGET \"LP1\", 70000\nPUT \"LP1\", \"3\"\n");
    let at: Vec<_> = slots.iter().map(|(l, c, _)| (*l, *c)).collect();
    assert_eq!(at, [(1, 12), (2, 12), (3, 12), (4, 12)]);
    assert_eq!(
        slots[0].2,
        "slot 0 does not exist; GET takes a whole slot number from 1 to 65535"
    );
    assert_eq!(slots[3].2, "PUT needs a number here, got a string");
    // A constant slot computed from a variable assigned once is caught too.
    let e = errors("S = 0\nGET \"LP1\", S + 0\n");
    assert_eq!((e[0].0, e[0].1), (2, 12));
    // The new keywords cannot name variables.
    assert_eq!(
        errors("PRINT 1\nmap = 1\n"),
        [(
            2,
            1,
            "map is a statement keyword and cannot name a variable; choose another name"
                .to_string()
        )]
    );
}

#[test]
fn bad_slots_and_station_names_at_run_time_are_faults_at_the_statement() {
    const SLOT: &str = "a slot must be a whole number from 1 to 65535";
    const NAME: &str = "a station name must be 1 to 16 letters, digits, '_' or '-'";
    // Source, the line of the fault, its text, and the requests that reached the host
    // before it.
    let cases: [(&str, u32, &str, &[Request]); 7] = [
        ("S = 1\nS = 0\nGET \"LP1\", S\n", 3, SLOT, &[]),
        ("S = 1\nS = 1.5\nPUT \"LP1\", S\n", 3, SLOT, &[]),
        ("S = 1\nS = 70000\nGET \"LP1\", S\n", 3, SLOT, &[]),
        (
            "FOR i = 65534 TO 65536\n  PUT \"LP1\", i\nNEXT\n",
            2,
            SLOT,
            &[put("LP1", 65534), put("LP1", 65535)],
        ),
        ("ST = \"bad name!\"\nMAP ST\n", 2, NAME, &[]),
        (
            "ST = \"LP1\"\nST = \"ABCDEFGHIJKLMNOPQ\"\nGET ST, 1\n",
            3,
            NAME,
            &[],
        ),
        // A string variable read before its first assignment runs holds "".
        (
            "CALL s\nST = \"LP1\"\nEND\nSUB s\n  MAP ST\nENDSUB\n",
            5,
            NAME,
            &[],
        ),
    ];
    for (src, line, text, before) in cases {
        let r = run(&program(src));
        let e = r.fault.unwrap_or_else(|| panic!("no fault: {src}"));
        assert_eq!(e.kind, RuntimeErrorKind::BadArgument(text), "{src}");
        assert_eq!(e.line, line, "{src}");
        assert_eq!(r.requests, before, "{src}");
    }
    let e = run(&program("ST = \"bad name!\"\nMAP ST\n")).fault.unwrap();
    assert_eq!(
        e.to_string(),
        "line 2: a station name must be 1 to 16 letters, digits, '_' or '-'"
    );
}

#[test]
fn the_listing_names_the_wafer_instructions() {
    let p = program("MAP \"LP1\"\nGET \"LP1\", 2\nPUT \"LP2\", 2\n");
    let listing = p.listing();
    for needle in [
        "1:1      MAP",
        "2:1      GET",
        "3:1      PUT",
        "$0      ; \"LP1\"",
    ] {
        assert!(listing.contains(needle), "{needle}\n{listing}");
    }
    let back = wrc_lang::Program::from_bytes(&p.to_bytes()).expect("decodes");
    assert_eq!(back, p);
}

#[test]
fn the_cassette_example_in_the_language_reference_moves_three_wafers() {
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/language.md");
    let text = std::fs::read_to_string(path).unwrap();
    let block = text
        .split("```wrl\n")
        .filter_map(|b| b.split("```").next())
        .find(|b| b.contains("GET FROM_PORT$, slot"))
        .expect("the example block");
    let r = run(&program(block));
    assert_eq!(r.fault, None);
    let mut want = vec![map("LP1"), map("LP2")];
    for slot in 1..=3 {
        want.extend([get("LP1", slot), put("LP2", slot), Request::Print]);
    }
    // A host that answers everything: the GET of the empty slot succeeds here.
    want.push(get("LP2", 4));
    assert_eq!(r.requests, want);
    assert_eq!(r.printed[0], "wafer 1 of 3 moved to LP2");
    assert_eq!(r.printed[2], "wafer 3 of 3 moved to LP2");
}

/// A dual-blade robot's statements: `GET`/`PUT station, slot, B` name blade B (`A`, or
/// nothing, is the hand) and `SWAP station, slot` yields its own request; a blade other than
/// A or B is a compile error at its column.
#[test]
fn blades_and_swap_yield_their_requests() {
    let src = "\
GET \"LP1\", 2, B
SWAP \"PM1\", 1
put \"LP2\", 1, a
PUT \"LP2\", 2
";
    let r = run(&program(src));
    assert_eq!(r.fault, None);
    assert_eq!(
        r.requests,
        [
            Request::Transfer {
                kind: TransferKind::Get,
                station: station("LP1"),
                slot: 2,
                blade_b: true,
            },
            Request::Swap {
                station: station("PM1"),
                slot: 1,
            },
            put("LP2", 1),
            put("LP2", 2),
        ]
    );
    assert_eq!(
        errors("GET \"LP1\", 2, C\n"),
        [(
            1,
            15,
            "the blade must be A or B, found 'C'; the syntax is GET station, slot[, A|B]"
                .to_string()
        )]
    );
    let e = errors("SWAP \"PM1\", 0\n");
    assert!(e[0].2.contains("slot"), "{e:?}");
}
