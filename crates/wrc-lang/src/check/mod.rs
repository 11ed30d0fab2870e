//! The checker: resolves names, infers and checks types, folds constant expressions and
//! checks constant targets against the robot model, producing the checked tree the code
//! generator compiles. Every problem becomes a diagnostic; nothing here panics on any tree.
//!
//! Scopes: each program (the one compiled with its INCLUDEd libraries, and each program it
//! calls with `CALL PROGRAM`) is a *unit* with its own global variables, SUBs, FUNCTIONs and
//! named points. Global variables take the type of their first assignment (or their `DIM`);
//! a read in a program's main body must follow an assignment in the text (or an assignment
//! inside some SUB). Inside a SUB or FUNCTION, parameters, `LOCAL`s and `DIM`s are local to
//! each call; other names are the unit's globals.
//!
//! `symbols.rs` declares and resolves names, `expr.rs` checks expressions, `stmt.rs`
//! statements.

mod expr;
mod stmt;
mod symbols;

use std::collections::HashMap;

use wrc_robot::{Posture, Robot};

use crate::ast::{BinOp, ExitKind, RoutineKind, Stmt, StmtKind, UnOp};
use crate::builtins::Builtin;
use crate::bytecode::{Init, Variable};
use crate::diagnostic::{Diagnostic, Span};
use crate::points::PointValue;
use crate::statements::CommandOp;
use crate::value::{Ty, Value};

pub(crate) use symbols::{for_each_block, Dims};
use symbols::{Global, Routine};

/// A checked expression: its type, and its value when the compiler knows it.
#[derive(Debug, Clone)]
pub(crate) struct TExpr {
    pub kind: TKind,
    pub ty: Ty,
    pub span: Span,
    pub konst: Option<Value>,
}

/// Where a variable lives: a global (its index among the checker's globals; the code
/// generator maps it to its slot), or a slot of the running SUB's frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Place {
    Global(u32),
    Local(u32),
}

/// An element of an array: where the array starts, its dimensions and the index
/// expressions (one per dimension).
#[derive(Debug, Clone)]
pub(crate) struct Elem {
    pub place: Place,
    pub dims: Dims,
    pub index: Vec<TExpr>,
}

#[derive(Debug, Clone)]
pub(crate) enum TKind {
    Num(f64),
    Bool(bool),
    Str(String),
    Load(Place),
    LoadElem(Box<Elem>),
    Unary(UnOp, Box<TExpr>),
    Binary(BinOp, Span, Box<TExpr>, Box<TExpr>),
    Joints(Vec<TExpr>),
    Pose(Vec<TExpr>),
    /// A built-in function and its arguments (a blade is a constant 0 or 1).
    Builtin(Builtin, Vec<TExpr>),
    /// A FUNCTION of the program (its routine index) and its arguments.
    Call(u32, Vec<TExpr>),
    PoseField(Box<TExpr>, u8),
    JointField(Box<TExpr>, u8),
}

/// A motion's checked options.
#[derive(Debug, Clone, Default)]
pub(crate) struct TMotion {
    pub speed: Option<TExpr>,
    pub accel: Option<TExpr>,
    /// `BLEND` given: with its zone [mm] on a Cartesian motion.
    pub blend: Option<Option<TExpr>>,
}

/// A checked statement argument.
#[derive(Debug, Clone)]
pub(crate) enum TArg {
    Value(TExpr),
    OptValue(Option<TExpr>),
    Posture(Option<Posture>),
    /// Blade B (true) or the hand, blade A.
    Blade(bool),
    Axis(u8),
    Items(Vec<TExpr>),
    /// TEACH's point: its global slot.
    Target(u32),
    /// `IN(n) = value` (boxed: two expressions in every argument would make each large).
    Input(Box<(TExpr, TExpr)>),
    Keyword(Option<TExpr>),
    Motion(Box<TMotion>),
}

/// One value test of a checked `CASE`.
#[derive(Debug, Clone)]
pub(crate) enum TCase {
    Is(TExpr),
    Range(TExpr, TExpr),
    /// `CASE IS op v`: the comparison (`=`, `<>`, `<`, `<=`, `>`, `>=`).
    Cmp(crate::ast::BinOp, TExpr),
}

