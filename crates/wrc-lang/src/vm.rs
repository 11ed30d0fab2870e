//! The VM: runs a [`Program`] inside the Command Interpreter's real-time cycle.
//!
//! [`Vm::new`] allocates everything once (stack, variables, call stack, PRINT buffer).
//! After that, [`Vm::load`], [`Vm::run`] and [`Vm::resume`] never allocate, block, sleep or
//! print: `run` executes at most a budget of instructions and returns a [`Step`] — ran out
//! of budget, yielded a [`Request`] to the host (a move, a delay, an input wait, a line of
//! text, an output, a speed, a wafer transfer or a slot scan), finished, or faulted. The
//! host owns all timing and I/O.

use core::fmt::{self, Write as _};

use wrc_robot::{InlineName, Joints, Pose, Posture, MAX_AXES};

use crate::bytecode::{Instr, Program, SourcePos};
use crate::error::{LoadError, RuntimeError, RuntimeErrorKind};
use crate::value::{self, Arith, Cmp, Value, STATION_NAME_LEN};

/// Size of the PRINT text buffer [bytes]; longer text is cut at a character boundary.
pub const PRINT_CAPACITY: usize = 256;

/// How much a VM holds, fixed when it is created.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VmLimits {
    /// Expression stack [values].
    pub stack: usize,
    /// Variable slots (user variables and two hidden slots per FOR loop).
    pub variables: usize,
    /// Deepest nesting of SUB calls.
    pub call_depth: usize,
}

impl Default for VmLimits {
    /// 256 stack values, 1024 variables, 64 nested calls: about 180 KiB.
    fn default() -> VmLimits {
        VmLimits {
            stack: 256,
            variables: 1024,
            call_depth: 64,
        }
    }
}

/// Synchronous reads the VM makes while it runs (they must not block).
pub trait VmIo {
    /// Level of input bit `n` (0-31).
    fn input(&self, n: u8) -> bool;
    /// The current pose of the tool centre point (where the robot is, or where the last move
    /// ended).
    fn here(&self) -> Pose;
}

/// A motion the program asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Home every axis.
    Home,
    /// PTP in joint space; one value per axis [deg or mm], entries past the program's axis
    /// count are 0.
    Joints(Joints),
    /// PTP to a pose [mm, deg] with an elbow posture, or `None`: keep the current one.
    Pose(Pose, Option<Posture>),
    /// Straight line of the tool centre point to a pose [mm, deg].
    Line(Pose),
    /// Move one axis (0-based index) by a signed number of pulses.
    Jog {
        /// Axis index [0-based].
        axis: usize,
        /// Pulses (negative: backwards).
        pulses: i64,
    },
}

/// Which way a [`Request::Transfer`] moves a wafer: the cell's own kind (its `as_str` is the
/// statement's keyword, `GET` or `PUT`).
pub use wrc_cell::TransferKind;

