//! `wrc bench controller`: the controller's own figures of merit, measured on this machine
//! with a simulated board — command-to-first-pulse latency, ESTOP-to-deceleration latency
//! (from the line being read and from it being sent), and the Pulse Generator's wake-up
//! jitter with no clients and while many TCP clients poll STATUS.

use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::Args;
use wrc_config::Config;
use wrc_controller::controller::{self, Options, Running};
use wrc_controller::shared::Shared;
use wrc_rt::RealtimeMode;

/// Arguments of `wrc bench controller`.
#[derive(Debug, Args)]
pub struct ControllerArgs {
    /// Latency runs (one move and one ESTOP each).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=1000))]
    runs: u32,
    /// Length of each jitter window [s].
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=3600))]
    seconds: u64,
    /// TCP clients polling STATUS in the loaded jitter window.
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=250))]
    clients: u32,
    /// Write the figures as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Do not ask for SCHED_FIFO.
    #[arg(long)]
    no_rt: bool,
}

pub(crate) struct Host {
    reader: BufReader<TcpStream>,
    writer: TcpStream,
}

impl Host {
    pub(crate) fn connect(addr: SocketAddr) -> anyhow::Result<Host> {
        let s = TcpStream::connect(addr)?;
        s.set_read_timeout(Some(Duration::from_secs(30)))?;
        s.set_nodelay(true)?;
        Ok(Host {
            reader: BufReader::new(s.try_clone()?),
            writer: s,
        })
    }
    pub(crate) fn send(&mut self, line: &str) -> anyhow::Result<()> {
        self.writer.write_all(format!("{line}\n").as_bytes())?;
        Ok(())
    }
    /// Read until a non-event line starting with one of `kinds`.
    pub(crate) fn expect(&mut self, kinds: &[&str]) -> anyhow::Result<String> {
        loop {
            let mut l = String::new();
            if self.reader.read_line(&mut l)? == 0 {
                bail!("the controller closed the connection");
            }
            let l = l.trim_end().to_string();
            if kinds.iter().any(|k| l.starts_with(k)) {
                return Ok(l);
            }
            if l.starts_with("NAK") {
                bail!("unexpected reply: {l}");
            }
        }
    }
}

fn start_controller(
    config: &Config,
    dpram: &std::path::Path,
    realtime: RealtimeMode,
) -> anyhow::Result<Running> {
    let options = Options {
        tcp: Some("127.0.0.1:0".parse().expect("address")),
        socket: None,
        sim_addr: "127.0.0.1:9".parse().expect("address"),
        serial: None,
        realtime,
        boards: vec![dpram.to_path_buf()],
        board_wait: Duration::from_secs(10),
        programs: dpram.with_file_name("programs"),
        cell: None,
    };
    controller::start(config, &options).context("the controller could not start")
}

#[derive(Default, Clone, Copy)]
struct Figures {
    min: f64,
    p50: f64,
    max: f64,
}

fn figures(mut v: Vec<f64>) -> Figures {
    if v.is_empty() {
        return Figures::default();
    }
    v.sort_by(f64::total_cmp);
    Figures {
        min: v[0],
        p50: v[v.len() / 2],
        max: v[v.len() - 1],
    }
}

fn wait_for(atomic: &AtomicU64, after: u64, timeout: Duration) -> Option<u64> {
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        let v = atomic.load(Ordering::Acquire);
        if v > after {
            return Some(v);
        }
        std::thread::sleep(Duration::from_micros(200));
    }
    None
}

/// Pulse Generator wake-up latency p99 and max [µs] of a running controller.
fn pg_latency(running: &Running) -> (f64, f64) {
    let stats = running.task_stats();
    let pg = stats.iter().find(|t| t.spec.name == "pulse_generator");
    match pg {
        Some(t) => (
            t.stats.latency.quantile_ns(0.99).unwrap_or(0) as f64 / 1000.0,
            t.stats.latency.max_ns().unwrap_or(0) as f64 / 1000.0,
        ),
        None => (0.0, 0.0),
    }
}

