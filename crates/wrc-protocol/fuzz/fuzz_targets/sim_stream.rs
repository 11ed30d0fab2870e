//! Fuzz the simulator datagram (docs/simulator-stream.md). First byte even: the rest is a
//! datagram off the network; `decode` accepts or refuses it without panicking, and an
//! accepted one encodes back to the same bytes (the format has one encoding per frame).
//! First byte odd: a frame built from the fuzzer's bytes, encoded into a buffer of a
//! fuzzer-chosen size; `encode` refuses exactly the frames and buffers it must, and what it
//! writes decodes to the same frame, bit for bit.
#![no_main]

use libfuzzer_sys::arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use wrc_protocol::sim_stream::{decode, encode, EncodeError, SimFrame, MAX_DATAGRAM_LEN};
use wrc_protocol::{Pose, State, MAX_AXES};

fuzz_target!(|input: &[u8]| {
    let Some((&mode, rest)) = input.split_first() else {
        return;
    };
    if mode & 1 == 0 {
        let Ok(frame) = decode(rest) else {
            return;
        };
        assert!((1..=MAX_AXES).contains(&frame.axis_count));
        assert!(frame.positions[frame.axis_count..]
            .iter()
            .all(|&p| p == 0.0));
        assert!(frame.pulses[frame.axis_count..].iter().all(|&p| p == 0));
        let mut buf = [0u8; MAX_DATAGRAM_LEN];
        let len = encode(&frame, &mut buf).expect("a decoded frame encodes");
        assert_eq!(&buf[..len], rest, "decode then encode changed the datagram");
    } else {
        let _ = round_trip(&mut Unstructured::new(rest));
    }
});

fn round_trip(u: &mut Unstructured<'_>) -> Result<()> {
    let axis_count = u.int_in_range(0..=MAX_AXES + 1)?;
    let mut frame = SimFrame {
        sequence: u.arbitrary()?,
        timestamp_ns: u.arbitrary()?,
        state: *u.choose(State::ALL)?,
        homed: u.arbitrary()?,
        inputs: u.arbitrary()?,
        outputs: u.arbitrary()?,
        tcp: Pose {
            x: u.arbitrary()?,
            y: u.arbitrary()?,
            z: u.arbitrary()?,
            yaw: u.arbitrary()?,
        },
        axis_count,
        ..SimFrame::default()
    };
    for i in 0..axis_count.min(MAX_AXES) {
        frame.positions[i] = u.arbitrary()?;
        frame.pulses[i] = u.arbitrary()?;
    }
    let mut buf = [0u8; MAX_DATAGRAM_LEN + 8];
    let size = u.int_in_range(0..=buf.len())?;
    match encode(&frame, &mut buf[..size]) {
        Ok(len) => {
            assert_eq!(len, frame.encoded_len());
            let back = decode(&buf[..len]).expect("an encoded frame decodes");
            assert_eq!(bits(&back), bits(&frame), "the frame did not round-trip");
        }
        Err(EncodeError::AxisCount(n)) => {
            assert_eq!(n, axis_count);
            assert!(!(1..=MAX_AXES).contains(&n));
        }
        Err(EncodeError::BufferTooSmall { need, got }) => {
            assert_eq!((need, got), (frame.encoded_len(), size));
            assert!(got < need);
        }
        Err(e) => panic!("unexpected encode error {e}"),
    }
    Ok(())
}

/// The frame with its floats as bits, so that NaN payloads compare equal.
fn bits(f: &SimFrame) -> impl PartialEq + std::fmt::Debug {
    let floats: Vec<u64> = [f.tcp.x, f.tcp.y, f.tcp.z, f.tcp.yaw]
        .iter()
        .chain(&f.positions)
        .map(|v| v.to_bits())
        .collect();
    (
        (f.sequence, f.timestamp_ns, f.state, f.homed),
        (f.inputs, f.outputs, f.axis_count, f.pulses),
        floats,
    )
}
