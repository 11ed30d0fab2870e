//! Types and values of the language, and the arithmetic both the compiler (folding constant
//! expressions) and the VM use, so both agree on every result. No allocation.

use core::fmt;

use wrc_robot::{InlineName, Joints, Pose, MAX_AXES};

use crate::error::RuntimeErrorKind;

/// The type of a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Ty {
    /// A number (f64).
    Number,
    /// TRUE or FALSE.
    Bool,
    /// A string (only literals; for PRINT).
    Str,
    /// A Cartesian pose: x, y, z [mm], yaw [deg].
    Pose,
    /// Joint positions, one per robot axis [deg or mm].
    Joints,
}

impl Ty {
    /// The type's name in messages and listings: `number`, `boolean`, `string`, `pose`,
    /// `joints`.
    pub fn name(self) -> &'static str {
        match self {
            Ty::Number => "number",
            Ty::Bool => "boolean",
            Ty::Str => "string",
            Ty::Pose => "pose",
            Ty::Joints => "joints",
        }
    }

    pub(crate) fn with_article(self) -> &'static str {
        match self {
            Ty::Number => "a number",
            Ty::Bool => "TRUE or FALSE (a comparison)",
            Ty::Str => "a string",
            Ty::Pose => "a pose (POSE(x, y, z, yaw))",
            Ty::Joints => "joints (JOINTS(...))",
        }
    }

    pub(crate) fn code(self) -> u8 {
        match self {
            Ty::Number => 0,
            Ty::Bool => 1,
            Ty::Str => 2,
            Ty::Pose => 3,
            Ty::Joints => 4,
        }
    }

    pub(crate) fn from_code(code: u8) -> Option<Ty> {
        Some(match code {
            0 => Ty::Number,
            1 => Ty::Bool,
            2 => Ty::Str,
            3 => Ty::Pose,
            4 => Ty::Joints,
            _ => return None,
        })
    }
}

