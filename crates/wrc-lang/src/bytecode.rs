//! The compiled program: a stack-machine instruction set, constant and string tables, the
//! source position of every instruction and where each statement starts, the SUBs and
//! FUNCTIONs with their frames, the global variables (with the named points' values) and
//! the source files; a human listing, JSON, and a versioned, checksummed binary form that is
//! fully verified when read back.

use std::fmt::Write as _;
use std::sync::atomic::{AtomicU64, Ordering};

use wrc_robot::{Joints, Pose, Posture, MAX_AXES};

pub use crate::builtins::Builtin;
use crate::error::DecodeError;
use crate::value::Ty;

/// Which options a motion instruction pops before its targets (flags of [`MoveFlags`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MoveFlags(pub u8);

impl MoveFlags {
    /// A SPEED value [%] is on the stack.
    pub const SPEED: u8 = 1;
    /// An ACCEL value [%] is on the stack.
    pub const ACCEL: u8 = 2;
    /// A BLEND zone [mm] is on the stack.
    pub const ZONE: u8 = 4;
    /// BLEND without a zone: a PTP motion passes its target moving.
    pub const PASS: u8 = 8;
    const ALL: u8 = 15;

    /// Whether `flag` is set.
    pub fn has(self, flag: u8) -> bool {
        self.0 & flag != 0
    }

    /// How many option values the instruction pops.
    pub fn values(self) -> u32 {
        (self.0 & (Self::SPEED | Self::ACCEL | Self::ZONE)).count_ones()
    }

    fn shown(self) -> String {
        let mut s = String::new();
        for (flag, word) in [
            (Self::SPEED, "SPEED"),
            (Self::ACCEL, "ACCEL"),
            (Self::ZONE, "BLEND mm"),
            (Self::PASS, "BLEND"),
        ] {
            if self.has(flag) {
                if !s.is_empty() {
                    s.push(' ');
                }
                s.push_str(word);
            }
        }
        s
    }
}

/// One instruction of the stack machine. Operands are indices into the program's tables or
/// instruction indices. Values are popped in the order they were pushed, last one first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Instr {
    /// Push constant number `#i`.
    Num(u32),
    /// Push TRUE.
    True,
    /// Push FALSE.
    False,
    /// Push string `$i`.
    Str(u32),
    /// Push global variable `i`.
    Load(u32),
    /// Pop into global variable `i`.
    Store(u32),
    /// Negate a number, pose or joints.
    Neg,
    /// Logical NOT.
    Not,
    /// `a + b` (numbers, poses, joints, strings).
    Add,
    /// `a - b` (numbers, poses, joints).
    Sub,
    /// `a * b`.
    Mul,
    /// `a / b`; division by zero is a fault.
    Div,
    /// `a = b`.
    Eq,
    /// `a <> b`.
    Ne,
    /// `a < b`.
    Lt,
    /// `a <= b`.
    Le,
    /// `a > b`.
    Gt,
    /// `a >= b`.
    Ge,
    /// `a AND b`.
    And,
    /// `a OR b`.
    Or,
    /// Pop `n` numbers (one per axis) and push joints.
    Joints(u8),
    /// Pop x, y, z, yaw and push a pose.
    Pose,
    /// Pop a pose and push field 0 x, 1 y, 2 z or 3 yaw.
    PoseField(u8),
    /// Pop joints and push joint `i` [0-based].
    JointField(u8),
    /// Pop the built-in's `n` arguments and push its result (a host's built-in first waits
    /// for the host's answer).
    Builtin(Builtin, u8),
    /// Push the current pose ([`VmIo::here`](crate::VmIo::here)).
    Here,
    /// Pop an input bit number, push its level ([`VmIo::input`](crate::VmIo::input)).
    Input,
    /// Pop step, limit, counter; push whether a FOR loop runs again (`counter <= limit` for a
    /// positive step, `>=` for a negative one; step 0 is a fault).
    ForTest,
    /// Continue at instruction `i`.
    Jump(u32),
    /// Pop a boolean; continue at instruction `i` if it is FALSE.
    JumpIfFalse(u32),
    /// Call routine `routine` (the SUB/FUNCTION table), popping its `args` arguments into
    /// its frame; a FUNCTION (`value`) pushes its result when it returns.
    Call {
        /// Index in the routine table.
        routine: u32,
        /// Arguments it pops.
        args: u8,
        /// It is a FUNCTION: it pushes a value.
        value: bool,
    },
    /// Return from a SUB.
    Ret,
    /// End the program.
    Halt,
    /// Yield a move home.
    Home(MoveFlags),
    /// Pop joints, yield a joint PTP move.
    MoveJ(MoveFlags),
    /// Pop a pose, yield a PTP move to it with a posture (or the current one).
    MoveP(Option<Posture>, MoveFlags),
    /// Pop a pose, yield a straight-line move to it.
    MoveL(MoveFlags),
    /// Pop pulses, yield a jog of axis `i` [0-based].
    Jog(u8, MoveFlags),
    /// Pop a speed [%], yield it.
    Speed,
    /// Pop seconds, yield a delay.
    Delay,
    /// Pop the level and the bit, yield an output change.
    Out,
    /// Pop the timeout [s] if there is one, the level and the bit; yield a wait for an input.
    Wait {
        /// A TIMEOUT was given.
        timeout: bool,
    },
    /// Pop `n` values, format them into the text buffer, yield.
    Print(u8),
    /// Pop the slot and the station, yield a GET (slot → hand).
    Get,
    /// Pop the slot and the station, yield a PUT (hand → slot).
    Put,
    /// Pop the station, yield a MAP (scan its slots).
    Map,
    /// Pop the slot and the station, yield a GET onto blade B (a dual-blade robot's).
    GetB,
    /// Pop the slot and the station, yield a PUT from blade B.
    PutB,
    /// Pop the slot and the station, yield a SWAP (the empty blade takes, the other puts).
    Swap,
    /// `a MOD b`: the remainder with the sign of b.
    Mod,
    /// Push local variable `i` of the running frame.
    LoadL(u32),
    /// Pop into local variable `i` of the running frame.
    StoreL(u32),
    /// Pop an index, push element `index` of the array at `base` (`len` elements; a local
    /// array of the frame if `local`); an index outside it is a fault.
    LoadElem {
        /// In the running frame (else a global).
        local: bool,
        /// The array's first slot.
        base: u32,
        /// Its number of elements.
        len: u32,
    },
    /// Pop a value and an index, store the value in element `index` of the array.
    StoreElem {
        /// In the running frame (else a global).
        local: bool,
        /// The array's first slot.
        base: u32,
        /// Its number of elements.
        len: u32,
    },
    /// Check that the index on top of the stack is a whole number below `n` (a dimension of
    /// a two-dimensional array); a fault otherwise.
    CheckIndex(u32),
    /// Pop the FUNCTION's value, return it to the caller.
    RetVal,
    /// A FUNCTION ended without RETURN: a fault.
    NoReturn,
    /// Drop the value on top of the stack (a FUNCTION called as a statement).
    Pop,
    /// Start a TRY: errors until its `TryEnd` go to the CATCH dispatch at instruction `i`.
    TryBegin(u32),
    /// The TRY block ended without an error: drop its handler.
    TryEnd,
    /// A CATCH clause ended: drop the handler it ran under.
    CatchEnd,
    /// No CATCH clause took the error: raise it again, to the TRY around this one.
    Rethrow,
    /// Run the failed statement of the innermost CATCH's TRY again.
    Retry,
    /// Pop the text if there is one and the code; raise that error.
    Raise {
        /// A text was given.
        text: bool,
    },
    /// Pop the target and the via pose, yield a circular move.
    Arc(MoveFlags),
    /// Pop the distance and the pose, yield a PTP move to the pose moved back along the
    /// hand by the distance.
    Appro(Option<Posture>, MoveFlags),
    /// The same as a straight line.
    Appros(MoveFlags),
    /// Pop a distance, yield a PTP move back along the hand from where the robot is.
    Depart(MoveFlags),
    /// The same as a straight line.
    Departs(MoveFlags),
    /// Pop an acceleration override [%], yield it.
    Accel,
    /// Pop the text if there is one; yield a wait for the operator.
    WaitOperator {
        /// A text was given.
        text: bool,
    },
    /// Pop the text and the code, yield an alarm to every host.
    Alarm,
    /// Yield a RESET of a caught alarm.
    Reset,
    /// Yield a TEACH of named point `i` (a global); push the host's answer (the point's
    /// new value, which a `Store` then keeps).
    Teach(u32),
}

