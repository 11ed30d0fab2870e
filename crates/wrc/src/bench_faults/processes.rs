//! `kill -9` of the campaign's processes: the simulated board under `wrc up
//! --restart-boards`, the GUI while it holds control, and the controller itself while its
//! board runs on.

use std::net::TcpStream;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Instant;

use anyhow::{bail, Context};
use tungstenite::Message;

use super::harness::{
    free_port, free_udp, kill9, poll, processes, Board, Lines, UpOptions, PATIENCE,
};
use super::kinds::{recover, STILL_PERIODS};
use super::session::Session;
use super::{Ctx, Round, Verdict};

/// A board of the campaign's own and a controller on it (restarted after a kill).
pub(crate) struct OwnCell {
    pub(super) board: Board,
    pub(super) session: Option<Session>,
    pub(super) options: UpOptions,
    pub(super) watchdog_periods: u32,
}

impl OwnCell {
    /// A board in `dir/board` and `wrc up --board` on it with its state in `dir/state`
    /// (`tmpfs`: on a tmpfs of its own, see [`super::harness::Tmpfs`]).
    pub(super) fn start(
        ctx: &Ctx,
        name: &str,
        tmpfs: Option<super::harness::Tmpfs>,
    ) -> anyhow::Result<OwnCell> {
        let dir = ctx.dir(name)?;
        let board_dir = dir.join("board");
        // Without SCHED_FIFO (or in a user namespace, where it is never allowed) the host
        // watchdog and the heartbeat are the ones `wrc up` gives its own boards then.
        let rt = ctx.rt && tmpfs.is_none();
        let config: Option<PathBuf> = (!rt).then(|| ctx.lenient_config.clone());
        let loaded = wrc_config::Config::load(config.as_deref())?;
        let watchdog_periods = loaded.boards.first().map_or(10, |b| b.watchdog_periods);
        let board = Board::start(&board_dir, config.as_deref(), watchdog_periods, rt)?;
        let options = UpOptions {
            state: dir.join("state"),
            config,
            board: Some(board.dpram.clone()),
            no_rt: !rt,
            tmpfs,
            ..UpOptions::default()
        };
        let session = Session::start(options.clone(), Some(&board_dir), false)?;
        Ok(OwnCell {
            board,
            session: Some(session),
            options,
            watchdog_periods,
        })
    }

    /// The controller session (started again when it was killed).
    pub(super) fn session(&mut self) -> anyhow::Result<&mut Session> {
        if self.session.is_none() {
            let dir = self.board.dpram.parent().map(PathBuf::from);
            self.session = Some(Session::start(self.options.clone(), dir.as_deref(), false)?);
        }
        self.session.as_mut().context("no session")
    }
}

