//! The statement table: every simple statement's keyword, argument grammar, compile-time
//! checks and the instruction it ends in. The parser, the checker, the code generator and
//! the docs all read [`STATEMENTS`]; block statements (`IF`, `WHILE`, `FOR`, `DO`,
//! `SELECT CASE`, `TRY`, `SUB`, `FUNCTION`), `CALL`, declarations and assignment are
//! structure and live in the parser.
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
//!        second: None,
//!        syntax: "GET station, slot[, A|B]",
//!        summary: "take the wafer in a station's slot onto the hand",
//!        args: &[
//!            ArgSpec::Value { ty: ArgTy::Station, check: ConstCheck::StationName },
//!            ArgSpec::Value { ty: ArgTy::Is(Ty::Number), check: ConstCheck::Slot },
//!            ArgSpec::Blade,
//!        ],
//!        op: CommandOp::Get,
//!    },
//!    ```
//!    (a new kind of argument value is an `ArgTy` or `ConstCheck` variant, checked by
//!    `check` at compile time through the same function of `value.rs` the VM uses);
//! 2. `CommandOp::Get`, and its instruction in `bytecode.rs` (`Instr::Get`: pops the slot and
//!    the station; an appended opcode number, a mnemonic and a `stack_effect` arm, which the
//!    encoder, decoder, verifier and listing then handle);
//! 3. its arm in `codegen.rs` (`CommandOp::Get => Instr::Get`) and in the VM, which checks the
//!    values and yields a [`Request`](crate::Request) (`Request::Transfer { kind, station,
//!    slot }`; `Request` is `#[non_exhaustive]`, so hosts already have a fallback arm);
//! 4. a section in `docs/language.md` (with an example the docs test compiles and runs) and
//!    tests.
//!
//! Parsing, type checking, constant checks and diagnostics come from the row.

use crate::value::Ty;

/// A simple statement: one keyword (or two: `WAIT OPERATOR`), a fixed argument grammar,
/// one final instruction.
#[derive(Debug, PartialEq)]
pub(crate) struct StatementDef {
    /// The keyword, upper case (statements are case-insensitive).
    pub keyword: &'static str,
    /// A second word that selects this row among the keyword's (`OPERATOR` of `WAIT
    /// OPERATOR`); `None` for the keyword's row without one.
    pub second: Option<&'static str>,
    /// The syntax, as the docs and messages show it.
    pub syntax: &'static str,
    /// One line on what it does.
    pub summary: &'static str,
    /// The arguments, in order. The first follows the keyword; each later one follows a
    /// comma unless it is a [`ArgSpec::Keyword`] or [`ArgSpec::Motion`].
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
    /// An optional `, expression` (left out: the statement's default).
    OptValue { ty: ArgTy, check: ConstCheck },
    /// Optional `, L|R` (also `LEFT`, `RIGHT`): the elbow posture.
    Posture,
    /// Optional `, A|B`: the blade of a dual-blade robot (A, the hand, when left out).
    Blade,
    /// A robot axis by name (`J1`, `Z`) or 1-based number, known at compile time.
    Axis,
    /// One or more expressions of any type, separated by commas (PRINT).
    Items,
    /// The name of a taught point (TEACH).
    Target,
    /// `IN(n) = value`: an input bit and the level to wait for.
    Input,
    /// Optional `KEYWORD value` (no comma before it), e.g. `TIMEOUT seconds`.
    Keyword {
        word: &'static str,
        ty: ArgTy,
        check: ConstCheck,
    },
    /// A motion's options, in any order, no commas: `SPEED pct`, `ACCEL pct` and, as
    /// `blend` says, `BLEND zone` or `BLEND`.
    Motion { blend: Blend },
}

/// What `BLEND` takes on a motion statement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Blend {
    /// No BLEND (HOME, JOG).
    No,
    /// `BLEND` alone: a PTP motion passes its target moving.
    Pass,
    /// `BLEND zone`: a Cartesian motion rounds the corner within `zone` [mm].
    Zone,
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
    /// An error or alarm code: a whole number from 1 to 65535.
    ErrorCode,
}

