//! The built-in functions: one table ([`BUILTINS`]) with each function's name, parameters,
//! result type and kind, read by the checker (names, argument types, constant folding), the
//! code generator, the VM and the docs test. Pure functions are evaluated here, by the
//! compiler when their arguments are constant and by the VM otherwise, so both agree on
//! every result. Nothing here allocates.

use core::fmt::Write as _;

use wrc_robot::Pose;

use crate::error::RuntimeErrorKind;
use crate::value::{self, Text, Ty, Value};

/// A built-in function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Builtin {
    /// `SIN(deg)`.
    Sin,
    /// `COS(deg)`.
    Cos,
    /// `TAN(deg)`.
    Tan,
    /// `ASIN(x)` [deg].
    Asin,
    /// `ACOS(x)` [deg].
    Acos,
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
    /// `ROUND(x[, decimals])`.
    Round,
    /// `INT(x)`: the largest whole number ≤ x.
    Int,
    /// `SGN(x)`: -1, 0 or 1.
    Sgn,
    /// `STR$(x)`: a number as PRINT shows it.
    Str,
    /// `FORMAT$(x, pattern)`.
    Format,
    /// `LEN(s)` [characters].
    Len,
    /// `LEFT$(s, n)`.
    Left,
    /// `RIGHT$(s, n)`.
    Right,
    /// `MID$(s, start[, n])`.
    Mid,
    /// `VAL(s)`.
    Val,
    /// `UCASE$(s)`.
    Ucase,
    /// `LCASE$(s)`.
    Lcase,
    /// `INSTR(s, part)`.
    Instr,
    /// `HERE()`: the current pose.
    Here,
    /// `IN(n)`: an input bit.
    In,
    /// `TIMER()`: seconds since the program started.
    Timer,
    /// `DIST(p, q)` [mm].
    Dist,
    /// `RELTOOL(p, dx, dy, dz[, dyaw])`: a pose moved in its own tool frame.
    RelTool,
    /// `INFRAME(frame, p)`: a pose given in a user frame, in the base frame.
    InFrame,
    /// `TOFRAME(frame, p)`: a pose of the base frame, in a user frame.
    ToFrame,
    /// `ERR`: the code of the error being handled.
    Err,
    /// `ERRMSG$`: its text.
    ErrMsg,
    /// `ERRLINE`: its source line.
    ErrLine,
    /// `OPERATOR$`: the operator's last answer to `WAIT OPERATOR`.
    Operator,
    /// `SLOT(station, n)`: the wafer map's state of a slot.
    Slot,
    /// `WAFER$(station, n)`: the id of the wafer in a slot.
    Wafer,
    /// `HAND$([A|B])`: the id of the wafer on the hand (blade).
    Hand,
    /// `SLOTS(station)`: the station's slot count.
    Slots,
    /// `PITCH(station)` [mm].
    Pitch,
    /// `STATION(station)`: its taught pose.
    Station,
    /// `APPROACH(station)` [mm].
    Approach,
}

/// A parameter's kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Param {
    /// A value of this type.
    Is(Ty),
    /// A station name (a string, checked like GET's).
    Station,
    /// `A` or `B`, written as a bare word: a blade (passed as 0 or 1).
    Blade,
}

/// Where a built-in's value comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// Computed from its arguments ([`Builtin::eval`]): folded when they are constant.
    Pure,
    /// Read from the host at once ([`crate::VmIo`]).
    Io,
    /// The VM's error-handling state.
    Vm,
    /// Asked of the host: the program waits for the answer ([`crate::Request::Cell`]).
    Host,
}

/// A row of the table.
#[derive(Debug)]
pub(crate) struct BuiltinDef {
    pub builtin: Builtin,
    pub name: &'static str,
    pub params: &'static [Param],
    /// Parameters that may be left out, at the end.
    pub optional: u8,
    pub ret: Ty,
    pub kind: Kind,
    /// Written without parentheses too (`ERR`, `ERRMSG$`).
    pub bare: bool,
    /// Syntax and one line for the docs.
    pub syntax: &'static str,
    pub summary: &'static str,
}

const N: Param = Param::Is(Ty::Number);
const S: Param = Param::Is(Ty::Str);
const P: Param = Param::Is(Ty::Pose);
const ST: Param = Param::Station;

