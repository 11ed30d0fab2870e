//! Every example of the language reference (docs/language.md) runs on the whole controller
//! under virtual time, as its note at the top of the file says: a ` ```wrl ` block is
//! uploaded and run after `CONTROL` and `HOME` on a fresh controller with the demo cell,
//! and must end with `INF`; a ` ```output ` block right after it gives the `EVT PRINT`
//! texts it must print, in order, and may end in `ABS <code>` (the program must end with
//! that code instead). ` ```wrl file=NAME.wrl ` blocks are uploaded as program NAME before
//! every later block (libraries and called programs), ` ```toml file=NAME.points.toml `
//! blocks become program NAME's named points (`POINT`); `name=` names the program run
//! (default `example`), `operator=A,B` gives the answers to its WAIT OPERATORs
//! (`CONTINUE A`, then `CONTINUE B`, then plain `CONTINUE`), and `config=dual-blade` runs
//! it on the dual-blade robot (config/dual-blade.toml).
//!
//! The test also checks that the blocks it runs use every statement and built-in of the
//! language, so a new one cannot be added without an example that runs.

use std::panic::{catch_unwind, AssertUnwindSafe};

use wrc_controller::simulation::SimCellFrom;
use wrc_lang::{PointValue, Points};

use crate::vhost::{dual_blade, repo, VHost};

/// Where the reference is, as failure messages name it.
const DOC: &str = "docs/language.md";

/// The axis count of both configurations the examples run on.
const AXES: usize = 4;

/// A fenced block of the reference.
#[derive(Debug, Clone)]
struct Fence {
    /// Line of its first text line [1-based].
    line: usize,
    /// Its language (`wrl`, `output`, `toml`, …).
    lang: String,
    /// Its `key=value` words after the language.
    attrs: Vec<(String, String)>,
    /// Its text, one `\n` after each line.
    text: String,
    /// Line of its closing fence [1-based].
    end: usize,
}

impl Fence {
    fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// Every fenced block of `text`.
fn fences(text: &str) -> Vec<Fence> {
    let mut out = Vec::new();
    let mut open: Option<Fence> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        match open.as_mut() {
            None => {
                if let Some(info) = trimmed.strip_prefix("```") {
                    let mut words = info.split_whitespace();
                    let lang = words.next().unwrap_or("").to_string();
                    let attrs = words
                        .map(|w| match w.split_once('=') {
                            Some((k, v)) => (k.to_string(), v.to_string()),
                            None => (w.to_string(), String::new()),
                        })
                        .collect();
                    open = Some(Fence {
                        line: i + 2,
                        lang,
                        attrs,
                        text: String::new(),
                        end: 0,
                    });
                }
            }
            Some(fence) => {
                if trimmed == "```" {
                    fence.end = i + 1;
                    out.extend(open.take());
                } else {
                    fence.text.push_str(line);
                    fence.text.push('\n');
                }
            }
        }
    }
    assert!(open.is_none(), "{DOC} ends inside a fenced block");
    out
}

/// What a program block must do.
#[derive(Debug, Default)]
struct Expected {
    /// The `EVT PRINT` texts, in order (`None`: not checked).
    printed: Option<Vec<String>>,
    /// The code it ends with (`None`: it ends normally, `INF`).
    abs: Option<u16>,
}

/// A block the test uses.
#[derive(Debug)]
enum Block {
    /// A program to run.
    Program { fence: Fence, expected: Expected },
    /// A stored program or library, uploaded for the later blocks.
    Stored { fence: Fence, name: String },
    /// A program's named points.
    Points { fence: Fence, program: String },
}

