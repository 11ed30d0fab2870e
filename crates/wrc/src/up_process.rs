//! `wrc up` as a child process, and host connections to it, for the benchmarks that drive
//! the real controller (`wrc bench cell --real-time`, `wrc bench soak`, `wrc bench faults`):
//! `wrc up` on free loopback ports (optionally inside a user and mount namespace with its
//! state directory on a small tmpfs), waited for until it says it is ready and stopped when
//! dropped; connections whose every line is time-stamped as it is read. Every wait has a
//! deadline; nothing here sleeps in the hope that a process got somewhere.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};

/// How long any single wait of the campaign may take before the round gives up on it: long
/// next to what it waits for (a transfer takes about 5 s), short next to the campaign.
pub(crate) const PATIENCE: Duration = Duration::from_secs(30);

/// Pause between two probes of a condition that has no event to wait on (a file, the
/// DPRAM): short next to a board period (10 ms).
pub(crate) const PROBE: Duration = Duration::from_millis(2);

/// Probe until `probe` gives `Some`, or `patience` has passed (`None`).
pub(crate) fn poll<T>(patience: Duration, mut probe: impl FnMut() -> Option<T>) -> Option<T> {
    let deadline = Instant::now() + patience;
    loop {
        if let Some(v) = probe() {
            return Some(v);
        }
        if Instant::now() >= deadline {
            return None;
        }
        std::thread::sleep(PROBE);
    }
}

/// Every line a reader produced, each with the instant it was read, kept for the round.
#[derive(Clone, Default)]
pub(crate) struct Lines {
    inner: Arc<(Mutex<LinesState>, Condvar)>,
}

#[derive(Default)]
struct LinesState {
    lines: Vec<(Instant, String)>,
    closed: bool,
}

impl Lines {
    /// Read `from` line by line on a thread of its own until it ends.
    pub(crate) fn spawn(from: impl Read + Send + 'static) -> Lines {
        let lines = Lines::default();
        let fill = lines.clone();
        std::thread::spawn(move || {
            let mut reader = BufReader::new(from);
            let mut buf = Vec::new();
            loop {
                buf.clear();
                match reader.read_until(b'\n', &mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(_) => {
                        let line = String::from_utf8_lossy(&buf).trim_end().to_string();
                        fill.push(line);
                    }
                }
            }
            fill.close();
        });
        lines
    }

    pub(crate) fn push(&self, line: String) {
        let (m, c) = &*self.inner;
        if let Ok(mut s) = m.lock() {
            s.lines.push((Instant::now(), line));
        }
        c.notify_all();
    }

    pub(crate) fn close(&self) {
        let (m, c) = &*self.inner;
        if let Ok(mut s) = m.lock() {
            s.closed = true;
        }
        c.notify_all();
    }

    /// How many lines have been read so far: a mark to search from.
    pub(crate) fn mark(&self) -> usize {
        self.inner.0.lock().map_or(0, |s| s.lines.len())
    }

    /// Whether the reader has ended (the stream closed).
    pub(crate) fn is_closed(&self) -> bool {
        self.inner.0.lock().map_or(true, |s| s.closed)
    }

    /// The first line from `mark` on that `matches`, with its index and the instant it was
    /// read; waits for it until `patience` has passed or the stream ends.
    pub(crate) fn find(
        &self,
        mark: usize,
        patience: Duration,
        matches: impl Fn(&str) -> bool,
    ) -> Option<(usize, Instant, String)> {
        let deadline = Instant::now() + patience;
        let (m, c) = &*self.inner;
        let mut s = m.lock().ok()?;
        let mut from = mark;
        loop {
            if let Some(i) = (from..s.lines.len()).find(|&i| matches(&s.lines[i].1)) {
                let (at, line) = &s.lines[i];
                return Some((i, *at, line.clone()));
            }
            from = s.lines.len();
            let now = Instant::now();
            if s.closed || now >= deadline {
                return None;
            }
            s = c.wait_timeout(s, deadline - now).ok()?.0;
        }
    }

    /// The lines from `mark` on, for a report.
    pub(crate) fn since(&self, mark: usize) -> Vec<String> {
        self.inner.0.lock().map_or_else(
            |_| Vec::new(),
            |s| {
                s.lines[mark.min(s.lines.len())..]
                    .iter()
                    .map(|(_, l)| l.clone())
                    .collect()
            },
        )
    }
}

/// Whether `line` is the reply of request `id` with one of `words` (`ACK`, `NAK`, `INF`,
/// `ABS`) as its first word.
pub(crate) fn reply_of(line: &str, id: u32, words: &[&str]) -> bool {
    let mut w = line.split_whitespace();
    matches!((w.next(), w.next()), (Some(word), Some(n)) if words.contains(&word) && n.parse::<u32>().ok() == Some(id))
}

