//! `wrc bench ui`: does the GUI disturb control? The Pulse Generator's wake-up latency is
//! measured in three windows of one controller run, with the robot moving all along: no GUI;
//! `wrc ui` (its own process) serving several browser-like WebSocket clients (simulator
//! stream, status stream, TASKS polled every second); and after `kill -9` of `wrc ui`. While
//! the GUI is open, each browser also measures the GUI's update latency: `STATUS` sent every
//! 200 ms through `wrc ui` to the controller, until its `ACK` is back in the browser.

use std::net::{SocketAddr, TcpListener, TcpStream, UdpSocket};
use std::path::PathBuf;
use std::process::{Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::Args;
use tungstenite::Message;
use wrc_config::Config;
use wrc_controller::controller::{self, Options, Running};
use wrc_rt::{Histogram, RealtimeMode};

use crate::bench_controller::Host;

/// Arguments of `wrc bench ui`.
#[derive(Debug, Args)]
pub struct UiBenchArgs {
    /// Length of each window [s].
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=3600))]
    seconds: u64,
    /// Browser-like WebSocket clients attached to `wrc ui`.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    browsers: u32,
    /// Write the figures as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Do not ask for SCHED_FIFO.
    #[arg(long)]
    no_rt: bool,
}

/// The Pulse Generator's latency histogram and overrun count so far.
fn pg_snapshot(running: &Running) -> (Histogram, u64) {
    running
        .task_stats()
        .into_iter()
        .find(|t| t.spec.name == "pulse_generator")
        .map(|t| (t.stats.latency, t.stats.overruns))
        .unwrap_or_default()
}

#[derive(Debug, Clone, Copy, Default)]
struct Window {
    cycles: u64,
    p50_us: f64,
    p99_us: f64,
    max_us: f64,
    overruns: u64,
}

/// Latency figures of the cycles between two snapshots (to within the histogram's 6.25 %
/// bucket width).
fn window(before: &(Histogram, u64), after: &(Histogram, u64)) -> Window {
    let h = after.0.since(&before.0);
    let us = |ns: Option<u64>| ns.unwrap_or(0) as f64 / 1000.0;
    Window {
        cycles: h.count(),
        p50_us: us(h.quantile_ns(0.5)),
        p99_us: us(h.quantile_ns(0.99)),
        max_us: us(h.max_ns()),
        overruns: after.1 - before.1,
    }
}

fn free_tcp_port() -> anyhow::Result<u16> {
    Ok(TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

fn free_udp_addr() -> anyhow::Result<SocketAddr> {
    Ok(UdpSocket::bind("127.0.0.1:0")?.local_addr()?)
}

/// Round trips browser → `wrc ui` → controller → `wrc ui` → browser [ms].
type RoundTrips = Arc<std::sync::Mutex<Vec<f64>>>;

/// One browser-like client: reads every frame, subscribes, polls TASKS each second, and
/// times a `STATUS` every 200 ms.
fn browser(
    port: u16,
    stop: Arc<AtomicBool>,
    frames: Arc<AtomicU64>,
    trips: RoundTrips,
) -> anyhow::Result<()> {
    let deadline = Instant::now() + Duration::from_secs(10);
    let stream = loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) => break s,
            Err(e) if Instant::now() > deadline => bail!("wrc ui did not open its port: {e}"),
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    };
    stream.set_read_timeout(Some(Duration::from_millis(200)))?;
    let (mut ws, _) = tungstenite::client(format!("ws://127.0.0.1:{port}/ws").as_str(), stream)
        .context("WebSocket handshake")?;
    ws.send(Message::Text("SUBSCRIBE".into()))?;
    let mut last_poll = Instant::now();
    let mut last_status = Instant::now();
    let mut waiting: Option<(u32, Instant)> = None;
    let mut next_id = 1u32;
    while !stop.load(Ordering::Acquire) {
        if last_poll.elapsed() >= Duration::from_secs(1) {
            last_poll = Instant::now();
            ws.send(Message::Text("TASKS".into()))?;
        }
        if waiting.is_none() && last_status.elapsed() >= Duration::from_millis(200) {
            last_status = Instant::now();
            ws.send(Message::Text(format!("{next_id} STATUS").into()))?;
            waiting = Some((next_id, Instant::now()));
            next_id += 1;
        }
        match ws.read() {
            Ok(message) => {
                frames.fetch_add(1, Ordering::Relaxed);
                if let (Message::Text(t), Some((id, sent))) = (&message, waiting) {
                    if t.as_str().starts_with(&format!("ACK {id} ")) {
                        let ms = sent.elapsed().as_secs_f64() * 1000.0;
                        if let Ok(mut v) = trips.lock() {
                            v.push(ms);
                        }
                        waiting = None;
                    }
                }
            }
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            // The GUI was killed: this browser is done.
            Err(_) => return Ok(()),
        }
    }
    Ok(())
}

