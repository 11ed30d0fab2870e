//! The service thread: the controller's non-real-time work, released by its queues. It
//! serves the program store (uploaded robot-language programs received line by line
//! ([`crate::upload`]), compiled with the controller's robot (`wrc-lang`), kept on disk
//! (`STATE_DIR/programs/<name>.wrl`, written atomically), listed and deleted; for
//! `RUN` compiles the stored text and hands the program to the Command Interpreter), the
//! wafer cell ([`crate::cell_service`]: stations, the wafer map, GET/PUT/MAP planning) and
//! the `ROBOT` and `TASKS` queries.
//!
//! Compiling allocates, so it happens here and never in a real-time task: the Ethernet and
//! RS232C tasks pass fixed-size messages in, the Command Interpreter receives a boxed
//! program (moving a box does not allocate) and sends it back here when it is done with it,
//! so the memory is also freed here.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use std::fmt::Write as _;

use wrc_lang::{PointValue, Points, Program};
use wrc_protocol::{Code, Event, Num, PointAction, ProgramName, ReplyBuf, ReplyTo};
use wrc_robot::Robot;
use wrc_rt::clock::monotonic_now_ns;
use wrc_rt::Waiter;

use crate::cell_service::CellService;
use crate::messages::cell_job::JobRefusal;
use crate::messages::{Outputs, ProgramAnswer, ProgramStart, SourceId, StoreLinks, StoreRequest};
use crate::queries::TaskCells;
use crate::shared::Shared;
use crate::upload::{self, ProgramText};

/// The service thread's longest wait between two looks at its queues [ns].
const POLL_NS: u64 = 50_000_000;

struct Upload {
    from: SourceId,
    to: ReplyTo,
    name: ProgramName,
    text: ProgramText,
}

/// The service thread's state: the program store, the wafer cell and the queries (runs on
/// its own non-real-time thread, see [`Service::run`]).
pub struct Service {
    dir: PathBuf,
    robot: Robot,
    links: StoreLinks,
    out: Outputs,
    uploads: Vec<Upload>,
    buf: ReplyBuf,
    period_ms: f64,
    tasks: TaskCells,
    cell: Option<CellService>,
    recorder: Option<crate::recorder::Recorder>,
    /// The commanded position, for `POINT … HERE` (none: refused).
    shared: Option<Arc<Shared>>,
    /// What names the signals in `ROBOT`'s `EVT SIGNAL` lines: `[io]`, the hand, the E-stop
    /// input (the stations' interlocks come from the cell).
    signals: Option<(wrc_config::IoConfig, wrc_config::HandConfig, Option<u8>)>,
}

impl Service {
    /// A store keeping programs in `dir` (created if missing).
    pub fn new(
        dir: &Path,
        robot: Robot,
        links: StoreLinks,
        out: Outputs,
    ) -> std::io::Result<Service> {
        fs::create_dir_all(dir)?;
        Ok(Service {
            dir: dir.to_path_buf(),
            robot,
            links,
            out,
            uploads: Vec::new(),
            buf: ReplyBuf::new(),
            period_ms: 0.0,
            tasks: TaskCells::default(),
            cell: None,
            recorder: None,
            shared: None,
            signals: None,
        })
    }

    /// Also serve the wafer cell: `STN`, `TEACH`, `WAFERS`, `GET`, `PUT`, `MAP`.
    pub fn with_cell(mut self, mut cell: CellService) -> Service {
        cell.connect(self.out.clone(), self.links.clone());
        self.cell = Some(cell);
        self
    }

    /// Also read the commanded position, for `POINT <program> <name> HERE`.
    pub fn with_shared(mut self, shared: Arc<Shared>) -> Service {
        self.shared = Some(shared);
        self
    }

    /// Also keep the trace recorder: drain it every step (saving the last seconds when an
    /// alarm is raised) and answer `TRACE SAVE`.
    pub fn with_recorder(mut self, recorder: crate::recorder::Recorder) -> Service {
        self.recorder = Some(recorder);
        self
    }

    /// The trace recorder, if kept (for `wrc sim --trace` and tests).
    pub fn recorder_mut(&mut self) -> Option<&mut crate::recorder::Recorder> {
        self.recorder.as_mut()
    }

