//! `wrc trace save` (ask a running controller to save its trace) and `wrc trace replay`
//! (run a recorded session again under virtual time and compare, period by period).
//!
//! A replay rebuilds the controller the trace describes (its configuration text, stations,
//! wafer map, stored programs and the simulated cell's ground truth at the start), sends
//! every recorded request at the virtual instant it was read, with one local client per
//! recorded connection (a host over TCP, the GUI on the local socket; opened and closed when
//! the recording says it was: a lost client has the same effect again), and compares what the replay does with what was recorded: every
//! sample (commanded and encoder pulses, inputs, outputs, state, error code, FIFO level; not
//! the wake-up latency, which measures the host) and every line delivered. It reports the
//! first period and the first line that differ, or that none does.

use std::collections::BTreeMap;
use std::io::{BufRead as _, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{bail, Context};
use wrc_config::Config;
use wrc_controller::simulation::{SimClient, START_NS};
use wrc_trace::{ClockKind, Direction, Sample, TraceFile};

/// Arguments of `wrc trace save`.
#[derive(Debug, clap::Args)]
pub struct SaveArgs {
    /// The file's name in the controller's trace directory (`<NAME>.wrctrace`; default:
    /// from the time).
    name: Option<String>,
    /// Controller address: HOST:PORT for TCP, or the path of the local Unix socket.
    #[arg(long, default_value = "127.0.0.1:7100")]
    addr: String,
}

/// Arguments of `wrc trace replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The trace file.
    file: PathBuf,
    /// Save the replay's own trace here (to plot or compare).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
}

/// Run `wrc trace save`.
pub fn save(args: SaveArgs) -> anyhow::Result<ExitCode> {
    let (mut reader, mut writer) =
        crate::connection::connect(&args.addr, Duration::from_secs(30), None)?;
    let request = match &args.name {
        Some(name) => format!("1 TRACE SAVE {name}\n"),
        None => "1 TRACE SAVE\n".to_string(),
    };
    writer.write_all(request.as_bytes())?;
    writer.flush()?;
    let mut line = String::new();
    loop {
        line.clear();
        if reader
            .read_line(&mut line)
            .context("no reply to TRACE SAVE")?
            == 0
        {
            bail!("the controller closed the connection before it replied");
        }
        let l = line.trim_end();
        if let Some(rest) = l.strip_prefix("ACK 1") {
            println!("{}", rest.trim_start());
            return Ok(ExitCode::SUCCESS);
        }
        if l.starts_with("NAK 1") {
            eprintln!("wrc: {l}");
            return Ok(ExitCode::from(1));
        }
    }
}

/// What a sample is compared on (the wake-up latency and execution time measure the host,
/// not the robot).
fn outputs(s: &Sample, axes: usize) -> (Vec<i64>, Vec<i64>, u32, u32, u8, u16, u16) {
    (
        s.commanded[..axes].to_vec(),
        s.actual[..axes].to_vec(),
        s.inputs,
        s.outputs,
        s.state,
        s.error_code,
        s.fifo_level,
    )
}

/// A replay client for a recorded connection of `source`: a host over TCP (the controller
/// names it `tcp<n>` as it did), anyone else on the local socket (the GUI's way; a recorded
/// pendant is replayed there, named as the GUI).
fn connect(
    sim: &mut wrc_controller::simulation::Simulation,
    source: u8,
) -> anyhow::Result<SimClient> {
    Ok(if source == wrc_trace::SOURCE_HOST {
        sim.connect_tcp()?
    } else {
        sim.connect()?
    })
}

