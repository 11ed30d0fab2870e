//! The fault kinds of the campaign, what each round judges, and the faults the simulated
//! board plays through its fault mailbox (E-stop, vacuum loss, following error).

use std::path::Path;
use std::time::Duration;

use anyhow::Context;
use rand::Rng;
use wrc_board::Fault;
use wrc_config::Config;

use super::harness::{read_world, BoardView, UpOptions, PATIENCE};
use super::session::Session;
use super::{Ctx, Round, Verdict};

/// A kind of fault the campaign injects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Estop,
    VacuumLoss,
    FollowingError,
    ClientDrop,
    SerialGarbage,
    BoardKill,
    GuiKill,
    SerialUnplug,
    ControllerKill,
    DiskFull,
    ReadOnly,
    CorruptWafers,
    CorruptStations,
    PowerLoss,
}

impl Kind {
    /// Every kind, in the campaign's order (those sharing one controller first).
    pub(crate) const ALL: [Kind; 14] = [
        Kind::Estop,
        Kind::VacuumLoss,
        Kind::FollowingError,
        Kind::ClientDrop,
        Kind::SerialGarbage,
        Kind::BoardKill,
        Kind::GuiKill,
        Kind::SerialUnplug,
        Kind::ControllerKill,
        Kind::DiskFull,
        Kind::ReadOnly,
        Kind::CorruptWafers,
        Kind::CorruptStations,
        Kind::PowerLoss,
    ];