    /// Also answer `ROBOT` (with the Pulse Generator's period [ms]) and `TASKS` (from the
    /// runtime's statistics cells, once they are set).
    pub fn with_queries(mut self, period_ms: f64, tasks: TaskCells) -> Service {
        self.period_ms = period_ms;
        self.tasks = tasks;
        self
    }

    /// Also name the configuration's signals in `ROBOT` (`EVT SIGNAL`; the stations'
    /// interlock inputs are added from the stations file).
    pub fn with_signals(mut self, config: &wrc_config::Config) -> Service {
        self.signals = Some((config.io.clone(), config.hand, config.estop_input()));
        self
    }

    /// Serve requests until `quit`, released by `wake` (notified by the request and event
    /// queues of [`StoreLinks::notifying`]) or every 50 ms at the latest.
    pub fn run(mut self, quit: Arc<AtomicBool>, mut wake: impl Waiter) {
        while !quit.load(Ordering::Acquire) {
            self.step();
            let _ = wake.wait_until_ns(monotonic_now_ns() + POLL_NS);
        }
    }

    /// Serve every queued request and the wafer cell's events, and free retired programs
    /// (public for tests).
    ///
    /// The wafer cell's events are applied before each request is answered: the Command
    /// Interpreter sends a job's map change (a commit, a mapping, the job's end) before the
    /// reply that tells the client the job is done, so whatever a client asks after that
    /// reply (`WAFERS`, the next `GET`) finds the change queued here and sees it applied.
    pub fn step(&mut self) {
        self.record();
        self.apply_cell_events();
        // The start-up recovery runs as soon as the inputs are read, before a request can
        // act on a map it has not settled.
        if let Some(cell) = self.cell.as_mut() {
            cell.poll();
        }
        while let Ok(request) = self.links.requests.try_recv() {
            self.apply_cell_events();
            self.handle(request);
        }
        while self.links.retired.try_recv().is_ok() {}
        self.apply_cell_events();
        if let Some(cell) = self.cell.as_mut() {
            cell.poll();
        }
    }

    /// Apply every wafer-cell event the Command Interpreter has queued (mappings, commits,
    /// job ends, a lost wafer).
    fn apply_cell_events(&mut self) {
        if let Some(cell) = self.cell.as_mut() {
            while let Ok(event) = self.links.cell_events.try_recv() {
                cell.on_event(event);
            }
            // The journal's records of those events on disk, with one sync.
            cell.sync_journal();
        }
    }

    fn path(&self, name: &ProgramName) -> PathBuf {
        self.dir.join(format!("{name}.wrl"))
    }

    fn reply_nak(&mut self, from: SourceId, to: ReplyTo, code: Code, text: &str) {
        let line = self.buf.nak(to, code, text);
        self.out.send(from, line);
    }

    /// Drain the trace recorder; an alarm's trace is saved and logged.
    fn record(&mut self) {
        let Some(recorder) = self.recorder.as_mut() else {
            return;
        };
        match recorder.drain() {
            None => {}
            Some(Ok(saved)) => tracing::info!(
                "wrc: trace of the last {:.1} s before the alarm saved in {}",
                saved.seconds,
                saved.path.display()
            ),
            Some(Err(e)) => tracing::error!("wrc: the alarm's trace could not be saved: {e}"),
        }
    }

    /// `TRACE SAVE [<name>]`.
    fn save_trace(&mut self, from: SourceId, to: ReplyTo, name: Option<ProgramName>) {
        self.record();
        let Some(recorder) = self.recorder.as_mut() else {
            let text = "this controller keeps no trace (no trace directory)";
            return self.reply_nak(from, to, Code::NotAvailable, text);
        };
        let reason = format!("TRACE SAVE from {}", source_label(from));
        match recorder.save_named(name.as_ref().map(|n| n.as_str()), &reason) {
            Ok(saved) => {
                let line = self.buf.ack(
                    to,
                    format_args!(
                        "file={} samples={} messages={} seconds={:.3}",
                        saved.path.display(),
                        saved.samples,
                        saved.messages,
                        saved.seconds
                    ),
                );
                self.out.send(from, line);
            }
            Err(e) => {
                let text = format!("the trace could not be saved: {e}");
                self.reply_nak(from, to, Code::Internal, &text);
            }
        }
    }

