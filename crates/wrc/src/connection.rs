//! A client connection to a running controller: TCP (`HOST:PORT`) or the local Unix socket
//! (a path), line-buffered, with a read timeout.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::os::unix::net::UnixStream;
use std::time::Duration;

use anyhow::Context;

/// Connect to `addr` (a path when it contains `/`); reads give up after `timeout`.
pub fn connect(
    addr: &str,
    timeout: Duration,
) -> anyhow::Result<(Box<dyn BufRead>, Box<dyn Write>)> {
    if addr.contains('/') {
        let s = UnixStream::connect(addr).with_context(|| {
            format!("cannot connect to the controller's socket {addr} (is `wrc up` running?)")
        })?;
        s.set_read_timeout(Some(timeout))?;
        Ok((Box::new(BufReader::new(s.try_clone()?)), Box::new(s)))
    } else {
        let s = TcpStream::connect(addr).with_context(|| {
            format!("cannot connect to the controller at {addr} (is `wrc up` running?)")
        })?;
        s.set_read_timeout(Some(timeout))?;
        Ok((Box::new(BufReader::new(s.try_clone()?)), Box::new(s)))
    }
}