/// What the program waits for the host to do. After carrying it out the host calls
/// [`Vm::resume`]; until then [`Vm::run`] returns the same request again.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Request {
    /// Carry out a motion; resume when it finished (or failed).
    Move(Motion),
    /// Resume after this long [s] (a host timer: the VM never sleeps).
    Delay {
        /// Duration [s], ≥ 0.
        seconds: f64,
    },
    /// Resume when input `n` has level `value`, or fail with
    /// [`RuntimeErrorKind::WaitTimeout`] after `timeout_s` [s].
    WaitInput {
        /// Input bit, 0-31.
        n: u8,
        /// The level to wait for.
        value: bool,
        /// Longest wait [s]; `None`: wait for ever.
        timeout_s: Option<f64>,
    },
    /// Print [`Vm::print_text`].
    Print,
    /// Set output `n` (0-31).
    Out {
        /// Output bit, 0-31.
        n: u8,
        /// On (1) or off (0).
        on: bool,
    },
    /// Set the speed override for later moves [%].
    Speed {
        /// 1-100 [%].
        pct: f64,
    },
    /// Move a wafer between a station slot and the hand; resume when it finished (or
    /// failed: [`RuntimeErrorKind::Transfer`] for a wafer-handling reason, with the host's
    /// code).
    Transfer {
        /// GET (slot → hand) or PUT (hand → slot).
        kind: TransferKind,
        /// The station, e.g. `LP1`, as the program wrote it (1-16 letters, digits, `_`,
        /// `-`; the VM checked that).
        station: InlineName<16>,
        /// The slot, from 1.
        slot: u16,
        /// Whether blade B makes it (a dual-blade robot's); the hand, blade A, otherwise.
        blade_b: bool,
    },
    /// A dual-blade robot's `SWAP`: take the slot's wafer with the empty blade, then put the
    /// other blade's wafer there; resume when it finished (or failed, like
    /// [`Request::Transfer`]).
    Swap {
        /// The station.
        station: InlineName<16>,
        /// The slot, from 1.
        slot: u16,
    },
    /// Scan a station's slots with the mapping sensor; resume when it finished (or failed,
    /// like [`Request::Transfer`]).
    Map {
        /// The station.
        station: InlineName<16>,
    },
}

/// How the host answers a [`Request`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Resume {
    /// Done: the move finished, the delay elapsed, the input matched, the text was printed…
    Ok,
    /// It failed; the next [`Vm::run`] returns this fault at the requesting statement's line
    /// (e.g. [`RuntimeErrorKind::Unreachable`], [`RuntimeErrorKind::WaitTimeout`],
    /// [`RuntimeErrorKind::Transfer`]).
    Failed(RuntimeErrorKind),
}

/// The outcome of [`Vm::run`]: a status, not an error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// The budget ran out; call `run` again (next cycle).
    Budget,
    /// The program waits for the host: carry out the request, then [`Vm::resume`].
    Yield(Request),
    /// The program ended (END, the end of the main program, or [`Vm::abort`]).
    Done,
    /// The program stopped with an error; it stays stopped until the next [`Vm::load`].
    Fault(RuntimeError),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Empty,
    Running,
    Waiting(Request),
    Done,
    Faulted(RuntimeError),
}

/// The bytecode interpreter. See the [module docs](self).
///
/// ```
/// use wrc_lang::{compile, Motion, Request, Resume, Step, Vm, VmIo, VmLimits};
/// use wrc_robot::{Pose, Robot};
///
/// struct Io;
/// impl VmIo for Io {
///     fn input(&self, _n: u8) -> bool { false }
///     fn here(&self) -> Pose { Pose::default() }
/// }
///
/// let robot = Robot::paper_default();
/// let compiled = compile("MOVEL POSE(300, 0, 0, 0)\nPRINT \"done\", 1 + 1\n", "demo.wrl", &robot);
/// let program = compiled.program.expect("compiles");
/// let mut vm = Vm::new(VmLimits::default());
/// vm.load(&program).unwrap();
/// let line = Pose { x: 300.0, y: 0.0, z: 0.0, yaw: 0.0 };
/// assert_eq!(vm.run(&program, 100, &mut Io), Step::Yield(Request::Move(Motion::Line(line))));
/// vm.resume(Resume::Ok); // the host finished the move
/// assert_eq!(vm.run(&program, 100, &mut Io), Step::Yield(Request::Print));
/// assert_eq!(vm.print_text(), "done 2");
/// vm.resume(Resume::Ok);
/// assert_eq!(vm.run(&program, 100, &mut Io), Step::Done);
/// ```
#[derive(Debug)]
pub struct Vm {
    limits: VmLimits,
    stack: Vec<Value>,
    vars: Vec<Value>,
    frames: Vec<u32>,
    pc: usize,
    state: State,
    program_id: u64,
    yield_pos: SourcePos,
    print: PrintBuffer,
}