    fn handle(&mut self, request: StoreRequest) {
        match request {
            StoreRequest::Begin { from, to, name } => {
                self.uploads.retain(|u| u.from != from);
                self.uploads.push(Upload {
                    from,
                    to,
                    name,
                    text: ProgramText::new(),
                });
            }
            StoreRequest::Line { from, len, text } => {
                if let Some(u) = self.uploads.iter_mut().find(|u| u.from == from) {
                    u.text.push_line(&text[..usize::from(len)]);
                }
            }
            StoreRequest::Cancel { from } => self.uploads.retain(|u| u.from != from),
            StoreRequest::End { from } => {
                let Some(i) = self.uploads.iter().position(|u| u.from == from) else {
                    return;
                };
                let upload = self.uploads.swap_remove(i);
                self.finish_upload(upload);
            }
            StoreRequest::List { from, to } => {
                let names = self.list();
                let line = self
                    .buf
                    .ack(to, format_args!("programs={}", names.join(",")));
                self.out.send(from, line);
            }
            StoreRequest::Delete { from, to, name } => match fs::remove_file(self.path(&name)) {
                Ok(()) => {
                    let line = self.buf.ack(to, "");
                    self.out.send(from, line);
                }
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                    let text = format!("no program named {name}; PROGRAMS lists them");
                    self.reply_nak(from, to, Code::ProgramUnknown, &text);
                }
                Err(e) => {
                    let text = format!("cannot delete {name}: {e}");
                    self.reply_nak(from, to, Code::Internal, &text);
                }
            },
            StoreRequest::Run {
                from,
                to,
                name,
                step,
            } => self.run_program(from, to, name, step),
            StoreRequest::Points { from, to, program } => self.points(from, to, program),
            StoreRequest::Point {
                from,
                to,
                program,
                point,
                action,
            } => self.point(from, to, program, point, action),
            StoreRequest::Cell { query } => {
                let answer = match self.cell.as_ref() {
                    Some(cell) => cell.answer(&query),
                    None => Err((
                        Code::NotAvailable,
                        "this controller has no wafer cell (no stations file)".into(),
                    )),
                };
                self.answer_program(answer);
            }
            StoreRequest::TeachPoint {
                program,
                point,
                value,
            } => {
                let answer = self
                    .store_point(program, point.as_str(), Some(value))
                    .map(|()| match value {
                        wrc_lang::PointValue::Pose(p) => wrc_lang::Answer::Pose(p),
                        wrc_lang::PointValue::Joints(j) => wrc_lang::Answer::Joints(j),
                    });
                self.answer_program(answer);
            }
            StoreRequest::Robot { from, to } => {
                let blade_b = self.cell.as_ref().and_then(|c| c.blade_b_offset());
                let (axes, ack) = crate::queries::robot_reply(&self.robot, self.period_ms, blade_b);
                for axis in &axes {
                    let line = self.buf.event(to.checksum, &Event::Axis(axis));
                    self.out.send(from, line);
                }
                let interlocks = self
                    .cell
                    .as_ref()
                    .map(|c| crate::queries::interlocks(&c.stations))
                    .unwrap_or_default();
                let signals = match &self.signals {
                    Some((io, hand, estop)) => io.signals(hand, *estop, &interlocks),
                    None => Vec::new(),
                };
                for signal in crate::queries::signal_lines(&signals) {
                    let line = self.buf.event(to.checksum, &Event::Signal(&signal));
                    self.out.send(from, line);
                }
                let line = self.buf.ack(to, ack);
                self.out.send(from, line);
            }
            StoreRequest::Stn { from, to } => match self.cell.as_mut() {
                Some(cell) => cell.stn(from, to),
                None => self.no_cell(from, to),
            },
            StoreRequest::Teach { from, to, name } => match self.cell.as_mut() {
                Some(cell) => cell.teach(from, to, &name),
                None => self.no_cell(from, to),
            },
            StoreRequest::Wafers { from, to } => match self.cell.as_mut() {
                Some(cell) => cell.wafers(from, to),
                None => self.no_cell(from, to),
            },
            StoreRequest::Recovery { from, to } => match self.cell.as_mut() {
                Some(cell) => cell.recovery(from, to),
                None => self.no_cell(from, to),
            },
            StoreRequest::Sense { from, to, blade } => match self.cell.as_mut() {
                Some(cell) => cell.sense(from, to, blade),
                None => self.no_cell(from, to),
            },
            StoreRequest::Confirm { from, to, arg } => match self.cell.as_mut() {
                Some(cell) => cell.confirm(from, to, arg),
                None => self.no_cell(from, to),
            },
            StoreRequest::Job {
                from,
                to,
                kind,
                station,
                slot,
                blade,
            } => match self.cell.as_mut() {
                Some(cell) => cell.job(from, to, kind, &station, slot, blade),
                None => self.no_cell(from, to),
            },
            StoreRequest::TraceSave { from, to, name } => self.save_trace(from, to, name),
            StoreRequest::Tasks { from, to } => {
                let tasks = self.tasks.get().map(Vec::as_slice).unwrap_or_default();
                for (spec, cell) in tasks {
                    let text = crate::queries::task_line(spec, &cell.snapshot());
                    let line = self.buf.event(to.checksum, &Event::Task(&text));
                    self.out.send(from, line);
                }
                let line = self.buf.ack(to, format_args!("tasks={}", tasks.len()));
                self.out.send(from, line);
            }
        }
    }

    fn no_cell(&mut self, from: SourceId, to: ReplyTo) {
        if from == SourceId::PROGRAM {
            let refusal = crate::messages::cell_job::JobRefusal::new(
                Code::NotAvailable,
                "this controller has no wafer cell (no stations file)",
            );
            let _ = self
                .links
                .jobs
                .try_send(crate::messages::cell_job::JobOffer::Refused(refusal));
            return;
        }
        self.reply_nak(
            from,
            to,
            Code::NotAvailable,
            "this controller has no wafer cell (no stations file)",
        );
    }

    /// The stored programs' names, sorted.
    pub fn list(&self) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(&self.dir)
            .into_iter()
            .flatten()
            .flatten()
            .filter_map(|e| {
                let name = e.file_name().into_string().ok()?;
                let stem = name.strip_suffix(".wrl")?;
                ProgramName::new(stem).map(|_| stem.to_string())
            })
            .collect();
        names.sort();
        names
    }

    /// Compile `source`; send every diagnostic to `from` as `EVT DIAG`. On errors, NAK 126
    /// and `None`.
    fn compile(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        name: &ProgramName,
        source: &str,
    ) -> Option<(Program, usize)> {
        let sources = wrc_lang::DirSources {
            dir: self.dir.clone(),
        };
        let verdict = upload::check(name, source, &self.robot, Some(&sources));
        for text in &verdict.diagnostics {
            let line = self.buf.event(to.checksum, &Event::Diag(text));
            self.out.send(from, line);
        }
        match verdict.result {
            Ok(compiled) => Some(compiled),
            Err(text) => {
                self.reply_nak(from, to, Code::ProgramInvalid, &text);
                None
            }
        }
    }

    fn finish_upload(&mut self, upload: Upload) {
        let Upload {
            from,
            to,
            name,
            text,
        } = upload;
        let lines = text.lines();
        let text = match text.finish(&name) {
            Ok(text) => text,
            Err(refusal) => return self.reply_nak(from, to, Code::ProgramInvalid, &refusal),
        };
        let Some((_, warnings)) = self.compile(from, to, &name, &text) else {
            return;
        };
        match wrc_cell::write_atomic(&self.path(&name), text.as_bytes()) {
            Ok(()) => {
                let line = self.buf.ack(
                    to,
                    format_args!("name={name} lines={lines} warnings={warnings}"),
                );
                self.out.send(from, line);
            }
            Err(e) => {
                let text = format!("cannot store {name}: {e}; nothing stored");
                self.reply_nak(from, to, Code::Internal, &text);
            }
        }
    }

    fn run_program(&mut self, from: SourceId, to: ReplyTo, name: ProgramName, step: bool) {
        let source = match fs::read_to_string(self.path(&name)) {
            Ok(s) => s,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let text = format!("no program named {name}; PROGRAMS lists them");
                return self.reply_nak(from, to, Code::ProgramUnknown, &text);
            }
            Err(e) => {
                let text = format!("cannot read {name}: {e}");
                return self.reply_nak(from, to, Code::Internal, &text);
            }
        };
        let Some((program, _)) = self.compile(from, to, &name, &source) else {
            return;
        };
        let start = ProgramStart {
            from,
            to,
            name,
            program: Box::new(program),
            step,
        };
        if self.links.starts.try_send(start).is_err() {
            self.reply_nak(
                from,
                to,
                Code::Busy,
                "the controller is busy starting another program; repeat RUN",
            );
        }
    }
}

