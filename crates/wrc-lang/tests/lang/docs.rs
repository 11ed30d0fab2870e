//! Every ```wrl block of docs/language.md compiles for its robot without errors or
//! warnings, so the reference's examples stay runnable (the controller's test
//! `language_docs` runs them). A block marked `file=NAME.wrl` is a stored program or library
//! that later blocks INCLUDE or CALL PROGRAM, and a ```toml block marked
//! `file=NAME.points.toml` is program NAME's points file: both reach the later blocks
//! through `wrc_lang::Sources`. `name=NAME` names the program (default `example`), and
//! `config=dual-blade` compiles it for the dual-blade robot.

use std::path::PathBuf;

use wrc_lang::{compile_with, CompileOptions};
use wrc_robot::Robot;

use crate::common::{robot, Store};

/// A fenced block: the line of its first text line, its info string's words and its text.
struct Fence {
    line: usize,
    info: Vec<String>,
    text: String,
}

impl Fence {
    fn attr(&self, key: &str) -> Option<&str> {
        self.info
            .iter()
            .find_map(|w| w.strip_prefix(key)?.strip_prefix('='))
    }
}

fn fences(text: &str) -> Vec<Fence> {
    let mut out = Vec::new();
    let mut open: Option<Fence> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if open.is_some() && trimmed == "```" {
            out.extend(open.take());
            continue;
        }
        match open.as_mut() {
            None => {
                if let Some(info) = trimmed.strip_prefix("```") {
                    open = Some(Fence {
                        line: i + 2,
                        info: info.split_whitespace().map(str::to_string).collect(),
                        text: String::new(),
                    });
                }
            }
            Some(fence) => {
                fence.text.push_str(line);
                fence.text.push('\n');
            }
        }
    }
    out
}

fn dual_blade() -> Robot {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/dual-blade.toml");
    wrc_config::Config::load(Some(&path)).unwrap().robot
}

#[test]
fn every_wrl_block_in_the_language_reference_compiles_cleanly() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/language.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut store = Store::default();
    let mut programs = 0;
    let mut stored = 0;
    let mut failures = Vec::new();
    for fence in fences(&text) {
        let lang = fence.info.first().map_or("", String::as_str);
        let file = fence.attr("file");
        match (lang, file) {
            ("toml", Some(f)) => {
                if let Some(program) = f.strip_suffix(".points.toml") {
                    store.points.insert(program.to_string(), fence.text.clone());
                }
                continue;
            }
            ("wrl", _) => {}
            _ => continue,
        }
        let robot = match fence.attr("config") {
            None => robot(),
            Some("dual-blade") => dual_blade(),
            Some(other) => panic!("docs/language.md:{}: unknown config={other}", fence.line),
        };
        let name = match file {
            Some(f) => f
                .strip_suffix(".wrl")
                .unwrap_or_else(|| panic!("docs/language.md:{}: file= ends in .wrl", fence.line)),
            None => fence.attr("name").unwrap_or("example"),
        };
        let compiled = compile_with(
            &fence.text,
            &format!("{name}.wrl"),
            &robot,
            &CompileOptions {
                name,
                sources: Some(&store),
            },
        );
        let rendered = compiled.render(&format!("{name}.wrl"), &fence.text);
        // A library compiled on its own has SUBs nobody calls: only its errors count; its
        // warnings show in the programs that include it.
        let clean = if file.is_some() {
            store.programs.insert(name.to_string(), fence.text.clone());
            stored += 1;
            compiled.errors() == 0
        } else {
            programs += 1;
            compiled.diagnostics.is_empty()
        };
        if !clean {
            failures.push(format!(
                "the block at docs/language.md:{}:\n{rendered}",
                fence.line
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(programs >= 66, "{programs} program blocks");
    assert!(stored >= 3, "{stored} file= blocks");
}