/// A checked `CATCH` clause: its codes (empty: every error).
#[derive(Debug, Clone)]
pub(crate) struct TCatch {
    pub codes: Vec<u16>,
    pub body: Vec<TStmt>,
    pub span: Span,
}

/// A checked statement.
// Built once per statement at compile time; boxing would only add noise.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub(crate) enum TStmt {
    Store {
        place: Place,
        value: TExpr,
        span: Span,
    },
    StoreElem {
        elem: Elem,
        value: TExpr,
        span: Span,
    },
    Command {
        op: CommandOp,
        args: Vec<TArg>,
        span: Span,
    },
    /// A SUB (or a FUNCTION whose value is dropped) and its arguments.
    Call {
        routine: u32,
        args: Vec<TExpr>,
        /// A FUNCTION: its value is dropped.
        discard: bool,
        span: Span,
    },
    If {
        arms: Vec<(TExpr, Vec<TStmt>)>,
        else_block: Vec<TStmt>,
    },
    While {
        cond: TExpr,
        body: Vec<TStmt>,
    },
    For {
        var: Place,
        limit: Place,
        step_slot: Place,
        from: Box<TExpr>,
        to: Box<TExpr>,
        step: Option<Box<TExpr>>,
        body: Vec<TStmt>,
        span: Span,
    },
    Do {
        /// `(until, condition)` after DO.
        pre: Option<(bool, Box<TExpr>)>,
        /// `(until, condition)` after LOOP.
        post: Option<(bool, Box<TExpr>)>,
        body: Vec<TStmt>,
        span: Span,
    },
    Select {
        /// Where the tested value is kept while the cases are tried.
        slot: Place,
        subject: TExpr,
        cases: Vec<(Vec<TCase>, Vec<TStmt>)>,
        else_block: Vec<TStmt>,
        span: Span,
    },
    Try {
        body: Vec<TStmt>,
        catches: Vec<TCatch>,
        span: Span,
    },
    Return {
        value: Option<TExpr>,
        span: Span,
    },
    Exit {
        kind: ExitKind,
        span: Span,
    },
    Retry {
        span: Span,
    },
}

/// A checked SUB or FUNCTION (or a called program's main body).
#[derive(Debug, Clone)]
pub(crate) struct TRoutine {
    pub name: String,
    pub kind: RoutineKind,
    pub params: u16,
    /// Parameters first, then the locals (named and hidden), one slot each (arrays several).
    pub locals: Vec<Variable>,
    pub ret: Option<Ty>,
    pub body: Vec<TStmt>,
    /// Where it is defined.
    pub span: Span,
}

/// The checked program.
#[derive(Debug, Clone)]
pub(crate) struct Checked {
    pub main: Vec<TStmt>,
    pub routines: Vec<TRoutine>,
    /// The global slots.
    pub globals: Vec<Variable>,
    /// The first slot of each global of [`Place::Global`] (arrays take several).
    pub global_slots: Vec<u32>,
    pub symbols: Vec<Symbol>,
}

/// One program to check: its name, its top-level statements (with its libraries' SUBs and
/// FUNCTIONs appended) and its named points.
#[derive(Debug, Clone)]
pub(crate) struct Unit {
    /// The program's name (`PROGRAM name` calls it).
    pub name: String,
    pub stmts: Vec<Stmt>,
    /// The points file's points: name and value.
    pub points: Vec<(String, PointValue)>,
}

/// What a name is, for the editor's completion and go-to-definition.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Symbol {
    /// The name, as first written.
    pub name: String,
    /// `variable`, `array`, `point`, `sub`, `function`, `parameter` or `local`.
    pub kind: &'static str,
    /// `number`, `string`, … (a FUNCTION's result type; empty for a SUB).
    #[serde(rename = "type")]
    pub ty: &'static str,
    /// Where it is defined: the source file's index ([`crate::Compiled::sources`]), line and
    /// column [1-based]. Points are defined in the points file: line 0.
    pub file: u16,
    /// Line [1-based].
    pub line: u32,
    /// Column [1-based].
    pub col: u32,
    /// The SUB or FUNCTION it belongs to (parameters and locals).
    pub scope: Option<String>,
    /// What to show: a SUB's or FUNCTION's signature, an array's size.
    pub detail: String,
}

