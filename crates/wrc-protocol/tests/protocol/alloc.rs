//! Counting allocator: the real-time path (frame, parse, reply, encode, decode) allocates
//! nothing.

use wrc_alloc_count::{heap_calls, CountingAllocator};
use wrc_protocol::sim_stream::{self, SimFrame, MAX_DATAGRAM_LEN};
use wrc_protocol::{
    Code, Command, Event, HelpBody, IoBody, LineReader, Parser, Pose, ReplyBuf, State, StatusBody,
    WhereBody,
};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Requests covering every verb, every error kind, checksums and garbage.
const STREAM: &[u8] = b"1 STATUS\r\n2 where\n3 HOME\n4 MOVJ 10 -20.5 3 4e1\n\
5 MOVP 250 100 20 30 L\n6 MOVL 250 100 20 30\n7 JOG j2 -1500\n8 JOG 2 10\n9 SPEED 50\n\
10 STOP\n11 ESTOP\n12 RESET\n13 IO\n14 OUT 3 1\n15 WAIT\n16 CONTROL\n17 RELEASE\n18 HELP\n\
19 SUBSCRIBE\n20 UNSUBSCRIBE\n21 FOO\n22 MOVJ 1 2\n23 MOVL 1e999 0 0 0\n24 SPEED 0\n\
25 JOG 9 1\n26 OUT 40 1\n27 OUT 1 2\n28 MOVP 1 2 3 4 X\n1 STATUS*05\n1 STATUS*49\n\
1 STATUS*4G\n123456789 STATUS\n\0\xFF\xFE garbage\n";

#[test]
fn framing_parsing_replying_and_encoding_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let serial = Parser::new(4).with_checksum(true);
    let tcp = Parser::new(4);
    let mut reader = LineReader::new();
    let mut out = ReplyBuf::new();
    let mut datagram = [0u8; MAX_DATAGRAM_LEN];
    let long = [b'x'; 600];
    let mut frame = SimFrame {
        axis_count: 4,
        ..SimFrame::default()
    };
    let joints = [10.0, -20.5, 3.0, 40.0];
    let mut lines = 0;
    let mut bytes_out = 0;

    let before = heap_calls().allocations;
    for round in 0..3 {
        // Split the stream at a different size each round, and add an over-long line.
        let step = [1, 7, 4096][round];
        for chunk in STREAM.chunks(step).chain([&long[..], b"\n"]) {
            let mut rest = chunk;
            while let Some(line) = reader.read(&mut rest) {
                lines += 1;
                let reply = match line {
                    Err(e) => out.line_error(&e),
                    Ok(line) => {
                        let _ = tcp.parse(line);
                        match serial.parse(line) {
                            Err(refused) => out.rejected(&refused),
                            Ok(request) => {
                                let to = request.reply_to();
                                match request.command {
                                    Command::Status => out.ack(
                                        to,
                                        StatusBody {
                                            state: State::Moving,
                                            homed: true,
                                            speed_pct: 12.5,
                                            owner: Some("serial"),
                                            err: Some(Code::FollowingError),
                                        },
                                    ),
                                    Command::Where => out.ack(
                                        to,
                                        WhereBody {
                                            joints: &joints,
                                            tcp: Pose {
                                                x: 250.0,
                                                y: -0.5,
                                                z: 20.0,
                                                yaw: 30.0,
                                            },
                                        },
                                    ),
                                    Command::Io => out.ack(
                                        to,
                                        IoBody {
                                            inputs: 5,
                                            outputs: 8,
                                        },
                                    ),
                                    Command::Help => out.ack(to, HelpBody),
                                    Command::Speed(pct) => out.ack(to, format_args!("speed={pct}")),
                                    Command::Stop => {
                                        out.abs(to, Code::Stopped, Code::Stopped.text())
                                    }
                                    _ => out.inf(to, ""),
                                }
                            }
                        }
                    }
                };
                bytes_out += reply.len();
            }
        }
        bytes_out += out.event(true, &Event::State(State::Idle)).len();
        bytes_out += out
            .event(
                false,
                &Event::Error {
                    code: Code::ServoAlarm,
                    text: "servo alarm on axis j1",
                },
            )
            .len();

        frame.sequence += 1;
        frame.positions[..4].copy_from_slice(&joints);
        let len = sim_stream::encode(&frame, &mut datagram).unwrap();
        let back = sim_stream::decode(&datagram[..len]).unwrap();
        assert_eq!(back.sequence, frame.sequence);
    }
    let allocated = heap_calls().allocations - before;

    assert_eq!(lines, 3 * 34, "every line and the over-long one came out");
    assert!(bytes_out > 3 * 34 * 6);
    assert_eq!(
        allocated, 0,
        "the real-time path allocated {allocated} times"
    );
}
