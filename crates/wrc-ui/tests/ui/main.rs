//! `wrc ui` as the browser meets it: a real server on a free loopback port, driven over
//! HTTP the way the web app does (docs/gui.md). The browser itself is exercised by web/e2e.

mod compile;

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
pub fn post_compile(addr: SocketAddr, body: &serde_json::Value) -> Answer {
    http(
        addr,
        "POST",
        "/api/compile",
        &[("content-type", "application/json")],
        body.to_string(),
    )
}
