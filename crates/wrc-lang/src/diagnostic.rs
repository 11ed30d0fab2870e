//! Compiler diagnostics: an error or warning at a line, column and span, rendered like rustc
//! with the source line and a caret (`^~~~`) under the span.

use core::fmt;

/// A place in the source: line and column [1-based, characters] and a length [characters],
/// in source file `file` (0: the program compiled; others: its INCLUDEd libraries and the
/// programs it calls, in the order they were loaded).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Span {
    pub line: u32,
    pub col: u32,
    pub len: u32,
    pub file: u16,
}

impl Span {
    /// A span from the start of `self` to the end of `end` (on the same line; otherwise
    /// `self`).
    pub fn to(self, end: Span) -> Span {
        if end.file == self.file && end.line == self.line && end.col + end.len > self.col {
            Span {
                len: end.col + end.len - self.col,
                ..self
            }
        } else {
            self
        }
    }

    /// `line:col`, as messages cite other places.
    pub fn at(self) -> String {
        format!("{}:{}", self.line, self.col)
    }

    /// A span at the start of line `line` of file `file`.
    pub fn line_start(file: u16, line: u32) -> Span {
        Span {
            line,
            col: 1,
            len: 1,
            file,
        }
    }
}

/// How serious a diagnostic is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The program does not compile.
    Error,
    /// The program compiles, but something in it is probably not what was meant.
    Warning,
}

impl Severity {
    /// `error` or `warning`.
    pub fn as_str(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
        }
    }
}

/// One error or warning of the compiler.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// The source file it is in: `None` for the program compiled, the name of an INCLUDEd
    /// library or a called program otherwise ([`crate::Compiled::sources`] has its text).
    pub file: Option<String>,
    /// Index of that file ([`crate::Compiled::sources`]; 0 for the program compiled).
    pub file_index: u16,
    /// Line [1-based].
    pub line: u32,
    /// Column [1-based, in characters; a tab counts as one].
    pub col: u32,
    /// Length of the marked span [characters, at least 1].
    pub len: u32,
    /// One plain sentence: what is wrong, and where it helps, what to do.
    pub message: String,
}

impl Diagnostic {
    pub(crate) fn error(span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Error, span, message.into())
    }

    pub(crate) fn warning(span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Warning, span, message.into())
    }

    fn new(severity: Severity, span: Span, message: String) -> Diagnostic {
        Diagnostic {
            severity,
            file: None,
            file_index: span.file,
            line: span.line.max(1),
            col: span.col.max(1),
            len: span.len.max(1),
            message,
        }
    }

    /// `true` for an error.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The diagnostic as rustc prints one: severity and message, `--> file:line:col`, the
    /// source line and a caret with tildes under the span, each line ending in `\n`.
    ///
    /// ```text
    /// error: expected ENDIF to close IF at 3:1, found ENDWHILE
    ///  --> cell.wrl:7:1
    ///   |
    /// 7 | ENDWHILE
    ///   | ^~~~~~~~
    /// ```
    pub fn render(&self, file: &str, source: &str) -> String {
        let text = source_line(source, self.line);
        let number = self.line.to_string();
        let pad = " ".repeat(number.len());
        let shown: String = text
            .chars()
            .map(|c| if c.is_control() { ' ' } else { c })
            .collect();
        let width = shown.chars().count() as u32;
        let start = self.col.saturating_sub(1);
        // Keep the caret on the line, or just past its end (a missing token at the end).
        let start = start.min(width);
        let len = self.len.min(width.saturating_sub(start)).max(1);
        let mut marker = " ".repeat(start as usize);
        marker.push('^');
        for _ in 1..len {
            marker.push('~');
        }
        format!(
            "{}: {}\n{pad}--> {file}:{}:{}\n{pad} |\n{number} | {}\n{pad} | {marker}\n",
            self.severity.as_str(),
            self.message,
            self.line,
            self.col,
            shown.trim_end(),
        )
    }
}

impl fmt::Display for Diagnostic {
    /// `line:col: severity: message`, on one line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}: {}: {}",
            self.line,
            self.col,
            self.severity.as_str(),
            self.message
        )
    }
}

/// Line `line` [1-based] of `source` without its line ending, or "" past the end.
fn source_line(source: &str, line: u32) -> &str {
    let index = (line as usize).saturating_sub(1);
    source
        .split('\n')
        .nth(index)
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .unwrap_or("")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_puts_the_caret_under_the_span() {
        let d = Diagnostic::error(
            Span {
                line: 2,
                col: 3,
                len: 4,
                file: 0,
            },
            "bad",
        );
        let out = d.render("a.wrl", "X = 1\n  FOO = 2\n");
        assert_eq!(
            out,
            "error: bad\n --> a.wrl:2:3\n  |\n2 |   FOO = 2\n  |   ^~~~\n"
        );
    }

    #[test]
    fn render_past_the_end_of_the_file_does_not_panic() {
        let d = Diagnostic::warning(
            Span {
                line: 99,
                col: 40,
                len: 7,
                file: 0,
            },
            "x",
        );
        assert!(d.render("a.wrl", "é\u{0}\t").contains("99 | \n"));
    }
}
