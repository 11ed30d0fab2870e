//! The editor's compiler (`POST /api/compile`, `GET /api/language`): a program, the libraries
//! and called programs the browser sends with it (then those of the controller's program
//! folder), and its named points, compiled by wrc-lang against the robot of `wrc ui`'s
//! configuration. It needs no controller, so the editor checks a program while the
//! controller is down. Plain functions on plain data; the HTTP side is in `api.rs`.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};
use wrc_lang::{CompileOptions, DirSources, Severity, Sources};
use wrc_robot::Robot;

/// Largest compile request [bytes]: a program may have 10,000 lines of 256 bytes (2.5 MB),
/// and its libraries travel with it.
pub const MAX_REQUEST_BYTES: usize = 8 << 20;

/// Most lines the controller stores in one program (its `UPLOAD` refuses more).
pub const MAX_PROGRAM_LINES: usize = 10_000;

/// Longest line the controller's line protocol carries [bytes, without the LF], so the
/// longest line of a program that can be uploaded.
pub const MAX_LINE_BYTES: usize = 256;

/// Most libraries and called programs one request may carry.
pub const MAX_FILES: usize = 256;

/// What the editor sends: the program, the other sources it names, its points.
#[derive(Debug, Clone, Default, Deserialize)]
pub struct CompileRequest {
    /// The program's name (1-32 letters, digits, `_` or `-`): its stored name, which names
    /// its points file and makes a `CALL PROGRAM` of itself a loop.
    pub name: String,
    /// The program's text.
    pub source: String,
    /// Libraries (`INCLUDE "name"`) and called programs (`CALL PROGRAM "name"`) by name;
    /// a name not here is read from the program folder.
    #[serde(default)]
    pub files: BTreeMap<String, String>,
    /// The program's points file (TOML, `[points]`); empty or absent: the folder's
    /// `<name>.points.toml`.
    #[serde(default)]
    pub points: Option<String>,
}

/// A request the compiler cannot take (HTTP 400).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RequestError {
    /// Not JSON, or not the fields the compiler takes.
    #[error("the request is not the JSON the compiler takes: {0}; send {{\"name\": \"demo\", \"source\": \"…\", \"files\": {{\"lib\": \"…\"}}, \"points\": \"…\"}}")]
    Json(String),
    /// A program or library name that cannot name a stored program.
    #[error("{0:?} cannot name a program: a name is 1-32 letters, digits, _ or -")]
    BadName(String),
    /// More files than one compilation reads.
    #[error("the request carries {0} files; a compilation reads at most {MAX_FILES}")]
    TooManyFiles(usize),
}

/// One diagnostic, as the editor shows it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct DiagnosticReply {
    /// `null` for the program compiled, else the library or called program it is in.
    pub file: Option<String>,
    /// Line [1-based].
    pub line: u32,
    /// Column [1-based, characters].
    pub col: u32,
    /// Length of the marked span [characters, at least 1].
    pub len: u32,
    /// `error` or `warning`.
    pub severity: &'static str,
    /// What is wrong and, where it helps, what to do.
    pub message: String,
}

/// The answer to a compile request.
#[derive(Debug, Clone, Serialize)]
pub struct CompileReply {
    /// No errors: the controller would store and run it.
    pub ok: bool,
    /// Errors and warnings, by file, line and column.
    pub diagnostics: Vec<DiagnosticReply>,
    /// The names the program and its libraries define (variables, arrays, points, SUBs,
    /// FUNCTIONs, parameters, locals), each with the index of its file in `files`.
    pub symbols: Vec<wrc_lang::Symbol>,
    /// The source files read: the program (0), then its libraries and called programs.
    pub files: Vec<String>,
    /// Bytecode instructions (0 when it does not compile).
    pub instructions: usize,
}

/// The built-ins, statements and keywords, for the editor's completion.
#[derive(Debug, Serialize)]
struct Language {
    functions: Vec<wrc_lang::BuiltinInfo>,
    statements: Vec<wrc_lang::StatementInfo>,
    keywords: Vec<&'static str>,
}

