//! `wrc ui` as the browser meets it: a real server on a free loopback port, driven over
//! HTTP the way the web app does (docs/gui.md). The browser itself is exercised by web/e2e.

mod compile;
mod programs;

use std::net::SocketAddr;
use std::path::PathBuf;

use http_body_util::{BodyExt, Full};
use hyper::body::Bytes;
use hyper::Request;
use hyper_util::rt::TokioIo;
use wrc_robot::Robot;
use wrc_ui::{Endpoint, Options, Ui};

/// A `wrc ui` on a free loopback port, with no controller behind it (the compiler needs
/// none), compiling for the paper robot with `programs` as the program folder.
pub fn start(programs: Option<PathBuf>, token: Option<&str>) -> Ui {
    Ui::start(Options {
        listen: "127.0.0.1:0".parse().unwrap(),
        controller: Endpoint::parse("/nonexistent/wrc.sock").unwrap(),
        sim_addr: None,
        token: token.map(str::to_string),
        controller_token: None,
        web_dir: None,
        robot: Robot::paper_default(),
        programs,
    })
    .expect("wrc ui starts")
}

/// An HTTP answer: status, content type and body.
#[derive(Debug)]
pub struct Answer {
    pub status: u16,
    pub content_type: String,
    pub body: String,
}

impl Answer {
    /// The body as JSON.
    pub fn json(&self) -> serde_json::Value {
        serde_json::from_str(&self.body).unwrap_or_else(|e| panic!("not JSON ({e}): {}", self.body))
    }
}

/// Send one request to `addr` (over a connection of its own) and read the whole answer.
pub fn http(
    addr: SocketAddr,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: impl Into<Bytes>,
) -> Answer {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let body = body.into();
    runtime.block_on(async move {
        let stream = tokio::net::TcpStream::connect(addr).await.unwrap();
        let (mut send, connection) = hyper::client::conn::http1::handshake(TokioIo::new(stream))
            .await
            .unwrap();
        tokio::spawn(connection);
        let mut request = Request::builder()
            .method(method)
            .uri(path)
            .header("host", addr.to_string());
        for (k, v) in headers {
            request = request.header(*k, *v);
        }
        let response = send
            .send_request(request.body(Full::new(body)).unwrap())
            .await
            .unwrap();
        let status = response.status().as_u16();
        let content_type = response
            .headers()
            .get("content-type")
            .map(|v| v.to_str().unwrap().to_string())
            .unwrap_or_default();
        let bytes = response.into_body().collect().await.unwrap().to_bytes();
        Answer {
            status,
            content_type,
            body: String::from_utf8_lossy(&bytes).to_string(),
        }
    })
}

/// `POST /api/compile` of `body` as JSON.
/// POST `body` (JSON) to `path` over a plain socket, the body written by another thread, and
/// read the answer to the end: a server may answer a body it refuses (413) before reading it,
/// and close, which an HTTP client writing the body sees as a broken pipe before the answer.
pub fn post_unread(addr: SocketAddr, path: &str, body: String) -> Answer {
    use std::io::{Read, Write};
    let mut stream = std::net::TcpStream::connect(addr).unwrap();
    let mut writer = stream.try_clone().unwrap();
    let head = format!(
        "POST {path} HTTP/1.1\r\nhost: {addr}\r\ncontent-type: application/json\r\ncontent-length: {}\r\nconnection: close\r\n\r\n",
        body.len()
    );
    let write = std::thread::spawn(move || {
        // Refused early, the rest of the body meets a closed socket: that is the point.
        let _ = writer
            .write_all(head.as_bytes())
            .and_then(|()| writer.write_all(body.as_bytes()));
    });
    let mut bytes = Vec::new();
    // The answer comes before the server closes; a reset after it ends the read.
    let mut buf = [0u8; 4096];
    loop {
        match stream.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => bytes.extend_from_slice(&buf[..n]),
        }
    }
    let _ = write.join();
    let text = String::from_utf8_lossy(&bytes).to_string();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no HTTP answer: {text:?}"));
    let content_type = head
        .lines()
        .find_map(|l| {
            l.to_ascii_lowercase()
                .strip_prefix("content-type:")
                .map(|v| v.trim().to_string())
        })
        .unwrap_or_default();
    Answer {
        status,
        content_type,
        body: body.to_string(),
    }
}

pub fn post_compile(addr: SocketAddr, body: &serde_json::Value) -> Answer {
    http(
        addr,
        "POST",
        "/api/compile",
        &[("content-type", "application/json")],
        body.to_string(),
    )
}