/// The instruction a statement ends in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CommandOp {
    Home,
    MoveJ,
    MoveP,
    MoveL,
    Arc,
    Appro,
    Appros,
    Depart,
    Departs,
    Jog,
    Speed,
    Accel,
    Delay,
    Out,
    Wait,
    WaitOperator,
    Print,
    End,
    Get,
    Put,
    Map,
    Swap,
    Raise,
    Alarm,
    Reset,
    Teach,
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

const POSE_TARGET: ArgSpec = ArgSpec::Value {
    ty: ArgTy::Is(Ty::Pose),
    check: ConstCheck::Reachable,
};

const POSE_ANY: ArgSpec = ArgSpec::Value {
    ty: ArgTy::Is(Ty::Pose),
    check: ConstCheck::None,
};

const DISTANCE: ArgSpec = ArgSpec::Value {
    ty: ArgTy::Is(Ty::Number),
    check: ConstCheck::None,
};

const PERCENT: ConstCheck = ConstCheck::Range {
    min: 1.0,
    max: 100.0,
    what: "SPEED",
    unit: " [%]",
};

const CODE: ArgSpec = ArgSpec::Value {
    ty: ArgTy::Is(Ty::Number),
    check: ConstCheck::ErrorCode,
};

const TEXT: ArgSpec = ArgSpec::Value {
    ty: ArgTy::Is(Ty::Str),
    check: ConstCheck::None,
};