/// `kill -9` of the board process during a transfer; `wrc up --restart-boards` starts it
/// again and RESET re-attaches it.
pub(super) fn board_kill(s: &mut Session, ctx: &mut Ctx) -> anyhow::Result<Round> {
    let state = s.options.state.clone();
    let line = s.next_transfer(ctx)?;
    let id = s.host.start(&line)?;
    let delay = ctx.delay(100, 2500);
    std::thread::sleep(delay);
    let mut round = Round::new(format!("{line}, {:.3} s in", delay.as_secs_f64()));
    let pid = *processes(&state, "board-sim")
        .first()
        .context("no board-sim process")?;
    let epoch = s.board()?.feedback().boards[0].epoch;
    let mark = s.host.lines.mark();
    let t0 = kill9(pid)?;
    let found = s
        .host
        .lines
        .find(mark, PATIENCE, |l| l.starts_with("EVT ERROR 300 "));
    if let Some((_, at, l)) = &found {
        round.detected(t0, *at, l);
    }
    let end = s
        .host
        .end_of(id, PATIENCE)
        .unwrap_or_else(|e| format!("{e:#}"));
    let stood = s.host.joints()?;
    // The board comes back (`--restart-boards`): it must stand where the arm stood, and the
    // controller must not have moved its commanded position meanwhile.
    let again = poll(PATIENCE, || {
        processes(&state, "board-sim")
            .into_iter()
            .find(|&p| p != pid)
    });
    let Some(_) = again else {
        round.stopped = Verdict::Fail("the board was not restarted".into());
        return Ok(round);
    };
    // Judged once the new process has taken the DPRAM over (a new epoch, its own count of
    // periods from 0).
    let board = s.board()?;
    poll(PATIENCE, || {
        (board.feedback().boards[0].epoch != epoch).then_some(())
    })
    .context("the restarted board did not take its DPRAM over")?;
    let from = board.feedback().boards[0].period_count;
    let at_rest = board.rest_after(from, 0, STILL_PERIODS).is_some();
    let still = s.host.joints()?;
    let mut stopped = vec![format!("the {line} ended `{end}`")];
    let mut ok = found.is_some() && end.starts_with("ABS") && at_rest && still == stood;
    if still != stood {
        stopped.push(format!(
            "the controller's position moved from {stood:?} to {still:?} with the board dead"
        ));
    }
    stopped.push(if at_rest {
        "the restarted board stands still".into()
    } else {
        "the restarted board moves".into()
    });
    round.recovered = match s.host.reset(PATIENCE) {
        Ok(()) => Verdict::Pass("RESET (re-attach)".into()),
        Err(r) => Verdict::Fail(format!("RESET refused: {r}")),
    };
    if round.recovered.is_pass() {
        // Re-attached where the board's encoders are: the arm did not jump.
        let f = board.feedback();
        let joints = s.host.joints()?;
        let config = wrc_config::Config::embedded_default();
        let off = joints
            .iter()
            .zip(config.robot.axes())
            .zip(&f.axes[..f.axis_count])
            .map(|((j, a), fb)| (a.units_to_pulses(*j) - fb.encoder).abs())
            .max()
            .unwrap_or(0);
        if off > 2 {
            ok = false;
            stopped.push(format!(
                "re-attached {off} pulses away from the board's encoders"
            ));
        } else {
            stopped.push("re-attached at the board's encoders".into());
        }
    }
    round.stopped = Verdict::from(ok, stopped.join("; "));
    let check = s.check_map();
    round.consistent = Verdict::from(
        check.problems.is_empty(),
        if check.problems.is_empty() {
            "WAFERS = wafers.toml = the cell, wafer by wafer".into()
        } else {
            check.problems.join("; ")
        },
    );
    if round.recovered.is_pass() {
        round.recovered = recover(s, ctx, false);
    }
    Ok(round)
}

/// A browser of `wrc ui`: a WebSocket client sending request lines.
struct Browser {
    ws: tungstenite::WebSocket<TcpStream>,
    next_id: u32,
}

impl Browser {
    fn connect(port: u16) -> anyhow::Result<Browser> {
        let stream = poll(PATIENCE, || TcpStream::connect(("127.0.0.1", port)).ok())
            .context("wrc ui does not accept connections")?;
        stream.set_read_timeout(Some(PATIENCE))?;
        let (mut ws, _) = tungstenite::client(format!("ws://127.0.0.1:{port}/ws").as_str(), stream)
            .context("WebSocket handshake with wrc ui")?;
        // As the web app does: requests only once the GUI has reached the controller.
        loop {
            if let Message::Text(t) = ws.read().context("wrc ui never reached the controller")? {
                if t.as_str().starts_with("EVT UI CONNECTED") {
                    return Ok(Browser { ws, next_id: 1 });
                }
            }
        }
    }

    /// Send `line` and fail unless it is accepted.
    fn ask(&mut self, line: &str) -> anyhow::Result<()> {
        let id = self.next_id;
        self.next_id += 1;
        self.ws.send(Message::Text(format!("{id} {line}").into()))?;
        let deadline = Instant::now() + PATIENCE;
        let mut seen = Vec::new();
        while Instant::now() < deadline {
            let message = self.ws.read().with_context(|| {
                format!("no reply to the GUI's `{line}`; it received: {seen:?}")
            })?;
            if let Message::Text(t) = message {
                let t = t.as_str();
                if t.starts_with(&format!("ACK {id}")) {
                    return Ok(());
                }
                if t.starts_with(&format!("NAK {id} ")) {
                    bail!("the GUI's `{line}` was refused: {t}");
                }
                seen.push(t.to_string());
            }
        }
        bail!("no reply to the GUI's `{line}`; it received: {seen:?}")
    }
}