/// The blocks of the reference, in order.
fn blocks(text: &str) -> Vec<Block> {
    let all = fences(text);
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, fence) in all.iter().enumerate() {
        match fence.lang.as_str() {
            "wrl" => {
                if let Some(file) = fence.attr("file") {
                    let name = file.strip_suffix(".wrl").unwrap_or_else(|| {
                        panic!("{DOC}:{}: file={file} must end in .wrl", fence.line)
                    });
                    out.push(Block::Stored {
                        fence: fence.clone(),
                        name: name.to_string(),
                    });
                    continue;
                }
                let mut expected = Expected::default();
                if let Some(next) = all.get(i + 1) {
                    // An output block directly after it: nothing but blank lines between.
                    let between = &lines[fence.end..next.line.saturating_sub(2)];
                    if next.lang == "output" && between.iter().all(|l| l.trim().is_empty()) {
                        let mut printed: Vec<String> =
                            next.text.lines().map(str::to_string).collect();
                        if let Some(code) = printed.last().and_then(|l| l.strip_prefix("ABS ")) {
                            expected.abs = Some(code.trim().parse().unwrap_or_else(|_| {
                                panic!("{DOC}:{}: ABS takes a code: {code:?}", next.line)
                            }));
                            printed.pop();
                        }
                        expected.printed = Some(printed);
                    }
                }
                out.push(Block::Program {
                    fence: fence.clone(),
                    expected,
                });
            }
            "toml" => {
                if let Some(program) = fence
                    .attr("file")
                    .and_then(|f| f.strip_suffix(".points.toml"))
                {
                    out.push(Block::Points {
                        fence: fence.clone(),
                        program: program.to_string(),
                    });
                }
            }
            _ => {}
        }
    }
    out
}

/// The `POINT` request that stores `value` as point `name` of `program`.
fn point_request(id: u32, program: &str, name: &str, value: &PointValue) -> String {
    match value {
        PointValue::Pose(p) => format!(
            "{id} POINT {program} {name} {} {} {} {}",
            p.x, p.y, p.z, p.yaw
        ),
        PointValue::Joints(j) => {
            let values: Vec<String> = j[..AXES].iter().map(|v| v.to_string()).collect();
            format!("{id} POINT {program} {name} JOINTS {}", values.join(" "))
        }
    }
}

/// What a program block did when it ran.
struct Run {
    /// The texts of its `EVT PRINT` lines, in order.
    printed: Vec<String>,
    /// The final reply to `RUN`: `INF 9` or `ABS 9 …`.
    end: String,
    /// Every line heard from `RUN` on.
    heard: Vec<String>,
}

/// Run program block `fence` after the blocks `earlier`, or say why it could not be run.
/// Panics (a line that never comes) are the caller's to catch.
fn run_block(fence: &Fence, earlier: &[&Block]) -> Result<Run, String> {
    let mut host = match fence.attr("config") {
        None => VHost::start(),
        Some("dual-blade") => VHost::start_config(&dual_blade(), SimCellFrom::default()),
        Some(other) => return Err(format!("unknown config={other}")),
    };
    let r = host.ask("1 CONTROL");
    if !r.starts_with("ACK 1") {
        return Err(format!("CONTROL: {r}"));
    }
    let r = host.motion(2, "HOME");
    if r != "INF 2" {
        return Err(format!("HOME: {r}"));
    }
    let mut id = 10;
    for block in earlier {
        id += 1;
        match block {
            Block::Points { fence: f, program } => {
                let points = Points::parse(&f.text, AXES)
                    .map_err(|e| format!("the points file at {DOC}:{}: {e}", f.line))?;
                for (name, value) in points.iter() {
                    id += 1;
                    let r = host.ask(&point_request(id, program, name, value));
                    if !r.starts_with(&format!("ACK {id}")) {
                        return Err(format!("point {name} of {DOC}:{}: {r}", f.line));
                    }
                }
            }
            Block::Stored { fence: f, name } => {
                let r = host.upload(id, name, &f.text);
                if !r.starts_with(&format!("ACK {id} name={name} ")) {
                    return Err(format!(
                        "the upload of {name} ({DOC}:{}): {r}; heard {:#?}",
                        f.line, host.seen
                    ));
                }
            }
            Block::Program { .. } => {}
        }
    }
    let name = fence.attr("name").unwrap_or("example");
    let r = host.upload(3, name, &fence.text);
    if !r.starts_with(&format!("ACK 3 name={name} ")) {
        return Err(format!("the upload: {r}; heard {:#?}", host.seen));
    }
    let mut answers = fence
        .attr("operator")
        .map(|a| a.split(',').map(str::to_string).collect::<Vec<_>>())
        .unwrap_or_default()
        .into_iter();
    host.seen.clear();
    let r = host.ask(&format!("9 RUN {name}"));
    if r != "ACK 9" {
        return Err(format!("RUN: {r}; heard {:#?}", host.seen));
    }
    let waiting = format!("EVT PROGRAM {name} WAITING");
    let mut printed = Vec::new();
    loop {
        let l = host.line();
        if let Some(text) = l.strip_prefix("EVT PRINT") {
            printed.push(text.strip_prefix(' ').unwrap_or(text).to_string());
        } else if l.starts_with(&waiting) {
            id += 1;
            let request = match answers.next() {
                Some(a) if !a.is_empty() => format!("{id} CONTINUE {a}"),
                _ => format!("{id} CONTINUE"),
            };
            host.send_raw(&format!("{request}\n"));
        } else if l.starts_with("INF 9") || l.starts_with("ABS 9") || l.starts_with("NAK 9") {
            return Ok(Run {
                printed,
                end: l,
                heard: std::mem::take(&mut host.seen),
            });
        } else if l.starts_with("NAK") {
            return Err(format!("{l}; heard {:#?}", host.seen));
        }
    }
}

