//! One browser WebSocket: its own connection to the controller (so each browser tab is its
//! own command source with its own control lock), request lines in, controller lines and
//! simulator datagrams out. The controller connection is retried every second while it is
//! down, and the browser is told (`EVT UI CONNECTED` / `EVT UI DISCONNECTED`).

use std::io::{self, BufRead, BufReader, Write};
use std::net::TcpStream;
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::Arc;
use std::time::{Duration, Instant};

use tungstenite::protocol::{Role, WebSocketConfig};
use tungstenite::{Bytes, Message, WebSocket};

use crate::Hub;

/// How often a WebSocket is polled for requests while output is drained [ms].
const POLL_MS: u64 = 5;
/// A browser that has not taken its output for this long is disconnected.
const WRITE_TIMEOUT: Duration = Duration::from_secs(3);
/// Output a browser may have pending before it is disconnected [bytes] (docs/gui.md).
pub const MAX_BACKLOG: usize = 1 << 20;
/// Pause between attempts to reach the controller.
const RETRY: Duration = Duration::from_secs(1);

/// Where the controller listens.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// Its local Unix socket (`STATE_DIR/wrc.sock`).
    Unix(PathBuf),
    /// Its host-protocol TCP address, `HOST:PORT`.
    Tcp(String),
}

/// The controller's address given to `wrc ui` is neither a socket path nor `HOST:PORT`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the controller address {0:?} is neither the path of its Unix socket (with a `/`) nor \
     HOST:PORT with a port 1..65535 (e.g. 192.168.1.10:7100)"
)]
pub struct EndpointError(pub String);

impl Endpoint {
    /// `HOST:PORT` is TCP (the host is resolved when connecting); anything with a `/` is the
    /// path of a Unix socket.
    pub fn parse(text: &str) -> Result<Endpoint, EndpointError> {
        if text.contains('/') {
            return Ok(Endpoint::Unix(PathBuf::from(text)));
        }
        let bad = || EndpointError(text.to_string());
        let (host, port) = text.rsplit_once(':').ok_or_else(bad)?;
        match port.parse::<u16>() {
            Ok(p) if p != 0 && !host.is_empty() => Ok(Endpoint::Tcp(text.to_string())),
            _ => Err(bad()),
        }
    }

    fn connect(&self) -> io::Result<Link> {
        match self {
            Endpoint::Unix(path) => UnixStream::connect(path).map(Link::Unix),
            Endpoint::Tcp(addr) => {
                let s = TcpStream::connect(addr)?;
                s.set_nodelay(true)?;
                Ok(Link::Tcp(s))
            }
        }
    }
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Endpoint::Unix(p) => write!(f, "unix:{}", p.display()),
            Endpoint::Tcp(a) => write!(f, "tcp:{a}"),
        }
    }
}

enum Link {
    Unix(UnixStream),
    Tcp(TcpStream),
}

impl Link {
    fn reader(&self) -> io::Result<Box<dyn io::Read + Send>> {
        Ok(match self {
            Link::Unix(s) => Box::new(s.try_clone()?),
            Link::Tcp(s) => Box::new(s.try_clone()?),
        })
    }

    fn write_line(&mut self, line: &str) -> io::Result<()> {
        let mut bytes = Vec::with_capacity(line.len() + 1);
        bytes.extend_from_slice(line.as_bytes());
        bytes.push(b'\n');
        match self {
            Link::Unix(s) => s.write_all(&bytes),
            Link::Tcp(s) => s.write_all(&bytes),
        }
    }

    fn shutdown(&self) {
        let _ = match self {
            Link::Unix(s) => s.shutdown(std::net::Shutdown::Both),
            Link::Tcp(s) => s.shutdown(std::net::Shutdown::Both),
        };
    }
}

/// What the controller's reader thread hands the session.
enum FromController {
    Line(String),
    Lost(String),
}

fn spawn_reader(link: &Link, to: Sender<FromController>) -> io::Result<()> {
    let read = link.reader()?;
    std::thread::Builder::new()
        .name("wrc-ui-ctl".into())
        .spawn(move || {
            let mut reader = BufReader::new(read);
            let mut line = String::new();
            loop {
                line.clear();
                match reader.read_line(&mut line) {
                    Ok(0) => {
                        let _ = to.send(FromController::Lost(
                            "the controller closed the connection".into(),
                        ));
                        return;
                    }
                    Ok(_) => {
                        let text = line.trim_end_matches(['\n', '\r']).to_string();
                        if to.send(FromController::Line(text)).is_err() {
                            return;
                        }
                    }
                    Err(e) => {
                        let _ =
                            to.send(FromController::Lost(format!("controller connection: {e}")));
                        return;
                    }
                }
            }
        })?;
    Ok(())
}

