//! `wrc send`: send one command line to a controller and print every reply until the
//! command's final one (NAK, INF or ABS; ACK for commands that finish at once). Exit code 0,
//! or 1 on NAK/ABS, 2 when the controller cannot be reached.

use std::io::{BufRead, Write};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{bail, Context};
use clap::Args;
use wrc_protocol::Verb;

/// Arguments of `wrc send`.
#[derive(Debug, Args)]
pub struct SendArgs {
    /// Controller address: HOST:PORT for TCP, or the path of the local Unix socket.
    #[arg(long, default_value = "127.0.0.1:7100")]
    addr: String,
    /// The controller's control token file (its `[host] token_file`), presented with AUTH
    /// before the command on TCP.
    #[arg(long, value_name = "FILE")]
    token_file: Option<std::path::PathBuf>,
    /// Give up after this long without the final reply [s].
    #[arg(long, default_value_t = 120.0)]
    timeout: f64,
    /// The command line, e.g. 'MOVJ 10 20 0 50' or '7 HOME'.
    #[arg(required = true, num_args = 1.., allow_hyphen_values = true)]
    command: Vec<String>,
}

/// Run `wrc send`.
pub fn run(args: SendArgs) -> anyhow::Result<ExitCode> {
    let line = args.command.join(" ");
    if line.contains('\n') {
        bail!("the command must be one line");
    }
    if !(args.timeout > 0.0 && args.timeout.is_finite()) {
        bail!("--timeout must be a positive number of seconds");
    }
    // Which reply ends it: the verb is the first word, or the second after a numeric id.
    let mut words = line.split_whitespace();
    let first = words.next().unwrap_or("");
    let verb_word = if first.bytes().all(|b| b.is_ascii_digit()) {
        words.next().unwrap_or("")
    } else {
        first
    };
    let verb = Verb::from_name(verb_word.as_bytes());
    if verb == Some(Verb::Upload) {
        bail!("UPLOAD is followed by the program's lines, which `wrc send` cannot send; use `wrc run FILE` (it uploads and runs a program)");
    }
    let completes_later = verb.is_some_and(|v| v.spec().completes_later);

    let timeout = Duration::from_secs_f64(args.timeout);
    let (reader, mut writer) =
        crate::connection::connect(&args.addr, timeout, args.token_file.as_deref())?;
    writer.write_all(format!("{line}\n").as_bytes())?;
    writer.flush()?;
    for reply in reader.lines() {
        let reply = reply.context("no final reply before the timeout")?;
        println!("{reply}");
        let kind = reply.split_whitespace().next().unwrap_or("");
        match kind {
            "NAK" | "ABS" => return Ok(ExitCode::from(1)),
            "INF" => return Ok(ExitCode::SUCCESS),
            "ACK" if !completes_later => return Ok(ExitCode::SUCCESS),
            _ => {}
        }
    }
    bail!("the controller closed the connection before the final reply")
}