/// Run `wrc bench ui`.
pub fn run(args: UiBenchArgs) -> anyhow::Result<ExitCode> {
    let config = Config::embedded_default();
    crate::bench_controller::on_simulated_board("ui", |dir| measure(&args, &config, dir))
}

fn measure(args: &UiBenchArgs, config: &Config, dir: &std::path::Path) -> anyhow::Result<ExitCode> {
    let socket = dir.join("wrc.sock");
    let sim_addr = free_udp_addr()?;
    let options = Options {
        tcp: Some("127.0.0.1:0".parse().expect("address")),
        socket: Some(socket.clone()),
        sim_addr,
        serial: None,
        realtime: if args.no_rt {
            RealtimeMode::Off
        } else {
            RealtimeMode::Auto
        },
        boards: vec![dir.join("board0.dpram")],
        board_wait: Duration::from_secs(10),
        programs: dir.join("programs"),
        traces: None,
        cell: None,
    };
    let running = controller::start(config, &options).context("the controller could not start")?;
    let tcp = running.tcp.context("the controller has no TCP port")?;

    // Keep the robot moving through every window, so the Pulse Generator does real work.
    let mut host = Host::connect(tcp)?;
    host.send("HOME")?;
    host.expect(&["INF"])?;
    let stop_motion = Arc::new(AtomicBool::new(false));
    let mover = {
        let stop = stop_motion.clone();
        std::thread::spawn(move || -> anyhow::Result<()> {
            let poses = ["MOVJ 60 60 -90 100", "MOVJ -60 120 30 20"];
            let mut i = 0;
            while !stop.load(Ordering::Acquire) {
                host.send(poses[i % 2])?;
                host.expect(&["INF", "ABS"])?;
                i += 1;
            }
            Ok(())
        })
    };
    std::thread::sleep(Duration::from_secs(1));
    let window_len = Duration::from_secs(args.seconds);

    eprintln!("jitter, no GUI: {} s …", args.seconds);
    let s0 = pg_snapshot(&running);
    std::thread::sleep(window_len);
    let s1 = pg_snapshot(&running);

    let ui_port = free_tcp_port()?;
    let exe = std::env::current_exe().context("cannot find the wrc executable")?;
    let mut ui = Command::new(exe)
        .arg("ui")
        .arg("--controller")
        .arg(&socket)
        .args(["--sim-addr", &sim_addr.to_string()])
        .args(["--ui-port", &ui_port.to_string()])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .spawn()
        .context("cannot start wrc ui")?;
    let stop_browsers = Arc::new(AtomicBool::new(false));
    let frames = Arc::new(AtomicU64::new(0));
    let trips: RoundTrips = Arc::default();
    let browsers: Vec<_> = (0..args.browsers)
        .map(|_| {
            let (stop, frames, trips) = (stop_browsers.clone(), frames.clone(), trips.clone());
            std::thread::spawn(move || browser(ui_port, stop, frames, trips))
        })
        .collect();
    std::thread::sleep(Duration::from_secs(1));
    // Only the window's round trips count (not the connections' start).
    if let Ok(mut v) = trips.lock() {
        v.clear();
    }
    eprintln!(
        "jitter, wrc ui serving {} browsers: {} s …",
        args.browsers, args.seconds
    );
    let f0 = frames.load(Ordering::Relaxed);
    let s2 = pg_snapshot(&running);
    std::thread::sleep(window_len);
    let s3 = pg_snapshot(&running);
    let frames_per_s = (frames.load(Ordering::Relaxed) - f0) as f64
        / args.seconds as f64
        / f64::from(args.browsers);
    let mut round_trips = trips.lock().map(|v| v.clone()).unwrap_or_default();
    round_trips.sort_by(f64::total_cmp);
    let at = |q: f64| {
        if round_trips.is_empty() {
            0.0
        } else {
            round_trips[((round_trips.len() - 1) as f64 * q).round() as usize]
        }
    };
    let (rt_p50, rt_p99, rt_max) = (at(0.5), at(0.99), at(1.0));

    // SAFETY: kill -9 of the child we started.
    unsafe {
        libc::kill(ui.id() as libc::pid_t, libc::SIGKILL);
    }
    let _ = ui.wait();
    stop_browsers.store(true, Ordering::Release);
    for b in browsers {
        match b.join() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => bail!("a browser client failed: {e:#}"),
            Err(_) => bail!("a browser client panicked"),
        }
    }
    eprintln!("jitter, after kill -9 of wrc ui: {} s …", args.seconds);
    let s4 = pg_snapshot(&running);
    std::thread::sleep(window_len);
    let s5 = pg_snapshot(&running);
    stop_motion.store(true, Ordering::Release);
    let state = running.shared().state();
    let _ = running.shutdown(Duration::from_secs(3));
    let _ = mover.join();

    let (none, open, killed) = (window(&s0, &s1), window(&s2, &s3), window(&s4, &s5));
    println!(
        "Pulse Generator wake-up latency [µs], robot moving, {} s windows",
        args.seconds
    );
    println!(
        "{:<28} {:>8} {:>9} {:>9} {:>9} {:>9}",
        "window", "cycles", "p50", "p99", "max", "overruns"
    );
    for (name, w) in [
        ("no GUI", none),
        ("GUI open", open),
        ("after kill -9 of the GUI", killed),
    ] {
        println!(
            "{name:<28} {:>8} {:>9.1} {:>9.1} {:>9.1} {:>9}",
            w.cycles, w.p50_us, w.p99_us, w.max_us, w.overruns
        );
    }
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
    println!(
        "ratios to no GUI: p99 {:.2} open, {:.2} after kill; max {:.2} open, {:.2} after kill",
        ratio(open.p99_us, none.p99_us),
        ratio(killed.p99_us, none.p99_us),
        ratio(open.max_us, none.max_us),
        ratio(killed.max_us, none.max_us)
    );
    println!(
        "each of {} browsers received {frames_per_s:.0} frames/s while the GUI was open; controller state at the end: {state}",
        args.browsers
    );
    println!(
        "GUI update latency (STATUS from a browser through wrc ui to its ACK back, {} round trips) [ms]: p50 {rt_p50:.2}, p99 {rt_p99:.2}, max {rt_max:.2}",
        round_trips.len()
    );
    if let Some(path) = &args.json {
        let w = |w: Window| serde_json::json!({"cycles": w.cycles, "p50_us": w.p50_us, "p99_us": w.p99_us, "max_us": w.max_us, "overruns": w.overruns});
        let json = serde_json::json!({
            "seconds": args.seconds,
            "browsers": args.browsers,
            "frames_per_s_per_browser": frames_per_s,
            "round_trip_ms": {"count": round_trips.len(), "p50": rt_p50, "p99": rt_p99, "max": rt_max},
            "no_gui": w(none),
            "gui_open": w(open),
            "after_kill": w(killed),
        });
        std::fs::write(path, serde_json::to_string_pretty(&json)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if frames_per_s < 1.0 {
        bail!("the browsers received no frames from wrc ui: the GUI was not really open");
    }
    Ok(ExitCode::SUCCESS)
}