impl Service {
    /// Send the running program the answer to its question (or why there is none).
    fn answer_program(&mut self, answer: Result<wrc_lang::Answer, (Code, String)>) {
        let message = match answer {
            Ok(a) => ProgramAnswer::Value(a),
            Err((code, text)) => ProgramAnswer::Failed(JobRefusal::new(code, &text)),
        };
        // The queue holds four answers and the program asks one question at a time.
        let _ = self.links.answers.try_send(message);
    }

    fn points_path(&self, program: &ProgramName) -> PathBuf {
        self.dir
            .join(wrc_lang::points::points_file_name(program.as_str()))
    }

    /// Program `program`'s points (none when it has no points file).
    fn load_points(&self, program: &ProgramName) -> Result<Points, String> {
        match fs::read_to_string(self.points_path(program)) {
            Ok(text) => Points::parse(&text, self.robot.axis_count()).map_err(|e| {
                format!(
                    "{}: {e}",
                    wrc_lang::points::points_file_name(program.as_str())
                )
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Points::new()),
            Err(e) => Err(e.to_string()),
        }
    }

    /// `<program> <name> pose <x> <y> <z> <yaw>` or `… joints <j1> …` (`deleted`).
    fn point_line(&self, program: &ProgramName, name: &str, value: Option<&PointValue>) -> String {
        let mut line = format!("{program} {name} ");
        let _ = match value {
            None => write!(line, "deleted"),
            Some(PointValue::Pose(p)) => write!(
                line,
                "pose {} {} {} {}",
                Num(p.x),
                Num(p.y),
                Num(p.z),
                Num(p.yaw)
            ),
            Some(PointValue::Joints(j)) => {
                let _ = line.write_str("joints");
                for v in &j[..self.robot.axis_count()] {
                    let _ = write!(line, " {}", Num(*v));
                }
                Ok(())
            }
        };
        line
    }

    /// Store (`Some`) or delete (`None`) point `name` of `program`, atomically, and tell
    /// every connection (`EVT POINT`).
    fn store_point(
        &mut self,
        program: ProgramName,
        name: &str,
        value: Option<PointValue>,
    ) -> Result<(), (Code, String)> {
        let mut points = self
            .load_points(&program)
            .map_err(|e| (Code::Internal, format!("cannot read the points: {e}")))?;
        match value {
            Some(v) => points
                .set(name, v)
                .map_err(|e| (Code::BadArgument, e.to_string()))?,
            None => {
                if !points.remove(name) {
                    return Err((
                        Code::BadArgument,
                        format!("{program} has no point {name}; POINTS lists them"),
                    ));
                }
            }
        }
        let text = points.to_text(program.as_str(), self.robot.axis_count());
        wrc_cell::write_atomic(&self.points_path(&program), text.as_bytes()).map_err(|e| {
            (
                Code::Internal,
                format!("cannot write the points of {program}: {e}; nothing changed"),
            )
        })?;
        let line = self.point_line(&program, name, value.as_ref());
        tracing::info!("wrc: point {line}");
        let reply = self.buf.event(false, &Event::Point(&line));
        self.out.send(SourceId::BROADCAST, reply);
        Ok(())
    }

    /// `POINTS <program>`.
    fn points(&mut self, from: SourceId, to: ReplyTo, program: ProgramName) {
        let points = match self.load_points(&program) {
            Ok(p) => p,
            Err(e) => {
                let text = format!("cannot read the points of {program}: {e}");
                return self.reply_nak(from, to, Code::Internal, &text);
            }
        };
        for (name, value) in points.iter() {
            let line = self.point_line(&program, name, Some(value));
            let reply = self.buf.event(to.checksum, &Event::Point(&line));
            self.out.send(from, reply);
        }
        let line = self.buf.ack(to, format_args!("points={}", points.len()));
        self.out.send(from, line);
    }

    /// `POINT <program> <name> …`.
    fn point(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        program: ProgramName,
        point: ProgramName,
        action: PointAction,
    ) {
        let name = point.as_str();
        let value = match action {
            PointAction::Delete => None,
            PointAction::Pose(p) => Some(PointValue::Pose(p)),
            PointAction::Joints(j) => Some(PointValue::Joints(j)),
            PointAction::Here => {
                let Some(shared) = self.shared.as_ref() else {
                    let text = "this controller cannot read the robot's position here";
                    return self.reply_nak(from, to, Code::NotAvailable, text);
                };
                let joints = self.robot.pulses_to_joints(&shared.commanded_pulses());
                let is_joints = matches!(
                    self.load_points(&program)
                        .ok()
                        .and_then(|p| p.get(name).copied()),
                    Some(PointValue::Joints(_))
                );
                Some(if is_joints {
                    PointValue::Joints(joints)
                } else {
                    PointValue::Pose(self.robot.forward(&joints))
                })
            }
        };
        match self.store_point(program, name, value) {
            Ok(()) => {
                let line = self.point_line(&program, name, value.as_ref());
                let reply = self.buf.ack(to, line.as_str());
                self.out.send(from, reply);
            }
            Err((code, text)) => self.reply_nak(from, to, code, &text),
        }
    }
}

/// Who asked, for a trace's reason.
fn source_label(from: SourceId) -> &'static str {
    match from.kind() {
        SourceId::TCP => "a host",
        SourceId::GUI => "the GUI",
        SourceId::PENDANT => "the pendant",
        _ => "the controller",
    }
}