/// `(pops, pushes)` of a motion with `flags` and `targets` target values.
fn motion(targets: u32, flags: MoveFlags) -> (u32, u32) {
    (targets + flags.values(), 0)
}

impl Instr {
    /// How many values the instruction pops and pushes.
    pub fn stack_effect(self) -> (u32, u32) {
        use Instr::*;
        match self {
            Num(_) | True | False | Str(_) | Load(_) | LoadL(_) | Here => (0, 1),
            Store(_) | StoreL(_) | Pop | RetVal => (1, 0),
            Neg | Not | PoseField(_) | JointField(_) | Input | CheckIndex(_) => (1, 1),
            LoadElem { .. } => (1, 1),
            StoreElem { .. } => (2, 0),
            Add | Sub | Mul | Div | Mod | Eq | Ne | Lt | Le | Gt | Ge | And | Or => (2, 1),
            Joints(n) => (u32::from(n), 1),
            Pose => (4, 1),
            Builtin(_, n) => (u32::from(n), 1),
            ForTest => (3, 1),
            Call { args, value, .. } => (u32::from(args), u32::from(value)),
            Jump(_) | Ret | Halt | NoReturn | TryBegin(_) | TryEnd | CatchEnd | Rethrow | Retry
            | Reset => (0, 0),
            Teach(_) => (0, 1),
            Home(f) => motion(0, f),
            MoveJ(f) | MoveP(_, f) | MoveL(f) | Jog(_, f) | Depart(f) | Departs(f) => motion(1, f),
            Arc(f) | Appro(_, f) | Appros(f) => motion(2, f),
            JumpIfFalse(_) | Speed | Accel | Delay | Map => (1, 0),
            Out | Get | Put | GetB | PutB | Swap | Alarm => (2, 0),
            Wait { timeout } => (if timeout { 3 } else { 2 }, 0),
            Print(n) => (u32::from(n), 0),
            Raise { text } => (1 + u32::from(text), 0),
            WaitOperator { text } => (u32::from(text), 0),
        }
    }

    /// The instruction's name in listings.
    pub fn mnemonic(self) -> &'static str {
        use Instr::*;
        match self {
            Num(_) => "NUM",
            True => "TRUE",
            False => "FALSE",
            Str(_) => "STR",
            Load(_) => "LOAD",
            Store(_) => "STORE",
            Neg => "NEG",
            Not => "NOT",
            Add => "ADD",
            Sub => "SUB",
            Mul => "MUL",
            Div => "DIV",
            Eq => "EQ",
            Ne => "NE",
            Lt => "LT",
            Le => "LE",
            Gt => "GT",
            Ge => "GE",
            And => "AND",
            Or => "OR",
            Joints(_) => "JOINTS",
            Pose => "POSE",
            PoseField(_) => "FIELD",
            JointField(_) => "JFIELD",
            Builtin(b, _) => b.name(),
            Here => "HERE",
            Input => "IN",
            ForTest => "FORTEST",
            Jump(_) => "JUMP",
            JumpIfFalse(_) => "JUMPF",
            Call { .. } => "CALL",
            Ret => "RET",
            Halt => "HALT",
            Home(_) => "HOME",
            MoveJ(_) => "MOVEJ",
            MoveP(..) => "MOVEP",
            MoveL(_) => "MOVEL",
            Jog(..) => "JOG",
            Speed => "SPEED",
            Delay => "DELAY",
            Out => "OUT",
            Wait { .. } => "WAIT",
            Print(_) => "PRINT",
            Get => "GET",
            Put => "PUT",
            Map => "MAP",
            GetB => "GETB",
            PutB => "PUTB",
            Swap => "SWAP",
            Mod => "MOD",
            LoadL(_) => "LOADL",
            StoreL(_) => "STOREL",
            LoadElem { .. } => "LOADE",
            StoreElem { .. } => "STOREE",
            CheckIndex(_) => "CHKIDX",
            RetVal => "RETVAL",
            NoReturn => "NORET",
            Pop => "POP",
            TryBegin(_) => "TRY",
            TryEnd => "TRYEND",
            CatchEnd => "CATCHEND",
            Rethrow => "RETHROW",
            Retry => "RETRY",
            Raise { .. } => "RAISE",
            Arc(_) => "ARC",
            Appro(..) => "APPRO",
            Appros(_) => "APPROS",
            Depart(_) => "DEPART",
            Departs(_) => "DEPARTS",
            Accel => "ACCEL",
            WaitOperator { .. } => "WAITOP",
            Alarm => "ALARM",
            Reset => "RESET",
            Teach(_) => "TEACH",
        }
    }
}

/// Where an instruction came from in the source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SourcePos {
    /// Line [1-based].
    pub line: u32,
    /// Column [1-based, characters].
    pub col: u32,
    /// The source file ([`Program::files`]; 0: the program's own).
    pub file: u16,
}

/// The value a named point starts with (from the points file).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Init {
    /// A pose.
    Pose(Pose),
    /// Joint positions.
    Joints(Joints),
}

/// A variable slot: a global of the program, or a slot of a routine's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Name, as first written; hidden slots are named after their statement.
    pub name: String,
    /// Its type (an array's elements' type).
    pub ty: Ty,
    /// A slot the compiler added (a FOR loop's limit and step, a SELECT CASE's value, an
    /// array's second and later elements), not a user variable.
    pub hidden: bool,
    /// Slots it takes: 1 for a variable, the element count for an array (which takes the
    /// slots after it too; those are hidden and have length 0).
    pub len: u32,
    /// A named point of the program's points file.
    pub point: bool,
    /// A point's value from the points file (it starts with it).
    pub init: Option<Init>,
}