enum Flow {
    Next,
    Yield(Request),
    Done,
}

type Exec = Result<Flow, RuntimeErrorKind>;

impl Vm {
    /// A VM with room for `limits`; the only allocation the VM ever makes.
    pub fn new(limits: VmLimits) -> Vm {
        Vm {
            limits,
            stack: Vec::with_capacity(limits.stack),
            vars: Vec::with_capacity(limits.variables),
            frames: Vec::with_capacity(limits.call_depth),
            pc: 0,
            state: State::Empty,
            program_id: 0,
            yield_pos: SourcePos::default(),
            print: PrintBuffer {
                bytes: vec![0; PRINT_CAPACITY].into_boxed_slice(),
                len: 0,
            },
        }
    }

    /// The limits the VM was created with.
    pub fn limits(&self) -> VmLimits {
        self.limits
    }

    /// Check that `program` fits and start it from the beginning: variables hold their
    /// type's zero (0, FALSE, "", a zero pose or joints). Does not allocate.
    pub fn load(&mut self, program: &Program) -> Result<(), LoadError> {
        if program.max_stack() > self.limits.stack {
            return Err(LoadError::StackTooSmall {
                needed: program.max_stack(),
                limit: self.limits.stack,
            });
        }
        if program.variable_count() > self.limits.variables {
            return Err(LoadError::TooManyVariables {
                needed: program.variable_count(),
                limit: self.limits.variables,
            });
        }
        self.stack.clear();
        self.frames.clear();
        self.vars.clear();
        for v in program.variables() {
            self.vars.push(Value::zero(v.ty));
        }
        self.pc = 0;
        self.state = State::Running;
        self.program_id = program.id;
        self.yield_pos = SourcePos::default();
        self.print.len = 0;
        Ok(())
    }

    /// End the program: `run` returns [`Step::Done`] until the next [`Vm::load`].
    pub fn abort(&mut self) {
        self.stack.clear();
        self.frames.clear();
        if self.state != State::Empty {
            self.state = State::Done;
        }
    }

    /// Answer the request of the last [`Step::Yield`]. Ignored when the VM is not waiting.
    pub fn resume(&mut self, resume: Resume) {
        if let State::Waiting(_) = self.state {
            self.state = match resume {
                Resume::Ok => State::Running,
                Resume::Failed(kind) => State::Faulted(RuntimeError {
                    kind,
                    line: self.yield_pos.line,
                    col: self.yield_pos.col,
                }),
            };
        }
    }

    /// The text of the last [`Request::Print`]: the items formatted and separated by one
    /// space, cut at [`PRINT_CAPACITY`] bytes.
    pub fn print_text(&self) -> &str {
        let bytes = self.print.bytes.get(..self.print.len).unwrap_or(&[]);
        core::str::from_utf8(bytes).unwrap_or("")
    }

    /// `true` while a [`Request`] waits for [`Vm::resume`].
    pub fn is_waiting(&self) -> bool {
        matches!(self.state, State::Waiting(_))
    }

    /// Where the program is: the statement it waits on, or the next instruction to run.
    pub fn position(&self, program: &Program) -> Option<SourcePos> {
        match self.state {
            State::Waiting(_) => Some(self.yield_pos),
            State::Running => program.position(self.pc),
            _ => None,
        }
    }

