//! A client connection to a running controller: TCP (`HOST:PORT`) or the local Unix socket
//! (a path), line-buffered, with a read timeout.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::os::unix::net::UnixStream;
use std::time::Duration;

use anyhow::Context;
use wrc_ui::Endpoint;

/// Connect to `addr`: the controller's Unix socket (a path, with a `/`) or `HOST:PORT`, as
/// `wrc ui --controller` reads it ([`Endpoint::parse`]); reads give up after `timeout`.
pub fn connect(
    addr: &str,
    timeout: Duration,
) -> anyhow::Result<(Box<dyn BufRead>, Box<dyn Write>)> {
    match Endpoint::parse(addr)? {
        Endpoint::Unix(path) => {
            let s = UnixStream::connect(&path).with_context(|| {
                format!(
                    "cannot connect to the controller's socket {} (is `wrc up` running?)",
                    path.display()
                )
            })?;
            s.set_read_timeout(Some(timeout))?;
            Ok((Box::new(BufReader::new(s.try_clone()?)), Box::new(s)))
        }
        Endpoint::Tcp(addr) => {
            let s = TcpStream::connect(&addr).with_context(|| {
                format!("cannot connect to the controller at {addr} (is `wrc up` running?)")
            })?;
            s.set_read_timeout(Some(timeout))?;
            Ok((Box::new(BufReader::new(s.try_clone()?)), Box::new(s)))
        }
    }
}
