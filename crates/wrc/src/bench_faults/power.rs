//! A power loss: `kill -9` of the simulated board and of `wrc up` together during a GET or
//! PUT, then `wrc up` again on the same state directory, whose board powers up where the
//! arm stood with every output off (`wrc board-sim --power-up`: the vacuum lets go, a held
//! wafer drops where the hand is). Judged as an operator finds the cell and brings it back:
//! what the controller says (`RECOVERY`, alarm 216), whether its map claims a wafer the
//! cell does not hold or forgets one it holds (before anything is resolved), whether the
//! recovery — RESET, HOME (straight out of a station first), SENSE, MAP — moves the hand
//! sideways through a station's side, and whether the map then equals the cell exactly.

use std::time::Instant;

use anyhow::Context;
use wrc_protocol::reply_field;

use super::harness::{check_map_with, kill9, poll, processes, read_world, UpOptions, PATIENCE};
use super::session::{Session, STATION, WAFERS};
use super::{Ctx, Round, Verdict};

/// One power-loss round on the campaign's own cell for it (started at the first round).
pub(super) fn power_loss(ctx: &mut Ctx, own: &mut Option<Session>) -> anyhow::Result<Round> {
    let mut s = match own.take() {
        Some(s) => s,
        None => {
            let options = UpOptions {
                state: ctx.dir("power-loss")?,
                no_rt: !ctx.rt,
                ..UpOptions::default()
            };
            Session::start(options, None, false)?
        }
    };
    let line = s.next_transfer(ctx)?;
    s.host.start(&line)?;
    let delay = ctx.delay(200, 3800);
    std::thread::sleep(delay);
    let mut round = Round::new(format!("{line}, {:.3} s in", delay.as_secs_f64()));
    // The power goes: the board (the arm freezes where it is) and the controller at once.
    let state = s.options.state.clone();
    let boards = processes(&state, "board-sim");
    anyhow::ensure!(
        !boards.is_empty(),
        "no board-sim process in {}",
        state.display()
    );
    for pid in &boards {
        kill9(*pid)?;
    }
    s.up.kill9();
    poll(PATIENCE, || {
        boards
            .iter()
            .all(|p| super::harness::zombie(*p))
            .then_some(())
    })
    .context("the board processes did not die")?;
    let tracking = std::mem::take(&mut s.tracking);
    let options = s.options.clone();
    drop(s);
    // The power comes back.
    let t0 = Instant::now();
    let mut s = Session::start_unprepared(options, None, false)?;
    s.tracking = tracking;
    let settled = poll(PATIENCE, || {
        let w = s.host.wafers().ok()??;
        (!w.contains("pending=")).then_some(w)
    });
    settled.context("the wafer map did not settle after the restart")?;
    let recovery = s.host.ask("RECOVERY")?;
    let at = Instant::now();
    let status = s.host.ask("STATUS")?;
    let uncertain: usize = reply_field(&recovery, "uncertain")
        .and_then(|n| n.parse().ok())
        .context("RECOVERY without uncertain=")?;
    let inside = reply_field(&recovery, "inside").unwrap_or("?").to_string();
    let alarm = status.contains("err=216");
    let said = format!(
        "{recovery}; {}",
        if alarm { "alarm 216" } else { "no alarm" }
    );
    // Anything uncertain, or the hand inside a station, is said with alarm 216; a transfer
    // the journal settled leaves nothing to say.
    let told = alarm == (uncertain > 0 || inside != "-");
    if told {
        round.detected(t0, at, &said);
    } else {
        round.signal = format!("alarm 216 not as RECOVERY says: {said}");
    }
    // Before anything is resolved: no certain wafer where the cell has none, none forgotten.
    let (wafers_file, world_file) = (s.wafers_file(), s.world.clone());
    let claims = check_map_with(
        &mut s.host,
        &wafers_file,
        &world_file,
        &mut s.tracking,
        WAFERS,
        true,
    );
    let sides = read_world(&world_file)?.side_collisions();
    // The operator's recovery.
    let steps = recover_after_power_loss(&mut s);
    let world = read_world(&world_file)?;
    let hit = world.side_collisions() - sides;
    round.stopped = Verdict::from(
        hit == 0,
        match (hit, inside.as_str()) {
            (0, "-") => {
                "the hand stood outside every station; HOME went by PTP, no side hit".into()
            }
            (0, st) => {
                format!("the hand stood inside {st}; HOME took it straight out first, no side hit")
            }
            (n, _) => format!(
                "{n} side collision(s) during the recovery: {:?}",
                world.last_side_collision()
            ),
        },
    );
    let exact = s.check_map();
    let recovered = s.host.ask("RECOVERY").unwrap_or_else(|e| format!("{e:#}"));
    let mut problems: Vec<String> = claims
        .problems
        .iter()
        .map(|p| format!("after the restart: {p}"))
        .collect();
    problems.extend(
        exact
            .problems
            .iter()
            .map(|p| format!("after the recovery: {p}")),
    );
    if !recovered.contains("uncertain=0 inside=-") {
        problems.push(format!("after the recovery: {recovered}"));
    }
    round.consistent = Verdict::from(
        problems.is_empty(),
        if problems.is_empty() {
            format!("{uncertain} uncertain after the restart, no wrong claim, none forgotten; after the recovery WAFERS = wafers.toml = the cell")
        } else {
            problems.join("; ")
        },
    );
    round.recovered = match steps {
        Ok(done) => match super::kinds::recover(&mut s, ctx, false) {
            Verdict::Pass(t) => Verdict::Pass(format!("{done}; {t}")),
            other => other,
        },
        Err(e) => Verdict::Fail(format!("{e:#}")),
    };
    *own = Some(s);
    Ok(round)
}

/// RESET (the alarm), HOME, SENSE, and MAP of the load port: what docs/protocol.md's
/// "After a power loss" tells an operator to do; what was done.
fn recover_after_power_loss(s: &mut Session) -> anyhow::Result<String> {
    s.host
        .reset(PATIENCE)
        .map_err(|e| anyhow::anyhow!("RESET refused: {e}"))?;
    s.host.run_ok("HOME")?;
    let sense = s.host.run_ok("SENSE")?;
    s.host.run_ok(&format!("MAP {STATION}"))?;
    let sensed = sense.split_whitespace().nth(2).unwrap_or("?").to_string();
    Ok(format!("RESET, HOME, SENSE ({sensed}), MAP {STATION}"))
}
