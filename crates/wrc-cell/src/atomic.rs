//! Crash-safe file replacement: write `FILE.tmp` in the same directory, fsync it, rename it
//! over `FILE`, fsync the directory. A reader (or a restart after `kill -9` or a power cut)
//! sees either the old file or the new one, never a mix or a truncated file.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// The temporary file written next to `path`: its file name with `.tmp` appended.
pub(crate) fn temp_path(path: &Path) -> io::Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            "the path names a directory, not a file",
        )
    })?;
    let mut tmp = name.to_os_string();
    tmp.push(".tmp");
    Ok(path.with_file_name(tmp))
}

/// Replace `path` with `bytes` atomically: write `FILE.tmp` in the same directory, fsync it,
/// rename it over `FILE`, fsync the directory. A reader, or a restart after `kill -9` or a
/// power cut, sees the old file or the new one, never a mix. A leftover `FILE.tmp` from an
/// earlier crash is simply overwritten. One writer per file: two processes saving the
/// same file at once would share the temporary name.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = temp_path(path)?;
    let result = (|| {
        let mut file = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, path)?;
        sync_dir(path.parent())
    })();
    if result.is_err() {
        // Best effort: the temporary file is never read, so a failure to remove it is harmless.
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Make the rename durable: fsync the directory holding the file.
fn sync_dir(dir: Option<&Path>) -> io::Result<()> {
    if !cfg!(unix) {
        return Ok(());
    }
    let dir = match dir {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match File::open(dir).and_then(|d| d.sync_all()) {
        // Some file systems cannot fsync a directory (EINVAL); the rename is then as durable as
        // that file system makes it.
        Err(e) if e.kind() == io::ErrorKind::InvalidInput => Ok(()),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_the_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("map.toml");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"two");
        assert!(!temp_path(&path).unwrap().exists());
    }

    #[test]
    fn a_stale_temporary_is_overwritten() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("map.toml");
        fs::write(temp_path(&path).unwrap(), b"half writ").unwrap();
        write_atomic(&path, b"whole").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"whole");
    }

    #[test]
    fn a_missing_directory_is_an_error_not_a_panic() {
        let err = write_atomic(Path::new("/nonexistent-wrc-dir/map.toml"), b"x").unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::NotFound);
        assert!(temp_path(Path::new("/")).is_err());
    }
}