    /// Its name on the command line and in the table.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Kind::Estop => "estop",
            Kind::VacuumLoss => "vacuum-loss",
            Kind::FollowingError => "following-error",
            Kind::ClientDrop => "client-drop",
            Kind::SerialGarbage => "serial-garbage",
            Kind::BoardKill => "board-kill",
            Kind::GuiKill => "gui-kill",
            Kind::SerialUnplug => "serial-unplug",
            Kind::ControllerKill => "controller-kill",
            Kind::DiskFull => "disk-full",
            Kind::ReadOnly => "read-only",
            Kind::CorruptWafers => "corrupt-wafers",
            Kind::CorruptStations => "corrupt-stations",
            Kind::PowerLoss => "power-loss",
        }
    }

    /// How it is injected and how each property is judged.
    pub(crate) fn about(self) -> &'static str {
        match self {
            Kind::Estop => "the E-stop input opens (fault mailbox `estop on`) during a GET or PUT; signal EVT ERROR 202; stopped: the arm at rest on the board within the brake bound, no side collision in the simulated cell; `estop off`, RESET, the next transfer",
            Kind::VacuumLoss => "the vacuum sensor drops (`sensor-flip` of the vacuum input) while the hand carries a wafer on a MOVJ; signal EVT ERROR 213; stopped: at rest on the board, no side collision; the sensor restored, RESET, SENSE (the wafer stays uncertain until then), the next transfer",
            Kind::FollowingError => "an encoder sticks (`encoder-stuck`, J1 or J3) during a MOVJ; signal EVT ERROR 203; stopped: at rest on the board, no side collision; the encoder freed, RESET, a MOVJ",
            Kind::ClientDrop => "a client that took CONTROL and started a GET or PUT closes its socket; signal EVT ERROR 208 to another client; stopped: at rest on the board, no side collision; RESET, the next transfer",
            Kind::SerialGarbage => "random bytes (up to 600, seeded) on the pendant's serial line (a pty) during a GET or PUT from TCP; signal a NAK on the serial line; the transfer must carry on to its INF, no side collision; the pendant answers STATUS afterwards",
            Kind::BoardKill => "kill -9 of `wrc board-sim` during a GET or PUT (`wrc up --restart-boards`); signal EVT ERROR 300; stopped: the controller sends nothing more and the restarted board stands where the arm stood, no side collision; RESET (re-attach), the next transfer",
            Kind::GuiKill => "kill -9 of `wrc ui` while its browser (a WebSocket client) holds CONTROL and runs a GET or PUT; signal EVT ERROR 208; stopped: at rest on the board, no side collision; RESET, the next transfer",
            Kind::SerialUnplug => "the pendant's line is unplugged (the pty closed) while the pendant holds CONTROL and runs a GET or PUT; signal EVT ERROR 208; stopped: at rest on the board, no side collision; RESET from TCP, the next transfer",
            Kind::ControllerKill => "kill -9 of `wrc up` during a GET or PUT (the board runs on its own); signal: the board's host watchdog trips (DPRAM), judged against its `watchdog_periods`; stopped: at rest within the brake bound; `wrc up --board` again, RESET, the next transfer",
            Kind::DiskFull => "the state directory's tmpfs (own user+mount namespace) filled during a GET or PUT; signal `cannot save the wafer map` on the log or NAK 301; stopped: no transfer starts (NAK 301) and TEACH (at PM2's seat, entered and left along its line) is refused, no side collision; wafers.toml and stations.toml byte-identical; space freed, the next transfer",
            Kind::ReadOnly => "the state directory remounted read-only during a GET or PUT; as disk-full",
            Kind::CorruptWafers => "wafers.toml corrupted (seeded: cut at a byte or at a line's end, bytes overwritten, a garbage line, zeroed) before `wrc up` starts; signal: it refuses to start (exit ≠ 0) naming the file; the file byte-identical, no process left; the file restored, `wrc up` starts with the same map",
            Kind::CorruptStations => "stations.toml corrupted likewise before `wrc up` starts; as corrupt-wafers",
            Kind::PowerLoss => "kill -9 of `wrc board-sim` and `wrc up` together during a GET or PUT (a power cut), then `wrc up` again (its board powers up where the arm stood, every output off); signal: RECOVERY and alarm 216 say what is uncertain and whether the hand is inside a station; consistent: right after the restart the map claims no wafer the cell does not hold where it says and forgets none, and after the recovery it equals the cell with nothing uncertain; stopped: the recovery's HOME makes no side collision; RESET, HOME, SENSE, MAP LP1, the next transfer",
        }
    }

    /// The code of the `EVT ERROR` the controller raises for it, if it raises one.
    fn code(self) -> Option<&'static str> {
        match self {
            Kind::Estop => Some("202"),
            Kind::VacuumLoss => Some("213"),
            Kind::FollowingError => Some("203"),
            Kind::ClientDrop | Kind::GuiKill | Kind::SerialUnplug => Some("208"),
            Kind::BoardKill => Some("300"),
            Kind::SerialGarbage
            | Kind::ControllerKill
            | Kind::DiskFull
            | Kind::ReadOnly
            | Kind::CorruptWafers
            | Kind::CorruptStations
            | Kind::PowerLoss => None,
        }
    }

    /// Whether it runs on the campaign's shared controller session.
    fn shared(self) -> bool {
        matches!(
            self,
            Kind::Estop
                | Kind::VacuumLoss
                | Kind::FollowingError
                | Kind::ClientDrop
                | Kind::SerialGarbage
                | Kind::BoardKill
                | Kind::GuiKill
                | Kind::SerialUnplug
        )
    }
}

/// Board periods in a row without a pulse or an encoder count that make "at rest".
pub(super) const STILL_PERIODS: u64 = 20;

/// Board periods within which a stop must have brought the arm to rest: the longest
/// time-optimal brake of any axis from its full speed (v/a + a/j), the FIFO's look-ahead and
/// a few periods for the servo lag to settle.
pub(super) fn brake_bound_periods() -> u64 {
    let config = Config::embedded_default();
    let brake_s = config
        .robot
        .axes()
        .iter()
        .map(|a| {
            let l = a.limits;
            l.max_velocity / l.max_acceleration + l.max_acceleration / l.max_jerk
        })
        .fold(0.0, f64::max);
    let fifo = config.boards.first().map_or(8, |b| u64::from(b.fifo_depth));
    (brake_s / config.motion.period_s).ceil() as u64 + fifo + 5
}