#[cfg(test)]
mod tests {
    //! The service thread stepped by hand, with the test playing the Command Interpreter
    //! (its cell events) and a host (its requests) through the queues.

    use std::sync::atomic::Ordering;
    use std::sync::Arc;

    use wrc_config::{Config, HandConfig};
    use wrc_protocol::{ReplyTo, StationName};
    use wrc_rt::ipc::MessageQueue;

    use super::Service;
    use crate::cell_service::CellService;
    use crate::messages::cell_job::{CellEvent, JobKind, JobOffer, MAX_MAP_SLOTS};
    use crate::messages::{OutLine, Outputs, SourceId, StoreLinks, StoreRequest};
    use crate::shared::Shared;

    const HOST: SourceId = SourceId(0x1000_0001);

    struct Rig {
        service: Service,
        links: StoreLinks,
        network: Arc<MessageQueue<OutLine>>,
        shared: Arc<Shared>,
        _dir: tempfile::TempDir,
    }

    impl Rig {
        /// A service with the demo cell (every slot unknown), a homed robot at rest and the
        /// load ports' interlock (input 14) asserted.
        fn new() -> Rig {
            let dir = tempfile::tempdir().unwrap();
            let robot = Config::embedded_default().robot;
            let shared = Arc::new(Shared::default());
            shared.homed.store(true, Ordering::Release);
            shared.inputs[0].store(1 << 14, Ordering::Release);
            shared.io_ready.store(true, Ordering::Release);
            for (c, p) in shared
                .commanded
                .iter()
                .zip(robot.joints_to_pulses(&robot.home()))
            {
                c.store(p, Ordering::Release);
            }
            let cell = CellService::open(
                &robot,
                &dir.path().join("stations.toml"),
                &dir.path().join("wafers.toml"),
                shared.clone(),
                HandConfig::default(),
            )
            .unwrap();
            let links = StoreLinks::new();
            let network = Arc::new(MessageQueue::new(256));
            let out = Outputs {
                network: network.clone(),
                serial: Arc::new(MessageQueue::new(16)),
            };
            let service = Service::new(&dir.path().join("programs"), robot, links.clone(), out)
                .unwrap()
                .with_cell(cell);
            Rig {
                service,
                links,
                network,
                shared,
                _dir: dir,
            }
        }