/// Check one program block: `Err` with what is wrong and what was heard.
fn check_block(fence: &Fence, expected: &Expected, earlier: &[&Block]) -> Result<(), String> {
    let Run {
        printed,
        end,
        heard,
    } = run_block(fence, earlier)?;
    let ended_right = match expected.abs {
        None => end == "INF 9",
        Some(code) => end.starts_with(&format!("ABS 9 {code} ")),
    };
    let want_end = match expected.abs {
        None => "INF".to_string(),
        Some(code) => format!("ABS {code}"),
    };
    let printed_right = expected
        .printed
        .as_ref()
        .is_none_or(|want| *want == printed);
    if ended_right && printed_right {
        return Ok(());
    }
    let mut why = String::new();
    if !ended_right {
        why.push_str(&format!("it ended with {end:?}, not {want_end}; "));
    }
    if let Some(want) = expected.printed.as_ref().filter(|_| !printed_right) {
        why.push_str(&format!(
            "it printed\n{}\ninstead of\n{}\n",
            printed.join("\n"),
            want.join("\n")
        ));
    }
    why.push_str(&format!("heard:\n  {}", heard.join("\n  ")));
    Err(why)
}

/// Run the program blocks of `blocks` on `threads` threads: the failures, each naming its
/// block's line.
fn run_all(blocks: &[Block], threads: usize) -> Vec<String> {
    let programs: Vec<usize> = blocks
        .iter()
        .enumerate()
        .filter(|(_, b)| matches!(b, Block::Program { .. }))
        .map(|(i, _)| i)
        .collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(&i) = programs.get(k) else {
                    return;
                };
                let Block::Program { fence, expected } = &blocks[i] else {
                    continue;
                };
                let earlier: Vec<&Block> = blocks[..i].iter().collect();
                let result =
                    catch_unwind(AssertUnwindSafe(|| check_block(fence, expected, &earlier)))
                        .unwrap_or_else(|panic| {
                            let text = panic
                                .downcast_ref::<String>()
                                .cloned()
                                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                                .unwrap_or_default();
                            Err(format!("the run panicked: {text}"))
                        });
                if let Err(why) = result {
                    failures
                        .lock()
                        .unwrap()
                        .push((fence.line, format!("{DOC}:{}: {why}", fence.line)));
                }
            });
        }
    });
    let mut failures = failures.into_inner().unwrap();
    failures.sort();
    failures.into_iter().map(|(_, f)| f).collect()
}

/// The words of a program's code, upper case, its comments and strings left out.
fn code_words(text: &str) -> Vec<String> {
    let mut words = Vec::new();
    for line in text.lines() {
        let mut code = String::new();
        let mut in_string = false;
        for c in line.chars() {
            match c {
                '"' => in_string = !in_string,
                '\'' if !in_string => break,
                _ if in_string => {}
                c => code.push(c),
            }
        }
        words.extend(
            code.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '$'))
                .filter(|w| !w.is_empty())
                .map(str::to_ascii_uppercase),
        );
        words.push("\n".to_string());
    }
    words
}