    /// Run at most `budget` instructions of `program` (the one given to [`Vm::load`]).
    /// Never allocates, blocks, sleeps or prints; reads inputs and the pose through `io`.
    pub fn run(&mut self, program: &Program, budget: u32, io: &mut impl VmIo) -> Step {
        match self.state {
            State::Empty => {
                return Step::Fault(RuntimeError {
                    kind: RuntimeErrorKind::NotLoaded,
                    line: 0,
                    col: 0,
                })
            }
            State::Waiting(r) => return Step::Yield(r),
            State::Done => return Step::Done,
            State::Faulted(e) => return Step::Fault(e),
            State::Running => {}
        }
        if program.id != self.program_id {
            return Step::Fault(RuntimeError {
                kind: RuntimeErrorKind::NotLoaded,
                line: 0,
                col: 0,
            });
        }
        for _ in 0..budget {
            let pc = self.pc;
            let Some(&instr) = program.code.get(pc) else {
                self.state = State::Done;
                return Step::Done;
            };
            self.pc = pc + 1;
            match self.exec(program, instr, io) {
                Ok(Flow::Next) => {}
                Ok(Flow::Yield(r)) => {
                    self.yield_pos = program.position(pc).unwrap_or_default();
                    self.state = State::Waiting(r);
                    return Step::Yield(r);
                }
                Ok(Flow::Done) => {
                    self.state = State::Done;
                    return Step::Done;
                }
                Err(kind) => {
                    let pos = program.position(pc).unwrap_or_default();
                    let e = RuntimeError {
                        kind,
                        line: pos.line,
                        col: pos.col,
                    };
                    self.state = State::Faulted(e);
                    return Step::Fault(e);
                }
            }
        }
        Step::Budget
    }

    fn push(&mut self, v: Value) -> Result<(), RuntimeErrorKind> {
        // The capacity was reserved in `new`: staying below the limit never reallocates.
        if self.stack.len() >= self.limits.stack {
            return Err(RuntimeErrorKind::StackOverflow);
        }
        self.stack.push(v);
        Ok(())
    }