macro_rules! def {
    ($b:ident, $name:literal, [$($p:expr),*], $opt:literal, $ret:ident, $kind:ident, $bare:literal, $syntax:literal, $summary:literal) => {
        BuiltinDef {
            builtin: Builtin::$b,
            name: $name,
            params: &[$($p),*],
            optional: $opt,
            ret: Ty::$ret,
            kind: Kind::$kind,
            bare: $bare,
            syntax: $syntax,
            summary: $summary,
        }
    };
}

/// Every built-in function.
pub(crate) const BUILTINS: &[BuiltinDef] = &[
    def!(Sin, "SIN", [N], 0, Number, Pure, false, "SIN(deg)", "sine of an angle in degrees"),
    def!(Cos, "COS", [N], 0, Number, Pure, false, "COS(deg)", "cosine of an angle in degrees"),
    def!(Tan, "TAN", [N], 0, Number, Pure, false, "TAN(deg)", "tangent of an angle in degrees"),
    def!(Asin, "ASIN", [N], 0, Number, Pure, false, "ASIN(x)", "the angle whose sine is x [deg], -90 to 90; x from -1 to 1"),
    def!(Acos, "ACOS", [N], 0, Number, Pure, false, "ACOS(x)", "the angle whose cosine is x [deg], 0 to 180; x from -1 to 1"),
    def!(Atan2, "ATAN2", [N, N], 0, Number, Pure, false, "ATAN2(y, x)", "the angle of (x, y) in degrees, -180 to 180"),
    def!(Sqrt, "SQRT", [N], 0, Number, Pure, false, "SQRT(x)", "square root; a negative x is a run-time error"),
    def!(Abs, "ABS", [N], 0, Number, Pure, false, "ABS(x)", "absolute value"),
    def!(Min, "MIN", [N, N], 0, Number, Pure, false, "MIN(a, b)", "the smaller of two numbers"),
    def!(Max, "MAX", [N, N], 0, Number, Pure, false, "MAX(a, b)", "the larger of two numbers"),
    def!(Round, "ROUND", [N, N], 1, Number, Pure, false, "ROUND(x[, decimals])", "x rounded to a number of decimals (default 0), halves away from zero"),
    def!(Int, "INT", [N], 0, Number, Pure, false, "INT(x)", "the largest whole number not above x"),
    def!(Sgn, "SGN", [N], 0, Number, Pure, false, "SGN(x)", "-1, 0 or 1: the sign of x"),
    def!(Str, "STR$", [N], 0, Str, Pure, false, "STR$(x)", "a number as text, as PRINT shows it"),
    def!(Format, "FORMAT$", [N, S], 0, Str, Pure, false, "FORMAT$(x, \"0.00\")", "a number as text by a pattern: the 0s after the point are the decimals, the 0s before it the fewest digits of the whole part"),
    def!(Len, "LEN", [S], 0, Number, Pure, false, "LEN(s)", "the number of characters of a string"),
    def!(Left, "LEFT$", [S, N], 0, Str, Pure, false, "LEFT$(s, n)", "the first n characters"),
    def!(Right, "RIGHT$", [S, N], 0, Str, Pure, false, "RIGHT$(s, n)", "the last n characters"),
    def!(Mid, "MID$", [S, N, N], 1, Str, Pure, false, "MID$(s, start[, n])", "n characters (default: the rest) from character start (from 1)"),
    def!(Val, "VAL", [S], 0, Number, Pure, false, "VAL(s)", "the number a string holds; a string that is not a number is a run-time error"),
    def!(Ucase, "UCASE$", [S], 0, Str, Pure, false, "UCASE$(s)", "the string in upper case"),
    def!(Lcase, "LCASE$", [S], 0, Str, Pure, false, "LCASE$(s)", "the string in lower case"),
    def!(Instr, "INSTR", [S, S], 0, Number, Pure, false, "INSTR(s, part)", "where part first appears in s (from 1), or 0"),
    def!(Here, "HERE", [], 0, Pose, Io, false, "HERE()", "the current pose of the tool centre point (where the last motion ended)"),
    def!(In, "IN", [N], 0, Bool, Io, false, "IN(n)", "the level of input bit n (0-31), TRUE or FALSE"),
    def!(Timer, "TIMER", [], 0, Number, Io, false, "TIMER()", "seconds since the program started [s]"),
    def!(Dist, "DIST", [P, P], 0, Number, Pure, false, "DIST(p, q)", "distance between two poses' points [mm]"),
    def!(RelTool, "RELTOOL", [P, N, N, N, N], 1, Pose, Pure, false, "RELTOOL(p, dx, dy, dz[, dyaw])", "p moved in its own tool frame: dx along the hand, dy to its left, dz up [mm], the hand turned by dyaw [deg]"),
    def!(InFrame, "INFRAME", [P, P], 0, Pose, Pure, false, "INFRAME(frame, p)", "p given in a user frame (its origin and yaw), in the base frame"),
    def!(ToFrame, "TOFRAME", [P, P], 0, Pose, Pure, false, "TOFRAME(frame, p)", "p of the base frame, in a user frame"),
    def!(Err, "ERR", [], 0, Number, Vm, true, "ERR", "the code of the error being handled (docs/protocol.md, or a RAISE code); 0 outside a CATCH"),
    def!(ErrMsg, "ERRMSG$", [], 0, Str, Vm, true, "ERRMSG$", "the text of the error being handled"),
    def!(ErrLine, "ERRLINE", [], 0, Number, Vm, true, "ERRLINE", "the source line of the error being handled"),
    def!(Operator, "OPERATOR$", [], 0, Str, Vm, true, "OPERATOR$", "the word the operator answered the last WAIT OPERATOR with (CONTINUE word), or \"\""),
    def!(Slot, "SLOT", [ST, N], 0, Number, Host, false, "SLOT(station, n)", "the wafer map's state of a slot: 0 empty, 1 a wafer, 2 a double wafer, 3 a cross-slotted one, -1 not mapped, -2 uncertain (after a transfer a power loss interrupted)"),
    def!(Wafer, "WAFER$", [ST, N], 0, Str, Host, false, "WAFER$(station, n)", "the id of the wafer in a slot (\"W3\"), or \"\""),
    def!(Hand, "HAND$", [Param::Blade], 1, Str, Host, false, "HAND$([A|B])", "the id of the wafer on the hand (or blade A or B), or \"\""),
    def!(Slots, "SLOTS", [ST], 0, Number, Host, false, "SLOTS(station)", "the station's number of slots"),
    def!(Pitch, "PITCH", [ST], 0, Number, Host, false, "PITCH(station)", "the station's slot pitch [mm]"),
    def!(Station, "STATION", [ST], 0, Pose, Host, false, "STATION(station)", "the station's taught pose: slot 1's wafer centre and support height, the hand's yaw into it"),
    def!(Approach, "APPROACH", [ST], 0, Number, Host, false, "APPROACH(station)", "how far back along the hand the robot waits before entering the station [mm]"),
];