/// A SUB, FUNCTION or called program: its entry and its frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Routine {
    /// Name, as written (`PROGRAM name` for a called program's main body).
    pub name: String,
    /// Index of its first instruction.
    pub entry: u32,
    /// Parameters: the frame's first slots.
    pub params: u16,
    /// The frame's slots: parameters, then locals (named and hidden).
    pub locals: Vec<Variable>,
    /// A FUNCTION's result type; `None` for a SUB.
    pub returns: Option<Ty>,
    /// Where it is defined.
    pub pos: SourcePos,
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// A compiled, verified program. Built by [`compile`](crate::compile) or
/// [`Program::from_bytes`]; run by [`Vm`](crate::Vm).
#[derive(Debug, Clone)]
pub struct Program {
    pub(crate) name: String,
    pub(crate) axes: u8,
    pub(crate) code: Vec<Instr>,
    pub(crate) positions: Vec<SourcePos>,
    pub(crate) constants: Vec<f64>,
    pub(crate) strings: Vec<String>,
    pub(crate) routines: Vec<Routine>,
    pub(crate) variables: Vec<Variable>,
    pub(crate) files: Vec<String>,
    /// The first instruction of every statement, ascending.
    pub(crate) statements: Vec<u32>,
    pub(crate) max_stack: u32,
    /// Identity for [`Vm::run`](crate::Vm::run)'s check that it runs the program it loaded;
    /// clones share it.
    pub(crate) id: u64,
}

impl PartialEq for Program {
    /// Same contents (the identity a VM checks is not compared).
    fn eq(&self, other: &Program) -> bool {
        self.name == other.name
            && self.axes == other.axes
            && self.code == other.code
            && self.positions == other.positions
            && self.constants.len() == other.constants.len()
            && self
                .constants
                .iter()
                .zip(&other.constants)
                .all(|(a, b)| a.to_bits() == b.to_bits())
            && self.strings == other.strings
            && self.routines == other.routines
            && self.variables == other.variables
            && self.files == other.files
            && self.statements == other.statements
            && self.max_stack == other.max_stack
    }
}

/// Version of the binary format [`Program::to_bytes`] writes.
pub const FORMAT_VERSION: u16 = 2;
const MAGIC: &[u8; 4] = b"WRCL";

pub(crate) fn next_id() -> u64 {
    NEXT_ID.fetch_add(1, Ordering::Relaxed)
}

impl Program {
    /// The program's name (the file it was compiled from).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The instructions.
    pub fn instructions(&self) -> &[Instr] {
        &self.code
    }

    /// Number of instructions.
    pub fn len(&self) -> usize {
        self.code.len()
    }

    /// `true` when there are no instructions.
    pub fn is_empty(&self) -> bool {
        self.code.is_empty()
    }

    /// The source position of instruction `pc`.
    pub fn position(&self, pc: usize) -> Option<SourcePos> {
        self.positions.get(pc).copied()
    }

    /// The number constants.
    pub fn constants(&self) -> &[f64] {
        &self.constants
    }

    /// The string table (string literals).
    pub fn strings(&self) -> &[String] {
        &self.strings
    }

    /// The SUBs, FUNCTIONs and called programs.
    pub fn routines(&self) -> &[Routine] {
        &self.routines
    }

    /// Every global slot, user variables first.
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// The source files: 0 is the program's own, then its libraries and the programs it
    /// calls.
    pub fn files(&self) -> &[String] {
        &self.files
    }

    /// The first instruction of every statement, ascending.
    pub fn statements(&self) -> &[u32] {
        &self.statements
    }

    /// Whether instruction `pc` starts a statement.
    pub fn starts_statement(&self, pc: usize) -> bool {
        u32::try_from(pc).is_ok_and(|pc| self.statements.binary_search(&pc).is_ok())
    }

    /// The start of the statement that instruction `pc` belongs to.
    pub(crate) fn statement_of(&self, pc: usize) -> usize {
        let pc = u32::try_from(pc).unwrap_or(u32::MAX);
        match self.statements.binary_search(&pc) {
            Ok(i) => self.statements[i] as usize,
            Err(0) => 0,
            Err(i) => self.statements[i - 1] as usize,
        }
    }

    /// The first statement on line `line` of file `file`, or, when that line has none, on
    /// the next line that has one: its first instruction and the line it is on.
    pub fn statement_at_line(&self, file: u16, line: u32) -> Option<(u32, u32)> {
        let mut best: Option<(u32, u32)> = None;
        for &pc in &self.statements {
            let pos = self.positions.get(pc as usize)?;
            if pos.file != file || pos.line < line {
                continue;
            }
            let better = match best {
                None => true,
                Some((_, l)) => pos.line < l,
            };
            if better {
                best = Some((pc, pos.line));
            }
        }
        best
    }

    /// The first instruction of the first statement on line `line` of the program's own
    /// file, if that line has one.
    pub fn statement_on_line(&self, line: u32) -> Option<u32> {
        self.statement_at_line(0, line)
            .filter(|&(_, l)| l == line)
            .map(|(pc, _)| pc)
    }

    /// Number of global slots the VM needs (user variables, arrays and hidden slots).
    pub fn variable_count(&self) -> usize {
        self.variables.len()
    }

    /// Number of variables the program names (without hidden slots).
    pub fn user_variable_count(&self) -> usize {
        self.variables.iter().filter(|v| !v.hidden).count()
    }

    /// Deepest expression stack one routine needs [values] (calls in expressions stack up).
    pub fn max_stack(&self) -> usize {
        self.max_stack as usize
    }

    /// Number of robot axes the program was compiled for (JOINTS values have this many).
    pub fn axis_count(&self) -> usize {
        usize::from(self.axes)
    }

    /// The largest frame of any routine [slots].
    pub fn max_frame(&self) -> usize {
        self.routines
            .iter()
            .map(|r| r.locals.len())
            .max()
            .unwrap_or(0)
    }

    fn operand(&self, instr: Instr) -> String {
        use Instr::*;
        let var = |i: u32| {
            self.variables
                .get(i as usize)
                .map_or("?", |v| v.name.as_str())
                .to_string()
        };
        let flags = |f: MoveFlags| f.shown();
        match instr {
            Num(i) => format!(
                "#{i:<6} ; {}",
                self.constants.get(i as usize).copied().unwrap_or(f64::NAN)
            ),
            Str(i) => format!(
                "${i:<6} ; {:?}",
                self.strings.get(i as usize).map_or("", |s| s.as_str())
            ),
            Load(i) | Store(i) | Teach(i) => format!("v{i:<6} ; {}", var(i)),
            LoadL(i) | StoreL(i) => format!("l{i}"),
            LoadElem { local, base, len } | StoreElem { local, base, len } => {
                let at = if local {
                    format!("l{base}")
                } else {
                    format!("v{base}")
                };
                let name = if local { String::new() } else { var(base) };
                format!("{at}[{len}] ; {name}")
            }
            CheckIndex(n) => format!("< {n}"),
            Joints(n) | Print(n) => n.to_string(),
            Builtin(_, n) => format!("{n}"),
            PoseField(i) => ["X", "Y", "Z", "YAW"]
                .get(usize::from(i))
                .unwrap_or(&"?")
                .to_string(),
            JointField(i) => format!("J{}", u32::from(i) + 1),
            Jog(a, f) => format!("axis {} {}", u32::from(a) + 1, flags(f)),
            Jump(t) | JumpIfFalse(t) | TryBegin(t) => format!("@{t:04}"),
            Call { routine, .. } => {
                let r = self.routines.get(routine as usize);
                format!(
                    "@{:04}  ; {}",
                    r.map_or(0, |r| r.entry),
                    r.map_or("?", |r| r.name.as_str())
                )
            }
            MoveP(Some(p), f) | Appro(Some(p), f) => format!("{} {}", p.letter(), flags(f)),
            Home(f)
            | MoveJ(f)
            | MoveP(None, f)
            | MoveL(f)
            | Arc(f)
            | Appro(None, f)
            | Appros(f)
            | Depart(f)
            | Departs(f) => flags(f),
            Wait { timeout: true } => "TIMEOUT".into(),
            Raise { text: true } | WaitOperator { text: true } => "TEXT".into(),
            _ => String::new(),
        }
    }

