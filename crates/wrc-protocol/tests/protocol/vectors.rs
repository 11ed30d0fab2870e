//! The simulator-stream test vector shared with the browser's decoder (web/src/protocol/stream.ts):
//! `tests/vectors/sim_stream_v1.json` holds one datagram as the Rust encoder writes it and
//! its decoded fields. This test keeps the file true; `WRC_BLESS=1` rewrites it.

use wrc_protocol::sim_stream::{decode, encode, MAX_DATAGRAM_LEN};
use wrc_protocol::{Pose, SimFrame, State};

fn frame() -> SimFrame {
    let mut f = SimFrame {
        sequence: 123_456,
        timestamp_ns: 9_876_543_210,
        state: State::Moving,
        homed: true,
        inputs: 0x8001,
        outputs: 0x0009,
        tcp: Pose {
            x: 250.5,
            y: -100.25,
            z: 20.0,
            yaw: 30.125,
        },
        axis_count: 4,
        ..SimFrame::default()
    };
    f.positions[..4].copy_from_slice(&[-75.5, 150.0, -45.25, 20.0]);
    f.pulses[..4].copy_from_slice(&[-75_500, 150_000, -45_250, 20_000]);
    f
}

fn json(bytes: &[u8], f: &SimFrame) -> String {
    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    let n = f.axis_count;
    serde_json::to_string_pretty(&serde_json::json!({
        "about": "one simulator datagram (docs/simulator-stream.md, version 1) as encoded by wrc_protocol::sim_stream::encode, and its fields; kept true by crates/wrc-protocol/tests/protocol/vectors.rs",
        "hex": hex,
        "decoded": {
            "seq": f.sequence,
            "timestamp_ns": f.timestamp_ns,
            "state": f.state.as_str(),
            "homed": f.homed,
            "inputs": f.inputs,
            "outputs": f.outputs,
            "x": f.tcp.x, "y": f.tcp.y, "z": f.tcp.z, "yaw": f.tcp.yaw,
            "positions": &f.positions[..n],
            "pulses": &f.pulses[..n],
        }
    }))
    .expect("json")
        + "\n"
}

#[test]
fn sim_stream_vector_matches_the_encoder() {
    let f = frame();
    let mut buf = [0u8; MAX_DATAGRAM_LEN];
    let len = encode(&f, &mut buf).expect("encodes");
    assert_eq!(decode(&buf[..len]).expect("decodes"), f);
    let text = json(&buf[..len], &f);
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/vectors/sim_stream_v1.json"
    );
    if std::env::var_os("WRC_BLESS").is_some() {
        std::fs::write(path, &text).expect("write the vector");
    }
    let stored = std::fs::read_to_string(path).expect("the vector file exists");
    assert_eq!(
        stored, text,
        "the vector is out of date; rerun with WRC_BLESS=1"
    );
}