/// Judge "stopped safely" on the board: the arm at rest within the brake bound of the
/// board period `from`.
pub(super) fn judge_rest(board: &BoardView, from: u64) -> Verdict {
    let bound = brake_bound_periods();
    match board.rest_after(from, bound, STILL_PERIODS) {
        Some(at) => Verdict::Pass(format!(
            "at rest on the board {} periods after the signal (bound {bound})",
            at.saturating_sub(from)
        )),
        None => Verdict::Fail(format!(
            "still moving on the board {bound} periods after the signal"
        )),
    }
}

/// `stopped`, unless the simulated cell of the world file `world` has counted more side
/// collisions than `before`: an arm that touched a station off its line, or an obstacle,
/// did not stop safely. (The board writes the file a moment after each change; a round
/// reads it after the arm has come to rest and the map has been compared with it.)
pub(super) fn untouched(stopped: Verdict, world: &Path, before: u32) -> Verdict {
    match read_world(world) {
        Ok(w) if w.side_collisions() <= before => stopped,
        Ok(w) => {
            let seen = match stopped {
                Verdict::Pass(t) | Verdict::Fail(t) => t,
                Verdict::NotReached => "not reached".into(),
            };
            Verdict::Fail(format!(
                "{} side collision(s) in the simulated cell, the latest at {}; {seen}",
                w.side_collisions() - before,
                w.last_side_collision()
                    .map_or_else(|| "?".to_string(), |n| n.to_string())
            ))
        }
        Err(e) => Verdict::Fail(format!("the simulated cell could not be read: {e:#}")),
    }
}

/// Run `rounds` rounds of `kind`; the rounds, and why any were not run.
pub(super) fn run(
    kind: Kind,
    ctx: &mut Ctx,
    rounds: u32,
    shared: &mut Option<Session>,
) -> (Vec<Round>, Option<String>) {
    if kind.shared() && shared.is_none() {
        match start_shared(ctx) {
            Ok(s) => *shared = Some(s),
            Err(e) => return (Vec::new(), Some(format!("set-up failed: {e:#}"))),
        }
    }
    let mut out = Vec::new();
    let mut skipped = None;
    let mut own = None;
    let mut power = None;
    for _ in 0..rounds {
        if ctx.out_of_time() {
            skipped = Some(format!(
                "{} of {rounds} rounds not run: the campaign's time ran out",
                rounds as usize - out.len()
            ));
            break;
        }
        let round = match kind {
            Kind::Estop | Kind::VacuumLoss | Kind::FollowingError => {
                with_shared(kind, shared, ctx, |s, ctx| board_fault_round(kind, s, ctx))
            }
            Kind::ClientDrop => with_shared(kind, shared, ctx, super::lines::client_drop),
            Kind::SerialGarbage => with_shared(kind, shared, ctx, super::lines::serial_garbage),
            Kind::SerialUnplug => with_shared(kind, shared, ctx, super::lines::serial_unplug),
            Kind::BoardKill => with_shared(kind, shared, ctx, super::processes::board_kill),
            Kind::GuiKill => with_shared(kind, shared, ctx, super::processes::gui_kill),
            Kind::ControllerKill => super::processes::controller_kill(ctx, &mut own),
            Kind::DiskFull => super::disk::disk_round(ctx, &mut own, false),
            Kind::ReadOnly => super::disk::disk_round(ctx, &mut own, true),
            Kind::CorruptWafers => super::disk::corrupt_round(ctx, "wafers.toml", shared),
            Kind::CorruptStations => super::disk::corrupt_round(ctx, "stations.toml", shared),
            Kind::PowerLoss => super::power::power_loss(ctx, &mut power),
        };
        match round {
            Ok(r) => out.push(r),
            Err(e) => {
                skipped = Some(format!("set-up failed: {e:#}"));
                break;
            }
        }
    }
    (out, skipped)
}

