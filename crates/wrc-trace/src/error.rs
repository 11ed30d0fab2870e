//! Why a trace could not be written or read: one sentence naming the file.

use crate::FORMAT_VERSION;

/// A trace that cannot be written or read. `file` is the path for [`TraceFile::save`] and
/// [`TraceFile::load`], and `<stream>` for [`TraceFile::write_to`] and
/// [`TraceFile::read_from`].
///
/// [`TraceFile::save`]: crate::TraceFile::save
/// [`TraceFile::load`]: crate::TraceFile::load
/// [`TraceFile::write_to`]: crate::TraceFile::write_to
/// [`TraceFile::read_from`]: crate::TraceFile::read_from
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TraceError {
    /// The operating system refused a read or a write.
    #[error("cannot {action} trace {file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// What was being done: `read`, `write`, `create the directory of`.
        action: &'static str,
        /// Why.
        source: std::io::Error,
    },
    /// The file does not start with the trace magic.
    #[error("{file} is not a wrc trace: it does not start with \"WRCTRACE\"")]
    NotATrace {
        /// The file.
        file: String,
    },
    /// The file is a trace of another format version, newer or older.
    #[error(
        "{file} was written by {} wrc (trace format {found}); this wrc reads trace format {supported} only{}",
        if *found > FORMAT_VERSION { "a newer" } else { "an older" },
        if *found > FORMAT_VERSION { ": read it with a newer wrc" } else { ": read it with the wrc that wrote it" },
    )]
    Version {
        /// The file.
        file: String,
        /// The format version in the file.
        found: u32,
        /// The format version this build reads and writes: [`FORMAT_VERSION`].
        supported: u32,
    },
    /// The file ends before its end section.
    #[error("{file} is truncated: it ends inside {what}; the file is incomplete")]
    Truncated {
        /// The file.
        file: String,
        /// Where the data stops: `the header`, `the samples section`, ….
        what: &'static str,
    },
    /// A section does not match its CRC-32: the file was damaged.
    #[error("{file} is corrupt: its {section} section fails its CRC-32 check")]
    Corrupt {
        /// The file.
        file: String,
        /// The section: `meta`, `samples`, `messages` or `end`.
        section: &'static str,
    },
    /// The content breaks a rule of the format (an axis count above the maximum, a length
    /// longer than its section, an unknown code), or a trace to write cannot be written.
    #[error("{file} is not a valid trace: {reason}")]
    Invalid {
        /// The file.
        file: String,
        /// Which rule.
        reason: String,
    },
}

impl TraceError {
    /// The same error naming `file` instead.
    pub(crate) fn in_file(mut self, name: &str) -> TraceError {
        match &mut self {
            TraceError::Io { file, .. }
            | TraceError::NotATrace { file }
            | TraceError::Version { file, .. }
            | TraceError::Truncated { file, .. }
            | TraceError::Corrupt { file, .. }
            | TraceError::Invalid { file, .. } => *file = name.to_string(),
        }
        self
    }
}
