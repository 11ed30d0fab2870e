//! The statement table: every simple statement's keyword, argument grammar, compile-time
//! checks and the instruction it ends in. The parser, the checker, the code generator and
//! the docs all read [`STATEMENTS`]; block statements (`IF`, `WHILE`, `FOR`, `SUB`) and
//! assignment are structure and live in the parser.
//!
//! # Adding a statement
//!
//! Wafer handling added `GET station, slot`, `PUT station, slot` and `MAP station`
//! this way; `GET` is the worked example. The change is:
//!
//! 1. a row here:
//!    ```text
//!    StatementDef {
//!        keyword: "GET",
//!        syntax: "GET station, slot",
//!        summary: "take the wafer in a station's slot onto the hand",
//!        args: &[
//!            ArgSpec::Value { ty: ArgTy::Station, check: ConstCheck::StationName },
//!            ArgSpec::Value { ty: ArgTy::Is(Ty::Number), check: ConstCheck::Slot },
//!        ],
//!        op: CommandOp::Get,
//!    },
//!    ```
//!    (a new kind of argument value is an `ArgTy` or `ConstCheck` variant, checked by
//!    `check.rs` at compile time through the same function of `value.rs` the VM uses);
//! 2. `CommandOp::Get`, and its instruction in `bytecode.rs` (`Instr::Get`: pops the slot and
//!    the station; an appended opcode number, a mnemonic and a `stack_effect` arm, which the
//!    encoder, decoder, verifier and listing then handle);
//! 3. its arm in `codegen.rs` (`CommandOp::Get => Instr::Get`) and in the VM, which checks the
//!    values and yields a [`Request`](crate::Request) (`Request::Transfer { kind, station,
//!    slot }`; `Request` is `#[non_exhaustive]`, so hosts already have a fallback arm);
//! 4. a section in `docs/language.md` and tests.
//!
//! Parsing, type checking, constant checks and diagnostics come from the row.

use crate::value::Ty;

/// A simple statement: one keyword, a fixed argument grammar, one final instruction.
#[derive(Debug, PartialEq)]
pub(crate) struct StatementDef {
    /// The keyword, upper case (statements are case-insensitive).
    pub keyword: &'static str,
    /// The syntax, as the docs and messages show it.
    pub syntax: &'static str,
    /// One line on what it does.
    pub summary: &'static str,
    /// The arguments, in order. The first follows the keyword; each later one follows a
    /// comma unless it is [`ArgSpec::Keyword`].
    pub args: &'static [ArgSpec],
    /// What the code generator emits after the argument values.
    pub op: CommandOp,
}

/// One argument of a statement.
#[derive(Debug, PartialEq)]
pub(crate) enum ArgSpec {
    /// An expression of a type, with a check applied when its value is known at compile time
    /// (and again by the VM at run time).
    Value { ty: ArgTy, check: ConstCheck },
    /// Optional `, L|R` (also `LEFT`, `RIGHT`): the elbow posture.
    Posture,
    /// Optional `, A|B`: the blade of a dual-blade robot (A, the hand, when left out).
    Blade,
    /// A robot axis by name (`J1`, `Z`) or 1-based number, known at compile time.
    Axis,
    /// One or more expressions of any type, separated by commas (PRINT).
    Items,
    /// The name of a SUB.
    Sub,
    /// `IN(n) = value`: an input bit and the level to wait for.
    Input,
    /// Optional `KEYWORD value` (no comma before it), e.g. `TIMEOUT seconds`.
    Keyword {
        word: &'static str,
        ty: ArgTy,
        check: ConstCheck,
    },
}

/// The type an argument takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ArgTy {
    /// Exactly this type.
    Is(Ty),
    /// A signal level: a number 0 or 1, or TRUE / FALSE.
    Level,
    /// A station name: a string (`"LP1"`, or a variable holding one).
    Station,
}

