//! The web app's files: embedded in the binary when `web/dist` existed at compile time,
//! otherwise read from a folder (the source tree's `web/dist`, or `--web-dir`).

use std::borrow::Cow;
use std::path::{Component, Path, PathBuf};

include!(concat!(env!("OUT_DIR"), "/embedded.rs"));

/// Where the app's files come from.
#[derive(Debug, Clone)]
pub enum Assets {
    /// Compiled into the binary.
    Embedded,
    /// A folder holding `index.html` and `assets/`.
    Folder(PathBuf),
    /// Nothing found: every page explains how to build the app.
    Missing,
}

/// The source tree's build folder, for a binary built without the app embedded.
pub fn source_tree_dist() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../web/dist")
}

impl Assets {
    /// `web_dir` when given; else the embedded app; else the source tree's `web/dist`.
    pub fn locate(web_dir: Option<&Path>) -> Assets {
        if let Some(dir) = web_dir {
            return Assets::Folder(dir.to_path_buf());
        }
        if !EMBEDDED.is_empty() {
            return Assets::Embedded;
        }
        let dist = source_tree_dist();
        if dist.join("index.html").is_file() {
            Assets::Folder(dist)
        } else {
            Assets::Missing
        }
    }

    /// Says where the files come from, for the start-up line.
    pub fn describe(&self) -> String {
        match self {
            Assets::Embedded => format!("embedded ({} files)", EMBEDDED.len()),
            Assets::Folder(dir) => format!("from {}", dir.display()),
            Assets::Missing => "missing: the web app is not built (make web)".to_string(),
        }
    }

    /// The file at URL path `path` (`/` is `index.html`), or `None`. Paths that climb out
    /// of the folder (`..`) are never served.
    pub fn get(&self, path: &str) -> Option<Cow<'static, [u8]>> {
        let rel = path.trim_start_matches('/');
        let rel = if rel.is_empty() { "index.html" } else { rel };
        match self {
            Assets::Embedded => EMBEDDED
                .iter()
                .find(|(name, _)| *name == rel)
                .map(|(_, bytes)| Cow::Borrowed(*bytes)),
            Assets::Folder(dir) => {
                let rel = Path::new(rel);
                if !rel.components().all(|c| matches!(c, Component::Normal(_))) {
                    return None;
                }
                std::fs::read(dir.join(rel)).ok().map(Cow::Owned)
            }
            Assets::Missing => None,
        }
    }
}

/// The Content-Type for a file name.
pub fn content_type(path: &str) -> &'static str {
    let ext = path.rsplit('.').next().unwrap_or("");
    match ext {
        "html" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" | "map" => "application/json",
        "svg" => "image/svg+xml",
        "png" => "image/png",
        "ico" => "image/x-icon",
        "woff2" => "font/woff2",
        "wasm" => "application/wasm",
        "txt" | "wrl" => "text/plain; charset=utf-8",
        _ => "application/octet-stream",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_never_serves_outside_itself() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("index.html"), "<p>hi</p>").unwrap();
        let assets = Assets::Folder(dir.path().to_path_buf());
        assert_eq!(assets.get("/").as_deref(), Some(&b"<p>hi</p>"[..]));
        assert!(assets.get("/../etc/passwd").is_none());
        assert!(assets.get("/assets/../../x").is_none());
        assert!(assets.get("/nope.js").is_none());
    }

    #[test]
    fn content_types() {
        assert_eq!(
            content_type("/assets/index-abc.js"),
            "text/javascript; charset=utf-8"
        );
        assert_eq!(content_type("index.html"), "text/html; charset=utf-8");
    }
}