    fn pop(&mut self) -> Result<Value, RuntimeErrorKind> {
        self.stack
            .pop()
            .ok_or(RuntimeErrorKind::InvalidProgram("stack underflow"))
    }

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
        match self.pop()? {
            // A string variable not assigned yet holds an index past the table: "".
            Value::Str(i) => {
                value::station(program.strings.get(i as usize).map_or("", |s| s.as_str()))
            }
            _ => Err(RuntimeErrorKind::InvalidProgram("expected a string")),
        }
    }

    fn binary(&mut self, f: impl FnOnce(Value, Value) -> Result<Value, RuntimeErrorKind>) -> Exec {
        let b = self.pop()?;
        let a = self.pop()?;
        let r = f(a, b)?;
        self.push(r)?;
        Ok(Flow::Next)
    }

    fn exec(&mut self, program: &Program, instr: Instr, io: &mut impl VmIo) -> Exec {
        use Instr::*;
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
            Neg => {
                let v = self.pop()?;
                self.push(value::negate(v)?)?;
            }
            Not => {
                let v = self.pop()?;
                self.push(value::not(v)?)?;
            }
            Add => return self.binary(|a, b| value::arith(Arith::Add, a, b)),
            Sub => return self.binary(|a, b| value::arith(Arith::Sub, a, b)),
            Mul => return self.binary(|a, b| value::arith(Arith::Mul, a, b)),
            Div => return self.binary(|a, b| value::arith(Arith::Div, a, b)),
            Eq => return self.binary(|a, b| value::compare(Cmp::Eq, a, b)),
            Ne => return self.binary(|a, b| value::compare(Cmp::Ne, a, b)),
            Lt => return self.binary(|a, b| value::compare(Cmp::Lt, a, b)),
            Le => return self.binary(|a, b| value::compare(Cmp::Le, a, b)),
            Gt => return self.binary(|a, b| value::compare(Cmp::Gt, a, b)),
            Ge => return self.binary(|a, b| value::compare(Cmp::Ge, a, b)),
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
                self.push(Value::Pose(wrc_robot::Pose { x, y, z, yaw }))?;
            }
            PoseField(i) => {
                let v = self.pop()?;
                self.push(value::pose_field(v, i)?)?;
            }
            JointField(i) => {
                let v = self.pop()?;
                self.push(value::joint_field(v, i)?)?;
            }
            Builtin(b) => {
                let (a, second) = if b.arity() == 2 {
                    let second = self.num()?;
                    (self.num()?, second)
                } else {
                    (self.num()?, 0.0)
                };
                self.push(b.apply(a, second)?)?;
            }
            Here => {
                let p = io.here();
                if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite() && p.yaw.is_finite()) {
                    return Err(RuntimeErrorKind::NotFinite);
                }
                self.push(Value::Pose(p))?;
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
            Call(t) => {
                if self.frames.len() >= self.limits.call_depth {
                    return Err(RuntimeErrorKind::CallTooDeep);
                }
                self.frames.push(self.pc as u32);
                self.pc = t as usize;
            }
            Ret => match self.frames.pop() {
                Some(back) => self.pc = back as usize,
                None => return Ok(Flow::Done),
            },
            Halt => return Ok(Flow::Done),
            Home => return Ok(Flow::Yield(Request::Move(Motion::Home))),
            MoveJ => match self.pop()? {
                Value::Joints(j) => return Ok(Flow::Yield(Request::Move(Motion::Joints(j)))),
                _ => return Err(RuntimeErrorKind::InvalidProgram("expected joints")),
            },
            MoveP(posture) => {
                let p = self.pose()?;
                return Ok(Flow::Yield(Request::Move(Motion::Pose(p, posture))));
            }
            MoveL => {
                let p = self.pose()?;
                return Ok(Flow::Yield(Request::Move(Motion::Line(p))));
            }
            Jog(axis) => {
                let pulses = value::pulses(self.pop()?)?;
                return Ok(Flow::Yield(Request::Move(Motion::Jog {
                    axis: usize::from(axis),
                    pulses,
                })));
            }
            Speed => {
                let pct = value::speed(self.pop()?)?;
                return Ok(Flow::Yield(Request::Speed { pct }));
            }
            Delay => {
                let seconds = value::seconds(self.pop()?)?;
                return Ok(Flow::Yield(Request::Delay { seconds }));
            }
            Out => {
                let on = value::level(self.pop()?)?;
                let n = value::bit(self.pop()?)?;
                return Ok(Flow::Yield(Request::Out { n, on }));
            }
            Wait { timeout } => {
                let timeout_s = if timeout {
                    Some(value::seconds(self.pop()?)?)
                } else {
                    None
                };
                let value = value::level(self.pop()?)?;
                let n = value::bit(self.pop()?)?;
                return Ok(Flow::Yield(Request::WaitInput {
                    n,
                    value,
                    timeout_s,
                }));
            }
            Print(n) => {
                let n = usize::from(n);
                let start = self
                    .stack
                    .len()
                    .checked_sub(n)
                    .ok_or(RuntimeErrorKind::InvalidProgram("stack underflow"))?;
                self.print.len = 0;
                for (i, v) in self.stack[start..].iter().enumerate() {
                    if i > 0 {
                        let _ = self.print.write_str(" ");
                    }
                    let _ = write_value(&mut self.print, program, v);
                }
                self.stack.truncate(start);
                return Ok(Flow::Yield(Request::Print));
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
                return Ok(Flow::Yield(if instr == Swap {
                    Request::Swap { station, slot }
                } else {
                    Request::Transfer {
                        kind,
                        station,
                        slot,
                        blade_b: matches!(instr, GetB | PutB),
                    }
                }));
            }
            Map => {
                let station = self.station(program)?;
                return Ok(Flow::Yield(Request::Map { station }));
            }
        }
        Ok(Flow::Next)
    }
}

/// The PRINT buffer: text is cut at its capacity, on a character boundary.
#[derive(Debug)]
struct PrintBuffer {
    bytes: Box<[u8]>,
    len: usize,
}

