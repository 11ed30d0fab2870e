//! The compiler never panics: seeded random token soup and random bytes either compile or
//! produce diagnostics; whatever compiles round-trips and runs within a budget.
//! (`crates/wrc-lang/fuzz` runs the same property with libFuzzer.)

use wrc_lang::{compile, Program, Resume, Step, Vm, VmLimits};

use crate::common::{robot, Io};

/// xorshift64*: a small seeded generator, so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[(self.next() % items.len() as u64) as usize]
    }
}

const WORDS: &[&str] = &[
    "IF", "THEN", "ELSEIF", "ELSE", "ENDIF", "WHILE", "ENDWHILE", "FOR", "TO", "STEP", "NEXT",
    "SUB", "ENDSUB", "CALL", "END", "HOME", "MOVEJ", "MOVEP", "MOVEL", "JOG", "SPEED", "DELAY",
    "OUT", "WAIT", "IN", "TIMEOUT", "PRINT", "GET", "PUT", "MAP", "\"LP1\"", "\"a b\"", "65536",
    "AND", "OR", "NOT", "TRUE", "FALSE", "JOINTS", "POSE", "HERE", "SIN", "ATAN2", "SQRT", "MIN",
    "X", "Y", "P", "J", "i", "s", "J1", "Z", "L", "R", "0", "1", "2", "-1", "300", "1e308", "0.5",
    "\"txt\"", "(", ")", ",", ".", "=", "<>", "<", ">=", "+", "-", "*", "/", "\n", "\n", "\n",
    "'c", "\"", ";", "é",
];

fn exercise(source: &str) {
    let compiled = compile(source, "fuzz.wrl", &robot());
    for d in &compiled.diagnostics {
        let _ = d.render("fuzz.wrl", source);
    }
    if let Some(p) = compiled.program {
        let back = Program::from_bytes(&p.to_bytes()).expect("a compiled program decodes");
        assert_eq!(back, p);
        let mut vm = Vm::new(VmLimits::default());
        vm.load(&p).expect("fits the default limits");
        let mut io = Io::default();
        for _ in 0..200 {
            match vm.run(&p, 100, &mut io) {
                Step::Budget | Step::Break(_) => {}
                Step::Yield(_) => vm.resume(Resume::Ok),
                Step::Done | Step::Fault(_) => break,
            }
        }
    }
}

#[test]
fn random_token_soup_never_panics() {
    let mut rng = Rng(0x5EED_1234_ABCD_0001);
    let mut compiled = 0;
    for _ in 0..3000 {
        let n = 1 + rng.next() % 40;
        let mut src = String::new();
        for _ in 0..n {
            src.push_str(rng.pick(WORDS));
            src.push(' ');
        }
        exercise(&src);
        if compile(&src, "f", &robot()).program.is_some() {
            compiled += 1;
        }
    }
    assert!(compiled > 0);
}

#[test]
fn random_lines_of_valid_statements_never_panic() {
    let lines = [
        "X = 1",
        "X = X + 1",
        "P = POSE(300, 0, 0, 0)",
        "MOVEP P, L",
        "MOVEL P + POSE(0, X, 0, 0)",
        "IF X > 3 THEN",
        "ELSE",
        "ENDIF",
        "WHILE X < 10",
        "ENDWHILE",
        "FOR i = 1 TO X",
        "NEXT",
        "CALL s",
        "SUB s",
        "ENDSUB",
        "PRINT X, P",
        "END",
        "JOG J1, X",
        "OUT 0, 1",
        "DELAY X / 10",
        "WAIT IN(0) = 1 TIMEOUT 1",
        "SPEED X",
        "X = 1 / (X - 5)",
        "MOVEJ JOINTS(X, 0, 0, 0)",
        "S = \"LP1\"",
        "S = \"not a station\"",
        "MAP S",
        "GET S, X",
        "PUT \"LP2\", X - 3",
    ];
    let mut rng = Rng(42);
    for _ in 0..3000 {
        let n = 1 + rng.next() % 25;
        let mut src = String::new();
        for _ in 0..n {
            src.push_str(rng.pick(&lines));
            src.push('\n');
        }
        exercise(&src);
    }
}

#[test]
fn random_bytes_and_pathological_inputs_never_panic() {
    let mut rng = Rng(7);
    for _ in 0..2000 {
        let n = (rng.next() % 200) as usize;
        let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
        exercise(&String::from_utf8_lossy(&bytes));
    }
    for src in [
        String::new(),
        "\n\n\n".into(),
        "\"".into(),
        "X = ".into(),
        "(".repeat(100_000),
        format!("X = {}1", "-".repeat(100_000)),
        format!("X = {}", "NOT ".repeat(100_000)),
        format!("X = 1{}", " + 1".repeat(100_000)),
        "IF TRUE THEN\n".repeat(10_000),
        "ENDIF\n".repeat(10_000),
        format!("PRINT {}", "1, ".repeat(300)),
        "X = 1e400".into(),
        "MOVEJ JOINTS(1e308, 1e308, 0, 0) + JOINTS(1e308, 0, 0, 0)".into(),
        "\u{0}\u{feff}\r\n\tX\r= 1\r\n".into(),
    ] {
        exercise(&src);
    }
}
