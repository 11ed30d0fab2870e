//! The syntax tree the parser builds: statements and expressions with their spans, before
//! names are resolved and types checked.

use wrc_robot::Posture;

use crate::diagnostic::Span;
use crate::statements::StatementDef;
use crate::value::Ty;

/// A name as written, and its upper-case key (names are case-insensitive).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Name {
    pub text: String,
    pub key: String,
    pub span: Span,
}

/// Unary operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum UnOp {
    Neg,
    Not,
}

/// Binary operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    And,
    Or,
}

impl BinOp {
    pub fn symbol(self) -> &'static str {
        match self {
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Mod => "MOD",
            BinOp::Eq => "=",
            BinOp::Ne => "<>",
            BinOp::Lt => "<",
            BinOp::Le => "<=",
            BinOp::Gt => ">",
            BinOp::Ge => ">=",
            BinOp::And => "AND",
            BinOp::Or => "OR",
        }
    }
}

/// An expression.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Expr {
    pub kind: ExprKind,
    pub span: Span,
    /// Height of the tree below (1 for a leaf); the parser keeps it bounded so that the
    /// recursive passes cannot overflow the stack.
    pub depth: u32,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ExprKind {
    Num(f64),
    Bool(bool),
    Str(String),
    Var(Name),
    /// `NAME[i]` or `NAME[i, j]`: an element of an array.
    Index(Name, Vec<Expr>),
    Unary(UnOp, Box<Expr>),
    /// Operator, its own span (where runtime errors point), operands.
    Binary(BinOp, Span, Box<Expr>, Box<Expr>),
    /// A function call `NAME(args)`: built-ins, the JOINTS / POSE constructors and the
    /// program's FUNCTIONs; `ERR`, `ERRMSG$`, `ERRLINE` and `OPERATOR$` written without
    /// parentheses too.
    Call(Name, Vec<Expr>),
    /// `expr.FIELD`.
    Field(Box<Expr>, Name),
    /// Something the parser could not read (already reported).
    Error,
}

/// An argument of a table-driven statement, in the order of its [`StatementDef`]'s `args`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Arg {
    Value(Expr),
    /// An optional value after a comma; `None` when left out.
    OptValue(Option<Expr>),
    /// `, L|R`; `None` when left out.
    Posture(Option<Posture>),
    /// `, A|B`: whether blade B was named (A when left out).
    Blade(bool),
    /// A robot axis, by name or 1-based number, resolved by the checker.
    Axis(AxisRef),
    /// PRINT items.
    Items(Vec<Expr>),
    /// A name the statement acts on (TEACH's point).
    Target(Name),
    /// WAIT's `IN(n) = value`.
    Input {
        n: Expr,
        value: Expr,
    },
    /// An optional `KEYWORD value`, e.g. `TIMEOUT s`.
    Keyword(Option<Expr>),
    /// A motion's options: `SPEED s`, `ACCEL a`, `BLEND [r]`, in any order.
    Motion(MotionOpts),
}

/// A motion statement's options, as written.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct MotionOpts {
    pub speed: Option<Expr>,
    pub accel: Option<Expr>,
    /// `BLEND` was written (with its zone [mm] where the statement takes one).
    pub blend: Option<(Span, Option<Expr>)>,
}

/// How a statement names a robot axis.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum AxisRef {
    Name(Name),
    Number(f64, Span),
}

/// A declared type: `AS NUMBER | BOOLEAN | STRING | POSE | JOINTS`, where it was written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TypeDecl {
    pub ty: Ty,
    pub span: Span,
}

/// A parameter of a SUB or FUNCTION.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Param {
    pub name: Name,
    pub ty: Option<TypeDecl>,
}

/// Which kind of routine a `SUB` / `FUNCTION` block is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RoutineKind {
    Sub,
    Function,
}

impl RoutineKind {
    pub fn word(self) -> &'static str {
        match self {
            RoutineKind::Sub => "SUB",
            RoutineKind::Function => "FUNCTION",
        }
    }
}

/// What `EXIT` leaves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ExitKind {
    For,
    While,
    Do,
    Sub,
    Function,
}