/// A host connection: requests with ids, every line received time-stamped in [`Lines`].
pub(crate) struct Conn {
    writer: Box<dyn Write + Send>,
    /// Every line received, events included.
    pub(crate) lines: Lines,
    next_id: u32,
    /// A TCP connection's socket, shut down when the connection is dropped: the reader
    /// thread holds a handle of its own, which would keep the connection open.
    tcp: Option<TcpStream>,
}

impl Conn {
    /// A TCP connection to the controller on loopback `port`.
    pub(crate) fn tcp(port: u16) -> anyhow::Result<Conn> {
        let s = TcpStream::connect(("127.0.0.1", port))
            .with_context(|| format!("cannot connect to the controller on port {port}"))?;
        s.set_nodelay(true)?;
        let reader = s.try_clone()?;
        let shutdown = s.try_clone()?;
        let mut conn = Conn::on(Box::new(s), reader);
        conn.tcp = Some(shutdown);
        Ok(conn)
    }

    /// A connection over any byte stream.
    pub(crate) fn on(writer: Box<dyn Write + Send>, reader: impl Read + Send + 'static) -> Conn {
        Conn {
            writer,
            lines: Lines::spawn(reader),
            next_id: 1,
            tcp: None,
        }
    }

    /// Write raw bytes.
    pub(crate) fn send_raw(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        self.writer.write_all(bytes)?;
        self.writer.flush()?;
        Ok(())
    }

    /// Send `line` with a fresh id; returns the id.
    pub(crate) fn send(&mut self, line: &str) -> anyhow::Result<u32> {
        let id = self.next_id;
        self.next_id += 1;
        self.send_raw(format!("{id} {line}\n").as_bytes())?;
        Ok(id)
    }

    /// Send `line` and wait for its first reply (`ACK` or `NAK`); returns the id and reply.
    pub(crate) fn request(&mut self, line: &str) -> anyhow::Result<(u32, String)> {
        let mark = self.lines.mark();
        let id = self.send(line)?;
        let (_, _, reply) = self
            .lines
            .find(mark, PATIENCE, |l| reply_of(l, id, &["ACK", "NAK"]))
            .with_context(|| format!("no reply to `{line}`"))?;
        Ok((id, reply))
    }

    /// Send `line` and fail unless it is accepted (`ACK`); the reply.
    pub(crate) fn ask(&mut self, line: &str) -> anyhow::Result<String> {
        let (_, reply) = self.request(line)?;
        if !reply.starts_with("ACK") {
            bail!("`{line}` was refused: {reply}");
        }
        Ok(reply)
    }

    /// The final reply (`INF` or `ABS`) of request `id`.
    pub(crate) fn end_of(&self, id: u32, patience: Duration) -> anyhow::Result<String> {
        let (_, _, end) = self
            .lines
            .find(0, patience, |l| reply_of(l, id, &["INF", "ABS"]))
            .with_context(|| format!("request {id} did not end within {patience:?}"))?;
        Ok(end)
    }