/// Run `measure` with a simulated board (`wrc board-sim`) on `DIR/board0.dpram` in a fresh
/// temporary directory `wrc-bench-<name>-<pid>`; the board and the directory are removed
/// afterwards, whatever `measure` returns.
pub(crate) fn on_simulated_board<T>(
    name: &str,
    measure: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    let dir = std::env::temp_dir().join(format!("wrc-bench-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut children = vec![crate::up::spawn_board(
        None,
        0,
        &dir.join("board0.dpram"),
        &dir.join("board0.log"),
        None,
        None,
    )?];
    let result = measure(&dir);
    crate::up::stop_children(&mut children);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// Run `wrc bench controller`.
pub fn run(args: ControllerArgs) -> anyhow::Result<ExitCode> {
    let config = Config::embedded_default();
    let realtime = if args.no_rt {
        RealtimeMode::Off
    } else {
        RealtimeMode::Auto
    };
    on_simulated_board("controller", |dir| {
        measure(&args, &config, &dir.join("board0.dpram"), realtime)
    })
}

fn measure(
    args: &ControllerArgs,
    config: &Config,
    dpram: &std::path::Path,
    realtime: RealtimeMode,
) -> anyhow::Result<ExitCode> {
    let period_ms = config
        .tasks
        .get("pulse_generator")
        .map_or(10.0, |t| t.period_us as f64 / 1000.0);

    // 1. Idle jitter, then the latency runs, on one controller.
    let running = start_controller(config, dpram, realtime)?;
    if let Some(s) = running.scheduling() {
        println!("wrc bench controller: {s}");
    }
    let addr = running.tcp.context("no TCP port")?;
    eprintln!("jitter, no clients: {} s …", args.seconds);
    std::thread::sleep(Duration::from_secs(args.seconds));
    let idle = pg_latency(&running);

    let shared: Arc<Shared> = running.shared().clone();
    let mut host = Host::connect(addr)?;
    host.send("RESET")?;
    host.expect(&["ACK"])?;
    host.send("1 HOME")?;
    host.expect(&["INF 1", "ABS 1"])?;
    let (mut to_pulse, mut estop_read, mut estop_sent, mut estop_periods) =
        (vec![], vec![], vec![], vec![]);
    eprintln!("latency: {} runs …", args.runs);
    for run in 0..args.runs {
        let target = if run % 2 == 0 {
            "MOVJ 120 40 -60 150"
        } else {
            "MOVJ -120 120 60 20"
        };
        let t0 = Shared::now_ns();
        host.send(&format!("{} {target}", 10 + run))?;
        host.expect(&["ACK"])?;
        let first = wait_for(&shared.first_pulse_ns, t0, Duration::from_secs(5))
            .context("no pulse within 5 s")?;
        to_pulse.push((first - t0) as f64 / 1000.0);
        std::thread::sleep(Duration::from_millis(250 + (run as u64 * 37) % 200));
        let t1 = Shared::now_ns();
        host.send("ESTOP")?;
        let decel = wait_for(&shared.decel_ns, t1, Duration::from_secs(5))
            .context("no deceleration within 5 s")?;
        let read = shared.urgent_read_ns.load(Ordering::Acquire).max(t1);
        estop_read.push((decel.saturating_sub(read)) as f64 / 1000.0);
        estop_sent.push((decel - t1) as f64 / 1000.0);
        estop_periods.push(decel.saturating_sub(read) as f64 / 1e6 / period_ms);
        host.expect(&["ABS"])?; // skips the ESTOP's own ACK, which comes first
        std::thread::sleep(Duration::from_millis(400));
        host.send("RESET")?;
        host.expect(&["ACK"])?;
    }
    drop(host);
    let _ = running.shutdown(Duration::from_secs(3));

    // 2. Jitter while many clients poll STATUS, on a fresh controller.
    let running = start_controller(config, dpram, realtime)?;
    let addr = running.tcp.context("no TCP port")?;
    let stop = Arc::new(AtomicBool::new(false));
    let polls = Arc::new(AtomicU64::new(0));
    let mut threads = Vec::new();
    for _ in 0..args.clients {
        let (stop, polls) = (stop.clone(), polls.clone());
        threads.push(std::thread::spawn(move || -> anyhow::Result<()> {
            let mut h = Host::connect(addr)?;
            while !stop.load(Ordering::Acquire) {
                h.send("STATUS")?;
                h.expect(&["ACK"])?;
                polls.fetch_add(1, Ordering::Relaxed);
            }
            Ok(())
        }));
    }
    eprintln!(
        "jitter, {} clients polling STATUS: {} s …",
        args.clients, args.seconds
    );
    std::thread::sleep(Duration::from_secs(args.seconds));
    let loaded = pg_latency(&running);
    stop.store(true, Ordering::Release);
    let mut failed = 0;
    let mut first_error = None;
    for t in threads {
        match t.join() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => {
                failed += 1;
                first_error.get_or_insert(e.to_string());
            }
            Err(_) => failed += 1,
        }
    }
    let _ = running.shutdown(Duration::from_secs(3));

    let c = figures(to_pulse);
    let r = figures(estop_read);
    let s = figures(estop_sent);
    let p = figures(estop_periods);
    println!();
    println!(
        "latency [ms]                          min      p50      max   (runs: {})",
        args.runs
    );
    println!(
        "command sent → first pulse        {:8.1} {:8.1} {:8.1}",
        c.min / 1e3,
        c.p50 / 1e3,
        c.max / 1e3
    );
    println!(
        "ESTOP sent → deceleration         {:8.1} {:8.1} {:8.1}",
        s.min / 1e3,
        s.p50 / 1e3,
        s.max / 1e3
    );
    println!(
        "ESTOP read → deceleration         {:8.2} {:8.2} {:8.2}",
        r.min / 1e3,
        r.p50 / 1e3,
        r.max / 1e3
    );
    println!(
        "  in Pulse Generator periods      {:8.2} {:8.2} {:8.2}   (target: within 2)",
        p.min, p.p50, p.max
    );
    println!();
    println!("Pulse Generator wake-up latency [µs]     p99      max");
    println!(
        "no clients                          {:8.1} {:8.1}",
        idle.0, idle.1
    );
    println!(
        "{:3} clients polling STATUS         {:8.1} {:8.1}   ({} polls, {} clients failed)",
        args.clients,
        loaded.0,
        loaded.1,
        polls.load(Ordering::Relaxed),
        failed
    );
    if let Some(path) = &args.json {
        let json = format!(
            "{{\"command_to_first_pulse_us\":{{\"min\":{:.1},\"p50\":{:.1},\"max\":{:.1}}},\
             \"estop_sent_to_decel_us\":{{\"min\":{:.1},\"p50\":{:.1},\"max\":{:.1}}},\
             \"estop_read_to_decel_us\":{{\"min\":{:.1},\"p50\":{:.1},\"max\":{:.1}}},\
             \"estop_read_to_decel_periods\":{{\"min\":{:.3},\"p50\":{:.3},\"max\":{:.3}}},\
             \"pg_latency_idle_us\":{{\"p99\":{:.1},\"max\":{:.1}}},\
             \"pg_latency_clients_us\":{{\"clients\":{},\"p99\":{:.1},\"max\":{:.1}}}}}\n",
            c.min,
            c.p50,
            c.max,
            s.min,
            s.p50,
            s.max,
            r.min,
            r.p50,
            r.max,
            p.min,
            p.p50,
            p.max,
            idle.0,
            idle.1,
            args.clients,
            loaded.0,
            loaded.1
        );
        std::fs::write(path, json).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if failed > 0 {
        bail!(
            "{failed} polling clients failed (first: {})",
            first_error.unwrap_or_else(|| "a panic".into())
        );
    }
    Ok(ExitCode::SUCCESS)
}
