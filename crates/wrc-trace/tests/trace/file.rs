//! The trace file: a round trip keeps everything, saves are atomic and create their
//! directory, and every kind of bad file is refused with its own error and a clear sentence.

use wrc_trace::{sample_file_bytes, Meta, TraceError, TraceFile, FORMAT_VERSION, MAGIC, MAX_AXES};

use crate::{bytes_of, sample_trace};

/// Offset of the first section (the meta): after the magic and the version.
const META_AT: usize = 12;

/// Section starts in `bytes`: (tag, offset of the tag, body length).
fn sections(bytes: &[u8]) -> Vec<([u8; 4], usize, usize)> {
    let mut at = META_AT;
    let mut out = Vec::new();
    while at < bytes.len() {
        let tag: [u8; 4] = bytes[at..at + 4].try_into().unwrap();
        let len = u64::from_le_bytes(bytes[at + 4..at + 12].try_into().unwrap()) as usize;
        out.push((tag, at, len));
        at += 4 + 8 + len + 4;
    }
    out
}

/// Recompute the CRC of the section at `at`, as a writer with a bug would have.
fn reseal(bytes: &mut [u8], at: usize) {
    let len = u64::from_le_bytes(bytes[at + 4..at + 12].try_into().unwrap()) as usize;
    let end = at + 12 + len;
    let crc = crc32fast::hash(&bytes[at..end]);
    bytes[end..end + 4].copy_from_slice(&crc.to_le_bytes());
}

fn read(bytes: &[u8]) -> Result<TraceFile, TraceError> {
    TraceFile::read_from(&mut &bytes[..])
}

#[test]
fn a_trace_reads_back_exactly_as_written() {
    let trace = sample_trace(120);
    let bytes = bytes_of(&trace);
    assert_eq!(&bytes[..8], &MAGIC);
    assert_eq!(bytes[8..12], FORMAT_VERSION.to_le_bytes());
    let back = read(&bytes).unwrap();
    assert_eq!(back, trace);
    assert!(back.messages.iter().any(|m| m.truncated()));
    // An empty trace of no axes too.
    let empty = TraceFile {
        meta: Meta::new("", 0, &[], &[]),
        samples: Vec::new(),
        messages: Vec::new(),
    };
    assert_eq!(read(&bytes_of(&empty)).unwrap(), empty);
}

#[test]
fn only_the_traces_axes_are_written() {
    let trace = sample_trace(100);
    let tags: Vec<_> = sections(&bytes_of(&trace))
        .into_iter()
        .map(|(tag, _, len)| (tag, len))
        .collect();
    assert_eq!(tags[1].0, *b"SMPL");
    assert_eq!(tags[1].1, 8 + 100 * sample_file_bytes(4));
    assert_eq!(sample_file_bytes(4), 93);
    assert_eq!(
        tags.iter().map(|t| t.0).collect::<Vec<_>>(),
        [*b"META", *b"SMPL", *b"MESG", *b"END\0"]
    );
}

#[test]
fn save_creates_the_directory_replaces_the_file_and_load_reads_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("traces/today/alarm.wrctrace");
    let trace = sample_trace(30);
    trace.save(&path).unwrap();
    assert_eq!(TraceFile::load(&path).unwrap(), trace);
    let shorter = sample_trace(5);
    shorter.save(&path).unwrap();
    assert_eq!(TraceFile::load(&path).unwrap(), shorter);
    let names: Vec<_> = std::fs::read_dir(path.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "no temporary file is left: {names:?}");
}

#[test]
fn load_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.wrctrace");
    let err = TraceFile::load(&missing).unwrap_err();
    assert!(matches!(err, TraceError::Io { .. }), "{err:?}");
    let text = err.to_string();
    assert!(text.starts_with("cannot read trace "), "{text}");
    assert!(text.contains("missing.wrctrace"), "{text}");

    let junk = dir.path().join("notes.txt");
    std::fs::write(&junk, "hello, world").unwrap();
    let err = TraceFile::load(&junk).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{} is not a wrc trace: it does not start with \"WRCTRACE\"",
            junk.display()
        )
    );
}

#[test]
fn a_save_that_cannot_write_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, "").unwrap();
    let err = sample_trace(3)
        .save(&blocker.join("x.wrctrace"))
        .unwrap_err();
    assert!(matches!(err, TraceError::Io { .. }), "{err:?}");
    assert!(
        err.to_string()
            .starts_with("cannot create the directory of trace "),
        "{err}"
    );
}

