//! Fuzz the program upload: the bytes a connection sends after `UPLOAD fuzz`, framed by the
//! connection's `LineReader` as the host tasks frame an upload (blank lines kept), each line passed to the program
//! store in a `StoreRequest::line` and collected by `ProgramText`, up to the line `.`; then
//! compiled by `upload::check` with the paper robot, as the service thread does.
//!
//! Asserts: no line is cut on its way to the store; the text compiled is the text sent,
//! verbatim (every line up to `.`, blank ones included, without its LF or CR LF); every
//! reply — the `NAK 103` that cancels an upload with an over-long line, each `EVT DIAG`
//! (naming the upload or the stored file it is in),
//! the final `ACK` or `NAK 126` — is one line of printable ASCII (with a valid `*HH` when
//! the input's length is odd, as for a serial client that sends checksums).
#![no_main]

use libfuzzer_sys::fuzz_target;
use wrc_controller::messages::{SourceId, StoreRequest};
use wrc_controller::upload::{check, ProgramText};
use wrc_protocol::{checksum, Code, Event, LineReader, ProgramName, ReplyBuf, ReplyTo};
use wrc_robot::Robot;

/// The store the upload compiles against: the examples' library `cell_lib`, a library `lib`
/// (INCLUDE "lib"), a program `other` (CALL PROGRAM "other") and the upload's points file.
struct Store;

impl wrc_lang::Sources for Store {
    fn program(&self, name: &str) -> Result<String, String> {
        match name {
            "cell_lib" => Ok(include_str!("../../../../examples/cell_lib.wrl").into()),
            "lib" => Ok("SUB greet(who$)\n  PRINT \"hello\", who$\nENDSUB\n\
                         FUNCTION twice(v)\n  RETURN v * 2\nENDFUNCTION\n"
                .into()),
            "other" => Ok("MOVEJ PARK\nPRINT twice(2)\nINCLUDE \"lib\"\n".into()),
            _ => Err(format!("there is no {name}.wrl")),
        }
    }

    fn points(&self, name: &str) -> Result<Option<String>, String> {
        Ok(match name {
            "fuzz" => {
                Some("[points]\nABOVE = { x = 250.0, y = 50.0, z = 20.0, yaw = 0.0 }\n".into())
            }
            "other" => Some("[points]\nPARK = { joints = [30.0, 60.0, -90.0, 10.0] }\n".into()),
            _ => None,
        })
    }
}

fuzz_target!(|stream: &[u8]| {
    let name = ProgramName::new("fuzz").expect("a program name");
    let to = ReplyTo {
        id: Some(1),
        checksum: stream.len() % 2 == 1,
    };
    let mut out = ReplyBuf::new();
    let mut reader = LineReader::new();
    // As the host tasks set it while a connection uploads.
    reader.keep_blank_lines(true);
    let mut text = ProgramText::new();
    let mut rest = stream;
    let mut ended = false;
    while let Some(line) = reader.read(&mut rest) {
        match line {
            Err(too_long) => {
                let cancelled = out.nak(
                    ReplyTo::default(),
                    too_long.code(),
                    format_args!("{too_long}; the upload is cancelled, nothing stored"),
                );
                one_line(cancelled, false);
                return;
            }
            Ok(b".") => {
                ended = true;
                break;
            }
            Ok(line) => {
                let StoreRequest::Line {
                    len, text: bytes, ..
                } = StoreRequest::line(SourceId(0x1000_0001), line)
                else {
                    unreachable!("StoreRequest::line makes a Line");
                };
                let kept = &bytes[..usize::from(len)];
                assert_eq!(kept, line, "a line was cut on its way to the store");
                text.push_line(kept);
            }
        }
    }
    if !ended {
        // The connection closed before `.`: the store forgets the upload.
        return;
    }
    let lines = text.lines();
    let source = text.finish(&name).expect("fewer lines than the limit");
    assert_eq!(
        source,
        sent(&stream[..stream.len() - rest.len()]),
        "the store's text is not what was sent"
    );

    let verdict = check(&name, &source, &Robot::paper_default(), Some(&Store));
    for diag in &verdict.diagnostics {
        let line = out.event(to.checksum, &Event::Diag(diag));
        // In the program uploaded, or in a stored file it INCLUDEs or CALLs.
        assert!(
            ["fuzz", "cell_lib", "lib", "other"]
                .iter()
                .any(|f| line.starts_with(format!("EVT DIAG {f}.wrl:").as_bytes())),
            "{line:?}"
        );
        one_line(line, to.checksum);
    }
    match verdict.result {
        Ok((_, warnings)) => {
            let ack = out.ack(
                to,
                format_args!("name={name} lines={lines} warnings={warnings}"),
            );
            one_line(ack, to.checksum);
        }
        Err(refusal) => {
            assert!(refusal.starts_with("fuzz: "), "{refusal}");
            let nak = out.nak(to, Code::ProgramInvalid, &refusal);
            assert!(nak.starts_with(b"NAK 1 126 fuzz: "), "{nak:?}");
            one_line(nak, to.checksum);
        }
    }
});

/// The program text a client sent in `framed` (its lines up to and including `.`): every
/// line before the `.`, without its LF or CR LF, each followed by LF; bytes that are not
/// UTF-8 as U+FFFD.
fn sent(framed: &[u8]) -> String {
    let mut lines: Vec<&[u8]> = framed.split(|&b| b == b'\n').collect();
    assert_eq!(lines.pop(), Some(&b""[..]), "the `.` line ends with its LF");
    let end = lines.pop().expect("the `.` line");
    assert!(end == b"." || end == b".\r", "{end:?}");
    let mut text = String::new();
    for line in lines {
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        text.push_str(&String::from_utf8_lossy(line));
        text.push('\n');
    }
    text
}

/// `reply` is one line of printable ASCII ending in LF, with a correct `*HH` before the LF
/// when `summed`.
fn one_line(reply: &[u8], summed: bool) {
    let Some((&b'\n', body)) = reply.split_last() else {
        panic!("a reply does not end in LF: {reply:?}");
    };
    assert!(
        body.iter().all(|&b| b.is_ascii_graphic() || b == b' '),
        "a reply is not one line of printable ASCII: {:?}",
        String::from_utf8_lossy(reply)
    );
    if summed {
        let star = body.len() - 3;
        assert_eq!(body[star], b'*');
        let hex = format!("{:02X}", checksum(&body[..star]));
        assert_eq!(&body[star + 1..], hex.as_bytes(), "wrong reply checksum");
    }
}