/// The kind of block a statement is inside, for `EXIT` and `RETRY`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Enclosing {
    Loop(ExitKind),
    TryBody,
    Catch,
}

/// Where the checker is.
#[derive(Debug, Clone, Default)]
struct Ctx {
    unit: u16,
    /// The SUB or FUNCTION whose body this is.
    routine: Option<u32>,
    /// Blocks around the statement, outermost first.
    blocks: Vec<Enclosing>,
}

struct Checker<'a> {
    robot: &'a Robot,
    diags: &'a mut Vec<Diagnostic>,
    /// The type pre-pass: no diagnostics, no use tracking.
    quiet: bool,
    globals: Vec<Global>,
    global_index: ByUnit,
    routines: Vec<Routine>,
    routine_index: ByUnit,
    /// Each unit's name and the routine of its main body (none for unit 0).
    unit_names: Vec<String>,
    /// Each source file's name as messages cite it (`cell_lib.wrl`), by file index.
    file_names: &'a [String],
    unit_main: Vec<Option<u32>>,
    ctx: Ctx,
    /// Main bodies: variables assigned so far in the text.
    assigned: Vec<bool>,
    /// A statement was left out of the checked tree (normally because of a reported error).
    dropped: bool,
    symbols: Vec<Symbol>,
}

/// Check parsed programs (`units[0]` is the one compiled). Returns `None` when there are
/// errors (all reported).
/// Check `units` (the program first): the typed program, or, when it has errors (reported in
/// `diags`), the names it defines as far as they were understood (for an editor's
/// completion while the program is being written).
pub(crate) fn check(
    units: &[Unit],
    robot: &Robot,
    file_names: &[String],
    diags: &mut Vec<Diagnostic>,
) -> Result<Checked, Vec<Symbol>> {
    let errors_before = diags.iter().filter(|d| d.is_error()).count();
    let mut c = Checker {
        robot,
        diags,
        quiet: false,
        globals: Vec::new(),
        global_index: ByUnit::default(),
        routines: Vec::new(),
        routine_index: ByUnit::default(),
        unit_names: units.iter().map(|u| u.name.clone()).collect(),
        file_names,
        unit_main: vec![None; units.len()],
        ctx: Ctx::default(),
        assigned: Vec::new(),
        dropped: false,
        symbols: Vec::new(),
    };
    c.declare(units);
    c.collect(units);
    c.infer_types(units);
    c.assigned = vec![false; c.globals.len()];

    let mut main = Vec::new();
    let mut bodies: Vec<Option<Vec<crate::check::TStmt>>> = vec![None; c.routines.len()];
    for (u, unit) in units.iter().enumerate() {
        let u = u as u16;
        c.ctx = Ctx {
            unit: u,
            routine: c.unit_main[usize::from(u)],
            blocks: Vec::new(),
        };
        let mut out = Vec::new();
        c.top_level(&unit.stmts, &mut out, &mut bodies);
        match c.unit_main[usize::from(u)] {
            None => main = out,
            Some(r) => bodies[r as usize] = Some(out),
        }
    }
    c.warn_unused(units.first().is_some_and(|u| is_library(&u.stmts)));

    let errors = c.diags.iter().filter(|d| d.is_error()).count();
    if errors > errors_before {
        return Err(c.take_symbols());
    }
    if c.dropped && errors == 0 {
        // Every dropped statement should have been reported; never compile without it.
        c.diags.push(Diagnostic::error(
            Span::line_start(0, 1),
            "internal error: a statement could not be compiled and no reason was given (a bug in wrc-lang, please report it)",
        ));
        return Err(c.take_symbols());
    }
    // One slot a variable, an array's elements in a row: its first slot named, the rest
    // hidden.
    let mut globals = Vec::with_capacity(c.globals.len());
    let mut global_slots = Vec::with_capacity(c.globals.len());
    for g in &c.globals {
        global_slots.push(globals.len() as u32);
        let ty = g.ty.unwrap_or(Ty::Number);
        globals.push(Variable {
            name: g.name.clone(),
            ty,
            hidden: g.hidden,
            len: g.dims.len(),
            point: g.point,
            init: g.init.and_then(|v| match v {
                Value::Pose(p) => Some(Init::Pose(p)),
                Value::Joints(j) => Some(Init::Joints(j)),
                _ => None,
            }),
        });
        for _ in 1..g.dims.len() {
            globals.push(Variable {
                name: format!("{}[]", g.name),
                ty,
                hidden: true,
                len: 0,
                point: false,
                init: None,
            });
        }
    }
    let routines = c
        .routines
        .iter()
        .zip(bodies)
        .map(|(r, body)| TRoutine {
            name: r.display_name(),
            kind: r.kind,
            params: r.params.len() as u16,
            locals: r.frame_variables(),
            ret: r.ret,
            body: body.unwrap_or_default(),
            span: r.name.span,
        })
        .collect();
    let symbols = c.take_symbols();
    Ok(Checked {
        main,
        routines,
        globals,
        global_slots,
        symbols,
    })
}

