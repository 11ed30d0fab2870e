//! Names: the units' global variables, arrays and points, their SUBs and FUNCTIONs with
//! their parameters and locals; declaring them (a pass over every unit before anything is
//! checked), resolving a name where it is used, and the type pre-pass.

use std::collections::HashMap;

use crate::ast::{Expr, Name, RoutineKind, Stmt, StmtKind, TypeDecl};
use crate::bytecode::Variable;
use crate::diagnostic::Span;
use crate::points::PointValue;
use crate::value::{Ty, Value};

use super::{article, Checker, Ctx, Symbol, Unit};

/// Most elements of one array.
pub(crate) const MAX_ARRAY: u32 = 65_536;

/// An array's dimensions: `n` of them (0 for a scalar), each `d[i]` long.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Dims {
    pub n: u8,
    pub d: [u32; 2],
}

impl Dims {
    pub const SCALAR: Dims = Dims { n: 0, d: [1, 1] };

    /// Slots it takes.
    pub fn len(&self) -> u32 {
        match self.n {
            0 => 1,
            1 => self.d[0],
            _ => self.d[0] * self.d[1],
        }
    }

    pub fn is_array(&self) -> bool {
        self.n > 0
    }

    /// `[25]` or `[3, 4]`.
    pub fn shown(&self) -> String {
        match self.n {
            0 => String::new(),
            1 => format!("[{}]", self.d[0]),
            _ => format!("[{}, {}]", self.d[0], self.d[1]),
        }
    }
}

/// A global variable, array or named point of a unit.
#[derive(Debug, Clone)]
pub(crate) struct Global {
    pub name: String,
    pub unit: u16,
    pub ty: Option<Ty>,
    pub ty_span: Span,
    pub first: Span,
    pub assigns: u32,
    pub konst: Option<Value>,
    pub read: bool,
    pub assigned_in_sub: bool,
    pub for_var: bool,
    pub hidden: bool,
    /// An assignment to it had an error: do not also warn that it is unused.
    pub broken: bool,
    pub dims: Dims,
    /// Declared with DIM (its type is fixed; it may be read before any assignment).
    pub declared: bool,
    /// A named point of the unit's points file (or one TEACH creates).
    pub point: bool,
    /// A TEACH of it runs in the program.
    pub taught: bool,
    /// A point's value from the points file.
    pub init: Option<Value>,
}

/// A parameter, local variable or local array of a SUB or FUNCTION.
#[derive(Debug, Clone)]
pub(crate) struct Local {
    pub name: String,
    pub ty: Option<Ty>,
    pub span: Span,
    pub dims: Dims,
    /// Its first slot in the frame.
    pub slot: u32,
    pub read: bool,
    pub param: bool,
    pub hidden: bool,
}

/// A SUB, FUNCTION or a called program's main body.
#[derive(Debug, Clone)]
pub(crate) struct Routine {
    pub name: Name,
    pub unit: u16,
    pub kind: RoutineKind,
    pub params: Vec<Ty>,
    pub ret: Option<Ty>,
    pub called: bool,
    pub locals: Vec<Local>,
    pub local_index: HashMap<String, usize>,
    pub next_slot: u32,
    /// The main body of a program called with `CALL PROGRAM`.
    pub program: bool,
    /// A RETURN with a value is somewhere in its body (FUNCTIONs need one).
    pub returns: bool,
}

impl Routine {
    /// `SUB name`, `FUNCTION name`, `PROGRAM name`.
    pub fn display_name(&self) -> String {
        if self.program {
            format!("PROGRAM {}", self.name.text)
        } else {
            self.name.text.clone()
        }
    }

    /// The frame's slots, in order (an array's element slots after its first are named
    /// `NAME[i]`).
    pub fn frame_variables(&self) -> Vec<Variable> {
        let mut out = Vec::with_capacity(self.next_slot as usize);
        for l in &self.locals {
            out.push(Variable {
                name: l.name.clone(),
                ty: l.ty.unwrap_or(Ty::Number),
                hidden: l.hidden,
                len: l.dims.len(),
                point: false,
                init: None,
            });
            for _ in 1..l.dims.len() {
                out.push(Variable {
                    name: format!("{}[]", l.name),
                    ty: l.ty.unwrap_or(Ty::Number),
                    hidden: true,
                    len: 0,
                    point: false,
                    init: None,
                });
            }
        }
        out
    }

