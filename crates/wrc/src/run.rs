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

/// A program checked here and what to send for it: for its libraries and the programs it
/// calls (deepest first), then for itself, the points of the local points file the
/// controller does not have yet and the upload; then `RUN`.
pub(crate) struct Checked {
    /// The name it is stored under.
    pub name: ProgramName,
    /// What to send before `RUN`, in order.
    steps: Vec<Setup>,
}

/// One step of the setup before `RUN`.
#[derive(Debug, Clone, PartialEq)]
enum Setup {
    /// A request (an `UPLOAD` with its text and `.` line).
    Send(String),
    /// Program `name`'s local points (`POINT` arguments after the program's name: the
    /// point's name and its value): ask the controller's with `POINTS`, then send the
    /// missing ones, before the program's upload (it compiles against them).
    Points {
        name: String,
        points: Vec<(String, String)>,
    },
}

/// The `UPLOAD` request of program `name` with `source`, request id `id`.
fn upload_request(id: u32, name: &str, source: &str) -> anyhow::Result<String> {
    if source.lines().any(|l| l.len() > wrc_protocol::MAX_LINE) {
        bail!(
            "{name} has a line longer than {} bytes, which the protocol cannot carry",
            wrc_protocol::MAX_LINE
        );
    }
    let mut upload = format!("{id} UPLOAD {name}\n");
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
    Ok(upload)
}

/// Compile `file` here against `config` (diagnostics on stderr), with the libraries and
/// called programs next to it and its points file (`<name>.points.toml` there), and make
/// what to send to store it under `name` (default: the file's stem). `Err(code)`: it does
/// not compile (exit 2).
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
    let dir = file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let sources = wrc_lang::DirSources {
        dir: dir.to_path_buf(),
    };
    let compiled = wrc_lang::compile_with(
        &source,
        &shown,
        &config.robot,
        &wrc_lang::CompileOptions {
            name: stem,
            sources: Some(&sources),
        },
    );
    if !compiled.diagnostics.is_empty() {
        eprintln!("{}", compiled.render(&shown, &source));
    }
    if compiled.program.is_none() || compiled.errors() > 0 {
        eprintln!("wrc: {shown} does not compile; nothing sent");
        return Ok(Err(ExitCode::from(2)));
    }
    let mut steps = Vec::new();
    // Libraries and called programs first, the deepest first: each compiles on its
    // upload with what it includes already stored, and with its points.
    for (k, other) in compiled.sources.iter().enumerate().skip(1).rev() {
        steps.extend(local_points(&sources, &other.name, &other.name, config)?);
        steps.push(Setup::Send(upload_request(
            10 + k as u32,
            &other.name,
            &other.text,
        )?));
    }
    steps.extend(local_points(&sources, stem, name.as_str(), config)?);
    steps.push(Setup::Send(upload_request(1, name.as_str(), &source)?));
    Ok(Ok(Checked { name, steps }))
}

/// The points step of program `stem`'s local points file (`<stem>.points.toml` in
/// `sources`), for the program stored as `name`; none without a points file.
fn local_points(
    sources: &wrc_lang::DirSources,
    stem: &str,
    name: &str,
    config: &Config,
) -> anyhow::Result<Option<Setup>> {
    let text = match wrc_lang::Sources::points(sources, stem) {
        Ok(Some(text)) => text,
        _ => return Ok(None),
    };
    let parsed = wrc_lang::Points::parse(&text, config.robot.axis_count())
        .map_err(|e| anyhow::anyhow!("{}: {e}", wrc_lang::points::points_file_name(stem)))?;
    let points = parsed
        .iter()
        .map(|(point, value)| {
            let args = match value {
                wrc_lang::PointValue::Pose(p) => format!("{} {} {} {}", p.x, p.y, p.z, p.yaw),
                wrc_lang::PointValue::Joints(j) => {
                    let values: Vec<String> = j[..config.robot.axis_count()]
                        .iter()
                        .map(|v| v.to_string())
                        .collect();
                    format!("JOINTS {}", values.join(" "))
                }
            };
            (point.to_string(), args)
        })
        .collect();
    Ok(Some(Setup::Points {
        name: name.to_string(),
        points,
    }))
}

/// Where a program's conversation with the controller stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// An upload (or a POINT) is sent; waiting for its `ACK`.
    Setting,
    /// `POINTS` is sent: collecting the points the controller has.
    Points,
    /// `RUN` is sent; printing what the program prints until it ends.
    Running,
}

/// What a line from the controller means for the conversation.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Heard {
    /// Nothing to do.
    Nothing,
    /// Send this next.
    Send(String),
    /// The conversation is over with this exit code.
    Ended(ExitCode),
}

/// The conversation of `wrc run` and `wrc sim` with the controller: uploads, points, RUN,
/// then what the program prints until it ends.
pub(crate) struct Conversation {
    name: ProgramName,
    /// What is still to do before `RUN`.
    queue: std::collections::VecDeque<Setup>,
    /// While `POINTS` is asked: the program and its local points.
    asked: Option<(String, Vec<(String, String)>)>,
    /// The names of the points the controller has (of the program asked about).
    known: Vec<String>,
    phase: Phase,
    /// The id of the request whose ACK is awaited.
    awaiting: String,
}

