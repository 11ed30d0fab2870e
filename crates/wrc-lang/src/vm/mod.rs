//! The VM: runs a [`Program`] inside the Command Interpreter's real-time cycle.
//!
//! [`Vm::new`] allocates everything once (expression stack, global variables, the frames'
//! local slots, call and TRY stacks, text buffers). After that, [`Vm::load`], [`Vm::run`],
//! [`Vm::resume`] and the debugger's calls never allocate, block, sleep or print: `run`
//! executes at most a budget of instructions and returns a [`Step`] — ran out of budget,
//! yielded a [`Request`] to the host (a move, a delay, an input wait, a line of text, an
//! output, a wafer transfer, a question about the cell, an alarm, the operator…), stopped
//! at a breakpoint or the end of a single step, finished, or faulted. The host owns all
//! timing and I/O.
//!
//! Errors: a run-time error (in the program, or a request the host could not carry out)
//! goes to the innermost `TRY` whose `CATCH` takes its code; only an error no TRY catches
//! ends the program with [`Step::Fault`].

mod debug;
mod exec;
mod format;
mod handlers;

use wrc_robot::{InlineName, Joints, Pose, Posture};

use crate::bytecode::Program;
pub use crate::bytecode::SourcePos;
use crate::error::{LoadError, RuntimeError, RuntimeErrorKind};
use crate::value::{Text, Ty, Value};
pub use debug::{StepMode, VarView, MAX_BREAKPOINTS};
use format::TextBuffer;
pub(crate) use format::{write_number, ProgramNum};

/// Size of the text buffer of PRINT, ALARM and WAIT OPERATOR [bytes]; longer text is cut
/// at a character boundary.
pub const PRINT_CAPACITY: usize = 256;

/// Size of the last error's text [bytes] ([`Vm::error_text`]: a host's refusal names the
/// axis, where along the line and the pose); `ERRMSG$` gives its first
/// [`crate::TEXT_CAPACITY`] bytes.
pub const ERROR_TEXT_CAPACITY: usize = 400;

/// How much a VM holds, fixed when it is created.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VmLimits {
    /// Expression stack [values].
    pub stack: usize,
    /// Global variable slots (variables, array elements, hidden slots).
    pub variables: usize,
    /// Deepest nesting of SUB and FUNCTION calls.
    pub call_depth: usize,
    /// Local slots of all the frames of the calls under way together.
    pub locals: usize,
    /// TRY blocks under way at once (nested, also across calls).
    pub handlers: usize,
}

impl Default for VmLimits {
    /// 256 stack values, 4096 global slots, 64 nested calls, 2048 local slots, 32 TRY
    /// blocks: about 900 KiB.
    fn default() -> VmLimits {
        VmLimits {
            stack: 256,
            variables: 4096,
            call_depth: 64,
            locals: 2048,
            handlers: 32,
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
    /// Seconds since the program started [s] (`TIMER()`); 0 if the host keeps no time.
    fn seconds(&self) -> f64 {
        0.0
    }
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
    /// Circular arc of the tool centre point through `via` to `to` [mm, deg].
    Arc {
        /// A pose the arc passes through (it sets the circle).
        via: Pose,
        /// Where the arc ends.
        to: Pose,
    },
    /// Move one axis (0-based index) by a signed number of pulses.
    Jog {
        /// Axis index [0-based].
        axis: usize,
        /// Pulses (negative: backwards).
        pulses: i64,
    },
}

/// Whether a motion stops at its target.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Blend {
    /// It stops at its target (the default).
    #[default]
    Stop,
    /// `BLEND` on a PTP motion: it passes its target moving into the next motion.
    Pass,
    /// `BLEND mm` on a Cartesian motion: it rounds the corner into the next motion within
    /// this distance of the target [mm].
    Zone(f64),
}

/// A motion statement's options.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MoveOptions {
    /// `SPEED pct` of this motion [%], else the override in force.
    pub speed_pct: Option<f64>,
    /// `ACCEL pct` of this motion [%], else the acceleration override in force.
    pub accel_pct: Option<f64>,
    /// `BLEND`: does it stop at its target?
    pub blend: Blend,
}

