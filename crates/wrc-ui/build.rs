//! Embeds the built web app (`web/dist`, made by `npm run build`) into the binary when it
//! exists at compile time. When it does not, nothing is embedded and `wrc ui` serves the
//! folder from the source tree at run time (or says how to build it).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn files(dir: &Path, root: &Path, out: &mut Vec<(String, PathBuf)>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            files(&path, root, out);
        } else if let Ok(rel) = path.strip_prefix(root) {
            let rel = rel.to_string_lossy().replace('\\', "/");
            out.push((rel, path));
        }
    }
}

fn main() {
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let dist = manifest.join("../../web/dist");
    let index = dist.join("index.html");
    // Vite rewrites index.html on every build (it names the hashed assets), so watching it
    // catches every rebuild. While it is missing cargo reruns this script on every build, so
    // a build that appears later (or reappears after Vite emptied the folder) is embedded.
    println!("cargo:rerun-if-changed={}", index.display());
    println!("cargo:rerun-if-changed=build.rs");
    let mut list = Vec::new();
    if index.exists() {
        files(&dist, &dist, &mut list);
    }
    list.sort();
    let mut code = String::from("/// The built web app: (path below `web/dist`, contents).\npub static EMBEDDED: &[(&str, &[u8])] = &[\n");
    for (rel, path) in &list {
        let _ = writeln!(
            code,
            "    ({rel:?}, include_bytes!({:?})),",
            path.canonicalize().unwrap_or(path.clone())
        );
    }
    code.push_str("];\n");
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets it"));
    std::fs::write(out.join("embedded.rs"), code).expect("write embedded.rs");
}
