//! wrc's robot language: a compiler for `.wrl` programs and the VM that runs them inside the
//! controller's Command Interpreter.
//!
//! The language is line-oriented and BASIC-like, in the tradition of Epson SPEL+, Adept V+,
//! Denso PAC and Kawasaki AS: `MOVEJ JOINTS(30, 60, -90, 100)`, `MOVEL P1 SPEED 20 BLEND 5`,
//! `WAIT IN(0) = 1 TIMEOUT 2`, `GET "LP1", 3`, `TRY … CATCH 212 … ENDTRY`, `IF SLOT("LP1", n)
//! = 1 THEN`, arrays, `SUB`/`FUNCTION` with parameters and locals, `SELECT CASE`, `INCLUDE`
//! (docs/language.md).
//!
//! - [`compile`] and [`compile_with`] lex, parse, check (names, types, argument counts,
//!   blocks, and constant targets against the [`Robot`]: reachability, joint limits, axis
//!   count) and emit compact bytecode. They report every error they can in one pass, each
//!   with file, line, column, the source line and a caret ([`Compiled::render`]), and never
//!   panic on any input. [`compile_with`] reads INCLUDEd libraries, called programs and the
//!   program's named points through [`Sources`].
//! - A [`Program`] is verified bytecode with a source position per instruction; it
//!   round-trips through a versioned binary form ([`Program::to_bytes`],
//!   [`Program::from_bytes`], which verifies every index, jump and stack depth).
//! - The [`Vm`] is real-time safe: after [`Vm::new`] no more memory is allocated.
//!   [`Vm::run`] executes at most a budget of instructions and returns a [`Step`]; motions,
//!   delays, input waits, outputs, PRINT, wafer transfers, questions about the cell, alarms
//!   and the operator are [`Request`]s the host carries out before it calls [`Vm::resume`]
//!   (or [`Vm::fail`]: a TRY may catch the error). Breakpoints and single steps stop it
//!   with [`Step::Break`]. The VM never blocks, sleeps or prints.
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
//!         Step::Yield(Request::Move(Motion::Joints(j), _)) => {
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
mod builtins;
mod bytecode;
mod check;
mod codegen;
mod diagnostic;
mod error;
mod lexer;
mod parser;
pub mod points;
mod statements;
mod value;
mod vm;

use std::collections::HashMap;

use wrc_robot::Robot;

use ast::{Stmt, StmtKind};
use diagnostic::Span;

pub use builtins::Builtin;
pub use bytecode::{Init, Instr, MoveFlags, Program, Routine, SourcePos, Variable, FORMAT_VERSION};
pub use check::Symbol;
pub use diagnostic::{Diagnostic, Severity};
pub use error::{DecodeError, LoadError, RuntimeError, RuntimeErrorKind};
pub use points::{PointValue, Points, PointsError};
pub use value::{Text, Ty, TEXT_CAPACITY};
pub use vm::{
    Answer, Blend, CellInfo, CellQuery, Motion, MoveOptions, Request, Resume, Step, StepMode,
    TransferKind, VarView, Vm, VmIo, VmLimits, MAX_BREAKPOINTS, PRINT_CAPACITY,
};

/// Where the compiler finds the other sources a program names: the stored programs and
/// libraries (`INCLUDE "name"`, `CALL PROGRAM "name"`) and a program's points file.
pub trait Sources {
    /// The text of the stored program or library `name` (without `.wrl`), or why it
    /// cannot be read.
    fn program(&self, name: &str) -> Result<String, String>;
    /// The text of program `name`'s points file (`<name>.points.toml`), `None` when it has
    /// none, or why it cannot be read.
    fn points(&self, name: &str) -> Result<Option<String>, String>;
}

/// [`Sources`] in a folder: program or library `name` is `<dir>/<name>.wrl`, its points
/// file `<dir>/<name>.points.toml` (the controller's program store, and `wrc compile` next
/// to the file compiled). A name must be 1-32 letters, digits, `_` or `-`, so that it
/// cannot reach outside the folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DirSources {
    /// The folder.
    pub dir: std::path::PathBuf,
}

impl DirSources {
    fn file(&self, name: &str, suffix: &str) -> Result<std::path::PathBuf, String> {
        let ok = !name.is_empty()
            && name.len() <= 32
            && name
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        if !ok {
            return Err("a program's name is 1-32 letters, digits, _ or -".into());
        }
        Ok(self.dir.join(format!("{name}{suffix}")))
    }
}