impl Conversation {
    /// The conversation for `checked`, and the first request to send.
    pub(crate) fn start(checked: Checked) -> (Conversation, String) {
        let mut talk = Conversation {
            name: checked.name,
            queue: checked.steps.into(),
            asked: None,
            known: Vec::new(),
            phase: Phase::Setting,
            awaiting: String::new(),
        };
        let first = match talk.next() {
            Heard::Send(r) => r,
            _ => String::new(),
        };
        (talk, first)
    }

    fn send(&mut self, request: String) -> Heard {
        self.awaiting = request.split(' ').next().unwrap_or("").to_string();
        Heard::Send(request)
    }

    /// The next request of the setup, or `RUN` once it is done.
    fn next(&mut self) -> Heard {
        match self.queue.pop_front() {
            Some(Setup::Send(r)) => {
                self.phase = Phase::Setting;
                self.send(r)
            }
            Some(Setup::Points { name, points }) => {
                self.phase = Phase::Points;
                self.known.clear();
                let request = format!("9 POINTS {name}\n");
                self.asked = Some((name, points));
                self.send(request)
            }
            None => {
                self.phase = Phase::Running;
                Heard::Send(format!("2 RUN {}\n", self.name))
            }
        }
    }

    /// Take one line `l` from the controller: print what `wrc run` prints (`PRINT` events
    /// and the final line on stdout, diagnostics, alarms and refusals on stderr).
    pub(crate) fn hear(&mut self, l: &str) -> Heard {
        let mut words = l.splitn(3, ' ');
        let kind = words.next().unwrap_or("");
        let id = words.next().unwrap_or("");
        let rest = words.next().unwrap_or("");
        match self.phase {
            Phase::Setting | Phase::Points => {
                if let Some(diag) = l.strip_prefix("EVT DIAG ") {
                    eprintln!("{diag}");
                } else if let (Phase::Points, Some(point)) =
                    (self.phase, l.strip_prefix("EVT POINT "))
                {
                    let mut w = point.split(' ');
                    let asked = self.asked.as_ref().map(|(n, _)| n.as_str());
                    if w.next() == asked {
                        if let Some(p) = w.next() {
                            self.known.push(p.to_ascii_uppercase());
                        }
                    }
                } else if kind == "ACK" && id == self.awaiting {
                    if let (Phase::Points, Some((name, points))) = (self.phase, self.asked.take()) {
                        // Only the points the controller does not have: never overwrite a
                        // point taught there. They go before the program's upload.
                        let missing: Vec<Setup> = points
                            .iter()
                            .filter(|(p, _)| !self.known.contains(&p.to_ascii_uppercase()))
                            .enumerate()
                            .map(|(k, (p, args))| {
                                Setup::Send(format!("{} POINT {name} {p} {args}\n", 30 + k))
                            })
                            .collect();
                        for step in missing.into_iter().rev() {
                            self.queue.push_front(step);
                        }
                    }
                    return self.next();
                } else if kind == "NAK" && id == self.awaiting {
                    eprintln!("wrc: the controller refused it: {l}");
                    return Heard::Ended(ExitCode::from(1));
                }
                Heard::Nothing
            }
            Phase::Running => match (kind, id) {
                ("EVT", "PRINT") => {
                    println!("{rest}");
                    Heard::Nothing
                }
                ("EVT", "DIAG") => {
                    eprintln!("{rest}");
                    Heard::Nothing
                }
                ("EVT", "ALARM") => {
                    eprintln!("wrc: alarm {rest}");
                    Heard::Nothing
                }
                ("EVT", "PROGRAM") if rest.split(' ').nth(1) == Some("WAITING") => {
                    eprintln!("wrc: the program waits for the operator (answer with `wrc send CONTINUE [answer]`): {rest}");
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

    /// Whether `RUN` has been sent.
    pub(crate) fn running(&self) -> bool {
        self.phase == Phase::Running
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
    let (mut talk, first) = Conversation::start(checked);
    writer.write_all(first.as_bytes())?;
    writer.flush()?;

    // RUN only once every text is stored: never an older program of the same name.
    let mut line = String::new();
    loop {
        line.clear();
        let what = if talk.running() {
            "no reply from the controller before the timeout"
        } else {
            "no reply to the upload before the timeout"
        };
        let n = reader.read_line(&mut line).context(what)?;
        if n == 0 {
            if talk.running() {
                bail!("the controller closed the connection before the program ended")
            }
            bail!("the controller closed the connection during the upload")
        }
        match talk.hear(line.trim_end()) {
            Heard::Nothing => {}
            Heard::Send(request) => {
                writer.write_all(request.as_bytes())?;
                writer.flush()?;
            }
            Heard::Ended(code) => return Ok(code),
        }
    }
}