/// The row of a name (upper case).
pub(crate) fn find(key: &str) -> Option<&'static BuiltinDef> {
    BUILTINS.iter().find(|d| d.name == key)
}

impl Builtin {
    /// Its row.
    pub(crate) fn def(self) -> &'static BuiltinDef {
        // Every variant has exactly one row (a test checks it).
        BUILTINS
            .iter()
            .find(|d| d.builtin == self)
            .unwrap_or(&BUILTINS[0])
    }

    /// The name, upper case.
    pub fn name(self) -> &'static str {
        self.def().name
    }

    /// Its number in the bytecode (its row's index; rows are only ever appended).
    pub(crate) fn code(self) -> u8 {
        BUILTINS.iter().position(|d| d.builtin == self).unwrap_or(0) as u8
    }

    pub(crate) fn from_code(code: u8) -> Option<Builtin> {
        BUILTINS.get(usize::from(code)).map(|d| d.builtin)
    }

    /// Evaluate a pure built-in on `args` (already of the right types); `strings` is the
    /// program's string table (for string literals).
    pub(crate) fn eval(
        self,
        args: &[Value],
        strings: &[String],
    ) -> Result<Value, RuntimeErrorKind> {
        let num = |i: usize| match args.get(i) {
            Some(Value::Num(x)) => Ok(*x),
            _ => Err(MISMATCH),
        };
        let text = |i: usize| {
            args.get(i)
                .and_then(|v| value::text_of(v, strings))
                .ok_or(MISMATCH)
        };
        let pose = |i: usize| match args.get(i) {
            Some(Value::Pose(p)) => Ok(*p),
            _ => Err(MISMATCH),
        };
        let n = value::num;
        match self {
            Builtin::Sin => n(num(0)?.to_radians().sin()),
            Builtin::Cos => n(num(0)?.to_radians().cos()),
            Builtin::Tan => {
                let a = num(0)?;
                // tan is infinite at ±90° (the f64 value of 90° in radians is not exactly
                // π/2, so its tangent is huge rather than infinite).
                if (a.rem_euclid(180.0) - 90.0).abs() < 1e-12 {
                    return Err(RuntimeErrorKind::NotFinite);
                }
                n(a.to_radians().tan())
            }
            Builtin::Asin | Builtin::Acos => {
                let x = num(0)?;
                if !(-1.0..=1.0).contains(&x) {
                    return Err(RuntimeErrorKind::BadArgument(
                        "ASIN and ACOS take a number from -1 to 1",
                    ));
                }
                let r = if self == Builtin::Asin {
                    x.asin()
                } else {
                    x.acos()
                };
                n(r.to_degrees())
            }
            Builtin::Atan2 => n(num(0)?.atan2(num(1)?).to_degrees()),
            Builtin::Sqrt => {
                let x = num(0)?;
                if x < 0.0 {
                    return Err(RuntimeErrorKind::BadArgument("SQRT of a negative number"));
                }
                n(x.sqrt())
            }
            Builtin::Abs => n(num(0)?.abs()),
            Builtin::Min => n(num(0)?.min(num(1)?)),
            Builtin::Max => n(num(0)?.max(num(1)?)),
            Builtin::Round => {
                let digits = if args.len() > 1 { num(1)? } else { 0.0 };
                n(round(num(0)?, decimals(digits)?))
            }
            Builtin::Int => n(num(0)?.floor()),
            Builtin::Sgn => {
                let x = num(0)?;
                n(if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else {
                    0.0
                })
            }
            Builtin::Str => {
                let mut t = Text::EMPTY;
                crate::vm::write_number(&mut t, num(0)?).map_err(|_| TOO_LONG)?;
                Ok(Value::Text(t))
            }
            Builtin::Format => format(num(0)?, text(1)?).map(Value::Text),
            Builtin::Len => n(text(0)?.chars().count() as f64),
            Builtin::Left | Builtin::Right => {
                let s = text(0)?;
                let count = whole(num(1)?, "LEFT$ and RIGHT$ take a count of 0 or more")?;
                let chars = s.chars().count();
                let (from, to) = if self == Builtin::Left {
                    (0, count.min(chars))
                } else {
                    (chars.saturating_sub(count), chars)
                };
                text_value(char_slice(s, from, to))
            }
            Builtin::Mid => {
                let s = text(0)?;
                let start = whole(num(1)?, "MID$ starts at character 1 or later")?;
                if start == 0 {
                    return Err(RuntimeErrorKind::BadArgument(
                        "MID$ starts at character 1 or later",
                    ));
                }
                let chars = s.chars().count();
                let from = (start - 1).min(chars);
                let to = if args.len() > 2 {
                    let count = whole(num(2)?, "MID$ takes a count of 0 or more")?;
                    from.saturating_add(count).min(chars)
                } else {
                    chars
                };
                text_value(char_slice(s, from, to))
            }
            Builtin::Val => match text(0)?.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(Value::Num(x)),
                _ => Err(RuntimeErrorKind::BadArgument(
                    "VAL of a string that is not a number",
                )),
            },
            Builtin::Ucase | Builtin::Lcase => {
                let mut t = Text::EMPTY;
                for c in text(0)?.chars() {
                    let mut buf = [0u8; 4];
                    let c = if self == Builtin::Ucase {
                        c.to_ascii_uppercase()
                    } else {
                        c.to_ascii_lowercase()
                    };
                    if !t.push(c.encode_utf8(&mut buf)) {
                        return Err(TOO_LONG);
                    }
                }
                Ok(Value::Text(t))
            }
            Builtin::Instr => {
                let (s, part) = (text(0)?, text(1)?);
                n(s.find(part)
                    .map_or(0.0, |at| (s[..at].chars().count() + 1) as f64))
            }
            Builtin::Dist => {
                let (p, q) = (pose(0)?, pose(1)?);
                n(((p.x - q.x).powi(2) + (p.y - q.y).powi(2) + (p.z - q.z).powi(2)).sqrt())
            }
            Builtin::RelTool => {
                let p = pose(0)?;
                let dyaw = if args.len() > 4 { num(4)? } else { 0.0 };
                value::pose(reltool(&p, num(1)?, num(2)?, num(3)?, dyaw))
            }
            Builtin::InFrame => value::pose(in_frame(&pose(0)?, &pose(1)?)),
            Builtin::ToFrame => value::pose(to_frame(&pose(0)?, &pose(1)?)),
            Builtin::Here
            | Builtin::In
            | Builtin::Timer
            | Builtin::Err
            | Builtin::ErrMsg
            | Builtin::ErrLine
            | Builtin::Operator
            | Builtin::Slot
            | Builtin::Wafer
            | Builtin::Hand
            | Builtin::Slots
            | Builtin::Pitch
            | Builtin::Station
            | Builtin::Approach => Err(RuntimeErrorKind::InvalidProgram("not a pure built-in")),
        }
    }
}

