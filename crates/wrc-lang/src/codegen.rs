//! The code generator: the checked tree to stack-machine instructions. The main program
//! comes first and ends in `HALT`; each SUB follows, ending in `RET`. Constant numbers and
//! booleans are emitted folded; the stack depth is tracked as code is emitted (every
//! statement starts and ends with an empty stack).

use std::collections::HashMap;

use crate::ast::{BinOp, UnOp};
use crate::bytecode::{next_id, Instr, Program, SourcePos, SubEntry};
use crate::check::{Checked, TArg, TExpr, TKind, TStmt};
use crate::diagnostic::Span;
use crate::statements::CommandOp;
use crate::value::Value;

/// Compile a checked program for a robot with `axes` axes.
pub(crate) fn generate(checked: Checked, name: &str, axes: u8) -> Program {
    let mut g = Gen {
        code: Vec::new(),
        positions: Vec::new(),
        constants: Vec::new(),
        const_index: HashMap::new(),
        strings: Vec::new(),
        string_index: HashMap::new(),
        depth: 0,
        max_depth: 0,
        calls: Vec::new(),
    };
    let mut end = Span::default();
    for s in &checked.main {
        g.stmt(s);
    }
    if let Some(last) = g.positions.last() {
        end = Span {
            line: last.line,
            col: last.col,
            len: 1,
        };
    }
    g.emit(Instr::Halt, end);
    let mut subs = Vec::with_capacity(checked.subs.len());
    for sub in &checked.subs {
        let entry = g.code.len() as u32;
        for s in &sub.body {
            g.stmt(s);
        }
        let at = g.positions.last().copied().unwrap_or_default();
        g.emit(
            Instr::Ret,
            Span {
                line: at.line,
                col: at.col,
                len: 1,
            },
        );
        subs.push(SubEntry {
            name: sub.name.clone(),
            entry,
        });
    }
    // The checker numbers SUBs in definition order, the order of `checked.subs`.
    for (pc, sub) in std::mem::take(&mut g.calls) {
        let entry = subs.get(sub as usize).map_or(0, |s| s.entry);
        g.code[pc] = Instr::Call(entry);
    }
    Program {
        name: name.to_string(),
        axes,
        code: g.code,
        positions: g.positions,
        constants: g.constants,
        strings: g.strings,
        subs,
        variables: checked.vars,
        max_stack: g.max_depth,
        id: next_id(),
    }
}

struct Gen {
    code: Vec<Instr>,
    positions: Vec<SourcePos>,
    constants: Vec<f64>,
    const_index: HashMap<u64, u32>,
    strings: Vec<String>,
    string_index: HashMap<String, u32>,
    depth: u32,
    max_depth: u32,
    /// `CALL` instructions and the SUB (checker index) each calls, patched at the end.
    calls: Vec<(usize, u32)>,
}

impl Gen {
    fn emit(&mut self, instr: Instr, span: Span) -> usize {
        let (pops, pushes) = instr.stack_effect();
        self.depth = self.depth.saturating_sub(pops) + pushes;
        self.max_depth = self.max_depth.max(self.depth);
        self.code.push(instr);
        self.positions.push(SourcePos {
            line: span.line,
            col: span.col,
        });
        self.code.len() - 1
    }

    fn here(&self) -> u32 {
        self.code.len() as u32
    }

    fn patch(&mut self, at: usize, target: u32) {
        self.code[at] = match self.code[at] {
            Instr::Jump(_) => Instr::Jump(target),
            Instr::JumpIfFalse(_) => Instr::JumpIfFalse(target),
            other => other,
        };
    }

    fn number(&mut self, x: f64, span: Span) {
        let bits = x.to_bits();
        let next = self.constants.len() as u32;
        let i = *self.const_index.entry(bits).or_insert(next);
        if i == next {
            self.constants.push(x);
        }
        self.emit(Instr::Num(i), span);
    }

    fn string(&mut self, s: &str, span: Span) {
        let i = match self.string_index.get(s) {
            Some(&i) => i,
            None => {
                let i = self.strings.len() as u32;
                self.strings.push(s.to_string());
                self.string_index.insert(s.to_string(), i);
                i
            }
        };
        self.emit(Instr::Str(i), span);
    }

    fn stmt(&mut self, s: &TStmt) {
        match s {
            TStmt::Store { slot, value, span } => {
                self.expr(value);
                self.emit(Instr::Store(*slot), *span);
            }
            TStmt::Command { op, args, span } => self.command(*op, args, *span),
            TStmt::If { arms, else_block } => {
                let mut to_end = Vec::new();
                for (i, (cond, body)) in arms.iter().enumerate() {
                    self.expr(cond);
                    let skip = self.emit(Instr::JumpIfFalse(0), cond.span);
                    for s in body {
                        self.stmt(s);
                    }
                    let is_last = else_block.is_empty() && i + 1 == arms.len();
                    if !is_last {
                        to_end.push(self.emit(Instr::Jump(0), cond.span));
                    }
                    let next = self.here();
                    self.patch(skip, next);
                }
                for s in else_block {
                    self.stmt(s);
                }
                let end = self.here();
                for at in to_end {
                    self.patch(at, end);
                }
            }
            TStmt::While { cond, body } => {
                let top = self.here();
                self.expr(cond);
                let exit = self.emit(Instr::JumpIfFalse(0), cond.span);
                for s in body {
                    self.stmt(s);
                }
                self.emit(Instr::Jump(top), cond.span);
                let end = self.here();
                self.patch(exit, end);
            }
            TStmt::For {
                var,
                limit,
                step_slot,
                from,
                to,
                step,
                body,
                span,
                next,
            } => {
                self.expr(from);
                self.emit(Instr::Store(*var), *span);
                self.expr(to);
                self.emit(Instr::Store(*limit), *span);
                match step {
                    Some(st) => self.expr(st),
                    None => self.number(1.0, *span),
                }
                self.emit(Instr::Store(*step_slot), *span);
                let top = self.here();
                self.emit(Instr::Load(*var), *span);
                self.emit(Instr::Load(*limit), *span);
                self.emit(Instr::Load(*step_slot), *span);
                self.emit(Instr::ForTest, *span);
                let exit = self.emit(Instr::JumpIfFalse(0), *span);
                for s in body {
                    self.stmt(s);
                }
                self.emit(Instr::Load(*var), *next);
                self.emit(Instr::Load(*step_slot), *next);
                self.emit(Instr::Add, *next);
                self.emit(Instr::Store(*var), *next);
                self.emit(Instr::Jump(top), *next);
                let end = self.here();
                self.patch(exit, end);
            }
        }
    }

