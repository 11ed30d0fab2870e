//! An uploaded program: the lines a connection sends between `UPLOAD <name>` and the line
//! `.`, collected into text ([`ProgramText`]), and what the compiler says about a program as
//! protocol text ([`check`]: one `EVT DIAG` body per diagnostic, the `NAK 126` text on
//! errors). Plain data and no I/O; it allocates, so it runs on the service thread, which
//! stores the text and sends the lines.
//!
//! ```
//! use wrc_controller::upload::{check, ProgramText};
//! use wrc_protocol::ProgramName;
//! use wrc_robot::Robot;
//!
//! let name = ProgramName::new("demo").unwrap();
//! let mut text = ProgramText::new();
//! for line in [&b"HOME"[..], b"MOVEJ JOINTS(0, 90, -90, 10)", b"BOGUS 1"] {
//!     text.push_line(line);
//! }
//! let source = text.finish(&name).unwrap();
//! let verdict = check(&name, &source, &Robot::paper_default(), None);
//! assert!(verdict.diagnostics[0].starts_with("demo.wrl:3:1: error: "));
//! assert!(verdict.result.unwrap_err().starts_with("demo: 1 error; first: 3:1 "));
//! ```

use std::fmt::Write as _;

use wrc_lang::{Program, Severity};
use wrc_protocol::ProgramName;
use wrc_robot::Robot;

/// Most lines in an uploaded program.
pub const MAX_PROGRAM_LINES: usize = 10_000;

/// The text of a program being uploaded, one line at a time.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ProgramText {
    text: String,
    lines: usize,
}

impl ProgramText {
    /// No lines yet.
    pub fn new() -> ProgramText {
        ProgramText::default()
    }

    /// Append one line as received (without its line end). Bytes that are not UTF-8 become
    /// U+FFFD, for the compiler to refuse with a position. Lines past
    /// [`MAX_PROGRAM_LINES`] are counted, not kept.
    pub fn push_line(&mut self, line: &[u8]) {
        self.lines += 1;
        if self.lines <= MAX_PROGRAM_LINES {
            self.text.push_str(&String::from_utf8_lossy(line));
            self.text.push('\n');
        }
    }

    /// Lines received so far.
    pub fn lines(&self) -> usize {
        self.lines
    }

    /// The program's text, or the `NAK 126` text when it has more than
    /// [`MAX_PROGRAM_LINES`] lines.
    pub fn finish(self, name: &ProgramName) -> Result<String, String> {
        if self.lines > MAX_PROGRAM_LINES {
            return Err(format!(
                "{name}: {} lines; a program may have at most {MAX_PROGRAM_LINES}; nothing stored",
                self.lines
            ));
        }
        Ok(self.text)
    }
}

/// What the compiler says about a program, as protocol text.
#[derive(Debug)]
pub struct Verdict {
    /// One `EVT DIAG` body per diagnostic, in the compiler's order:
    /// `<name>.wrl:<line>:<col>: error: <message>` (or `warning:`).
    pub diagnostics: Vec<String>,
    /// The program and its number of warnings, or the `NAK 126` text when it has errors:
    /// `<name>: <n> error(s); first: <line>:<col> <message>`.
    pub result: Result<(Program, usize), String>,
}

/// Compile `source`, the program `name`, for `robot`, with its libraries, the programs it
/// calls and its points file from `sources` (none: a program on its own).
pub fn check(
    name: &ProgramName,
    source: &str,
    robot: &Robot,
    sources: Option<&dyn wrc_lang::Sources>,
) -> Verdict {
    let file = format!("{name}.wrl");
    let compiled = wrc_lang::compile_with(
        source,
        &file,
        robot,
        &wrc_lang::CompileOptions {
            name: name.as_str(),
            sources,
        },
    );
    let mut errors = 0;
    let mut warnings = 0;
    let mut first_error = String::new();
    let mut diagnostics = Vec::with_capacity(compiled.diagnostics.len());
    for d in &compiled.diagnostics {
        let severity = match d.severity {
            Severity::Error => {
                errors += 1;
                "error"
            }
            _ => {
                warnings += 1;
                "warning"
            }
        };
        // Replies are printable ASCII: write the compiler's ellipsis as three dots rather
        // than let the line writer turn it into '?'.
        let message = d
            .message
            .replace('\u{2026}', "...")
            .replace('\u{2192}', "->");
        let mut text = String::new();
        let shown = match &d.file {
            Some(other) => format!("{other}.wrl"),
            None => file.clone(),
        };
        let _ = write!(text, "{shown}:{}:{}: {severity}: {message}", d.line, d.col);
        if severity == "error" && first_error.is_empty() {
            first_error = format!("{}:{} {message}", d.line, d.col);
        }
        diagnostics.push(text);
    }
    let result = match compiled.program {
        Some(program) if errors == 0 => Ok((program, warnings)),
        _ => Err(format!(
            "{name}: {errors} error{}; first: {first_error}",
            if errors == 1 { "" } else { "s" }
        )),
    };
    Verdict {
        diagnostics,
        result,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn name() -> ProgramName {
        ProgramName::new("p").unwrap()
    }

    #[test]
    fn lines_are_kept_with_their_line_ends_and_bad_utf8_is_replaced() {
        let mut text = ProgramText::new();
        text.push_line(b"HOME");
        text.push_line(b"PRINT \"\xFF\"");
        assert_eq!(text.lines(), 2);
        assert_eq!(text.finish(&name()).unwrap(), "HOME\nPRINT \"\u{FFFD}\"\n");
    }

    #[test]
    fn a_program_over_the_line_limit_is_refused_with_its_count() {
        let mut text = ProgramText::new();
        for _ in 0..=MAX_PROGRAM_LINES {
            text.push_line(b"HOME");
        }
        assert_eq!(
            text.finish(&name()).unwrap_err(),
            "p: 10001 lines; a program may have at most 10000; nothing stored"
        );
    }

    #[test]
    fn a_good_program_compiles_and_a_bad_one_names_its_first_error() {
        let robot = Robot::paper_default();
        let good = check(&name(), "HOME\n", &robot, None);
        assert!(good.diagnostics.is_empty());
        assert_eq!(good.result.unwrap().1, 0);
        let bad = check(&name(), "HOME\nBOGUS\nBOGUS\n", &robot, None);
        assert_eq!(bad.diagnostics.len(), 2);
        assert!(bad.diagnostics[0].starts_with("p.wrl:2:1: error: "));
        assert!(bad
            .result
            .unwrap_err()
            .starts_with("p: 2 errors; first: 2:1 "));
    }
}
