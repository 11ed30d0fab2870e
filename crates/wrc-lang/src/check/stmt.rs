//! Checking statements: assignments, the statement table's commands with their constant
//! checks against the robot, calls, blocks, declarations, RETURN, EXIT and RETRY.

use wrc_robot::{Pose, Posture};

use crate::ast::{
    Arg, AxisRef, CaseTest, Catch, ExitKind, Expr, LoopCond, MotionOpts, Name, RoutineKind, Stmt,
    StmtKind,
};
use crate::builtins;
use crate::statements::{ArgSpec, ArgTy, CommandOp, ConstCheck, StatementDef};
use crate::value::{self, Ty, Value};
use crate::vm::ProgramNum;

use super::symbols::Sym;
use super::{article, Checker, Enclosing, Place, TArg, TCase, TCatch, TExpr, TMotion, TStmt};
use crate::diagnostic::Span;

impl Checker<'_> {
    /// A unit's top level: its main body (into `out`) and its routines (into `bodies`).
    pub(super) fn top_level(
        &mut self,
        stmts: &[Stmt],
        out: &mut Vec<TStmt>,
        bodies: &mut [Option<Vec<TStmt>>],
    ) {
        let mut ended: Option<Span> = None;
        let mut warned = false;
        for s in stmts {
            match &s.kind {
                StmtKind::Routine { name, body, .. } => {
                    if let Some(r) = self.routine_named(&name.key) {
                        if self.routines[r as usize].name.span == name.span {
                            let b = self.routine_body(r, body);
                            bodies[r as usize] = Some(b);
                        }
                    }
                    continue;
                }
                StmtKind::Include { .. } | StmtKind::Dim { .. } => continue,
                _ => {}
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
            self.stmt(s, out);
        }
    }

    fn routine_body(&mut self, r: u32, body: &[Stmt]) -> Vec<TStmt> {
        let saved = std::mem::take(&mut self.ctx.blocks);
        let was = self.ctx.routine;
        self.ctx.routine = Some(r);
        let out = self.block(body);
        self.ctx.routine = was;
        self.ctx.blocks = saved;
        let routine = &self.routines[r as usize];
        if routine.kind == RoutineKind::Function && !routine.returns {
            let (span, text) = (routine.name.span, routine.name.text.clone());
            self.error(
                span,
                format!("FUNCTION {text} never returns a value: end it with RETURN value"),
            );
        }
        out
    }

    pub(super) fn block(&mut self, stmts: &[Stmt]) -> Vec<TStmt> {
        let mut out = Vec::with_capacity(stmts.len());
        let mut ended: Option<(Span, &'static str)> = None;
        let mut warned = false;
        for s in stmts {
            if let StmtKind::Routine { name, body, .. } = &s.kind {
                // Nested: reported by the parser; its body is checked all the same.
                if let Some(r) = self.routine_named(&name.key) {
                    if self.routines[r as usize].name.span == name.span {
                        let ctx = self.ctx.clone();
                        self.routine_body(r, body);
                        self.ctx = ctx;
                    }
                }
                continue;
            }
            if let (Some((end, word)), false) = (ended, warned) {
                warned = true;
                let msg = if word == "END" {
                    format!("this code never runs: END at {} ends the program", end.at())
                } else {
                    format!(
                        "this code never runs: {word} at {} leaves the block",
                        end.at()
                    )
                };
                self.warning(s.span, msg);
            }
            if let Some(word) = leaves_block(s) {
                ended = ended.or(Some((s.span, word)));
            }
            self.stmt(s, &mut out);
        }
        out
    }

    fn nested(&mut self, enclosing: Enclosing, stmts: &[Stmt]) -> Vec<TStmt> {
        self.ctx.blocks.push(enclosing);
        let out = self.block(stmts);
        self.ctx.blocks.pop();
        out
    }

    fn stmt(&mut self, s: &Stmt, out: &mut Vec<TStmt>) {
        let before = out.len();
        let silent = matches!(
            s.kind,
            StmtKind::Routine { .. }
                | StmtKind::Include { .. }
                | StmtKind::Dim { .. }
                | StmtKind::Local { init: None, .. }
        );
        self.stmt_inner(s, out);
        if out.len() == before && !silent {
            self.dropped = true;
        }
    }

    fn mark_assigned(&mut self, g: u32) {
        if self.in_main() {
            if let Some(a) = self.assigned.get_mut(g as usize) {
                *a = true;
            }
        }
    }

    fn stmt_inner(&mut self, s: &Stmt, out: &mut Vec<TStmt>) {
        match &s.kind {
            StmtKind::Assign {
                target,
                index,
                value,
            } => self.assign(s.span, target, index, value, out),
            StmtKind::Command { def, args } => {
                if let Some(t) = self.command(def, args, s.span) {
                    out.push(t);
                }
            }
            StmtKind::Call { name, args } => self.call_stmt(s.span, name, args, out),
            StmtKind::CallProgram { name, .. } => {
                match self.unit_names.iter().position(|u| u == name) {
                    Some(u) if u > 0 => {
                        if let Some(r) = self.unit_main[u] {
                            out.push(TStmt::Call {
                                routine: r,
                                args: Vec::new(),
                                discard: false,
                                span: s.span,
                            });
                        }
                    }
                    // Itself (a loop) or not loaded: the loader reported why.
                    Some(_) | None => {}
                }
            }
            StmtKind::If { arms, else_block } => {
                let mut tarms = Vec::with_capacity(arms.len());
                let mut ok = true;
                for (i, (cond, body)) in arms.iter().enumerate() {
                    let word = if i == 0 { "IF" } else { "ELSEIF" };
                    let c = self.condition(cond, word);
                    let b = self.block(body);
                    match c {
                        Some(c) => tarms.push((c, b)),
                        None => ok = false,
                    }
                }
                let e = self.block(else_block);
                if ok {
                    out.push(TStmt::If {
                        arms: tarms,
                        else_block: e,
                    });
                }
            }
            StmtKind::While { cond, body } => {
                let c = self.condition(cond, "WHILE");
                let b = self.nested(Enclosing::Loop(ExitKind::While), body);
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
                ..
            } => self.for_stmt(s.span, var, from, to, step.as_deref(), body, out),
            StmtKind::Do {
                pre,
                post,
                body,
                end,
            } => {
                let mut ok = true;
                let mut cond = |c: &Option<LoopCond>, this: &mut Self| match c {
                    None => None,
                    Some(c) => {
                        let word = if c.until { "UNTIL" } else { "WHILE" };
                        match this.condition(&c.cond, word) {
                            Some(t) => Some((c.until, t)),
                            None => {
                                ok = false;
                                None
                            }
                        }
                    }
                };
                let pre_t = cond(pre, self);
                let b = self.nested(Enclosing::Loop(ExitKind::Do), body);
                let post_t = cond(post, self);
                if ok {
                    out.push(TStmt::Do {
                        pre: pre_t.map(|(u, c)| (u, Box::new(c))),
                        post: post_t.map(|(u, c)| (u, Box::new(c))),
                        body: b,
                        span: *end,
                    });
                }
            }
            StmtKind::Select {
                subject,
                cases,
                else_block,
            } => self.select(s.span, subject, cases, else_block.as_deref(), out),
            StmtKind::Try { body, catches } => self.try_stmt(s.span, body, catches, out),
            StmtKind::Routine { .. } | StmtKind::Include { .. } => {}
            StmtKind::Dim { name, .. } => {
                if self.in_main() && !self.is_top_level_dim(name) {
                    self.error(
                        s.span,
                        format!(
                            "DIM {} belongs at the top level of the program (or in a SUB or FUNCTION)",
                            name.text
                        ),
                    );
                }
            }
            StmtKind::Local { name, init, .. } => {
                if self.ctx.routine.is_none() || self.in_main() {
                    self.error(
                        s.span,
                        "LOCAL is for SUBs and FUNCTIONs; at the top level every variable is global",
                    );
                    return;
                }
                let Some(value) = init else { return };
                let Some(Sym::Local(r, i)) = self.lookup(name) else {
                    return;
                };
                let Some(te) = self.expr(value) else { return };
                let l = &self.routines[r as usize].locals[i];
                let (ty, slot) = (l.ty.unwrap_or(te.ty), l.slot);
                if ty != te.ty {
                    let msg = format!(
                        "LOCAL {} is {}; it cannot start as {}",
                        name.text,
                        article(ty),
                        article(te.ty)
                    );
                    self.error(te.span, msg);
                    return;
                }
                out.push(TStmt::Store {
                    place: Place::Local(slot),
                    value: te,
                    span: s.span,
                });
            }
            StmtKind::Return(value) => self.return_stmt(s.span, value.as_ref(), out),
            StmtKind::Exit(kind) => {
                let ok = match kind {
                    ExitKind::For | ExitKind::While | ExitKind::Do => {
                        self.ctx.blocks.contains(&Enclosing::Loop(*kind))
                    }
                    ExitKind::Sub | ExitKind::Function => {
                        let want = if *kind == ExitKind::Sub {
                            RoutineKind::Sub
                        } else {
                            RoutineKind::Function
                        };
                        self.ctx.routine.is_some_and(|r| {
                            let r = &self.routines[r as usize];
                            r.kind == want && !r.program
                        })
                    }
                };
                if !ok {
                    let msg = match kind {
                        ExitKind::Function => {
                            "EXIT FUNCTION outside a FUNCTION (a FUNCTION ends with RETURN value)"
                                .to_string()
                        }
                        _ => format!("EXIT {0} outside a {0} (END ends the program)", kind.word()),
                    };
                    self.error(s.span, msg);
                    return;
                }
                if *kind == ExitKind::Function {
                    self.error(
                        s.span,
                        "a FUNCTION must return a value: write RETURN value instead of EXIT FUNCTION",
                    );
                    return;
                }
                out.push(TStmt::Exit {
                    kind: *kind,
                    span: s.span,
                });
            }
            StmtKind::Retry => {
                if !self.ctx.blocks.contains(&Enclosing::Catch) {
                    self.error(
                        s.span,
                        "RETRY outside a CATCH block: it runs the failed statement of a TRY again",
                    );
                    return;
                }
                out.push(TStmt::Retry { span: s.span });
            }
        }
    }

    /// Whether `name` is a DIM of the main body's top level (declared in the first pass).
    fn is_top_level_dim(&self, name: &Name) -> bool {
        self.global_index
            .get(self.ctx.unit, &name.key)
            .is_some_and(|&g| self.globals[g as usize].first == name.span)
    }

    fn assign(
        &mut self,
        span: Span,
        target: &Name,
        index: &[Expr],
        value: &Expr,
        out: &mut Vec<TStmt>,
    ) {
        let te = self.expr(value);
        if !index.is_empty() {
            let elem = self.element(target, index, true);
            let (Some((elem, ty)), Some(te)) = (elem, te) else {
                return;
            };
            if ty != te.ty {
                let msg = format!(
                    "{} holds {}s; an element cannot be assigned {}",
                    target.text,
                    ty.name(),
                    article(te.ty)
                );
                self.error(te.span, msg);
                return;
            }
            out.push(TStmt::StoreElem {
                elem,
                value: te,
                span,
            });
            return;
        }
        match self.lookup(target) {
            Some(Sym::Local(r, i)) => {
                let l = &self.routines[r as usize].locals[i];
                let (ty, slot, dims, first) = (l.ty, l.slot, l.dims, l.span);
                let Some(te) = te else { return };
                if dims.is_array() {
                    let msg = format!(
                        "{} is an array; assign one element, {}[i] = …",
                        target.text, target.text
                    );
                    self.error(target.span, msg);
                    return;
                }
                if let Some(ty) = ty {
                    if ty != te.ty {
                        let msg = self.type_clash(target, ty, first, te.ty);
                        self.error(te.span, msg);
                        return;
                    }
                }
                out.push(TStmt::Store {
                    place: Place::Local(slot),
                    value: te,
                    span,
                });
            }
            Some(Sym::Global(g)) => {
                self.mark_assigned(g);
                let v = &self.globals[g as usize];
                if v.point {
                    let msg = format!(
                        "{} is a named point (the program's points file); TEACH {} stores where the robot is, or edit it in the points file",
                        target.text, target.text
                    );
                    self.error(target.span, msg);
                    return;
                }
                if v.dims.is_array() {
                    let msg = format!(
                        "{} is an array; assign one element, {}[i] = …",
                        target.text, target.text
                    );
                    self.error(target.span, msg);
                    return;
                }
                let Some(te) = te else {
                    self.globals[g as usize].broken = true;
                    return;
                };
                let v = &self.globals[g as usize];
                if let Some(ty) = v.ty {
                    if ty != te.ty {
                        let msg = self.type_clash(target, ty, v.ty_span, te.ty);
                        self.error(te.span, msg);
                        self.globals[g as usize].broken = true;
                        return;
                    }
                }
                if target.text.ends_with('$') && te.ty != Ty::Str {
                    let msg = format!(
                        "{} ends in $, so it holds a string; it cannot be assigned {}",
                        target.text,
                        article(te.ty)
                    );
                    self.error(te.span, msg);
                    return;
                }
                out.push(TStmt::Store {
                    place: Place::Global(g),
                    value: te,
                    span,
                });
            }
            None => {
                // Only globals are made on first sight, in the collect pass.
                self.unknown_target(target);
            }
        }
    }

    fn unknown_target(&mut self, target: &Name) {
        let msg = format!("{} cannot be assigned here", target.text);
        self.error(target.span, msg);
    }

    fn call_stmt(&mut self, span: Span, name: &Name, args: &[Expr], out: &mut Vec<TStmt>) {
        match self.routine_named(&name.key) {
            Some(r) => {
                let discard = self.routines[r as usize].kind == RoutineKind::Function;
                if let Some(args) = self.routine_args(r, name, args, span) {
                    out.push(TStmt::Call {
                        routine: r,
                        args,
                        discard,
                        span,
                    });
                }
            }
            None => {
                let known: Vec<String> = self
                    .routines
                    .iter()
                    .filter(|r| r.unit == self.ctx.unit && !r.program)
                    .map(|r| r.name.text.clone())
                    .collect();
                let msg = if builtins::find(&name.key).is_some() {
                    format!(
                        "{} is a built-in function, not a SUB: use its value, X = {}(…)",
                        name.text, name.text
                    )
                } else if known.is_empty() {
                    format!(
                        "unknown SUB {}: the program defines no SUBs (SUB {} … ENDSUB)",
                        name.text, name.text
                    )
                } else {
                    format!(
                        "unknown SUB {}; the SUBs and FUNCTIONs are {}",
                        name.text,
                        known.join(", ")
                    )
                };
                self.error(name.span, msg);
                for a in args {
                    self.expr(a);
                }
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn for_stmt(
        &mut self,
        span: Span,
        var: &Name,
        from: &Expr,
        to: &Expr,
        step: Option<&Expr>,
        body: &[Stmt],
        out: &mut Vec<TStmt>,
    ) {
        let from_t = self.number(from, "FOR's first value");
        let place = match self.lookup(var) {
            Some(Sym::Local(r, i)) => {
                let l = &self.routines[r as usize].locals[i];
                if l.ty != Some(Ty::Number) || l.dims.is_array() {
                    let msg = format!(
                        "{} holds {} (since {}); a FOR loop counts with a number",
                        var.text,
                        l.ty.map_or("another type", article),
                        l.span.at()
                    );
                    self.error(var.span, msg);
                    return;
                }
                let slot = l.slot;
                self.routines[r as usize].locals[i].read = true;
                Place::Local(slot)
            }
            Some(Sym::Global(g)) => {
                self.mark_assigned(g);
                let v = &self.globals[g as usize];
                if v.ty != Some(Ty::Number) || v.dims.is_array() || v.point {
                    let msg = format!(
                        "{} holds {} (since {}); a FOR loop counts with a number",
                        var.text,
                        v.ty.map_or("another type", article),
                        v.ty_span.at()
                    );
                    self.error(var.span, msg);
                    return;
                }
                Place::Global(g)
            }
            None => {
                self.unknown_target(var);
                return;
            }
        };
        let to_t = self.number(to, "FOR's last value");
        let step_t = step.map(|e| self.number(e, "STEP"));
        let mut ok = true;
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
                        span,
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
        let limit = self.hidden_slot(format!("{}.limit@{}", var.text, span.at()), Ty::Number);
        let step_slot = self.hidden_slot(format!("{}.step@{}", var.text, span.at()), Ty::Number);
        let b = self.nested(Enclosing::Loop(ExitKind::For), body);
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
                var: place,
                limit,
                step_slot,
                from: Box::new(from),
                to: Box::new(to),
                step: step_t.map(Box::new),
                body: b,
                span,
            });
        }
    }

    fn select(
        &mut self,
        span: Span,
        subject: &Expr,
        cases: &[(Vec<CaseTest>, Vec<Stmt>, Span)],
        else_block: Option<&[Stmt]>,
        out: &mut Vec<TStmt>,
    ) {
        let subj = self.expr(subject);
        if let Some(t) = &subj {
            if !matches!(t.ty, Ty::Number | Ty::Str) {
                let msg = format!(
                    "SELECT CASE tests a number or a string, got {}",
                    article(t.ty)
                );
                self.error(t.span, msg);
            }
        }
        let ty = subj
            .as_ref()
            .map(|t| t.ty)
            .filter(|ty| matches!(ty, Ty::Number | Ty::Str));
        let mut tcases = Vec::with_capacity(cases.len());
        let mut ok = subj
            .as_ref()
            .is_some_and(|t| matches!(t.ty, Ty::Number | Ty::Str));
        for (tests, body, _) in cases {
            let mut ttests = Vec::with_capacity(tests.len());
            for test in tests {
                match test {
                    CaseTest::Is(e) => match (self.expr(e), ty) {
                        (Some(t), Some(want)) if t.ty == want => ttests.push(TCase::Is(t)),
                        (Some(t), Some(want)) => {
                            let msg = format!(
                                "CASE compares with {}, got {}",
                                article(want),
                                article(t.ty)
                            );
                            self.error(t.span, msg);
                            ok = false;
                        }
                        _ => ok = false,
                    },
                    CaseTest::Cmp(op, e) => match (self.expr(e), ty) {
                        (Some(t), Some(want))
                            if t.ty == want
                                && (want == Ty::Number
                                    || matches!(
                                        op,
                                        crate::ast::BinOp::Eq | crate::ast::BinOp::Ne
                                    )) =>
                        {
                            ttests.push(TCase::Cmp(*op, t))
                        }
                        (Some(t), Some(want)) if t.ty == want => {
                            let msg = format!(
                                "CASE IS {} compares numbers; strings compare with CASE IS = or CASE IS <>",
                                op.symbol()
                            );
                            self.error(t.span, msg);
                            ok = false;
                        }
                        (Some(t), Some(want)) => {
                            let msg = format!(
                                "CASE IS compares with {}, got {}",
                                article(want),
                                article(t.ty)
                            );
                            self.error(t.span, msg);
                            ok = false;
                        }
                        _ => ok = false,
                    },
                    CaseTest::Range(lo, hi) => {
                        let lo = self.number(lo, "a CASE range's first value");
                        let hi = self.number(hi, "a CASE range's last value");
                        if ty != Some(Ty::Number) {
                            if let Some(t) = &lo {
                                self.error(t.span, "a CASE range (lo TO hi) tests numbers");
                            }
                            ok = false;
                        }
                        match (lo, hi) {
                            (Some(lo), Some(hi)) => ttests.push(TCase::Range(lo, hi)),
                            _ => ok = false,
                        }
                    }
                }
            }
            let b = self.block(body);
            tcases.push((ttests, b));
        }
        let e = else_block.map(|b| self.block(b)).unwrap_or_default();
        let (Some(subject), true) = (subj, ok) else {
            return;
        };
        let slot = self.hidden_slot(format!("select@{}", span.at()), subject.ty);
        out.push(TStmt::Select {
            slot,
            subject,
            cases: tcases,
            else_block: e,
            span,
        });
    }

    fn try_stmt(&mut self, span: Span, body: &[Stmt], catches: &[Catch], out: &mut Vec<TStmt>) {
        let b = self.nested(Enclosing::TryBody, body);
        let mut tcatches = Vec::with_capacity(catches.len());
        let mut ok = true;
        let mut seen: Vec<(u16, Span)> = Vec::new();
        for c in catches {
            let mut codes = Vec::with_capacity(c.codes.len());
            for e in &c.codes {
                let Some(t) = self.expr(e) else {
                    ok = false;
                    continue;
                };
                match t.konst {
                    Some(v @ Value::Num(_)) if value::error_code(v).is_ok() => {
                        let code = value::error_code(v).unwrap_or(0);
                        if let Some((_, at)) = seen.iter().find(|(c, _)| *c == code) {
                            let msg = format!(
                                "code {code} is caught already by the CATCH at {}",
                                at.at()
                            );
                            self.warning(t.span, msg);
                        }
                        seen.push((code, c.span));
                        codes.push(code);
                    }
                    _ => {
                        self.error(
                            t.span,
                            "a CATCH code is a constant whole number from 1 to 65535 (docs/protocol.md lists the controller's; RAISE makes your own)",
                        );
                        ok = false;
                    }
                }
            }
            let body = self.nested(Enclosing::Catch, &c.body);
            tcatches.push(TCatch {
                codes,
                body,
                span: c.span,
            });
        }
        if ok && !tcatches.is_empty() {
            out.push(TStmt::Try {
                body: b,
                catches: tcatches,
                span,
            });
        }
    }

    fn return_stmt(&mut self, span: Span, value: Option<&Expr>, out: &mut Vec<TStmt>) {
        let routine = self
            .ctx
            .routine
            .filter(|&r| !self.routines[r as usize].program);
        let Some(r) = routine else {
            self.error(
                span,
                "RETURN is for SUBs and FUNCTIONs; END ends the program",
            );
            if let Some(v) = value {
                self.expr(v);
            }
            return;
        };
        let (kind, ret, name) = {
            let routine = &self.routines[r as usize];
            (routine.kind, routine.ret, routine.name.text.clone())
        };
        match (kind, value) {
            (RoutineKind::Sub, None) => out.push(TStmt::Return { value: None, span }),
            (RoutineKind::Sub, Some(v)) => {
                self.error(
                    v.span,
                    format!("SUB {name} returns no value; make it a FUNCTION to return one"),
                );
            }
            (RoutineKind::Function, None) => {
                self.error(
                    span,
                    format!("FUNCTION {name} must return a value: RETURN value"),
                );
            }
            (RoutineKind::Function, Some(v)) => {
                self.routines[r as usize].returns = true;
                let Some(t) = self.expr(v) else { return };
                let want = ret.unwrap_or(Ty::Number);
                if t.ty != want {
                    let msg = format!(
                        "FUNCTION {name} returns {}, got {}",
                        article(want),
                        article(t.ty)
                    );
                    self.error(t.span, msg);
                    return;
                }
                out.push(TStmt::Return {
                    value: Some(t),
                    span,
                });
            }
        }
    }

    pub(super) fn condition(&mut self, e: &Expr, word: &str) -> Option<TExpr> {
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
                (ArgSpec::OptValue { ty, check }, Arg::OptValue(e)) => match e {
                    None => Some(TArg::OptValue(None)),
                    Some(e) => self
                        .typed_arg(def, e, *ty, *check, None)
                        .map(|t| TArg::OptValue(Some(t))),
                },
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
                (ArgSpec::Target, Arg::Target(name)) => self.teach_target(name),
                (ArgSpec::Input, Arg::Input { n, value }) => {
                    let n =
                        self.typed_arg(def, n, ArgTy::Is(Ty::Number), ConstCheck::OutputBit, None);
                    let v = self.typed_arg(def, value, ArgTy::Level, ConstCheck::None, None);
                    match (n, v) {
                        (Some(n), Some(value)) => Some(TArg::Input(Box::new((n, value)))),
                        _ => None,
                    }
                }
                (ArgSpec::Keyword { ty, check, .. }, Arg::Keyword(e)) => match e {
                    None => Some(TArg::Keyword(None)),
                    Some(e) => self
                        .typed_arg(def, e, *ty, *check, None)
                        .map(|t| TArg::Keyword(Some(t))),
                },
                (ArgSpec::Motion { .. }, Arg::Motion(m)) => {
                    self.motion(def, m).map(|m| TArg::Motion(Box::new(m)))
                }
                _ => None,
            };
            match t {
                Some(t) => out.push(t),
                None => ok = false,
            }
        }
        if ok && matches!(def.op, CommandOp::Appro | CommandOp::Appros) {
            ok = self.approach_reachable(&out, posture.flatten());
        }
        (ok && out.len() == def.args.len()).then_some(TStmt::Command {
            op: def.op,
            args: out,
            span,
        })
    }

    /// APPRO/APPROS with a constant pose and distance: the approach point must be reachable.
    fn approach_reachable(&mut self, args: &[TArg], posture: Option<Posture>) -> bool {
        let (Some(TArg::Value(p)), Some(TArg::Value(d))) = (args.first(), args.get(1)) else {
            return true;
        };
        let (Some(Value::Pose(pose)), Some(Value::Num(dist))) = (p.konst, d.konst) else {
            return true;
        };
        let target = builtins::reltool(&pose, -dist, 0.0, 0.0, 0.0);
        if let Some(e) = self.unreachable(&target, posture) {
            let span = p.span.to(d.span);
            self.error(
                span,
                format!(
                    "unreachable approach: {} mm back along the hand from the pose is x={:.3} y={:.3}: {e}",
                    ProgramNum(dist),
                    target.x,
                    target.y
                ),
            );
            return false;
        }
        true
    }

    fn teach_target(&mut self, name: &Name) -> Option<TArg> {
        match self.lookup(name) {
            Some(Sym::Global(g)) if self.globals[g as usize].point => {
                self.globals[g as usize].read = true;
                Some(TArg::Target(g))
            }
            Some(Sym::Global(_)) => {
                let msg = format!(
                    "{} is a variable of the program, not a named point; TEACH stores points of the points file (choose a name the program does not assign)",
                    name.text
                );
                self.error(name.span, msg);
                None
            }
            Some(Sym::Local(..)) => {
                let msg = format!(
                    "{} is a local variable; TEACH stores named points of the program's points file",
                    name.text
                );
                self.error(name.span, msg);
                None
            }
            None => None,
        }
    }

    fn motion(&mut self, def: &StatementDef, m: &MotionOpts) -> Option<TMotion> {
        let mut ok = true;
        let mut pct = |e: &Option<Expr>, what: &'static str, this: &mut Self| -> Option<TExpr> {
            let e = e.as_ref()?;
            let t = this.typed_arg(
                def,
                e,
                ArgTy::Is(Ty::Number),
                ConstCheck::Range {
                    min: 1.0,
                    max: 100.0,
                    what,
                    unit: " [%]",
                },
                None,
            );
            if t.is_none() {
                ok = false;
            }
            t
        };
        let speed = pct(&m.speed, "SPEED", self);
        let accel = pct(&m.accel, "ACCEL", self);
        let blend = match &m.blend {
            None => None,
            Some((_, None)) => Some(None),
            Some((_, Some(e))) => {
                let t = self.expr(e);
                match t {
                    Some(t) if t.ty == Ty::Number => {
                        if let Some(Value::Num(x)) = t.konst {
                            if value::zone(Value::Num(x)).is_err() {
                                let msg = format!(
                                    "a BLEND zone is 0 or more mm (at most 1000), got {}",
                                    ProgramNum(x)
                                );
                                self.error(t.span, msg);
                                ok = false;
                            }
                        }
                        Some(Some(t))
                    }
                    Some(t) => {
                        let msg = format!("BLEND takes a zone in mm, got {}", article(t.ty));
                        self.error(t.span, msg);
                        ok = false;
                        None
                    }
                    None => {
                        ok = false;
                        None
                    }
                }
            }
        };
        ok.then_some(TMotion {
            speed,
            accel,
            blend,
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
            if let super::TKind::Str(text) = &t.kind {
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
            (ConstCheck::ErrorCode, Value::Num(x)) if value::error_code(Value::Num(x)).is_err() => {
                Some(format!(
                    "{} takes a code that is a whole number from 1 to 65535 (use 1000 and up for your own), got {}",
                    def.keyword,
                    ProgramNum(x)
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
}

fn is_end(s: &Stmt) -> bool {
    matches!(&s.kind, StmtKind::Command { def, .. } if def.op == CommandOp::End)
}

/// A statement after which nothing in the same block runs (END, RETURN, EXIT, RETRY,
/// RAISE): its word.
fn leaves_block(s: &Stmt) -> Option<&'static str> {
    match &s.kind {
        StmtKind::Command { def, .. } if matches!(def.op, CommandOp::End | CommandOp::Raise) => {
            Some(def.keyword)
        }
        StmtKind::Return(_) => Some("RETURN"),
        StmtKind::Exit(_) => Some("EXIT"),
        StmtKind::Retry => Some("RETRY"),
        _ => None,
    }
}