/// `kill -9` of `wrc ui` while its browser holds control and runs a transfer.
pub(super) fn gui_kill(s: &mut Session, ctx: &mut Ctx) -> anyhow::Result<Round> {
    let port = free_port()?;
    let mut ui = Command::new(super::harness::exe()?)
        .arg("ui")
        .arg("--controller")
        .arg(&s.up.socket)
        .args(["--sim-addr", &free_udp()?])
        .args(["--ui-port", &port.to_string()])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .context("cannot start wrc ui")?;
    let out = Lines::spawn(ui.stdout.take().context("no stdout")?);
    let result = (|| -> anyhow::Result<Round> {
        out.find(0, PATIENCE, |l| l.starts_with("wrc ui: GUI on"))
            .context("wrc ui did not start")?;
        let mut browser = Browser::connect(port)?;
        browser.ask("CONTROL")?;
        let line = s.next_transfer(ctx)?;
        browser.ask(&line)?;
        let delay = ctx.delay(100, 2500);
        std::thread::sleep(delay);
        let mut round = Round::new(format!("{line}, {:.3} s in", delay.as_secs_f64()));
        let mark = s.host.lines.mark();
        let t0 = Instant::now();
        ui.kill()?;
        let _ = ui.wait();
        drop(browser);
        super::lines::after_lost_owner(s, ctx, &mut round, mark, t0);
        Ok(round)
    })();
    let _ = ui.kill();
    let _ = ui.wait();
    result
}

/// `kill -9` of `wrc up` during a transfer while its board runs on: the board's host
/// watchdog must stop the arm within its stated periods; a new `wrc up --board` on the
/// same state directory settles the map and, after RESET, carries on.
pub(super) fn controller_kill(ctx: &mut Ctx, own: &mut Option<OwnCell>) -> anyhow::Result<Round> {
    if own.is_none() {
        *own = Some(OwnCell::start(ctx, "controller-kill", None)?);
    }
    let cell = own.as_mut().context("no cell")?;
    let watchdog = u64::from(cell.watchdog_periods);
    let s = cell.session()?;
    let line = s.next_transfer(ctx)?;
    s.host.start(&line)?;
    let delay = ctx.delay(100, 2500);
    std::thread::sleep(delay);
    let mut round = Round::new(format!("{line}, {:.3} s in", delay.as_secs_f64()));
    let board = s.board()?;
    let before = board.feedback().boards[0];
    let t0 = s.up.kill9();
    let trip = poll(PATIENCE, || {
        let f = board.feedback().boards[0];
        (f.watchdog_trips > before.watchdog_trips).then_some((Instant::now(), f.period_count))
    });
    let mut tripped_in = None;
    if let Some((at, period)) = trip {
        let periods = period.saturating_sub(before.period_count);
        tripped_in = Some(periods);
        round.detected(
            t0,
            at,
            &format!("the board's host watchdog tripped {periods} board periods after the kill"),
        );
    }
    // The board's FIFO runs dry a few periods after the kill (the axes hold where the last
    // pushed period left them); the watchdog then latches the stop. Both are counted in
    // the board's own periods from the kill.
    let bound = watchdog + 2 + super::kinds::brake_bound_periods();
    let rest = board.rest_after(before.period_count, bound, STILL_PERIODS);
    round.stopped = match (tripped_in, rest) {
        (Some(p), Some(at)) => Verdict::from(
            p <= watchdog + 2,
            format!(
                "at rest on the board {} periods after the kill; the watchdog tripped after {p} (watchdog_periods {watchdog}, +2 for the refresh in flight)",
                at.saturating_sub(before.period_count)
            ),
        ),
        (None, _) => Verdict::Fail("the board's watchdog never tripped".into()),
        (Some(p), None) => Verdict::Fail(format!(
            "the watchdog tripped after {p} periods, but the arm still moved {bound} periods after the kill"
        )),
    };
    // A new controller on the same state directory and board.
    let tracking = cell.session.take().map(|s| s.tracking.clone());
    let restarted = cell.session();
    round.recovered = match &restarted {
        Ok(_) => Verdict::Pass("wrc up --board again, RESET, HOME".into()),
        Err(e) => Verdict::Fail(format!("wrc up again: {e:#}")),
    };
    let Ok(s) = restarted else {
        return Ok(round);
    };
    if let Some(t) = tracking {
        s.tracking = t;
    }
    let check = s.check_map();
    round.consistent = Verdict::from(
        check.problems.is_empty(),
        if check.problems.is_empty() {
            "WAFERS = wafers.toml = the cell after the restart, wafer by wafer".into()
        } else {
            check.problems.join("; ")
        },
    );
    round.recovered = match recover(s, ctx, false) {
        Verdict::Pass(t) => Verdict::Pass(format!("wrc up --board again, RESET, HOME; {t}")),
        other => other,
    };
    Ok(round)
}