#[test]
fn a_wrong_magic_is_not_a_trace() {
    let mut bytes = bytes_of(&sample_trace(3));
    bytes[0] = b'X';
    assert!(matches!(read(&bytes), Err(TraceError::NotATrace { .. })));
    assert!(matches!(
        read(b"PK\x03\x04 a zip file"),
        Err(TraceError::NotATrace { .. })
    ));
}

#[test]
fn newer_and_older_formats_are_refused_with_a_clear_sentence() {
    let mut bytes = bytes_of(&sample_trace(3));
    bytes[8..12].copy_from_slice(&3u32.to_le_bytes());
    let err = read(&bytes).unwrap_err();
    assert!(
        matches!(
            err,
            TraceError::Version {
                found: 3,
                supported: 2,
                ..
            }
        ),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        "<stream> was written by a newer wrc (trace format 3); this wrc reads trace format 2 \
         only: read it with a newer wrc"
    );
    // Format 1 (before connections were recorded) is older.
    for older in [1u32, 0] {
        bytes[8..12].copy_from_slice(&older.to_le_bytes());
        let err = read(&bytes).unwrap_err();
        assert!(
            matches!(err, TraceError::Version { found, .. } if found == older),
            "{err:?}"
        );
        assert!(
            err.to_string()
                .contains(&format!("written by an older wrc (trace format {older})")),
            "{err}"
        );
    }
}

#[test]
fn a_file_cut_anywhere_is_truncated_and_says_where() {
    let bytes = bytes_of(&sample_trace(40));
    let s = sections(&bytes);
    let cases = [
        (0, "the header"),
        (5, "the header"),
        (10, "the header"),
        (META_AT + 2, "the meta section"),
        (s[0].1 + 30, "the meta section"),
        (s[1].1 + 12 + 100, "the samples section"),
        (s[2].1 - 1, "the samples section"),
        (s[2].1 + 20, "the messages section"),
        (s[3].1, "the end section"),
        (bytes.len() - 1, "the end section"),
    ];
    for (len, what) in cases {
        let err = read(&bytes[..len]).unwrap_err();
        match &err {
            TraceError::Truncated { what: w, .. } => assert_eq!(*w, what, "cut at {len}"),
            other => panic!("cut at {len}: {other:?}"),
        }
        assert!(
            err.to_string().contains(" is truncated: it ends inside "),
            "{err}"
        );
    }
    assert!(read(&bytes).is_ok());
}

#[test]
fn a_flipped_byte_in_any_section_is_corrupt_and_names_the_section() {
    let bytes = bytes_of(&sample_trace(40));
    for ((_, at, len), section) in sections(&bytes)
        .into_iter()
        .zip(["meta", "samples", "messages"])
    {
        for offset in [at + 12, at + 12 + len / 2, at + 12 + len - 1] {
            let mut bad = bytes.clone();
            bad[offset] ^= 0x10;
            match read(&bad) {
                Err(TraceError::Corrupt { section: s, .. }) => assert_eq!(s, section),
                other => panic!("byte {offset} flipped: {other:?}"),
            }
        }
    }
    // The CRC itself and the tag are checked too.
    let mut bad = bytes.clone();
    let last = bad.len() - 1;
    bad[last] ^= 1;
    assert!(matches!(
        read(&bad),
        Err(TraceError::Corrupt { section: "end", .. })
    ));
    let mut bad = bytes.clone();
    bad[META_AT] = b'X';
    let err = read(&bad).unwrap_err();
    assert!(matches!(
        err,
        TraceError::Corrupt {
            section: "meta",
            ..
        }
    ));
    assert_eq!(
        err.to_string(),
        "<stream> is corrupt: its meta section fails its CRC-32 check"
    );
}

#[test]
fn a_huge_length_is_refused_without_allocating_it() {
    let mut bytes = bytes_of(&sample_trace(3));
    let samples_at = sections(&bytes)[1].1;
    bytes[samples_at + 4..samples_at + 12].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(
        read(&bytes),
        Err(TraceError::Corrupt {
            section: "samples",
            ..
        })
    ));
    // Within the cap but past the end of the data: a truncation, read only as far as it goes.
    bytes[samples_at + 4..samples_at + 12].copy_from_slice(&(1u64 << 31).to_le_bytes());
    assert!(matches!(
        read(&bytes),
        Err(TraceError::Truncated {
            what: "the samples section",
            ..
        })
    ));
}

