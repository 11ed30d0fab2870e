//! Golden diagnostics: every `tests/golden/*.wrl` compiles for the default robot to exactly
//! the rendered diagnostics in its `.expected` file. `UPDATE_GOLDEN=1 cargo test -p
//! wrc-lang` rewrites the expected files (review the diff before committing).

use std::path::PathBuf;

use wrc_lang::compile;

use crate::common::robot;

#[test]
fn diagnostics_match_the_golden_files() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden");
    let update = std::env::var_os("UPDATE_GOLDEN").is_some();
    let mut cases: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "wrl"))
        .collect();
    cases.sort();
    assert!(cases.len() >= 10, "{} golden cases", cases.len());
    let mut failures = Vec::new();
    for path in cases {
        let source = std::fs::read_to_string(&path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let compiled = compile(&source, &name, &robot());
        let mut actual = compiled.render(&name, &source);
        actual.push_str(&format!(
            "\n{name}: errors {}, warnings {}, {}\n",
            compiled.errors(),
            compiled.warnings(),
            if compiled.program.is_some() {
                "compiled"
            } else {
                "not compiled"
            }
        ));
        let expected_path = path.with_extension("expected");
        if update {
            std::fs::write(&expected_path, &actual).unwrap();
            continue;
        }
        let expected = std::fs::read_to_string(&expected_path).unwrap_or_default();
        if expected != actual {
            failures.push(format!(
                "{name}: the diagnostics differ from {} (UPDATE_GOLDEN=1 rewrites it)\n--- expected\n{expected}--- actual\n{actual}",
                expected_path.display()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