/// `GET /api/language`'s body (made once).
pub fn language_json() -> &'static str {
    static JSON: OnceLock<String> = OnceLock::new();
    JSON.get_or_init(|| {
        let mut keywords: Vec<&'static str> = wrc_lang::keywords().collect();
        keywords.sort_unstable();
        keywords.dedup();
        let language = Language {
            functions: wrc_lang::builtin_functions().collect(),
            statements: wrc_lang::statements().collect(),
            keywords,
        };
        serde_json::to_string(&language).unwrap_or_else(|_| "{}".into())
    })
}

/// A program's or library's name: 1-32 letters, digits, `_` or `-` (as the controller's).
pub fn name_ok(name: &str) -> bool {
    (1..=32).contains(&name.len())
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
}

/// Read a request body.
pub fn parse_request(body: &[u8]) -> Result<CompileRequest, RequestError> {
    let request: CompileRequest =
        serde_json::from_slice(body).map_err(|e| RequestError::Json(e.to_string()))?;
    if !name_ok(&request.name) {
        return Err(RequestError::BadName(request.name));
    }
    if request.files.len() > MAX_FILES {
        return Err(RequestError::TooManyFiles(request.files.len()));
    }
    if let Some(bad) = request.files.keys().find(|n| !name_ok(n)) {
        return Err(RequestError::BadName(bad.clone()));
    }
    Ok(request)
}

/// Where a compilation finds the other sources: the request's, then the program folder.
struct RequestSources<'a> {
    request: &'a CompileRequest,
    folder: Option<DirSources>,
}

impl Sources for RequestSources<'_> {
    fn program(&self, name: &str) -> Result<String, String> {
        if let Some(text) = self.request.files.get(name) {
            return Ok(text.clone());
        }
        match &self.folder {
            Some(folder) => folder.program(name),
            None => Err(format!(
                "the editor did not send it and wrc ui has no program folder to read {name}.wrl from (wrc ui --programs DIR)"
            )),
        }
    }

    fn points(&self, name: &str) -> Result<Option<String>, String> {
        if name == self.request.name {
            if let Some(text) = self.request.points.as_deref() {
                if !text.trim().is_empty() {
                    return Ok(Some(text.to_string()));
                }
            }
        }
        match &self.folder {
            Some(folder) => folder.points(name),
            None => Ok(None),
        }
    }
}

/// Compile `request` for `robot`, reading what it does not carry from `programs`.
pub fn compile(request: &CompileRequest, robot: &Robot, programs: Option<&Path>) -> CompileReply {
    let sources = RequestSources {
        request,
        folder: programs.map(|dir| DirSources {
            dir: dir.to_path_buf(),
        }),
    };
    let file = format!("{}.wrl", request.name);
    let compiled = wrc_lang::compile_with(
        &request.source,
        &file,
        robot,
        &CompileOptions {
            name: &request.name,
            sources: Some(&sources),
        },
    );
    let mut diagnostics: Vec<DiagnosticReply> = compiled
        .diagnostics
        .iter()
        .map(|d| DiagnosticReply {
            file: d.file.clone(),
            line: d.line,
            col: d.col,
            len: d.len,
            severity: d.severity.as_str(),
            message: d.message.clone(),
        })
        .collect();
    let too_big = upload_limits(&request.source);
    let ok = compiled.program.is_some() && compiled.errors() == 0 && too_big.is_empty();
    diagnostics.extend(too_big);
    diagnostics.sort_by(|a, b| {
        (a.file.is_some(), &a.file, a.line, a.col).cmp(&(b.file.is_some(), &b.file, b.line, b.col))
    });
    CompileReply {
        ok,
        diagnostics,
        symbols: compiled.symbols,
        files: compiled
            .sources
            .iter()
            .enumerate()
            .map(|(i, f)| {
                if i == 0 {
                    request.name.clone()
                } else {
                    f.name.clone()
                }
            })
            .collect(),
        instructions: compiled.program.as_ref().map_or(0, |p| p.len()),
    }
}

