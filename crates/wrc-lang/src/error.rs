//! Errors: a program's run-time faults, a bytecode blob that does not decode, a program that
//! does not fit a VM. Run-time errors are `Copy` and carry only static text, so raising one
//! in the real-time cycle never allocates.

use core::fmt;

/// What went wrong while a program ran.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RuntimeErrorKind {
    /// A division by zero.
    #[error("division by zero")]
    DivisionByZero,
    /// An expression needed more stack than the VM has.
    #[error("expression stack overflow")]
    StackOverflow,
    /// SUB calls nested deeper than the VM's `call_depth` (usually a SUB that calls itself
    /// without end).
    #[error("SUB calls nested too deep (a SUB calling itself without end?)")]
    CallTooDeep,
    /// A result that is not a finite number (an overflow to infinity).
    #[error("result is not a finite number")]
    NotFinite,
    /// A value a built-in or a statement does not take; the text says which.
    #[error("{0}")]
    BadArgument(&'static str),
    /// The host refused or ended what the program asked for (a move out of reach or
    /// stopped, a transfer whose slot is empty, a RESET it cannot do, …): `code` is the
    /// host's protocol code (docs/protocol.md, e.g. 111 out of reach, 131 the slot is empty,
    /// 212 the wafer was not sensed); the host's text is [`Vm::error_text`](crate::Vm::error_text).
    #[error("the controller could not do it (code {code})")]
    Host {
        /// The host's code (the controller's protocol code).
        code: u16,
    },
    /// `RAISE code [, text]`: an error the program raised itself; the text is
    /// [`Vm::error_text`](crate::Vm::error_text).
    #[error("error {code} raised by the program")]
    Raised {
        /// The code RAISE gave (1 to 65535).
        code: u16,
    },
    /// An array index outside the array (the text names the index and the bounds).
    #[error("array index out of range")]
    IndexOutOfRange,
    /// A FUNCTION ended without `RETURN value`.
    #[error("a FUNCTION ended without RETURN")]
    NoReturn,
    /// TRY blocks (with the calls between them) nested deeper than the VM's handler stack.
    #[error("TRY blocks nested too deep")]
    TryTooDeep,
    /// `WAIT IN(n) = v TIMEOUT s`: the input did not reach the level in time.
    #[error("WAIT timed out")]
    WaitTimeout,
    /// `run` was called with no program loaded, or with another program than the one loaded.
    #[error("no program loaded (or run with a different program than the one loaded)")]
    NotLoaded,
    /// The bytecode broke an invariant the verifier should have caught (a bug in wrc).
    #[error("invalid bytecode ({0})")]
    InvalidProgram(&'static str),
}

impl RuntimeErrorKind {
    /// The error's code, as `ERR` gives it and an uncaught error ends the program with:
    /// the host's or RAISE's code; 211 for a WAIT that timed out; 301 for an internal
    /// error; 210 (a program error) for the rest.
    pub fn code(&self) -> u16 {
        match self {
            RuntimeErrorKind::Host { code } | RuntimeErrorKind::Raised { code } => *code,
            RuntimeErrorKind::WaitTimeout => 211,
            RuntimeErrorKind::NotLoaded | RuntimeErrorKind::InvalidProgram(_) => 301,
            RuntimeErrorKind::DivisionByZero
            | RuntimeErrorKind::StackOverflow
            | RuntimeErrorKind::CallTooDeep
            | RuntimeErrorKind::NotFinite
            | RuntimeErrorKind::BadArgument(_)
            | RuntimeErrorKind::IndexOutOfRange
            | RuntimeErrorKind::NoReturn
            | RuntimeErrorKind::TryTooDeep => 210,
        }
    }

    /// Whether a TRY can catch it (not the VM's own invariants).
    pub fn catchable(&self) -> bool {
        !matches!(
            self,
            RuntimeErrorKind::NotLoaded | RuntimeErrorKind::InvalidProgram(_)
        )
    }
}

/// A run-time fault and where in the source it happened.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RuntimeError {
    /// What went wrong.
    pub kind: RuntimeErrorKind,
    /// Source line [1-based] of the instruction; 0 when there is none.
    pub line: u32,
    /// Source column [1-based] of the instruction; 0 when there is none.
    pub col: u32,
    /// The source file ([`Program::files`](crate::Program::files); 0: the program's own).
    pub file: u16,
}

impl fmt::Display for RuntimeError {
    /// `line 12: division by zero`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.kind)
    }
}

impl std::error::Error for RuntimeError {}

/// A bytecode blob that [`Program::from_bytes`](crate::Program::from_bytes) refuses.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// It does not start with the magic bytes `WRCL`.
    #[error("not wrc-lang bytecode (the magic bytes WRCL are missing)")]
    BadMagic,
    /// It was written by a different format version.
    #[error(
        "bytecode format version {found} is not supported (this build reads version {supported})"
    )]
    UnsupportedVersion {
        /// Version in the blob.
        found: u16,
        /// Version this build reads.
        supported: u16,
    },
    /// It ends in the middle of a field.
    #[error("bytecode is truncated: it ends inside the {what}")]
    Truncated {
        /// The field being read.
        what: &'static str,
    },
    /// The checksum does not match the contents.
    #[error("bytecode checksum mismatch: the blob is corrupted")]
    BadChecksum,
    /// A field holds a value that is not allowed (an unknown opcode, an index out of range,
    /// text that is not UTF-8, a jump outside the code, …).
    #[error("invalid bytecode: {what} at instruction {at}")]
    Invalid {
        /// What is wrong.
        what: &'static str,
        /// The instruction index, or 0 for header fields.
        at: usize,
    },
    /// The stack check failed: an instruction pops more than is there, two paths reach an
    /// instruction with different stack depths, or the declared maximum is too small.
    #[error("invalid bytecode: {what} at instruction {at}")]
    Stack {
        /// What is wrong.
        what: &'static str,
        /// The instruction index.
        at: usize,
    },
    /// Bytes follow the end of the program.
    #[error("bytecode has {0} bytes after its end")]
    TrailingBytes(usize),
}

/// A program that does not fit a VM's limits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    /// The program's expressions need a deeper stack than the VM has.
    #[error("the program needs a stack of {needed} values, the VM has {limit}")]
    StackTooSmall {
        /// Stack depth the program needs [values].
        needed: usize,
        /// The VM's stack [values].
        limit: usize,
    },
    /// The program has more variables than the VM has room for.
    #[error("the program has {needed} variables, the VM has room for {limit}")]
    TooManyVariables {
        /// Variables of the program (including hidden FOR loop slots).
        needed: usize,
        /// The VM's variable slots.
        limit: usize,
    },
    /// A routine's frame is larger than the VM's room for locals.
    #[error("a SUB or FUNCTION needs {needed} local slots, the VM has room for {limit}")]
    FrameTooLarge {
        /// Slots of the largest frame.
        needed: usize,
        /// The VM's local slots.
        limit: usize,
    },
}
