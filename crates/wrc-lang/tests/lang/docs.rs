//! Every ```wrl block of docs/language.md compiles for the default robot without errors or
//! warnings, so the reference's examples stay runnable.

use std::path::PathBuf;

use wrc_lang::compile;

use crate::common::robot;

#[test]
fn every_wrl_block_in_the_language_reference_compiles_cleanly() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/language.md");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut blocks = Vec::new();
    let mut current: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        match &mut current {
            None if line.trim() == "```wrl" => current = Some((i + 2, String::new())),
            Some((start, body)) if line.trim() == "```" => {
                blocks.push((*start, std::mem::take(body)));
                current = None;
            }
            Some((_, body)) => {
                body.push_str(line);
                body.push('\n');
            }
            None => {}
        }
    }
    assert!(blocks.len() >= 18, "{} blocks", blocks.len());
    for (line, source) in blocks {
        let compiled = compile(&source, "language.md", &robot());
        assert!(
            compiled.diagnostics.is_empty(),
            "the block at docs/language.md:{line}:\n{}",
            compiled.render("block", &source)
        );
    }
}
