//! A `wrc up` child process on free loopback ports, in a state directory of the caller's, for
//! the benchmarks that measure the real controller (`wrc bench cell --real-time`,
//! `wrc bench soak`): started, waited for until its host port answers, stopped (SIGTERM,
//! then SIGKILL) when dropped.

use std::ffi::OsStr;
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};

/// How long `wrc up` may take to open its host port.
const START_S: u64 = 30;

/// A running `wrc up`.
pub(crate) struct UpProcess {
    /// The process.
    pub child: Child,
    /// Its host port on 127.0.0.1.
    pub port: u16,
}

impl UpProcess {
    /// `wrc up --no-ui` with its state in `dir` and `extra` arguments, on free loopback
    /// ports; returns once its host port accepts a connection.
    pub(crate) fn start<S: AsRef<OsStr>>(dir: &Path, extra: &[S]) -> anyhow::Result<UpProcess> {
        let port = std::net::TcpListener::bind("127.0.0.1:0")?
            .local_addr()?
            .port();
        let sim = std::net::UdpSocket::bind("127.0.0.1:0")?.local_addr()?;
        let child = Command::new(std::env::current_exe()?)
            .args(["up", "--no-ui"])
            .args(extra)
            .args(["--port", &format!("127.0.0.1:{port}")])
            .args(["--sim-addr", &sim.to_string()])
            .arg("--state-dir")
            .arg(dir)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .context("cannot start wrc up")?;
        // From here on a failure stops the controller (on drop) before it is reported.
        let mut up = UpProcess { child, port };
        let began = Instant::now();
        loop {
            match TcpStream::connect(("127.0.0.1", port)) {
                Ok(_) => return Ok(up),
                Err(_) if began.elapsed() < Duration::from_secs(START_S) => {
                    if let Some(status) = up.child.try_wait()? {
                        bail!("wrc up exited ({status}) before it opened its port");
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
                Err(e) => bail!("wrc up did not open its port within {START_S} s: {e}"),
            }
        }
    }

    /// A new connection to its host port: no Nagle delay, reads give up after `timeout`.
    pub(crate) fn connect(&self, timeout: Duration) -> anyhow::Result<TcpStream> {
        let s = TcpStream::connect(("127.0.0.1", self.port))
            .with_context(|| format!("cannot connect to wrc up on port {}", self.port))?;
        s.set_read_timeout(Some(timeout))?;
        s.set_nodelay(true)?;
        Ok(s)
    }

    /// Whether it still runs.
    pub(crate) fn alive(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }
}

impl Drop for UpProcess {
    fn drop(&mut self) {
        crate::up::stop_children(std::slice::from_mut(&mut self.child));
    }
}