/// What a question about the cell asks (`SLOT`, `WAFER$`, … of [`Request::Cell`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum CellInfo {
    /// `SLOT(station, n)`: the wafer map's state of a slot (a number: 0 empty, 1 a wafer,
    /// 2 a double wafer, 3 a cross-slotted one, -1 not mapped).
    SlotState,
    /// `WAFER$(station, n)`: the id of the wafer in a slot, or "" (text).
    SlotWafer,
    /// `HAND$([A|B])`: the id of the wafer on the blade, or "" (text).
    HandWafer,
    /// `SLOTS(station)`: the slot count (a number).
    Slots,
    /// `PITCH(station)`: the slot pitch [mm] (a number).
    Pitch,
    /// `STATION(station)`: the taught pose (a pose).
    Pose,
    /// `APPROACH(station)`: the approach distance [mm] (a number).
    Approach,
}

/// A question about the cell: what, and of which station, slot or blade.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellQuery {
    /// What is asked.
    pub info: CellInfo,
    /// The station (empty for `HAND$`).
    pub station: InlineName<16>,
    /// The slot, from 1 (0 when the question names none).
    pub slot: u16,
    /// `HAND$(B)`: blade B; otherwise the hand, blade A.
    pub blade_b: bool,
}

/// Which way a [`Request::Transfer`] moves a wafer: the cell's own kind (its `as_str` is the
/// statement's keyword, `GET` or `PUT`).
pub use wrc_cell::TransferKind;

/// What the program waits for the host to do. After carrying it out the host calls
/// [`Vm::resume`]; until then [`Vm::run`] returns the same request again.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Request {
    /// Carry out a motion with its options; resume when it finished (or failed). A motion
    /// with [`Blend::Pass`] or [`Blend::Zone`] does not stop at its target: the host
    /// answers at once (the program goes on to its next motion, which the host blends
    /// into) and reports a failure with a later request.
    Move(Motion, MoveOptions),
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
    /// Set the acceleration override for later moves [%].
    Accel {
        /// 1-100 [%].
        pct: f64,
    },
    /// Move a wafer between a station slot and the hand; resume when it finished (or
    /// failed: [`Vm::fail`] with the host's code).
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
    /// A question about the wafer map or a station; resume with
    /// [`Resume::Value`] carrying the answer (a number, a text or a pose, as
    /// [`CellInfo`] says), or [`Vm::fail`] (an unknown station: 130).
    Cell(CellQuery),
    /// `WAIT OPERATOR [text]`: show [`Vm::print_text`] to the operator and wait until they
    /// answer (`CONTINUE [word]`); resume with [`Resume::Ok`] or, with their word,
    /// [`Resume::Value`]`(Answer::Text(…))` (`OPERATOR$` reads it).
    Operator,
    /// `ALARM code, text`: tell every host and the GUI ([`Vm::print_text`] is the text);
    /// resume at once.
    Alarm {
        /// The alarm's code.
        code: u16,
    },
    /// `RESET`: clear the alarm the program caught (as a host's RESET); resume when done,
    /// or fail with the host's code.
    Reset,
    /// `TEACH point`: store where the robot is as the named point; resume with
    /// [`Resume::Value`] carrying the pose (or, for a point of joints, the joints) stored.
    Teach {
        /// The point's name.
        point: InlineName<32>,
        /// A point of joints (else a pose).
        joints: bool,
        /// The called program (`CALL PROGRAM`) whose point it is; `None`: the program run.
        program: Option<InlineName<32>>,
    },
}

/// A value the host answers a [`Request::Cell`], [`Request::Teach`] or
/// [`Request::Operator`] with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Answer {
    /// A number.
    Number(f64),
    /// A text.
    Text(Text),
    /// A pose.
    Pose(Pose),
    /// Joint positions.
    Joints(Joints),
}

