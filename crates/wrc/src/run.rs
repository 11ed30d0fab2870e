//! `wrc run FILE`: compile a robot-language program here (diagnostics on stderr, exit 2 on
//! errors, as `wrc compile`), upload it to a running controller under its file name, run it
//! and print what it prints until it ends. Exit code 0 when it ends normally (INF), 1 when
//! the controller refuses it or it ends abnormally (NAK/ABS), 2 when it does not compile or
//! the controller cannot be reached.

use std::io::Write as _;
use std::path::{Path, PathBuf};
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
    /// The controller's control token file (its `[host] token_file`), presented with AUTH
    /// before the upload on TCP.
    #[arg(long, value_name = "FILE")]
    token_file: Option<PathBuf>,
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

/// A program checked here and ready to upload.
pub(crate) struct Checked {
    /// The name it is stored under.
    pub name: ProgramName,
    /// The `UPLOAD` request with the program's text, ending with its `.` line.
    pub upload: String,
}

/// Compile `file` here against `config` (diagnostics on stderr) and make its upload under
/// `name` (default: the file's stem). `Err(code)`: it does not compile (exit 2).
pub(crate) fn check(
    file: &Path,
    name: Option<&str>,
    config: &Config,
) -> anyhow::Result<Result<Checked, ExitCode>> {
    let source =
        std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    let shown = file.display().to_string();
    let stem = file
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("program");
    let name_text = name.unwrap_or(stem);
    let Some(name) = ProgramName::new(name_text) else {
        bail!(
            "\"{name_text}\" cannot name a program (1-32 letters, digits, _ or -); give one with --name"
        );
    };

    let compiled = wrc_lang::compile(&source, &shown, &config.robot);
    for d in &compiled.diagnostics {
        eprint!("{}", d.render(&shown, &source));
    }
    if compiled.program.is_none() || compiled.diagnostics.iter().any(|d| d.is_error()) {
        eprintln!("wrc: {shown} does not compile; nothing sent");
        return Ok(Err(ExitCode::from(2)));
    }
    if source.lines().any(|l| l.len() > wrc_protocol::MAX_LINE) {
        bail!(
            "{shown} has a line longer than {} bytes, which the protocol cannot carry",
            wrc_protocol::MAX_LINE
        );
    }
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
    Ok(Ok(Checked { name, upload }))
}

/// The `RUN` request of a checked program, sent once its upload is acknowledged.
pub(crate) fn run_request(name: &ProgramName) -> String {
    format!("2 RUN {name}\n")
}

/// Where a program's conversation with the controller stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Phase {
    /// The upload is sent; waiting for its `ACK 1`.
    Uploading,
    /// `RUN` is sent; printing what the program prints until it ends.
    Running,
}

/// What a line from the controller means for the conversation.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Heard {
    /// Nothing to do.
    Nothing,
    /// The upload is stored: send `RUN` now.
    Stored,
    /// The conversation is over with this exit code.
    Ended(ExitCode),
}

/// Take one line `l` from the controller in `phase`: print what `wrc run` prints (`PRINT`
/// events and the final line on stdout, diagnostics and refusals on stderr).
pub(crate) fn hear(phase: Phase, l: &str) -> Heard {
    let mut words = l.splitn(3, ' ');
    let kind = words.next().unwrap_or("");
    let id = words.next().unwrap_or("");
    match phase {
        Phase::Uploading => {
            if let Some(diag) = l.strip_prefix("EVT DIAG ") {
                eprintln!("{diag}");
            } else if l.starts_with("ACK 1") {
                return Heard::Stored;
            } else if l.starts_with("NAK") {
                eprintln!("wrc: the controller refused the program: {l}");
                return Heard::Ended(ExitCode::from(1));
            }
            Heard::Nothing
        }
        Phase::Running => match (kind, id) {
            ("EVT", "PRINT") => {
                println!("{}", words.next().unwrap_or(""));
                Heard::Nothing
            }
            ("EVT", "DIAG") => {
                eprintln!("{}", words.next().unwrap_or(""));
                Heard::Nothing
            }
            ("NAK", _) => {
                eprintln!("wrc: refused: {l}");
                Heard::Ended(ExitCode::from(1))
            }
            ("INF", "2") => {
                println!("{l}");
                Heard::Ended(ExitCode::SUCCESS)
            }
            ("ABS", _) => {
                println!("{l}");
                Heard::Ended(ExitCode::from(1))
            }
            _ => Heard::Nothing,
        },
    }
}

/// Run `wrc run`.
pub fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    if !(args.timeout > 0.0 && args.timeout.is_finite()) {
        bail!("--timeout must be a positive number of seconds");
    }
    let config = Config::load(args.config.as_deref())?;
    let checked = match check(&args.file, args.name.as_deref(), &config)? {
        Ok(checked) => checked,
        Err(code) => return Ok(code),
    };
    let (mut reader, mut writer) = crate::connection::connect(
        &args.addr,
        Duration::from_secs_f64(args.timeout),
        args.token_file.as_deref(),
    )?;
    writer.write_all(checked.upload.as_bytes())?;
    writer.flush()?;

    // RUN only once this text is stored: never an older program of the same name.
    let mut phase = Phase::Uploading;
    let mut line = String::new();
    loop {
        line.clear();
        let what = match phase {
            Phase::Uploading => "no reply to the upload before the timeout",
            Phase::Running => "no reply from the controller before the timeout",
        };
        let n = reader.read_line(&mut line).context(what)?;
        if n == 0 {
            match phase {
                Phase::Uploading => bail!("the controller closed the connection during the upload"),
                Phase::Running => {
                    bail!("the controller closed the connection before the program ended")
                }
            }
        }
        match hear(phase, line.trim_end()) {
            Heard::Nothing => {}
            Heard::Stored => {
                writer.write_all(run_request(&checked.name).as_bytes())?;
                writer.flush()?;
                phase = Phase::Running;
            }
            Heard::Ended(code) => return Ok(code),
        }
    }
}