/// Every simple statement.
pub(crate) const STATEMENTS: &[StatementDef] = &[
    StatementDef {
        keyword: "HOME",
        second: None,
        syntax: "HOME [SPEED pct] [ACCEL pct]",
        summary: "move every axis to its home position",
        args: &[ArgSpec::Motion { blend: Blend::No }],
        op: CommandOp::Home,
    },
    StatementDef {
        keyword: "MOVEJ",
        second: None,
        syntax: "MOVEJ joints [SPEED pct] [ACCEL pct] [BLEND]",
        summary: "PTP move in joint space [deg, mm]",
        args: &[
            ArgSpec::Value {
                ty: ArgTy::Is(Ty::Joints),
                check: ConstCheck::JointLimits,
            },
            ArgSpec::Motion { blend: Blend::Pass },
        ],
        op: CommandOp::MoveJ,
    },
    StatementDef {
        keyword: "MOVEP",
        second: None,
        syntax: "MOVEP pose [, L|R] [SPEED pct] [ACCEL pct] [BLEND]",
        summary: "PTP move to a pose; L/R picks the elbow posture (default: keep the current one)",
        args: &[
            POSE_TARGET,
            ArgSpec::Posture,
            ArgSpec::Motion { blend: Blend::Pass },
        ],
        op: CommandOp::MoveP,
    },
    StatementDef {
        keyword: "MOVEL",
        second: None,
        syntax: "MOVEL pose [SPEED pct] [ACCEL pct] [BLEND mm]",
        summary: "straight-line move of the tool centre point to a pose",
        args: &[POSE_TARGET, ArgSpec::Motion { blend: Blend::Zone }],
        op: CommandOp::MoveL,
    },
    StatementDef {
        keyword: "ARC",
        second: None,
        syntax: "ARC via, pose [SPEED pct] [ACCEL pct] [BLEND mm]",
        summary: "circular move of the tool centre point through a via pose to a pose",
        args: &[
            POSE_TARGET,
            POSE_TARGET,
            ArgSpec::Motion { blend: Blend::Zone },
        ],
        op: CommandOp::Arc,
    },
    StatementDef {
        keyword: "APPRO",
        second: None,
        syntax: "APPRO pose, mm [, L|R] [SPEED pct] [ACCEL pct] [BLEND]",
        summary: "PTP move to a pose moved back along the hand by a distance [mm]",
        args: &[
            POSE_ANY,
            DISTANCE,
            ArgSpec::Posture,
            ArgSpec::Motion { blend: Blend::Pass },
        ],
        op: CommandOp::Appro,
    },
    StatementDef {
        keyword: "APPROS",
        second: None,
        syntax: "APPROS pose, mm [SPEED pct] [ACCEL pct] [BLEND mm]",
        summary: "straight-line move to a pose moved back along the hand by a distance [mm]",
        args: &[POSE_ANY, DISTANCE, ArgSpec::Motion { blend: Blend::Zone }],
        op: CommandOp::Appros,
    },
    StatementDef {
        keyword: "DEPART",
        second: None,
        syntax: "DEPART mm [SPEED pct] [ACCEL pct] [BLEND]",
        summary: "PTP move back along the hand by a distance [mm] from where the robot is",
        args: &[DISTANCE, ArgSpec::Motion { blend: Blend::Pass }],
        op: CommandOp::Depart,
    },
    StatementDef {
        keyword: "DEPARTS",
        second: None,
        syntax: "DEPARTS mm [SPEED pct] [ACCEL pct] [BLEND mm]",
        summary: "straight-line move back along the hand by a distance [mm]",
        args: &[DISTANCE, ArgSpec::Motion { blend: Blend::Zone }],
        op: CommandOp::Departs,
    },
    StatementDef {
        keyword: "JOG",
        second: None,
        syntax: "JOG axis, pulses [SPEED pct] [ACCEL pct]",
        summary: "move one axis by a signed number of pulses",
        args: &[
            ArgSpec::Axis,
            ArgSpec::Value {
                ty: ArgTy::Is(Ty::Number),
                check: ConstCheck::WholeNumber,
            },
            ArgSpec::Motion { blend: Blend::No },
        ],
        op: CommandOp::Jog,
    },
    StatementDef {
        keyword: "SPEED",
        second: None,
        syntax: "SPEED pct",
        summary: "speed override for later moves [%], 1-100",
        args: &[ArgSpec::Value {
            ty: ArgTy::Is(Ty::Number),
            check: PERCENT,
        }],
        op: CommandOp::Speed,
    },
    StatementDef {
        keyword: "ACCEL",
        second: None,
        syntax: "ACCEL pct",
        summary: "acceleration override for later moves [%], 1-100",
        args: &[ArgSpec::Value {
            ty: ArgTy::Is(Ty::Number),
            check: ConstCheck::Range {
                min: 1.0,
                max: 100.0,
                what: "ACCEL",
                unit: " [%]",
            },
        }],
        op: CommandOp::Accel,
    },
    StatementDef {
        keyword: "DELAY",
        second: None,
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
        second: None,
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
        second: Some("OPERATOR"),
        syntax: "WAIT OPERATOR [text]",
        summary: "wait until the operator answers CONTINUE (the GUI or a host), showing a text",
        args: &[ArgSpec::OptValue {
            ty: ArgTy::Is(Ty::Str),
            check: ConstCheck::None,
        }],
        op: CommandOp::WaitOperator,
    },
    StatementDef {
        keyword: "WAIT",
        second: None,
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
        second: None,
        syntax: "PRINT item [, item ...]",
        summary: "print numbers, text, poses or joints, separated by one space",
        args: &[ArgSpec::Items],
        op: CommandOp::Print,
    },
    StatementDef {
        keyword: "GET",
        second: None,
        syntax: "GET station, slot[, A|B]",
        summary: "take the wafer in a station's slot (from 1) onto the hand (or blade A or B)",
        args: TRANSFER_ARGS,
        op: CommandOp::Get,
    },
    StatementDef {
        keyword: "PUT",
        second: None,
        syntax: "PUT station, slot[, A|B]",
        summary: "put the hand's (or blade A's or B's) wafer into a station's slot (from 1)",
        args: TRANSFER_ARGS,
        op: CommandOp::Put,
    },
    StatementDef {
        keyword: "SWAP",
        second: None,
        syntax: "SWAP station, slot",
        summary: "dual-blade robot: take the slot's wafer with the empty blade, put the other blade's there",
        args: TRANSFER_ARGS.split_at(2).0,
        op: CommandOp::Swap,
    },
    StatementDef {
        keyword: "MAP",
        second: None,
        syntax: "MAP station",
        summary: "scan a station's slots with the mapping sensor",
        args: &[ArgSpec::Value {
            ty: ArgTy::Station,
            check: ConstCheck::StationName,
        }],
        op: CommandOp::Map,
    },
    StatementDef {
        keyword: "RAISE",
        second: None,
        syntax: "RAISE code [, text]",
        summary: "raise an error (caught by TRY … CATCH; otherwise it ends the program)",
        args: &[
            CODE,
            ArgSpec::OptValue {
                ty: ArgTy::Is(Ty::Str),
                check: ConstCheck::None,
            },
        ],
        op: CommandOp::Raise,
    },
    StatementDef {
        keyword: "ALARM",
        second: None,
        syntax: "ALARM code, text",
        summary: "tell every host and the GUI of an alarm (EVT ALARM); the program goes on",
        args: &[CODE, TEXT],
        op: CommandOp::Alarm,
    },
    StatementDef {
        keyword: "RESET",
        second: None,
        syntax: "RESET",
        summary: "clear a vacuum (212) or interlock (214) alarm the program caught, as a host's RESET",
        args: &[],
        op: CommandOp::Reset,
    },
    StatementDef {
        keyword: "TEACH",
        second: None,
        syntax: "TEACH point",
        summary: "store where the robot is as a named point of the program's points file",
        args: &[ArgSpec::Target],
        op: CommandOp::Teach,
    },
    StatementDef {
        keyword: "END",
        second: None,
        syntax: "END",
        summary: "end the program",
        args: &[],
        op: CommandOp::End,
    },
];

