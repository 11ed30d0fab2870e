//! `wrc ui`: serves the web GUI and bridges the browser to the controller, in a process of
//! its own so that a GUI fault can never disturb control (docs/gui.md).
//!
//! - HTTP: the built app (embedded, or a folder), one request per connection.
//! - `/ws`: a WebSocket per browser tab, each with its own connection to the controller's
//!   line protocol (Unix socket locally, TCP remotely); request lines in, reply and event
//!   lines out, as text frames.
//! - The controller's simulator datagrams (UDP) are fanned out to every WebSocket as binary
//!   frames; a browser that is behind loses datagrams, never lines.
//! - Loopback by default; any other listening address needs a token that every WebSocket
//!   must present, and a WebSocket from a page of another origin is refused.
//!
//! ```no_run
//! use wrc_ui::{Endpoint, Options, Ui};
//! let ui = Ui::start(Options {
//!     listen: "127.0.0.1:8080".parse().unwrap(),
//!     controller: Endpoint::parse("/tmp/wrc/wrc.sock").expect("a socket path"),
//!     sim_addr: Some("127.0.0.1:7200".parse().unwrap()),
//!     token: None,
//!     web_dir: None,
//! })
//! .expect("starts");
//! println!("GUI on http://{}", ui.local_addr());
//! ```
#![deny(missing_docs)]

pub mod assets;
pub mod http;
pub mod session;

use std::io::Write;
use std::net::{SocketAddr, TcpListener, TcpStream, UdpSocket};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

pub use assets::Assets;
use session::Datagram;
pub use session::{Endpoint, EndpointError};

/// Simulator datagrams queued per browser before newer ones are dropped.
const SIM_QUEUE: usize = 64;

/// How `wrc ui` runs.
#[derive(Debug, Clone)]
pub struct Options {
    /// HTTP and WebSocket address (`127.0.0.1:8080`).
    pub listen: SocketAddr,
    /// The controller.
    pub controller: Endpoint,
    /// Receive the simulator datagrams on this UDP address; `None`: no 3D stream.
    pub sim_addr: Option<SocketAddr>,
    /// Token every WebSocket must present (`?token=`); required off loopback.
    pub token: Option<String>,
    /// Serve the app from this folder instead of the embedded one.
    pub web_dir: Option<PathBuf>,
}

/// Why `wrc ui` could not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum UiError {
    /// Listening off loopback without a token.
    #[error("listening on {0} (not a loopback address) requires --token: anyone on the network could drive the robot")]
    TokenRequired(SocketAddr),
    /// A token with characters that need escaping in a URL, or too short to guess poorly.
    #[error("the token must be 8 to 128 letters, digits, '-', '_', '.' or '~'")]
    BadToken,
    /// The HTTP port could not be bound.
    #[error("cannot listen on {addr}: {source} (is another wrc ui running? --ui-port moves it)")]
    Listen {
        /// The address.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// The simulator's UDP address could not be bound.
    #[error("cannot receive simulator datagrams on udp {addr}: {source} (is another wrc ui running? --sim-addr moves it)")]
    Simulator {
        /// The address.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// `--web-dir` names a folder without a built app.
    #[error(
        "--web-dir {0}: no index.html there; give the folder `npm run build` writes (web/dist)"
    )]
    WebDir(PathBuf),
    /// A thread could not be started.
    #[error("cannot start a thread: {0}")]
    Thread(std::io::Error),
}

/// Where notes about sessions go (stderr when none is set).
type NoteSink = Box<dyn Fn(&str) + Send>;

/// State shared by the server's threads and sessions.
pub struct Hub {
    endpoint: Endpoint,
    stop: AtomicBool,
    next_id: AtomicU64,
    sessions: Mutex<Vec<(u64, SyncSender<Datagram>)>>,
    /// Simulator datagrams received.
    pub sim_received: AtomicU64,
    /// Simulator datagrams not delivered to a browser that was behind.
    pub sim_dropped: AtomicU64,
    notes: Mutex<Option<NoteSink>>,
}

impl Hub {
    fn register(&self) -> (u64, Receiver<Datagram>) {
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let (tx, rx) = sync_channel(SIM_QUEUE);
        if let Ok(mut s) = self.sessions.lock() {
            s.push((id, tx));
        }
        (id, rx)
    }

    fn unregister(&self, id: u64) {
        if let Ok(mut s) = self.sessions.lock() {
            s.retain(|(i, _)| *i != id);
        }
    }

    /// Browsers connected now.
    pub fn sessions(&self) -> usize {
        self.sessions.lock().map(|s| s.len()).unwrap_or(0)
    }

