//! `wrc ui`: serves the web GUI and bridges the browser to the controller, in a process of
//! its own so that a GUI fault can never disturb control (docs/gui.md).
//!
//! - HTTP (axum on tokio, two worker threads): the built app (embedded, or a folder).
//! - `/ws`: a WebSocket per browser tab, each with its own connection to the controller's
//!   line protocol (Unix socket locally, TCP remotely); request lines in, reply and event
//!   lines out, as text frames, each pushed the moment it arrives.
//! - The controller's simulator datagrams (UDP) are fanned out to every WebSocket as binary
//!   frames; a browser that is behind loses datagrams, never lines.
//! - `/api/compile` and `/api/language`: the editor's compiler, which needs no controller
//!   (a program, its libraries and points compiled against the configured robot on a
//!   blocking thread; `compile.rs`, `api.rs`); `/api/programs[/<name>]`: the stored programs
//!   and libraries the editor opens, read from the program folder.
//! - Loopback by default; any other listening address needs a token that every WebSocket
//!   and API request must present, and a page of another origin is refused.
//!
//! ```no_run
//! use wrc_ui::{Endpoint, Options, Ui};
//! let ui = Ui::start(Options {
//!     listen: "127.0.0.1:8080".parse().unwrap(),
//!     controller: Endpoint::parse("/tmp/wrc/wrc.sock").expect("a socket path"),
//!     sim_addr: Some("127.0.0.1:7200".parse().unwrap()),
//!     token: None,
//!     controller_token: None,
//!     web_dir: None,
//!     robot: wrc_robot::Robot::paper_default(),
//!     programs: Some("/tmp/wrc/programs".into()),
//! })
//! .expect("starts");
//! println!("GUI on http://{}", ui.local_addr());
//! ```
#![deny(missing_docs)]

mod api;
pub mod assets;
pub mod compile;
pub mod session;