/// How the host answers a [`Request`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Resume {
    /// Done: the move finished, the delay elapsed, the input matched, the text was printed…
    Ok,
    /// Done, with the answer the request asked for.
    Value(Answer),
    /// It failed; the next [`Vm::run`] raises this error at the requesting statement (a
    /// TRY may catch it). [`Vm::fail`] does the same with the host's code and text.
    Failed(RuntimeErrorKind),
}

/// The outcome of [`Vm::run`]: a status, not an error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// The budget ran out; call `run` again (next cycle).
    Budget,
    /// The program waits for the host: carry out the request, then [`Vm::resume`].
    Yield(Request),
    /// The program stopped at a breakpoint, or where a single step ends
    /// ([`Vm::step`]), before running the statement at this position; call `run` to go on.
    Break(SourcePos),
    /// The program ended (END, the end of the main program, or [`Vm::abort`]).
    Done,
    /// The program stopped with an error no TRY caught ([`Vm::error_text`] says what); it
    /// stays stopped until the next [`Vm::load`].
    Fault(RuntimeError),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Empty,
    Running,
    Waiting(Request),
    /// The host failed the request: raise this at the next `run`.
    Failing(RuntimeErrorKind),
    Done,
    Faulted(RuntimeError),
}

/// What a yielding instruction does with the host's answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Awaiting {
    /// Nothing: [`Resume::Ok`].
    Nothing,
    /// A value of this type, pushed on the stack.
    Value(Ty),
    /// The operator's word (kept for `OPERATOR$`).
    Operator,
}

/// A call under way.
#[derive(Debug, Clone, Copy)]
struct Frame {
    /// Where the caller goes on.
    ret: u32,
    /// Its first local slot.
    base: u32,
    /// The routine.
    routine: u32,
}

/// An error being handled: its code, where it happened, its text, and the statement RETRY
/// runs again.
#[derive(Debug, Clone, Copy)]
struct Caught {
    kind: RuntimeErrorKind,
    code: u16,
    pos: SourcePos,
    retry_pc: u32,
    text: Text,
}

/// A TRY under way.
#[derive(Debug, Clone, Copy)]
struct Handler {
    /// Its CATCH dispatch.
    catch_pc: u32,
    /// Its TRY instruction (the statement RETRY runs when an inner TRY passes the error on).
    try_pc: u32,
    /// The call depth it was entered at.
    frames: u32,
    /// The stack depth it was entered at.
    stack: u32,
    /// The error its CATCH is handling, while one is.
    caught: Option<Caught>,
}

/// The bytecode interpreter. See the [module docs](self).
///
/// ```
/// use wrc_lang::{compile, Motion, MoveOptions, Request, Resume, Step, Vm, VmIo, VmLimits};
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
/// assert_eq!(
///     vm.run(&program, 100, &mut Io),
///     Step::Yield(Request::Move(Motion::Line(line), MoveOptions::default()))
/// );
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
    locals: Vec<Value>,
    frames: Vec<Frame>,
    handlers: Vec<Handler>,
    pc: usize,
    state: State,
    awaiting: Awaiting,
    program_id: u64,
    /// The instruction that yielded (or raised), and its position.
    yield_pc: usize,
    yield_pos: SourcePos,
    text: TextBuffer,
    /// The last error's text (the fault's; `ERRMSG$` has its start).
    error_text: TextBuffer,
    /// The operator's last answer (`OPERATOR$`).
    operator: Text,
    /// The text of the error the instruction being executed raises, when it has its own
    /// (an index, RAISE's text).
    pending_text: Option<Text>,
    debug: debug::Debugger,
}