/// The campaign's shared controller: `wrc up` with its own simulated board and cell,
/// `--restart-boards`, a pendant on a pty.
fn start_shared(ctx: &mut Ctx) -> anyhow::Result<Session> {
    let n = std::fs::read_dir(&ctx.root)?.count();
    let options = UpOptions {
        state: ctx.dir(&format!("shared-{n}"))?,
        restart_boards: true,
        no_rt: !ctx.rt,
        ..UpOptions::default()
    };
    Session::start(options, None, true)
}

/// Run a round on the shared session. A round that fails mid-way leaves the session as it
/// can: faults cleared, RESET; a session that does not answer any more is started again.
fn with_shared(
    kind: Kind,
    shared: &mut Option<Session>,
    ctx: &mut Ctx,
    round: impl FnOnce(&mut Session, &mut Ctx) -> anyhow::Result<Round>,
) -> anyhow::Result<Round> {
    let s = shared.as_mut().context("no shared session")?;
    let (host, log) = (s.host.lines.clone(), s.up.log.clone());
    let (host_mark, log_mark) = (host.mark(), log.mark());
    let world = s.world.clone();
    let touched = read_world(&world)?.side_collisions();
    let r = round(s, ctx).map(|mut r| {
        r.stopped = untouched(r.stopped, &world, touched);
        r.transcript = host.since(host_mark);
        r.disturbed = r
            .transcript
            .iter()
            .filter(|l| l.starts_with("EVT ERROR ") && l.split_whitespace().nth(2) != kind.code())
            .cloned()
            .collect();
        r.transcript
            .extend(log.since(log_mark).into_iter().map(|l| format!("log: {l}")));
        r
    });
    let healthy = shared.as_mut().is_some_and(|s| heal(s).is_ok());
    if !healthy {
        let old = shared.take().context("no shared session")?;
        // Parked and started again; a controller that cannot be is replaced by a fresh one
        // in a fresh cell (its board would otherwise start with the hand's wafer lost).
        let s = match old.restart() {
            Ok(s) => s,
            Err(_) => start_shared(ctx)?,
        };
        *shared = Some(s);
    }
    r
}

/// Clear injected faults, restore a pendant, RESET if needed: the session as the next
/// round expects it.
fn heal(s: &mut Session) -> anyhow::Result<()> {
    if s.up.pid() == 0 || s.host.lines.is_closed() {
        anyhow::bail!("the controller is gone");
    }
    if let Ok(board) = s.board() {
        let _ = board.inject(Fault::Clear);
    }
    if s.host.state()? != "IDLE" {
        s.host
            .reset(Duration::from_secs(10))
            .map_err(|e| anyhow::anyhow!("RESET refused: {e}"))?;
    }
    if s.pendant.is_none() {
        anyhow::bail!("the pendant is unplugged");
    }
    Ok(())
}

/// `MOVJ` targets far apart in J1, J3 and Z (120°, 120°, 80 mm), for the moves faults fall
/// into. The arm is folded (J2 150°): the hand, and a wafer on it, stay within about 255 mm
/// of the base, short of every station of the demo cell (their boxes begin 270-315 mm out)
/// at any height, so the move goes straight from a transfer's end or from the other target,
/// and so does any brake along it.
const FAR_POSES: [&str; 2] = ["MOVJ 60 150 -90 100", "MOVJ -60 150 30 20"];

/// The one of [`FAR_POSES`] farther from the arm.
pub(super) fn far_move(s: &mut Session) -> anyhow::Result<&'static str> {
    let j = s.host.joints()?;
    Ok(if j.first().copied().unwrap_or(0.0) > 0.0 {
        FAR_POSES[1]
    } else {
        FAR_POSES[0]
    })
}