    /// A human listing: a header with the tables, then one instruction per line with its
    /// index, source `line:col`, mnemonic and operand.
    pub fn listing(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "; {}: {} instructions, {} variables, max stack {}, {} axes",
            self.name,
            self.code.len(),
            self.variables.len(),
            self.max_stack,
            self.axes
        );
        for (i, f) in self.files.iter().enumerate().skip(1) {
            let _ = writeln!(out, "; file {i} {f}");
        }
        for (i, v) in self.variables.iter().enumerate() {
            if v.len == 0 {
                continue;
            }
            let size = if v.len > 1 {
                format!("[{}]", v.len)
            } else {
                String::new()
            };
            let point = if v.point { " point" } else { "" };
            let _ = writeln!(out, "; v{i} {}{size} ({}){point}", v.name, v.ty);
        }
        for r in &self.routines {
            let kind = match r.returns {
                Some(ty) => format!("FUNCTION ({ty})"),
                None => "SUB".into(),
            };
            let _ = writeln!(
                out,
                "; {kind} {} @{:04}, {} parameters, frame {}",
                r.name,
                r.entry,
                r.params,
                r.locals.len()
            );
        }
        for (pc, instr) in self.code.iter().enumerate() {
            let pos = self.positions.get(pc).copied().unwrap_or_default();
            let at = if pos.file == 0 {
                format!("{}:{}", pos.line, pos.col)
            } else {
                format!("{}:{}:{}", pos.file, pos.line, pos.col)
            };
            let line = format!(
                "{pc:04}  {at:<8} {:<8} {}",
                instr.mnemonic(),
                self.operand(*instr)
            );
            let _ = writeln!(out, "{}", line.trim_end());
        }
        out
    }

    /// The program as JSON: format and version, name, axes, max stack, files, variables,
    /// constants, strings, routines, statement starts, and every instruction with its
    /// operand, a note resolving the operand and its source position.
    pub fn to_json(&self) -> String {
        #[derive(serde::Serialize)]
        struct Json<'a> {
            format: &'static str,
            version: u16,
            name: &'a str,
            axes: u8,
            max_stack: u32,
            files: &'a [String],
            variables: Vec<JsonVar<'a>>,
            constants: &'a [f64],
            strings: &'a [String],
            routines: Vec<JsonRoutine<'a>>,
            statements: &'a [u32],
            code: Vec<JsonInstr>,
        }
        #[derive(serde::Serialize)]
        struct JsonVar<'a> {
            name: &'a str,
            #[serde(rename = "type")]
            ty: &'static str,
            hidden: bool,
            len: u32,
            point: bool,
        }
        #[derive(serde::Serialize)]
        struct JsonRoutine<'a> {
            name: &'a str,
            entry: u32,
            params: u16,
            locals: Vec<JsonVar<'a>>,
            returns: Option<&'static str>,
        }
        #[derive(serde::Serialize)]
        struct JsonInstr {
            pc: usize,
            file: u16,
            line: u32,
            col: u32,
            op: &'static str,
            operand: String,
            note: String,
        }
        fn var(v: &Variable) -> JsonVar<'_> {
            JsonVar {
                name: v.name.as_str(),
                ty: v.ty.name(),
                hidden: v.hidden,
                len: v.len,
                point: v.point,
            }
        }
        let json = Json {
            format: "wrc-lang bytecode",
            version: FORMAT_VERSION,
            name: &self.name,
            axes: self.axes,
            max_stack: self.max_stack,
            files: &self.files,
            variables: self.variables.iter().map(var).collect(),
            constants: &self.constants,
            strings: &self.strings,
            routines: self
                .routines
                .iter()
                .map(|r| JsonRoutine {
                    name: &r.name,
                    entry: r.entry,
                    params: r.params,
                    locals: r.locals.iter().map(var).collect(),
                    returns: r.returns.map(Ty::name),
                })
                .collect(),
            statements: &self.statements,
            code: self
                .code
                .iter()
                .enumerate()
                .map(|(pc, instr)| {
                    let pos = self.positions.get(pc).copied().unwrap_or_default();
                    let text = self.operand(*instr);
                    let (operand, note) = match text.split_once(';') {
                        Some((o, n)) => (o.trim().to_string(), n.trim().to_string()),
                        None => (text.trim().to_string(), String::new()),
                    };
                    JsonInstr {
                        pc,
                        file: pos.file,
                        line: pos.line,
                        col: pos.col,
                        op: instr.mnemonic(),
                        operand,
                        note,
                    }
                })
                .collect(),
        };
        serde_json::to_string_pretty(&json).unwrap_or_default()
    }

    /// The binary form: magic `WRCL`, format version, the tables, the code, the source
    /// positions, the statement starts and an FNV-1a checksum. Integers are LEB128 varints,
    /// numbers f64 little-endian.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Vec::with_capacity(16 + self.code.len() * 4);
        w.extend_from_slice(MAGIC);
        w.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        w.push(self.axes);
        put_var(&mut w, self.max_stack);
        put_str(&mut w, &self.name);
        put_var(&mut w, self.files.len() as u32);
        for f in &self.files {
            put_str(&mut w, f);
        }
        put_variables(&mut w, &self.variables);
        put_var(&mut w, self.constants.len() as u32);
        for c in &self.constants {
            w.extend_from_slice(&c.to_le_bytes());
        }
        put_var(&mut w, self.strings.len() as u32);
        for s in &self.strings {
            put_str(&mut w, s);
        }
        put_var(&mut w, self.routines.len() as u32);
        for r in &self.routines {
            put_str(&mut w, &r.name);
            put_var(&mut w, r.entry);
            put_var(&mut w, u32::from(r.params));
            w.push(r.returns.map_or(255, Ty::code));
            put_pos(&mut w, r.pos);
            put_variables(&mut w, &r.locals);
        }
        put_var(&mut w, self.code.len() as u32);
        for instr in &self.code {
            encode(&mut w, *instr);
        }
        for pos in &self.positions {
            put_pos(&mut w, *pos);
        }
        put_var(&mut w, self.statements.len() as u32);
        let mut last = 0;
        for &s in &self.statements {
            put_var(&mut w, s - last);
            last = s;
        }
        let sum = fnv1a(&w);
        w.extend_from_slice(&sum.to_le_bytes());
        w
    }

    /// Read and verify a blob written by [`Program::to_bytes`]. Every field is checked —
    /// the checksum, every index, every jump target and the stack depth along every path —
    /// so a program that decodes cannot make the VM index out of bounds.
    pub fn from_bytes(bytes: &[u8]) -> Result<Program, DecodeError> {
        if bytes.len() < 4 || &bytes[..4] != MAGIC {
            return Err(DecodeError::BadMagic);
        }
        if bytes.len() < 6 {
            return Err(DecodeError::Truncated { what: "version" });
        }
        let version = u16::from_le_bytes([bytes[4], bytes[5]]);
        if version != FORMAT_VERSION {
            return Err(DecodeError::UnsupportedVersion {
                found: version,
                supported: FORMAT_VERSION,
            });
        }
        if bytes.len() < 6 + 8 {
            return Err(DecodeError::Truncated { what: "checksum" });
        }
        let (body, sum) = bytes.split_at(bytes.len() - 8);
        let mut sum_bytes = [0u8; 8];
        sum_bytes.copy_from_slice(sum);
        if fnv1a(body) != u64::from_le_bytes(sum_bytes) {
            return Err(DecodeError::BadChecksum);
        }
        let program = decode_body(body)?;
        program.verify()?;
        Ok(program)
    }

    /// Check every operand and the stack depth along every path.
    pub(crate) fn verify(&self) -> Result<(), DecodeError> {
        let invalid = |what, at| Err(DecodeError::Invalid { what, at });
        if self.axes == 0 || usize::from(self.axes) > MAX_AXES {
            return invalid("axis count outside 1..=16", 0);
        }
        if self.positions.len() != self.code.len() {
            return invalid("position table length", 0);
        }
        if self.files.is_empty() {
            return invalid("no source file", 0);
        }
        if let Some(i) = self.constants.iter().position(|c| !c.is_finite()) {
            return invalid("constant that is not a finite number", i);
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| usize::from(p.file) >= self.files.len())
        {
            return invalid("source file index", i);
        }
        let len = self.code.len();
        if self.statements.windows(2).any(|w| w[0] >= w[1])
            || self.statements.last().is_some_and(|&s| s as usize >= len)
        {
            return invalid("statement table", 0);
        }
        let globals = self.variables.len();
        if let Some(i) = arrays_fit(&self.variables) {
            return invalid("an array longer than the variable table", i);
        }
        for r in &self.routines {
            if r.entry as usize >= len {
                return invalid("routine entry outside the code", r.entry as usize);
            }
            if usize::from(r.params) > r.locals.len() || arrays_fit(&r.locals).is_some() {
                return invalid("routine frame", r.entry as usize);
            }
        }
        // Which routine each instruction belongs to (the main program's is `None`): a
        // local slot is checked against its own frame.
        let owner = self.owners();
        for (pc, instr) in self.code.iter().enumerate() {
            use Instr::*;
            let frame = owner[pc].map_or(0, |r| self.routines[r].locals.len());
            let ok = match *instr {
                Num(i) => (i as usize) < self.constants.len(),
                Str(i) => (i as usize) < self.strings.len(),
                Load(i) | Store(i) => (i as usize) < globals,
                Teach(i) => self.variables.get(i as usize).is_some_and(|v| v.point),
                LoadL(i) | StoreL(i) => (i as usize) < frame,
                LoadElem { local, base, len } | StoreElem { local, base, len } => {
                    let room = if local { frame } else { globals };
                    len > 0 && (base as usize).saturating_add(len as usize) <= room
                }
                Joints(n) => n == self.axes,
                PoseField(i) => i < 4,
                JointField(i) => i < self.axes,
                Jog(i, f) => i < self.axes && f.0 & !MoveFlags::ALL == 0,
                Jump(t) | JumpIfFalse(t) => t as usize <= len,
                TryBegin(t) => (t as usize) < len,
                Call {
                    routine,
                    args,
                    value,
                } => self
                    .routines
                    .get(routine as usize)
                    .is_some_and(|r| r.params == u16::from(args) && r.returns.is_some() == value),
                Builtin(b, n) => {
                    let d = b.def();
                    usize::from(n) <= d.params.len()
                        && usize::from(n) >= d.params.len() - usize::from(d.optional)
                }
                Print(n) => n > 0,
                Home(f)
                | MoveJ(f)
                | MoveP(_, f)
                | MoveL(f)
                | Arc(f)
                | Appro(_, f)
                | Appros(f)
                | Depart(f)
                | Departs(f) => f.0 & !MoveFlags::ALL == 0,
                _ => true,
            };
            if !ok {
                return invalid("operand out of range", pc);
            }
        }
        let needed = self.stack_depth()?;
        if needed > self.max_stack {
            return Err(DecodeError::Stack {
                what: "declared maximum stack depth too small",
                at: 0,
            });
        }
        Ok(())
    }

    /// The routine each instruction belongs to: the main program runs from 0 up to the
    /// first routine's entry, each routine from its entry to the next one's.
    fn owners(&self) -> Vec<Option<usize>> {
        let mut entries: Vec<(usize, usize)> = self
            .routines
            .iter()
            .enumerate()
            .map(|(i, r)| (r.entry as usize, i))
            .collect();
        entries.sort_unstable();
        let mut owner = vec![None; self.code.len()];
        for (k, &(entry, r)) in entries.iter().enumerate() {
            let end = entries.get(k + 1).map_or(self.code.len(), |e| e.0);
            for o in owner.iter_mut().take(end).skip(entry) {
                *o = Some(r);
            }
        }
        owner
    }

    /// The deepest stack any path needs; every routine's body starts at depth 0 (its caller's
    /// values below it are its caller's), every statement starts at depth 0.
    fn stack_depth(&self) -> Result<u32, DecodeError> {
        let len = self.code.len();
        let mut depth: Vec<Option<u32>> = vec![None; len];
        let mut work: Vec<(usize, u32)> = Vec::new();
        let mut max = 0;
        if len > 0 {
            work.push((0, 0));
        }
        for r in &self.routines {
            work.push((r.entry as usize, 0));
        }
        for &s in &self.statements {
            work.push((s as usize, 0));
        }
        let stack = |what, at| Err(DecodeError::Stack { what, at });
        while let Some((pc, d)) = work.pop() {
            if pc >= len {
                continue; // the end of the code: the program is done
            }
            match depth[pc] {
                Some(seen) if seen == d => continue,
                Some(_) => return stack("paths reach it with different stack depths", pc),
                None => depth[pc] = Some(d),
            }
            let instr = self.code[pc];
            let (pops, pushes) = instr.stack_effect();
            if pops > d {
                return stack("pops more values than the stack holds", pc);
            }
            let after = d - pops + pushes;
            max = max.max(after).max(d);
            match instr {
                Instr::Jump(t) => work.push((t as usize, after)),
                Instr::JumpIfFalse(t) => {
                    work.push((t as usize, after));
                    work.push((pc + 1, after));
                }
                Instr::TryBegin(t) => {
                    if d != 0 {
                        return stack("TRY needs an empty stack", pc);
                    }
                    work.push((t as usize, 0));
                    work.push((pc + 1, 0));
                }
                Instr::Ret if d != 0 => return stack("RET needs an empty stack", pc),
                Instr::RetVal if d != 1 => return stack("RETVAL needs exactly its value", pc),
                Instr::Ret
                | Instr::RetVal
                | Instr::Halt
                | Instr::NoReturn
                | Instr::Rethrow
                | Instr::Retry
                | Instr::Raise { .. } => {}
                _ => work.push((pc + 1, after)),
            }
        }
        Ok(max)
    }
}

