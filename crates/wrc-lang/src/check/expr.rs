//! Checking expressions: types, names, built-in and FUNCTION calls, array elements, and
//! folding constant sub-expressions with the functions the VM uses.

use wrc_robot::Pose;

use crate::ast::{BinOp, Expr, ExprKind, Name, RoutineKind, UnOp};
use crate::builtins::{self, Builtin, Kind, Param};
use crate::diagnostic::Span;
use crate::error::RuntimeErrorKind;
use crate::value::{self, Arith, Cmp, Ty, Value};

use super::symbols::{Dims, Sym};
use super::{article, Checker, Elem, Place, TExpr, TKind};

impl Checker<'_> {
    /// Type-check an expression; `None` after an error (reported once) or an unknown type.
    pub(super) fn expr(&mut self, e: &Expr) -> Option<TExpr> {
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
            ExprKind::Index(name, index) => {
                let elem = self.element(name, index, false)?;
                let ty = elem.1;
                mk(TKind::LoadElem(Box::new(elem.0)), ty, None)
            }
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

    /// Mark a variable read; in a main body, report a read before any assignment.
    fn read_global(&mut self, g: u32, name: &Name) {
        if self.quiet {
            return;
        }
        let i = g as usize;
        self.globals[i].read = true;
        let v = &self.globals[i];
        let before = !self.in_main()
            || v.assigned_in_sub
            || v.declared
            || self.assigned.get(i).copied().unwrap_or(true);
        if !before {
            let msg = format!(
                "{} is used before it is assigned (first assigned at {})",
                name.text,
                self.cite(v.first, name.span)
            );
            self.error(name.span, msg);
        }
    }

    fn unknown_name(&mut self, name: &Name) {
        let msg = if let Some(r) = self.routine_named(&name.key) {
            let kind = self.routines[r as usize].kind;
            match kind {
                RoutineKind::Sub => format!(
                    "{} is a SUB, not a value: run it with CALL {}",
                    name.text, name.text
                ),
                RoutineKind::Function => format!(
                    "{} is a FUNCTION: call it with parentheses, {}(…)",
                    name.text, name.text
                ),
            }
        } else if let Some(b) = builtins::find(&name.key) {
            if b.params.is_empty() {
                format!("{} is a built-in function: write {}()", name.text, b.name)
            } else {
                format!(
                    "{} is a built-in function: it needs its arguments in parentheses, {}",
                    name.text, b.syntax
                )
            }
        } else if self.robot.axis_index(&name.text).is_some() {
            format!(
                "unknown variable {}: it is never assigned (to read axis {} use HERE() or JOINTS fields)",
                name.text, name.text
            )
        } else {
            format!(
                "unknown variable {}: it is never assigned (assign it first, {} = …, or teach it as a named point)",
                name.text, name.text
            )
        };
        self.error(name.span, msg);
    }

    fn var(&mut self, name: &Name) -> Option<TExpr> {
        let Some(sym) = self.lookup(name) else {
            self.unknown_name(name);
            return None;
        };
        match sym {
            Sym::Local(r, i) => {
                let l = &self.routines[r as usize].locals[i];
                let (ty, slot, dims) = (l.ty?, l.slot, l.dims);
                if dims.is_array() {
                    self.not_indexed(name, dims, ty);
                    return None;
                }
                if !self.quiet {
                    self.routines[r as usize].locals[i].read = true;
                }
                Some(TExpr {
                    kind: TKind::Load(Place::Local(slot)),
                    ty,
                    span: name.span,
                    konst: None,
                })
            }
            Sym::Global(g) => {
                self.read_global(g, name);
                let v = &self.globals[g as usize];
                if v.dims.is_array() {
                    let (dims, ty) = (v.dims, v.ty.unwrap_or(Ty::Number));
                    self.not_indexed(name, dims, ty);
                    return None;
                }
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
                let konst = if v.assigns <= 1 && !v.for_var && (!v.declared || v.point) {
                    v.konst
                } else {
                    None
                };
                Some(TExpr {
                    kind: TKind::Load(Place::Global(g)),
                    ty,
                    span: name.span,
                    konst,
                })
            }
        }
    }

    fn not_indexed(&mut self, name: &Name, dims: Dims, ty: Ty) {
        let idx = if dims.n == 1 { "[i]" } else { "[i, j]" };
        let msg = format!(
            "{} is an array of {} {}s{}: use one element, {}{idx}",
            name.text,
            dims.len(),
            ty.name(),
            dims.shown(),
            name.text
        );
        self.error(name.span, msg);
    }

    /// An array element `name[index]`: where, and the element type. `store`: it is being
    /// assigned (not read).
    pub(super) fn element(
        &mut self,
        name: &Name,
        index: &[Expr],
        store: bool,
    ) -> Option<(Elem, Ty)> {
        let Some(sym) = self.lookup(name) else {
            let msg = format!(
                "unknown array {}: declare it first with DIM {}[size]",
                name.text, name.text
            );
            self.error(name.span, msg);
            return None;
        };
        let (place, dims, ty) = match sym {
            Sym::Local(r, i) => {
                let l = &self.routines[r as usize].locals[i];
                let (place, dims, ty) = (Place::Local(l.slot), l.dims, l.ty?);
                if !self.quiet && !store {
                    self.routines[r as usize].locals[i].read = true;
                }
                (place, dims, ty)
            }
            Sym::Global(g) => {
                let v = &self.globals[g as usize];
                let (dims, ty) = (v.dims, v.ty);
                if !self.quiet && !store {
                    self.globals[g as usize].read = true;
                }
                (Place::Global(g), dims, ty.unwrap_or(Ty::Number))
            }
        };
        if !dims.is_array() {
            let msg = format!(
                "{} is not an array; declare one with DIM {}[size]",
                name.text, name.text
            );
            self.error(name.span, msg);
            return None;
        }
        if index.len() != usize::from(dims.n) {
            let msg = format!(
                "{} has {} dimension{} ({}{}), got {} index{}",
                name.text,
                dims.n,
                if dims.n == 1 { "" } else { "s" },
                name.text,
                dims.shown(),
                index.len(),
                if index.len() == 1 { "" } else { "es" }
            );
            self.error(name.span, msg);
            for e in index {
                self.expr(e);
            }
            return None;
        }
        let mut out = Vec::with_capacity(index.len());
        let mut ok = true;
        for (k, e) in index.iter().enumerate() {
            match self.expr(e) {
                Some(t) if t.ty == Ty::Number => {
                    if let Some(Value::Num(x)) = t.konst {
                        let n = dims.d[k];
                        if !(x >= 0.0 && x.fract() == 0.0 && x < f64::from(n)) {
                            let msg = format!(
                                "index {} is outside {}{}: indexes go from 0 to {}",
                                crate::vm::ProgramNum(x),
                                name.text,
                                dims.shown(),
                                n - 1
                            );
                            self.error(t.span, msg);
                            ok = false;
                        }
                    }
                    out.push(t);
                }
                Some(t) => {
                    let msg = format!("an index is a number, got {}", article(t.ty));
                    self.error(t.span, msg);
                    ok = false;
                }
                None => ok = false,
            }
        }
        ok.then_some((
            Elem {
                place,
                dims,
                index: out,
            },
            ty,
        ))
    }

    pub(super) fn binary(
        &mut self,
        op: BinOp,
        op_span: Span,
        l: TExpr,
        r: TExpr,
        span: Span,
    ) -> Option<TExpr> {
        use Ty::*;
        let ty = match op {
            BinOp::Add => match (l.ty, r.ty) {
                (Number, Number) => Some(Number),
                (Pose, Pose) => Some(Pose),
                (Joints, Joints) => Some(Joints),
                (Str, Str) => Some(Str),
                _ => None,
            },
            BinOp::Sub => match (l.ty, r.ty) {
                (Number, Number) => Some(Number),
                (Pose, Pose) => Some(Pose),
                (Joints, Joints) => Some(Joints),
                _ => None,
            },
            BinOp::Mul | BinOp::Div | BinOp::Mod => {
                (l.ty == Number && r.ty == Number).then_some(Number)
            }
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
                BinOp::Add if l.ty == Str || r.ty == Str => format!(
                    "cannot add {} and {}: to put a number into a string write STR$(x) or FORMAT$(x, \"0.0\")",
                    article(l.ty),
                    article(r.ty)
                ),
                BinOp::Add => format!("cannot add {} and {}", article(l.ty), article(r.ty)),
                BinOp::Sub => format!("cannot subtract {} from {}", article(r.ty), article(l.ty)),
                BinOp::Mul | BinOp::Div | BinOp::Mod => format!(
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
        if matches!(op, BinOp::Div | BinOp::Mod) && r.konst == Some(Value::Num(0.0)) {
            self.error(op_span, "division by zero");
            return None;
        }
        let mut konst = None;
        if let (Some(a), Some(b)) = (l.konst, r.konst) {
            let result = match op {
                BinOp::Add => value::arith(Arith::Add, a, b, &[]),
                BinOp::Sub => value::arith(Arith::Sub, a, b, &[]),
                BinOp::Mul => value::arith(Arith::Mul, a, b, &[]),
                BinOp::Div => value::arith(Arith::Div, a, b, &[]),
                BinOp::Mod => value::arith(Arith::Mod, a, b, &[]),
                BinOp::Eq => value::compare(Cmp::Eq, a, b, &[]),
                BinOp::Ne => value::compare(Cmp::Ne, a, b, &[]),
                BinOp::Lt => value::compare(Cmp::Lt, a, b, &[]),
                BinOp::Le => value::compare(Cmp::Le, a, b, &[]),
                BinOp::Gt => value::compare(Cmp::Gt, a, b, &[]),
                BinOp::Ge => value::compare(Cmp::Ge, a, b, &[]),
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

    /// `JOINTS(…)` / `POSE(…)`: every argument a number, the right count.
    fn constructor(&mut self, name: &Name, args: &[Expr], span: Span) -> Option<TExpr> {
        let joints = name.key == "JOINTS";
        let n_axes = self.robot.axis_count();
        let (want, what) = if joints {
            (
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
            )
        } else {
            (4, "x, y, z [mm], yaw [deg]".to_string())
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
            let msg = format!(
                "{} takes {want} value{s} ({what}), got {}",
                name.key,
                args.len()
            );
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
        let (kind, ty, konst) = if joints {
            let konst = nums.map(|v| {
                let mut j = [0.0; wrc_robot::MAX_AXES];
                j[..v.len()].copy_from_slice(&v);
                Value::Joints(j)
            });
            (TKind::Joints(targs), Ty::Joints, konst)
        } else {
            let konst = nums.map(|v| {
                Value::Pose(Pose {
                    x: v[0],
                    y: v[1],
                    z: v[2],
                    yaw: v[3],
                })
            });
            (TKind::Pose(targs), Ty::Pose, konst)
        };
        Some(TExpr {
            kind,
            ty,
            span,
            konst,
        })
    }

    fn call(&mut self, name: &Name, args: &[Expr], span: Span) -> Option<TExpr> {
        let key = name.key.as_str();
        if key == "JOINTS" || key == "POSE" {
            return self.constructor(name, args, span);
        }
        if let Some(def) = builtins::find(key) {
            return self.builtin(def, name, args, span);
        }
        if let Some(r) = self.routine_named(key) {
            let routine = &self.routines[r as usize];
            if routine.kind == RoutineKind::Sub {
                let msg = format!(
                    "{} is a SUB and returns no value: run it with CALL {}(…)",
                    name.text, name.text
                );
                self.error(name.span, msg);
                for a in args {
                    self.expr(a);
                }
                return None;
            }
            let ret = routine.ret.unwrap_or(Ty::Number);
            let args = self.routine_args(r, name, args, span)?;
            return Some(TExpr {
                kind: TKind::Call(r, args),
                ty: ret,
                span,
                konst: None,
            });
        }
        let msg = format!(
            "unknown function {}; the built-ins are {} (docs/language.md), and the program's FUNCTIONs",
            name.text,
            builtins::BUILTINS
                .iter()
                .map(|d| d.name)
                .chain(["JOINTS", "POSE"])
                .collect::<Vec<_>>()
                .join(", ")
        );
        self.error(name.span, msg);
        // Still check the arguments for their own errors.
        for a in args {
            self.expr(a);
        }
        None
    }

    /// The arguments of a call of routine `r`: the right count, each of its parameter's
    /// type.
    pub(super) fn routine_args(
        &mut self,
        r: u32,
        name: &Name,
        args: &[Expr],
        span: Span,
    ) -> Option<Vec<crate::check::TExpr>> {
        if !self.quiet {
            self.routines[r as usize].called = true;
        }
        let params = self.routines[r as usize].params.clone();
        let kind = self.routines[r as usize].kind.word();
        let mut out = Vec::with_capacity(args.len());
        let mut ok = true;
        for (i, a) in args.iter().enumerate() {
            match (self.expr(a), params.get(i)) {
                (Some(t), Some(&want)) if t.ty == want => out.push(t),
                (Some(t), Some(&want)) => {
                    let msg = format!(
                        "argument {} of {} must be {}, got {}",
                        i + 1,
                        name.text,
                        article(want),
                        article(t.ty)
                    );
                    self.error(t.span, msg);
                    ok = false;
                }
                (Some(_), None) => {}
                (None, _) => ok = false,
            }
        }
        if args.len() != params.len() {
            let s = if params.len() == 1 { "" } else { "s" };
            let msg = format!(
                "{kind} {} takes {} argument{s}, got {}",
                name.text,
                params.len(),
                args.len()
            );
            self.error(span, msg);
            return None;
        }
        ok.then_some(out)
    }

    fn builtin(
        &mut self,
        def: &'static builtins::BuiltinDef,
        name: &Name,
        args: &[Expr],
        span: Span,
    ) -> Option<TExpr> {
        let max = def.params.len();
        let min = max - usize::from(def.optional);
        if args.len() < min || args.len() > max {
            let msg = if max == 0 {
                format!("{} takes no arguments, got {}", def.name, args.len())
            } else if min == max {
                let s = if max == 1 { "" } else { "s" };
                format!(
                    "{} takes {max} argument{s} ({}), got {}",
                    def.name,
                    def.syntax,
                    args.len()
                )
            } else {
                format!(
                    "{} takes {min} to {max} arguments ({}), got {}",
                    def.name,
                    def.syntax,
                    args.len()
                )
            };
            self.error(span, msg);
            for a in args {
                if !matches!(&a.kind, ExprKind::Var(n) if matches!(n.key.as_str(), "A" | "B")) {
                    self.expr(a);
                }
            }
            return None;
        }
        let mut targs = Vec::with_capacity(args.len());
        let mut ok = true;
        for (a, param) in args.iter().zip(def.params) {
            match param {
                Param::Blade => {
                    let b = match &a.kind {
                        ExprKind::Var(n) if n.key == "A" => Some(0.0),
                        ExprKind::Var(n) if n.key == "B" => Some(1.0),
                        _ => None,
                    };
                    match b {
                        Some(x) => targs.push(TExpr {
                            kind: TKind::Num(x),
                            ty: Ty::Number,
                            span: a.span,
                            konst: Some(Value::Num(x)),
                        }),
                        None => {
                            self.error(
                                a.span,
                                format!(
                                    "{} takes a blade, A or B (as written, no quotes)",
                                    def.name
                                ),
                            );
                            ok = false;
                        }
                    }
                }
                Param::Is(want) => match self.expr(a) {
                    Some(t) if t.ty == *want => targs.push(t),
                    Some(t) => {
                        let msg = format!(
                            "{} takes {} here, got {}",
                            def.name,
                            article(*want),
                            article(t.ty)
                        );
                        self.error(t.span, msg);
                        ok = false;
                    }
                    None => ok = false,
                },
                Param::Station => match self.expr(a) {
                    Some(t) if t.ty == Ty::Str => {
                        if let TKind::Str(text) = &t.kind {
                            if value::station(text).is_err() {
                                let msg = format!(
                                    "{text:?} is not a station name; station names are 1 to {} letters, digits, '_' or '-' (like \"LP1\")",
                                    value::STATION_NAME_LEN
                                );
                                self.error(t.span, msg);
                                ok = false;
                            }
                        }
                        targs.push(t);
                    }
                    Some(t) => {
                        let msg = format!(
                            "{} takes a station name in quotes (like \"LP1\"), got {}",
                            def.name,
                            article(t.ty)
                        );
                        self.error(t.span, msg);
                        ok = false;
                    }
                    None => ok = false,
                },
            }
        }
        if !ok {
            return None;
        }
        if def.builtin == Builtin::In {
            if let Some(k) = targs[0].konst {
                if value::bit(k).is_err() {
                    self.error(targs[0].span, "input bits are whole numbers from 0 to 31");
                    return None;
                }
            }
        }
        if matches!(def.builtin, Builtin::Slot | Builtin::Wafer) {
            if let Some(Value::Num(x)) = targs[1].konst {
                if value::slot(Value::Num(x)).is_err() {
                    let msg = format!(
                        "slot {} does not exist; slots are whole numbers from 1 to {}",
                        crate::vm::ProgramNum(x),
                        value::MAX_SLOT
                    );
                    self.error(targs[1].span, msg);
                    return None;
                }
            }
        }
        let mut konst = None;
        if def.kind == Kind::Pure && def.ret != Ty::Str {
            let values: Option<Vec<Value>> = targs.iter().map(|t| t.konst).collect();
            if let Some(values) = values {
                match def.builtin.eval(&values, &[]) {
                    Ok(k) => konst = Some(k),
                    Err(e) => {
                        self.error(span, format!("{}: {e}", def.name));
                        return None;
                    }
                }
            }
        }
        if matches!(
            def.builtin,
            Builtin::Err | Builtin::ErrMsg | Builtin::ErrLine
        ) && !self.ctx.blocks.contains(&super::Enclosing::Catch)
            && !self.quiet
        {
            let msg = format!(
                "{} is only meaningful inside a CATCH block (it is 0 or \"\" elsewhere)",
                def.name
            );
            self.warning(name.span, msg);
        }
        Some(TExpr {
            kind: TKind::Builtin(def.builtin, targs),
            ty: def.ret,
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
}