impl Checker<'_> {
    /// The symbols gathered, with the types inferred for variables and locals.
    fn take_symbols(&mut self) -> Vec<Symbol> {
        let c = self;
        let mut symbols = std::mem::take(&mut c.symbols);
        for sym in symbols
            .iter_mut()
            .filter(|s| s.ty.is_empty() && s.kind == "variable")
        {
            if let Some(&g) = c.global_index.get(0, &sym.name.to_ascii_uppercase()) {
                sym.ty = c.globals[g as usize].ty.map_or("", Ty::name);
            }
        }
        for sym in symbols
            .iter_mut()
            .filter(|s| s.ty.is_empty() && s.kind == "local")
        {
            let scope = sym.scope.clone().unwrap_or_default().to_ascii_uppercase();
            if let Some(&r) = c.routine_index.get(0, &scope) {
                let r = &c.routines[r as usize];
                if let Some(&i) = r.local_index.get(&sym.name.to_ascii_uppercase()) {
                    sym.ty = r.locals[i].ty.map_or("", Ty::name);
                }
            }
        }
        symbols
    }
}

/// `a number`, `TRUE/FALSE`, … for messages.
pub(crate) fn article(ty: Ty) -> &'static str {
    match ty {
        Ty::Number => "a number",
        Ty::Bool => "TRUE/FALSE",
        Ty::Str => "a string",
        Ty::Pose => "a pose",
        Ty::Joints => "joints",
    }
}

impl Checker<'_> {
    fn error(&mut self, span: Span, message: impl Into<String>) {
        if !self.quiet {
            self.diags.push(Diagnostic::error(span, message));
        }
    }

    fn warning(&mut self, span: Span, message: impl Into<String>) {
        if !self.quiet {
            self.diags.push(Diagnostic::warning(span, message));
        }
    }

    /// Whether the statements being checked are a main body (the program's or a called
    /// program's), not a SUB's or FUNCTION's.
    fn in_main(&self) -> bool {
        match self.ctx.routine {
            None => true,
            Some(r) => self.routines[r as usize].program,
        }
    }
}

/// Whether a program is a library: nothing at its top level runs (only SUBs, FUNCTIONs,
/// DIMs and INCLUDEs), so its routines are there for others to call.
fn is_library(stmts: &[Stmt]) -> bool {
    !stmts.is_empty()
        && stmts.iter().all(|s| {
            matches!(
                s.kind,
                StmtKind::Routine { .. } | StmtKind::Include { .. } | StmtKind::Dim { .. }
            )
        })
}

/// Names of each unit (upper case) to their index: looked up by `&str`, without making a
/// key (the checker looks a name up at every use).
#[derive(Debug, Default)]
pub(crate) struct ByUnit(Vec<HashMap<String, u32>>);

impl ByUnit {
    pub(crate) fn get(&self, unit: u16, key: &str) -> Option<&u32> {
        self.0.get(usize::from(unit)).and_then(|m| m.get(key))
    }

    pub(crate) fn contains_key(&self, unit: u16, key: &str) -> bool {
        self.get(unit, key).is_some()
    }

    pub(crate) fn insert(&mut self, unit: u16, key: String, value: u32) {
        let u = usize::from(unit);
        if self.0.len() <= u {
            self.0.resize_with(u + 1, HashMap::new);
        }
        self.0[u].insert(key, value);
    }
}