impl fmt::Display for Ty {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Longest text a string value built at run time holds [bytes] (`"a" + "b"`, `STR$`,
/// `FORMAT$`, a host's answer); string literals of any length live in the program's string
/// table.
pub const TEXT_CAPACITY: usize = 126;

/// The error text of a string that would be longer than [`TEXT_CAPACITY`].
pub(crate) const TEXT_TOO_LONG: &str =
    "a string built while the program runs is limited to 126 bytes";

/// A string built at run time, inline (no heap): at most [`TEXT_CAPACITY`] bytes of UTF-8.
#[derive(Clone, Copy)]
pub struct Text {
    len: u8,
    bytes: [u8; TEXT_CAPACITY],
}

impl Text {
    /// The empty text.
    pub const EMPTY: Text = Text {
        len: 0,
        bytes: [0; TEXT_CAPACITY],
    };

    /// `text`, or `None` when it is longer than [`TEXT_CAPACITY`] bytes.
    pub fn new(text: &str) -> Option<Text> {
        let mut t = Text::EMPTY;
        t.push(text).then_some(t)
    }

    /// `text` cut at [`TEXT_CAPACITY`] bytes on a character boundary.
    pub fn cut(text: &str) -> Text {
        let mut n = text.len().min(TEXT_CAPACITY);
        while !text.is_char_boundary(n) {
            n -= 1;
        }
        let mut t = Text::EMPTY;
        t.push(&text[..n]);
        t
    }

    /// Append `text`; `false` (and nothing appended) when it does not fit.
    pub fn push(&mut self, text: &str) -> bool {
        let len = usize::from(self.len);
        let end = len + text.len();
        if end > TEXT_CAPACITY {
            return false;
        }
        self.bytes[len..end].copy_from_slice(text.as_bytes());
        self.len = end as u8;
        true
    }

    /// The text.
    pub fn as_str(&self) -> &str {
        // Only whole `&str`s are ever copied in, so the bytes are UTF-8.
        core::str::from_utf8(&self.bytes[..usize::from(self.len)]).unwrap_or("")
    }
}

impl PartialEq for Text {
    fn eq(&self, other: &Text) -> bool {
        self.as_str() == other.as_str()
    }
}

impl fmt::Debug for Text {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

impl fmt::Write for Text {
    /// Appends, or fails when the text would not fit (nothing of `s` is appended then).
    fn write_str(&mut self, s: &str) -> fmt::Result {
        if self.push(s) {
            Ok(())
        } else {
            Err(fmt::Error)
        }
    }
}

/// A value on the VM's stack or in a variable. `Copy`, no heap: a string literal is an
/// index into the program's string table, a string built at run time is inline [`Text`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Value {
    Num(f64),
    Bool(bool),
    /// String literal `$i` of the program's table (`u32::MAX`: the empty string).
    Str(u32),
    /// A string built at run time.
    Text(Text),
    Pose(Pose),
    Joints(Joints),
}

impl Value {
    /// The value a variable of type `ty` holds before its first assignment.
    pub fn zero(ty: Ty) -> Value {
        match ty {
            Ty::Number => Value::Num(0.0),
            Ty::Bool => Value::Bool(false),
            Ty::Str => Value::Text(Text::EMPTY),
            Ty::Pose => Value::Pose(Pose::default()),
            Ty::Joints => Value::Joints([0.0; MAX_AXES]),
        }
    }

    /// The type of the value.
    pub fn ty(&self) -> Ty {
        match self {
            Value::Num(_) => Ty::Number,
            Value::Bool(_) => Ty::Bool,
            Value::Str(_) | Value::Text(_) => Ty::Str,
            Value::Pose(_) => Ty::Pose,
            Value::Joints(_) => Ty::Joints,
        }
    }
}

/// The text of a string value, with `strings` the program's string table; `None` for a
/// value that is not a string.
pub(crate) fn text_of<'a>(v: &'a Value, strings: &'a [String]) -> Option<&'a str> {
    match v {
        Value::Str(i) => Some(strings.get(*i as usize).map_or("", |s| s.as_str())),
        Value::Text(t) => Some(t.as_str()),
        _ => None,
    }
}

type R = Result<Value, RuntimeErrorKind>;

pub(crate) fn num(x: f64) -> R {
    if x.is_finite() {
        Ok(Value::Num(x))
    } else {
        Err(RuntimeErrorKind::NotFinite)
    }
}

pub(crate) fn pose(p: Pose) -> R {
    if p.x.is_finite() && p.y.is_finite() && p.z.is_finite() && p.yaw.is_finite() {
        Ok(Value::Pose(p))
    } else {
        Err(RuntimeErrorKind::NotFinite)
    }
}

fn joints(j: Joints) -> R {
    if j.iter().all(|v| v.is_finite()) {
        Ok(Value::Joints(j))
    } else {
        Err(RuntimeErrorKind::NotFinite)
    }
}

const MISMATCH: RuntimeErrorKind = RuntimeErrorKind::InvalidProgram("operand types");

/// `-v`, `NOT v`.
pub(crate) fn negate(v: Value) -> R {
    match v {
        Value::Num(a) => num(-a),
        Value::Pose(p) => pose(Pose {
            x: -p.x,
            y: -p.y,
            z: -p.z,
            yaw: -p.yaw,
        }),
        Value::Joints(j) => joints(j.map(|v| -v)),
        _ => Err(MISMATCH),
    }
}

pub(crate) fn not(v: Value) -> R {
    match v {
        Value::Bool(b) => Ok(Value::Bool(!b)),
        _ => Err(MISMATCH),
    }
}

/// Arithmetic: numbers with numbers; poses and joints add and subtract field by field;
/// strings add (`"a" + "b"`), with `strings` the program's string table.
pub(crate) fn arith(op: Arith, a: Value, b: Value, strings: &[String]) -> R {
    if let (Some(x), Some(y), Arith::Add) = (text_of(&a, strings), text_of(&b, strings), op) {
        let mut t = Text::EMPTY;
        return if t.push(x) && t.push(y) {
            Ok(Value::Text(t))
        } else {
            Err(RuntimeErrorKind::BadArgument(TEXT_TOO_LONG))
        };
    }
    match (a, b) {
        (Value::Num(a), Value::Num(b)) => match op {
            Arith::Add => num(a + b),
            Arith::Sub => num(a - b),
            Arith::Mul => num(a * b),
            Arith::Div if b == 0.0 => Err(RuntimeErrorKind::DivisionByZero),
            Arith::Div => num(a / b),
            Arith::Mod if b == 0.0 => Err(RuntimeErrorKind::DivisionByZero),
            // The remainder takes the sign of the divisor (-7 MOD 3 = 2), as a slot
            // counter wrapping around expects.
            Arith::Mod => num(a - b * (a / b).floor()),
        },
        (Value::Pose(p), Value::Pose(q)) => {
            let s = match op {
                Arith::Add => 1.0,
                Arith::Sub => -1.0,
                _ => return Err(MISMATCH),
            };
            pose(Pose {
                x: p.x + s * q.x,
                y: p.y + s * q.y,
                z: p.z + s * q.z,
                yaw: p.yaw + s * q.yaw,
            })
        }
        (Value::Joints(p), Value::Joints(q)) => {
            let s = match op {
                Arith::Add => 1.0,
                Arith::Sub => -1.0,
                _ => return Err(MISMATCH),
            };
            let mut out = [0.0; MAX_AXES];
            for ((o, a), b) in out.iter_mut().zip(p).zip(q) {
                *o = a + s * b;
            }
            joints(out)
        }
        _ => Err(MISMATCH),
    }
}

/// The four arithmetic operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Arith {
    Add,
    Sub,
    Mul,
    Div,
    Mod,
}

/// The comparison operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Cmp {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

/// Comparison: numbers with every operator; booleans and strings with `=` and `<>` (strings
/// by their text, with `strings` the program's string table).
pub(crate) fn compare(op: Cmp, a: Value, b: Value, strings: &[String]) -> R {
    if let (Some(x), Some(y)) = (text_of(&a, strings), text_of(&b, strings)) {
        return match op {
            Cmp::Eq => Ok(Value::Bool(x == y)),
            Cmp::Ne => Ok(Value::Bool(x != y)),
            _ => Err(MISMATCH),
        };
    }
    let r = match (a, b) {
        (Value::Num(a), Value::Num(b)) => match op {
            Cmp::Eq => a == b,
            Cmp::Ne => a != b,
            Cmp::Lt => a < b,
            Cmp::Le => a <= b,
            Cmp::Gt => a > b,
            Cmp::Ge => a >= b,
        },
        (Value::Bool(a), Value::Bool(b)) => match op {
            Cmp::Eq => a == b,
            Cmp::Ne => a != b,
            _ => return Err(MISMATCH),
        },
        _ => return Err(MISMATCH),
    };
    Ok(Value::Bool(r))
}

/// `AND`, `OR`.
pub(crate) fn logic(and: bool, a: Value, b: Value) -> R {
    match (a, b) {
        (Value::Bool(a), Value::Bool(b)) => Ok(Value::Bool(if and { a && b } else { a || b })),
        _ => Err(MISMATCH),
    }
}

/// Field `index` of a pose: 0 x, 1 y, 2 z, 3 yaw.
pub(crate) fn pose_field(v: Value, index: u8) -> R {
    match v {
        Value::Pose(p) => Ok(Value::Num(match index {
            0 => p.x,
            1 => p.y,
            2 => p.z,
            3 => p.yaw,
            _ => return Err(RuntimeErrorKind::InvalidProgram("pose field")),
        })),
        _ => Err(MISMATCH),
    }
}

/// Joint `index` [0-based] of a joint vector.
pub(crate) fn joint_field(v: Value, index: u8) -> R {
    match v {
        Value::Joints(j) => j
            .get(usize::from(index))
            .map(|&x| Value::Num(x))
            .ok_or(RuntimeErrorKind::InvalidProgram("joint index")),
        _ => Err(MISMATCH),
    }
}

/// A signal level: 0 / 1 or FALSE / TRUE.
pub(crate) fn level(v: Value) -> Result<bool, RuntimeErrorKind> {
    match v {
        Value::Bool(b) => Ok(b),
        Value::Num(x) => {
            if x == 0.0 {
                Ok(false)
            } else if x == 1.0 {
                Ok(true)
            } else {
                Err(RuntimeErrorKind::BadArgument("a level must be 0 or 1"))
            }
        }
        _ => Err(MISMATCH),
    }
}

/// An I/O bit number: a whole number 0 to 31.
pub(crate) fn bit(v: Value) -> Result<u8, RuntimeErrorKind> {
    match v {
        Value::Num(x) if (0.0..=31.0).contains(&x) && x.fract() == 0.0 => Ok(x as u8),
        Value::Num(_) => Err(RuntimeErrorKind::BadArgument(
            "an I/O bit must be a whole number from 0 to 31",
        )),
        _ => Err(MISMATCH),
    }
}

/// Most pulses one JOG may ask for (pulse counts must stay exact in f64).
pub(crate) const MAX_JOG_PULSES: f64 = 1e15;

/// JOG pulses: a whole number, at most [`MAX_JOG_PULSES`] in size.
pub(crate) fn pulses(v: Value) -> Result<i64, RuntimeErrorKind> {
    match v {
        Value::Num(x) if x.fract() == 0.0 && x.abs() <= MAX_JOG_PULSES => Ok(x as i64),
        Value::Num(_) => Err(RuntimeErrorKind::BadArgument(
            "JOG pulses must be a whole number of at most 1e15",
        )),
        _ => Err(MISMATCH),
    }
}

/// SPEED: 1 to 100 [%].
pub(crate) fn speed(v: Value) -> Result<f64, RuntimeErrorKind> {
    match v {
        Value::Num(x) if (1.0..=100.0).contains(&x) => Ok(x),
        Value::Num(_) => Err(RuntimeErrorKind::BadArgument(
            "SPEED must be from 1 to 100 [%]",
        )),
        _ => Err(MISMATCH),
    }
}

/// An acceleration override: 1 to 100 [%].
pub(crate) fn accel(v: Value) -> Result<f64, RuntimeErrorKind> {
    match v {
        Value::Num(x) if (1.0..=100.0).contains(&x) => Ok(x),
        Value::Num(_) => Err(RuntimeErrorKind::BadArgument(
            "ACCEL must be from 1 to 100 [%]",
        )),
        _ => Err(MISMATCH),
    }
}

/// Largest BLEND zone [mm].
pub(crate) const MAX_ZONE_MM: f64 = 1000.0;

/// A BLEND zone: 0 to [`MAX_ZONE_MM`] [mm].
pub(crate) fn zone(v: Value) -> Result<f64, RuntimeErrorKind> {
    match v {
        Value::Num(x) if (0.0..=MAX_ZONE_MM).contains(&x) => Ok(x),
        Value::Num(_) => Err(RuntimeErrorKind::BadArgument(
            "a BLEND zone is 0 to 1000 mm",
        )),
        _ => Err(MISMATCH),
    }
}

/// An error or alarm code: a whole number from 1 to 65535.
pub(crate) fn error_code(v: Value) -> Result<u16, RuntimeErrorKind> {
    match v {
        Value::Num(x) if (1.0..=65535.0).contains(&x) && x.fract() == 0.0 => Ok(x as u16),
        Value::Num(_) => Err(RuntimeErrorKind::BadArgument(
            "a code is a whole number from 1 to 65535",
        )),
        _ => Err(MISMATCH),
    }
}

/// A distance [mm]: any finite number.
pub(crate) fn distance(v: Value) -> Result<f64, RuntimeErrorKind> {
    match v {
        Value::Num(x) => Ok(x),
        _ => Err(MISMATCH),
    }
}

/// A duration: 0 or more seconds.
pub(crate) fn seconds(v: Value) -> Result<f64, RuntimeErrorKind> {
    match v {
        Value::Num(x) if x >= 0.0 => Ok(x),
        Value::Num(_) => Err(RuntimeErrorKind::BadArgument(
            "a time must be 0 or more seconds",
        )),
        _ => Err(MISMATCH),
    }
}

/// Longest station name [characters]: the host protocol's station names
/// (`wrc_protocol::StationName`, `wrc_robot::InlineName<16>`).
pub(crate) const STATION_NAME_LEN: usize = 16;

/// A station name as GET, PUT and MAP take it: 1 to 16 ASCII letters, digits, `_` or `-`
/// (the rule of [`InlineName::new`], which does the check).
pub(crate) fn station(text: &str) -> Result<InlineName<STATION_NAME_LEN>, RuntimeErrorKind> {
    InlineName::new(text).ok_or(RuntimeErrorKind::BadArgument(
        "a station name must be 1 to 16 letters, digits, '_' or '-'",
    ))
}

/// Highest slot number GET and PUT take.
pub(crate) const MAX_SLOT: u16 = u16::MAX;

/// A slot number: a whole number from 1 to [`MAX_SLOT`].
pub(crate) fn slot(v: Value) -> Result<u16, RuntimeErrorKind> {
    match v {
        Value::Num(x) if (1.0..=f64::from(MAX_SLOT)).contains(&x) && x.fract() == 0.0 => {
            Ok(x as u16)
        }
        Value::Num(_) => Err(RuntimeErrorKind::BadArgument(
            "a slot must be a whole number from 1 to 65535",
        )),
        _ => Err(MISMATCH),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_whole_numbers_from_1_to_65535() {
        assert_eq!(slot(Value::Num(1.0)), Ok(1));
        assert_eq!(slot(Value::Num(65535.0)), Ok(65535));
        for bad in [0.0, -1.0, 1.5, 65536.0, 70000.0, f64::NAN, f64::INFINITY] {
            assert!(
                matches!(slot(Value::Num(bad)), Err(RuntimeErrorKind::BadArgument(_))),
                "{bad}"
            );
        }
        assert_eq!(slot(Value::Bool(true)), Err(MISMATCH));
    }

    #[test]
    fn station_names_follow_the_protocols_rule() {
        for good in ["LP1", "a", "load_port-2", "ABCDEFGHIJKLMNOP"] {
            assert_eq!(
                station(good).map(|n| n.as_str().to_string()),
                Ok(good.into())
            );
        }
        for bad in ["", "L P1", "bad name!", "ABCDEFGHIJKLMNOPQ", "LPé", "LP1\n"] {
            assert!(station(bad).is_err(), "{bad:?}");
        }
    }
}