use std::net::{SocketAddr, TcpListener, UdpSocket};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use axum::extract::ws::rejection::WebSocketUpgradeRejection;
use axum::extract::{DefaultBodyLimit, Query, State, WebSocketUpgrade};
use axum::http::{header, HeaderMap, Method, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::routing::any;
use axum::serve::ListenerExt;
use axum::Router;
use tokio::sync::{broadcast, watch, Semaphore};
use wrc_robot::Robot;

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
    /// The controller's control token, sent as `AUTH <token>` on each TCP connection to it
    /// (a controller bound off loopback with `[host] token_file`); `None`: not sent.
    pub controller_token: Option<String>,
    /// Serve the app from this folder instead of the embedded one.
    pub web_dir: Option<PathBuf>,
    /// The robot the editor's programs are compiled for (`/api/compile`): the controller's.
    pub robot: Robot,
    /// The controller's program folder (`STATE_DIR/programs`): libraries, called programs
    /// and points files the editor does not send are read there; `None`: only what it sends.
    pub programs: Option<PathBuf>,
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

/// Where notes about sessions go (the log when none is set).
type NoteSink = Box<dyn Fn(&str) + Send>;

/// State shared by the server's tasks and sessions.
pub struct Hub {
    endpoint: Endpoint,
    controller_token: Option<String>,
    /// Set once: stop serving.
    stop: watch::Sender<bool>,
    /// Browsers connected now.
    sessions: AtomicUsize,
    /// The simulator datagrams, fanned out to every session (each keeps at most
    /// [`SIM_QUEUE`] it has not sent yet; older ones are dropped and counted).
    sim: broadcast::Sender<Datagram>,
    /// Simulator datagrams received.
    pub sim_received: AtomicU64,
    /// Simulator datagrams not delivered to a browser that was behind.
    pub sim_dropped: AtomicU64,
    notes: Mutex<Option<NoteSink>>,
}

impl Hub {
    /// Browsers connected now.
    pub fn sessions(&self) -> usize {
        self.sessions.load(Ordering::Acquire)
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
    thread: Option<JoinHandle<()>>,
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

/// The `host[:port]` of an `Origin` (`http://host:port`) or `Host` header value.
fn authority(value: &str) -> &str {
    let rest = value.split_once("://").map_or(value, |(_, r)| r);
    rest.split('/').next().unwrap_or(rest)
}

/// What every request handler sees.
#[derive(Clone)]
struct App {
    hub: Arc<Hub>,
    assets: Assets,
    token: Option<String>,
    /// The robot programs are compiled for.
    robot: Arc<Robot>,
    /// The controller's program folder, if known.
    programs: Option<Arc<PathBuf>>,
    /// Compilations running at once (each on a blocking thread) are at most its permits.
    compiles: Arc<Semaphore>,
}

/// Compilations `wrc ui` runs at once; more requests wait their turn.
const PARALLEL_COMPILES: usize = 2;

/// Why a request to `/ws` or `/api/…` is refused (HTTP 403), if it is: without the right
/// `?token=` when a token is set, or from a page of another origin than the one it names
/// (a page of another site must not drive the robot through the operator's browser).
fn refusal(app: &App, headers: &HeaderMap, query: &[(String, String)]) -> Option<&'static str> {
    if let Some(expected) = &app.token {
        let given = query
            .iter()
            .find(|(k, _)| k == "token")
            .map(|(_, v)| v.as_str());
        if !given.is_some_and(|t| same(t, expected)) {
            return Some("wrong or missing token: open the page as http://HOST:PORT/?token=…");
        }
    }
    let header = |name: header::HeaderName| headers.get(name).and_then(|v| v.to_str().ok());
    if let (Some(origin), Some(host)) = (header(header::ORIGIN), header(header::HOST)) {
        if authority(origin) != authority(host) {
            return Some("a page of another origin may not use the robot's WebSocket or API");
        }
    }
    None
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
        listener.set_nonblocking(true).map_err(UiError::Thread)?;
        if let Some(s) = &sim {
            s.set_nonblocking(true).map_err(UiError::Thread)?;
        }
        let assets = Assets::locate(options.web_dir.as_deref());
        let hub = Arc::new(Hub {
            endpoint: options.controller.clone(),
            controller_token: options.controller_token.clone(),
            stop: watch::channel(false).0,
            sessions: AtomicUsize::new(0),
            sim: broadcast::channel(SIM_QUEUE).0,
            sim_received: AtomicU64::new(0),
            sim_dropped: AtomicU64::new(0),
            notes: Mutex::new(None),
        });
        // Two worker threads: the GUI is the least urgent thing on the machine.
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("wrc-ui")
            .enable_all()
            .build()
            .map_err(UiError::Thread)?;
        let app = App {
            hub: hub.clone(),
            assets: assets.clone(),
            token: options.token.clone(),
            robot: Arc::new(options.robot),
            programs: options.programs.map(Arc::new),
            compiles: Arc::new(Semaphore::new(PARALLEL_COMPILES)),
        };
        let thread = std::thread::Builder::new()
            .name("wrc-ui".into())
            .spawn(move || runtime.block_on(serve(listener, sim, app)))
            .map_err(UiError::Thread)?;
        Ok(Ui {
            addr,
            sim_addr,
            assets,
            hub,
            thread: Some(thread),
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

    /// Send notes (a session that ended abnormally, …) to `sink` instead of the log.
    pub fn on_note(&self, sink: impl Fn(&str) + Send + 'static) {
        if let Ok(mut n) = self.hub.notes.lock() {
            *n = Some(Box::new(sink));
        }
    }

    /// Stop serving: close every WebSocket (and its controller connection) and return.
    pub fn stop(mut self) {
        self.hub.stop.send_replace(true);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Ui {
    fn drop(&mut self) {
        self.hub.stop.send_replace(true);
    }
}

/// The server: HTTP for the app's files, `/ws` for the WebSockets, the simulator's
/// datagrams fanned out, until the hub says stop.
async fn serve(listener: TcpListener, sim: Option<UdpSocket>, app: App) {
    let hub = app.hub.clone();
    let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
        hub.note("wrc ui: cannot serve on the bound port");
        return;
    };
    if let Some(sim) = sim.and_then(|s| tokio::net::UdpSocket::from_std(s).ok()) {
        tokio::spawn(sim_loop(sim, hub.clone()));
    }
    let router = Router::new()
        .route("/ws", any(websocket))
        .route(
            "/api/compile",
            any(api::compile).layer(DefaultBodyLimit::max(compile::MAX_REQUEST_BYTES)),
        )
        .route("/api/language", any(api::language))
        .route("/api/programs", any(api::programs))
        .route("/api/programs/{name}", any(api::program))
        .fallback(file)
        .with_state(app);
    // Lines go out the moment they are written (no Nagle delay waiting for the browser's
    // ACK: that alone added 40 ms to some round trips).
    let listener = listener.tap_io(|tcp| {
        let _ = tcp.set_nodelay(true);
    });
    let mut stop = hub.stop.subscribe();
    let _ = axum::serve(listener, router)
        .with_graceful_shutdown(async move { stopped(&mut stop).await })
        .await;
}

/// `keep-alive` for an answer, `close` after a refusal.
fn connection_after(status: StatusCode) -> &'static str {
    if status.is_success() || status == StatusCode::NOT_FOUND {
        "keep-alive"
    } else {
        "close"
    }
}

/// A one-line text answer; a refusal also closes the connection.
fn plain(status: StatusCode, text: &str) -> Response {
    (
        status,
        [
            (header::CONTENT_TYPE, "text/plain; charset=utf-8"),
            (header::CONNECTION, connection_after(status)),
        ],
        format!("{text}\n"),
    )
        .into_response()
}

/// `/ws`: the token (off loopback) and the page's origin are checked before the upgrade.
async fn websocket(
    State(app): State<App>,
    method: Method,
    headers: HeaderMap,
    Query(query): Query<Vec<(String, String)>>,
    upgrade: Result<WebSocketUpgrade, WebSocketUpgradeRejection>,
) -> Response {
    if method != Method::GET {
        return plain(StatusCode::METHOD_NOT_ALLOWED, "only GET");
    }
    let Ok(upgrade) = upgrade else {
        return plain(StatusCode::BAD_REQUEST, "WebSocket upgrade expected");
    };
    if let Some(why) = refusal(&app, &headers, &query) {
        return plain(StatusCode::FORBIDDEN, why);
    }
    let hub = app.hub.clone();
    upgrade
        .max_message_size(session::MAX_MESSAGE)
        .on_upgrade(move |socket| session::run(socket, hub))
}

/// Every other path: a file of the app (GET or HEAD).
async fn file(State(app): State<App>, method: Method, uri: Uri) -> Response {
    if method != Method::GET && method != Method::HEAD {
        return plain(StatusCode::METHOD_NOT_ALLOWED, "only GET");
    }
    let path = uri.path();
    match app.assets.get(path) {
        Some(body) => {
            let cache = if path.starts_with("/assets/") {
                "public, max-age=31536000, immutable"
            } else {
                "no-cache"
            };
            let kind = assets::content_type(if path == "/" { "index.html" } else { path });
            (
                [(header::CONTENT_TYPE, kind), (header::CACHE_CONTROL, cache)],
                body.into_owned(),
            )
                .into_response()
        }
        None if matches!(app.assets, Assets::Missing) => (
            StatusCode::SERVICE_UNAVAILABLE,
            [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
            MISSING_PAGE,
        )
            .into_response(),
        None => plain(StatusCode::NOT_FOUND, "no such file"),
    }
}

const MISSING_PAGE: &str = "<!doctype html><meta charset=utf-8><title>wrc</title>\
<h1>The wrc web app is not built</h1><p>Build it with <code>make web</code> (or \
<code>cd web &amp;&amp; npm ci &amp;&amp; npm run build</code>) and reload, or start \
<code>wrc ui --web-dir DIR</code>. The controller runs without it.</p>";

/// Until the hub says stop (or is gone).
async fn stopped(stop: &mut watch::Receiver<bool>) {
    let _ = stop.wait_for(|s| *s).await;
}

async fn sim_loop(socket: tokio::net::UdpSocket, hub: Arc<Hub>) {
    let mut buf = [0u8; 2048];
    let mut stop = hub.stop.subscribe();
    loop {
        tokio::select! {
            () = stopped(&mut stop) => return,
            got = socket.recv(&mut buf) => {
                if let Ok(n) = got {
                    hub.sim_received.fetch_add(1, Ordering::Relaxed);
                    // No browser connected: nobody to send it to.
                    let _ = hub.sim.send(Datagram::copy_from_slice(&buf[..n]));
                }
            }
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
            controller_token: None,
            web_dir: None,
            robot: Robot::paper_default(),
            programs: None,
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
