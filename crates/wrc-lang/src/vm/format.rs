//! How values become text: numbers (one format everywhere: PRINT, STR$, the checker's
//! messages, the debugger), poses, joints and strings, written into fixed buffers without
//! allocating.

use core::fmt::{self, Write as _};

use wrc_robot::MAX_AXES;

use crate::bytecode::Program;
use crate::value::{self, Value};

/// A text buffer of fixed capacity: text is cut there, on a character boundary.
#[derive(Debug)]
pub(crate) struct TextBuffer {
    pub bytes: Box<[u8]>,
    pub len: usize,
}

impl TextBuffer {
    pub fn new(capacity: usize) -> TextBuffer {
        TextBuffer {
            bytes: vec![0; capacity].into_boxed_slice(),
            len: 0,
        }
    }

    pub fn clear(&mut self) {
        self.len = 0;
    }

    pub fn as_str(&self) -> &str {
        let bytes = self.bytes.get(..self.len).unwrap_or(&[]);
        core::str::from_utf8(bytes).unwrap_or("")
    }
}

impl fmt::Write for TextBuffer {
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

/// A value as PRINT shows it (`quoted`: strings in double quotes, as the debugger shows
/// them).
pub(crate) fn write_value(
    w: &mut impl fmt::Write,
    program: &Program,
    v: &Value,
    quoted: bool,
) -> fmt::Result {
    match v {
        Value::Num(x) => write_number(w, *x),
        Value::Bool(b) => w.write_str(if *b { "TRUE" } else { "FALSE" }),
        Value::Str(_) | Value::Text(_) => {
            let text = value::text_of(v, &program.strings).unwrap_or("");
            if quoted {
                w.write_char('"')?;
                for c in text.chars() {
                    if c == '"' {
                        w.write_str("\"\"")?;
                    } else {
                        w.write_char(c)?;
                    }
                }
                w.write_char('"')
            } else {
                w.write_str(text)
            }
        }
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
    fn the_text_buffer_cuts_on_a_character_boundary() {
        let mut b = TextBuffer::new(5);
        b.write_str("abcé€").unwrap();
        assert_eq!(b.as_str(), "abcé");
    }
}
