//! Faults on the lines to the controller: a controlling TCP client that drops mid-command,
//! garbage on the pendant's serial line, the serial line unplugged.

use std::net::{Shutdown, TcpStream};
use std::time::Instant;

use rand::Rng;

use super::harness::{Conn, PATIENCE};
use super::kinds::{judge_rest, recover};
use super::session::Session;
use super::{Ctx, Round, Verdict};

/// The map check's verdict.
fn map_verdict(s: &mut Session) -> Verdict {
    let check = s.check_map();
    Verdict::from(
        check.problems.is_empty(),
        if check.problems.is_empty() {
            "WAFERS = wafers.toml = the cell, wafer by wafer".into()
        } else {
            check.problems.join("; ")
        },
    )
}

/// After a lost controlling source: `EVT ERROR 208` to the host, the arm at rest, RESET,
/// the map, the next transfer.
pub(super) fn after_lost_owner(
    s: &mut Session,
    ctx: &mut Ctx,
    round: &mut Round,
    mark: usize,
    t0: Instant,
) {
    let board = match s.board() {
        Ok(b) => b,
        Err(e) => {
            round.error = Some(format!("{e:#}"));
            return;
        }
    };
    let found = s
        .host
        .lines
        .find(mark, PATIENCE, |l| l.starts_with("EVT ERROR 208 "));
    let from = board.feedback().boards[0].period_count;
    if let Some((_, at, l)) = &found {
        round.detected(t0, *at, l);
    }
    round.stopped = judge_rest(&board, from);
    round.recovered = match s.host.reset(std::time::Duration::from_secs(10)) {
        Ok(()) => Verdict::Pass("RESET".into()),
        Err(r) => Verdict::Fail(format!("RESET refused: {r}")),
    };
    round.consistent = map_verdict(s);
    if round.recovered.is_pass() {
        round.recovered = recover(s, ctx, false);
    }
}

/// A client takes CONTROL, starts the next transfer and closes its socket at a random
/// moment.
pub(super) fn client_drop(s: &mut Session, ctx: &mut Ctx) -> anyhow::Result<Round> {
    let stream = TcpStream::connect(("127.0.0.1", s.up.port))?;
    stream.set_nodelay(true)?;
    let mut owner = Conn::on(Box::new(stream.try_clone()?), stream.try_clone()?);
    owner.ask("CONTROL")?;
    let line = s.next_transfer(ctx)?;
    owner.start(&line)?;
    let delay = ctx.delay(100, 2500);
    std::thread::sleep(delay);
    let mut round = Round::new(format!("{line}, {:.3} s in", delay.as_secs_f64()));
    let mark = s.host.lines.mark();
    let t0 = Instant::now();
    stream.shutdown(Shutdown::Both)?;
    drop(owner);
    after_lost_owner(s, ctx, &mut round, mark, t0);
    Ok(round)
}

/// Random bytes, in lines of random length, some longer than a request may be.
fn garbage(ctx: &mut Ctx) -> Vec<u8> {
    let n = ctx.rng.random_range(1..=600usize);
    let mut bytes: Vec<u8> = (0..n).map(|_| ctx.rng.random::<u8>()).collect();
    // At least one line that is not blank, and the last one ended, so every line the
    // garbage holds is read and answered.
    bytes.push(b'#');
    bytes.push(b'\n');
    bytes
}

/// Garbage on the pendant's line while the host runs a transfer: NAK on the pendant's line,
/// the transfer carries on to its INF, the pendant is answered afterwards.
pub(super) fn serial_garbage(s: &mut Session, ctx: &mut Ctx) -> anyhow::Result<Round> {
    let line = s.next_transfer(ctx)?;
    let id = s.host.start(&line)?;
    let delay = ctx.delay(100, 2500);
    std::thread::sleep(delay);
    let bytes = garbage(ctx);
    let mut round = Round::new(format!(
        "{line}, {:.3} s in, {} bytes",
        delay.as_secs_f64(),
        bytes.len()
    ));
    let pendant = s
        .pendant
        .as_mut()
        .ok_or_else(|| anyhow::anyhow!("no pendant"))?;
    let mark = pendant.conn.lines.mark();
    let t0 = Instant::now();
    pendant.conn.send_raw(&bytes)?;
    if let Some((_, at, l)) = pendant
        .conn
        .lines
        .find(mark, PATIENCE, |l| l.starts_with("NAK"))
    {
        round.detected(t0, at, &l);
    }
    let end = s.host.end_of(id, PATIENCE * 2);
    round.stopped = match end {
        Ok(end) => Verdict::from(
            end.starts_with("INF"),
            format!("the transfer carried on: {end}"),
        ),
        Err(e) => Verdict::Fail(format!("{e:#}")),
    };
    round.consistent = map_verdict(s);
    let pendant = s
        .pendant
        .as_mut()
        .ok_or_else(|| anyhow::anyhow!("no pendant"))?;
    round.recovered = match pendant.conn.request("STATUS") {
        Ok((_, r)) => Verdict::from(r.starts_with("ACK"), format!("the pendant's STATUS: {r}")),
        Err(e) => Verdict::Fail(format!("the pendant's STATUS: {e:#}")),
    };
    Ok(round)
}

/// The pendant takes CONTROL and runs a transfer; its line is unplugged at a random moment.
/// The controller is started again (with a new line) after the round.
pub(super) fn serial_unplug(s: &mut Session, ctx: &mut Ctx) -> anyhow::Result<Round> {
    let line = s.next_transfer(ctx)?;
    let pendant = s
        .pendant
        .as_mut()
        .ok_or_else(|| anyhow::anyhow!("no pendant"))?;
    pendant.conn.ask("CONTROL")?;
    pendant.conn.start(&line)?;
    let delay = ctx.delay(100, 2500);
    std::thread::sleep(delay);
    let mut round = Round::new(format!("{line}, {:.3} s in", delay.as_secs_f64()));
    let mark = s.host.lines.mark();
    let pendant = s
        .pendant
        .take()
        .ok_or_else(|| anyhow::anyhow!("no pendant"))?;
    let t0 = pendant.unplug()?;
    after_lost_owner(s, ctx, &mut round, mark, t0);
    Ok(round)
}
