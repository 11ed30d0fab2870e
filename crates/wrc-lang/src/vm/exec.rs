//! Executing one instruction. Every value is checked where the VM relies on it (types,
//! ranges, indexes), so a verified program can only fail with a run-time error, never make
//! the VM index out of bounds.

use core::fmt::Write as _;

use wrc_robot::{InlineName, Pose, MAX_AXES};

use crate::builtins::{self, Builtin, Kind};
use crate::bytecode::{Instr, MoveFlags, Program};
use crate::error::RuntimeErrorKind;
use crate::value::{self, Arith, Cmp, Text, Ty, Value, STATION_NAME_LEN};

use super::format::write_value;
use super::{
    Awaiting, Blend, CellInfo, CellQuery, Exec, Flow, Frame, Motion, MoveOptions, Request,
    TransferKind, Vm, VmIo,
};

/// Most arguments of a built-in.
const MAX_BUILTIN_ARGS: usize = 5;

/// HERE() to the nanometre: forward kinematics leaves rounding noise (1.4e-14 mm) that
/// would print in exponent form.
fn clean(p: Pose) -> Pose {
    let r = |v: f64| {
        let c = (v * 1e9).round() / 1e9;
        if c == 0.0 {
            0.0
        } else {
            c
        }
    };
    Pose {
        x: r(p.x),
        y: r(p.y),
        z: r(p.z),
        yaw: r(p.yaw),
    }
}

impl Vm {
    fn num(&mut self) -> Result<f64, RuntimeErrorKind> {
        match self.pop()? {
            Value::Num(x) => Ok(x),
            _ => Err(RuntimeErrorKind::InvalidProgram("expected a number")),
        }
    }

    fn bool(&mut self) -> Result<bool, RuntimeErrorKind> {
        match self.pop()? {
            Value::Bool(b) => Ok(b),
            _ => Err(RuntimeErrorKind::InvalidProgram("expected a boolean")),
        }
    }

    fn pose(&mut self) -> Result<Pose, RuntimeErrorKind> {
        match self.pop()? {
            Value::Pose(p) => Ok(p),
            _ => Err(RuntimeErrorKind::InvalidProgram("expected a pose")),
        }
    }

    /// Pop a string and check it is a station name.
    fn station(
        &mut self,
        program: &Program,
    ) -> Result<InlineName<STATION_NAME_LEN>, RuntimeErrorKind> {
        let v = self.pop()?;
        match value::text_of(&v, &program.strings) {
            Some(text) => value::station(text),
            None => Err(RuntimeErrorKind::InvalidProgram("expected a string")),
        }
    }

    /// Pop a string into the text buffer.
    fn text_arg(&mut self, program: &Program) -> Result<(), RuntimeErrorKind> {
        let v = self.pop()?;
        let text = value::text_of(&v, &program.strings)
            .ok_or(RuntimeErrorKind::InvalidProgram("expected a string"))?;
        self.text.clear();
        let _ = self.text.write_str(text);
        Ok(())
    }

    fn binary(&mut self, f: impl FnOnce(Value, Value) -> Result<Value, RuntimeErrorKind>) -> Exec {
        let b = self.pop()?;
        let a = self.pop()?;
        let r = f(a, b)?;
        self.push(r)?;
        Ok(Flow::Next)
    }

    /// The running frame's first local slot.
    fn base(&self) -> Result<usize, RuntimeErrorKind> {
        self.frames
            .last()
            .map(|f| f.base as usize)
            .ok_or(RuntimeErrorKind::InvalidProgram("a local outside a SUB"))
    }

    /// Pop an array index and check it against `len`: the slot of the element.
    fn element(&mut self, local: bool, base: u32, len: u32) -> Result<usize, RuntimeErrorKind> {
        let i = self.num()?;
        self.check_index(i, len)?;
        let start = if local { self.base()? } else { 0 };
        Ok(start + base as usize + i as usize)
    }