/// The statements, block words and built-ins that no block the test runs uses.
fn unused_words(blocks: &[Block]) -> Vec<String> {
    let mut words = Vec::new();
    for b in blocks {
        match b {
            Block::Program { fence, .. } | Block::Stored { fence, .. } => {
                words.extend(code_words(&fence.text));
            }
            Block::Points { .. } => {}
        }
    }
    let uses = |phrase: &str| {
        let parts: Vec<&str> = phrase.split(' ').collect();
        words
            .windows(parts.len())
            .any(|w| w.iter().zip(&parts).all(|(a, b)| a == b))
    };
    let mut wanted: Vec<String> = wrc_lang::statements()
        .map(|s| s.keyword.to_string())
        .chain(wrc_lang::builtin_functions().map(|b| b.name.to_string()))
        .collect();
    wanted.extend(
        [
            "WAIT OPERATOR",
            "IF",
            "ELSEIF",
            "ELSE",
            "ENDIF",
            "WHILE",
            "ENDWHILE",
            "FOR",
            "STEP",
            "NEXT",
            "DO",
            "LOOP UNTIL",
            "LOOP WHILE",
            "DO WHILE",
            "DO UNTIL",
            "SELECT CASE",
            "CASE IS",
            "CASE ELSE",
            "ENDSELECT",
            "TRY",
            "CATCH",
            "ENDTRY",
            "RETRY",
            "SUB",
            "ENDSUB",
            "FUNCTION",
            "ENDFUNCTION",
            "RETURN",
            "CALL",
            "CALL PROGRAM",
            "DIM",
            "LOCAL",
            "AS",
            "EXIT FOR",
            "EXIT WHILE",
            "EXIT DO",
            "EXIT SUB",
            "INCLUDE",
            "MOD",
            "AND",
            "OR",
            "NOT",
            "TRUE",
            "FALSE",
            "POSE",
            "JOINTS",
            "TIMEOUT",
            "BLEND",
        ]
        .map(str::to_string),
    );
    wanted.sort();
    wanted.dedup();
    wanted.into_iter().filter(|w| !uses(w)).collect()
}

#[test]
fn every_example_of_the_language_reference_runs_on_the_controller() {
    let text = std::fs::read_to_string(repo().join(DOC)).unwrap();
    let blocks = blocks(&text);
    let programs = blocks
        .iter()
        .filter(|b| matches!(b, Block::Program { .. }))
        .count();
    let checked = blocks
        .iter()
        .filter(|b| matches!(b, Block::Program { expected, .. } if expected.printed.is_some()))
        .count();
    // The reference's examples: a floor, so that a parsing mistake cannot make it pass.
    assert!(programs >= 66, "{programs} program blocks");
    assert!(checked >= 64, "{checked} blocks with their output");
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get().min(8));
    let failures = run_all(&blocks, threads);
    assert!(
        failures.is_empty(),
        "{} of {programs} examples failed:\n\n{}",
        failures.len(),
        failures.join("\n\n")
    );
    let unused = unused_words(&blocks);
    assert!(
        unused.is_empty(),
        "no example that runs uses {}",
        unused.join(", ")
    );
}

#[test]
fn the_block_reader_pairs_output_with_its_program_and_reads_the_markers() {
    let text = "\
intro
```wrl file=lib.wrl
SUB s
ENDSUB
```
```toml file=demo.points.toml
[points]
A = { x = 1, y = 2, z = 3, yaw = 4 }
```
```wrl name=demo operator=SKIP,RETRY
PRINT 1
```

```output
1
ABS 215
```
```wrl
PRINT 2
```
text between
```output
2
```
";
    let b = blocks(text);
    assert_eq!(b.len(), 4, "{b:#?}");
    assert!(matches!(&b[0], Block::Stored { name, .. } if name == "lib"));
    assert!(matches!(&b[1], Block::Points { program, .. } if program == "demo"));
    let Block::Program { fence, expected } = &b[2] else {
        panic!("{b:#?}")
    };
    assert_eq!(fence.line, 11);
    assert_eq!(fence.attr("name"), Some("demo"));
    assert_eq!(fence.attr("operator"), Some("SKIP,RETRY"));
    assert_eq!(expected.printed.as_deref(), Some(&["1".to_string()][..]));
    assert_eq!(expected.abs, Some(215));
    // An output block after prose belongs to no program.
    let Block::Program { expected, .. } = &b[3] else {
        panic!("{b:#?}")
    };
    assert!(expected.printed.is_none());
    assert_eq!(
        code_words("PRINT \"HOME\" ' MOVEJ\nX = 1")
            .into_iter()
            .filter(|w| w != "\n")
            .collect::<Vec<_>>(),
        ["PRINT", "X", "1"]
    );
}