/// What keeps the program from being uploaded though it compiles: too many lines, or lines
/// too long for the line protocol (the first few of them).
fn upload_limits(source: &str) -> Vec<DiagnosticReply> {
    let mut out = Vec::new();
    let error = |line: usize, message: String| DiagnosticReply {
        file: None,
        line: u32::try_from(line).unwrap_or(u32::MAX),
        col: 1,
        len: 1,
        severity: Severity::Error.as_str(),
        message,
    };
    let mut lines = 0;
    for (i, text) in source.lines().enumerate() {
        lines = i + 1;
        let bytes = text.len();
        if bytes > MAX_LINE_BYTES && out.len() < 5 {
            out.push(error(
                i + 1,
                format!("this line is {bytes} bytes; the controller takes lines of at most {MAX_LINE_BYTES} bytes: split it"),
            ));
        }
    }
    if lines > MAX_PROGRAM_LINES {
        out.push(error(
            MAX_PROGRAM_LINES + 1,
            format!("the program has {lines} lines; the controller stores at most {MAX_PROGRAM_LINES}: move SUBs into a library (INCLUDE)"),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(source: &str) -> CompileRequest {
        CompileRequest {
            name: "demo".into(),
            source: source.into(),
            ..CompileRequest::default()
        }
    }

    #[test]
    fn names_are_those_of_stored_programs() {
        assert!(name_ok("cell_lib-2"));
        for bad in ["", "a/b", "..", "a b", &"x".repeat(33)] {
            assert!(!name_ok(bad), "{bad:?}");
        }
        let e = parse_request(br#"{"name": "../etc", "source": ""}"#).unwrap_err();
        assert_eq!(e, RequestError::BadName("../etc".into()));
        let e = parse_request(br#"{"name": "p", "source": "", "files": {"a b": ""}}"#);
        assert_eq!(e.unwrap_err(), RequestError::BadName("a b".into()));
        let e = parse_request(br#"{"name": "p"}"#).unwrap_err().to_string();
        assert!(e.contains("missing field `source`"), "{e}");
    }

    #[test]
    fn lines_the_controller_would_refuse_are_errors() {
        let robot = Robot::paper_default();
        let long = format!("PRINT \"{}\"\n", "x".repeat(300));
        let reply = compile(&request(&format!("PRINT 1\n{long}")), &robot, None);
        assert!(!reply.ok);
        assert_eq!(reply.diagnostics.len(), 1, "{:?}", reply.diagnostics);
        assert_eq!(reply.diagnostics[0].line, 2);
        assert!(reply.diagnostics[0].message.contains("at most 256 bytes"));
        let many = "PRINT 1\n".repeat(MAX_PROGRAM_LINES + 1);
        let reply = compile(&request(&many), &robot, None);
        assert!(!reply.ok);
        assert_eq!(
            reply.diagnostics.last().map(|d| d.line),
            Some(MAX_PROGRAM_LINES as u32 + 1)
        );
    }

    #[test]
    fn the_language_lists_built_ins_statements_and_keywords() {
        let v: serde_json::Value = serde_json::from_str(language_json()).unwrap();
        let slot = v["functions"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["name"] == "SLOT")
            .expect("SLOT");
        assert!(slot["syntax"].as_str().unwrap().starts_with("SLOT("));
        let statements = v["statements"].as_array().unwrap();
        assert!(statements
            .iter()
            .any(|s| s["syntax"].as_str().unwrap().starts_with("WAIT OPERATOR")));
        let keywords: Vec<&str> = v["keywords"]
            .as_array()
            .unwrap()
            .iter()
            .map(|k| k.as_str().unwrap())
            .collect();
        assert!(keywords.contains(&"TRY") && keywords.contains(&"ENDSELECT"));
        assert_eq!(
            keywords.iter().filter(|k| **k == "WAIT").count(),
            1,
            "no keyword twice"
        );
    }
}