    fn check_index(&mut self, i: f64, len: u32) -> Result<(), RuntimeErrorKind> {
        if i >= 0.0 && i.fract() == 0.0 && i < f64::from(len) {
            return Ok(());
        }
        // The message names the index and the bounds (raise keeps this text).
        let mut t = Text::EMPTY;
        let _ = write!(t, "array index ");
        let _ = super::write_number(&mut t, i);
        let _ = write!(t, " is outside 0 to {}", len.saturating_sub(1));
        self.pending_text = Some(t);
        Err(RuntimeErrorKind::IndexOutOfRange)
    }

    /// The option values of a motion (popped in reverse: zone, accel, speed).
    fn move_options(&mut self, flags: MoveFlags) -> Result<MoveOptions, RuntimeErrorKind> {
        let mut opts = MoveOptions::default();
        if flags.has(MoveFlags::ZONE) {
            opts.blend = Blend::Zone(value::zone(self.pop()?)?);
        } else if flags.has(MoveFlags::PASS) {
            opts.blend = Blend::Pass;
        }
        if flags.has(MoveFlags::ACCEL) {
            opts.accel_pct = Some(value::accel(self.pop()?)?);
        }
        if flags.has(MoveFlags::SPEED) {
            opts.speed_pct = Some(value::speed(self.pop()?)?);
        }
        Ok(opts)
    }

    fn motion(&mut self, motion: Motion, opts: MoveOptions) -> Exec {
        Ok(Flow::Yield(Request::Move(motion, opts), Awaiting::Nothing))
    }

    /// APPRO (`posture`: a PTP motion) or APPROS (`None`: a straight line): the pose moved
    /// back along the hand by the distance.
    fn approach(&mut self, f: MoveFlags, posture: Option<Option<wrc_robot::Posture>>) -> Exec {
        let opts = self.move_options(f)?;
        let d = value::distance(self.pop()?)?;
        let p = self.pose()?;
        let Value::Pose(target) = value::pose(builtins::reltool(&p, -d, 0.0, 0.0, 0.0))? else {
            return Err(RuntimeErrorKind::NotFinite);
        };
        let motion = match posture {
            Some(posture) => Motion::Pose(target, posture),
            None => Motion::Line(target),
        };
        self.motion(motion, opts)
    }

    fn call(&mut self, program: &Program, routine: u32, args: u8) -> Result<(), RuntimeErrorKind> {
        if self.frames.len() >= self.limits.call_depth {
            return Err(RuntimeErrorKind::CallTooDeep);
        }
        let r = program
            .routines
            .get(routine as usize)
            .ok_or(RuntimeErrorKind::InvalidProgram("routine index"))?;
        let base = self.locals.len();
        if base + r.locals.len() > self.limits.locals {
            return Err(RuntimeErrorKind::CallTooDeep);
        }
        for v in &r.locals {
            self.locals.push(Value::zero(v.ty));
        }
        let n = usize::from(args);
        let from = self
            .stack
            .len()
            .checked_sub(n)
            .ok_or(RuntimeErrorKind::InvalidProgram("stack underflow"))?;
        for (k, v) in self.stack[from..].iter().enumerate() {
            self.locals[base + k] = *v;
        }
        self.stack.truncate(from);
        self.frames.push(Frame {
            ret: self.pc as u32,
            base: base as u32,
            routine,
        });
        self.pc = r.entry as usize;
        Ok(())
    }

    /// Return from the running call; `false` when there is none (the main program's end).
    fn ret(&mut self) -> bool {
        let Some(f) = self.frames.pop() else {
            return false;
        };
        self.locals.truncate(f.base as usize);
        self.drop_frame_handlers();
        self.pc = f.ret as usize;
        true
    }