impl ExitKind {
    pub fn word(self) -> &'static str {
        match self {
            ExitKind::For => "FOR",
            ExitKind::While => "WHILE",
            ExitKind::Do => "DO",
            ExitKind::Sub => "SUB",
            ExitKind::Function => "FUNCTION",
        }
    }
}

/// One value test of a `CASE` line.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum CaseTest {
    /// `CASE v`: equal to the value.
    Is(Expr),
    /// `CASE lo TO hi`: within the range (numbers).
    Range(Expr, Expr),
    /// `CASE IS < v` (`=`, `<>`, `<`, `<=`, `>`, `>=`): the subject compared with the value.
    Cmp(BinOp, Expr),
}

/// One `CATCH` clause: its codes (none: every error) and its block.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Catch {
    pub codes: Vec<Expr>,
    pub body: Vec<Stmt>,
    pub span: Span,
}

/// A loop condition of `DO` / `LOOP`: `WHILE cond` (`until == false`) or `UNTIL cond`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LoopCond {
    pub until: bool,
    pub cond: Expr,
}

/// A statement.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Stmt {
    pub kind: StmtKind,
    /// The statement's first word (or the assigned name).
    pub span: Span,
}

// Tree nodes are built once per statement at compile time; boxing would only add noise.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum StmtKind {
    /// `name = value` or `name[i] = value`.
    Assign {
        target: Name,
        index: Vec<Expr>,
        value: Expr,
    },
    /// A statement from the statement table.
    Command {
        def: &'static StatementDef,
        args: Vec<Arg>,
    },
    /// `CALL name [(args)]`.
    Call {
        name: Name,
        args: Vec<Expr>,
    },
    /// `CALL PROGRAM "name"`.
    CallProgram {
        name: String,
        span: Span,
    },
    If {
        /// Each `IF` / `ELSEIF` condition and its block.
        arms: Vec<(Expr, Vec<Stmt>)>,
        else_block: Vec<Stmt>,
    },
    While {
        cond: Expr,
        body: Vec<Stmt>,
    },
    For {
        var: Name,
        from: Box<Expr>,
        to: Box<Expr>,
        step: Option<Box<Expr>>,
        body: Vec<Stmt>,
        /// Where `NEXT` is (the loop's increment and jump back point there).
        next: Span,
    },
    /// `DO [WHILE|UNTIL cond]` … `LOOP [WHILE|UNTIL cond]`.
    Do {
        pre: Option<LoopCond>,
        post: Option<LoopCond>,
        body: Vec<Stmt>,
        /// Where `LOOP` is.
        end: Span,
    },
    /// `SELECT CASE subject` … `CASE …` … `CASE ELSE` … `ENDSELECT`.
    Select {
        subject: Expr,
        cases: Vec<(Vec<CaseTest>, Vec<Stmt>, Span)>,
        else_block: Option<Vec<Stmt>>,
    },
    /// `TRY` … `CATCH [codes]` … `ENDTRY`.
    Try {
        body: Vec<Stmt>,
        catches: Vec<Catch>,
    },
    /// `SUB name [(params)]` … `ENDSUB`, `FUNCTION name(params) [AS type]` …
    /// `ENDFUNCTION`.
    Routine {
        kind: RoutineKind,
        name: Name,
        params: Vec<Param>,
        ret: Option<TypeDecl>,
        body: Vec<Stmt>,
    },
    /// `DIM name[dims] [AS type]` or `DIM name AS type`.
    Dim {
        name: Name,
        dims: Vec<Expr>,
        ty: Option<TypeDecl>,
    },
    /// `LOCAL name [AS type] [= value]`.
    Local {
        name: Name,
        ty: Option<TypeDecl>,
        init: Option<Expr>,
    },
    /// `RETURN [value]`.
    Return(Option<Expr>),
    /// `EXIT FOR | WHILE | DO | SUB | FUNCTION`.
    Exit(ExitKind),
    /// `RETRY`.
    Retry,
    /// `INCLUDE "name"`: the library's SUBs and FUNCTIONs (already parsed in; the
    /// statement stays for its position).
    Include {
        name: String,
    },
}
