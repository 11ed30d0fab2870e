//! The compiled program: a stack-machine instruction set, constant and string tables, the
//! source position of every instruction, SUB entry points and variables; a human listing,
//! JSON, and a versioned, checksummed binary form that is fully verified when read back.

use std::fmt::Write as _;
use std::sync::atomic::{AtomicU64, Ordering};

use wrc_robot::{Posture, MAX_AXES};

use crate::error::{DecodeError, RuntimeErrorKind};
use crate::value::{Ty, Value};

/// A built-in function of numbers (angles in degrees).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Builtin {
    /// `SIN(deg)`.
    Sin,
    /// `COS(deg)`.
    Cos,
    /// `ATAN2(y, x)` [deg].
    Atan2,
    /// `SQRT(x)`, x ≥ 0.
    Sqrt,
    /// `ABS(x)`.
    Abs,
    /// `MIN(a, b)`.
    Min,
    /// `MAX(a, b)`.
    Max,
}

impl Builtin {
    /// Apply it to `a` (and `b`, for the functions of two numbers). Angles are in degrees.
    pub(crate) fn apply(self, a: f64, b: f64) -> Result<Value, RuntimeErrorKind> {
        let num = crate::value::num;
        match self {
            Builtin::Sin => num(a.to_radians().sin()),
            Builtin::Cos => num(a.to_radians().cos()),
            Builtin::Atan2 => num(a.atan2(b).to_degrees()),
            Builtin::Sqrt if a < 0.0 => {
                Err(RuntimeErrorKind::BadArgument("SQRT of a negative number"))
            }
            Builtin::Sqrt => num(a.sqrt()),
            Builtin::Abs => num(a.abs()),
            Builtin::Min => num(a.min(b)),
            Builtin::Max => num(a.max(b)),
        }
    }

    /// Every built-in.
    pub const ALL: [Builtin; 7] = [
        Builtin::Sin,
        Builtin::Cos,
        Builtin::Atan2,
        Builtin::Sqrt,
        Builtin::Abs,
        Builtin::Min,
        Builtin::Max,
    ];

    /// The name, upper case.
    pub fn name(self) -> &'static str {
        match self {
            Builtin::Sin => "SIN",
            Builtin::Cos => "COS",
            Builtin::Atan2 => "ATAN2",
            Builtin::Sqrt => "SQRT",
            Builtin::Abs => "ABS",
            Builtin::Min => "MIN",
            Builtin::Max => "MAX",
        }
    }

    /// Number of arguments.
    pub fn arity(self) -> u8 {
        match self {
            Builtin::Atan2 | Builtin::Min | Builtin::Max => 2,
            _ => 1,
        }
    }

    pub(crate) fn from_name(key: &str) -> Option<Builtin> {
        Builtin::ALL.into_iter().find(|b| b.name() == key)
    }

    fn code(self) -> u8 {
        match self {
            Builtin::Sin => 0,
            Builtin::Cos => 1,
            Builtin::Atan2 => 2,
            Builtin::Sqrt => 3,
            Builtin::Abs => 4,
            Builtin::Min => 5,
            Builtin::Max => 6,
        }
    }

    fn from_code(code: u8) -> Option<Builtin> {
        Builtin::ALL.get(usize::from(code)).copied()
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
    /// Push variable `i`.
    Load(u32),
    /// Pop into variable `i`.
    Store(u32),
    /// Negate a number, pose or joints.
    Neg,
    /// Logical NOT.
    Not,
    /// `a + b` (numbers, poses, joints).
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
    /// Pop the built-in's arguments and push its result.
    Builtin(Builtin),
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
    /// Call the SUB at instruction `i`.
    Call(u32),
    /// Return from a SUB.
    Ret,
    /// End the program.
    Halt,
    /// Yield a move home.
    Home,
    /// Pop joints, yield a joint PTP move.
    MoveJ,
    /// Pop a pose, yield a PTP move to it with a posture (or the current one).
    MoveP(Option<Posture>),
    /// Pop a pose, yield a straight-line move to it.
    MoveL,
    /// Pop pulses, yield a jog of axis `i` [0-based].
    Jog(u8),
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
    /// Pop `n` values, format them into the print buffer, yield.
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
}