/// E-stop, vacuum loss, following error: a fault the board plays, injected at a random
/// moment into a transfer or a move; the `EVT ERROR` the controller must raise.
fn board_fault_round(kind: Kind, s: &mut Session, ctx: &mut Ctx) -> anyhow::Result<Round> {
    let config = Config::embedded_default();
    let vacuum_input = config.hand.vacuum_input;
    let board = s.board()?;
    let (fault, clear, code, line, delay) = match kind {
        Kind::Estop => {
            let line = s.next_transfer(ctx)?;
            (
                Fault::Estop { on: true },
                Fault::Estop { on: false },
                202,
                line,
                ctx.delay(100, 2500),
            )
        }
        Kind::VacuumLoss => {
            // A wafer on the hand, carried on a long move.
            let wafers = s.host.wafers()?.unwrap_or_default();
            if !wrc_protocol::reply_field(&wafers, "hand").is_some_and(|h| h.starts_with('W')) {
                let get = s.next_transfer(ctx)?;
                s.host.run_ok(&get)?;
            }
            (
                Fault::SensorFlip {
                    input: vacuum_input,
                    on: true,
                },
                Fault::SensorFlip {
                    input: vacuum_input,
                    on: false,
                },
                213,
                far_move(s)?.to_string(),
                ctx.delay(50, 500),
            )
        }
        Kind::FollowingError => {
            // J1 or J3, which turn 120° on these moves.
            let axis = if ctx.rng.random_bool(0.5) { 0 } else { 2 };
            (
                Fault::EncoderStuck { axis, on: true },
                Fault::EncoderStuck { axis, on: false },
                203,
                far_move(s)?.to_string(),
                ctx.delay(50, 450),
            )
        }
        _ => anyhow::bail!("{} is not a board fault", kind.name()),
    };
    let id = s.host.start(&line)?;
    std::thread::sleep(delay);
    let mut round = Round::new(format!(
        "{line}, {:.3} s in, \"{fault}\"",
        delay.as_secs_f64()
    ));
    let mark = s.host.lines.mark();
    let t0 = board.inject(fault)?;
    let signal = format!("EVT ERROR {code} ");
    let found = s
        .host
        .lines
        .find(mark, PATIENCE, |l| l.starts_with(&signal));
    let from = board.feedback().boards[0].period_count;
    if let Some((_, at, l)) = &found {
        round.detected(t0, *at, l);
    }
    let end = s
        .host
        .end_of(id, PATIENCE)
        .unwrap_or_else(|e| format!("{e:#}"));
    round.stopped = match judge_rest(&board, from) {
        Verdict::Pass(t) => Verdict::from(
            found.is_some() && end.starts_with("ABS"),
            format!("{t}; the {line} ended `{end}`"),
        ),
        other => other,
    };
    board.inject(clear)?;
    round.recovered = match s.host.reset(Duration::from_secs(10)) {
        Ok(()) => Verdict::Pass("RESET".into()),
        Err(r) => Verdict::Fail(format!("RESET refused: {r}")),
    };
    if kind == Kind::VacuumLoss && round.recovered.is_pass() {
        // RESET clears the alarm, not the uncertain wafer: the sensor, read with the valve
        // on, settles it (the wafer is still held; the sensor answers again).
        round.recovered = match s.host.run("SENSE") {
            Ok(end) if end.starts_with("INF") => Verdict::Pass(format!("RESET, SENSE: {end}")),
            Ok(end) => Verdict::Fail(format!("RESET, then SENSE: {end}")),
            Err(e) => Verdict::Fail(format!("RESET, then SENSE: {e:#}")),
        };
    }
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
        round.recovered = recover(s, ctx, kind == Kind::FollowingError);
    }
    Ok(round)
}

/// After RESET: the next transfer (or a move) must end with `INF`.
pub(super) fn recover(s: &mut Session, ctx: &mut Ctx, with_move: bool) -> Verdict {
    let line = if with_move {
        far_move(s).map(str::to_string)
    } else {
        s.next_transfer(ctx)
    };
    let line = match line {
        Ok(l) => l,
        Err(e) => return Verdict::Fail(format!("{e:#}")),
    };
    match s.host.run(&line) {
        Ok(end) => Verdict::from(
            end.starts_with("INF"),
            format!("RESET, then `{line}`: {end}"),
        ),
        Err(e) => Verdict::Fail(format!("RESET, then `{line}`: {e:#}")),
    }
}
