//! docs/architecture.md draws the crates in layers and lists each one's dependencies on the
//! others; this keeps the list true: it must be the graph `cargo metadata` reports.

use std::collections::BTreeMap;
use std::process::Command;

/// The workspace crates each workspace crate depends on (normal dependencies, optional ones
/// included), from `cargo metadata`.
fn actual() -> BTreeMap<String, Vec<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut graph = BTreeMap::new();
    for p in meta["packages"].as_array().unwrap() {
        let mut deps: Vec<String> = p["dependencies"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|d| d["kind"].is_null())
            .map(|d| d["name"].as_str().unwrap().to_string())
            .filter(|n| n.starts_with("wrc"))
            .collect();
        deps.sort();
        graph.insert(p["name"].as_str().unwrap().to_string(), deps);
    }
    graph
}

/// The table between the `crate graph` markers of docs/architecture.md.
fn documented() -> BTreeMap<String, Vec<String>> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/architecture.md");
    let doc = std::fs::read_to_string(path).unwrap();
    let start = doc
        .find("<!-- crate graph: begin -->")
        .expect("the begin marker");
    let end = doc
        .find("<!-- crate graph: end -->")
        .expect("the end marker");
    let mut graph = BTreeMap::new();
    for line in doc[start..end].lines().skip(3) {
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        let [name, deps] = cells[..] else {
            continue;
        };
        let mut deps: Vec<String> = deps
            .split(',')
            .map(|d| d.split('(').next().unwrap().trim().to_string())
            .filter(|d| d.starts_with("wrc"))
            .collect();
        deps.sort();
        graph.insert(name.to_string(), deps);
    }
    graph
}

#[test]
fn the_crate_graph_is_the_documented_one() {
    let (actual, documented) = (actual(), documented());
    assert!(actual.len() >= 10, "{actual:?}");
    assert_eq!(
        documented, actual,
        "docs/architecture.md's crate table differs from cargo metadata"
    );
}
