//! The trace recorder's costs (the README's figures): one sample pushed into the ring (what the
//! Pulse Generator pays every period), and saving and loading a trace (what the service
//! thread pays on `TRACE SAVE` or an alarm): the default 30 s window at 10 ms, and a whole
//! 25-wafer session (371 s, as `wrc sim --trace` saves it).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use wrc_trace::{Direction, Message, Meta, Ring, Sample};

const PERIOD_NS: u64 = 10_000_000;

/// A ring holding `seconds` of 4-axis samples at 10 ms and `messages` request/reply lines,
/// with values that change every period (as a moving arm's do).
fn filled(seconds: f64, messages: usize) -> Ring {
    let mut ring = Ring::for_seconds(seconds, PERIOD_NS, messages);
    let periods = (seconds * 1e9 / PERIOD_NS as f64) as u64;
    for k in 0..periods {
        ring.push_sample(&sample(k));
    }
    for k in 0..messages as u64 {
        let line = format!("{k} GET LP1 {}", k % 25 + 1);
        let dir = if k % 2 == 0 {
            Direction::Request
        } else {
            Direction::Reply
        };
        ring.push_message(&Message::new(k * 180_000_000, dir, 0, 1, line.as_bytes()));
    }
    ring
}

fn sample(k: u64) -> Sample {
    let mut s = Sample {
        t_ns: k * PERIOD_NS,
        inputs: 0x4001,
        outputs: 1,
        state: (k % 3) as u8,
        fifo_level: 2,
        latency_ns: 50_000 + (k % 97) as u32,
        exec_ns: 20_000,
        ..Sample::default()
    };
    for a in 0..4 {
        s.commanded[a] = (k as i64) * (a as i64 + 1) * 37;
        s.actual[a] = s.commanded[a] - 3;
    }
    s
}

fn meta() -> Meta {
    let mut m = Meta::new(
        "bench",
        PERIOD_NS,
        &["j1", "j2", "j3", "z"],
        &["IDLE", "MOVING", "HELD", "ERROR", "ESTOP"],
    );
    m.config_toml = "# the configuration text\n".repeat(200);
    m
}

fn recorder(c: &mut Criterion) {
    let mut ring = filled(30.0, 10_000);
    let mut k = 0u64;
    c.bench_function("trace: push one sample into a full 30 s ring", |b| {
        b.iter(|| {
            k += 1;
            ring.push_sample(black_box(&sample(k)));
        })
    });

    let dir = tempfile::tempdir().unwrap();
    for (name, seconds, messages) in [
        ("default 30 s window, 10,000 lines", 30.0, 10_000),
        ("25-wafer session 371 s, 2,000 lines", 371.0, 2_000),
    ] {
        let ring = filled(seconds, messages);
        let path = dir.path().join("bench.wrctrace");
        c.bench_function(&format!("trace: snapshot and save, {name}"), |b| {
            b.iter(|| ring.snapshot(meta(), None).save(&path).unwrap())
        });
        c.bench_function(&format!("trace: load, {name}"), |b| {
            b.iter(|| wrc_trace::TraceFile::load(black_box(&path)).unwrap())
        });
        let size = std::fs::metadata(&path).unwrap().len();
        eprintln!("trace file, {name}: {size} bytes");
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = recorder
}
criterion_main!(benches);
