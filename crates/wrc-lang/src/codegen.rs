//! The code generator: the checked tree to stack-machine instructions. The main program
//! comes first and ends in `HALT`; each routine follows (a SUB ends in `RET`, a FUNCTION in
//! `NORET`, the fault of falling off its end). Constant numbers and booleans are emitted
//! folded; the stack depth is tracked as code is emitted (every statement starts and ends
//! with an empty stack of its routine), and the first instruction of every statement is
//! recorded (RETRY, breakpoints and single steps go by statements).

use std::collections::HashMap;

use crate::ast::{BinOp, ExitKind, RoutineKind, UnOp};
use crate::builtins::Builtin;
use crate::bytecode::{next_id, Instr, MoveFlags, Program, Routine, SourcePos};
use crate::check::{Checked, Elem, Place, TArg, TCase, TExpr, TKind, TMotion, TStmt};
use crate::diagnostic::Span;
use crate::statements::CommandOp;
use crate::value::Value;

/// Compile a checked program for a robot with `axes` axes; `files` names the sources
/// (index 0 the program's own).
pub(crate) fn generate(checked: Checked, name: &str, axes: u8, files: Vec<String>) -> Program {
    let mut g = Gen {
        code: Vec::new(),
        positions: Vec::new(),
        constants: Vec::new(),
        const_index: HashMap::new(),
        strings: Vec::new(),
        string_index: HashMap::new(),
        statements: Vec::new(),
        depth: 0,
        max_depth: 0,
        blocks: Vec::new(),
        in_program_routine: false,
        global_slots: checked.global_slots.clone(),
    };
    for s in &checked.main {
        g.stmt(s);
    }
    let end = g.last_span();
    g.emit(Instr::Halt, end);
    let mut routines = Vec::with_capacity(checked.routines.len());
    for r in &checked.routines {
        let entry = g.here();
        g.depth = 0;
        g.in_program_routine = r.name.starts_with("PROGRAM ");
        for s in &r.body {
            g.stmt(s);
        }
        let end = g.last_span();
        let last = match r.kind {
            RoutineKind::Function => Instr::NoReturn,
            RoutineKind::Sub => Instr::Ret,
        };
        g.emit(last, end);
        routines.push(Routine {
            name: r.name.clone(),
            entry,
            params: r.params,
            locals: r.locals.clone(),
            returns: r.ret,
            pos: SourcePos {
                line: r.span.line,
                col: r.span.col,
                file: r.span.file,
            },
        });
    }
    Program {
        name: name.to_string(),
        axes,
        code: g.code,
        positions: g.positions,
        constants: g.constants,
        strings: g.strings,
        routines,
        variables: checked.globals,
        files,
        statements: g.statements,
        max_stack: g.max_depth,
        id: next_id(),
    }
}

/// A block the statements being generated are inside, for EXIT.
enum Block {
    /// A loop, and the jumps out of it (EXIT) to patch to its end.
    Loop(ExitKind, Vec<usize>),
    /// A TRY's protected block: leaving it drops its handler.
    TryBody,
    /// A CATCH clause: leaving it drops the handler it runs under.
    Catch,
}