impl ArgTy {
    pub fn accepts(self, ty: Ty) -> bool {
        match self {
            ArgTy::Is(want) => want == ty,
            ArgTy::Level => matches!(ty, Ty::Number | Ty::Bool),
            ArgTy::Station => ty == Ty::Str,
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            ArgTy::Is(ty) => ty.with_article(),
            ArgTy::Level => "0 or 1 (or TRUE / FALSE)",
            ArgTy::Station => "a station name in quotes (like \"LP1\")",
        }
    }
}

/// A check on an argument whose value the compiler knows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ConstCheck {
    None,
    /// A pose the arm reaches (with the statement's posture if it has one).
    Reachable,
    /// Joint values within every axis's soft limits.
    JointLimits,
    /// A number in `min..=max`; `what` names it in the message (`speed`).
    Range {
        min: f64,
        max: f64,
        what: &'static str,
        unit: &'static str,
    },
    /// An output bit number, 0 to 31.
    OutputBit,
    /// A whole number (pulses).
    WholeNumber,
    /// A number of seconds, 0 or more.
    Seconds,
    /// A station name: 1 to 16 letters, digits, `_` or `-` (checked on string literals).
    StationName,
    /// A slot number: a whole number from 1 to 65535.
    Slot,
}

/// The instruction a statement ends in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CommandOp {
    Home,
    MoveJ,
    MoveP,
    MoveL,
    Jog,
    Speed,
    Delay,
    Out,
    Wait,
    Print,
    Call,
    End,
    Get,
    Put,
    Map,
    Swap,
}

/// `station, slot[, A|B]` of GET and PUT; SWAP takes the first two.
const TRANSFER_ARGS: &[ArgSpec] = &[
    ArgSpec::Value {
        ty: ArgTy::Station,
        check: ConstCheck::StationName,
    },
    ArgSpec::Value {
        ty: ArgTy::Is(Ty::Number),
        check: ConstCheck::Slot,
    },
    ArgSpec::Blade,
];