impl fmt::Write for PrintBuffer {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let room = self.bytes.len() - self.len;
        let mut take = s.len().min(room);
        while !s.is_char_boundary(take) {
            take -= 1;
        }
        self.bytes[self.len..self.len + take].copy_from_slice(&s.as_bytes()[..take]);
        self.len += take;
        Ok(())
    }
}

/// A small buffer on the stack for formatting one number.
struct StackText {
    bytes: [u8; 40],
    len: usize,
}

impl fmt::Write for StackText {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let end = self.len + s.len();
        if end > self.bytes.len() {
            return Err(fmt::Error);
        }
        self.bytes[self.len..end].copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

/// A number as PRINT shows it: whole numbers without a point, others with up to 6
/// decimals (trailing zeros dropped), very large or small ones in exponent form.
pub(crate) fn write_number(w: &mut impl fmt::Write, x: f64) -> fmt::Result {
    if x == 0.0 {
        return w.write_str("0");
    }
    if x.fract() == 0.0 && x.abs() < 1e15 {
        return write!(w, "{}", x as i64);
    }
    let a = x.abs();
    if !(1e-4..1e15).contains(&a) {
        return write!(w, "{x:e}");
    }
    let mut t = StackText {
        bytes: [0; 40],
        len: 0,
    };
    write!(t, "{x:.6}")?;
    let mut end = t.len;
    while end > 0 && t.bytes[end - 1] == b'0' {
        end -= 1;
    }
    if end > 0 && t.bytes[end - 1] == b'.' {
        end -= 1;
    }
    let text = core::str::from_utf8(&t.bytes[..end]).map_err(|_| fmt::Error)?;
    // "-0.0000001" rounds to "-0": print 0.
    if text == "-0" {
        return w.write_str("0");
    }
    w.write_str(text)
}

/// A number in the language's one format ([`write_number`]), for `format!` and `{}`: what
/// the checker's messages quote is what PRINT would show.
pub(crate) struct ProgramNum(pub f64);

impl fmt::Display for ProgramNum {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_number(f, self.0)
    }
}

fn write_value(w: &mut impl fmt::Write, program: &Program, v: &Value) -> fmt::Result {
    match v {
        Value::Num(x) => write_number(w, *x),
        Value::Bool(b) => w.write_str(if *b { "TRUE" } else { "FALSE" }),
        Value::Str(i) => w.write_str(program.strings.get(*i as usize).map_or("", |s| s.as_str())),
        Value::Pose(p) => {
            w.write_str("POSE(")?;
            for (i, x) in [p.x, p.y, p.z, p.yaw].into_iter().enumerate() {
                if i > 0 {
                    w.write_str(", ")?;
                }
                write_number(w, x)?;
            }
            w.write_str(")")
        }
        Value::Joints(j) => {
            w.write_str("JOINTS(")?;
            let n = program.axis_count().min(MAX_AXES);
            for (i, x) in j[..n].iter().enumerate() {
                if i > 0 {
                    w.write_str(", ")?;
                }
                write_number(w, *x)?;
            }
            w.write_str(")")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn num(x: f64) -> String {
        let mut s = String::new();
        write_number(&mut s, x).unwrap();
        s
    }

    #[test]
    fn numbers_print_short() {
        assert_eq!(num(3.0), "3");
        assert_eq!(num(-0.0), "0");
        assert_eq!(num(0.1 + 0.2), "0.3");
        assert_eq!(num(1.0 / 3.0), "0.333333");
        assert_eq!(num(-2.5), "-2.5");
        assert_eq!(num(1e20), "1e20");
        assert_eq!(num(1.5e-7), "1.5e-7");
        assert_eq!(num(0.99999999), "1");
    }

    #[test]
    fn the_print_buffer_cuts_on_a_character_boundary() {
        let mut b = PrintBuffer {
            bytes: vec![0; 5].into_boxed_slice(),
            len: 0,
        };
        b.write_str("abcé€").unwrap();
        assert_eq!(&b.bytes[..b.len], "abcé".as_bytes());
    }
}