    fn builtin(&mut self, program: &Program, b: Builtin, n: u8, io: &mut impl VmIo) -> Exec {
        let def = b.def();
        let n = usize::from(n).min(MAX_BUILTIN_ARGS);
        let mut args = [Value::Num(0.0); MAX_BUILTIN_ARGS];
        for slot in args[..n].iter_mut().rev() {
            *slot = self.pop()?;
        }
        let args = &args[..n];
        let value = match def.kind {
            Kind::Pure => b.eval(args, &program.strings)?,
            Kind::Io => match b {
                Builtin::Timer => value::num(io.seconds())?,
                Builtin::Here => Value::Pose(clean(io.here())),
                _ => {
                    let bit = value::bit(args[0])?;
                    Value::Bool(io.input(bit))
                }
            },
            Kind::Vm => {
                let caught = self.caught().copied();
                match b {
                    Builtin::Err => Value::Num(caught.map_or(0.0, |c| f64::from(c.code))),
                    Builtin::ErrLine => Value::Num(caught.map_or(0.0, |c| f64::from(c.pos.line))),
                    Builtin::ErrMsg => Value::Text(caught.map_or(Text::EMPTY, |c| c.text)),
                    _ => Value::Text(self.operator),
                }
            }
            Kind::Host => {
                let station = |v: &Value| -> Result<InlineName<16>, RuntimeErrorKind> {
                    value::station(value::text_of(v, &program.strings).unwrap_or(""))
                };
                let no_station =
                    InlineName::new("-").ok_or(RuntimeErrorKind::InvalidProgram("station name"))?;
                let (info, station, slot, blade_b) = match b {
                    Builtin::Slot => (
                        CellInfo::SlotState,
                        station(&args[0])?,
                        value::slot(args[1])?,
                        false,
                    ),
                    Builtin::Wafer => (
                        CellInfo::SlotWafer,
                        station(&args[0])?,
                        value::slot(args[1])?,
                        false,
                    ),
                    Builtin::Hand => (
                        CellInfo::HandWafer,
                        no_station,
                        0,
                        args.first() == Some(&Value::Num(1.0)),
                    ),
                    Builtin::Slots => (CellInfo::Slots, station(&args[0])?, 0, false),
                    Builtin::Pitch => (CellInfo::Pitch, station(&args[0])?, 0, false),
                    Builtin::Station => (CellInfo::Pose, station(&args[0])?, 0, false),
                    _ => (CellInfo::Approach, station(&args[0])?, 0, false),
                };
                let query = CellQuery {
                    info,
                    station,
                    slot,
                    blade_b,
                };
                return Ok(Flow::Yield(Request::Cell(query), Awaiting::Value(def.ret)));
            }
        };
        self.push(value)?;
        Ok(Flow::Next)
    }