/// Every simple statement.
pub(crate) const STATEMENTS: &[StatementDef] = &[
    StatementDef {
        keyword: "HOME",
        syntax: "HOME",
        summary: "move every axis to its home position",
        args: &[],
        op: CommandOp::Home,
    },
    StatementDef {
        keyword: "MOVEJ",
        syntax: "MOVEJ joints",
        summary: "PTP move in joint space [deg, mm]",
        args: &[ArgSpec::Value {
            ty: ArgTy::Is(Ty::Joints),
            check: ConstCheck::JointLimits,
        }],
        op: CommandOp::MoveJ,
    },
    StatementDef {
        keyword: "MOVEP",
        syntax: "MOVEP pose [, L|R]",
        summary: "PTP move to a pose; L/R picks the elbow posture (default: keep the current one)",
        args: &[
            ArgSpec::Value {
                ty: ArgTy::Is(Ty::Pose),
                check: ConstCheck::Reachable,
            },
            ArgSpec::Posture,
        ],
        op: CommandOp::MoveP,
    },
    StatementDef {
        keyword: "MOVEL",
        syntax: "MOVEL pose",
        summary: "straight-line move of the tool centre point to a pose",
        args: &[ArgSpec::Value {
            ty: ArgTy::Is(Ty::Pose),
            check: ConstCheck::Reachable,
        }],
        op: CommandOp::MoveL,
    },
    StatementDef {
        keyword: "JOG",
        syntax: "JOG axis, pulses",
        summary: "move one axis by a signed number of pulses",
        args: &[
            ArgSpec::Axis,
            ArgSpec::Value {
                ty: ArgTy::Is(Ty::Number),
                check: ConstCheck::WholeNumber,
            },
        ],
        op: CommandOp::Jog,
    },
    StatementDef {
        keyword: "SPEED",
        syntax: "SPEED pct",
        summary: "speed override for later moves [%], 1-100",
        args: &[ArgSpec::Value {
            ty: ArgTy::Is(Ty::Number),
            check: ConstCheck::Range {
                min: 1.0,
                max: 100.0,
                what: "SPEED",
                unit: " [%]",
            },
        }],
        op: CommandOp::Speed,
    },
    StatementDef {
        keyword: "DELAY",
        syntax: "DELAY seconds",
        summary: "wait a number of seconds [s]",
        args: &[ArgSpec::Value {
            ty: ArgTy::Is(Ty::Number),
            check: ConstCheck::Seconds,
        }],
        op: CommandOp::Delay,
    },
    StatementDef {
        keyword: "OUT",
        syntax: "OUT n, 0|1",
        summary: "switch output bit n (0-31) off or on",
        args: &[
            ArgSpec::Value {
                ty: ArgTy::Is(Ty::Number),
                check: ConstCheck::OutputBit,
            },
            ArgSpec::Value {
                ty: ArgTy::Level,
                check: ConstCheck::None,
            },
        ],
        op: CommandOp::Out,
    },
    StatementDef {
        keyword: "WAIT",
        syntax: "WAIT IN(n) = 0|1 [TIMEOUT seconds]",
        summary: "wait until input bit n (0-31) has a level, at most a time [s]",
        args: &[
            ArgSpec::Input,
            ArgSpec::Keyword {
                word: "TIMEOUT",
                ty: ArgTy::Is(Ty::Number),
                check: ConstCheck::Seconds,
            },
        ],
        op: CommandOp::Wait,
    },
    StatementDef {
        keyword: "PRINT",
        syntax: "PRINT item [, item ...]",
        summary: "print numbers, text, poses or joints, separated by one space",
        args: &[ArgSpec::Items],
        op: CommandOp::Print,
    },
    StatementDef {
        keyword: "CALL",
        syntax: "CALL name",
        summary: "run a SUB and come back",
        args: &[ArgSpec::Sub],
        op: CommandOp::Call,
    },
    StatementDef {
        keyword: "GET",
        syntax: "GET station, slot[, A|B]",
        summary: "take the wafer in a station's slot (from 1) onto the hand (or blade A or B)",
        args: TRANSFER_ARGS,
        op: CommandOp::Get,
    },
    StatementDef {
        keyword: "PUT",
        syntax: "PUT station, slot[, A|B]",
        summary: "put the hand's (or blade A's or B's) wafer into a station's slot (from 1)",
        args: TRANSFER_ARGS,
        op: CommandOp::Put,
    },
    StatementDef {
        keyword: "SWAP",
        syntax: "SWAP station, slot",
        summary: "dual-blade robot: take the slot's wafer with the empty blade, put the other blade's there",
        args: TRANSFER_ARGS.split_at(2).0,
        op: CommandOp::Swap,
    },
    StatementDef {
        keyword: "MAP",
        syntax: "MAP station",
        summary: "scan a station's slots with the mapping sensor",
        args: &[ArgSpec::Value {
            ty: ArgTy::Station,
            check: ConstCheck::StationName,
        }],
        op: CommandOp::Map,
    },
    StatementDef {
        keyword: "END",
        syntax: "END",
        summary: "end the program",
        args: &[],
        op: CommandOp::End,
    },
];

/// The table row of a keyword (upper case).
pub(crate) fn find(keyword: &str) -> Option<&'static StatementDef> {
    STATEMENTS.iter().find(|d| d.keyword == keyword)
}

/// Words that are not names: block keywords, operators, literals, constructors and
/// built-ins. Statement keywords (from [`STATEMENTS`]) are reserved too.
pub(crate) const RESERVED: &[&str] = &[
    "IF", "THEN", "ELSEIF", "ELSE", "ENDIF", "WHILE", "ENDWHILE", "FOR", "TO", "STEP", "NEXT",
    "SUB", "ENDSUB", "AND", "OR", "NOT", "TRUE", "FALSE", "TIMEOUT", "IN", "HERE", "JOINTS",
    "POSE", "SIN", "COS", "ATAN2", "SQRT", "ABS", "MIN", "MAX",
];

/// Is `key` (upper case) a keyword that cannot name a variable or SUB?
pub(crate) fn is_reserved(key: &str) -> bool {
    RESERVED.contains(&key) || find(key).is_some()
}
