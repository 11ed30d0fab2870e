//! The simulator datagram: the versioned little-endian binary frame the Simulator Manager
//! sends over UDP every period (docs/simulator-stream.md). Encoding writes into the caller's
//! buffer without allocating; decoding checks everything and never panics.

use wrc_robot::{Pose, MAX_AXES};

use crate::state::State;

/// The first four bytes of every datagram: `WRCS`.
pub const MAGIC: [u8; 4] = *b"WRCS";

/// The layout version this crate writes and reads. Any change to the layout bumps it.
pub const VERSION: u16 = 1;

/// Default destination of the datagrams.
pub const DEFAULT_ADDR: &str = "127.0.0.1:7200";

/// Bytes before the per-axis arrays.
pub const HEADER_LEN: usize = 72;

/// Bytes per axis: one f64 position and one i64 pulse count.
pub const AXIS_LEN: usize = 16;

/// Largest datagram (16 axes) [bytes].
pub const MAX_DATAGRAM_LEN: usize = HEADER_LEN + AXIS_LEN * MAX_AXES;

/// One sample of the controller's state, as sent to the simulator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimFrame {
    /// Datagram counter, +1 per period; gaps mean lost datagrams.
    pub sequence: u64,
    /// Sample time on the controller's monotonic clock [ns]; only differences matter.
    pub timestamp_ns: u64,
    /// Controller state.
    pub state: State,
    /// Every axis has been homed.
    pub homed: bool,
    /// Input word, bit n = input n.
    pub inputs: u32,
    /// Output word, bit n = output n.
    pub outputs: u32,
    /// Tool centre point: x, y, z [mm], yaw [deg].
    pub tcp: Pose,
    /// Number of axes, 1 to [`MAX_AXES`].
    pub axis_count: usize,
    /// Position of each axis in axis units ([deg] or [mm]); entries from `axis_count` on are
    /// not sent and decode as zero.
    pub positions: [f64; MAX_AXES],
    /// Position of each axis [pulse]; entries from `axis_count` on as for `positions`.
    pub pulses: [i64; MAX_AXES],
}

impl Default for SimFrame {
    fn default() -> Self {
        SimFrame {
            sequence: 0,
            timestamp_ns: 0,
            state: State::Idle,
            homed: false,
            inputs: 0,
            outputs: 0,
            tcp: Pose::default(),
            axis_count: 1,
            positions: [0.0; MAX_AXES],
            pulses: [0; MAX_AXES],
        }
    }
}

impl SimFrame {
    /// Length of this frame's datagram [bytes]: 72 + 16 × axis count.
    pub fn encoded_len(&self) -> usize {
        HEADER_LEN + AXIS_LEN * self.axis_count
    }
}

/// Why a frame could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum EncodeError {
    /// The axis count is 0 or more than 16.
    #[error("a frame carries 1 to 16 axes, not {0}")]
    AxisCount(usize),
    /// The buffer is smaller than the datagram.
    #[error("the datagram needs {need} bytes but the buffer has {got}")]
    BufferTooSmall {
        /// Datagram length [bytes].
        need: usize,
        /// Buffer length [bytes].
        got: usize,
    },
}

/// Why bytes are not a datagram this crate can read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// Fewer bytes than the fixed header.
    #[error("datagram of {0} bytes is shorter than the 72-byte header")]
    TooShort(usize),
    /// The first four bytes are not `WRCS`.
    #[error("not a wrc simulator datagram (magic is not WRCS)")]
    BadMagic,
    /// A layout version this crate does not know.
    #[error("simulator datagram version {0} is not supported; this reader knows version 1")]
    UnsupportedVersion(u16),
    /// The axis count is 0 or more than 16.
    #[error("axis count {0} is not within 1 to 16")]
    AxisCount(u8),
    /// The length does not match the axis count.
    #[error("datagram of {len} bytes should have {expected} bytes for its axis count")]
    Length {
        /// Bytes received.
        len: usize,
        /// 72 + 16 × axis count.
        expected: usize,
    },
    /// An unknown state number.
    #[error("state {0} is not a known state (0 to {last})", last = State::ALL.len() - 1)]
    State(u8),
    /// The homed byte is neither 0 nor 1.
    #[error("homed byte {0} is neither 0 nor 1")]
    Homed(u8),
    /// A reserved byte is not zero.
    #[error("reserved byte at offset {0} is not zero")]
    Reserved(usize),
}