impl Sources for DirSources {
    fn program(&self, name: &str) -> Result<String, String> {
        let path = self.file(name, ".wrl")?;
        std::fs::read_to_string(&path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => format!("there is no {}", path.display()),
            _ => format!("{}: {e}", path.display()),
        })
    }

    fn points(&self, name: &str) -> Result<Option<String>, String> {
        let path = self.file(name, ".points.toml")?;
        match std::fs::read_to_string(&path) {
            Ok(text) => Ok(Some(text)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(format!("{}: {e}", path.display())),
        }
    }
}

/// How to compile: the program's name and where its other sources are.
#[derive(Clone, Copy)]
pub struct CompileOptions<'a> {
    /// The program's name (its stored name: `CALL PROGRAM` of it is a loop, its points file
    /// is `<name>.points.toml`).
    pub name: &'a str,
    /// Libraries, called programs and points files; `None`: a program on its own (INCLUDE
    /// and CALL PROGRAM are errors, it has no named points).
    pub sources: Option<&'a dyn Sources>,
}

/// A source file of a compilation: the program's own (index 0), its libraries and the
/// programs it calls, in the order they were read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourceFile {
    /// Its name (the program's file name for index 0, the stored name for the others).
    pub name: String,
    /// Its text.
    pub text: String,
}

