//! The syntax tree the parser builds: statements and expressions with their spans, before
//! names are resolved and types checked.

use wrc_robot::Posture;

use crate::diagnostic::Span;
use crate::statements::StatementDef;

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
    Unary(UnOp, Box<Expr>),
    /// Operator, its own span (where runtime errors point), operands.
    Binary(BinOp, Span, Box<Expr>, Box<Expr>),
    /// A function call `NAME(args)`: built-ins and the JOINTS / POSE constructors.
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
    /// `, L|R`; `None` when left out.
    Posture(Option<Posture>),
    /// `, A|B`: whether blade B was named (A when left out).
    Blade(bool),
    /// A robot axis, by name or 1-based number, resolved by the checker.
    Axis(AxisRef),
    /// PRINT items.
    Items(Vec<Expr>),
    /// CALL's SUB name.
    Sub(Name),
    /// WAIT's `IN(n) = value`.
    Input {
        n: Expr,
        value: Expr,
    },
    /// An optional `KEYWORD value`, e.g. `TIMEOUT s`.
    Keyword(Option<Expr>),
}

/// How a statement names a robot axis.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum AxisRef {
    Name(Name),
    Number(f64, Span),
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
    Assign {
        target: Name,
        value: Expr,
    },
    /// A statement from the statement table.
    Command {
        def: &'static StatementDef,
        args: Vec<Arg>,
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
        from: Expr,
        to: Expr,
        step: Option<Expr>,
        body: Vec<Stmt>,
        /// Where `NEXT` is (the loop's increment and jump back point there).
        next: Span,
    },
    Sub {
        name: Name,
        body: Vec<Stmt>,
    },
}
