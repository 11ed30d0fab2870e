//! The checker: resolves names, infers and checks types, folds constant expressions and
//! checks constant targets against the robot model, producing the checked tree the code
//! generator compiles. Every problem becomes a diagnostic; nothing here panics on any tree.
//!
//! Variables are global (SUBs share them) and take the type of their first assignment. A
//! read in the main program must follow an assignment in the text (or an assignment inside
//! some SUB); a read inside a SUB needs an assignment anywhere.

use std::collections::HashMap;

use wrc_robot::{Pose, Posture, Robot};

use crate::ast::{Arg, AxisRef, BinOp, Expr, ExprKind, Name, Stmt, StmtKind, UnOp};
use crate::bytecode::{Builtin, Variable};
use crate::diagnostic::{Diagnostic, Span};
use crate::error::RuntimeErrorKind;
use crate::statements::{ArgSpec, ArgTy, CommandOp, ConstCheck, StatementDef};
use crate::value::{self, Arith, Cmp, Ty, Value};
use crate::vm::ProgramNum;

/// A checked expression: its type, and its value when the compiler knows it.
#[derive(Debug, Clone)]
pub(crate) struct TExpr {
    pub kind: TKind,
    pub ty: Ty,
    pub span: Span,
    pub konst: Option<Value>,
}

#[derive(Debug, Clone)]
pub(crate) enum TKind {
    Num(f64),
    Bool(bool),
    Str(String),
    Load(u32),
    Unary(UnOp, Box<TExpr>),
    Binary(BinOp, Span, Box<TExpr>, Box<TExpr>),
    Joints(Vec<TExpr>),
    Pose(Vec<TExpr>),
    Builtin(Builtin, Vec<TExpr>),
    Here,
    Input(Box<TExpr>),
    PoseField(Box<TExpr>, u8),
    JointField(Box<TExpr>, u8),
}

/// A checked statement argument.
#[derive(Debug, Clone)]
pub(crate) enum TArg {
    Value(TExpr),
    Posture(Option<Posture>),
    /// Blade B (true) or the hand, blade A.
    Blade(bool),
    Axis(u8),
    Items(Vec<TExpr>),
    Sub(u32),
    Input {
        n: TExpr,
        value: TExpr,
    },
    Keyword(Option<TExpr>),
}

/// A checked statement.
// Built once per statement at compile time; boxing would only add noise.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub(crate) enum TStmt {
    Store {
        slot: u32,
        value: TExpr,
        span: Span,
    },
    Command {
        op: CommandOp,
        args: Vec<TArg>,
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
        var: u32,
        limit: u32,
        step_slot: u32,
        from: TExpr,
        to: TExpr,
        step: Option<TExpr>,
        body: Vec<TStmt>,
        span: Span,
        next: Span,
    },
}

/// A checked SUB.
#[derive(Debug, Clone)]
pub(crate) struct TSub {
    pub name: String,
    pub body: Vec<TStmt>,
}

/// The checked program.
#[derive(Debug, Clone)]
pub(crate) struct Checked {
    pub main: Vec<TStmt>,
    pub subs: Vec<TSub>,
    pub vars: Vec<Variable>,
}

struct Var {
    name: String,
    first: Span,
    ty: Option<Ty>,
    ty_span: Span,
    assigns: u32,
    konst: Option<Value>,
    read: bool,
    assigned_in_sub: bool,
    for_var: bool,
    hidden: bool,
    /// An assignment to it had an error: do not also warn that it is unused.
    broken: bool,
}

struct SubInfo {
    name: Name,
    called: bool,
}

struct Checker<'a> {
    robot: &'a Robot,
    diags: &'a mut Vec<Diagnostic>,
    /// The type pre-pass: no diagnostics, no use tracking.
    quiet: bool,
    vars: Vec<Var>,
    var_index: HashMap<String, u32>,
    subs: Vec<SubInfo>,
    sub_index: HashMap<String, u32>,
    in_sub: bool,
    /// Main program: variables assigned so far in the text.
    assigned: Vec<bool>,
    /// A statement was left out of the checked tree (normally because of a reported error).
    dropped: bool,
}

/// Check a parsed program. Returns `None` when there are errors (all reported).
pub(crate) fn check(stmts: &[Stmt], robot: &Robot, diags: &mut Vec<Diagnostic>) -> Option<Checked> {
    let errors_before = diags.iter().filter(|d| d.is_error()).count();
    let mut c = Checker {
        robot,
        diags,
        quiet: false,
        vars: Vec::new(),
        var_index: HashMap::new(),
        subs: Vec::new(),
        sub_index: HashMap::new(),
        in_sub: false,
        assigned: Vec::new(),
        dropped: false,
    };
    c.collect(stmts, false);
    c.infer_types(stmts);
    c.assigned = vec![false; c.vars.len()];

    let mut main = Vec::new();
    let mut subs = Vec::new();
    c.top_level(stmts, &mut main, &mut subs);
    c.warn_unused();

    let errors = c.diags.iter().filter(|d| d.is_error()).count();
    if errors > errors_before {
        return None;
    }
    if c.dropped && errors == 0 {
        // Every dropped statement should have been reported; never compile without it.
        c.diags.push(Diagnostic::error(
            Span {
                line: 1,
                col: 1,
                len: 1,
            },
            "internal error: a statement could not be compiled and no reason was given (a bug in wrc-lang, please report it)",
        ));
        return None;
    }
    let vars = c
        .vars
        .iter()
        .map(|v| Variable {
            name: v.name.clone(),
            ty: v.ty.unwrap_or(Ty::Number),
            hidden: v.hidden,
        })
        .collect();
    Some(Checked { main, subs, vars })
}