        fn request(&self, request: StoreRequest) {
            self.links.requests.try_send(request).ok().unwrap();
        }

        fn wafers(&self, id: u32) {
            self.request(StoreRequest::Wafers {
                from: HOST,
                to: ReplyTo {
                    id: Some(id),
                    checksum: false,
                },
            });
        }

        /// The host's replies (events left out).
        fn replies(&self) -> Vec<String> {
            std::iter::from_fn(|| self.network.try_recv().ok())
                .map(|l| String::from_utf8_lossy(l.bytes()).trim_end().to_string())
                .filter(|l| !l.starts_with("EVT"))
                .collect()
        }
    }

    /// Regression (found by `wrc bench faults`, a transfer sent the moment `wrc up` said it
    /// was ready): before the I/O Monitor's first period the inputs read 0, and a GET was
    /// refused because the station's interlock "was closed" (135). Until the inputs are
    /// read, a transfer is asked to repeat (138), as while the map is reconciled.
    #[test]
    fn a_transfer_before_the_inputs_are_read_is_asked_to_repeat_not_refused_for_the_interlock() {
        let mut r = Rig::new();
        let mut codes = [0u8; MAX_MAP_SLOTS];
        codes[..25].fill(1);
        r.links
            .cell_events
            .try_send(CellEvent::Mapped {
                station_index: 0,
                count: 25,
                codes,
            })
            .ok()
            .unwrap();
        r.shared.io_ready.store(false, Ordering::Release);
        r.shared.inputs[0].store(0, Ordering::Release);
        let get = |r: &Rig, id: u32| {
            r.request(StoreRequest::Job {
                from: HOST,
                to: ReplyTo {
                    id: Some(id),
                    checksum: false,
                },
                kind: JobKind::Get,
                station: StationName::new("LP1").unwrap(),
                slot: 1,
                blade: wrc_cell::Blade::A,
            })
        };
        get(&r, 1);
        r.service.step();
        let replies = r.replies();
        assert!(replies[0].starts_with("NAK 1 138 "), "{replies:?}");
        assert!(r.links.jobs.try_recv().is_err(), "nothing handed over");
        // Read: the interlock is asserted, and the GET goes ahead.
        r.shared.inputs[0].store(1 << 14, Ordering::Release);
        r.shared.io_ready.store(true, Ordering::Release);
        get(&r, 2);
        r.service.step();
        assert!(r.replies().is_empty(), "the GET is not refused");
        assert!(matches!(r.links.jobs.try_recv(), Ok(JobOffer::Start(_))));
    }