/// The index of the first array of `vars` that runs past their end, if any.
fn arrays_fit(vars: &[Variable]) -> Option<usize> {
    vars.iter()
        .enumerate()
        .find(|(i, v)| (*i).saturating_add(v.len as usize) > vars.len())
        .map(|(i, _)| i)
}

fn put_var(w: &mut Vec<u8>, mut v: u32) {
    loop {
        let byte = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            w.push(byte);
            return;
        }
        w.push(byte | 0x80);
    }
}

fn put_str(w: &mut Vec<u8>, s: &str) {
    put_var(w, s.len() as u32);
    w.extend_from_slice(s.as_bytes());
}

fn put_pos(w: &mut Vec<u8>, pos: SourcePos) {
    put_var(w, pos.line);
    put_var(w, pos.col);
    put_var(w, u32::from(pos.file));
}

fn put_f64s(w: &mut Vec<u8>, values: &[f64]) {
    for v in values {
        w.extend_from_slice(&v.to_le_bytes());
    }
}

fn put_variables(w: &mut Vec<u8>, vars: &[Variable]) {
    put_var(w, vars.len() as u32);
    for v in vars {
        put_str(w, &v.name);
        w.push(v.ty.code());
        w.push(u8::from(v.hidden) | (u8::from(v.point) << 1));
        put_var(w, v.len);
        match &v.init {
            None => w.push(0),
            Some(Init::Pose(p)) => {
                w.push(1);
                put_f64s(w, &[p.x, p.y, p.z, p.yaw]);
            }
            Some(Init::Joints(j)) => {
                w.push(2);
                put_f64s(w, j);
            }
        }
    }
}

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