/// The result of [`compile`]: the program (`None` when there is an error), every
/// diagnostic in file and source order, the source files and the names defined (for an
/// editor).
#[derive(Debug, Clone)]
pub struct Compiled {
    /// The program, when there are no errors (there may be warnings).
    pub program: Option<Program>,
    /// Errors and warnings, sorted by file, line and column.
    pub diagnostics: Vec<Diagnostic>,
    /// The source files; [`Diagnostic::file_index`] and [`SourcePos::file`] index it.
    pub sources: Vec<SourceFile>,
    /// The variables, arrays, points, SUBs, FUNCTIONs, parameters and locals the program
    /// (with its libraries) defines, where, and what they are.
    pub symbols: Vec<Symbol>,
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
    /// line between them; `file` and `source` name the program's own file (diagnostics in
    /// other files show theirs).
    pub fn render(&self, file: &str, source: &str) -> String {
        self.diagnostics
            .iter()
            .map(|d| match self.sources.get(usize::from(d.file_index)) {
                Some(f) if d.file_index > 0 => d.render(&f.name, &f.text),
                _ => d.render(file, source),
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// Compile `source` for `robot`, on its own (no libraries, no called programs, no named
/// points). `file` names the program (its listing header, [`Program::name`] and the
/// diagnostics' file).
///
/// Constant targets are checked against the robot: a constant `POSE` the arm cannot reach,
/// a constant `JOINTS` outside the soft limits or with the wrong number of values, a
/// `SPEED` outside 1-100, an unknown `JOG` axis. Values only known at run time are checked
/// by the VM (and the host refuses moves it cannot make).
pub fn compile(source: &str, file: &str, robot: &Robot) -> Compiled {
    let stem = file.strip_suffix(".wrl").unwrap_or(file);
    let stem = stem.rsplit('/').next().unwrap_or(stem);
    compile_with(
        source,
        file,
        robot,
        &CompileOptions {
            name: stem,
            sources: None,
        },
    )
}

/// Compile `source` as [`compile`] does, reading its INCLUDEd libraries, the programs it
/// calls and its points file through `options.sources`.
pub fn compile_with(source: &str, file: &str, robot: &Robot, options: &CompileOptions) -> Compiled {
    let mut loader = Loader {
        robot,
        sources: options.sources,
        files: vec![SourceFile {
            name: file.to_string(),
            text: source.to_string(),
        }],
        units: Vec::new(),
        unit_index: HashMap::new(),
        loading: Vec::new(),
        diags: Vec::new(),
    };
    let tokens = lexer::lex(source, 0, &mut loader.diags);
    let stmts = parser::parse(source, &tokens, &mut loader.diags);
    loader.unit(options.name, stmts, 0);
    let Loader {
        files,
        mut units,
        mut diags,
        ..
    } = loader;
    // The program compiled is unit 0.
    if let Some(i) = units.iter().position(|u| u.name == options.name) {
        let main = units.remove(i);
        units.insert(0, main);
    }
    // As messages cite a place in another file: `cell_lib.wrl:47:5`.
    let file_names: Vec<String> = files
        .iter()
        .enumerate()
        .map(|(i, f)| {
            if i == 0 {
                f.name.clone()
            } else {
                format!("{}.wrl", f.name)
            }
        })
        .collect();
    let checked = check::check(&units, robot, &file_names, &mut diags);
    let has_errors = diags.iter().any(Diagnostic::is_error);
    let (program, symbols) = match checked {
        Ok(checked) if !has_errors => {
            let symbols = checked.symbols.clone();
            let axes = u8::try_from(robot.axis_count()).unwrap_or(u8::MAX);
            let names = files.iter().map(|f| f.name.clone()).collect();
            (Some(codegen::generate(checked, file, axes, names)), symbols)
        }
        Ok(checked) => (None, checked.symbols),
        // Names as far as they were understood: an editor completes them while the
        // program is being written.
        Err(known) => (None, known),
    };
    for d in &mut diags {
        if d.file_index > 0 {
            d.file = files.get(usize::from(d.file_index)).map(|f| f.name.clone());
        }
    }
    diags.sort_by_key(|d| (d.file_index, d.line, d.col));
    Compiled {
        program,
        diagnostics: diags,
        sources: files,
        symbols,
    }
}

/// Reads the units of a compilation: the program, its libraries (merged into it) and the
/// programs it calls (each a unit of its own), with their points files.
struct Loader<'a> {
    robot: &'a Robot,
    sources: Option<&'a dyn Sources>,
    files: Vec<SourceFile>,
    units: Vec<check::Unit>,
    unit_index: HashMap<String, usize>,
    /// The programs being read, outermost first (a CALL PROGRAM loop is an error).
    loading: Vec<String>,
    diags: Vec<Diagnostic>,
}

/// Most source files in one compilation.
const MAX_FILES: usize = 256;

impl Loader<'_> {
    /// Read a source file `name` through the sources: its index, or `None` (reported at
    /// `span`).
    fn read(&mut self, name: &str, what: &str, span: Span) -> Option<(u16, Vec<Stmt>)> {
        let Some(sources) = self.sources else {
            self.diags.push(Diagnostic::error(
                span,
                format!(
                    "{what} {name:?} cannot be read here: compile the program in the controller's program store or with `wrc compile`, which read {name}.wrl next to the program"
                ),
            ));
            return None;
        };
        if self.files.len() >= MAX_FILES {
            self.diags.push(Diagnostic::error(
                span,
                format!("more than {MAX_FILES} source files"),
            ));
            return None;
        }
        match sources.program(name) {
            Ok(text) => {
                let index = self.files.len() as u16;
                let tokens = lexer::lex(&text, index, &mut self.diags);
                let stmts = parser::parse(&text, &tokens, &mut self.diags);
                self.files.push(SourceFile {
                    name: name.to_string(),
                    text,
                });
                Some((index, stmts))
            }
            Err(why) => {
                self.diags.push(Diagnostic::error(
                    span,
                    format!("{what} {name:?} cannot be read: {why}"),
                ));
                None
            }
        }
    }

    /// Make unit `name` from its parsed statements (file `file`): its libraries merged in,
    /// the programs it calls read as units of their own, its points file.
    fn unit(&mut self, name: &str, mut stmts: Vec<Stmt>, file: u16) {
        self.loading.push(name.to_string());
        self.unit_index.insert(name.to_string(), usize::MAX);
        let mut included: Vec<String> = Vec::new();
        let mut i = 0;
        while i < stmts.len() {
            if let StmtKind::Include { name: lib } = &stmts[i].kind {
                let (lib, span) = (lib.clone(), stmts[i].span);
                if lib == name || self.loading.contains(&lib) {
                    self.diags.push(Diagnostic::error(
                        span,
                        format!("INCLUDE {lib:?} includes a program that is being compiled (an include loop)"),
                    ));
                } else if !included.contains(&lib) {
                    included.push(lib.clone());
                    self.loading.push(lib.clone());
                    if let Some((_, lib_stmts)) = self.read(&lib, "library", span) {
                        for s in lib_stmts {
                            match &s.kind {
                                StmtKind::Routine { .. }
                                | StmtKind::Dim { .. }
                                | StmtKind::Include { .. } => stmts.push(s),
                                _ => self.diags.push(Diagnostic::error(
                                    s.span,
                                    format!(
                                        "library {lib} may hold only SUBs, FUNCTIONs, DIMs and INCLUDEs: its statements would never run"
                                    ),
                                )),
                            }
                        }
                    }
                    self.loading.pop();
                }
            }
            i += 1;
        }
        let mut calls = Vec::new();
        collect_calls(&stmts, &mut calls);
        for (callee, span) in calls {
            if let Some(at) = self.loading.iter().position(|n| *n == callee) {
                let chain: Vec<&str> = self.loading[at..].iter().map(String::as_str).collect();
                self.diags.push(Diagnostic::error(
                    span,
                    format!("CALL PROGRAM loop: {} → {callee}", chain.join(" → ")),
                ));
                continue;
            }
            if self.unit_index.contains_key(&callee) {
                continue;
            }
            if let Some((index, callee_stmts)) = self.read(&callee, "program", span) {
                self.unit(&callee, callee_stmts, index);
            }
        }
        let points = self.points(name, file);
        self.loading.pop();
        self.unit_index.insert(name.to_string(), self.units.len());
        self.units.push(check::Unit {
            name: name.to_string(),
            stmts,
            points,
        });
    }

    /// Program `name`'s named points (its points file's), reported at the start of its file
    /// `file` when the file cannot be read.
    fn points(&mut self, name: &str, file: u16) -> Vec<(String, PointValue)> {
        let Some(sources) = self.sources else {
            return Vec::new();
        };
        let file_name = points::points_file_name(name);
        let problem = match sources.points(name) {
            Ok(None) => return Vec::new(),
            Ok(Some(text)) => match Points::parse(&text, self.robot.axis_count()) {
                Ok(p) => return p.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
                Err(e) => e.to_string(),
            },
            Err(why) => why,
        };
        self.diags.push(Diagnostic::error(
            Span::line_start(file, 1),
            format!("the points file {file_name} cannot be read: {problem}"),
        ));
        Vec::new()
    }
}

/// A built-in function, for the docs and an editor's completion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct BuiltinInfo {
    /// Its name (`SLOT`, `ERRMSG$`).
    pub name: &'static str,
    /// How it is written (`SLOT(station, n)`).
    pub syntax: &'static str,
    /// What it gives.
    pub summary: &'static str,
}

/// Every built-in function.
pub fn builtin_functions() -> impl Iterator<Item = BuiltinInfo> {
    builtins::BUILTINS.iter().map(|d| BuiltinInfo {
        name: d.name,
        syntax: d.syntax,
        summary: d.summary,
    })
}

/// A statement of the statement table, for the docs and an editor's completion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct StatementInfo {
    /// Its keyword (`MOVEL`; `WAIT OPERATOR` has two words).
    pub keyword: &'static str,
    /// How it is written.
    pub syntax: &'static str,
    /// What it does.
    pub summary: &'static str,
}

/// Every simple statement (block statements, CALL, DIM, LOCAL and assignment are
/// structure: docs/language.md describes them).
pub fn statements() -> impl Iterator<Item = StatementInfo> {
    statements::STATEMENTS.iter().map(|d| StatementInfo {
        keyword: d.syntax.split(' ').next().unwrap_or(d.keyword),
        syntax: d.syntax,
        summary: d.summary,
    })
}

/// Every keyword of the language (reserved: not a name).
pub fn keywords() -> impl Iterator<Item = &'static str> {
    statements::RESERVED
        .iter()
        .copied()
        .chain(statements::STATEMENTS.iter().map(|d| d.keyword))
}

/// Every `CALL PROGRAM "name"` in `stmts` (also inside blocks and routines), with its span.
fn collect_calls(stmts: &[Stmt], out: &mut Vec<(String, Span)>) {
    for s in stmts {
        match &s.kind {
            StmtKind::CallProgram { name, span } => {
                if !out.iter().any(|(n, _)| n == name) {
                    out.push((name.clone(), *span));
                }
            }
            other => check::for_each_block(other, |body| collect_calls(body, out)),
        }
    }
}
