//! Fuzz the host protocol's request path: a byte stream, as a socket or the serial port
//! delivers it cut into chunks, framed by `LineReader` and each line parsed by `Parser`
//! for a TCP connection (no checksums) or the serial port (`*HH` accepted). As the host
//! tasks do, an accepted `UPLOAD` makes the following lines program text, blank ones
//! included, up to a line `.` or an over-long line.
//!
//! Input: one mode byte (bit 0: serial; bits 1-4: axis count - 1), up to three chunk
//! lengths (0: the rest of the stream), then the stream. Asserts: the lines do not depend on
//! where the stream was cut; every line fits the limit and holds no LF, and outside an
//! upload none is blank; an accepted line
//! is the same request on the other kind of connection (with its checksum removed, or a
//! correct one appended); every reply — `ACK`, the `NAK` of a refused line, the `NAK 103`
//! of an over-long one — is one line of printable ASCII that echoes the id, carries the
//! code and a text that does not start with a digit, and a valid `*HH` exactly when the
//! request carried one.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wrc_protocol::{
    checksum, Command, LineError, LineReader, Parser, ReplyBuf, Request, Verb, MAX_LINE,
    REPLY_CAPACITY,
};

fuzz_target!(|input: &[u8]| {
    let Some((&mode, rest)) = input.split_first() else {
        return;
    };
    let serial = mode & 1 == 1;
    let axis_count = usize::from((mode >> 1) & 15) + 1;
    let (cuts, stream) = rest.split_at(rest.len().min(3));
    let parser = Parser::new(axis_count).with_checksum(serial);

    let whole = frame(&parser, stream, &[]);
    assert_eq!(
        whole,
        frame(&parser, stream, cuts),
        "framing depends on the chunk boundaries"
    );

    let mut out = ReplyBuf::new();
    for (uploading, line) in &whole {
        match line {
            Err(too_long) => {
                let reply = out.line_error(too_long).to_vec();
                assert!(reply.starts_with(b"NAK 103 "), "{reply:?}");
                one_line(&reply, false);
            }
            Ok(_) if *uploading => {}
            Ok(line) => check_line(&parser, line, &mut out),
        }
    }
});

/// The lines of `stream` fed in chunks of the lengths in `cuts`, cycled (0 or none: the
/// rest at once), each with whether it is an upload's program text.
fn frame(parser: &Parser, stream: &[u8], cuts: &[u8]) -> Vec<(bool, Result<Vec<u8>, LineError>)> {
    let mut reader = LineReader::new();
    let mut uploading = false;
    let mut lines = Vec::new();
    let mut rest = stream;
    for k in 0.. {
        if rest.is_empty() {
            break;
        }
        let n = match cuts.get(k % cuts.len().max(1)) {
            Some(&c) if c != 0 => usize::from(c).min(rest.len()),
            _ => rest.len(),
        };
        let (mut chunk, tail) = rest.split_at(n);
        rest = tail;
        loop {
            reader.keep_blank_lines(uploading);
            let Some(line) = reader.read(&mut chunk) else {
                break;
            };
            let was_uploading = uploading;
            match line {
                Ok(line) => {
                    assert!(
                        line.len() <= MAX_LINE,
                        "a line over the limit was passed on"
                    );
                    assert!(!line.contains(&b'\n'), "a line holds an LF");
                    if uploading {
                        uploading = line != b".";
                    } else {
                        assert!(
                            !line.iter().all(|&b| matches!(b, b' ' | b'\t' | b'\r')),
                            "a blank line was passed on"
                        );
                        uploading = matches!(
                            parser.parse(line),
                            Ok(Request {
                                command: Command::Upload(_),
                                ..
                            })
                        );
                    }
                }
                Err(_) => uploading = false,
            }
            lines.push((was_uploading, line.map(<[u8]>::to_vec)));
        }
        assert!(
            chunk.is_empty(),
            "read returned None before the chunk was used up"
        );
    }
    assert!(reader.pending() <= MAX_LINE + 1);
    lines
}

fn check_line(parser: &Parser, line: &[u8], out: &mut ReplyBuf) {
    match parser.parse(line) {
        Ok(request) => {
            let verb = request.command.verb();
            assert_eq!(Verb::from_name(verb.name().as_bytes()), Some(verb));
            let reply = out.ack(request.reply_to(), "").to_vec();
            one_line(&reply, request.checksum);
            let words = reply_words(&reply);
            assert_eq!(words[0], "ACK");
            if let Some(id) = request.id {
                assert_eq!(words.get(1).copied(), Some(id.to_string().as_str()));
            }
            if request.checksum {
                // Serial with `*HH`: without the suffix it is the same request on TCP.
                let star = line.iter().position(|&b| b == b'*').expect("a checksum");
                let plain = Parser::new(parser.axis_count())
                    .parse(&line[..star])
                    .unwrap_or_else(|e| panic!("accepted with a checksum, refused without: {e}"));
                assert_eq!((plain.id, plain.command), (request.id, request.command));
                assert!(!plain.checksum);
            } else {
                // No checksum: with a correct one appended it is the same request on serial.
                let mut summed = line.to_vec();
                summed.extend_from_slice(format!("*{:02X}", checksum(line)).as_bytes());
                let serial = parser
                    .with_checksum(true)
                    .parse(&summed)
                    .unwrap_or_else(|e| panic!("accepted, refused with its checksum: {e}"));
                assert_eq!((serial.id, serial.command), (request.id, request.command));
                assert!(serial.checksum);
            }
        }
        Err(rejected) => {
            let reply = out.rejected(&rejected).to_vec();
            one_line(&reply, rejected.checksum);
            let words = reply_words(&reply);
            let mut words = words.iter();
            assert_eq!(words.next(), Some(&"NAK"));
            if let Some(id) = rejected.id {
                assert_eq!(
                    words.next(),
                    Some(&id.to_string().as_str()),
                    "id not echoed"
                );
            }
            let code = rejected.code().number().to_string();
            assert_eq!(words.next(), Some(&code.as_str()), "code missing");
            let text = words.next().expect("a NAK has a text");
            assert!(
                !text.starts_with(|c: char| c.is_ascii_digit()),
                "a NAK text starts with a digit: {:?}",
                String::from_utf8_lossy(&reply)
            );
        }
    }
}

/// The words of a reply line without its LF and `*HH`.
fn reply_words(reply: &[u8]) -> Vec<&str> {
    let text = std::str::from_utf8(reply).expect("replies are ASCII");
    let text = text.trim_end_matches('\n');
    let text = text.split('*').next().unwrap_or(text);
    text.split(' ').collect()
}

/// `reply` is one line of printable ASCII ending in LF, with a correct `*HH` before the LF
/// when `summed`, and no `*` otherwise.
fn one_line(reply: &[u8], summed: bool) {
    assert!(reply.len() <= REPLY_CAPACITY, "reply over its capacity");
    let Some((&b'\n', body)) = reply.split_last() else {
        panic!("a reply does not end in LF: {reply:?}");
    };
    assert!(
        body.iter().all(|&b| b.is_ascii_graphic() || b == b' '),
        "a reply is not one line of printable ASCII: {:?}",
        String::from_utf8_lossy(reply)
    );
    if summed {
        let star = body.len().checked_sub(3).expect("room for *HH");
        assert_eq!(body[star], b'*');
        assert!(!body[..star].contains(&b'*'));
        let hex = format!("{:02X}", checksum(&body[..star]));
        assert_eq!(&body[star + 1..], hex.as_bytes(), "wrong reply checksum");
    } else {
        assert!(!body.contains(&b'*'), "a `*` in a reply without checksum");
    }
}
