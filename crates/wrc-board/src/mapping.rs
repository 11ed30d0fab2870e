//! The mapping of a DPRAM into the process: a shared-memory file, a PCI BAR resource file or
//! a UIO device, one code path (`mmap` with `MAP_SHARED`). All of the crate's `unsafe` is
//! here: the mapping hands out `&AtomicU32`/`&AtomicU64` views of its words, and every other
//! module reads and writes the DPRAM only through them.

use std::fs::{File, OpenOptions};
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, AtomicU64};
use std::sync::Arc;

use memmap2::{MmapOptions, MmapRaw};

use crate::layout::{self, LayoutError, LAYOUT_SIZE};

/// A DPRAM that cannot be used; every variant names the path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OpenError {
    /// The operating system refused (missing file, permissions, mmap).
    #[error("DPRAM {path}: {what}: {error}", path = path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// What was attempted.
        what: &'static str,
        /// Why it failed (in the message, so not also a `source`).
        error: std::io::Error,
    },
    /// Not a regular file, PCI resource file or UIO device.
    #[error("DPRAM {path}: cannot be mapped: expected a shared-memory file, a PCI resource file (/sys/bus/pci/devices/…/resourceN) or a UIO device (/dev/uioN)", path = path.display())]
    NotMappable {
        /// The path.
        path: PathBuf,
    },
    /// Shorter than the layout.
    #[error("DPRAM {path}: truncated: {len} bytes, the layout needs {need}", path = path.display(), need = layout::LAYOUT_SIZE)]
    Truncated {
        /// The path.
        path: PathBuf,
        /// Its length [byte].
        len: u64,
    },
    /// The header is wrong (foreign file, other version, bad field, not initialised yet).
    #[error("DPRAM {path}: {problem}", path = path.display())]
    Layout {
        /// The path.
        path: PathBuf,
        /// What is wrong.
        problem: LayoutError,
    },
    /// A valid board, but not the one the configuration describes.
    #[error("DPRAM {path}: the board reports {field} = {found}, the configuration expects {expected}", path = path.display())]
    Mismatch {
        /// The path.
        path: PathBuf,
        /// The header field.
        field: &'static str,
        /// What the board reports.
        found: u32,
        /// What was expected.
        expected: u32,
    },
}

impl OpenError {
    /// True when waiting may help: the file does not exist yet or the board is still
    /// initialising it.
    pub fn is_not_ready(&self) -> bool {
        match self {
            OpenError::Io { error, .. } => error.kind() == std::io::ErrorKind::NotFound,
            OpenError::Layout { problem, .. } => matches!(problem, LayoutError::NotReady),
            OpenError::Truncated { len: 0, .. } => true,
            _ => false,
        }
    }
}

/// A mapped DPRAM window of at least [`LAYOUT_SIZE`] bytes.
#[derive(Debug)]
pub struct Mapping {
    map: Arc<MmapRaw>,
    path: PathBuf,
}