/// Serve one upgraded WebSocket until the browser leaves, stops reading, or the ui stops.
pub fn run(stream: TcpStream, hub: Arc<Hub>) {
    let _ = stream.set_nodelay(true);
    if stream
        .set_read_timeout(Some(Duration::from_millis(POLL_MS)))
        .and(stream.set_write_timeout(Some(WRITE_TIMEOUT)))
        .is_err()
    {
        return;
    }
    let config = WebSocketConfig::default()
        .max_write_buffer_size(MAX_BACKLOG)
        .max_message_size(Some(1 << 20));
    let mut ws = WebSocket::from_raw_socket(stream, Role::Server, Some(config));
    let (session_id, sim) = hub.register();
    let endpoint = hub.endpoint.clone();
    let (to_session, from_controller) = mpsc::channel();
    let mut link: Option<Link> = None;
    let mut last_try: Option<Instant> = None;
    let mut told_down = false;
    let result: Result<(), String> = (|| loop {
        if hub.stop.load(Ordering::Acquire) {
            return Ok(());
        }
        if link.is_none() && last_try.is_none_or(|t| t.elapsed() >= RETRY) {
            last_try = Some(Instant::now());
            match endpoint.connect() {
                Ok(l) => match spawn_reader(&l, to_session.clone()) {
                    Ok(()) => {
                        link = Some(l);
                        told_down = false;
                        send_text(&mut ws, format!("EVT UI CONNECTED {endpoint}"))?;
                    }
                    Err(e) => return Err(format!("cannot start the controller reader: {e}")),
                },
                Err(e) if !told_down => {
                    told_down = true;
                    send_text(
                        &mut ws,
                        format!(
                            "EVT UI DISCONNECTED cannot reach the controller at {endpoint}: {e}"
                        ),
                    )?;
                }
                Err(_) => {}
            }
        }
        match ws.read() {
            Ok(Message::Text(text)) => {
                let text = text.as_str();
                let text = text.strip_suffix('\n').unwrap_or(text);
                for line in text.split('\n') {
                    let line = line.strip_suffix('\r').unwrap_or(line);
                    let sent = match link.as_mut() {
                        Some(l) => l.write_line(line).is_ok(),
                        None => false,
                    };
                    if !sent {
                        send_text(
                            &mut ws,
                            format!(
                                "EVT UI DISCONNECTED not connected to the controller; not sent: {}",
                                cut(line, 80)
                            ),
                        )?;
                    }
                }
            }
            Ok(Message::Close(_)) => return Ok(()),
            Ok(_) => {}
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) => {}
            Err(tungstenite::Error::ConnectionClosed | tungstenite::Error::AlreadyClosed) => {
                return Ok(())
            }
            Err(e) => return Err(format!("browser: {e}")),
        }
        drain(&mut ws, &from_controller, &mut link)?;
        let mut dropped = 0u64;
        while let Ok(datagram) = sim.try_recv() {
            match ws.write(Message::Binary(datagram)) {
                Ok(()) => {}
                Err(tungstenite::Error::WriteBufferFull(_)) => dropped += 1,
                Err(e) => return Err(format!("browser: {e}")),
            }
        }
        hub.sim_dropped.fetch_add(dropped, Ordering::Relaxed);
        match ws.flush() {
            Ok(()) => {}
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                return Err("the browser stopped reading; disconnected".into())
            }
            Err(tungstenite::Error::ConnectionClosed | tungstenite::Error::AlreadyClosed) => {
                return Ok(())
            }
            Err(e) => return Err(format!("browser: {e}")),
        }
    })();
    if let Some(l) = link.take() {
        l.shutdown();
    }
    hub.unregister(session_id);
    if let Err(why) = result {
        hub.note(&format!("wrc ui: WebSocket session ended: {why}"));
    }
    let _ = ws.close(None);
    let _ = ws.flush();
}

fn drain(
    ws: &mut WebSocket<TcpStream>,
    from_controller: &Receiver<FromController>,
    link: &mut Option<Link>,
) -> Result<(), String> {
    while let Ok(out) = from_controller.try_recv() {
        match out {
            FromController::Line(text) => send_text(ws, text)?,
            FromController::Lost(why) => {
                if let Some(l) = link.take() {
                    l.shutdown();
                }
                send_text(ws, format!("EVT UI DISCONNECTED {why}"))?;
            }
        }
    }
    Ok(())
}

fn send_text(ws: &mut WebSocket<TcpStream>, text: String) -> Result<(), String> {
    match ws.write(Message::Text(text.into())) {
        Ok(()) => Ok(()),
        Err(tungstenite::Error::WriteBufferFull(_)) => {
            Err("the browser stopped reading (over 1 MiB pending); disconnected".into())
        }
        Err(e) => Err(format!("browser: {e}")),
    }
}

fn cut(text: &str, max: usize) -> &str {
    match text.char_indices().nth(max) {
        Some((i, _)) => &text[..i],
        None => text,
    }
}

/// A simulator datagram on its way to a browser.
pub type Datagram = Bytes;