fn article(ty: Ty) -> &'static str {
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

    fn var_slot(&mut self, name: &Name) -> u32 {
        if let Some(&i) = self.var_index.get(&name.key) {
            return i;
        }
        let i = self.vars.len() as u32;
        self.vars.push(Var {
            name: name.text.clone(),
            first: name.span,
            ty: None,
            ty_span: name.span,
            assigns: 0,
            konst: None,
            read: false,
            assigned_in_sub: false,
            for_var: false,
            hidden: false,
            broken: false,
        });
        self.var_index.insert(name.key.clone(), i);
        i
    }

    fn hidden_slot(&mut self, name: String) -> u32 {
        let i = self.vars.len() as u32;
        self.vars.push(Var {
            name,
            first: Span::default(),
            ty: Some(Ty::Number),
            ty_span: Span::default(),
            assigns: 2,
            konst: None,
            read: true,
            assigned_in_sub: false,
            for_var: false,
            hidden: true,
            broken: false,
        });
        self.assigned.push(true);
        i
    }

    /// Register every SUB and every assigned variable, in text order.
    fn collect(&mut self, stmts: &[Stmt], in_sub: bool) {
        for s in stmts {
            match &s.kind {
                StmtKind::Assign { target, .. } => {
                    let i = self.var_slot(target) as usize;
                    self.vars[i].assigns += 1;
                    self.vars[i].assigned_in_sub |= in_sub;
                }
                StmtKind::Command { .. } => {}
                StmtKind::If { arms, else_block } => {
                    for (_, body) in arms {
                        self.collect(body, in_sub);
                    }
                    self.collect(else_block, in_sub);
                }
                StmtKind::While { body, .. } => self.collect(body, in_sub),
                StmtKind::For { var, body, .. } => {
                    let i = self.var_slot(var) as usize;
                    let v = &mut self.vars[i];
                    v.assigns += 2;
                    v.assigned_in_sub |= in_sub;
                    v.for_var = true;
                    if v.ty.is_none() {
                        v.ty = Some(Ty::Number);
                        v.ty_span = var.span;
                    }
                    self.collect(body, in_sub);
                }
                StmtKind::Sub { name, body } => {
                    if let Some(&first) = self.sub_index.get(&name.key) {
                        let at = self.subs[first as usize].name.span.at();
                        self.error(
                            name.span,
                            format!("SUB {} is defined twice (first at {at})", name.text),
                        );
                    } else {
                        self.sub_index
                            .insert(name.key.clone(), self.subs.len() as u32);
                        self.subs.push(SubInfo {
                            name: name.clone(),
                            called: false,
                        });
                    }
                    self.collect(body, true);
                }
            }
        }
    }

    /// Give every variable the type (and, if it is assigned once, the constant value) of its
    /// first assignment whose type is known, repeating until nothing changes.
    fn infer_types(&mut self, stmts: &[Stmt]) {
        let mut assignments = Vec::new();
        gather_assignments(stmts, &self.var_index, &mut assignments);
        self.quiet = true;
        loop {
            let mut changed = false;
            for &(slot, expr, span) in &assignments {
                let slot = slot as usize;
                let v = &self.vars[slot];
                let settled = v.ty.is_some() && (v.assigns != 1 || v.for_var || v.konst.is_some());
                if settled {
                    continue;
                }
                let Some(te) = self.expr(expr) else { continue };
                let v = &mut self.vars[slot];
                if v.ty.is_none() {
                    v.ty = Some(te.ty);
                    v.ty_span = span;
                    changed = true;
                }
                if v.assigns == 1 && !v.for_var && v.konst.is_none() && te.konst.is_some() {
                    v.konst = te.konst;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        self.quiet = false;
    }

    fn top_level(&mut self, stmts: &[Stmt], main: &mut Vec<TStmt>, subs: &mut Vec<TSub>) {
        let mut ended: Option<Span> = None;
        let mut warned = false;
        for s in stmts {
            if let StmtKind::Sub { name, body } = &s.kind {
                self.sub(name, body, subs);
                continue;
            }
            if let (Some(end), false) = (ended, warned) {
                warned = true;
                self.warning(
                    s.span,
                    format!("this code never runs: END at {} ends the program", end.at()),
                );
            }
            if is_end(s) {
                ended = ended.or(Some(s.span));
            }
            self.stmt(s, main, subs);
        }
    }

    fn sub(&mut self, name: &Name, body: &[Stmt], subs: &mut Vec<TSub>) {
        let was = self.in_sub;
        self.in_sub = true;
        let body = self.block(body, subs);
        self.in_sub = was;
        subs.push(TSub {
            name: name.text.clone(),
            body,
        });
    }

    fn block(&mut self, stmts: &[Stmt], subs: &mut Vec<TSub>) -> Vec<TStmt> {
        let mut out = Vec::with_capacity(stmts.len());
        let mut ended: Option<Span> = None;
        let mut warned = false;
        for s in stmts {
            if let StmtKind::Sub { name, body } = &s.kind {
                // Nested SUB: already reported by the parser; check its body anyway.
                self.sub(name, body, subs);
                continue;
            }
            if let (Some(end), false) = (ended, warned) {
                warned = true;
                self.warning(
                    s.span,
                    format!("this code never runs: END at {} ends the program", end.at()),
                );
            }
            if is_end(s) {
                ended = ended.or(Some(s.span));
            }
            self.stmt(s, &mut out, subs);
        }
        out
    }

    fn stmt(&mut self, s: &Stmt, out: &mut Vec<TStmt>, subs: &mut Vec<TSub>) {
        let before = out.len();
        self.stmt_inner(s, out, subs);
        if out.len() == before && !matches!(s.kind, StmtKind::Sub { .. }) {
            self.dropped = true;
        }
    }

    fn stmt_inner(&mut self, s: &Stmt, out: &mut Vec<TStmt>, subs: &mut Vec<TSub>) {
        match &s.kind {
            StmtKind::Assign { target, value } => {
                let te = self.expr(value);
                let slot = self.var_slot(target);
                self.mark_assigned(slot);
                let Some(te) = te else {
                    self.vars[slot as usize].broken = true;
                    return;
                };
                let v = &self.vars[slot as usize];
                if let Some(ty) = v.ty {
                    if ty != te.ty {
                        let msg = format!(
                            "{} holds {} (since {}); it cannot be assigned {}",
                            target.text,
                            article(ty),
                            v.ty_span.at(),
                            article(te.ty)
                        );
                        self.error(te.span, msg);
                        self.vars[slot as usize].broken = true;
                        return;
                    }
                }
                out.push(TStmt::Store {
                    slot,
                    value: te,
                    span: s.span,
                });
            }
            StmtKind::Command { def, args } => {
                if let Some(t) = self.command(def, args, s.span) {
                    out.push(t);
                }
            }
            StmtKind::If { arms, else_block } => {
                let mut tarms = Vec::with_capacity(arms.len());
                let mut ok = true;
                for (i, (cond, body)) in arms.iter().enumerate() {
                    let word = if i == 0 { "IF" } else { "ELSEIF" };
                    let c = self.condition(cond, word);
                    let b = self.block(body, subs);
                    match c {
                        Some(c) => tarms.push((c, b)),
                        None => ok = false,
                    }
                }
                let e = self.block(else_block, subs);
                if ok {
                    out.push(TStmt::If {
                        arms: tarms,
                        else_block: e,
                    });
                }
            }
            StmtKind::While { cond, body } => {
                let c = self.condition(cond, "WHILE");
                let b = self.block(body, subs);
                if let Some(cond) = c {
                    out.push(TStmt::While { cond, body: b });
                }
            }
            StmtKind::For {
                var,
                from,
                to,
                step,
                body,
                next,
            } => {
                let slot = self.var_slot(var);
                let from_t = self.number(from, "FOR's first value");
                self.mark_assigned(slot);
                let to_t = self.number(to, "FOR's last value");
                let step_t = step.as_ref().map(|e| self.number(e, "STEP"));
                let v = &self.vars[slot as usize];
                let mut ok = true;
                if v.ty != Some(Ty::Number) {
                    let msg = format!(
                        "{} holds {} (since {}); a FOR loop counts with a number",
                        var.text,
                        v.ty.map_or("another type", article),
                        v.ty_span.at()
                    );
                    self.error(var.span, msg);
                    ok = false;
                }
                if let Some(Some(st)) = &step_t {
                    if st.konst == Some(Value::Num(0.0)) {
                        self.error(st.span, "STEP 0 never ends the loop");
                        ok = false;
                    }
                }
                if let (Some(f), Some(t)) = (&from_t, &to_t) {
                    let st = match &step_t {
                        None => Some(Value::Num(1.0)),
                        Some(Some(st)) => st.konst,
                        Some(None) => None,
                    };
                    if let (Some(Value::Num(a)), Some(Value::Num(b)), Some(Value::Num(st))) =
                        (f.konst, t.konst, st)
                    {
                        if (st > 0.0 && a > b) || (st < 0.0 && a < b) {
                            let hint = if st > 0.0 {
                                " (write STEP -1 to count down)"
                            } else {
                                ""
                            };
                            self.warning(
                                s.span,
                                format!(
                                    "this loop never runs: {} to {} with STEP {}{hint}",
                                    ProgramNum(a),
                                    ProgramNum(b),
                                    ProgramNum(st)
                                ),
                            );
                        }
                    }
                }
                let limit = self.hidden_slot(format!("{}.limit@{}", var.text, s.span.at()));
                let step_slot = self.hidden_slot(format!("{}.step@{}", var.text, s.span.at()));
                let b = self.block(body, subs);
                let step_t = match step_t {
                    None => None,
                    Some(Some(t)) => Some(t),
                    Some(None) => {
                        ok = false;
                        None
                    }
                };
                if let (true, Some(from), Some(to)) = (ok, from_t, to_t) {
                    out.push(TStmt::For {
                        var: slot,
                        limit,
                        step_slot,
                        from,
                        to,
                        step: step_t,
                        body: b,
                        span: s.span,
                        next: *next,
                    });
                }
            }
            StmtKind::Sub { name, body } => self.sub(name, body, subs),
        }
    }

    fn mark_assigned(&mut self, slot: u32) {
        if !self.in_sub {
            if let Some(a) = self.assigned.get_mut(slot as usize) {
                *a = true;
            }
        }
    }

    fn condition(&mut self, e: &Expr, word: &str) -> Option<TExpr> {
        let t = self.expr(e)?;
        if t.ty != Ty::Bool {
            let msg = format!(
                "{word} needs a condition that is TRUE or FALSE (a comparison like X > 0), got {}",
                article(t.ty)
            );
            self.error(t.span, msg);
            return None;
        }
        Some(t)
    }

    fn number(&mut self, e: &Expr, what: &str) -> Option<TExpr> {
        let t = self.expr(e)?;
        if t.ty != Ty::Number {
            let msg = format!("{what} must be a number, got {}", article(t.ty));
            self.error(t.span, msg);
            return None;
        }
        Some(t)
    }

    fn command(&mut self, def: &'static StatementDef, args: &[Arg], span: Span) -> Option<TStmt> {
        let posture = args.iter().find_map(|a| match a {
            Arg::Posture(p) => Some(*p),
            _ => None,
        });
        let mut out = Vec::with_capacity(args.len());
        let mut ok = true;
        for (spec, arg) in def.args.iter().zip(args) {
            let t = match (spec, arg) {
                (ArgSpec::Value { ty, check }, Arg::Value(e)) => self
                    .typed_arg(def, e, *ty, *check, posture.flatten())
                    .map(TArg::Value),
                (ArgSpec::Posture, Arg::Posture(p)) => Some(TArg::Posture(*p)),
                (ArgSpec::Blade, Arg::Blade(b)) => Some(TArg::Blade(*b)),
                (ArgSpec::Axis, Arg::Axis(a)) => self.axis(a).map(TArg::Axis),
                (ArgSpec::Items, Arg::Items(items)) => {
                    if items.len() > usize::from(u8::MAX) {
                        self.error(span, "PRINT takes at most 255 items");
                        None
                    } else {
                        let mut t = Vec::with_capacity(items.len());
                        for e in items {
                            if let Some(x) = self.expr(e) {
                                t.push(x);
                            }
                        }
                        (t.len() == items.len()).then_some(TArg::Items(t))
                    }
                }
                (ArgSpec::Sub, Arg::Sub(name)) => match self.sub_index.get(&name.key) {
                    Some(&i) => {
                        if !self.quiet {
                            self.subs[i as usize].called = true;
                        }
                        Some(TArg::Sub(i))
                    }
                    None => {
                        let known: Vec<_> = self.subs.iter().map(|s| s.name.text.clone()).collect();
                        let msg = if known.is_empty() {
                            format!(
                                "unknown SUB {}: the program defines no SUBs (SUB {} … ENDSUB)",
                                name.text, name.text
                            )
                        } else {
                            format!(
                                "unknown SUB {}; the SUBs are {}",
                                name.text,
                                known.join(", ")
                            )
                        };
                        self.error(name.span, msg);
                        None
                    }
                },
                (ArgSpec::Input, Arg::Input { n, value }) => {
                    let n =
                        self.typed_arg(def, n, ArgTy::Is(Ty::Number), ConstCheck::OutputBit, None);
                    let v = self.typed_arg(def, value, ArgTy::Level, ConstCheck::None, None);
                    match (n, v) {
                        (Some(n), Some(value)) => Some(TArg::Input { n, value }),
                        _ => None,
                    }
                }
                (ArgSpec::Keyword { ty, check, .. }, Arg::Keyword(e)) => match e {
                    None => Some(TArg::Keyword(None)),
                    Some(e) => self
                        .typed_arg(def, e, *ty, *check, None)
                        .map(|t| TArg::Keyword(Some(t))),
                },
                _ => None,
            };
            match t {
                Some(t) => out.push(t),
                None => ok = false,
            }
        }
        (ok && out.len() == def.args.len()).then_some(TStmt::Command {
            op: def.op,
            args: out,
            span,
        })
    }

    fn axis(&mut self, a: &AxisRef) -> Option<u8> {
        let n = self.robot.axis_count();
        let names: Vec<_> = self
            .robot
            .axes()
            .iter()
            .map(|a| a.name.as_str().to_string())
            .collect();
        let (found, span, shown) = match a {
            AxisRef::Name(name) => (
                self.robot.axis_index(&name.text),
                name.span,
                name.text.clone(),
            ),
            AxisRef::Number(x, span) => {
                let ok = x.fract() == 0.0 && *x >= 1.0 && *x <= n as f64;
                (
                    ok.then(|| *x as usize - 1),
                    *span,
                    ProgramNum(*x).to_string(),
                )
            }
        };
        match found {
            Some(i) => u8::try_from(i).ok(),
            None => {
                let msg = format!(
                    "axis {shown} does not exist; this robot's axes are {} (or 1 to {n})",
                    names.join(", ")
                );
                self.error(span, msg);
                None
            }
        }
    }

    /// An argument of a required type, checked against the robot when constant.
    fn typed_arg(
        &mut self,
        def: &StatementDef,
        e: &Expr,
        want: ArgTy,
        check: ConstCheck,
        posture: Option<Posture>,
    ) -> Option<TExpr> {
        let t = self.expr(e)?;
        if !want.accepts(t.ty) {
            let msg = format!(
                "{} needs {} here, got {}",
                def.keyword,
                want.describe(),
                article(t.ty)
            );
            self.error(t.span, msg);
            return None;
        }
        if want == ArgTy::Level {
            if let Some(Value::Num(x)) = t.konst {
                if x != 0.0 && x != 1.0 {
                    let msg = format!(
                        "a level must be 0 or 1 (or TRUE / FALSE), got {}",
                        ProgramNum(x)
                    );
                    self.error(t.span, msg);
                    return None;
                }
            }
        }
        if check == ConstCheck::StationName {
            // Strings are not folded (their value is a string-table index), so the literal
            // itself is checked; a variable's text is checked by the VM.
            if let TKind::Str(text) = &t.kind {
                if value::station(text).is_err() {
                    let msg = format!(
                        "{:?} is not a station name; station names are 1 to {} letters, digits, '_' or '-' (like \"LP1\")",
                        text,
                        value::STATION_NAME_LEN
                    );
                    self.error(t.span, msg);
                    return None;
                }
            }
        }
        let Some(k) = t.konst else { return Some(t) };
        let problem = match (check, k) {
            (
                ConstCheck::Range {
                    min,
                    max,
                    what,
                    unit,
                },
                Value::Num(x),
            ) if !(min..=max).contains(&x) => Some(format!(
                "{what} {} is out of range; {what} takes {} to {}{unit}",
                ProgramNum(x),
                ProgramNum(min),
                ProgramNum(max)
            )),
            (ConstCheck::OutputBit, Value::Num(x)) if value::bit(Value::Num(x)).is_err() => {
                let what = if def.keyword == "WAIT" {
                    "input"
                } else {
                    "output"
                };
                Some(format!(
                    "{what} {} does not exist; {what}s are 0 to 31",
                    ProgramNum(x)
                ))
            }
            (ConstCheck::WholeNumber, Value::Num(x)) if value::pulses(Value::Num(x)).is_err() => {
                Some(format!(
                    "{} takes a whole number of pulses (at most 1e15), got {}",
                    def.keyword,
                    ProgramNum(x)
                ))
            }
            (ConstCheck::Slot, Value::Num(x)) if value::slot(Value::Num(x)).is_err() => {
                Some(format!(
                    "slot {} does not exist; {} takes a whole slot number from 1 to {}",
                    ProgramNum(x),
                    def.keyword,
                    value::MAX_SLOT
                ))
            }
            (ConstCheck::Seconds, Value::Num(x)) if x < 0.0 => Some(format!(
                "a time must be 0 or more seconds, got {}",
                ProgramNum(x)
            )),
            (ConstCheck::JointLimits, Value::Joints(j)) => self
                .robot
                .check_joints(&j)
                .err()
                .map(|e| format!("joint target out of limits: {e}")),
            (ConstCheck::Reachable, Value::Pose(p)) => self
                .unreachable(&p, posture)
                .map(|e| format!("unreachable pose: {e}")),
            _ => None,
        };
        if let Some(msg) = problem {
            self.error(t.span, msg);
            return None;
        }
        Some(t)
    }

    /// Why the arm cannot reach `pose` with `posture` (or with either posture).
    fn unreachable(&self, pose: &Pose, posture: Option<Posture>) -> Option<String> {
        let tries: &[Posture] = match posture {
            Some(Posture::Left) => &[Posture::Left],
            Some(Posture::Right) => &[Posture::Right],
            None => &[Posture::Right, Posture::Left],
        };
        let mut first = None;
        for &p in tries {
            match self.robot.inverse(pose, p, None) {
                Ok(_) => return None,
                Err(e) => {
                    first.get_or_insert(e);
                }
            }
        }
        first.map(|e| {
            let suffix = match posture {
                Some(p) => format!(" (posture {})", p.letter()),
                None => String::new(),
            };
            format!("{e}{suffix}")
        })
    }

    /// Type-check an expression; `None` after an error (reported once) or an unknown type.
    fn expr(&mut self, e: &Expr) -> Option<TExpr> {
        let span = e.span;
        let mk = |kind, ty, konst| {
            Some(TExpr {
                kind,
                ty,
                span,
                konst,
            })
        };
        match &e.kind {
            ExprKind::Error => None,
            ExprKind::Num(x) => mk(TKind::Num(*x), Ty::Number, Some(Value::Num(*x))),
            ExprKind::Bool(b) => mk(TKind::Bool(*b), Ty::Bool, Some(Value::Bool(*b))),
            ExprKind::Str(s) => mk(TKind::Str(s.clone()), Ty::Str, None),
            ExprKind::Var(name) => self.var(name),
            ExprKind::Unary(op, inner) => {
                let t = self.expr(inner)?;
                let ok = match op {
                    UnOp::Neg => matches!(t.ty, Ty::Number | Ty::Pose | Ty::Joints),
                    UnOp::Not => t.ty == Ty::Bool,
                };
                if !ok {
                    let msg = match op {
                        UnOp::Neg => format!("cannot negate {}", article(t.ty)),
                        UnOp::Not => format!(
                            "NOT needs TRUE or FALSE (a comparison), got {}",
                            article(t.ty)
                        ),
                    };
                    self.error(span, msg);
                    return None;
                }
                let konst = match (t.konst, op) {
                    (Some(k), UnOp::Neg) => value::negate(k).ok(),
                    (Some(k), UnOp::Not) => value::not(k).ok(),
                    _ => None,
                };
                let ty = t.ty;
                mk(TKind::Unary(*op, Box::new(t)), ty, konst)
            }
            ExprKind::Binary(op, op_span, l, r) => {
                let l = self.expr(l);
                let r = self.expr(r);
                self.binary(*op, *op_span, l?, r?, span)
            }
            ExprKind::Call(name, args) => self.call(name, args, span),
            ExprKind::Field(inner, field) => {
                let t = self.expr(inner)?;
                self.field(t, field, span)
            }
        }
    }

    fn var(&mut self, name: &Name) -> Option<TExpr> {
        let Some(&slot) = self.var_index.get(&name.key) else {
            let msg = if let Some(sub) = self.sub_index.get(&name.key) {
                let _ = sub;
                format!(
                    "{} is a SUB, not a value: run it with CALL {}",
                    name.text, name.text
                )
            } else if self.robot.axis_index(&name.text).is_some() {
                format!(
                    "unknown variable {}: it is never assigned (to read axis {} use HERE() or JOINTS fields)",
                    name.text, name.text
                )
            } else {
                format!(
                    "unknown variable {}: it is never assigned (assign it first: {} = …)",
                    name.text, name.text
                )
            };
            self.error(name.span, msg);
            return None;
        };
        let i = slot as usize;
        if !self.quiet {
            self.vars[i].read = true;
            let before = self.in_sub
                || self.vars[i].assigned_in_sub
                || self.assigned.get(i).copied().unwrap_or(true);
            if !before {
                let msg = format!(
                    "{} is used before it is assigned (first assigned at {})",
                    name.text,
                    self.vars[i].first.at()
                );
                self.error(name.span, msg);
            }
        }
        let v = &self.vars[i];
        let Some(ty) = v.ty else {
            if v.broken {
                return None; // its assignment's error is reported
            }
            let msg = format!(
                "cannot tell what {} holds: every assignment to it uses values that are not known yet; assign it a plain value first (e.g. {} = 0)",
                name.text, name.text
            );
            self.error(name.span, msg);
            return None;
        };
        let konst = if v.assigns == 1 && !v.for_var {
            v.konst
        } else {
            None
        };
        Some(TExpr {
            kind: TKind::Load(slot),
            ty,
            span: name.span,
            konst,
        })
    }

    fn binary(
        &mut self,
        op: BinOp,
        op_span: Span,
        l: TExpr,
        r: TExpr,
        span: Span,
    ) -> Option<TExpr> {
        use Ty::*;
        let ty = match op {
            BinOp::Add | BinOp::Sub => match (l.ty, r.ty) {
                (Number, Number) => Some(Number),
                (Pose, Pose) => Some(Pose),
                (Joints, Joints) => Some(Joints),
                _ => None,
            },
            BinOp::Mul | BinOp::Div => (l.ty == Number && r.ty == Number).then_some(Number),
            BinOp::Eq | BinOp::Ne => match (l.ty, r.ty) {
                (Number, Number) | (Bool, Bool) | (Str, Str) => Some(Bool),
                _ => None,
            },
            BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => {
                (l.ty == Number && r.ty == Number).then_some(Bool)
            }
            BinOp::And | BinOp::Or => (l.ty == Bool && r.ty == Bool).then_some(Bool),
        };
        let Some(ty) = ty else {
            let msg = match op {
                BinOp::Add => format!("cannot add {} and {}", article(l.ty), article(r.ty)),
                BinOp::Sub => format!("cannot subtract {} from {}", article(r.ty), article(l.ty)),
                BinOp::Mul | BinOp::Div => format!(
                    "'{}' works on numbers, got {} and {}",
                    op.symbol(),
                    article(l.ty),
                    article(r.ty)
                ),
                BinOp::And | BinOp::Or => format!(
                    "{} needs TRUE or FALSE on both sides (comparisons), got {} and {}",
                    op.symbol(),
                    article(l.ty),
                    article(r.ty)
                ),
                _ if l.ty == r.ty && matches!(l.ty, Pose | Joints) => format!(
                    "cannot compare {} with '{}': compare their fields (like P.X)",
                    if l.ty == Pose { "poses" } else { "joints" },
                    op.symbol()
                ),
                _ if l.ty == r.ty => format!(
                    "'{}' does not order {}; use = or <>",
                    op.symbol(),
                    if l.ty == Bool {
                        "TRUE/FALSE values"
                    } else {
                        "strings"
                    }
                ),
                _ => format!("cannot compare {} with {}", article(l.ty), article(r.ty)),
            };
            self.error(op_span, msg);
            return None;
        };
        // Division by a known zero is an error even when the left side is not known.
        if op == BinOp::Div && r.konst == Some(Value::Num(0.0)) {
            self.error(op_span, "division by zero");
            return None;
        }
        let mut konst = None;
        if let (Some(a), Some(b)) = (l.konst, r.konst) {
            let result = match op {
                BinOp::Add => value::arith(Arith::Add, a, b),
                BinOp::Sub => value::arith(Arith::Sub, a, b),
                BinOp::Mul => value::arith(Arith::Mul, a, b),
                BinOp::Div => value::arith(Arith::Div, a, b),
                BinOp::Eq => value::compare(Cmp::Eq, a, b),
                BinOp::Ne => value::compare(Cmp::Ne, a, b),
                BinOp::Lt => value::compare(Cmp::Lt, a, b),
                BinOp::Le => value::compare(Cmp::Le, a, b),
                BinOp::Gt => value::compare(Cmp::Gt, a, b),
                BinOp::Ge => value::compare(Cmp::Ge, a, b),
                BinOp::And => value::logic(true, a, b),
                BinOp::Or => value::logic(false, a, b),
            };
            match result {
                Ok(v) => konst = Some(v),
                Err(RuntimeErrorKind::NotFinite) => {
                    self.error(op_span, "the result is not a finite number (too large)");
                    return None;
                }
                Err(e) => {
                    self.error(op_span, e.to_string());
                    return None;
                }
            }
        }
        Some(TExpr {
            kind: TKind::Binary(op, op_span, Box::new(l), Box::new(r)),
            ty,
            span,
            konst,
        })
    }

    fn call(&mut self, name: &Name, args: &[Expr], span: Span) -> Option<TExpr> {
        let key = name.key.as_str();
        let n_axes = self.robot.axis_count();
        let (want, what): (usize, String) = match key {
            "JOINTS" => (
                n_axes,
                format!(
                    "one per axis of robot {} ({})",
                    self.robot.name,
                    self.robot
                        .axes()
                        .iter()
                        .map(|a| a.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            "POSE" => (4, "x, y, z [mm], yaw [deg]".into()),
            "HERE" => (0, "none".into()),
            "IN" => (1, "the input bit, 0 to 31".into()),
            _ => match Builtin::from_name(key) {
                Some(b) => (
                    usize::from(b.arity()),
                    if b.arity() == 1 {
                        "x".into()
                    } else {
                        "a, b".into()
                    },
                ),
                None => {
                    let msg = if self.sub_index.contains_key(key) {
                        format!(
                            "{} is a SUB, not a function: run it with CALL {}",
                            name.text, name.text
                        )
                    } else {
                        format!(
                            "unknown function {}; the built-ins are SIN, COS, ATAN2, SQRT, ABS, MIN, MAX, IN, HERE, JOINTS and POSE",
                            name.text
                        )
                    };
                    self.error(name.span, msg);
                    // Still check the arguments for their own errors.
                    for a in args {
                        self.expr(a);
                    }
                    return None;
                }
            },
        };
        let mut targs = Vec::with_capacity(args.len());
        let mut ok = true;
        for a in args {
            match self.expr(a) {
                Some(t) if t.ty == Ty::Number => targs.push(t),
                Some(t) => {
                    let msg = format!("{} takes numbers, got {}", name.key, article(t.ty));
                    self.error(t.span, msg);
                    ok = false;
                }
                None => ok = false,
            }
        }
        if args.len() != want {
            let s = if want == 1 { "" } else { "s" };
            let msg = if key == "HERE" {
                format!("HERE() takes no arguments, got {}", args.len())
            } else {
                format!(
                    "{} takes {want} value{s} ({what}), got {}",
                    name.key,
                    args.len()
                )
            };
            self.error(span, msg);
            return None;
        }
        if !ok {
            return None;
        }
        let nums: Option<Vec<f64>> = targs
            .iter()
            .map(|t| match t.konst {
                Some(Value::Num(x)) => Some(x),
                _ => None,
            })
            .collect();
        let (kind, ty, konst) = match key {
            "JOINTS" => {
                let konst = nums.map(|v| {
                    let mut j = [0.0; wrc_robot::MAX_AXES];
                    j[..v.len()].copy_from_slice(&v);
                    Value::Joints(j)
                });
                (TKind::Joints(targs), Ty::Joints, konst)
            }
            "POSE" => {
                let konst = nums.map(|v| {
                    Value::Pose(Pose {
                        x: v[0],
                        y: v[1],
                        z: v[2],
                        yaw: v[3],
                    })
                });
                (TKind::Pose(targs), Ty::Pose, konst)
            }
            "HERE" => (TKind::Here, Ty::Pose, None),
            "IN" => {
                let arg = targs.pop()?;
                if let Some(k) = arg.konst {
                    if value::bit(k).is_err() {
                        let msg = "input bits are whole numbers from 0 to 31";
                        self.error(arg.span, msg);
                        return None;
                    }
                }
                (TKind::Input(Box::new(arg)), Ty::Bool, None)
            }
            _ => {
                let b = Builtin::from_name(key)?;
                let mut konst = None;
                if let Some(v) = nums {
                    let a = v.first().copied().unwrap_or(0.0);
                    let bv = v.get(1).copied().unwrap_or(0.0);
                    match b.apply(a, bv) {
                        Ok(k) => konst = Some(k),
                        Err(e) => {
                            self.error(span, format!("{}: {e}", b.name()));
                            return None;
                        }
                    }
                }
                (TKind::Builtin(b, targs), Ty::Number, konst)
            }
        };
        Some(TExpr {
            kind,
            ty,
            span,
            konst,
        })
    }

    fn field(&mut self, t: TExpr, field: &Name, span: Span) -> Option<TExpr> {
        let key = field.key.as_str();
        let n = self.robot.axis_count();
        match t.ty {
            Ty::Pose => {
                let index = match key {
                    "X" => 0,
                    "Y" => 1,
                    "Z" => 2,
                    "YAW" => 3,
                    _ => {
                        let msg = format!("a pose has fields X, Y, Z and YAW, not {}", field.text);
                        self.error(field.span, msg);
                        return None;
                    }
                };
                let konst = t.konst.and_then(|k| value::pose_field(k, index).ok());
                Some(TExpr {
                    kind: TKind::PoseField(Box::new(t), index),
                    ty: Ty::Number,
                    span,
                    konst,
                })
            }
            Ty::Joints => {
                let index = key
                    .strip_prefix('J')
                    .and_then(|d| d.parse::<usize>().ok())
                    .filter(|&i| (1..=n).contains(&i) && !key[1..].starts_with('0'));
                let Some(i) = index else {
                    let msg = format!("joints have fields J1 to J{n}, not {}", field.text);
                    self.error(field.span, msg);
                    return None;
                };
                let index = (i - 1) as u8;
                let konst = t.konst.and_then(|k| value::joint_field(k, index).ok());
                Some(TExpr {
                    kind: TKind::JointField(Box::new(t), index),
                    ty: Ty::Number,
                    span,
                    konst,
                })
            }
            other => {
                let msg = format!(
                    "{} has no fields; fields belong to poses (P.X) and joints (J.J1)",
                    article(other)
                );
                self.error(field.span, msg);
                None
            }
        }
    }

    fn warn_unused(&mut self) {
        let mut warnings = Vec::new();
        for v in &self.vars {
            if !v.read && !v.hidden && !v.for_var && !v.broken && !v.name.starts_with('_') {
                warnings.push((
                    v.first,
                    format!(
                        "variable {} is assigned but never used (start its name with _ to keep it quiet)",
                        v.name
                    ),
                ));
            }
        }
        for s in &self.subs {
            if !s.called {
                warnings.push((s.name.span, format!("SUB {} is never called", s.name.text)));
            }
        }
        for (span, msg) in warnings {
            self.warning(span, msg);
        }
    }
}

fn is_end(s: &Stmt) -> bool {
    matches!(&s.kind, StmtKind::Command { def, .. } if def.op == CommandOp::End)
}

/// Every assignment in text order: its variable slot, value and span.
fn gather_assignments<'a>(
    stmts: &'a [Stmt],
    index: &HashMap<String, u32>,
    out: &mut Vec<(u32, &'a Expr, Span)>,
) {
    for s in stmts {
        match &s.kind {
            StmtKind::Assign { target, value } => {
                if let Some(&slot) = index.get(&target.key) {
                    out.push((slot, value, s.span));
                }
            }
            StmtKind::Command { .. } => {}
            StmtKind::If { arms, else_block } => {
                for (_, b) in arms {
                    gather_assignments(b, index, out);
                }
                gather_assignments(else_block, index, out);
            }
            StmtKind::While { body, .. }
            | StmtKind::For { body, .. }
            | StmtKind::Sub { body, .. } => gather_assignments(body, index, out),
        }
    }
}
