//! A client connection to a running controller: TCP (`HOST:PORT`) or the local Unix socket
//! (a path), line-buffered, with a read timeout.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::time::Duration;

use anyhow::{bail, Context};
use wrc_ui::Endpoint;

/// Connect to `addr`: the controller's Unix socket (a path, with a `/`) or `HOST:PORT`, as
/// `wrc ui --controller` reads it ([`Endpoint::parse`]); reads give up after `timeout`. On
/// TCP with a `token_file` (the controller's `[host] token_file`), present its token first
/// (`AUTH`) and fail if the controller refuses it.
pub fn connect(
    addr: &str,
    timeout: Duration,
    token_file: Option<&Path>,
) -> anyhow::Result<(Box<dyn BufRead>, Box<dyn Write>)> {
    let (mut reader, mut writer) = open(addr, timeout)?;
    if let (Endpoint::Tcp(_), Some(file)) = (Endpoint::parse(addr)?, token_file) {
        let token = wrc_controller::host_access::read_token(file)?;
        writer.write_all(format!("AUTH {}\n", token.as_str()).as_bytes())?;
        writer.flush()?;
        loop {
            let mut line = String::new();
            if reader
                .read_line(&mut line)
                .context("no answer to AUTH before the timeout")?
                == 0
            {
                bail!("the controller closed the connection after AUTH");
            }
            if line.starts_with("ACK") {
                break;
            }
            if line.starts_with("NAK") {
                bail!(
                    "the controller refused the control token: {}",
                    line.trim_end()
                );
            }
        }
    }
    Ok((reader, writer))
}

fn open(addr: &str, timeout: Duration) -> anyhow::Result<(Box<dyn BufRead>, Box<dyn Write>)> {
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
