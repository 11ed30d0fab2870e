//! Fuzz the layout reader: any bytes as a DPRAM image (a foreign file, a corrupt board).
//! The header check must accept or refuse without panicking; an accepted image is mapped
//! and read by the host driver (feedback seqlock, FIFO room, I/O) and by the board side
//! (FIFO pop, mailboxes), which must stay in bounds whatever the indices say.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wrc_board::dpram::{AxisRecord, Dpram};
use wrc_board::layout::{control, fault, Header, LAYOUT_SIZE};
use wrc_board::{DpramBoard, Expect, Fault, Feedback, Mapping, MotionBoard};

fuzz_target!(|input: &[u8]| {
    // First byte odd: a valid header over a body of the fuzzer's bytes (repeated), so the
    // deep readers meet garbage FIFO indices, sequence words and mailboxes. Even: the raw
    // bytes are the whole image (truncated, foreign, bad header fields).
    let image;
    let data: &[u8] = match input.split_first() {
        Some((mode, body)) if mode & 1 == 1 && !body.is_empty() => {
            let mut bytes: Vec<u8> = body.iter().copied().cycle().take(LAYOUT_SIZE).collect();
            Header {
                board_id: u32::from(mode >> 6),
                axis_count: 1 + u32::from((mode >> 1) & 3),
                period_us: 1_000,
                fifo_depth: 1 + u32::from((mode >> 3) & 7),
                epoch: 1,
            }
            .encode(&mut bytes);
            image = bytes;
            &image
        }
        _ => input,
    };
    let parsed = Header::parse(data);
    // Also the live reader: same answer as the byte reader on any image.
    let map = Mapping::anonymous().expect("anonymous mapping");
    let n = data.len().min(LAYOUT_SIZE);
    for (i, chunk) in data[..n].chunks(4).enumerate() {
        let mut w = [0u8; 4];
        w[..chunk.len()].copy_from_slice(chunk);
        map.u32(i * 4)
            .store(u32::from_le_bytes(w), std::sync::atomic::Ordering::Relaxed);
    }
    if data.len() < LAYOUT_SIZE {
        assert!(parsed.is_err());
        return;
    }
    let board_side = map.share();
    let attached = DpramBoard::attach(map, Expect::default());
    assert_eq!(parsed.is_ok(), attached.is_ok());
    let Ok(mut host) = attached else { return };
    let mut feedback = Feedback::default();
    let _ = host.read_feedback(&mut feedback);
    let _ = host.fifo_free();
    let _ = host.push(&[1; 16]);
    let _ = host.read_inputs(0);
    let _ = host.clear_alarms(0xFFFF);
    let board = Dpram::attach(board_side).expect("same header");
    for channel in 0..board.header().axis_count as usize {
        let _ = board.fifo_pop(channel);
        let _ = board.fifo_drain(channel);
        let mut r = AxisRecord::default();
        let _ = board.read_feedback(channel, &mut r);
        board.write_feedback(channel, &r);
    }
    if let Some((code, a0, a1)) = board.pending(fault::SEQ, fault::ACK) {
        let _ = Fault::decode(code, a0, a1);
    }
    let _ = board.pending(control::COMMAND_SEQ, control::COMMAND_ACK);
    let _: Result<Header, _> = parsed;
});
