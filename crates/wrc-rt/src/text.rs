//! Text formatted in a real-time cycle: a fixed-capacity buffer on the stack that implements
//! [`core::fmt::Write`], so `write!` works without a heap. What does not fit is cut at a
//! character boundary (the text stays valid UTF-8) and [`FixedText::truncated`] says so.
//!
//! ```
//! use std::fmt::Write;
//! use wrc_rt::FixedText;
//!
//! let mut t = FixedText::<16>::new();
//! let _ = write!(t, "speed={}", 80);
//! assert_eq!(t.as_str(), "speed=80");
//! let _ = write!(t, " and a great deal more");
//! assert_eq!(t.as_str(), "speed=80 and a g");
//! assert!(t.truncated());
//! ```

use core::fmt;

/// Up to `N` bytes of UTF-8 text, formatted in place (no allocation, `Copy`).
#[derive(Clone, Copy)]
pub struct FixedText<const N: usize> {
    buf: [u8; N],
    len: usize,
    truncated: bool,
}

impl<const N: usize> FixedText<N> {
    /// Empty text.
    pub const fn new() -> Self {
        FixedText {
            buf: [0; N],
            len: 0,
            truncated: false,
        }
    }

    /// The text written so far.
    pub fn as_str(&self) -> &str {
        // Only whole characters of `&str`s are ever copied in.
        core::str::from_utf8(&self.buf[..self.len]).unwrap_or("")
    }

    /// Its bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Whether something written did not fit (and was cut at a character boundary).
    pub fn truncated(&self) -> bool {
        self.truncated
    }
}

impl<const N: usize> Default for FixedText<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> fmt::Write for FixedText<N> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let room = N - self.len;
        let mut take = s.len().min(room);
        while !s.is_char_boundary(take) {
            take -= 1;
        }
        self.buf[self.len..self.len + take].copy_from_slice(&s.as_bytes()[..take]);
        self.len += take;
        if take < s.len() {
            self.truncated = true;
            return Err(fmt::Error);
        }
        Ok(())
    }
}

impl<const N: usize> fmt::Debug for FixedText<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

impl<const N: usize> fmt::Display for FixedText<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmt::Write;

    #[test]
    fn a_cut_keeps_whole_characters() {
        let mut t = FixedText::<5>::new();
        assert!(write!(t, "ab°c").is_ok()); // ° is 2 bytes: 5 in all
        assert_eq!(t.as_str(), "ab°c");
        let mut t = FixedText::<3>::new();
        assert!(write!(t, "a°b").is_err());
        assert_eq!(t.as_str(), "a°");
        let mut t = FixedText::<2>::new();
        assert!(write!(t, "a°").is_err());
        assert_eq!(t.as_str(), "a");
        assert!(t.truncated());
        assert!(!FixedText::<4>::new().truncated());
    }
}