const MISMATCH: RuntimeErrorKind = RuntimeErrorKind::InvalidProgram("built-in argument types");
const TOO_LONG: RuntimeErrorKind = RuntimeErrorKind::BadArgument(value::TEXT_TOO_LONG);

fn text_value(s: &str) -> Result<Value, RuntimeErrorKind> {
    Text::new(s).map(Value::Text).ok_or(TOO_LONG)
}

/// A count or position: a whole number of 0 or more.
fn whole(x: f64, what: &'static str) -> Result<usize, RuntimeErrorKind> {
    if x >= 0.0 && x.fract() == 0.0 && x <= 1e9 {
        Ok(x as usize)
    } else {
        Err(RuntimeErrorKind::BadArgument(what))
    }
}

/// Characters `from..to` of `s`.
fn char_slice(s: &str, from: usize, to: usize) -> &str {
    let start = s.char_indices().nth(from).map_or(s.len(), |(i, _)| i);
    let end = s.char_indices().nth(to).map_or(s.len(), |(i, _)| i);
    &s[start..end.max(start)]
}

/// A number of decimals: a whole number from 0 to 12.
fn decimals(x: f64) -> Result<usize, RuntimeErrorKind> {
    if (0.0..=12.0).contains(&x) && x.fract() == 0.0 {
        Ok(x as usize)
    } else {
        Err(RuntimeErrorKind::BadArgument(
            "a number of decimals is a whole number from 0 to 12",
        ))
    }
}