struct Gen {
    code: Vec<Instr>,
    positions: Vec<SourcePos>,
    constants: Vec<f64>,
    const_index: HashMap<u64, u32>,
    strings: Vec<String>,
    string_index: HashMap<String, u32>,
    statements: Vec<u32>,
    depth: u32,
    max_depth: u32,
    blocks: Vec<Block>,
    /// Generating a called program's main body: END returns to the caller.
    in_program_routine: bool,
    /// Each global's first slot.
    global_slots: Vec<u32>,
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
            file: span.file,
        });
        self.code.len() - 1
    }

    fn here(&self) -> u32 {
        self.code.len() as u32
    }

    /// A statement starts at the next instruction.
    fn mark(&mut self) {
        let pc = self.here();
        if self.statements.last().is_none_or(|&last| last < pc) {
            self.statements.push(pc);
        }
    }

    fn last_span(&self) -> Span {
        self.positions.last().map_or_else(Span::default, |p| Span {
            line: p.line,
            col: p.col,
            len: 1,
            file: p.file,
        })
    }

    fn patch(&mut self, at: usize, target: u32) {
        self.code[at] = match self.code[at] {
            Instr::Jump(_) => Instr::Jump(target),
            Instr::JumpIfFalse(_) => Instr::JumpIfFalse(target),
            Instr::TryBegin(_) => Instr::TryBegin(target),
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

    fn slot(&self, global: u32) -> u32 {
        self.global_slots
            .get(global as usize)
            .copied()
            .unwrap_or(global)
    }

    fn load(&mut self, place: Place, span: Span) {
        let instr = match place {
            Place::Global(i) => Instr::Load(self.slot(i)),
            Place::Local(i) => Instr::LoadL(i),
        };
        self.emit(instr, span);
    }

    fn store(&mut self, place: Place, span: Span) {
        let instr = match place {
            Place::Global(i) => Instr::Store(self.slot(i)),
            Place::Local(i) => Instr::StoreL(i),
        };
        self.emit(instr, span);
    }

    /// The linear index of an element: one index, or `i * columns + j` with each checked
    /// against its dimension.
    fn index(&mut self, elem: &Elem, span: Span) {
        match elem.index.as_slice() {
            [i] => self.expr(i),
            [i, j] => {
                self.expr(i);
                self.emit(Instr::CheckIndex(elem.dims.d[0]), i.span);
                self.number(f64::from(elem.dims.d[1]), span);
                self.emit(Instr::Mul, span);
                self.expr(j);
                self.emit(Instr::CheckIndex(elem.dims.d[1]), j.span);
                self.emit(Instr::Add, span);
            }
            _ => {}
        }
    }

    fn elem_operands(&self, elem: &Elem) -> (bool, u32, u32) {
        match elem.place {
            Place::Global(b) => (false, self.slot(b), elem.dims.len()),
            Place::Local(b) => (true, b, elem.dims.len()),
        }
    }

    /// Leave the blocks out to the innermost loop of `kind`: drop the handlers of the TRYs
    /// in between and jump to the loop's end.
    fn exit_loop(&mut self, kind: ExitKind, span: Span) {
        let mut drops = Vec::new();
        let mut target = None;
        for (i, b) in self.blocks.iter().enumerate().rev() {
            match b {
                Block::Loop(k, _) if *k == kind => {
                    target = Some(i);
                    break;
                }
                Block::Loop(..) => {}
                Block::TryBody => drops.push(Instr::TryEnd),
                Block::Catch => drops.push(Instr::CatchEnd),
            }
        }
        for d in drops {
            self.emit(d, span);
        }
        let at = self.emit(Instr::Jump(0), span);
        if let Some(Block::Loop(_, exits)) = target.and_then(|i| self.blocks.get_mut(i)) {
            exits.push(at);
        }
    }

    fn body(&mut self, stmts: &[TStmt]) {
        for s in stmts {
            self.stmt(s);
        }
    }

    /// Generate `stmts` inside a block; returns the EXIT jumps of a loop block.
    fn in_block(&mut self, block: Block, stmts: &[TStmt]) -> Vec<usize> {
        self.blocks.push(block);
        self.body(stmts);
        match self.blocks.pop() {
            Some(Block::Loop(_, exits)) => exits,
            _ => Vec::new(),
        }
    }

    fn stmt(&mut self, s: &TStmt) {
        match s {
            TStmt::Store { place, value, span } => {
                self.mark();
                self.expr(value);
                self.store(*place, *span);
            }
            TStmt::StoreElem { elem, value, span } => {
                self.mark();
                self.index(elem, *span);
                self.expr(value);
                let (local, base, len) = self.elem_operands(elem);
                self.emit(Instr::StoreElem { local, base, len }, *span);
            }
            TStmt::Command { op, args, span } => {
                self.mark();
                self.command(*op, args, *span);
            }
            TStmt::Call {
                routine,
                args,
                discard,
                span,
            } => {
                self.mark();
                for a in args {
                    self.expr(a);
                }
                let instr = Instr::Call {
                    routine: *routine,
                    args: args.len() as u8,
                    value: *discard,
                };
                self.emit(instr, *span);
                if *discard {
                    self.emit(Instr::Pop, *span);
                }
            }
            TStmt::If { arms, else_block } => {
                let mut to_end = Vec::new();
                for (i, (cond, body)) in arms.iter().enumerate() {
                    self.mark();
                    self.expr(cond);
                    let skip = self.emit(Instr::JumpIfFalse(0), cond.span);
                    self.body(body);
                    let is_last = else_block.is_empty() && i + 1 == arms.len();
                    if !is_last {
                        to_end.push(self.emit(Instr::Jump(0), cond.span));
                    }
                    let next = self.here();
                    self.patch(skip, next);
                }
                self.body(else_block);
                let end = self.here();
                for at in to_end {
                    self.patch(at, end);
                }
            }
            TStmt::While { cond, body } => {
                let top = self.here();
                self.mark();
                self.expr(cond);
                let exit = self.emit(Instr::JumpIfFalse(0), cond.span);
                let exits = self.in_block(Block::Loop(ExitKind::While, Vec::new()), body);
                self.emit(Instr::Jump(top), cond.span);
                let end = self.here();
                self.patch(exit, end);
                for at in exits {
                    self.patch(at, end);
                }
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
            } => {
                let span = *span;
                self.mark();
                self.expr(from);
                self.store(*var, span);
                self.expr(to);
                self.store(*limit, span);
                match step {
                    Some(st) => self.expr(st),
                    None => self.number(1.0, span),
                }
                self.store(*step_slot, span);
                let first = self.emit(Instr::Jump(0), span);
                // Each later round: the increment and the test, one statement on FOR's line.
                let top = self.here();
                self.mark();
                self.load(*var, span);
                self.load(*step_slot, span);
                self.emit(Instr::Add, span);
                self.store(*var, span);
                let test = self.here();
                self.patch(first, test);
                self.load(*var, span);
                self.load(*limit, span);
                self.load(*step_slot, span);
                self.emit(Instr::ForTest, span);
                let exit = self.emit(Instr::JumpIfFalse(0), span);
                let exits = self.in_block(Block::Loop(ExitKind::For, Vec::new()), body);
                self.emit(Instr::Jump(top), span);
                let end = self.here();
                self.patch(exit, end);
                for at in exits {
                    self.patch(at, end);
                }
            }
            TStmt::Do {
                pre,
                post,
                body,
                span,
            } => {
                let top = self.here();
                let mut exit = None;
                if let Some((until, cond)) = pre {
                    self.mark();
                    self.expr(cond);
                    if *until {
                        self.emit(Instr::Not, cond.span);
                    }
                    exit = Some(self.emit(Instr::JumpIfFalse(0), cond.span));
                }
                let exits = self.in_block(Block::Loop(ExitKind::Do, Vec::new()), body);
                match post {
                    Some((until, cond)) => {
                        self.mark();
                        self.expr(cond);
                        if !*until {
                            self.emit(Instr::Not, cond.span);
                        }
                        self.emit(Instr::JumpIfFalse(top), cond.span);
                    }
                    None => {
                        self.emit(Instr::Jump(top), *span);
                    }
                }
                let end = self.here();
                for at in exit.into_iter().chain(exits) {
                    self.patch(at, end);
                }
            }
            TStmt::Select {
                slot,
                subject,
                cases,
                else_block,
                span,
            } => {
                self.mark();
                self.expr(subject);
                self.store(*slot, *span);
                let mut to_end = Vec::new();
                for (tests, body) in cases {
                    self.mark();
                    for (k, test) in tests.iter().enumerate() {
                        match test {
                            TCase::Is(e) => {
                                self.load(*slot, e.span);
                                self.expr(e);
                                self.emit(Instr::Eq, e.span);
                            }
                            TCase::Cmp(op, e) => {
                                self.load(*slot, e.span);
                                self.expr(e);
                                let instr = match op {
                                    BinOp::Ne => Instr::Ne,
                                    BinOp::Lt => Instr::Lt,
                                    BinOp::Le => Instr::Le,
                                    BinOp::Gt => Instr::Gt,
                                    BinOp::Ge => Instr::Ge,
                                    _ => Instr::Eq,
                                };
                                self.emit(instr, e.span);
                            }
                            TCase::Range(lo, hi) => {
                                self.load(*slot, lo.span);
                                self.expr(lo);
                                self.emit(Instr::Ge, lo.span);
                                self.load(*slot, hi.span);
                                self.expr(hi);
                                self.emit(Instr::Le, hi.span);
                                self.emit(Instr::And, hi.span);
                            }
                        }
                        if k > 0 {
                            self.emit(Instr::Or, *span);
                        }
                    }
                    let skip = self.emit(Instr::JumpIfFalse(0), *span);
                    self.body(body);
                    to_end.push(self.emit(Instr::Jump(0), *span));
                    let next = self.here();
                    self.patch(skip, next);
                }
                self.body(else_block);
                let end = self.here();
                for at in to_end {
                    self.patch(at, end);
                }
            }
            TStmt::Try {
                body,
                catches,
                span,
            } => {
                self.mark();
                let begin = self.emit(Instr::TryBegin(0), *span);
                self.in_block(Block::TryBody, body);
                self.emit(Instr::TryEnd, *span);
                let mut to_end = vec![self.emit(Instr::Jump(0), *span)];
                let dispatch = self.here();
                self.patch(begin, dispatch);
                self.depth = 0;
                for c in catches {
                    let mut skip = None;
                    if !c.codes.is_empty() {
                        self.mark();
                        for (k, code) in c.codes.iter().enumerate() {
                            self.emit(Instr::Builtin(Builtin::Err, 0), c.span);
                            self.number(f64::from(*code), c.span);
                            self.emit(Instr::Eq, c.span);
                            if k > 0 {
                                self.emit(Instr::Or, c.span);
                            }
                        }
                        skip = Some(self.emit(Instr::JumpIfFalse(0), c.span));
                    }
                    self.in_block(Block::Catch, &c.body);
                    self.emit(Instr::CatchEnd, c.span);
                    to_end.push(self.emit(Instr::Jump(0), c.span));
                    if let Some(skip) = skip {
                        let next = self.here();
                        self.patch(skip, next);
                    }
                }
                let last = catches.last().map_or(*span, |c| c.span);
                self.emit(Instr::Rethrow, last);
                let end = self.here();
                for at in to_end {
                    self.patch(at, end);
                }
            }
            TStmt::Return { value, span } => {
                self.mark();
                match value {
                    Some(v) => {
                        self.expr(v);
                        self.emit(Instr::RetVal, *span);
                    }
                    None => {
                        self.emit(Instr::Ret, *span);
                    }
                }
            }
            TStmt::Exit { kind, span } => {
                self.mark();
                match kind {
                    ExitKind::Sub | ExitKind::Function => {
                        self.emit(Instr::Ret, *span);
                    }
                    _ => self.exit_loop(*kind, *span),
                }
            }
            TStmt::Retry { span } => {
                self.mark();
                self.emit(Instr::Retry, *span);
            }
        }
    }

    /// The option values of a motion (SPEED, ACCEL, BLEND zone, in that order) and its
    /// flags.
    fn motion(&mut self, m: &TMotion) -> MoveFlags {
        let mut flags = 0;
        if let Some(e) = &m.speed {
            self.expr(e);
            flags |= MoveFlags::SPEED;
        }
        if let Some(e) = &m.accel {
            self.expr(e);
            flags |= MoveFlags::ACCEL;
        }
        match &m.blend {
            Some(Some(e)) => {
                self.expr(e);
                flags |= MoveFlags::ZONE;
            }
            Some(None) => flags |= MoveFlags::PASS,
            None => {}
        }
        MoveFlags(flags)
    }

    fn command(&mut self, op: CommandOp, args: &[TArg], span: Span) {
        let mut posture = None;
        let mut blade_b = false;
        let mut axis = 0;
        let mut items = 0u8;
        let mut timeout = false;
        let mut text = false;
        let mut flags = MoveFlags::default();
        let mut target = 0;
        for a in args {
            match a {
                TArg::Value(e) => self.expr(e),
                TArg::OptValue(e) => {
                    if let Some(e) = e {
                        self.expr(e);
                        text = true;
                    }
                }
                TArg::Posture(p) => posture = *p,
                TArg::Blade(b) => blade_b = *b,
                TArg::Axis(i) => axis = *i,
                TArg::Items(list) => {
                    for e in list {
                        self.expr(e);
                    }
                    items = list.len().min(255) as u8;
                }
                TArg::Target(g) => target = self.slot(*g),
                TArg::Input(input) => {
                    let (n, value) = &**input;
                    self.expr(n);
                    self.expr(value);
                }
                TArg::Keyword(e) => {
                    if let Some(e) = e {
                        self.expr(e);
                        timeout = true;
                    }
                }
                TArg::Motion(m) => flags = self.motion(m),
            }
        }
        let instr = match op {
            CommandOp::Home => Instr::Home(flags),
            CommandOp::MoveJ => Instr::MoveJ(flags),
            CommandOp::MoveP => Instr::MoveP(posture, flags),
            CommandOp::MoveL => Instr::MoveL(flags),
            CommandOp::Arc => Instr::Arc(flags),
            CommandOp::Appro => Instr::Appro(posture, flags),
            CommandOp::Appros => Instr::Appros(flags),
            CommandOp::Depart => Instr::Depart(flags),
            CommandOp::Departs => Instr::Departs(flags),
            CommandOp::Jog => Instr::Jog(axis, flags),
            CommandOp::Speed => Instr::Speed,
            CommandOp::Accel => Instr::Accel,
            CommandOp::Delay => Instr::Delay,
            CommandOp::Out => Instr::Out,
            CommandOp::Wait => Instr::Wait { timeout },
            CommandOp::WaitOperator => Instr::WaitOperator { text },
            CommandOp::Print => Instr::Print(items),
            CommandOp::End if self.in_program_routine => Instr::Ret,
            CommandOp::End => Instr::Halt,
            CommandOp::Get if blade_b => Instr::GetB,
            CommandOp::Put if blade_b => Instr::PutB,
            CommandOp::Get => Instr::Get,
            CommandOp::Put => Instr::Put,
            CommandOp::Map => Instr::Map,
            CommandOp::Swap => Instr::Swap,
            CommandOp::Raise => Instr::Raise { text },
            CommandOp::Alarm => Instr::Alarm,
            CommandOp::Reset => Instr::Reset,
            CommandOp::Teach => Instr::Teach(target),
        };
        self.emit(instr, span);
        if let Instr::Teach(g) = instr {
            self.emit(Instr::Store(g), span);
        }
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
            TKind::Load(place) => self.load(*place, e.span),
            TKind::LoadElem(elem) => {
                self.index(elem, e.span);
                let (local, base, len) = self.elem_operands(elem);
                self.emit(Instr::LoadElem { local, base, len }, e.span);
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
                    BinOp::Mod => Instr::Mod,
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
                let instr = match b {
                    Builtin::Here => Instr::Here,
                    Builtin::In => Instr::Input,
                    _ => Instr::Builtin(*b, args.len() as u8),
                };
                self.emit(instr, e.span);
            }
            TKind::Call(r, args) => {
                for a in args {
                    self.expr(a);
                }
                self.emit(
                    Instr::Call {
                        routine: *r,
                        args: args.len() as u8,
                        value: true,
                    },
                    e.span,
                );
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
