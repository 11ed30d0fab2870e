//! wrc's robot language: a compiler for `.wrl` programs and the VM that runs them inside the
//! controller's Command Interpreter.
//!
//! The language is line-oriented and BASIC-like, in the tradition of Epson SPEL+, Denso PAC
//! and Kawasaki AS: `MOVEJ JOINTS(30, 60, -90, 100)`, `MOVEL P1 + POSE(0, 0, 10, 0)`,
//! `WAIT IN(0) = 1 TIMEOUT 2`, `GET "LP1", 3`, `FOR`/`WHILE`/`IF`, `SUB`/`CALL`, `PRINT`
//! (docs/language.md).
//!
//! - [`compile`] lexes, parses, checks (names, types, argument counts, blocks, and constant
//!   targets against the [`Robot`]: reachability, joint limits, axis count) and emits
//!   compact bytecode. It reports every error it can in one pass, each with line, column,
//!   the source line and a caret ([`Diagnostic::render`]), and never panics on any input.
//! - A [`Program`] is verified bytecode with a source position per instruction; it
//!   round-trips through a versioned binary form ([`Program::to_bytes`],
//!   [`Program::from_bytes`], which verifies every index, jump and stack depth).
//! - The [`Vm`] is real-time safe: after [`Vm::new`] no more memory is allocated.
//!   [`Vm::run`] executes at most a budget of instructions and returns a [`Step`]; motions,
//!   delays, input waits, outputs, speed changes, PRINT and wafer transfers (`GET`, `PUT`,
//!   `MAP`) are [`Request`]s the host carries out before it calls [`Vm::resume`]. The VM
//!   never blocks, sleeps or prints.
//!
//! ```
//! use wrc_lang::{compile, Motion, Request, Resume, Step, Vm, VmIo, VmLimits};
//! use wrc_robot::{Pose, Robot};
//!
//! struct Cell;
//! impl VmIo for Cell {
//!     fn input(&self, _n: u8) -> bool { true }
//!     fn here(&self) -> Pose { Pose::default() }
//! }
//!
//! let robot = Robot::paper_default();
//! let source = "FOR i = 1 TO 2\n  MOVEJ JOINTS(30 * i, 60, -90, 0)\nNEXT i\n";
//! let compiled = compile(source, "cell.wrl", &robot);
//! assert!(compiled.diagnostics.is_empty());
//! let program = compiled.program.unwrap();
//!
//! let mut vm = Vm::new(VmLimits::default()); // allocates; nothing below does
//! vm.load(&program).unwrap();
//! let mut moves = Vec::new();
//! loop {
//!     match vm.run(&program, 1000, &mut Cell) {
//!         Step::Yield(Request::Move(Motion::Joints(j))) => {
//!             moves.push(j[0]);
//!             vm.resume(Resume::Ok); // the move finished
//!         }
//!         Step::Done => break,
//!         other => panic!("{other:?}"),
//!     }
//! }
//! assert_eq!(moves, [30.0, 60.0]);
//! ```
//!
//! A compile error renders like rustc's:
//!
//! ```
//! let robot = wrc_robot::Robot::paper_default();
//! let source = "SPEED 150\n";
//! let compiled = wrc_lang::compile(source, "cell.wrl", &robot);
//! assert!(compiled.program.is_none());
//! assert_eq!(
//!     compiled.diagnostics[0].render("cell.wrl", source),
//!     "error: SPEED 150 is out of range; SPEED takes 1 to 100 [%]\n --> cell.wrl:1:7\n  |\n1 | SPEED 150\n  |       ^~~\n"
//! );
//! ```
#![deny(missing_docs)]

mod ast;
mod bytecode;
mod check;
mod codegen;
mod diagnostic;
mod error;
mod lexer;
mod parser;
mod statements;
mod value;
mod vm;

use wrc_robot::Robot;

pub use bytecode::{Builtin, Instr, Program, SourcePos, SubEntry, Variable, FORMAT_VERSION};
pub use diagnostic::{Diagnostic, Severity};
pub use error::{DecodeError, LoadError, RuntimeError, RuntimeErrorKind};
pub use value::Ty;
pub use vm::{Motion, Request, Resume, Step, TransferKind, Vm, VmIo, VmLimits, PRINT_CAPACITY};

/// The result of [`compile`]: the program (`None` when there is an error) and every
/// diagnostic, in source order.
#[derive(Debug, Clone)]
pub struct Compiled {
    /// The program, when there are no errors (there may be warnings).
    pub program: Option<Program>,
    /// Errors and warnings, sorted by line and column.
    pub diagnostics: Vec<Diagnostic>,
}

impl Compiled {
    /// Number of errors.
    pub fn errors(&self) -> usize {
        self.diagnostics.iter().filter(|d| d.is_error()).count()
    }

    /// Number of warnings.
    pub fn warnings(&self) -> usize {
        self.diagnostics.len() - self.errors()
    }

    /// Every diagnostic rendered ([`Diagnostic::render`]), one after the other with a blank
    /// line between them.
    pub fn render(&self, file: &str, source: &str) -> String {
        self.diagnostics
            .iter()
            .map(|d| d.render(file, source))
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// Compile `source` for `robot`. `file` names the program (its listing header and
/// [`Program::name`]).
///
/// Constant targets are checked against the robot: a constant `POSE` the arm cannot reach,
/// a constant `JOINTS` outside the soft limits or with the wrong number of values, a
/// `SPEED` outside 1-100, an unknown `JOG` axis. Values only known at run time are checked
/// by the VM (and the host refuses moves it cannot make).
pub fn compile(source: &str, file: &str, robot: &Robot) -> Compiled {
    let mut diagnostics = Vec::new();
    let tokens = lexer::lex(source, &mut diagnostics);
    let stmts = parser::parse(source, &tokens, &mut diagnostics);
    let checked = check::check(&stmts, robot, &mut diagnostics);
    let has_errors = diagnostics.iter().any(Diagnostic::is_error);
    let program = match checked {
        Some(checked) if !has_errors => {
            let axes = u8::try_from(robot.axis_count()).unwrap_or(u8::MAX);
            Some(codegen::generate(checked, file, axes))
        }
        _ => None,
    };
    diagnostics.sort_by_key(|d| (d.line, d.col));
    Compiled {
        program,
        diagnostics,
    }
}