/// `x` rounded to `d` decimals, halves away from zero.
fn round(x: f64, d: usize) -> f64 {
    let scale = 10f64.powi(d as i32);
    let r = (x * scale).round() / scale;
    if r.is_finite() {
        r
    } else {
        x
    }
}

/// `FORMAT$`: `pattern` is `0`s, with an optional `.` and more `0`s.
pub(crate) fn format(x: f64, pattern: &str) -> Result<Text, RuntimeErrorKind> {
    let (whole_part, frac) = match pattern.split_once('.') {
        Some((w, f)) => (w, f),
        None => (pattern, ""),
    };
    if whole_part.is_empty() && frac.is_empty()
        || !whole_part.bytes().all(|b| b == b'0')
        || !frac.bytes().all(|b| b == b'0')
    {
        return Err(RuntimeErrorKind::BadArgument(
            "a FORMAT$ pattern is 0s with an optional point, like \"0.00\" or \"000\"",
        ));
    }
    let d = frac.len().min(12);
    let width = whole_part.len();
    let r = round(x, d);
    let r = if r == 0.0 { 0.0 } else { r }; // no "-0.00"
    let mut t = Text::EMPTY;
    let negative = r < 0.0;
    // The digits of the whole part padded to `width`, the sign in front.
    let mut digits = Text::EMPTY;
    write!(digits, "{:.*}", d, r.abs()).map_err(|_| TOO_LONG)?;
    let int_len = digits.as_str().find('.').unwrap_or(digits.as_str().len());
    if negative && !t.push("-") {
        return Err(TOO_LONG);
    }
    for _ in int_len..width {
        if !t.push("0") {
            return Err(TOO_LONG);
        }
    }
    if !t.push(digits.as_str()) {
        return Err(TOO_LONG);
    }
    Ok(t)
}

/// `RELTOOL`: `p` moved in its own tool frame (x along the hand, y to its left, z up).
pub(crate) fn reltool(p: &Pose, dx: f64, dy: f64, dz: f64, dyaw: f64) -> Pose {
    let (s, c) = p.yaw.to_radians().sin_cos();
    Pose {
        x: p.x + dx * c - dy * s,
        y: p.y + dx * s + dy * c,
        z: p.z + dz,
        yaw: p.yaw + dyaw,
    }
}