    /// Start an action (`ACK` required); its id. A `NAK 138` ("repeat in a moment": the
    /// controller is still reading its inputs or settling the map) is repeated, as a host
    /// does, for at most [`PATIENCE`].
    pub(crate) fn start(&mut self, line: &str) -> anyhow::Result<u32> {
        let deadline = Instant::now() + PATIENCE;
        loop {
            let (id, reply) = self.request(line)?;
            if reply.starts_with("ACK") {
                return Ok(id);
            }
            let busy = reply.split_whitespace().nth(2) == Some("138");
            if !busy || Instant::now() >= deadline {
                bail!("`{line}` was refused: {reply}");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Run an action to its end; its `INF`/`ABS`.
    pub(crate) fn run(&mut self, line: &str) -> anyhow::Result<String> {
        let id = self.start(line)?;
        self.end_of(id, PATIENCE * 2)
    }

    /// Run an action and fail unless it ends with `INF`.
    pub(crate) fn run_ok(&mut self, line: &str) -> anyhow::Result<String> {
        let end = self.run(line)?;
        if !end.starts_with("INF") {
            bail!("`{line}` ended abnormally: {end}");
        }
        Ok(end)
    }

    /// The `ACK` body of `WAFERS` (`hand=… LP1=…`), or `None` when the map came in parts.
    pub(crate) fn wafers(&mut self) -> anyhow::Result<Option<String>> {
        let reply = self.ask("WAFERS")?;
        let body = reply.splitn(3, ' ').nth(2).unwrap_or("").to_string();
        Ok((!body.starts_with("parts=")).then_some(body))
    }

    /// `STATUS`'s `state=` word.
    pub(crate) fn state(&mut self) -> anyhow::Result<String> {
        let reply = self.ask("STATUS")?;
        Ok(wrc_protocol::reply_field(&reply, "state")
            .unwrap_or("?")
            .to_string())
    }

    /// `WHERE`'s joints [deg, mm].
    pub(crate) fn joints(&mut self) -> anyhow::Result<Vec<f64>> {
        let reply = self.ask("WHERE")?;
        let j = wrc_protocol::reply_field(&reply, "j").context("WHERE without j=")?;
        j.split(',')
            .map(|v| {
                v.parse::<f64>()
                    .context("WHERE: a joint that is not a number")
            })
            .collect()
    }

    /// Send `RESET` until it is accepted, for at most `patience` (`NAK 300` while a board
    /// comes back, `NAK 121` while the arm still brakes); the last refusal when it never is.
    pub(crate) fn reset(&mut self, patience: Duration) -> Result<(), String> {
        let deadline = Instant::now() + patience;
        loop {
            let reply = match self.request("RESET") {
                Ok((_, r)) => r,
                Err(e) => return Err(format!("{e:#}")),
            };
            if reply.starts_with("ACK") {
                return Ok(());
            }
            if Instant::now() >= deadline {
                return Err(reply);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// Free loopback TCP port.
pub(crate) fn free_port() -> anyhow::Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

/// Free loopback UDP address (for the simulator stream, which nobody reads here).
pub(crate) fn free_udp() -> anyhow::Result<String> {
    Ok(std::net::UdpSocket::bind("127.0.0.1:0")?
        .local_addr()?
        .to_string())
}

/// The `wrc` executable running the campaign.
pub(crate) fn exe() -> anyhow::Result<PathBuf> {
    std::env::current_exe().context("cannot find the wrc executable")
}

/// A state directory on its own small tmpfs, mounted in a user and mount namespace that only
/// the controller lives in (no privilege needed where unprivileged user namespaces are
/// allowed): the campaign fills it or makes it read-only under the running controller.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tmpfs {
    /// Its size [bytes].
    pub(crate) bytes: u64,
}

/// How to start `wrc up`.
#[derive(Debug, Clone, Default)]
pub(crate) struct UpOptions {
    /// Its state directory.
    pub(crate) state: PathBuf,
    /// A configuration file (default: the embedded one).
    pub(crate) config: Option<PathBuf>,
    /// A board's DPRAM to use instead of starting a simulated board.
    pub(crate) board: Option<PathBuf>,
    /// `--restart-boards`.
    pub(crate) restart_boards: bool,
    /// `--serial DEV`.
    pub(crate) serial: Option<PathBuf>,
    /// `--no-rt`.
    pub(crate) no_rt: bool,
    /// The state directory on a tmpfs of its own (see [`Tmpfs`]).
    pub(crate) tmpfs: Option<Tmpfs>,
}

/// A running `wrc up`, its output time-stamped line by line.
pub(crate) struct Up {
    child: Option<Child>,
    /// Its host protocol port.
    pub(crate) port: u16,
    /// Its local GUI socket.
    pub(crate) socket: PathBuf,
    /// Standard error: the controller's log.
    pub(crate) log: Lines,
    /// Its state directory as this process reaches it (through `/proc/PID/root` when it
    /// lives in a mount namespace of its own).
    pub(crate) state: PathBuf,
    namespaced: bool,
    state_inside: PathBuf,
}

/// Why `wrc up` did not come up.
pub(crate) struct Refused {
    /// Its exit status.
    pub(crate) status: ExitStatus,
    /// What it wrote on standard error.
    pub(crate) stderr: String,
}

impl Up {
    fn command(o: &UpOptions, port: u16, socket: &Path) -> anyhow::Result<Command> {
        let exe = exe()?;
        let mut up: Vec<std::ffi::OsString> = vec![
            "up".into(),
            "--no-ui".into(),
            "--port".into(),
            format!("127.0.0.1:{port}").into(),
            "--sim-addr".into(),
            free_udp()?.into(),
            "--state-dir".into(),
            o.state.clone().into(),
            "--socket".into(),
            socket.into(),
        ];
        if let Some(c) = &o.config {
            up.extend(["--config".into(), c.clone().into()]);
        }
        if let Some(b) = &o.board {
            up.extend(["--board".into(), b.clone().into()]);
        }
        if let Some(s) = &o.serial {
            up.extend(["--serial".into(), s.clone().into()]);
        }
        if o.restart_boards {
            up.push("--restart-boards".into());
        }
        if o.no_rt || o.tmpfs.is_some() {
            up.push("--no-rt".into());
        }
        let cmd = match o.tmpfs {
            None => {
                let mut c = Command::new(exe);
                c.args(up);
                c
            }
            Some(t) => {
                // unshare execs sh, which mounts the tmpfs and execs wrc up: one process id.
                let mut c = Command::new("unshare");
                c.args(["--user", "--map-root-user", "--mount", "sh", "-c"])
                    .arg(format!(
                        "mount -t tmpfs -o size={} tmpfs \"$0\" && exec \"$@\"",
                        t.bytes
                    ))
                    .arg(&o.state)
                    .arg(exe)
                    .args(up);
                c
            }
        };
        Ok(cmd)
    }

    /// Start `wrc up` and wait until it says it is ready; `Err(Refused)` when it exits
    /// first (a refusal at start-up), an error when it neither exits nor gets ready.
    pub(crate) fn start(o: &UpOptions) -> anyhow::Result<Result<Up, Refused>> {
        std::fs::create_dir_all(&o.state)
            .with_context(|| format!("cannot create {}", o.state.display()))?;
        let port = free_port()?;
        // The socket outside the state directory: the directory may be a tmpfs made
        // read-only, or in another mount namespace.
        let socket = o.state.with_file_name(format!("wrc-{port}.sock"));
        let mut cmd = Up::command(o, port, &socket)?;
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .context("cannot start wrc up")?;
        let out = Lines::spawn(child.stdout.take().context("no stdout")?);
        let log = Lines::spawn(child.stderr.take().context("no stderr")?);
        let ready = out.find(0, PATIENCE, |l| l.starts_with("wrc: ready"));
        if ready.is_none() {
            let status = poll(Duration::from_secs(5), || child.try_wait().ok().flatten());
            let Some(status) = status else {
                let _ = child.kill();
                let _ = child.wait();
                bail!(
                    "wrc up neither got ready nor exited within {PATIENCE:?}: {}",
                    log.since(0).join(" / ")
                );
            };
            // Its output to the end.
            log.find(0, Duration::from_secs(2), |_| false);
            return Ok(Err(Refused {
                status,
                stderr: log.since(0).join("\n"),
            }));
        }
        let state = match o.tmpfs {
            Some(_) => PathBuf::from(format!("/proc/{}/root", child.id()))
                .join(o.state.strip_prefix("/").unwrap_or(&o.state)),
            None => o.state.clone(),
        };
        Ok(Ok(Up {
            child: Some(child),
            port,
            socket,
            log,
            state,
            namespaced: o.tmpfs.is_some(),
            state_inside: o.state.clone(),
        }))
    }

    /// Whether it still runs.
    pub(crate) fn alive(&mut self) -> bool {
        self.child
            .as_mut()
            .is_some_and(|c| matches!(c.try_wait(), Ok(None)))
    }

    /// Its process id.
    pub(crate) fn pid(&self) -> u32 {
        self.child.as_ref().map_or(0, Child::id)
    }

    /// A host connection to it.
    pub(crate) fn conn(&self) -> anyhow::Result<Conn> {
        Conn::tcp(self.port)
    }

    /// `kill -9` it; the instant the signal was sent.
    pub(crate) fn kill9(&mut self) -> Instant {
        let t = Instant::now();
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
        t
    }

    /// Run `mount -o remount,bind,ro|rw` on its state directory, inside its namespace.
    pub(crate) fn remount(&self, read_only: bool) -> anyhow::Result<()> {
        if !self.namespaced {
            bail!("the state directory is not a tmpfs of its own");
        }
        let out = Command::new("nsenter")
            .args([
                "-t",
                &self.pid().to_string(),
                "-U",
                "-m",
                "--preserve-credentials",
            ])
            .args(["mount", "-o"])
            .arg(if read_only {
                "remount,bind,ro"
            } else {
                "remount,bind,rw"
            })
            .arg(&self.state_inside)
            .output()
            .context("cannot run nsenter")?;
        if !out.status.success() {
            bail!(
                "nsenter … mount -o remount: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            );
        }
        Ok(())
    }

    /// SIGTERM, and wait for it to exit.
    pub(crate) fn stop(&mut self) {
        if let Some(c) = self.child.as_mut() {
            crate::up::stop_children(std::slice::from_mut(c));
        }
        self.child = None;
    }
}

impl Drop for Conn {
    fn drop(&mut self) {
        if let Some(s) = &self.tcp {
            let _ = s.shutdown(std::net::Shutdown::Both);
        }
    }
}

impl Drop for Up {
    fn drop(&mut self) {
        self.stop();
        let _ = std::fs::remove_file(&self.socket);
    }
}
