//! The binary form: `from_bytes(to_bytes(p)) == p`, and every truncated or corrupted blob is
//! an error, never a panic.

use wrc_lang::{DecodeError, Program, FORMAT_VERSION};

use crate::common::{program, run};

const SOURCE: &str = "\
P = POSE(300, -100, 0, 0)
J = JOINTS(1, 2, 3, 4)
STATION = \"LP2\"
MAP STATION
FOR i = 5 TO 1 STEP -2
  IF i > 2 AND NOT IN(3) THEN
    MOVEP P + POSE(0, i, 0, 0), L
  ELSE
    MOVEL P
  ENDIF
  JOG Z, 100
  WAIT IN(1) = 1 TIMEOUT 1
  GET \"LP1\", i
  PUT STATION, 6 - i
NEXT
CALL s
PRINT \"J\", J.J2, \"é\", P, SQRT(2)
END
SUB s
  OUT 1, 1
  SPEED 20
  DELAY 0.5
  HOME
ENDSUB
";

#[test]
fn to_bytes_and_from_bytes_are_inverse() {
    let p = program(SOURCE);
    let bytes = p.to_bytes();
    assert_eq!(&bytes[..4], b"WRCL");
    let back = Program::from_bytes(&bytes).expect("decodes");
    assert_eq!(back, p);
    assert_eq!(back.to_bytes(), bytes);
    assert_eq!(back.listing(), p.listing());
    // The decoded program runs the same.
    let (a, b) = (run(&p), run(&back));
    assert_eq!(a.requests, b.requests);
    assert_eq!(a.printed, b.printed);
    // Compact: a few bytes per instruction.
    assert!(
        bytes.len() < p.len() * 8,
        "{} bytes for {}",
        bytes.len(),
        p.len()
    );
}

#[test]
fn every_truncation_is_an_error() {
    let bytes = program(SOURCE).to_bytes();
    for len in 0..bytes.len() {
        assert!(Program::from_bytes(&bytes[..len]).is_err(), "length {len}");
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(Program::from_bytes(&longer).is_err());
}

#[test]
fn every_corrupted_byte_is_an_error() {
    let bytes = program(SOURCE).to_bytes();
    for i in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut bad = bytes.clone();
            bad[i] ^= flip;
            assert!(Program::from_bytes(&bad).is_err(), "byte {i} ^ {flip:#x}");
        }
    }
}

#[test]
fn header_errors_say_what_is_wrong() {
    let bytes = program("PRINT 1\n").to_bytes();
    assert_eq!(Program::from_bytes(b"ELF!"), Err(DecodeError::BadMagic));
    let mut v2 = bytes.clone();
    v2[4..6].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    assert_eq!(
        Program::from_bytes(&v2),
        Err(DecodeError::UnsupportedVersion {
            found: FORMAT_VERSION + 1,
            supported: FORMAT_VERSION
        })
    );
    let mut sum = bytes.clone();
    let last = sum.len() - 1;
    sum[last] ^= 1;
    assert_eq!(Program::from_bytes(&sum), Err(DecodeError::BadChecksum));
    assert_eq!(
        DecodeError::BadChecksum.to_string(),
        "bytecode checksum mismatch: the blob is corrupted"
    );
}

#[test]
fn the_listing_and_json_describe_the_program() {
    let p =
        program("P = POSE(300, 0, 0, 0)\nMOVEL P\nCALL s\nPRINT f(2)\nEND\nSUB s\n  PRINT \"hi\"\nENDSUB\nFUNCTION f(x)\n  RETURN x * 2\nENDFUNCTION\n");
    let listing = p.listing();
    assert!(listing.contains("; v0 P (pose)"), "{listing}");
    assert!(listing.contains("; SUB s @"), "{listing}");
    assert!(listing.contains("; FUNCTION (number) f @"), "{listing}");
    assert!(listing.contains("2:1      MOVEL"), "{listing}");
    assert!(listing.contains("CALL     @"), "{listing}");
    let json: serde_json::Value = serde_json::from_str(&p.to_json()).expect("valid JSON");
    assert_eq!(json["version"], FORMAT_VERSION);
    assert_eq!(json["variables"][0]["type"], "pose");
    assert_eq!(json["strings"][0], "hi");
    assert_eq!(json["routines"][0]["name"], "s");
    assert_eq!(json["routines"][1]["returns"], "number");
    assert_eq!(json["routines"][1]["params"], 1);
    let code = json["code"].as_array().unwrap();
    assert_eq!(code.len(), p.len());
    assert!(code.iter().any(|i| i["op"] == "MOVEL" && i["line"] == 2));
}