    fn broadcast(&self, datagram: &[u8]) {
        let bytes = Datagram::copy_from_slice(datagram);
        let Ok(sessions) = self.sessions.lock() else {
            return;
        };
        for (_, tx) in sessions.iter() {
            if let Err(TrySendError::Full(_)) = tx.try_send(bytes.clone()) {
                self.sim_dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    fn note(&self, text: &str) {
        match self.notes.lock().ok().as_ref().and_then(|n| n.as_ref()) {
            Some(sink) => sink(text),
            None => tracing::info!("{text}"),
        }
    }
}

/// A running `wrc ui`.
pub struct Ui {
    addr: SocketAddr,
    sim_addr: Option<SocketAddr>,
    assets: Assets,
    hub: Arc<Hub>,
    threads: Vec<JoinHandle<()>>,
}

fn token_ok(token: &str) -> bool {
    (8..=128).contains(&token.len())
        && token
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.' | b'~'))
}

/// Compare without stopping at the first difference (no timing hint to a guesser).
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

impl Ui {
    /// Bind the HTTP port and the simulator's UDP address and start serving.
    pub fn start(options: Options) -> Result<Ui, UiError> {
        match &options.token {
            Some(t) if !token_ok(t) => return Err(UiError::BadToken),
            None if !options.listen.ip().is_loopback() => {
                return Err(UiError::TokenRequired(options.listen))
            }
            _ => {}
        }
        if let Some(dir) = &options.web_dir {
            if !dir.join("index.html").is_file() {
                return Err(UiError::WebDir(dir.clone()));
            }
        }
        let listener = TcpListener::bind(options.listen).map_err(|source| UiError::Listen {
            addr: options.listen,
            source,
        })?;
        let addr = listener.local_addr().map_err(|source| UiError::Listen {
            addr: options.listen,
            source,
        })?;
        let sim = match options.sim_addr {
            Some(a) => {
                Some(UdpSocket::bind(a).map_err(|source| UiError::Simulator { addr: a, source })?)
            }
            None => None,
        };
        let sim_addr = sim.as_ref().and_then(|s| s.local_addr().ok());
        let assets = Assets::locate(options.web_dir.as_deref());
        let hub = Arc::new(Hub {
            endpoint: options.controller.clone(),
            stop: AtomicBool::new(false),
            next_id: AtomicU64::new(0),
            sessions: Mutex::new(Vec::new()),
            sim_received: AtomicU64::new(0),
            sim_dropped: AtomicU64::new(0),
            notes: Mutex::new(None),
        });
        let mut threads = Vec::new();
        listener.set_nonblocking(true).map_err(UiError::Thread)?;
        {
            let hub = hub.clone();
            let assets = assets.clone();
            let token = options.token.clone();
            threads.push(
                std::thread::Builder::new()
                    .name("wrc-ui-http".into())
                    .spawn(move || accept_loop(listener, hub, assets, token))
                    .map_err(UiError::Thread)?,
            );
        }
        if let Some(socket) = sim {
            let hub = hub.clone();
            threads.push(
                std::thread::Builder::new()
                    .name("wrc-ui-sim".into())
                    .spawn(move || sim_loop(socket, hub))
                    .map_err(UiError::Thread)?,
            );
        }
        Ok(Ui {
            addr,
            sim_addr,
            assets,
            hub,
            threads,
        })
    }

    /// The HTTP address actually bound (with the real port when 0 was asked).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The UDP address the simulator datagrams are received on.
    pub fn sim_addr(&self) -> Option<SocketAddr> {
        self.sim_addr
    }

    /// Where the app's files come from.
    pub fn assets(&self) -> &Assets {
        &self.assets
    }

    /// Counters and sessions.
    pub fn hub(&self) -> &Arc<Hub> {
        &self.hub
    }

    /// Send notes (a session that ended abnormally, …) to `sink` instead of stderr.
    pub fn on_note(&self, sink: impl Fn(&str) + Send + 'static) {
        if let Ok(mut n) = self.hub.notes.lock() {
            *n = Some(Box::new(sink));
        }
    }

    /// Stop serving: close every WebSocket (and its controller connection) and return.
    pub fn stop(mut self) {
        self.hub.stop.store(true, Ordering::Release);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for Ui {
    fn drop(&mut self) {
        self.hub.stop.store(true, Ordering::Release);
    }
}

fn accept_loop(listener: TcpListener, hub: Arc<Hub>, assets: Assets, token: Option<String>) {
    let mut sessions: Vec<JoinHandle<()>> = Vec::new();
    while !hub.stop.load(Ordering::Acquire) {
        match listener.accept() {
            Ok((stream, _)) => {
                let hub = hub.clone();
                let assets = assets.clone();
                let token = token.clone();
                if let Ok(h) = std::thread::Builder::new()
                    .name("wrc-ui-conn".into())
                    .spawn(move || serve(stream, hub, &assets, token.as_deref()))
                {
                    sessions.push(h);
                }
                sessions.retain(|h| !h.is_finished());
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(_) => std::thread::sleep(Duration::from_millis(20)),
        }
    }
    for h in sessions {
        let _ = h.join();
    }
}

fn serve(mut stream: TcpStream, hub: Arc<Hub>, assets: &Assets, token: Option<&str>) {
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_read_timeout(Some(Duration::from_secs(10)));
    let _ = stream.set_write_timeout(Some(Duration::from_secs(10)));
    let head = match http::read_head(&mut stream) {
        Ok(h) => h,
        Err(http::HeadError::Io(_)) => return,
        Err(e) => {
            let _ = http::error(&mut stream, "400 Bad Request", &format!("{e}\n"));
            return;
        }
    };
    let send_body = head.method != "HEAD";
    if head.method != "GET" && head.method != "HEAD" {
        let _ = http::error(&mut stream, "405 Method Not Allowed", "only GET\n");
        return;
    }
    if head.path == "/ws" {
        if !head.is_websocket() {
            let _ = http::error(
                &mut stream,
                "400 Bad Request",
                "WebSocket upgrade expected\n",
            );
            return;
        }
        if let Some(expected) = token {
            if !head.query_param("token").is_some_and(|t| same(t, expected)) {
                let _ = http::error(
                    &mut stream,
                    "403 Forbidden",
                    "wrong or missing token: open the page as http://HOST:PORT/?token=…\n",
                );
                return;
            }
        }
        if let (Some(origin), Some(host)) = (head.header("origin"), head.header("host")) {
            if http::authority(origin) != http::authority(host) {
                let _ = http::error(
                    &mut stream,
                    "403 Forbidden",
                    "a page of another origin may not open the robot's WebSocket\n",
                );
                return;
            }
        }
        let key = head.header("sec-websocket-key").unwrap_or_default();
        let accept = tungstenite::handshake::derive_accept_key(key.as_bytes());
        let response = format!(
            "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: {accept}\r\n\r\n"
        );
        if stream.write_all(response.as_bytes()).is_err() {
            return;
        }
        session::run(stream, hub);
        return;
    }
    match assets.get(&head.path) {
        Some(body) => {
            let cache = if head.path.starts_with("/assets/") {
                "Cache-Control: public, max-age=31536000, immutable\r\n"
            } else {
                "Cache-Control: no-cache\r\n"
            };
            let _ = http::respond(
                &mut stream,
                "200 OK",
                assets::content_type(if head.path == "/" {
                    "index.html"
                } else {
                    &head.path
                }),
                cache,
                &body,
                send_body,
            );
        }
        None if matches!(assets, Assets::Missing) => {
            let _ = http::respond(
                &mut stream,
                "503 Service Unavailable",
                "text/html; charset=utf-8",
                "",
                MISSING_PAGE.as_bytes(),
                send_body,
            );
        }
        None => {
            let _ = http::error(&mut stream, "404 Not Found", "no such file\n");
        }
    }
}

const MISSING_PAGE: &str = "<!doctype html><meta charset=utf-8><title>wrc</title>\
<h1>The wrc web app is not built</h1><p>Build it with <code>make web</code> (or \
<code>cd web &amp;&amp; npm ci &amp;&amp; npm run build</code>) and reload, or start \
<code>wrc ui --web-dir DIR</code>. The controller runs without it.</p>";

fn sim_loop(socket: UdpSocket, hub: Arc<Hub>) {
    let _ = socket.set_read_timeout(Some(Duration::from_millis(200)));
    let mut buf = [0u8; 2048];
    while !hub.stop.load(Ordering::Acquire) {
        match socket.recv(&mut buf) {
            Ok(n) => {
                hub.sim_received.fetch_add(1, Ordering::Relaxed);
                hub.broadcast(&buf[..n]);
            }
            Err(_) => continue,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens() {
        assert!(token_ok("s3cret-token_1.2~"));
        assert!(!token_ok("short"));
        assert!(!token_ok("has space in it"));
        assert!(!token_ok("percent%20"));
        assert!(same("abcdefgh", "abcdefgh"));
        assert!(!same("abcdefgh", "abcdefgX"));
        assert!(!same("abc", "abcd"));
    }

    #[test]
    fn a_controller_address_is_a_socket_path_or_host_and_port() {
        assert!(matches!(
            Endpoint::parse("/tmp/wrc/wrc.sock"),
            Ok(Endpoint::Unix(_))
        ));
        for good in ["127.0.0.1:7100", "robot-1:7100", "[::1]:7100"] {
            assert_eq!(
                Endpoint::parse(good),
                Ok(Endpoint::Tcp(good.into())),
                "{good}"
            );
        }
        for bad in ["nonsense:port", "7100", ":7100", "host:0", "host:70000", ""] {
            let e = Endpoint::parse(bad).unwrap_err().to_string();
            assert!(
                e.contains("HOST:PORT") && e.contains(&format!("{bad:?}")),
                "{e}"
            );
        }
    }

    #[test]
    fn off_loopback_needs_a_token() {
        let options = Options {
            listen: "0.0.0.0:0".parse().unwrap(),
            controller: Endpoint::parse("127.0.0.1:1").unwrap(),
            sim_addr: None,
            token: None,
            web_dir: None,
        };
        assert!(matches!(
            Ui::start(options.clone()),
            Err(UiError::TokenRequired(_))
        ));
        let empty = tempfile::tempdir().unwrap();
        let options = Options {
            listen: "127.0.0.1:0".parse().unwrap(),
            web_dir: Some(empty.path().to_path_buf()),
            ..options
        };
        assert!(matches!(Ui::start(options), Err(UiError::WebDir(_))));
    }
}