/// The table row of a keyword (upper case) followed by the word `next` (upper case, or "").
pub(crate) fn find(keyword: &str, next: &str) -> Option<&'static StatementDef> {
    STATEMENTS
        .iter()
        .find(|d| d.keyword == keyword && d.second == Some(next))
        .or_else(|| {
            STATEMENTS
                .iter()
                .find(|d| d.keyword == keyword && d.second.is_none())
        })
}

/// Words that are not names: block keywords, operators, literals, type names and the words
/// of clauses. Statement keywords (from [`STATEMENTS`]) and the built-in values written
/// without parentheses (`ERR`, `ERRMSG$`, …) are reserved too; the other built-in
/// functions are not (`SLOT(…)` is the function, `slot` may be a variable).
pub(crate) const RESERVED: &[&str] = &[
    "IF",
    "THEN",
    "ELSEIF",
    "ELSE",
    "ENDIF",
    "WHILE",
    "ENDWHILE",
    "FOR",
    "TO",
    "STEP",
    "NEXT",
    "SUB",
    "ENDSUB",
    "FUNCTION",
    "ENDFUNCTION",
    "RETURN",
    "CALL",
    "PROGRAM",
    "AND",
    "OR",
    "NOT",
    "MOD",
    "TRUE",
    "FALSE",
    "TIMEOUT",
    "IN",
    "JOINTS",
    "POSE",
    "DO",
    "LOOP",
    "UNTIL",
    "EXIT",
    "SELECT",
    "CASE",
    "ENDSELECT",
    "IS",
    "TRY",
    "CATCH",
    "ENDTRY",
    "RETRY",
    "DIM",
    "LOCAL",
    "AS",
    "NUMBER",
    "BOOLEAN",
    "STRING",
    "INCLUDE",
    "BLEND",
    "OPERATOR",
];

/// Is `key` (upper case) a keyword that cannot name a variable or SUB?
pub(crate) fn is_reserved(key: &str) -> bool {
    RESERVED.contains(&key)
        || STATEMENTS.iter().any(|d| d.keyword == key)
        || crate::builtins::find(key).is_some_and(|b| b.bare)
}

/// The type a type name in an `AS` clause stands for.
pub(crate) fn type_named(key: &str) -> Option<Ty> {
    Some(match key {
        "NUMBER" => Ty::Number,
        "BOOLEAN" => Ty::Bool,
        "STRING" => Ty::Str,
        "POSE" => Ty::Pose,
        "JOINTS" => Ty::Joints,
        _ => return None,
    })
}
