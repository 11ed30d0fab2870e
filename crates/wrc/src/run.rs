//! `wrc run FILE`: compile a robot-language program here (diagnostics on stderr, exit 2 on
//! errors, as `wrc compile`), upload it to a running controller under its file name, run it
//! and print what it prints until it ends. Exit code 0 when it ends normally (INF), 1 when
//! the controller refuses it or it ends abnormally (NAK/ABS), 2 when it does not compile or
//! the controller cannot be reached.

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{bail, Context};
use clap::Args;
use wrc_config::Config;
use wrc_protocol::ProgramName;

/// Arguments of `wrc run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The program (`.wrl`).
    file: PathBuf,
    /// Controller address: HOST:PORT for TCP, or the path of the local Unix socket.
    #[arg(long, default_value = "127.0.0.1:7100")]
    addr: String,
    /// Robot configuration to check the program against here (the controller checks it
    /// again with its own); default: the embedded paper robot.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Store it under this name instead of the file's name.
    #[arg(long)]
    name: Option<String>,
    /// Give up after this long without a line from the controller [s].
    #[arg(long, default_value_t = 600.0)]
    timeout: f64,
}

/// Run `wrc run`.
pub fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    if !(args.timeout > 0.0 && args.timeout.is_finite()) {
        bail!("--timeout must be a positive number of seconds");
    }
    let config = Config::load(args.config.as_deref())?;
    let source = std::fs::read_to_string(&args.file)
        .with_context(|| format!("cannot read {}", args.file.display()))?;
    let file = args.file.display().to_string();
    let stem = args
        .file
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("program");
    let name_text = args.name.clone().unwrap_or_else(|| stem.to_string());
    let Some(name) = ProgramName::new(&name_text) else {
        bail!(
            "\"{name_text}\" cannot name a program (1-32 letters, digits, _ or -); give one with --name"
        );
    };

    let compiled = wrc_lang::compile(&source, &file, &config.robot);
    for d in &compiled.diagnostics {
        eprint!("{}", d.render(&file, &source));
    }
    if compiled.program.is_none() || compiled.diagnostics.iter().any(|d| d.is_error()) {
        eprintln!("wrc: {file} does not compile; nothing sent");
        return Ok(ExitCode::from(2));
    }
    if source.lines().any(|l| l.len() > wrc_protocol::MAX_LINE) {
        bail!(
            "{file} has a line longer than {} bytes, which the protocol cannot carry",
            wrc_protocol::MAX_LINE
        );
    }

    let (mut reader, mut writer) =
        crate::connection::connect(&args.addr, Duration::from_secs_f64(args.timeout))?;
    let mut upload = format!("1 UPLOAD {name}\n");
    for line in source.lines() {
        // A line that is exactly "." would end the upload early; a leading space keeps its
        // meaning (it is not valid program text anyway).
        if line == "." {
            upload.push_str(" .\n");
        } else {
            upload.push_str(line);
            upload.push('\n');
        }
    }
    upload.push_str(".\n");
    writer.write_all(upload.as_bytes())?;
    writer.flush()?;

    // RUN only once this text is stored: never an older program of the same name.
    let mut line = String::new();
    loop {
        line.clear();
        let n = reader
            .read_line(&mut line)
            .context("no reply to the upload before the timeout")?;
        if n == 0 {
            bail!("the controller closed the connection during the upload");
        }
        let l = line.trim_end();
        if let Some(diag) = l.strip_prefix("EVT DIAG ") {
            eprintln!("{diag}");
        } else if l.starts_with("ACK 1") {
            break;
        } else if l.starts_with("NAK") {
            eprintln!("wrc: the controller refused the program: {l}");
            return Ok(ExitCode::from(1));
        }
    }
    writer.write_all(format!("2 RUN {name}\n").as_bytes())?;
    writer.flush()?;

    loop {
        line.clear();
        let n = reader
            .read_line(&mut line)
            .context("no reply from the controller before the timeout")?;
        if n == 0 {
            bail!("the controller closed the connection before the program ended");
        }
        let l = line.trim_end();
        let mut words = l.splitn(3, ' ');
        let kind = words.next().unwrap_or("");
        let id = words.next().unwrap_or("");
        match (kind, id) {
            ("EVT", "PRINT") => println!("{}", words.next().unwrap_or("")),
            ("EVT", "DIAG") => eprintln!("{}", words.next().unwrap_or("")),
            ("EVT", _) | ("ACK", _) => {}
            ("NAK", _) => {
                eprintln!("wrc: refused: {l}");
                return Ok(ExitCode::from(1));
            }
            ("INF", "2") => {
                println!("{l}");
                return Ok(ExitCode::SUCCESS);
            }
            ("ABS", _) => {
                println!("{l}");
                return Ok(ExitCode::from(1));
            }
            _ => {}
        }
    }
}