    fn add_local(&mut self, local: Local) -> usize {
        let i = self.locals.len();
        self.next_slot += local.dims.len();
        self.local_index.insert(local.name.to_ascii_uppercase(), i);
        self.locals.push(local);
        i
    }
}

/// What a name stands for where it is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Sym {
    Local(u32, usize),
    Global(u32),
}

impl Checker<'_> {
    fn new_global(&mut self, unit: u16, name: &Name) -> u32 {
        let i = self.globals.len() as u32;
        self.globals.push(Global {
            name: name.text.clone(),
            unit,
            ty: None,
            ty_span: name.span,
            first: name.span,
            assigns: 0,
            konst: None,
            read: false,
            assigned_in_sub: false,
            for_var: false,
            hidden: false,
            broken: false,
            dims: Dims::SCALAR,
            declared: false,
            point: false,
            taught: false,
            init: None,
        });
        self.global_index.insert(unit, name.key.clone(), i);
        i
    }

    /// The global `name` of the current unit, made if it does not exist yet.
    pub(super) fn global_slot(&mut self, name: &Name) -> u32 {
        let unit = self.ctx.unit;
        match self.global_index.get(unit, &name.key) {
            Some(&i) => i,
            None => self.new_global(unit, name),
        }
    }

    /// A hidden slot of type number (a FOR loop's limit and step, a SELECT CASE's value):
    /// in the running frame inside a SUB, FUNCTION or called program, else a global.
    pub(super) fn hidden_slot(&mut self, name: String, ty: Ty) -> super::Place {
        if let Some(r) = self.ctx.routine {
            let routine = &mut self.routines[r as usize];
            let slot = routine.next_slot;
            routine.add_local(Local {
                name,
                ty: Some(ty),
                span: Span::default(),
                dims: Dims::SCALAR,
                slot,
                read: true,
                param: false,
                hidden: true,
            });
            return super::Place::Local(slot);
        }
        let i = self.globals.len() as u32;
        self.globals.push(Global {
            name,
            unit: self.ctx.unit,
            ty: Some(ty),
            ty_span: Span::default(),
            first: Span::default(),
            assigns: 2,
            konst: None,
            read: true,
            assigned_in_sub: false,
            for_var: false,
            hidden: true,
            broken: false,
            dims: Dims::SCALAR,
            declared: true,
            point: false,
            taught: false,
            init: None,
        });
        self.assigned.push(true);
        super::Place::Global(i)
    }

    /// Resolve `name` where it is used: a local of the current SUB, else a global of the
    /// current unit.
    pub(super) fn lookup(&self, name: &Name) -> Option<Sym> {
        if let Some(r) = self.ctx.routine {
            if let Some(&i) = self.routines[r as usize].local_index.get(&name.key) {
                return Some(Sym::Local(r, i));
            }
        }
        self.global_index
            .get(self.ctx.unit, &name.key)
            .map(|&g| Sym::Global(g))
    }

    /// The SUB or FUNCTION `key` of the current unit.
    pub(super) fn routine_named(&self, key: &str) -> Option<u32> {
        self.routine_index.get(self.ctx.unit, key).copied()
    }

    /// The constant dimensions of a DIM, each a whole number of 1 or more.
    fn dims(&mut self, name: &Name, exprs: &[Expr]) -> Option<Dims> {
        if exprs.len() > 2 {
            self.error(
                exprs[2].span,
                "arrays have one or two dimensions: DIM A[n] or DIM A[rows, columns]",
            );
            return None;
        }
        let mut d = [1u32; 2];
        for (i, e) in exprs.iter().enumerate() {
            let was = self.quiet;
            let t = self.expr(e);
            self.quiet = was;
            match t.and_then(|t| t.konst) {
                Some(Value::Num(x))
                    if x >= 1.0 && x.fract() == 0.0 && x <= f64::from(MAX_ARRAY) =>
                {
                    d[i] = x as u32;
                }
                _ => {
                    self.error(
                        e.span,
                        format!(
                            "an array's size must be a constant whole number from 1 to {MAX_ARRAY}"
                        ),
                    );
                    return None;
                }
            }
        }
        let dims = Dims {
            n: exprs.len() as u8,
            d,
        };
        if dims.len() > MAX_ARRAY {
            self.error(
                name.span,
                format!("{} has more than {MAX_ARRAY} elements", name.text),
            );
            return None;
        }
        Some(dims)
    }

    fn symbol(
        &mut self,
        name: &Name,
        kind: &'static str,
        ty: Option<Ty>,
        scope: Option<String>,
        detail: String,
    ) {
        if self.quiet {
            return;
        }
        self.symbols.push(Symbol {
            name: name.text.clone(),
            kind,
            ty: ty.map_or("", Ty::name),
            file: name.span.file,
            line: name.span.line,
            col: name.span.col,
            scope,
            detail,
        });
    }

    /// Declare every unit's points, top-level DIMs and routines (with their parameters and
    /// locals), before anything is resolved.
    pub(super) fn declare(&mut self, units: &[Unit]) {
        for (u, unit) in units.iter().enumerate() {
            let u = u as u16;
            self.ctx = Ctx {
                unit: u,
                routine: None,
                blocks: Vec::new(),
            };
            for (name, value) in &unit.points {
                let key = name.to_ascii_uppercase();
                let n = Name {
                    text: name.clone(),
                    key: key.clone(),
                    span: Span::line_start(0, 0),
                };
                if self.global_index.contains_key(u, &key) {
                    continue; // the points file's reader refuses duplicates
                }
                let g = self.new_global(u, &n);
                let v = match value {
                    PointValue::Pose(p) => Value::Pose(*p),
                    PointValue::Joints(j) => Value::Joints(*j),
                };
                let glob = &mut self.globals[g as usize];
                glob.ty = Some(v.ty());
                glob.point = true;
                glob.declared = true;
                glob.init = Some(v);
                glob.konst = Some(v);
                if u == 0 {
                    let detail = match value {
                        PointValue::Pose(p) => format!(
                            "POSE({}, {}, {}, {})",
                            crate::vm::ProgramNum(p.x),
                            crate::vm::ProgramNum(p.y),
                            crate::vm::ProgramNum(p.z),
                            crate::vm::ProgramNum(p.yaw)
                        ),
                        PointValue::Joints(_) => "JOINTS(…)".into(),
                    };
                    self.symbol(&n, "point", Some(v.ty()), None, detail);
                }
            }
            if u > 0 {
                // A called program's main body is a routine without parameters.
                let name = Name {
                    text: unit.name.clone(),
                    key: format!("PROGRAM {}", unit.name.to_ascii_uppercase()),
                    span: Span::line_start(unit_file(unit), 1),
                };
                let r = self.routines.len() as u32;
                self.routines.push(Routine {
                    name,
                    unit: u,
                    kind: RoutineKind::Sub,
                    params: Vec::new(),
                    ret: None,
                    called: true,
                    locals: Vec::new(),
                    local_index: HashMap::new(),
                    next_slot: 0,
                    program: true,
                    returns: false,
                });
                self.unit_main[usize::from(u)] = Some(r);
            }
            for s in &unit.stmts {
                match &s.kind {
                    StmtKind::Dim { name, dims, ty } => {
                        self.declare_global_dim(name, dims, *ty);
                    }
                    _ => self.declare_routines(std::slice::from_ref(s)),
                }
            }
        }
    }

    /// Declare the routines among `stmts`, and those nested in blocks (reported by the
    /// parser; declared so that their calls are not reported again).
    fn declare_routines(&mut self, stmts: &[Stmt]) {
        for s in stmts {
            match &s.kind {
                StmtKind::Routine {
                    kind,
                    name,
                    params,
                    ret,
                    body,
                } => self.declare_routine(*kind, name, params, *ret, body),
                other => for_each_block(other, |body| self.declare_routines(body)),
            }
        }
    }

    fn declare_global_dim(&mut self, name: &Name, dims: &[Expr], ty: Option<TypeDecl>) {
        let u = self.ctx.unit;
        if let Some(&g) = self.global_index.get(u, &name.key) {
            let first = self.globals[g as usize].first;
            let msg = if self.globals[g as usize].point {
                format!(
                    "{} is a named point of the points file; choose another name",
                    name.text
                )
            } else {
                format!(
                    "{} is declared twice (first at {})",
                    name.text,
                    self.cite(first, name.span)
                )
            };
            self.error(name.span, msg);
            return;
        }
        let d = if dims.is_empty() {
            Some(Dims::SCALAR)
        } else {
            self.dims(name, dims)
        };
        let g = self.new_global(u, name);
        let ty = ty.map_or(default_ty(name), |t| t.ty);
        let glob = &mut self.globals[g as usize];
        glob.ty = Some(ty);
        glob.ty_span = name.span;
        glob.declared = true;
        match d {
            Some(d) => glob.dims = d,
            None => glob.broken = true,
        }
        let dims = glob.dims;
        if u == 0 {
            let kind = if dims.is_array() { "array" } else { "variable" };
            self.symbol(
                name,
                kind,
                Some(ty),
                None,
                format!(
                    "{}{} AS {}",
                    name.text,
                    dims.shown(),
                    ty.name().to_ascii_uppercase()
                ),
            );
        }
    }

    fn declare_routine(
        &mut self,
        kind: RoutineKind,
        name: &Name,
        params: &[crate::ast::Param],
        ret: Option<TypeDecl>,
        body: &[Stmt],
    ) {
        let u = self.ctx.unit;
        if let Some(&first) = self.routine_index.get(u, &name.key) {
            let at = self.routines[first as usize].name.span;
            let msg = format!(
                "{} {} is defined twice (first at {})",
                kind.word(),
                name.text,
                self.cite(at, name.span)
            );
            self.error(name.span, msg);
            return;
        }
        let r = self.routines.len() as u32;
        let mut routine = Routine {
            name: name.clone(),
            unit: u,
            kind,
            params: Vec::new(),
            ret: match kind {
                RoutineKind::Function => Some(ret.map_or(default_ty(name), |t| t.ty)),
                RoutineKind::Sub => None,
            },
            called: false,
            locals: Vec::new(),
            local_index: HashMap::new(),
            next_slot: 0,
            program: false,
            returns: false,
        };
        let mut signature = Vec::new();
        for p in params {
            let ty = p.ty.map_or(default_ty(&p.name), |t| t.ty);
            if routine.local_index.contains_key(&p.name.key) {
                self.error(
                    p.name.span,
                    format!("parameter {} is named twice", p.name.text),
                );
                continue;
            }
            signature.push(format!(
                "{} AS {}",
                p.name.text,
                ty.name().to_ascii_uppercase()
            ));
            routine.params.push(ty);
            let slot = routine.next_slot;
            routine.add_local(Local {
                name: p.name.text.clone(),
                ty: Some(ty),
                span: p.name.span,
                dims: Dims::SCALAR,
                slot,
                read: false,
                param: true,
                hidden: false,
            });
        }
        self.routine_index.insert(u, name.key.clone(), r);
        self.routines.push(routine);
        if u == 0 {
            let detail = match kind {
                RoutineKind::Sub => format!("SUB {}({})", name.text, signature.join(", ")),
                RoutineKind::Function => format!(
                    "FUNCTION {}({}) AS {}",
                    name.text,
                    signature.join(", "),
                    ret.map_or(default_ty(name), |t| t.ty)
                        .name()
                        .to_ascii_uppercase()
                ),
            };
            let k = if kind == RoutineKind::Sub {
                "sub"
            } else {
                "function"
            };
            let ret_ty = self.routines[r as usize].ret;
            self.symbol(name, k, ret_ty, None, detail);
            for p in params {
                self.symbol(
                    &p.name,
                    "parameter",
                    Some(p.ty.map_or(Ty::Number, |t| t.ty)),
                    Some(name.text.clone()),
                    String::new(),
                );
            }
        }
        // Locals: LOCAL and DIM anywhere in the body, in text order.
        let was = self.ctx.routine;
        self.ctx.routine = Some(r);
        self.declare_locals(body, &name.text);
        self.ctx.routine = was;
    }

    fn declare_locals(&mut self, stmts: &[Stmt], scope: &str) {
        for s in stmts {
            match &s.kind {
                StmtKind::Local { name, ty, .. } => {
                    self.declare_local(name, &[], *ty, scope);
                }
                StmtKind::Dim { name, dims, ty } => {
                    let ty = Some(ty.unwrap_or(TypeDecl {
                        ty: default_ty(name),
                        span: name.span,
                    }));
                    self.declare_local(name, dims, ty, scope);
                }
                _ => {
                    for_each_block(&s.kind, |body| self.declare_locals(body, scope));
                }
            }
        }
    }

    fn declare_local(&mut self, name: &Name, dims: &[Expr], ty: Option<TypeDecl>, scope: &str) {
        let Some(r) = self.ctx.routine else { return };
        if let Some(&i) = self.routines[r as usize].local_index.get(&name.key) {
            let l = &self.routines[r as usize].locals[i];
            let msg = if l.param {
                format!(
                    "{} is a parameter of this {}; a LOCAL cannot have its name",
                    name.text,
                    self.routines[r as usize].kind.word()
                )
            } else {
                format!(
                    "{} is declared twice in this {} (first at {})",
                    name.text,
                    self.routines[r as usize].kind.word(),
                    l.span.at()
                )
            };
            self.error(name.span, msg);
            return;
        }
        let d = if dims.is_empty() {
            Dims::SCALAR
        } else {
            match self.dims(name, dims) {
                Some(d) => d,
                None => Dims::SCALAR,
            }
        };
        let routine = &mut self.routines[r as usize];
        let slot = routine.next_slot;
        routine.add_local(Local {
            name: name.text.clone(),
            ty: ty
                .map(|t| t.ty)
                .or_else(|| name.text.ends_with('$').then_some(Ty::Str)),
            span: name.span,
            dims: d,
            slot,
            read: false,
            param: false,
            hidden: false,
        });
        if self.ctx.unit == 0 {
            let kind = "local";
            let shown = ty.map(|t| t.ty);
            self.symbol(name, kind, shown, Some(scope.to_string()), d.shown());
        }
    }

    /// Register every variable assigned anywhere (globals made on first sight), FOR loop
    /// variables and TEACH targets, with the unit and routine each is in.
    pub(super) fn collect(&mut self, units: &[Unit]) {
        for (u, unit) in units.iter().enumerate() {
            self.ctx = Ctx {
                unit: u as u16,
                routine: self.unit_main[u],
                blocks: Vec::new(),
            };
            for s in &unit.stmts {
                if let StmtKind::Routine { name, body, .. } = &s.kind {
                    let was = self.ctx.routine;
                    self.ctx.routine = self.routine_named(&name.key);
                    if self.ctx.routine.is_some() {
                        self.collect_block(body);
                    }
                    self.ctx.routine = was;
                } else {
                    self.collect_block(std::slice::from_ref(s));
                }
            }
        }
    }

    fn collect_block(&mut self, stmts: &[Stmt]) {
        let in_sub = !self.in_main();
        for s in stmts {
            match &s.kind {
                StmtKind::Assign { target, .. } => {
                    if let Some(Sym::Local(..)) = self.lookup(target) {
                        continue;
                    }
                    let g = self.global_slot(target) as usize;
                    self.globals[g].assigns += 1;
                    self.globals[g].assigned_in_sub |= in_sub;
                    if self.ctx.unit == 0
                        && self.globals[g].assigns == 1
                        && !self.globals[g].declared
                    {
                        let n = target.clone();
                        self.symbol(&n, "variable", None, None, String::new());
                    }
                }
                StmtKind::For { var, body, .. } => {
                    if !matches!(self.lookup(var), Some(Sym::Local(..))) {
                        let g = self.global_slot(var) as usize;
                        let v = &mut self.globals[g];
                        v.assigns += 2;
                        v.assigned_in_sub |= in_sub;
                        v.for_var = true;
                        if v.ty.is_none() {
                            v.ty = Some(Ty::Number);
                            v.ty_span = var.span;
                        }
                    }
                    self.collect_block(body);
                }
                StmtKind::Command { def, args }
                    if def.op == crate::statements::CommandOp::Teach =>
                {
                    for a in args {
                        if let crate::ast::Arg::Target(name) = a {
                            if matches!(self.lookup(name), Some(Sym::Local(..))) {
                                continue; // reported when checked
                            }
                            let known = self.lookup(name).is_some();
                            let g = self.global_slot(name) as usize;
                            let v = &mut self.globals[g];
                            if !known {
                                // A new point: a pose, zero until TEACH runs.
                                v.point = true;
                                v.declared = true;
                                v.ty = Some(Ty::Pose);
                                v.ty_span = name.span;
                            }
                            if v.point {
                                v.taught = true;
                                v.konst = None;
                                v.assigns += 1;
                                v.assigned_in_sub |= in_sub;
                            }
                        }
                    }
                }
                StmtKind::Routine { .. } => {} // nested: reported by the parser
                other => for_each_block(other, |body| self.collect_block(body)),
            }
        }
    }

    /// Give every global the type (and, if it is assigned once, the constant value) of its
    /// first assignment whose type is known, and every `LOCAL x = value` the type of its
    /// value, repeating until nothing changes.
    pub(super) fn infer_types(&mut self, units: &[Unit]) {
        let mut targets = Vec::new();
        for (u, unit) in units.iter().enumerate() {
            self.ctx = Ctx {
                unit: u as u16,
                routine: self.unit_main[u],
                blocks: Vec::new(),
            };
            for s in &unit.stmts {
                if let StmtKind::Routine { name, body, .. } = &s.kind {
                    let was = self.ctx.routine;
                    self.ctx.routine = self.routine_named(&name.key);
                    if self.ctx.routine.is_some() {
                        self.gather(body, &mut targets);
                    }
                    self.ctx.routine = was;
                } else {
                    self.gather(std::slice::from_ref(s), &mut targets);
                }
            }
        }
        self.quiet = true;
        loop {
            let mut changed = false;
            for (ctx, target, expr, span) in &targets {
                self.ctx = ctx.clone();
                match *target {
                    Sym::Global(g) => {
                        let v = &self.globals[g as usize];
                        let settled = v.ty.is_some()
                            && (v.assigns != 1 || v.for_var || v.konst.is_some() || v.declared);
                        if settled {
                            continue;
                        }
                        let Some(te) = self.expr(expr) else { continue };
                        let v = &mut self.globals[g as usize];
                        if v.ty.is_none() {
                            v.ty = Some(te.ty);
                            v.ty_span = *span;
                            changed = true;
                        }
                        if v.assigns == 1
                            && !v.for_var
                            && !v.declared
                            && v.konst.is_none()
                            && te.konst.is_some()
                        {
                            v.konst = te.konst;
                            changed = true;
                        }
                    }
                    Sym::Local(r, i) => {
                        if self.routines[r as usize].locals[i].ty.is_some() {
                            continue;
                        }
                        let Some(te) = self.expr(expr) else { continue };
                        self.routines[r as usize].locals[i].ty = Some(te.ty);
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        self.quiet = false;
        // Locals whose type is still unknown: report once, give them a number.
        for r in 0..self.routines.len() {
            for i in 0..self.routines[r].locals.len() {
                let l = &self.routines[r].locals[i];
                if l.ty.is_none() {
                    let (span, name) = (l.span, l.name.clone());
                    self.error(
                        span,
                        format!(
                            "cannot tell what {name} holds: its first value uses values that are not known yet; write LOCAL {name} AS type"
                        ),
                    );
                    self.routines[r].locals[i].ty = Some(Ty::Number);
                }
            }
        }
    }

    #[allow(clippy::type_complexity)]
    fn gather<'s>(&mut self, stmts: &'s [Stmt], out: &mut Vec<(Ctx, Sym, &'s Expr, Span)>) {
        for s in stmts {
            match &s.kind {
                StmtKind::Assign {
                    target,
                    index,
                    value,
                } if index.is_empty() => {
                    if let Some(Sym::Global(g)) = self.lookup(target) {
                        out.push((self.ctx.clone(), Sym::Global(g), value, s.span));
                    }
                }
                StmtKind::Local {
                    name,
                    ty: None,
                    init: Some(value),
                } => {
                    if let Some(sym @ Sym::Local(..)) = self.lookup(name) {
                        out.push((self.ctx.clone(), sym, value, s.span));
                    }
                }
                StmtKind::Routine { .. } => {}
                other => for_each_block(other, |body| self.gather(body, out)),
            }
        }
    }

    /// Warnings: unused variables, locals and routines. Warn of what is never used; a SUB or FUNCTION never called only in the program's own
    /// file (not an included library's), and not at all in a library.
    pub(super) fn warn_unused(&mut self, library: bool) {
        let mut warnings = Vec::new();
        for v in &self.globals {
            if v.unit == 0
                && !v.read
                && !v.hidden
                && !v.for_var
                && !v.broken
                && !v.point
                && !v.name.starts_with('_')
            {
                let what = if v.dims.is_array() {
                    format!("array {} is declared but never used", v.name)
                } else if v.declared && v.assigns == 0 {
                    format!("variable {} is declared but never used", v.name)
                } else {
                    format!("variable {} is assigned but never used", v.name)
                };
                warnings.push((
                    v.first,
                    format!("{what} (start its name with _ to keep it quiet)"),
                ));
            }
        }
        for r in &self.routines {
            if r.unit == 0 && !r.called && !r.program && !library && r.name.span.file == 0 {
                warnings.push((
                    r.name.span,
                    format!("{} {} is never called", r.kind.word(), r.name.text),
                ));
            }
            if r.unit == 0 {
                for l in &r.locals {
                    if !l.read && !l.hidden && !l.param && !l.name.starts_with('_') {
                        warnings.push((
                            l.span,
                            format!(
                                "local {} of {} is never used (start its name with _ to keep it quiet)",
                                l.name, r.name.text
                            ),
                        ));
                    }
                }
            }
        }
        for (span, msg) in warnings {
            self.warning(span, msg);
        }
    }

    /// `place` as a message at `here` cites it: `line:col` in the same file,
    /// `file.wrl:line:col` in another.
    pub(super) fn cite(&self, place: Span, here: Span) -> String {
        if place.file == here.file {
            return place.at();
        }
        match self.file_names.get(usize::from(place.file)) {
            Some(file) => format!("{file}:{}", place.at()),
            None => place.at(),
        }
    }

    /// A message for a type a value cannot change to.
    pub(super) fn type_clash(&self, name: &Name, ty: Ty, since: Span, got: Ty) -> String {
        format!(
            "{} holds {} (since {}); it cannot be assigned {}",
            name.text,
            article(ty),
            self.cite(since, name.span),
            article(got)
        )
    }
}

/// The source file a unit's first statement is in.
fn unit_file(unit: &Unit) -> u16 {
    unit.stmts.first().map_or(0, |s| s.span.file)
}

/// Call `f` on every statement list directly inside a block statement.
pub(crate) fn for_each_block<'s>(kind: &'s StmtKind, mut f: impl FnMut(&'s [Stmt])) {
    match kind {
        StmtKind::If { arms, else_block } => {
            for (_, body) in arms {
                f(body);
            }
            f(else_block);
        }
        StmtKind::While { body, .. } | StmtKind::For { body, .. } | StmtKind::Do { body, .. } => {
            f(body)
        }
        StmtKind::Select {
            cases, else_block, ..
        } => {
            for (_, body, _) in cases {
                f(body);
            }
            if let Some(b) = else_block {
                f(b);
            }
        }
        StmtKind::Try { body, catches } => {
            f(body);
            for c in catches {
                f(&c.body);
            }
        }
        StmtKind::Routine { body, .. } => f(body),
        StmtKind::Assign { .. }
        | StmtKind::Command { .. }
        | StmtKind::Call { .. }
        | StmtKind::CallProgram { .. }
        | StmtKind::Dim { .. }
        | StmtKind::Local { .. }
        | StmtKind::Return(_)
        | StmtKind::Exit(_)
        | StmtKind::Retry
        | StmtKind::Include { .. } => {}
    }
}

/// The type of a declared name without `AS`: a string when it ends in `$` (`who$`,
/// `name$(…)`), else a number.
fn default_ty(name: &Name) -> Ty {
    if name.text.ends_with('$') {
        Ty::Str
    } else {
        Ty::Number
    }
}