fn posture_code(p: Option<Posture>) -> u32 {
    match p {
        None => 0,
        Some(Posture::Left) => 1,
        Some(Posture::Right) => 2,
    }
}

fn encode(w: &mut Vec<u8>, instr: Instr) {
    use Instr::*;
    let f = |m: MoveFlags| u32::from(m.0);
    let (op, args): (u8, [Option<u32>; 3]) = match instr {
        Num(i) => (1, [Some(i), None, None]),
        True => (2, [None; 3]),
        False => (3, [None; 3]),
        Str(i) => (4, [Some(i), None, None]),
        Load(i) => (5, [Some(i), None, None]),
        Store(i) => (6, [Some(i), None, None]),
        Neg => (7, [None; 3]),
        Not => (8, [None; 3]),
        Add => (9, [None; 3]),
        Sub => (10, [None; 3]),
        Mul => (11, [None; 3]),
        Div => (12, [None; 3]),
        Eq => (13, [None; 3]),
        Ne => (14, [None; 3]),
        Lt => (15, [None; 3]),
        Le => (16, [None; 3]),
        Gt => (17, [None; 3]),
        Ge => (18, [None; 3]),
        And => (19, [None; 3]),
        Or => (20, [None; 3]),
        Joints(n) => (21, [Some(u32::from(n)), None, None]),
        Pose => (22, [None; 3]),
        PoseField(i) => (23, [Some(u32::from(i)), None, None]),
        JointField(i) => (24, [Some(u32::from(i)), None, None]),
        Builtin(b, n) => (25, [Some(u32::from(b.code())), Some(u32::from(n)), None]),
        Here => (26, [None; 3]),
        Input => (27, [None; 3]),
        ForTest => (28, [None; 3]),
        Jump(t) => (29, [Some(t), None, None]),
        JumpIfFalse(t) => (30, [Some(t), None, None]),
        Call {
            routine,
            args,
            value,
        } => (
            31,
            [Some(routine), Some(u32::from(args)), Some(u32::from(value))],
        ),
        Ret => (32, [None; 3]),
        Halt => (33, [None; 3]),
        Home(m) => (34, [Some(f(m)), None, None]),
        MoveJ(m) => (35, [Some(f(m)), None, None]),
        MoveP(p, m) => (36, [Some(posture_code(p)), Some(f(m)), None]),
        MoveL(m) => (37, [Some(f(m)), None, None]),
        Jog(a, m) => (38, [Some(u32::from(a)), Some(f(m)), None]),
        Speed => (39, [None; 3]),
        Delay => (40, [None; 3]),
        Out => (41, [None; 3]),
        Wait { timeout } => (42, [Some(u32::from(timeout)), None, None]),
        Print(n) => (43, [Some(u32::from(n)), None, None]),
        Get => (44, [None; 3]),
        Put => (45, [None; 3]),
        Map => (46, [None; 3]),
        GetB => (47, [None; 3]),
        PutB => (48, [None; 3]),
        Swap => (49, [None; 3]),
        Mod => (50, [None; 3]),
        LoadL(i) => (51, [Some(i), None, None]),
        StoreL(i) => (52, [Some(i), None, None]),
        LoadElem { local, base, len } => (53, [Some(u32::from(local)), Some(base), Some(len)]),
        StoreElem { local, base, len } => (54, [Some(u32::from(local)), Some(base), Some(len)]),
        CheckIndex(n) => (55, [Some(n), None, None]),
        RetVal => (56, [None; 3]),
        NoReturn => (57, [None; 3]),
        Pop => (58, [None; 3]),
        TryBegin(t) => (59, [Some(t), None, None]),
        TryEnd => (60, [None; 3]),
        CatchEnd => (61, [None; 3]),
        Rethrow => (62, [None; 3]),
        Retry => (63, [None; 3]),
        Raise { text } => (64, [Some(u32::from(text)), None, None]),
        Arc(m) => (65, [Some(f(m)), None, None]),
        Appro(p, m) => (66, [Some(posture_code(p)), Some(f(m)), None]),
        Appros(m) => (67, [Some(f(m)), None, None]),
        Depart(m) => (68, [Some(f(m)), None, None]),
        Departs(m) => (69, [Some(f(m)), None, None]),
        Accel => (70, [None; 3]),
        WaitOperator { text } => (71, [Some(u32::from(text)), None, None]),
        Alarm => (72, [None; 3]),
        Reset => (73, [None; 3]),
        Teach(i) => (74, [Some(i), None, None]),
    };
    w.push(op);
    for a in args.into_iter().flatten() {
        put_var(w, a);
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn byte(&mut self, what: &'static str) -> Result<u8, DecodeError> {
        let b = *self
            .bytes
            .get(self.pos)
            .ok_or(DecodeError::Truncated { what })?;
        self.pos += 1;
        Ok(b)
    }

    fn var(&mut self, what: &'static str) -> Result<u32, DecodeError> {
        let mut v: u64 = 0;
        for shift in (0..35).step_by(7) {
            let b = self.byte(what)?;
            v |= u64::from(b & 0x7f) << shift;
            if b & 0x80 == 0 {
                return u32::try_from(v).map_err(|_| DecodeError::Invalid {
                    what: "varint larger than 32 bits",
                    at: 0,
                });
            }
        }
        Err(DecodeError::Invalid {
            what: "varint longer than 5 bytes",
            at: 0,
        })
    }

    fn small(&mut self, what: &'static str) -> Result<u8, DecodeError> {
        u8::try_from(self.var(what)?).map_err(|_| DecodeError::Invalid { what, at: 0 })
    }

    fn flag(&mut self, what: &'static str) -> Result<bool, DecodeError> {
        match self.var(what)? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(DecodeError::Invalid { what, at: 0 }),
        }
    }

    fn take(&mut self, n: usize, what: &'static str) -> Result<&[u8], DecodeError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or(DecodeError::Truncated { what })?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn f64(&mut self, what: &'static str) -> Result<f64, DecodeError> {
        let mut b = [0u8; 8];
        b.copy_from_slice(self.take(8, what)?);
        let v = f64::from_le_bytes(b);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(DecodeError::Invalid {
                what: "a number that is not finite",
                at: 0,
            })
        }
    }

    fn string(&mut self, what: &'static str) -> Result<String, DecodeError> {
        let n = self.var(what)? as usize;
        let raw = self.take(n, what)?;
        String::from_utf8(raw.to_vec()).map_err(|_| DecodeError::Invalid {
            what: "text that is not UTF-8",
            at: 0,
        })
    }

    /// A count of items each at least `min_size` bytes long: never more than the bytes left
    /// could hold, so a corrupted count cannot make us allocate a huge table.
    fn count(&mut self, what: &'static str, min_size: usize) -> Result<usize, DecodeError> {
        let n = self.var(what)? as usize;
        let left = self.bytes.len() - self.pos;
        if n.saturating_mul(min_size) > left {
            return Err(DecodeError::Truncated { what });
        }
        Ok(n)
    }

    fn pos_(&mut self, what: &'static str) -> Result<SourcePos, DecodeError> {
        let line = self.var(what)?;
        let col = self.var(what)?;
        let file = u16::try_from(self.var(what)?).map_err(|_| DecodeError::Invalid {
            what: "source file index",
            at: 0,
        })?;
        Ok(SourcePos { line, col, file })
    }

    fn variables(&mut self, what: &'static str) -> Result<Vec<Variable>, DecodeError> {
        let n = self.count(what, 5)?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let name = self.string(what)?;
            let ty = Ty::from_code(self.byte(what)?).ok_or(DecodeError::Invalid {
                what: "unknown variable type",
                at: 0,
            })?;
            let flags = self.byte(what)?;
            if flags > 3 {
                return Err(DecodeError::Invalid {
                    what: "variable flag",
                    at: 0,
                });
            }
            let len = self.var(what)?;
            let init = match self.byte(what)? {
                0 => None,
                1 => {
                    let v = [
                        self.f64(what)?,
                        self.f64(what)?,
                        self.f64(what)?,
                        self.f64(what)?,
                    ];
                    Some(Init::Pose(Pose {
                        x: v[0],
                        y: v[1],
                        z: v[2],
                        yaw: v[3],
                    }))
                }
                2 => {
                    let mut j = [0.0; MAX_AXES];
                    for slot in &mut j {
                        *slot = self.f64(what)?;
                    }
                    Some(Init::Joints(j))
                }
                _ => {
                    return Err(DecodeError::Invalid {
                        what: "point value kind",
                        at: 0,
                    })
                }
            };
            let fits = match init {
                None => true,
                Some(Init::Pose(_)) => ty == Ty::Pose,
                Some(Init::Joints(_)) => ty == Ty::Joints,
            };
            if !fits {
                return Err(DecodeError::Invalid {
                    what: "a point's value of another type than its variable",
                    at: 0,
                });
            }
            out.push(Variable {
                name,
                ty,
                hidden: flags & 1 != 0,
                len,
                point: flags & 2 != 0,
                init,
            });
        }
        Ok(out)
    }
}