impl Instr {
    /// How many values the instruction pops and pushes.
    pub fn stack_effect(self) -> (u32, u32) {
        use Instr::*;
        match self {
            Num(_) | True | False | Str(_) | Load(_) | Here => (0, 1),
            Store(_) => (1, 0),
            Neg | Not | PoseField(_) | JointField(_) | Input => (1, 1),
            Add | Sub | Mul | Div | Eq | Ne | Lt | Le | Gt | Ge | And | Or => (2, 1),
            Joints(n) => (u32::from(n), 1),
            Pose => (4, 1),
            Builtin(b) => (u32::from(b.arity()), 1),
            ForTest => (3, 1),
            Jump(_) | Call(_) | Ret | Halt | Home => (0, 0),
            JumpIfFalse(_) | MoveJ | MoveP(_) | MoveL | Jog(_) | Speed | Delay | Map => (1, 0),
            Out | Get | Put | GetB | PutB | Swap => (2, 0),
            Wait { timeout } => (if timeout { 3 } else { 2 }, 0),
            Print(n) => (u32::from(n), 0),
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
            Builtin(b) => b.name(),
            Here => "HERE",
            Input => "IN",
            ForTest => "FORTEST",
            Jump(_) => "JUMP",
            JumpIfFalse(_) => "JUMPF",
            Call(_) => "CALL",
            Ret => "RET",
            Halt => "HALT",
            Home => "HOME",
            MoveJ => "MOVEJ",
            MoveP(_) => "MOVEP",
            MoveL => "MOVEL",
            Jog(_) => "JOG",
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
}

/// A SUB: its name as first written and its first instruction.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SubEntry {
    /// Name, as written in `SUB name`.
    pub name: String,
    /// Index of its first instruction.
    pub entry: u32,
}

/// A variable slot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Variable {
    /// Name, as first written; hidden slots are named after their FOR loop.
    pub name: String,
    /// Its type.
    pub ty: Ty,
    /// A slot the compiler added (a FOR loop's limit and step), not a user variable.
    pub hidden: bool,
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
    pub(crate) subs: Vec<SubEntry>,
    pub(crate) variables: Vec<Variable>,
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
            && self.subs == other.subs
            && self.variables == other.variables
            && self.max_stack == other.max_stack
    }
}

