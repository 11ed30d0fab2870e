//! One browser WebSocket: its own connection to the controller (so each browser tab is its
//! own command source with its own control lock), request lines in, controller lines and
//! simulator datagrams out, each pushed the moment it arrives (one task per browser waits on
//! all three at once). The controller connection is retried every second while it is down,
//! and the browser is told (`EVT UI CONNECTED` / `EVT UI DISCONNECTED`).

use std::io;
use std::path::PathBuf;
use std::pin::Pin;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use axum::body::Bytes;
use axum::extract::ws::{Message, WebSocket};
use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncBufReadExt, AsyncRead, AsyncWrite, AsyncWriteExt, BufReader, Lines};
use tokio::net::{TcpStream, UnixStream};
use tokio::sync::broadcast::error::RecvError;

use crate::Hub;

/// A browser that has not taken a message for this long is disconnected (it stopped
/// reading: its socket's buffers are full).
const WRITE_TIMEOUT: Duration = Duration::from_secs(3);
/// Largest message a browser may send [bytes].
pub const MAX_MESSAGE: usize = 1 << 20;
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

    /// Connect; on TCP with `token`, present it (`AUTH`) and wait for the controller's
    /// answer, so a refused token is an error here and its reply never reaches the browser.
    async fn connect(&self, token: Option<&str>) -> io::Result<Link> {
        let mut link = self.open().await?;
        if let (Endpoint::Tcp(_), Some(token)) = (self, token) {
            link.write
                .write_all(format!("AUTH {token}\n").as_bytes())
                .await?;
            loop {
                let Some(line) = link.lines.next_line().await? else {
                    return Err(io::Error::other("the controller closed the connection"));
                };
                if line.starts_with("ACK") {
                    break;
                }
                if line.starts_with("NAK") {
                    return Err(io::Error::other(format!(
                        "the controller refused the control token: {line}"
                    )));
                }
            }
        }
        Ok(link)
    }

    async fn open(&self) -> io::Result<Link> {
        let (read, write): (Reader, Writer) = match self {
            Endpoint::Unix(path) => {
                let (r, w) = UnixStream::connect(path).await?.into_split();
                (Box::pin(r), Box::pin(w))
            }
            Endpoint::Tcp(addr) => {
                let s = TcpStream::connect(addr).await?;
                s.set_nodelay(true)?;
                let (r, w) = s.into_split();
                (Box::pin(r), Box::pin(w))
            }
        };
        Ok(Link {
            lines: BufReader::new(read).lines(),
            write,
        })
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

type Reader = Pin<Box<dyn AsyncRead + Send>>;
type Writer = Pin<Box<dyn AsyncWrite + Send>>;

/// The controller connection of one browser.
struct Link {
    lines: Lines<BufReader<Reader>>,
    write: Writer,
}

/// Why a session ended abnormally (for the log).
type Ended = Result<(), String>;

/// Send one message, giving up on a browser that has stopped reading.
async fn send(
    ws: &mut futures_util::stream::SplitSink<WebSocket, Message>,
    message: Message,
) -> Ended {
    match tokio::time::timeout(WRITE_TIMEOUT, ws.send(message)).await {
        Ok(Ok(())) => Ok(()),
        Ok(Err(e)) => Err(format!("browser: {e}")),
        Err(_) => Err("the browser stopped reading; disconnected".into()),
    }
}

fn text(line: String) -> Message {
    Message::Text(line.into())
}

/// Serve one upgraded WebSocket until the browser leaves, stops reading, or the ui stops.
pub async fn run(socket: WebSocket, hub: Arc<Hub>) {
    hub.sessions.fetch_add(1, Ordering::AcqRel);
    let mut stop = hub.stop.subscribe();
    let mut sim = hub.sim.subscribe();
    let (mut to_browser, mut from_browser) = socket.split();
    let endpoint = hub.endpoint.clone();
    let mut link: Option<Link> = None;
    let mut told_down = false;
    let mut retry = tokio::time::interval(RETRY);
    retry.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let result: Ended = async {
        loop {
            tokio::select! {
                () = crate::stopped(&mut stop) => return Ok(()),
                _ = retry.tick(), if link.is_none() => match endpoint.connect(hub.controller_token.as_deref()).await {
                    Ok(l) => {
                        link = Some(l);
                        told_down = false;
                        send(&mut to_browser, text(format!("EVT UI CONNECTED {endpoint}"))).await?;
                    }
                    Err(e) if !told_down => {
                        told_down = true;
                        send(
                            &mut to_browser,
                            text(format!(
                                "EVT UI DISCONNECTED cannot reach the controller at {endpoint}: {e}"
                            )),
                        )
                        .await?;
                    }
                    Err(_) => {}
                },
                message = from_browser.next() => match message {
                    Some(Ok(Message::Text(t))) => {
                        let t = t.as_str();
                        let t = t.strip_suffix('\n').unwrap_or(t);
                        for line in t.split('\n') {
                            let line = line.strip_suffix('\r').unwrap_or(line);
                            let sent = match link.as_mut() {
                                Some(l) => {
                                    let mut bytes = Vec::with_capacity(line.len() + 1);
                                    bytes.extend_from_slice(line.as_bytes());
                                    bytes.push(b'\n');
                                    l.write.write_all(&bytes).await.is_ok()
                                }
                                None => false,
                            };
                            if !sent {
                                send(
                                    &mut to_browser,
                                    text(format!(
                                        "EVT UI DISCONNECTED not connected to the controller; not sent: {}",
                                        cut(line, 80)
                                    )),
                                )
                                .await?;
                            }
                        }
                    }
                    Some(Ok(Message::Close(_))) | None => return Ok(()),
                    Some(Ok(_)) => {}
                    Some(Err(e)) => return Err(format!("browser: {e}")),
                },
                line = next_line(&mut link) => match line {
                    Ok(Some(line)) => send(&mut to_browser, text(line)).await?,
                    Ok(None) => {
                        link = None;
                        retry.reset();
                        send(
                            &mut to_browser,
                            text("EVT UI DISCONNECTED the controller closed the connection".into()),
                        )
                        .await?;
                    }
                    Err(e) => {
                        link = None;
                        retry.reset();
                        send(
                            &mut to_browser,
                            text(format!("EVT UI DISCONNECTED controller connection: {e}")),
                        )
                        .await?;
                    }
                },
                datagram = sim.recv() => match datagram {
                    Ok(bytes) => send(&mut to_browser, Message::Binary(bytes)).await?,
                    // A browser that is behind loses datagrams, never lines.
                    Err(RecvError::Lagged(n)) => {
                        hub.sim_dropped.fetch_add(n, Ordering::Relaxed);
                    }
                    Err(RecvError::Closed) => return Ok(()),
                },
            }
        }
    }
    .await;
    hub.sessions.fetch_sub(1, Ordering::AcqRel);
    if let Err(why) = result {
        hub.note(&format!("wrc ui: WebSocket session ended: {why}"));
    }
    let _ = to_browser.close().await;
}

/// The controller's next line; pending for ever while there is no connection.
async fn next_line(link: &mut Option<Link>) -> io::Result<Option<String>> {
    match link.as_mut() {
        Some(l) => l
            .lines
            .next_line()
            .await
            .map(|line| line.map(|t| t.trim_end_matches('\r').to_string())),
        None => std::future::pending().await,
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