fn decode_body(body: &[u8]) -> Result<Program, DecodeError> {
    let mut r = Reader {
        bytes: body,
        pos: 6,
    };
    let axes = r.byte("header")?;
    let max_stack = r.var("header")?;
    let name = r.string("name")?;
    let n = r.count("file table", 1)?;
    let mut files = Vec::with_capacity(n);
    for _ in 0..n {
        files.push(r.string("file table")?);
    }
    let variables = r.variables("variable table")?;
    let n = r.count("constant table", 8)?;
    let mut constants = Vec::with_capacity(n);
    for _ in 0..n {
        constants.push(r.f64("constant table")?);
    }
    let n = r.count("string table", 1)?;
    let mut strings = Vec::with_capacity(n);
    for _ in 0..n {
        strings.push(r.string("string table")?);
    }
    let n = r.count("routine table", 8)?;
    let mut routines = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.string("routine table")?;
        let entry = r.var("routine table")?;
        let params = u16::try_from(r.var("routine table")?).map_err(|_| DecodeError::Invalid {
            what: "parameter count",
            at: 0,
        })?;
        let returns = match r.byte("routine table")? {
            255 => None,
            code => Some(Ty::from_code(code).ok_or(DecodeError::Invalid {
                what: "unknown result type",
                at: 0,
            })?),
        };
        let pos = r.pos_("routine table")?;
        let locals = r.variables("routine frame")?;
        routines.push(Routine {
            name,
            entry,
            params,
            locals,
            returns,
            pos,
        });
    }
    // Each instruction takes at least one byte, and its position three more.
    let n = r.count("code", 4)?;
    let mut code = Vec::with_capacity(n);
    for at in 0..n {
        code.push(decode_instr(&mut r).map_err(|e| match e {
            DecodeError::Invalid { what, .. } => DecodeError::Invalid { what, at },
            other => other,
        })?);
    }
    let mut positions = Vec::with_capacity(n);
    for _ in 0..n {
        positions.push(r.pos_("position table")?);
    }
    let n = r.count("statement table", 1)?;
    let mut statements = Vec::with_capacity(n);
    let mut last = 0u32;
    for i in 0..n {
        let d = r.var("statement table")?;
        if i > 0 && d == 0 {
            return Err(DecodeError::Invalid {
                what: "statement table",
                at: 0,
            });
        }
        last = last.checked_add(d).ok_or(DecodeError::Invalid {
            what: "statement table",
            at: 0,
        })?;
        statements.push(last);
    }
    if r.pos != body.len() {
        return Err(DecodeError::TrailingBytes(body.len() - r.pos));
    }
    Ok(Program {
        name,
        axes,
        code,
        positions,
        constants,
        strings,
        routines,
        variables,
        files,
        statements,
        max_stack,
        id: next_id(),
    })
}

