//! The session transcripts in docs/protocol.md: every request line parses the way the
//! document says, every parser refusal is formatted exactly as shown, and every reply line
//! is well formed (known reply word and code, ids echoed in order, `INF`/`ABS` only after
//! an `ACK`, valid checksums), so the document cannot drift from the code.

use std::collections::BTreeSet;

use wrc_protocol::{checksum, Code, Parser, ReplyBuf, Severity, State};

fn transcripts() -> Vec<Vec<String>> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/protocol.md");
    let doc = std::fs::read_to_string(path).expect("docs/protocol.md is readable");
    let mut blocks = Vec::new();
    let mut lines = doc.lines();
    while let Some(line) = lines.next() {
        if !line.starts_with("<!-- session") {
            continue;
        }
        assert_eq!(
            lines.next(),
            Some("```text"),
            "a session marker precedes a text block"
        );
        let block: Vec<String> = lines
            .by_ref()
            .take_while(|l| *l != "```")
            .map(str::to_owned)
            .collect();
        blocks.push(block);
    }
    blocks
}

/// The id of a reply (the number right after the reply word, if the word after it is a
/// number too for NAK/ABS), and the rest of the line.
fn split_id<'a>(kind: &str, words: &[&'a str]) -> (Option<u32>, Vec<&'a str>) {
    let numeric = |w: Option<&&str>| w.is_some_and(|w| w.bytes().all(|b| b.is_ascii_digit()));
    let has_id = match kind {
        "NAK" | "ABS" => numeric(words.first()) && numeric(words.get(1)),
        _ => numeric(words.first()),
    };
    if has_id {
        (Some(words[0].parse().unwrap()), words[1..].to_vec())
    } else {
        (None, words.to_vec())
    }
}

#[test]
fn documented_sessions_match_the_code() {
    let blocks = transcripts();
    assert_eq!(
        blocks.len(),
        2,
        "docs/protocol.md has the main and the serial session"
    );
    let parser = Parser::new(4).with_checksum(true);
    let mut out = ReplyBuf::new();
    let mut checked = 0;
    for block in blocks {
        let mut expected_nak: Option<String> = None;
        let mut awaiting_first: Option<Option<u32>> = None;
        let mut running = BTreeSet::new();
        for line in &block {
            if let Some(request) = line.strip_prefix("> ") {
                assert!(
                    awaiting_first.is_none(),
                    "the request before {line:?} got no reply"
                );
                match parser.parse(request.as_bytes()) {
                    Ok(r) => {
                        awaiting_first = Some(r.id);
                        if r.command.verb().spec().completes_later {
                            running.insert(r.id);
                        }
                    }
                    Err(refused) => {
                        expected_nak = Some(
                            String::from_utf8(out.rejected(&refused).to_vec())
                                .unwrap()
                                .trim_end()
                                .to_owned(),
                        );
                    }
                }
                continue;
            }
            let reply = line.strip_prefix("< ").expect("lines start with > or <");
            checked += 1;
            if let Some(nak) = expected_nak.take() {
                assert_eq!(reply, nak, "the parser's NAK is documented exactly");
                continue;
            }
            let body = match reply.rsplit_once('*') {
                Some((before, sum)) => {
                    assert_eq!(
                        sum,
                        format!("{:02X}", checksum(before.as_bytes())),
                        "{reply}"
                    );
                    before
                }
                None => reply,
            };
            let words: Vec<&str> = body.split(' ').collect();
            let (kind, rest) = (words[0], &words[1..]);
            let (id, rest) = split_id(kind, rest);
            match kind {
                "ACK" | "NAK" => {
                    assert_eq!(
                        awaiting_first.take(),
                        Some(id),
                        "first reply echoes the id: {reply}"
                    );
                    if kind == "ACK" {
                        assert!(rest.iter().all(|w| w.contains('=')), "{reply}");
                    } else {
                        running.remove(&id);
                    }
                }
                "INF" | "ABS" => {
                    assert!(
                        running.remove(&id),
                        "{reply} ends an action that was accepted"
                    );
                }
                "EVT" => {
                    let name = rest[0];
                    assert!(
                        ["STATE", "ERROR", "INPUT", "CONTROL", "STATUS"].contains(&name),
                        "{reply}"
                    );
                    if name == "STATE" {
                        assert!(State::ALL.iter().any(|s| s.as_str() == rest[1]), "{reply}");
                    }
                }
                other => panic!("unknown reply word {other} in {reply}"),
            }
            if kind == "NAK" || kind == "ABS" {
                let code = Code::from_number(rest[0].parse().unwrap()).expect("a documented code");
                let severity = code.severity();
                if kind == "NAK" {
                    assert_eq!(severity, Severity::Warning, "{reply}");
                } else {
                    assert_ne!(severity, Severity::Warning, "{reply}");
                }
                assert_eq!(rest[1..].join(" "), code.text(), "default text: {reply}");
            }
        }
        assert!(awaiting_first.is_none() && expected_nak.is_none());
    }
    assert!(checked > 30);
}

/// The code table in docs/protocol.md lists every code with its number, name and text.
#[test]
fn documented_code_table_matches_the_code() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/protocol.md");
    let doc = std::fs::read_to_string(path).unwrap();
    for &code in Code::ALL {
        let row = format!("| {} | `{:?}` | {}", code.number(), code, code.text());
        assert!(doc.contains(&row), "docs/protocol.md lacks the row {row:?}");
    }
}

/// The "Errors the parser finds" table in docs/protocol.md shows the exact NAK for each
/// literal request.
#[test]
fn documented_parser_errors_match_the_code() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/protocol.md");
    let doc = std::fs::read_to_string(path).unwrap();
    let section = doc
        .split("### Errors the parser finds")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("the section exists");
    let serial = Parser::new(4).with_checksum(true);
    let tcp = Parser::new(4);
    let mut out = ReplyBuf::new();
    let mut checked = 0;
    for row in section.lines().filter(|l| l.starts_with("| `")) {
        let row = row.replace("\\|", "\u{1}");
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let (request, reply) = (cells[1], cells[2]);
        let Some((literal, note)) = request.strip_prefix('`').and_then(|r| r.split_once('`'))
        else {
            continue;
        };
        if literal.contains('<') {
            continue; // written with a placeholder such as <NUL>
        }
        let parser = if note.contains("TCP") { tcp } else { serial };
        let refused = parser
            .parse(literal.replace('\u{1}', "|").as_bytes())
            .unwrap_err();
        let line = String::from_utf8(out.rejected(&refused).to_vec()).unwrap();
        let expected = reply.trim_matches('`').replace('\u{1}', "|");
        assert_eq!(line.trim_end(), expected, "row for {literal:?}");
        checked += 1;
    }
    assert!(checked >= 15, "only {checked} rows were checked");
}
