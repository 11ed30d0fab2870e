//! Just enough HTTP/1.1 for the app: read one request head, answer with a file or an
//! error, and recognise a WebSocket upgrade. Every response closes the connection.

use std::io::{self, Read, Write};

/// Largest request head accepted [bytes].
pub const MAX_HEAD: usize = 16 * 1024;

/// One parsed request head.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Head {
    /// `GET`, `HEAD`, …
    pub method: String,
    /// The path, without the query.
    pub path: String,
    /// The query string after `?`, without it (empty when none).
    pub query: String,
    /// Headers, names in lower case.
    pub headers: Vec<(String, String)>,
}

impl Head {
    /// The first header named `name` (lower case).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// The value of query parameter `key` (no percent-decoding: tokens are plain).
    pub fn query_param(&self, key: &str) -> Option<&str> {
        self.query
            .split('&')
            .filter_map(|pair| pair.split_once('='))
            .find(|(k, _)| *k == key)
            .map(|(_, v)| v)
    }

    /// A WebSocket upgrade request: `Upgrade: websocket` and a `Sec-WebSocket-Key`.
    pub fn is_websocket(&self) -> bool {
        self.header("upgrade")
            .is_some_and(|v| v.eq_ignore_ascii_case("websocket"))
            && self.header("sec-websocket-key").is_some()
    }
}

/// Why a request head could not be read.
#[derive(Debug, thiserror::Error)]
pub enum HeadError {
    /// The connection failed or closed before the head was complete.
    #[error("connection: {0}")]
    Io(#[from] io::Error),
    /// The head is longer than [`MAX_HEAD`].
    #[error("request head longer than {MAX_HEAD} bytes")]
    TooLong,
    /// Not HTTP.
    #[error("malformed request: {0}")]
    Malformed(String),
}

/// Read and parse one request head (the bytes up to the blank line).
pub fn read_head(stream: &mut impl Read) -> Result<Head, HeadError> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 1024];
    loop {
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Err(HeadError::Io(io::ErrorKind::UnexpectedEof.into()));
        }
        buf.extend_from_slice(&chunk[..n]);
        if buf.windows(4).any(|w| w == b"\r\n\r\n") {
            break;
        }
        if buf.len() > MAX_HEAD {
            return Err(HeadError::TooLong);
        }
    }
    let mut headers = [httparse::EMPTY_HEADER; 64];
    let mut request = httparse::Request::new(&mut headers);
    match request.parse(&buf) {
        Ok(httparse::Status::Complete(_)) => {}
        Ok(httparse::Status::Partial) => return Err(HeadError::Malformed("incomplete".into())),
        Err(e) => return Err(HeadError::Malformed(e.to_string())),
    }
    let target = request.path.unwrap_or("/");
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    Ok(Head {
        method: request.method.unwrap_or("").to_string(),
        path: path.to_string(),
        query: query.to_string(),
        headers: request
            .headers
            .iter()
            .map(|h| {
                (
                    h.name.to_ascii_lowercase(),
                    String::from_utf8_lossy(h.value).trim().to_string(),
                )
            })
            .collect(),
    })
}

/// Write a complete response and flush it.
pub fn respond(
    stream: &mut impl Write,
    status: &str,
    content_type: &str,
    extra_headers: &str,
    body: &[u8],
    send_body: bool,
) -> io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\n\
         X-Content-Type-Options: nosniff\r\nConnection: close\r\n{extra_headers}\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes())?;
    if send_body {
        stream.write_all(body)?;
    }
    stream.flush()
}

/// A plain-text error response.
pub fn error(stream: &mut impl Write, status: &str, text: &str) -> io::Result<()> {
    respond(
        stream,
        status,
        "text/plain; charset=utf-8",
        "",
        text.as_bytes(),
        true,
    )
}

/// The host part of a `Host` header or an `Origin` URL (`http://a:8080` → `a:8080`).
pub fn authority(value: &str) -> &str {
    let rest = value.split_once("://").map_or(value, |(_, r)| r);
    rest.split('/').next().unwrap_or(rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_websocket_upgrade_with_a_token() {
        let raw = b"GET /ws?token=abc&x=1 HTTP/1.1\r\nHost: 127.0.0.1:8080\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nOrigin: http://127.0.0.1:8080\r\n\r\n";
        let head = read_head(&mut &raw[..]).unwrap();
        assert_eq!(head.path, "/ws");
        assert_eq!(head.query_param("token"), Some("abc"));
        assert!(head.is_websocket());
        assert_eq!(authority(head.header("origin").unwrap()), "127.0.0.1:8080");
        assert_eq!(authority(head.header("host").unwrap()), "127.0.0.1:8080");
    }

    #[test]
    fn refuses_garbage_and_endless_heads() {
        assert!(matches!(
            read_head(&mut &b"\x00\x01\x02 nonsense\r\n\r\n"[..]),
            Err(HeadError::Malformed(_))
        ));
        let long = vec![b'a'; MAX_HEAD + 2048];
        assert!(matches!(read_head(&mut &long[..]), Err(HeadError::TooLong)));
        assert!(matches!(
            read_head(&mut &b"GET / HTTP/1.1\r\n"[..]),
            Err(HeadError::Io(_))
        ));
    }
}