impl Mapping {
    /// Map an existing DPRAM at `path` read-write: a regular (shared-memory) file, a PCI
    /// resource file (`/sys/bus/pci/devices/…/resourceN`) or a UIO device (`/dev/uioN`,
    /// map 0, its size read from `/sys/class/uio/uioN/maps/map0/size`).
    pub fn open(path: &Path) -> Result<Mapping, OpenError> {
        let io = |what: &'static str| {
            let path = path.to_path_buf();
            move |error| OpenError::Io { path, what, error }
        };
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .map_err(io("cannot open"))?;
        let meta = file.metadata().map_err(io("cannot stat"))?;
        let len = if meta.file_type().is_char_device() {
            uio_map_size(path)?
        } else if meta.is_file() {
            meta.len()
        } else {
            return Err(OpenError::NotMappable {
                path: path.to_path_buf(),
            });
        };
        if len < LAYOUT_SIZE as u64 {
            return Err(OpenError::Truncated {
                path: path.to_path_buf(),
                len,
            });
        }
        Mapping::map(file, len as usize, path)
    }

    /// Create (or open) a regular file at `path` for a simulated board and map it; a file
    /// that is empty is sized to the layout (zeros); a shorter, non-empty one is refused. The caller checks what is in it.
    pub fn create(path: &Path) -> Result<Mapping, OpenError> {
        let io = |what: &'static str| {
            let path = path.to_path_buf();
            move |error| OpenError::Io { path, what, error }
        };
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(io("cannot create"))?;
        let meta = file.metadata().map_err(io("cannot stat"))?;
        if !meta.is_file() {
            return Err(OpenError::NotMappable {
                path: path.to_path_buf(),
            });
        }
        match meta.len() {
            0 => file
                .set_len(LAYOUT_SIZE as u64)
                .map_err(io("cannot size"))?,
            len if len < LAYOUT_SIZE as u64 => {
                return Err(OpenError::Truncated {
                    path: path.to_path_buf(),
                    len,
                })
            }
            _ => {}
        }
        Mapping::map(file, LAYOUT_SIZE, path)
    }

    /// An anonymous, zeroed mapping of [`LAYOUT_SIZE`] bytes: a DPRAM shared by threads of
    /// one process (tests, fuzzing), with the same access code as a file mapping.
    pub fn anonymous() -> Result<Mapping, OpenError> {
        let map = MmapOptions::new()
            .len(LAYOUT_SIZE)
            .map_anon()
            .map_err(|error| OpenError::Io {
                path: PathBuf::from("<anonymous>"),
                what: "cannot map",
                error,
            })?;
        Ok(Mapping {
            map: Arc::new(MmapRaw::from(map)),
            path: PathBuf::from("<anonymous>"),
        })
    }

    fn map(file: File, len: usize, path: &Path) -> Result<Mapping, OpenError> {
        let map = MmapOptions::new()
            .len(len)
            .map_raw(&file)
            .map_err(|error| OpenError::Io {
                path: path.to_path_buf(),
                what: "cannot mmap",
                error,
            })?;
        Ok(Mapping {
            map: Arc::new(map),
            path: path.to_path_buf(),
        })
    }

    /// A second handle on the same memory (in-process host and board, e.g. an anonymous
    /// mapping shared by a test's driver and simulated board).
    pub fn share(&self) -> Mapping {
        Mapping {
            map: Arc::clone(&self.map),
            path: self.path.clone(),
        }
    }

    /// The mapped path (or `<anonymous>`).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Length of the mapping [byte] (at least [`LAYOUT_SIZE`]).
    pub fn len(&self) -> usize {
        self.map.len()
    }

    /// Never true: a mapping holds at least the layout. (For clippy's `len` convention.)
    pub fn is_empty(&self) -> bool {
        self.map.len() == 0
    }

    /// The 32-bit word at byte `offset`.
    ///
    /// # Panics
    /// If `offset` is not 4-aligned or the word is outside the layout: offsets come from
    /// [`crate::layout`] constants, so this is a bug in this crate, never bad data.
    #[inline]
    pub fn u32(&self, offset: usize) -> &AtomicU32 {
        assert!(
            offset % 4 == 0 && offset + 4 <= LAYOUT_SIZE,
            "DPRAM offset {offset:#x}"
        );
        // SAFETY: the mapping is page-aligned and at least LAYOUT_SIZE long (checked when it
        // was made), and `offset` is 4-aligned and in range (asserted), so the pointer is
        // valid and aligned for an AtomicU32, which has the layout of a u32. The memory is
        // shared with another process or thread that also touches it only through atomic
        // accesses, which is what AtomicU32 permits. The reference borrows `self`, and the
        // mapping stays mapped until `self` is dropped.
        unsafe { &*(self.map.as_mut_ptr().add(offset) as *const AtomicU32) }
    }

    /// The 64-bit word at byte `offset`.
    ///
    /// # Panics
    /// As [`Mapping::u32`], with 8-byte alignment.
    #[inline]
    pub fn u64(&self, offset: usize) -> &AtomicU64 {
        assert!(
            offset % 8 == 0 && offset + 8 <= LAYOUT_SIZE,
            "DPRAM offset {offset:#x}"
        );
        // SAFETY: as in `u32`: in range, 8-aligned (the mapping base is page-aligned), only
        // accessed atomically by every party, borrowed no longer than the mapping lives.
        unsafe { &*(self.map.as_mut_ptr().add(offset) as *const AtomicU64) }
    }
}

/// Size of UIO map 0 of `/dev/uioN`, from sysfs.
fn uio_map_size(path: &Path) -> Result<u64, OpenError> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let sys = PathBuf::from(format!("/sys/class/uio/{name}/maps/map0/size"));
    let text = std::fs::read_to_string(&sys).map_err(|error| OpenError::Io {
        path: path.to_path_buf(),
        what: "is a character device but not a UIO device with a map 0 (cannot read its size from sysfs)",
        error,
    })?;
    let text = text.trim();
    let hex = text.strip_prefix("0x").unwrap_or(text);
    u64::from_str_radix(hex, 16).map_err(|_| OpenError::NotMappable {
        path: path.to_path_buf(),
    })
}