/// Run `wrc trace replay`.
pub fn replay(args: ReplayArgs) -> anyhow::Result<ExitCode> {
    let recorded = TraceFile::load(&args.file)?;
    let meta = &recorded.meta;
    if !meta.from_start {
        bail!(
            "{}: this trace holds the last {:.1} s of a session, not the session from its start \
             (older requests were overwritten); a replay needs every request: save it with \
             `wrc sim --trace`, or raise [trace] seconds and messages",
            args.file.display(),
            recorded.duration_ns() as f64 / 1e9
        );
    }
    let (Some(first), Some(last)) = (recorded.samples.first(), recorded.samples.last()) else {
        bail!(
            "{}: the trace has no samples to compare",
            args.file.display()
        );
    };
    let mut config = Config::parse(&meta.config_toml, "the trace's configuration")
        .context("the trace's configuration")?;
    config.trace.seconds = 3600.0_f64
        .min(recorded.duration_ns() as f64 / 1e9 + 10.0)
        .max(1.0);
    config.trace.messages = config.trace.messages.max(recorded.messages.len() + 1000);
    config.trace.save_on_alarm = false;
    let period_ns = meta.period_ns.max(1);
    // Virtual traces share the replay's clock; a real-time one is aligned on its first
    // Pulse Generator period (its first sample).
    let offset: i128 = match meta.clock {
        ClockKind::Virtual => 0,
        ClockKind::Monotonic => {
            eprintln!(
                "wrc trace replay: a real-time trace: aligned on its first sample, replayed \
                 under virtual time (its timing jitter is not replayed, so periods may differ)"
            );
            i128::from(START_NS + period_ns) - i128::from(first.t_ns)
        }
    };
    let at = |t: u64| (i128::from(t) + offset).max(0) as u64;

    let dir = crate::sim::state_dir(None)?;
    let state = &dir.path;
    std::fs::create_dir_all(state.join("programs"))?;
    for (name, text) in &meta.programs {
        std::fs::write(state.join("programs").join(format!("{name}.wrl")), text)?;
    }
    if let Some(text) = &meta.wafers_toml {
        std::fs::write(state.join("wafers.toml"), text)?;
    }
    let stations = match &meta.stations_toml {
        Some(text) => {
            let p = state.join("stations.toml");
            std::fs::write(&p, text)?;
            Some(p)
        }
        None => None,
    };
    let mut sim = crate::sim::build(
        &config,
        state,
        stations,
        meta.world_toml.as_deref(),
        // Recorded hosts come back as hosts, on a free loopback port.
        Some("127.0.0.1:0".parse().expect("an address")),
        "127.0.0.1:9".parse().expect("an address"),
    )?;
    let start: Vec<i64> = sim.shared().commanded_pulses()[..meta.axis_count()].to_vec();
    if !meta.start_pulses.is_empty() && start != meta.start_pulses {
        eprintln!(
            "wrc trace replay: the recording started at {:?} pulses, the replay's board at {start:?}",
            meta.start_pulses
        );
    }

    // Every recorded input at the instant it came: a connection opened, a request read, a
    // connection closed; one local client per recorded connection (a connection already open
    // when the trace began opens at its first request).
    let mut clients: BTreeMap<(u8, u16), SimClient> = BTreeMap::new();
    let (mut requests, mut connections) = (0usize, 0usize);
    for m in recorded
        .messages
        .iter()
        .filter(|m| m.direction != Direction::Reply)
    {
        // Given just before the cycles of its instant: the Ethernet task reads it at `t` in
        // its priority turn, as it did in the recording.
        sim.run_before_ns(at(m.t_ns));
        let key = (m.source, m.client);
        match m.direction {
            Direction::Opened => {
                clients.insert(key, connect(&mut sim, m.source)?);
                connections += 1;
            }
            Direction::Closed => {
                if clients.remove(&key).is_some() {
                    // Dropped: the controller reads the end of the stream now.
                    sim.notify_network();
                }
            }
            Direction::Request | Direction::Reply => {
                let client = match clients.entry(key) {
                    std::collections::btree_map::Entry::Occupied(e) => e.into_mut(),
                    std::collections::btree_map::Entry::Vacant(e) => {
                        connections += 1;
                        e.insert(connect(&mut sim, m.source)?)
                    }
                };
                let mut line = m.line().to_vec();
                line.push(b'\n');
                sim.send(client, &String::from_utf8_lossy(&line))?;
                requests += 1;
            }
        }
    }
    sim.run_until_ns(at(last.t_ns));
    let replayed = sim
        .trace("wrc trace replay")
        .context("the replay keeps no trace")?;
    if let Some(out) = &args.out {
        replayed.save(out)?;
    }

    // Samples, period by period, on the recording's window.
    let axes = meta.axis_count();
    let by_time: BTreeMap<u64, &Sample> = replayed.samples.iter().map(|s| (s.t_ns, s)).collect();
    let mut compared = 0usize;
    for rec in &recorded.samples {
        let t = at(rec.t_ns);
        let t_s = (t.saturating_sub(START_NS)) as f64 / 1e9;
        match by_time.get(&t) {
            None => {
                println!("first difference at t = {t_s:.3} s: the replay has no period there");
                return Ok(ExitCode::from(1));
            }
            Some(rep) if outputs(rep, axes) != outputs(rec, axes) => {
                println!(
                    "first difference at t = {t_s:.3} s (period {compared} of the trace):\n  \
                     recorded: {}\n  replayed: {}",
                    describe(rec, axes, meta),
                    describe(rep, axes, meta)
                );
                return Ok(ExitCode::from(1));
            }
            Some(_) => compared += 1,
        }
    }
    // Lines delivered, in order, within the recording's window.
    // Lines before the instant the trace was saved: the reply to the request that saved it
    // (and whatever came after it at that instant) is not in the recording.
    let end = at(last.t_ns);
    let saved = match meta.saved_at_ns {
        0 => u64::MAX,
        t => at(t),
    };
    let replies = |t: &TraceFile, shift: i128| -> Vec<(u64, String)> {
        t.messages
            .iter()
            .filter(|m| m.direction == Direction::Reply)
            .map(|m| {
                (
                    (i128::from(m.t_ns) + shift).max(0) as u64,
                    m.text().into_owned(),
                )
            })
            .filter(|(t, _)| *t <= end && *t < saved)
            .collect()
    };
    let (rec_lines, rep_lines) = (replies(&recorded, offset), replies(&replayed, 0));
    for (i, pair) in rec_lines.iter().zip(&rep_lines).enumerate() {
        if pair.0 != pair.1 {
            println!(
                "first difference in the lines delivered, line {}:\n  recorded: {:.3} s {}\n  replayed: {:.3} s {}",
                i + 1,
                pair.0 .0.saturating_sub(START_NS) as f64 / 1e9,
                pair.0 .1,
                pair.1 .0.saturating_sub(START_NS) as f64 / 1e9,
                pair.1 .1
            );
            return Ok(ExitCode::from(1));
        }
    }
    if rec_lines.len() != rep_lines.len() {
        println!(
            "the lines delivered differ in number: {} recorded, {} replayed",
            rec_lines.len(),
            rep_lines.len()
        );
        return Ok(ExitCode::from(1));
    }
    println!(
        "replay identical: {compared} periods and {} lines delivered, {} requests from {} connection(s), {:.3} s of virtual time",
        rec_lines.len(),
        requests,
        connections,
        sim.virtual_s()
    );
    Ok(ExitCode::SUCCESS)
}

fn describe(s: &Sample, axes: usize, meta: &wrc_trace::Meta) -> String {
    format!(
        "commanded {:?} actual {:?} in {:08x} out {:08x} {} err {} fifo {}",
        &s.commanded[..axes],
        &s.actual[..axes],
        s.inputs,
        s.outputs,
        meta.state_name(s.state),
        s.error_code,
        s.fifo_level
    )
}