    pub(super) fn exec(&mut self, program: &Program, instr: Instr, io: &mut impl VmIo) -> Exec {
        use Instr::*;
        let strings = &program.strings;
        match instr {
            Num(i) => {
                let x = program
                    .constants
                    .get(i as usize)
                    .copied()
                    .ok_or(RuntimeErrorKind::InvalidProgram("constant index"))?;
                self.push(Value::Num(x))?;
            }
            True => self.push(Value::Bool(true))?,
            False => self.push(Value::Bool(false))?,
            Str(i) => self.push(Value::Str(i))?,
            Load(i) => {
                let v = *self
                    .vars
                    .get(i as usize)
                    .ok_or(RuntimeErrorKind::InvalidProgram("variable index"))?;
                self.push(v)?;
            }
            Store(i) => {
                let v = self.pop()?;
                let slot = self
                    .vars
                    .get_mut(i as usize)
                    .ok_or(RuntimeErrorKind::InvalidProgram("variable index"))?;
                *slot = v;
            }
            LoadL(i) => {
                let at = self.base()? + i as usize;
                let v = *self
                    .locals
                    .get(at)
                    .ok_or(RuntimeErrorKind::InvalidProgram("local index"))?;
                self.push(v)?;
            }
            StoreL(i) => {
                let v = self.pop()?;
                let at = self.base()? + i as usize;
                let slot = self
                    .locals
                    .get_mut(at)
                    .ok_or(RuntimeErrorKind::InvalidProgram("local index"))?;
                *slot = v;
            }
            LoadElem { local, base, len } => {
                let at = self.element(local, base, len)?;
                let v = if local {
                    self.locals.get(at)
                } else {
                    self.vars.get(at)
                }
                .copied()
                .ok_or(RuntimeErrorKind::InvalidProgram("array index"))?;
                self.push(v)?;
            }
            StoreElem { local, base, len } => {
                let v = self.pop()?;
                let at = self.element(local, base, len)?;
                let slot = if local {
                    self.locals.get_mut(at)
                } else {
                    self.vars.get_mut(at)
                }
                .ok_or(RuntimeErrorKind::InvalidProgram("array index"))?;
                *slot = v;
            }
            CheckIndex(n) => {
                let i = match self.stack.last() {
                    Some(Value::Num(x)) => *x,
                    _ => return Err(RuntimeErrorKind::InvalidProgram("expected an index")),
                };
                self.check_index(i, n)?;
            }
            Neg => {
                let v = self.pop()?;
                self.push(value::negate(v)?)?;
            }
            Not => {
                let v = self.pop()?;
                self.push(value::not(v)?)?;
            }
            Add => return self.binary(|a, b| value::arith(Arith::Add, a, b, strings)),
            Sub => return self.binary(|a, b| value::arith(Arith::Sub, a, b, strings)),
            Mul => return self.binary(|a, b| value::arith(Arith::Mul, a, b, strings)),
            Div => return self.binary(|a, b| value::arith(Arith::Div, a, b, strings)),
            Mod => return self.binary(|a, b| value::arith(Arith::Mod, a, b, strings)),
            Eq => return self.binary(|a, b| value::compare(Cmp::Eq, a, b, strings)),
            Ne => return self.binary(|a, b| value::compare(Cmp::Ne, a, b, strings)),
            Lt => return self.binary(|a, b| value::compare(Cmp::Lt, a, b, strings)),
            Le => return self.binary(|a, b| value::compare(Cmp::Le, a, b, strings)),
            Gt => return self.binary(|a, b| value::compare(Cmp::Gt, a, b, strings)),
            Ge => return self.binary(|a, b| value::compare(Cmp::Ge, a, b, strings)),
            And => return self.binary(|a, b| value::logic(true, a, b)),
            Or => return self.binary(|a, b| value::logic(false, a, b)),
            Joints(n) => {
                let n = usize::from(n).min(MAX_AXES);
                let mut j = [0.0; MAX_AXES];
                for slot in j[..n].iter_mut().rev() {
                    *slot = self.num()?;
                }
                self.push(Value::Joints(j))?;
            }
            Pose => {
                let yaw = self.num()?;
                let z = self.num()?;
                let y = self.num()?;
                let x = self.num()?;
                self.push(value::pose(wrc_robot::Pose { x, y, z, yaw })?)?;
            }
            PoseField(i) => {
                let v = self.pop()?;
                self.push(value::pose_field(v, i)?)?;
            }
            JointField(i) => {
                let v = self.pop()?;
                self.push(value::joint_field(v, i)?)?;
            }
            Builtin(b, n) => return self.builtin(program, b, n, io),
            Here => {
                let p = clean(io.here());
                self.push(value::pose(p)?)?;
            }
            Input => {
                let n = value::bit(self.pop()?)?;
                self.push(Value::Bool(io.input(n)))?;
            }
            ForTest => {
                let step = self.num()?;
                let limit = self.num()?;
                let counter = self.num()?;
                let more = if step > 0.0 {
                    counter <= limit
                } else if step < 0.0 {
                    counter >= limit
                } else {
                    return Err(RuntimeErrorKind::BadArgument(
                        "FOR STEP 0 never ends the loop",
                    ));
                };
                self.push(Value::Bool(more))?;
            }
            Jump(t) => self.pc = t as usize,
            JumpIfFalse(t) => {
                if !self.bool()? {
                    self.pc = t as usize;
                }
            }
            Call { routine, args, .. } => self.call(program, routine, args)?,
            Ret => {
                if !self.ret() {
                    return Ok(Flow::Done);
                }
            }
            RetVal => {
                let v = self.pop()?;
                if !self.ret() {
                    return Ok(Flow::Done);
                }
                self.push(v)?;
            }
            NoReturn => {
                let name = self
                    .frames
                    .last()
                    .and_then(|f| program.routines.get(f.routine as usize))
                    .map_or("?", |r| r.name.as_str());
                let mut t = Text::EMPTY;
                let _ = write!(t, "FUNCTION {name} ended without RETURN");
                self.pending_text = Some(t);
                return Err(RuntimeErrorKind::NoReturn);
            }
            Pop => {
                self.pop()?;
            }
            Halt => return Ok(Flow::Done),
            TryBegin(catch) => self.try_begin(catch, self.pc - 1)?,
            TryEnd | CatchEnd => self.try_end(),
            Rethrow => return Err(RuntimeErrorKind::InvalidProgram("RETHROW is run by run()")),
            Retry => self.retry()?,
            Raise { text } => {
                let t = if text {
                    let v = self.pop()?;
                    Some(Text::cut(value::text_of(&v, strings).unwrap_or("")))
                } else {
                    None
                };
                let code = value::error_code(self.pop()?)?;
                let t = t.unwrap_or_else(|| {
                    let mut t = Text::EMPTY;
                    let _ = write!(t, "error {code} raised by the program");
                    t
                });
                self.pending_text = Some(t);
                return Err(RuntimeErrorKind::Raised { code });
            }
            Home(f) => {
                let opts = self.move_options(f)?;
                return self.motion(Motion::Home, opts);
            }
            MoveJ(f) => {
                let opts = self.move_options(f)?;
                match self.pop()? {
                    Value::Joints(j) => return self.motion(Motion::Joints(j), opts),
                    _ => return Err(RuntimeErrorKind::InvalidProgram("expected joints")),
                }
            }
            MoveP(posture, f) => {
                let opts = self.move_options(f)?;
                let p = self.pose()?;
                return self.motion(Motion::Pose(p, posture), opts);
            }
            MoveL(f) => {
                let opts = self.move_options(f)?;
                let p = self.pose()?;
                return self.motion(Motion::Line(p), opts);
            }
            Arc(f) => {
                let opts = self.move_options(f)?;
                let to = self.pose()?;
                let via = self.pose()?;
                return self.motion(Motion::Arc { via, to }, opts);
            }
            Appro(posture, f) => return self.approach(f, Some(posture)),
            Appros(f) => return self.approach(f, None),
            Depart(f) | Departs(f) => {
                let opts = self.move_options(f)?;
                let d = value::distance(self.pop()?)?;
                let here = clean(io.here());
                let target = value::pose(builtins::reltool(&here, -d, 0.0, 0.0, 0.0))?;
                let Value::Pose(target) = target else {
                    return Err(RuntimeErrorKind::NotFinite);
                };
                let motion = match instr {
                    Depart(_) => Motion::Pose(target, None),
                    _ => Motion::Line(target),
                };
                return self.motion(motion, opts);
            }
            Jog(axis, f) => {
                let opts = self.move_options(f)?;
                let pulses = value::pulses(self.pop()?)?;
                return self.motion(
                    Motion::Jog {
                        axis: usize::from(axis),
                        pulses,
                    },
                    opts,
                );
            }
            Speed => {
                let pct = value::speed(self.pop()?)?;
                return Ok(Flow::Yield(Request::Speed { pct }, Awaiting::Nothing));
            }
            Accel => {
                let pct = value::accel(self.pop()?)?;
                return Ok(Flow::Yield(Request::Accel { pct }, Awaiting::Nothing));
            }
            Delay => {
                let seconds = value::seconds(self.pop()?)?;
                return Ok(Flow::Yield(Request::Delay { seconds }, Awaiting::Nothing));
            }
            Out => {
                let on = value::level(self.pop()?)?;
                let n = value::bit(self.pop()?)?;
                return Ok(Flow::Yield(Request::Out { n, on }, Awaiting::Nothing));
            }
            Wait { timeout } => {
                let timeout_s = if timeout {
                    Some(value::seconds(self.pop()?)?)
                } else {
                    None
                };
                let value = value::level(self.pop()?)?;
                let n = value::bit(self.pop()?)?;
                return Ok(Flow::Yield(
                    Request::WaitInput {
                        n,
                        value,
                        timeout_s,
                    },
                    Awaiting::Nothing,
                ));
            }
            Print(n) => {
                let n = usize::from(n);
                let start = self
                    .stack
                    .len()
                    .checked_sub(n)
                    .ok_or(RuntimeErrorKind::InvalidProgram("stack underflow"))?;
                self.text.clear();
                for (i, v) in self.stack[start..].iter().enumerate() {
                    if i > 0 {
                        let _ = self.text.write_str(" ");
                    }
                    let _ = write_value(&mut self.text, program, v, false);
                }
                self.stack.truncate(start);
                return Ok(Flow::Yield(Request::Print, Awaiting::Nothing));
            }
            Get | Put | GetB | PutB | Swap => {
                let slot = self.pop()?;
                let station = self.station(program)?;
                let slot = value::slot(slot)?;
                let kind = if matches!(instr, Get | GetB) {
                    TransferKind::Get
                } else {
                    TransferKind::Put
                };
                let request = if instr == Swap {
                    Request::Swap { station, slot }
                } else {
                    Request::Transfer {
                        kind,
                        station,
                        slot,
                        blade_b: matches!(instr, GetB | PutB),
                    }
                };
                return Ok(Flow::Yield(request, Awaiting::Nothing));
            }
            Map => {
                let station = self.station(program)?;
                return Ok(Flow::Yield(Request::Map { station }, Awaiting::Nothing));
            }
            WaitOperator { text } => {
                if text {
                    self.text_arg(program)?;
                } else {
                    self.text.clear();
                }
                return Ok(Flow::Yield(Request::Operator, Awaiting::Operator));
            }
            Alarm => {
                self.text_arg(program)?;
                let code = value::error_code(self.pop()?)?;
                return Ok(Flow::Yield(Request::Alarm { code }, Awaiting::Nothing));
            }
            Reset => return Ok(Flow::Yield(Request::Reset, Awaiting::Nothing)),
            Teach(i) => {
                let v = program
                    .variables
                    .get(i as usize)
                    .ok_or(RuntimeErrorKind::InvalidProgram("variable index"))?;
                let point = InlineName::new(&v.name).ok_or(RuntimeErrorKind::BadArgument(
                    "a point's name is 1 to 32 characters",
                ))?;
                let joints = v.ty == Ty::Joints;
                // The point is in the points file of the program whose code runs: the
                // nearest called program on the call stack (a SUB is called only from its
                // own program), else the program run.
                let program_name = self
                    .frames
                    .iter()
                    .rev()
                    .find_map(|f| {
                        program
                            .routines
                            .get(f.routine as usize)
                            .and_then(|r| r.name.strip_prefix("PROGRAM "))
                    })
                    .and_then(InlineName::new);
                return Ok(Flow::Yield(
                    Request::Teach {
                        point,
                        joints,
                        program: program_name,
                    },
                    Awaiting::Value(v.ty),
                ));
            }
        }
        Ok(Flow::Next)
    }
}