enum Flow {
    Next,
    Yield(Request, Awaiting),
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
            locals: Vec::with_capacity(limits.locals),
            frames: Vec::with_capacity(limits.call_depth),
            handlers: Vec::with_capacity(limits.handlers),
            pc: 0,
            state: State::Empty,
            awaiting: Awaiting::Nothing,
            program_id: 0,
            yield_pc: 0,
            yield_pos: SourcePos::default(),
            text: TextBuffer::new(PRINT_CAPACITY),
            error_text: TextBuffer::new(ERROR_TEXT_CAPACITY),
            operator: Text::EMPTY,
            pending_text: None,
            debug: debug::Debugger::default(),
        }
    }

    /// The limits the VM was created with.
    pub fn limits(&self) -> VmLimits {
        self.limits
    }

    /// Check that `program` fits and start it from the beginning: variables hold their
    /// type's zero (0, FALSE, "", a zero pose or joints), named points their points file's
    /// value. Breakpoints are kept (they are the host's); a single step is not. Does not
    /// allocate.
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
        if program.max_frame() > self.limits.locals {
            return Err(LoadError::FrameTooLarge {
                needed: program.max_frame(),
                limit: self.limits.locals,
            });
        }
        self.stack.clear();
        self.frames.clear();
        self.locals.clear();
        self.handlers.clear();
        self.vars.clear();
        for v in program.variables() {
            self.vars.push(match v.init {
                Some(crate::bytecode::Init::Pose(p)) => Value::Pose(p),
                Some(crate::bytecode::Init::Joints(j)) => Value::Joints(j),
                None => Value::zero(v.ty),
            });
        }
        self.pc = 0;
        self.state = State::Running;
        self.awaiting = Awaiting::Nothing;
        self.program_id = program.id;
        self.yield_pc = 0;
        self.yield_pos = SourcePos::default();
        self.text.clear();
        self.error_text.clear();
        self.operator = Text::EMPTY;
        self.debug.new_run();
        Ok(())
    }

    /// End the program: `run` returns [`Step::Done`] until the next [`Vm::load`].
    pub fn abort(&mut self) {
        self.stack.clear();
        self.frames.clear();
        self.locals.clear();
        self.handlers.clear();
        if self.state != State::Empty {
            self.state = State::Done;
        }
    }

    /// Answer the request of the last [`Step::Yield`]. Ignored when the VM is not waiting.
    pub fn resume(&mut self, resume: Resume) {
        let State::Waiting(_) = self.state else {
            return;
        };
        let awaiting = std::mem::replace(&mut self.awaiting, Awaiting::Nothing);
        self.state = match resume {
            Resume::Failed(kind) => {
                handlers::set_text(&mut self.error_text, kind, None);
                State::Failing(kind)
            }
            Resume::Ok => match awaiting {
                Awaiting::Value(_) => State::Failing(RuntimeErrorKind::InvalidProgram(
                    "the host answered a question without a value",
                )),
                Awaiting::Operator => {
                    self.operator = Text::EMPTY;
                    State::Running
                }
                Awaiting::Nothing => State::Running,
            },
            Resume::Value(answer) => {
                let value = match answer {
                    Answer::Number(x) => Value::Num(x),
                    Answer::Text(t) => Value::Text(t),
                    Answer::Pose(p) => Value::Pose(p),
                    Answer::Joints(j) => Value::Joints(j),
                };
                match awaiting {
                    Awaiting::Value(ty) if value.ty() == ty && finite(&value) => {
                        match self.push(value) {
                            Ok(()) => State::Running,
                            Err(kind) => State::Failing(kind),
                        }
                    }
                    Awaiting::Value(_) => State::Failing(RuntimeErrorKind::InvalidProgram(
                        "the host answered a question with a value of another type",
                    )),
                    Awaiting::Operator => {
                        if let Value::Text(t) = value {
                            self.operator = t;
                        }
                        State::Running
                    }
                    Awaiting::Nothing => State::Running,
                }
            }
        };
    }

    /// Fail the request of the last [`Step::Yield`] with the host's `code` and `text`
    /// ([`RuntimeErrorKind::Host`]): a TRY whose CATCH takes `code` handles it (`ERR` is
    /// `code`, `ERRMSG$` `text`); otherwise the program ends with it. Ignored when the VM
    /// is not waiting.
    pub fn fail(&mut self, code: u16, text: &str) {
        if let State::Waiting(_) = self.state {
            self.awaiting = Awaiting::Nothing;
            let kind = RuntimeErrorKind::Host { code };
            handlers::set_text(&mut self.error_text, kind, Some(text));
            self.state = State::Failing(kind);
        }
    }

    /// The text of the last [`Request::Print`], [`Request::Alarm`] or
    /// [`Request::Operator`]: the items formatted and separated by one space, cut at
    /// [`PRINT_CAPACITY`] bytes.
    pub fn print_text(&self) -> &str {
        self.text.as_str()
    }

    /// The text of the last error: the one being handled (`ERRMSG$`) or the one the program
    /// ended with ([`Step::Fault`]).
    pub fn error_text(&self) -> &str {
        self.error_text.as_str()
    }

    /// The last error's code (`ERR`'s, the fault's), 0 before any.
    pub fn error_code(&self) -> u16 {
        match self.state {
            State::Faulted(e) => e.kind.code(),
            _ => self.caught().map_or(0, |c| c.code),
        }
    }

    /// `true` while a [`Request`] waits for [`Vm::resume`].
    pub fn is_waiting(&self) -> bool {
        matches!(self.state, State::Waiting(_))
    }

    /// Where the program is: the statement it waits on, or the next instruction to run.
    pub fn position(&self, program: &Program) -> Option<SourcePos> {
        match self.state {
            State::Waiting(_) | State::Failing(_) => Some(self.yield_pos),
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
                    file: 0,
                })
            }
            State::Waiting(r) => return Step::Yield(r),
            State::Done => return Step::Done,
            State::Faulted(e) => return Step::Fault(e),
            State::Running | State::Failing(_) => {}
        }
        if program.id != self.program_id {
            return Step::Fault(RuntimeError {
                kind: RuntimeErrorKind::NotLoaded,
                line: 0,
                col: 0,
                file: 0,
            });
        }
        if let State::Failing(kind) = self.state {
            // The text is the host's (set by `fail` or `resume`).
            self.state = State::Running;
            if let Some(step) = self.raise_kept(program, kind, self.yield_pc) {
                return step;
            }
        }
        for _ in 0..budget {
            let pc = self.pc;
            if self.debug.armed() {
                if let Some(pos) = self.debug.stop_here(program, pc, self.frames.len()) {
                    return Step::Break(pos);
                }
            }
            let Some(&instr) = program.code.get(pc) else {
                self.state = State::Done;
                return Step::Done;
            };
            self.pc = pc + 1;
            if matches!(instr, crate::bytecode::Instr::Rethrow) {
                if let Some(step) = self.rethrow(program) {
                    return step;
                }
                continue;
            }
            match self.exec(program, instr, io) {
                Ok(Flow::Next) => {}
                Ok(Flow::Yield(r, awaiting)) => {
                    self.yield_pc = pc;
                    self.yield_pos = program.position(pc).unwrap_or_default();
                    self.state = State::Waiting(r);
                    self.awaiting = awaiting;
                    return Step::Yield(r);
                }
                Ok(Flow::Done) => {
                    self.state = State::Done;
                    return Step::Done;
                }
                Err(kind) => {
                    let text = self.pending_text.take();
                    if let Some(step) =
                        self.raise(program, kind, pc, text.as_ref().map(Text::as_str))
                    {
                        return step;
                    }
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
}

/// Whether every number of a value is finite.
fn finite(v: &Value) -> bool {
    match v {
        Value::Num(x) => x.is_finite(),
        Value::Pose(p) => [p.x, p.y, p.z, p.yaw].iter().all(|x| x.is_finite()),
        Value::Joints(j) => j.iter().all(|x| x.is_finite()),
        Value::Bool(_) | Value::Str(_) | Value::Text(_) => true,
    }
}