fn decode_instr(r: &mut Reader<'_>) -> Result<Instr, DecodeError> {
    use Instr::*;
    let op = r.byte("code")?;
    let bad = |what| DecodeError::Invalid { what, at: 0 };
    let posture = |r: &mut Reader<'_>| -> Result<Option<Posture>, DecodeError> {
        match r.small("code")? {
            0 => Ok(None),
            1 => Ok(Some(Posture::Left)),
            2 => Ok(Some(Posture::Right)),
            _ => Err(bad("unknown posture")),
        }
    };
    let flags = |r: &mut Reader<'_>| -> Result<MoveFlags, DecodeError> {
        let f = r.small("code")?;
        if f & !MoveFlags::ALL != 0 {
            return Err(bad("motion flags"));
        }
        Ok(MoveFlags(f))
    };
    Ok(match op {
        1 => Num(r.var("code")?),
        2 => True,
        3 => False,
        4 => Str(r.var("code")?),
        5 => Load(r.var("code")?),
        6 => Store(r.var("code")?),
        7 => Neg,
        8 => Not,
        9 => Add,
        10 => Sub,
        11 => Mul,
        12 => Div,
        13 => Eq,
        14 => Ne,
        15 => Lt,
        16 => Le,
        17 => Gt,
        18 => Ge,
        19 => And,
        20 => Or,
        21 => Joints(r.small("code")?),
        22 => Pose,
        23 => PoseField(r.small("code")?),
        24 => JointField(r.small("code")?),
        25 => {
            let b = crate::builtins::Builtin::from_code(r.small("code")?)
                .ok_or(bad("unknown built-in"))?;
            Builtin(b, r.small("code")?)
        }
        26 => Here,
        27 => Input,
        28 => ForTest,
        29 => Jump(r.var("code")?),
        30 => JumpIfFalse(r.var("code")?),
        31 => Call {
            routine: r.var("code")?,
            args: r.small("code")?,
            value: r.flag("code")?,
        },
        32 => Ret,
        33 => Halt,
        34 => Home(flags(r)?),
        35 => MoveJ(flags(r)?),
        36 => {
            let p = posture(r)?;
            MoveP(p, flags(r)?)
        }
        37 => MoveL(flags(r)?),
        38 => {
            let a = r.small("code")?;
            Jog(a, flags(r)?)
        }
        39 => Speed,
        40 => Delay,
        41 => Out,
        42 => Wait {
            timeout: r.flag("code")?,
        },
        43 => Print(r.small("code")?),
        44 => Get,
        45 => Put,
        46 => Map,
        47 => GetB,
        48 => PutB,
        49 => Swap,
        50 => Mod,
        51 => LoadL(r.var("code")?),
        52 => StoreL(r.var("code")?),
        53 => LoadElem {
            local: r.flag("code")?,
            base: r.var("code")?,
            len: r.var("code")?,
        },
        54 => StoreElem {
            local: r.flag("code")?,
            base: r.var("code")?,
            len: r.var("code")?,
        },
        55 => CheckIndex(r.var("code")?),
        56 => RetVal,
        57 => NoReturn,
        58 => Pop,
        59 => TryBegin(r.var("code")?),
        60 => TryEnd,
        61 => CatchEnd,
        62 => Rethrow,
        63 => Retry,
        64 => Raise {
            text: r.flag("code")?,
        },
        65 => Arc(flags(r)?),
        66 => {
            let p = posture(r)?;
            Appro(p, flags(r)?)
        }
        67 => Appros(flags(r)?),
        68 => Depart(flags(r)?),
        69 => Departs(flags(r)?),
        70 => Accel,
        71 => WaitOperator {
            text: r.flag("code")?,
        },
        72 => Alarm,
        73 => Reset,
        74 => Teach(r.var("code")?),
        _ => return Err(bad("unknown opcode")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn program(code: Vec<Instr>, max_stack: u32) -> Program {
        let n = code.len();
        Program {
            name: "t".into(),
            axes: 4,
            code,
            positions: vec![
                SourcePos {
                    line: 1,
                    col: 1,
                    file: 0
                };
                n
            ],
            constants: vec![1.0],
            strings: vec![],
            routines: vec![],
            variables: vec![Variable {
                name: "X".into(),
                ty: Ty::Number,
                hidden: false,
                len: 1,
                point: false,
                init: None,
            }],
            files: vec!["t".into()],
            statements: vec![0],
            max_stack,
            id: next_id(),
        }
    }

    #[test]
    fn varints_round_trip() {
        for v in [0, 1, 127, 128, 300, 1 << 21, u32::MAX] {
            let mut w = Vec::new();
            put_var(&mut w, v);
            let mut r = Reader { bytes: &w, pos: 0 };
            assert_eq!(r.var("x").unwrap(), v);
            assert_eq!(r.pos, w.len());
        }
    }

    #[test]
    fn the_verifier_catches_what_a_checksum_cannot() {
        use Instr::*;
        let ok = program(vec![Num(0), Store(0), Halt], 1);
        assert_eq!(ok.verify(), Ok(()));
        let cases = [
            program(vec![Add, Halt], 4),                          // underflow
            program(vec![Num(0), Halt], 0),                       // declared stack too small
            program(vec![Num(7), Halt], 1),                       // constant index
            program(vec![Load(3), Halt], 1),                      // variable index
            program(vec![Jump(9)], 1),                            // jump target
            program(vec![True, JumpIfFalse(3), Num(0), Halt], 2), // depth differs at a merge
            program(vec![Joints(3), Halt], 4),                    // JOINTS arity ≠ axes
            program(
                vec![
                    Num(0),
                    Call {
                        routine: 0,
                        args: 0,
                        value: false,
                    },
                    Halt,
                ],
                1,
            ), // no such routine
            program(vec![Num(0), Num(0), Jog(4, MoveFlags(0)), Halt], 2), // axis index
            program(vec![LoadL(0), Halt], 1),                     // no frame in the main program
            program(
                vec![
                    Num(0),
                    LoadElem {
                        local: false,
                        base: 0,
                        len: 2,
                    },
                    Halt,
                ],
                1,
            ), // array past the globals
            program(vec![Teach(0), Halt], 1),                     // TEACH of a non-point
            program(vec![Num(0), TryBegin(3), Halt, Halt], 1),    // TRY with values stacked
            program(vec![Num(0), Num(0), MoveL(MoveFlags(16)), Halt], 2), // unknown motion flag
        ];
        for (i, p) in cases.iter().enumerate() {
            assert!(p.verify().is_err(), "case {i}: {:?}", p.code);
        }
    }

    #[test]
    fn every_instruction_encodes_and_decodes() {
        use Instr::*;
        let f = MoveFlags(MoveFlags::SPEED | MoveFlags::ZONE);
        let all = [
            Num(0),
            True,
            False,
            Str(0),
            Load(0),
            Store(0),
            Neg,
            Not,
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
            Joints(4),
            Pose,
            PoseField(3),
            JointField(2),
            Builtin(crate::Builtin::Atan2, 2),
            Builtin(crate::Builtin::Round, 1),
            Here,
            Input,
            ForTest,
            Jump(5),
            JumpIfFalse(6),
            Call {
                routine: 7,
                args: 2,
                value: true,
            },
            Ret,
            Halt,
            Home(MoveFlags(0)),
            MoveJ(MoveFlags(MoveFlags::PASS)),
            MoveP(Some(Posture::Left), f),
            MoveP(None, MoveFlags(0)),
            MoveL(f),
            Jog(1, MoveFlags(MoveFlags::ACCEL)),
            Speed,
            Delay,
            Out,
            Wait { timeout: true },
            Print(3),
            Get,
            Put,
            Map,
            GetB,
            PutB,
            Swap,
            Mod,
            LoadL(3),
            StoreL(4),
            LoadElem {
                local: true,
                base: 2,
                len: 5,
            },
            StoreElem {
                local: false,
                base: 9,
                len: 25,
            },
            CheckIndex(3),
            RetVal,
            NoReturn,
            Pop,
            TryBegin(12),
            TryEnd,
            CatchEnd,
            Rethrow,
            Retry,
            Raise { text: true },
            Arc(f),
            Appro(Some(Posture::Right), MoveFlags(MoveFlags::PASS)),
            Appros(f),
            Depart(MoveFlags(0)),
            Departs(f),
            Accel,
            WaitOperator { text: false },
            Alarm,
            Reset,
            Teach(3),
        ];
        for instr in all {
            let mut w = Vec::new();
            encode(&mut w, instr);
            let mut r = Reader { bytes: &w, pos: 0 };
            assert_eq!(decode_instr(&mut r).unwrap(), instr);
            assert_eq!(r.pos, w.len());
        }
    }

    #[test]
    fn wafer_handling_opcodes_keep_their_numbers() {
        // Appended after PRINT (43); stored programs depend on these numbers.
        for (instr, op) in [
            (Instr::Get, 44u8),
            (Instr::Put, 45),
            (Instr::Map, 46),
            (Instr::GetB, 47),
            (Instr::PutB, 48),
            (Instr::Swap, 49),
        ] {
            let mut w = Vec::new();
            encode(&mut w, instr);
            assert_eq!(w, [op], "{instr:?}");
        }
        assert_eq!(Instr::Get.stack_effect(), (2, 0));
        assert_eq!(Instr::Put.stack_effect(), (2, 0));
        assert_eq!(Instr::Map.stack_effect(), (1, 0));
        assert_eq!(
            [Instr::Get, Instr::Put, Instr::Map].map(Instr::mnemonic),
            ["GET", "PUT", "MAP"]
        );
        for instr in [Instr::GetB, Instr::PutB, Instr::Swap] {
            assert_eq!(instr.stack_effect(), (2, 0));
        }
    }
}