/// Write `frame` into `buf` and return the datagram's length [bytes]. Allocation-free.
///
/// ```
/// use wrc_protocol::sim_stream::{decode, encode, SimFrame, MAX_DATAGRAM_LEN};
///
/// let mut frame = SimFrame { sequence: 42, axis_count: 4, ..SimFrame::default() };
/// frame.positions[1] = 90.0;
/// frame.pulses[1] = 90_000;
/// let mut buf = [0u8; MAX_DATAGRAM_LEN];
/// let len = encode(&frame, &mut buf).unwrap();
/// assert_eq!(len, 72 + 16 * 4);
/// assert_eq!(decode(&buf[..len]).unwrap(), frame);
/// ```
pub fn encode(frame: &SimFrame, buf: &mut [u8]) -> Result<usize, EncodeError> {
    let n = frame.axis_count;
    if !(1..=MAX_AXES).contains(&n) {
        return Err(EncodeError::AxisCount(n));
    }
    let need = frame.encoded_len();
    let Some(out) = buf.get_mut(..need) else {
        return Err(EncodeError::BufferTooSmall {
            need,
            got: buf.len(),
        });
    };
    out.fill(0);
    out[0..4].copy_from_slice(&MAGIC);
    out[4..6].copy_from_slice(&VERSION.to_le_bytes());
    out[6] = n as u8;
    out[7] = frame.state.to_u8();
    out[8..16].copy_from_slice(&frame.sequence.to_le_bytes());
    out[16..24].copy_from_slice(&frame.timestamp_ns.to_le_bytes());
    out[24] = u8::from(frame.homed);
    out[28..32].copy_from_slice(&frame.inputs.to_le_bytes());
    out[32..36].copy_from_slice(&frame.outputs.to_le_bytes());
    let tcp = [frame.tcp.x, frame.tcp.y, frame.tcp.z, frame.tcp.yaw];
    for (i, v) in tcp.iter().enumerate() {
        out[40 + 8 * i..48 + 8 * i].copy_from_slice(&v.to_le_bytes());
    }
    let (positions, pulses) = out[HEADER_LEN..].split_at_mut(8 * n);
    for (chunk, v) in positions.chunks_exact_mut(8).zip(&frame.positions) {
        chunk.copy_from_slice(&v.to_le_bytes());
    }
    for (chunk, v) in pulses.chunks_exact_mut(8).zip(&frame.pulses) {
        chunk.copy_from_slice(&v.to_le_bytes());
    }
    Ok(need)
}