    fn command(&mut self, op: CommandOp, args: &[TArg], span: Span) {
        let mut posture = None;
        let mut blade_b = false;
        let mut axis = 0;
        let mut items = 0u8;
        let mut timeout = false;
        for a in args {
            match a {
                TArg::Value(e) => self.expr(e),
                TArg::Posture(p) => posture = *p,
                TArg::Blade(b) => blade_b = *b,
                TArg::Axis(i) => axis = *i,
                TArg::Items(list) => {
                    for e in list {
                        self.expr(e);
                    }
                    items = list.len().min(255) as u8;
                }
                TArg::Sub(i) => {
                    let at = self.emit(Instr::Call(0), span);
                    self.calls.push((at, *i));
                }
                TArg::Input { n, value } => {
                    self.expr(n);
                    self.expr(value);
                }
                TArg::Keyword(e) => {
                    if let Some(e) = e {
                        self.expr(e);
                        timeout = true;
                    }
                }
            }
        }
        let instr = match op {
            CommandOp::Home => Instr::Home,
            CommandOp::MoveJ => Instr::MoveJ,
            CommandOp::MoveP => Instr::MoveP(posture),
            CommandOp::MoveL => Instr::MoveL,
            CommandOp::Jog => Instr::Jog(axis),
            CommandOp::Speed => Instr::Speed,
            CommandOp::Delay => Instr::Delay,
            CommandOp::Out => Instr::Out,
            CommandOp::Wait => Instr::Wait { timeout },
            CommandOp::Print => Instr::Print(items),
            CommandOp::Call => return, // emitted with its argument
            CommandOp::End => Instr::Halt,
            CommandOp::Get if blade_b => Instr::GetB,
            CommandOp::Put if blade_b => Instr::PutB,
            CommandOp::Get => Instr::Get,
            CommandOp::Put => Instr::Put,
            CommandOp::Map => Instr::Map,
            CommandOp::Swap => Instr::Swap,
        };
        self.emit(instr, span);
    }

    fn expr(&mut self, e: &TExpr) {
        match e.konst {
            Some(Value::Num(x)) => return self.number(x, e.span),
            Some(Value::Bool(b)) => {
                self.emit(if b { Instr::True } else { Instr::False }, e.span);
                return;
            }
            _ => {}
        }
        match &e.kind {
            TKind::Num(x) => self.number(*x, e.span),
            TKind::Bool(b) => {
                self.emit(if *b { Instr::True } else { Instr::False }, e.span);
            }
            TKind::Str(s) => self.string(s, e.span),
            TKind::Load(slot) => {
                self.emit(Instr::Load(*slot), e.span);
            }
            TKind::Unary(op, inner) => {
                self.expr(inner);
                let instr = match op {
                    UnOp::Neg => Instr::Neg,
                    UnOp::Not => Instr::Not,
                };
                self.emit(instr, e.span);
            }
            TKind::Binary(op, op_span, l, r) => {
                self.expr(l);
                self.expr(r);
                let instr = match op {
                    BinOp::Add => Instr::Add,
                    BinOp::Sub => Instr::Sub,
                    BinOp::Mul => Instr::Mul,
                    BinOp::Div => Instr::Div,
                    BinOp::Eq => Instr::Eq,
                    BinOp::Ne => Instr::Ne,
                    BinOp::Lt => Instr::Lt,
                    BinOp::Le => Instr::Le,
                    BinOp::Gt => Instr::Gt,
                    BinOp::Ge => Instr::Ge,
                    BinOp::And => Instr::And,
                    BinOp::Or => Instr::Or,
                };
                self.emit(instr, *op_span);
            }
            TKind::Joints(args) => {
                for a in args {
                    self.expr(a);
                }
                self.emit(Instr::Joints(args.len() as u8), e.span);
            }
            TKind::Pose(args) => {
                for a in args {
                    self.expr(a);
                }
                self.emit(Instr::Pose, e.span);
            }
            TKind::Builtin(b, args) => {
                for a in args {
                    self.expr(a);
                }
                self.emit(Instr::Builtin(*b), e.span);
            }
            TKind::Here => {
                self.emit(Instr::Here, e.span);
            }
            TKind::Input(n) => {
                self.expr(n);
                self.emit(Instr::Input, e.span);
            }
            TKind::PoseField(inner, i) => {
                self.expr(inner);
                self.emit(Instr::PoseField(*i), e.span);
            }
            TKind::JointField(inner, i) => {
                self.expr(inner);
                self.emit(Instr::JointField(*i), e.span);
            }
        }
    }
}