    /// Pins the bug where `WAFERS` sent right after a job's `INF` could show the map from
    /// before the job: a step answered the queued requests before it applied the queued
    /// cell events, although the Command Interpreter had sent the map change first.
    #[test]
    fn a_request_sent_after_a_jobs_reply_sees_the_map_change_sent_before_that_reply() {
        let mut r = Rig::new();
        // MAP LP1: the Command Interpreter reports the scan and the job's end, then `INF`;
        // the host's WAFERS comes after the INF, and the service wakes to find both.
        let mut codes = [0u8; MAX_MAP_SLOTS];
        codes[..25].fill(1);
        let map = [
            CellEvent::Mapped {
                station_index: 0,
                count: 25,
                codes,
            },
            CellEvent::Ended {
                kind: JobKind::Map,
                started: true,
                code: None,
                sensed: [false, false],
            },
        ];
        for event in map {
            r.links.cell_events.try_send(event).ok().unwrap();
        }
        r.wafers(8);
        r.service.step();
        let replies = r.replies();
        assert!(
            replies[0].starts_with("ACK 8 hand=- LP1=W1..W25 LP2=?x25 "),
            "{replies:?}"
        );

        // GET LP1 3: planned and handed over; the Command Interpreter reports the commit and
        // the end, then `INF 20 W3`; the host asks WAFERS and then GETs again.
        r.request(StoreRequest::Job {
            from: HOST,
            to: ReplyTo {
                id: Some(20),
                checksum: false,
            },
            kind: JobKind::Get,
            station: StationName::new("LP1").unwrap(),
            slot: 3,
            blade: wrc_cell::Blade::A,
        });
        r.service.step();
        assert!(r.replies().is_empty(), "the GET is not refused");
        assert!(matches!(r.links.jobs.try_recv(), Ok(JobOffer::Start(_))));
        let get = [
            CellEvent::Commit,
            CellEvent::Ended {
                kind: JobKind::Get,
                started: true,
                code: None,
                sensed: [true, false],
            },
        ];
        for event in get {
            r.links.cell_events.try_send(event).ok().unwrap();
        }
        r.wafers(21);
        r.request(StoreRequest::Job {
            from: HOST,
            to: ReplyTo {
                id: Some(22),
                checksum: false,
            },
            kind: JobKind::Get,
            station: StationName::new("LP1").unwrap(),
            slot: 4,
            blade: wrc_cell::Blade::A,
        });
        r.service.step();
        let replies = r.replies();
        assert!(
            replies[0].starts_with("ACK 21 hand=W3 LP1=W1,W2,-,W4..W25 "),
            "{replies:?}"
        );
        assert!(replies[1].starts_with("NAK 22 133 "), "{replies:?}");
    }
}