/// Read a datagram. Checks magic, version, axis count, exact length, state, homed flag
/// and reserved bytes; floating-point values are passed through as sent.
pub fn decode(bytes: &[u8]) -> Result<SimFrame, DecodeError> {
    if bytes.len() < HEADER_LEN {
        return Err(DecodeError::TooShort(bytes.len()));
    }
    if bytes[0..4] != MAGIC {
        return Err(DecodeError::BadMagic);
    }
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    if version != VERSION {
        return Err(DecodeError::UnsupportedVersion(version));
    }
    let n = usize::from(bytes[6]);
    if !(1..=MAX_AXES).contains(&n) {
        return Err(DecodeError::AxisCount(bytes[6]));
    }
    let expected = HEADER_LEN + AXIS_LEN * n;
    if bytes.len() != expected {
        return Err(DecodeError::Length {
            len: bytes.len(),
            expected,
        });
    }
    let state = State::from_u8(bytes[7]).ok_or(DecodeError::State(bytes[7]))?;
    let homed = match bytes[24] {
        0 => false,
        1 => true,
        other => return Err(DecodeError::Homed(other)),
    };
    for offset in (25..28).chain(36..40) {
        if bytes[offset] != 0 {
            return Err(DecodeError::Reserved(offset));
        }
    }
    let u64_at = |o: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[o..o + 8]);
        u64::from_le_bytes(b)
    };
    let u32_at = |o: usize| {
        let mut b = [0u8; 4];
        b.copy_from_slice(&bytes[o..o + 4]);
        u32::from_le_bytes(b)
    };
    let f64_at = |o: usize| f64::from_bits(u64_at(o));
    let mut frame = SimFrame {
        sequence: u64_at(8),
        timestamp_ns: u64_at(16),
        state,
        homed,
        inputs: u32_at(28),
        outputs: u32_at(32),
        tcp: Pose {
            x: f64_at(40),
            y: f64_at(48),
            z: f64_at(56),
            yaw: f64_at(64),
        },
        axis_count: n,
        ..SimFrame::default()
    };
    for i in 0..n {
        frame.positions[i] = f64_at(HEADER_LEN + 8 * i);
        frame.pulses[i] = u64_at(HEADER_LEN + 8 * n + 8 * i) as i64;
    }
    Ok(frame)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sample() -> SimFrame {
        let mut frame = SimFrame {
            sequence: 0x0102_0304_0506_0708,
            timestamp_ns: 1_000_000_007,
            state: State::Moving,
            homed: true,
            inputs: 0xDEAD_BEEF,
            outputs: 0x0000_0005,
            tcp: Pose {
                x: 250.5,
                y: -100.25,
                z: 20.0,
                yaw: 30.0,
            },
            axis_count: 4,
            ..SimFrame::default()
        };
        frame.positions[..4].copy_from_slice(&[10.0, -20.0, 5.5, 12.0]);
        frame.pulses[..4].copy_from_slice(&[10_000, -20_000, 5_500, 12_000]);
        frame
    }

    #[test]
    fn layout_matches_the_offset_table() {
        let frame = sample();
        let mut buf = [0xAAu8; MAX_DATAGRAM_LEN];
        let len = encode(&frame, &mut buf).unwrap();
        assert_eq!(len, 136);
        let b = &buf[..len];
        assert_eq!(&b[0..4], b"WRCS");
        assert_eq!(&b[4..6], &[1, 0]);
        assert_eq!((b[6], b[7]), (4, 1));
        assert_eq!(&b[8..16], &[8, 7, 6, 5, 4, 3, 2, 1]);
        assert_eq!(
            u64::from_le_bytes(b[16..24].try_into().unwrap()),
            1_000_000_007
        );
        assert_eq!(&b[24..28], &[1, 0, 0, 0]);
        assert_eq!(&b[28..32], &[0xEF, 0xBE, 0xAD, 0xDE]);
        assert_eq!(&b[32..40], &[5, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(f64::from_le_bytes(b[40..48].try_into().unwrap()), 250.5);
        assert_eq!(f64::from_le_bytes(b[64..72].try_into().unwrap()), 30.0);
        assert_eq!(f64::from_le_bytes(b[72..80].try_into().unwrap()), 10.0);
        assert_eq!(f64::from_le_bytes(b[96..104].try_into().unwrap()), 12.0);
        assert_eq!(i64::from_le_bytes(b[104..112].try_into().unwrap()), 10_000);
        assert_eq!(i64::from_le_bytes(b[112..120].try_into().unwrap()), -20_000);
        assert_eq!(decode(b).unwrap(), frame);
    }

    #[test]
    fn encode_checks_axis_count_and_buffer() {
        let mut frame = sample();
        let mut small = [0u8; 100];
        assert_eq!(
            encode(&frame, &mut small),
            Err(EncodeError::BufferTooSmall {
                need: 136,
                got: 100
            })
        );
        frame.axis_count = 0;
        assert_eq!(
            encode(&frame, &mut [0; 512]),
            Err(EncodeError::AxisCount(0))
        );
        frame.axis_count = 17;
        assert_eq!(
            encode(&frame, &mut [0; 512]),
            Err(EncodeError::AxisCount(17))
        );
    }

    #[test]
    fn decode_refuses_what_it_does_not_know() {
        let mut buf = [0u8; MAX_DATAGRAM_LEN];
        let len = encode(&sample(), &mut buf).unwrap();
        let good = &buf[..len];
        let with = |offset: usize, byte: u8| {
            let mut b = good.to_vec();
            b[offset] = byte;
            decode(&b)
        };
        assert_eq!(decode(&good[..71]), Err(DecodeError::TooShort(71)));
        assert_eq!(
            decode(&good[..len - 1]),
            Err(DecodeError::Length {
                len: 135,
                expected: 136
            })
        );
        assert_eq!(with(0, b'X'), Err(DecodeError::BadMagic));
        assert_eq!(with(4, 2), Err(DecodeError::UnsupportedVersion(2)));
        assert_eq!(with(6, 0), Err(DecodeError::AxisCount(0)));
        assert_eq!(with(6, 17), Err(DecodeError::AxisCount(17)));
        assert_eq!(
            with(6, 3),
            Err(DecodeError::Length {
                len: 136,
                expected: 120
            })
        );
        assert_eq!(with(7, 6), Err(DecodeError::State(6)));
        // The message names the highest state number there is.
        assert_eq!(
            DecodeError::State(6).to_string(),
            "state 6 is not a known state (0 to 5)"
        );
        assert_eq!(with(7, 5).map(|f| f.state), Ok(State::Held));
        assert_eq!(with(24, 2), Err(DecodeError::Homed(2)));
        assert_eq!(with(26, 1), Err(DecodeError::Reserved(26)));
        assert_eq!(with(39, 1), Err(DecodeError::Reserved(39)));
    }

    fn frames() -> impl Strategy<Value = SimFrame> {
        (
            any::<(u64, u64, bool, u32, u32)>(),
            0u8..5,
            1usize..=MAX_AXES,
            proptest::array::uniform4(any::<f64>()),
            proptest::array::uniform16(any::<f64>()),
            proptest::array::uniform16(any::<i64>()),
        )
            .prop_map(
                |(
                    (sequence, timestamp_ns, homed, inputs, outputs),
                    state,
                    n,
                    tcp,
                    mut positions,
                    mut pulses,
                )| {
                    positions[n..].fill(0.0);
                    pulses[n..].fill(0);
                    SimFrame {
                        sequence,
                        timestamp_ns,
                        state: State::from_u8(state).unwrap(),
                        homed,
                        inputs,
                        outputs,
                        tcp: Pose {
                            x: tcp[0],
                            y: tcp[1],
                            z: tcp[2],
                            yaw: tcp[3],
                        },
                        axis_count: n,
                        positions,
                        pulses,
                    }
                },
            )
    }

    /// Bitwise equality, so that NaN payloads count as round-tripped.
    fn same(a: &SimFrame, b: &SimFrame) -> bool {
        let bits = |f: &SimFrame| {
            let mut v = vec![
                f.tcp.x.to_bits(),
                f.tcp.y.to_bits(),
                f.tcp.z.to_bits(),
                f.tcp.yaw.to_bits(),
            ];
            v.extend(f.positions.iter().map(|p| p.to_bits()));
            v
        };
        bits(a) == bits(b)
            && (
                a.sequence,
                a.timestamp_ns,
                a.state,
                a.homed,
                a.inputs,
                a.outputs,
                a.axis_count,
                a.pulses,
            ) == (
                b.sequence,
                b.timestamp_ns,
                b.state,
                b.homed,
                b.inputs,
                b.outputs,
                b.axis_count,
                b.pulses,
            )
    }

    proptest! {
        #[test]
        fn encode_then_decode_round_trips(frame in frames()) {
            let mut buf = [0u8; MAX_DATAGRAM_LEN + 8];
            let len = encode(&frame, &mut buf).unwrap();
            prop_assert_eq!(len, frame.encoded_len());
            let back = decode(&buf[..len]).unwrap();
            prop_assert!(same(&frame, &back), "{:?} != {:?}", frame, back);
        }

        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = decode(&bytes);
        }

        #[test]
        fn damaged_datagrams_never_panic(frame in frames(), offset in 0usize..MAX_DATAGRAM_LEN, byte in any::<u8>(), cut in 0usize..MAX_DATAGRAM_LEN) {
            let mut buf = [0u8; MAX_DATAGRAM_LEN];
            let len = encode(&frame, &mut buf).unwrap();
            buf[offset % len] = byte;
            if let Ok(back) = decode(&buf[..len.min(cut.max(1))]) {
                prop_assert!(back.axis_count >= 1 && back.axis_count <= MAX_AXES);
            }
        }
    }
}