/// Version of the binary format [`Program::to_bytes`] writes.
pub const FORMAT_VERSION: u16 = 1;
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

    /// The string table (PRINT text).
    pub fn strings(&self) -> &[String] {
        &self.strings
    }

    /// The SUBs, in source order.
    pub fn subs(&self) -> &[SubEntry] {
        &self.subs
    }

    /// Every variable slot, user variables first.
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// Number of variable slots the VM needs (user variables and hidden FOR slots).
    pub fn variable_count(&self) -> usize {
        self.variables.len()
    }

    /// Number of variables the program names (without hidden FOR slots).
    pub fn user_variable_count(&self) -> usize {
        self.variables.iter().filter(|v| !v.hidden).count()
    }

    /// Deepest expression stack the program needs [values].
    pub fn max_stack(&self) -> usize {
        self.max_stack as usize
    }

    /// Number of robot axes the program was compiled for (JOINTS values have this many).
    pub fn axis_count(&self) -> usize {
        usize::from(self.axes)
    }

    fn operand(&self, instr: Instr) -> String {
        use Instr::*;
        match instr {
            Num(i) => format!(
                "#{i:<6} ; {}",
                self.constants.get(i as usize).copied().unwrap_or(f64::NAN)
            ),
            Str(i) => format!(
                "${i:<6} ; {:?}",
                self.strings.get(i as usize).map_or("", |s| s.as_str())
            ),
            Load(i) | Store(i) => format!(
                "v{i:<6} ; {}",
                self.variables
                    .get(i as usize)
                    .map_or("?", |v| v.name.as_str())
            ),
            Joints(n) | Print(n) => n.to_string(),
            PoseField(i) => ["X", "Y", "Z", "YAW"]
                .get(usize::from(i))
                .unwrap_or(&"?")
                .to_string(),
            JointField(i) => format!("J{}", u32::from(i) + 1),
            Jog(a) => format!("axis {}", u32::from(a) + 1),
            Jump(t) | JumpIfFalse(t) => format!("@{t:04}"),
            Call(t) => {
                let name = self
                    .subs
                    .iter()
                    .find(|s| s.entry == t)
                    .map_or("?", |s| s.name.as_str());
                format!("@{t:04}  ; {name}")
            }
            MoveP(Some(p)) => p.letter().to_string(),
            Wait { timeout: true } => "TIMEOUT".into(),
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
        for (i, v) in self.variables.iter().enumerate() {
            let _ = writeln!(out, "; v{i} {} ({})", v.name, v.ty);
        }
        for s in &self.subs {
            let _ = writeln!(out, "; SUB {} @{:04}", s.name, s.entry);
        }
        for (pc, instr) in self.code.iter().enumerate() {
            let pos = self.positions.get(pc).copied().unwrap_or_default();
            let at = format!("{}:{}", pos.line, pos.col);
            let line = format!(
                "{pc:04}  {at:<8} {:<8} {}",
                instr.mnemonic(),
                self.operand(*instr)
            );
            let _ = writeln!(out, "{}", line.trim_end());
        }
        out
    }

    /// The program as JSON: format and version, name, axes, max stack, variables,
    /// constants, strings, SUBs, and every instruction with its operand, a note resolving
    /// the operand (the constant's value, the variable's name, …) and its source position.
    pub fn to_json(&self) -> String {
        #[derive(serde::Serialize)]
        struct Json<'a> {
            format: &'static str,
            version: u16,
            name: &'a str,
            axes: u8,
            max_stack: u32,
            variables: Vec<JsonVar<'a>>,
            constants: &'a [f64],
            strings: &'a [String],
            subs: Vec<JsonSub<'a>>,
            code: Vec<JsonInstr>,
        }
        #[derive(serde::Serialize)]
        struct JsonVar<'a> {
            name: &'a str,
            #[serde(rename = "type")]
            ty: &'static str,
            hidden: bool,
        }
        #[derive(serde::Serialize)]
        struct JsonSub<'a> {
            name: &'a str,
            entry: u32,
        }
        #[derive(serde::Serialize)]
        struct JsonInstr {
            pc: usize,
            line: u32,
            col: u32,
            op: &'static str,
            operand: String,
            note: String,
        }
        let json = Json {
            format: "wrc-lang bytecode",
            version: FORMAT_VERSION,
            name: &self.name,
            axes: self.axes,
            max_stack: self.max_stack,
            variables: self
                .variables
                .iter()
                .map(|v| JsonVar {
                    name: &v.name,
                    ty: v.ty.name(),
                    hidden: v.hidden,
                })
                .collect(),
            constants: &self.constants,
            strings: &self.strings,
            subs: self
                .subs
                .iter()
                .map(|s| JsonSub {
                    name: &s.name,
                    entry: s.entry,
                })
                .collect(),
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
    /// positions and an FNV-1a checksum. Integers are LEB128 varints, numbers f64
    /// little-endian.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Vec::with_capacity(16 + self.code.len() * 4);
        w.extend_from_slice(MAGIC);
        w.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        w.push(self.axes);
        put_var(&mut w, self.max_stack);
        put_str(&mut w, &self.name);
        put_var(&mut w, self.variables.len() as u32);
        for v in &self.variables {
            put_str(&mut w, &v.name);
            w.push(v.ty.code());
            w.push(u8::from(v.hidden));
        }
        put_var(&mut w, self.constants.len() as u32);
        for c in &self.constants {
            w.extend_from_slice(&c.to_le_bytes());
        }
        put_var(&mut w, self.strings.len() as u32);
        for s in &self.strings {
            put_str(&mut w, s);
        }
        put_var(&mut w, self.subs.len() as u32);
        for s in &self.subs {
            put_str(&mut w, &s.name);
            put_var(&mut w, s.entry);
        }
        put_var(&mut w, self.code.len() as u32);
        for instr in &self.code {
            encode(&mut w, *instr);
        }
        for pos in &self.positions {
            put_var(&mut w, pos.line);
            put_var(&mut w, pos.col);
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
        if let Some(i) = self.constants.iter().position(|c| !c.is_finite()) {
            return invalid("constant that is not a finite number", i);
        }
        let len = self.code.len();
        for s in &self.subs {
            if s.entry as usize >= len {
                return invalid("SUB entry outside the code", s.entry as usize);
            }
        }
        for (pc, instr) in self.code.iter().enumerate() {
            use Instr::*;
            let ok = match *instr {
                Num(i) => (i as usize) < self.constants.len(),
                Str(i) => (i as usize) < self.strings.len(),
                Load(i) | Store(i) => (i as usize) < self.variables.len(),
                Joints(n) => n == self.axes,
                PoseField(i) => i < 4,
                JointField(i) | Jog(i) => i < self.axes,
                Jump(t) | JumpIfFalse(t) => t as usize <= len,
                Call(t) => (t as usize) < len,
                Print(n) => n > 0,
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

    /// The deepest stack any path needs; SUB bodies start (and calls happen) at depth 0.
    fn stack_depth(&self) -> Result<u32, DecodeError> {
        let len = self.code.len();
        let mut depth: Vec<Option<u32>> = vec![None; len];
        let mut work: Vec<(usize, u32)> = Vec::new();
        let mut max = 0;
        if len > 0 {
            work.push((0, 0));
        }
        for instr in &self.code {
            if let Instr::Call(t) = instr {
                work.push((*t as usize, 0));
            }
        }
        for s in &self.subs {
            work.push((s.entry as usize, 0));
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
                Instr::Call(_) | Instr::Ret if d != 0 => {
                    return stack("CALL and RET need an empty stack", pc)
                }
                Instr::Ret | Instr::Halt => {}
                _ => work.push((pc + 1, after)),
            }
        }
        Ok(max)
    }
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

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

fn posture_code(p: Option<Posture>) -> u8 {
    match p {
        None => 0,
        Some(Posture::Left) => 1,
        Some(Posture::Right) => 2,
    }
}

fn encode(w: &mut Vec<u8>, instr: Instr) {
    use Instr::*;
    let (op, arg): (u8, Option<u32>) = match instr {
        Num(i) => (1, Some(i)),
        True => (2, None),
        False => (3, None),
        Str(i) => (4, Some(i)),
        Load(i) => (5, Some(i)),
        Store(i) => (6, Some(i)),
        Neg => (7, None),
        Not => (8, None),
        Add => (9, None),
        Sub => (10, None),
        Mul => (11, None),
        Div => (12, None),
        Eq => (13, None),
        Ne => (14, None),
        Lt => (15, None),
        Le => (16, None),
        Gt => (17, None),
        Ge => (18, None),
        And => (19, None),
        Or => (20, None),
        Joints(n) => (21, Some(u32::from(n))),
        Pose => (22, None),
        PoseField(i) => (23, Some(u32::from(i))),
        JointField(i) => (24, Some(u32::from(i))),
        Builtin(b) => (25, Some(u32::from(b.code()))),
        Here => (26, None),
        Input => (27, None),
        ForTest => (28, None),
        Jump(t) => (29, Some(t)),
        JumpIfFalse(t) => (30, Some(t)),
        Call(t) => (31, Some(t)),
        Ret => (32, None),
        Halt => (33, None),
        Home => (34, None),
        MoveJ => (35, None),
        MoveP(p) => (36, Some(u32::from(posture_code(p)))),
        MoveL => (37, None),
        Jog(a) => (38, Some(u32::from(a))),
        Speed => (39, None),
        Delay => (40, None),
        Out => (41, None),
        Wait { timeout } => (42, Some(u32::from(timeout))),
        Print(n) => (43, Some(u32::from(n))),
        // Wafer handling (format version 1 still: appended numbers, none renumbered).
        Get => (44, None),
        Put => (45, None),
        Map => (46, None),
        // Dual-blade robot (appended as well).
        GetB => (47, None),
        PutB => (48, None),
        Swap => (49, None),
    };
    w.push(op);
    if let Some(arg) = arg {
        put_var(w, arg);
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
}

fn decode_body(body: &[u8]) -> Result<Program, DecodeError> {
    let mut r = Reader {
        bytes: body,
        pos: 6,
    };
    let axes = r.byte("header")?;
    let max_stack = r.var("header")?;
    let name = r.string("name")?;
    let n = r.count("variable table", 3)?;
    let mut variables = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.string("variable table")?;
        let ty = Ty::from_code(r.byte("variable table")?).ok_or(DecodeError::Invalid {
            what: "unknown variable type",
            at: 0,
        })?;
        let hidden = match r.byte("variable table")? {
            0 => false,
            1 => true,
            _ => {
                return Err(DecodeError::Invalid {
                    what: "variable flag",
                    at: 0,
                })
            }
        };
        variables.push(Variable { name, ty, hidden });
    }
    let n = r.count("constant table", 8)?;
    let mut constants = Vec::with_capacity(n);
    for _ in 0..n {
        let mut b = [0u8; 8];
        b.copy_from_slice(r.take(8, "constant table")?);
        constants.push(f64::from_le_bytes(b));
    }
    let n = r.count("string table", 1)?;
    let mut strings = Vec::with_capacity(n);
    for _ in 0..n {
        strings.push(r.string("string table")?);
    }
    let n = r.count("SUB table", 2)?;
    let mut subs = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.string("SUB table")?;
        let entry = r.var("SUB table")?;
        subs.push(SubEntry { name, entry });
    }
    // Each instruction takes at least one byte, and its position two more.
    let n = r.count("code", 3)?;
    let mut code = Vec::with_capacity(n);
    for at in 0..n {
        code.push(decode_instr(&mut r).map_err(|e| match e {
            DecodeError::Invalid { what, .. } => DecodeError::Invalid { what, at },
            other => other,
        })?);
    }
    let mut positions = Vec::with_capacity(n);
    for _ in 0..n {
        let line = r.var("position table")?;
        let col = r.var("position table")?;
        positions.push(SourcePos { line, col });
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
        subs,
        variables,
        max_stack,
        id: next_id(),
    })
}

fn decode_instr(r: &mut Reader<'_>) -> Result<Instr, DecodeError> {
    use Instr::*;
    let op = r.byte("code")?;
    let bad = |what| DecodeError::Invalid { what, at: 0 };
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
        25 => Builtin(
            crate::bytecode::Builtin::from_code(r.small("code")?).ok_or(bad("unknown built-in"))?,
        ),
        26 => Here,
        27 => Input,
        28 => ForTest,
        29 => Jump(r.var("code")?),
        30 => JumpIfFalse(r.var("code")?),
        31 => Call(r.var("code")?),
        32 => Ret,
        33 => Halt,
        34 => Home,
        35 => MoveJ,
        36 => MoveP(match r.small("code")? {
            0 => None,
            1 => Some(Posture::Left),
            2 => Some(Posture::Right),
            _ => return Err(bad("unknown posture")),
        }),
        37 => MoveL,
        38 => Jog(r.small("code")?),
        39 => Speed,
        40 => Delay,
        41 => Out,
        42 => Wait {
            timeout: match r.small("code")? {
                0 => false,
                1 => true,
                _ => return Err(bad("WAIT flag")),
            },
        },
        43 => Print(r.small("code")?),
        44 => Get,
        45 => Put,
        46 => Map,
        47 => GetB,
        48 => PutB,
        49 => Swap,
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
            positions: vec![SourcePos { line: 1, col: 1 }; n],
            constants: vec![1.0],
            strings: vec![],
            subs: vec![],
            variables: vec![Variable {
                name: "X".into(),
                ty: Ty::Number,
                hidden: false,
            }],
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
            program(vec![Num(0), Call(3), Halt, Ret], 1),         // call with values on the stack
            program(vec![Num(0), Num(0), Jog(4), Halt], 2),       // axis index
        ];
        for (i, p) in cases.iter().enumerate() {
            assert!(p.verify().is_err(), "case {i}: {:?}", p.code);
        }
    }

    #[test]
    fn every_instruction_encodes_and_decodes() {
        use Instr::*;
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
            Builtin(crate::Builtin::Atan2),
            Here,
            Input,
            ForTest,
            Jump(5),
            JumpIfFalse(6),
            Call(7),
            Ret,
            Halt,
            Home,
            MoveJ,
            MoveP(Some(Posture::Left)),
            MoveP(None),
            MoveL,
            Jog(1),
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