/// `INFRAME`: `p`, given in `frame` (its origin x, y, z and its yaw), in the base frame.
pub(crate) fn in_frame(frame: &Pose, p: &Pose) -> Pose {
    let (s, c) = frame.yaw.to_radians().sin_cos();
    Pose {
        x: frame.x + p.x * c - p.y * s,
        y: frame.y + p.x * s + p.y * c,
        z: frame.z + p.z,
        yaw: frame.yaw + p.yaw,
    }
}

/// `TOFRAME`: `p` of the base frame, in `frame`.
pub(crate) fn to_frame(frame: &Pose, p: &Pose) -> Pose {
    let (s, c) = frame.yaw.to_radians().sin_cos();
    let (dx, dy) = (p.x - frame.x, p.y - frame.y);
    Pose {
        x: dx * c + dy * s,
        y: -dx * s + dy * c,
        z: p.z - frame.z,
        yaw: p.yaw - frame.yaw,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(v: Value) -> String {
        match v {
            Value::Text(t) => t.as_str().to_string(),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn every_builtin_has_one_row_and_its_code_round_trips() {
        for (i, d) in BUILTINS.iter().enumerate() {
            assert_eq!(d.builtin.code() as usize, i, "{}", d.name);
            assert_eq!(Builtin::from_code(i as u8), Some(d.builtin));
            assert_eq!(
                BUILTINS.iter().filter(|e| e.builtin == d.builtin).count(),
                1
            );
            assert!(usize::from(d.optional) <= d.params.len());
        }
    }

    #[test]
    fn format_pads_and_rounds() {
        let f = |x: f64, p: &str| format(x, p).map(|t| t.as_str().to_string());
        assert_eq!(f(1.23456, "0.00").unwrap(), "1.23");
        assert_eq!(f(7.0, "000").unwrap(), "007");
        assert_eq!(f(2.5, "0").unwrap(), "3");
        assert_eq!(f(-2.5, "0").unwrap(), "-3");
        assert_eq!(f(-0.001, "0.00").unwrap(), "0.00");
        assert_eq!(f(-4.25, "000.0").unwrap(), "-004.3");
        assert_eq!(f(1234.5, "0").unwrap(), "1235");
        assert!(f(1.0, "#.##").is_err());
        assert!(f(1.0, "").is_err());
    }

    #[test]
    fn strings_count_characters_not_bytes() {
        let s = [Value::Text(Text::new("wafér").unwrap()), Value::Num(2.0)];
        assert_eq!(t(Builtin::Right.eval(&s, &[]).unwrap()), "ér");
        assert_eq!(Builtin::Len.eval(&s[..1], &[]), Ok(Value::Num(5.0)));
        let mid = [s[0], Value::Num(2.0), Value::Num(3.0)];
        assert_eq!(t(Builtin::Mid.eval(&mid, &[]).unwrap()), "afé");
        let past = [s[0], Value::Num(9.0)];
        assert_eq!(t(Builtin::Mid.eval(&past, &[]).unwrap()), "");
        let find = [s[0], Value::Text(Text::new("ér").unwrap())];
        assert_eq!(Builtin::Instr.eval(&find, &[]), Ok(Value::Num(4.0)));
    }

    #[test]
    fn frames_invert_each_other() {
        let frame = Pose {
            x: 100.0,
            y: -50.0,
            z: 10.0,
            yaw: 30.0,
        };
        let p = Pose {
            x: 12.0,
            y: 34.0,
            z: 5.0,
            yaw: -10.0,
        };
        let back = to_frame(&frame, &in_frame(&frame, &p));
        for (a, b) in [
            (back.x, p.x),
            (back.y, p.y),
            (back.z, p.z),
            (back.yaw, p.yaw),
        ] {
            assert!((a - b).abs() < 1e-9, "{back:?}");
        }
        // RELTOOL along the hand of a pose at yaw 90: +y.
        let q = reltool(
            &Pose {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                yaw: 90.0,
            },
            10.0,
            0.0,
            0.0,
            0.0,
        );
        assert!(q.x.abs() < 1e-9 && (q.y - 10.0).abs() < 1e-9, "{q:?}");
    }
}