#[test]
fn content_that_breaks_the_rules_is_invalid_even_with_a_good_crc() {
    let trace = sample_trace(10);
    let bytes = bytes_of(&trace);
    // The axis count follows wrc_version, reason, clock and period_ns in the meta body.
    let axes_at = META_AT + 12 + (4 + 5) + (4 + 10) + 1 + 8;
    assert_eq!(bytes[axes_at..axes_at + 4], 4u32.to_le_bytes());
    let mut bad = bytes.clone();
    bad[axes_at..axes_at + 4].copy_from_slice(&17u32.to_le_bytes());
    reseal(&mut bad, META_AT);
    let err = read(&bad).unwrap_err();
    assert_eq!(
        err.to_string(),
        "<stream> is not a valid trace: it has 17 axes; a trace has at most 16"
    );
    // A sample count that does not match the section's size.
    let mut bad = bytes.clone();
    let samples_at = sections(&bytes)[1].1;
    bad[samples_at + 12..samples_at + 20].copy_from_slice(&u64::MAX.to_le_bytes());
    reseal(&mut bad, samples_at);
    let err = read(&bad).unwrap_err();
    assert!(matches!(err, TraceError::Invalid { .. }), "{err:?}");
    assert!(err.to_string().contains("samples of 93 bytes"), "{err}");
    // A message whose direction is none of request, reply, opened, closed. The first
    // message (the host's connection) starts after the section's tag, length and count:
    // its direction follows its t_ns.
    let messages_at = sections(&bytes)[2].1;
    let direction_at = messages_at + 12 + 8 + 8;
    assert_eq!(direction_code(&bytes, direction_at), 2, "opened");
    let mut bad = bytes.clone();
    bad[direction_at] = 4;
    reseal(&mut bad, messages_at);
    let err = read(&bad).unwrap_err();
    assert_eq!(
        err.to_string(),
        "<stream> is not a valid trace: a message has direction code 4; it is 0 to 3"
    );
    // Sections out of order: a samples section where the meta belongs.
    let s = sections(&bytes);
    let mut swapped = bytes[..META_AT].to_vec();
    swapped.extend_from_slice(&bytes[s[1].1..s[2].1]);
    let err = read(&swapped).unwrap_err();
    assert!(
        err.to_string()
            .contains("the meta section (tag \"META\") was expected"),
        "{err}"
    );
}

fn direction_code(bytes: &[u8], at: usize) -> u8 {
    bytes[at]
}

#[test]
fn a_trace_with_too_many_axes_is_not_written() {
    let names: Vec<String> = (0..=MAX_AXES).map(|i| format!("A{i}")).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let trace = TraceFile {
        meta: Meta::new("x", 1, &names, &[]),
        samples: Vec::new(),
        messages: Vec::new(),
    };
    let mut out = Vec::new();
    let err = trace.write_to(&mut out).unwrap_err();
    assert!(matches!(err, TraceError::Invalid { .. }), "{err:?}");
    assert!(out.is_empty(), "nothing is written");
}

#[test]
fn the_summary_says_what_the_trace_holds() {
    let summary = sample_trace(200).summary();
    for expected in [
        "reason:   TRACE SAVE",
        "by wrc 0.1.0, trace format 2",
        "virtual clock",
        "period:   10 ms, 4 axes (J1, J2, J3, Z)",
        "duration: 1.990 s (t = 0.000 s to 1.990 s)",
        "samples:  200",
        "messages: 44 (21 requests, 21 replies; connections: 1 opened, 1 closed), from the session's start",
        "states:   IDLE, MOVING",
        "errors:   206",
    ] {
        assert!(summary.contains(expected), "{expected:?} in\n{summary}");
    }
}

#[test]
fn docs_trace_md_states_this_layout() {
    let doc = include_str!("../../../../docs/trace.md");
    let size = |t: &str| doc.contains(t);
    assert!(size(&format!(
        "# Trace files, format version {FORMAT_VERSION}"
    )));
    assert!(size(&format!(
        "`{}` (`wrc_trace::FORMAT_VERSION`)",
        FORMAT_VERSION
    )));
    assert!(size("**29 + 16 × axis count** bytes each (93 bytes"));
    assert_eq!(sample_file_bytes(0), 29);
    assert_eq!(sample_file_bytes(1) - sample_file_bytes(0), 16);
    assert!(
        size(&format!(
            "`size_of::<Sample>()` = {} bytes",
            std::mem::size_of::<wrc_trace::Sample>()
        )),
        "the ring's sample size in docs/trace.md"
    );
    assert!(
        size(&format!(
            "{} bytes per message slot",
            std::mem::size_of::<wrc_trace::Message>()
        )),
        "the ring's message size in docs/trace.md"
    );
    for tag in ["`META`", "`SMPL`", "`MESG`", "`END\\0`"] {
        assert!(size(tag), "{tag}");
    }
}
