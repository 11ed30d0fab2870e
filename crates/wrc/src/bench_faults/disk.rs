//! Faults of the state directory: full or read-only while the controller saves the wafer
//! map or the stations (the previous file must stay intact and the failure be reported),
//! and a corrupt state file at start-up (a clear refusal, nothing overwritten).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Context;
use rand::Rng;
use wrc_cell::WaferMap;

use super::harness::{
    check_map, processes, read_world, tmpfs_namespaces_work, Tmpfs, Up, UpOptions, PATIENCE,
};
use super::kinds::{judge_rest, recover, untouched};
use super::processes::OwnCell;
use super::session::Session;
use super::{Ctx, Round, Verdict};

/// The state directory's tmpfs: room for the controller's files, small to fill [bytes].
const TMPFS_BYTES: u64 = 1 << 20;

/// Fill the file system of `dir` until a write fails for want of space.
fn fill(dir: &Path) -> anyhow::Result<()> {
    let mut f = std::fs::File::create(dir.join("fill"))?;
    let chunk = vec![0u8; 16 * 1024];
    loop {
        match f.write(&chunk) {
            Ok(0) => return Ok(()),
            Ok(_) => {}
            Err(e) if e.raw_os_error() == Some(libc::ENOSPC) => return Ok(()),
            Err(e) => return Err(e).context("filling the state directory"),
        }
    }
}

/// The station `name`'s pose and its approach pose (`approach` mm back along its line), each
/// `x y z yaw` [mm, deg], from `STN`.
fn station_poses(s: &mut Session, name: &str) -> anyhow::Result<(String, String)> {
    let mark = s.host.lines.mark();
    s.host.ask("STN")?;
    let lines = s.host.lines.since(mark);
    let line = lines
        .iter()
        .find(|l| l.starts_with(&format!("EVT STATION {name} ")))
        .with_context(|| format!("no station {name} in STN"))?;
    let f = |k: &str| -> anyhow::Result<f64> {
        wrc_protocol::reply_field(line, k)
            .and_then(|v| v.parse().ok())
            .with_context(|| format!("no number {k}= in {line}"))
    };
    let (x, y, z, yaw, back) = (f("x")?, f("y")?, f("z")?, f("yaw")?, f("approach")?);
    let (sin, cos) = yaw.to_radians().sin_cos();
    Ok((
        format!("{x:.3} {y:.3} {z:.3} {yaw:.3}"),
        format!(
            "{:.3} {:.3} {z:.3} {yaw:.3}",
            x - back * cos,
            y - back * sin
        ),
    ))
}

/// Take the hand into station `name` as a transfer does — to its approach pose, then
/// straight in along its line: any other way into a station touches it (the controller
/// refuses it, NAK 117) — `TEACH` the station at its own pose there, and take the hand
/// straight out to the approach pose again. The TEACH's reply, or what stopped the hand.
fn teach_at_station(s: &mut Session, name: &str) -> anyhow::Result<String> {
    let (seat, approach) = station_poses(s, name)?;
    for line in [format!("MOVP {approach}"), format!("MOVL {seat}")] {
        match s.host.run(&line) {
            Ok(end) if end.starts_with("INF") => {}
            Ok(end) => return Ok(format!("`{line}` ended `{end}`")),
            Err(e) => return Ok(format!("`{line}`: {e:#}")),
        }
    }
    let teach = s.host.request(&format!("TEACH {name}"))?.1;
    let out = format!("MOVL {approach}");
    Ok(match s.host.run(&out) {
        Ok(end) if end.starts_with("INF") => teach,
        Ok(end) => format!("{teach}; then `{out}` ended `{end}`"),
        Err(e) => format!("{teach}; then `{out}`: {e:#}"),
    })
}

/// The state directory filled (or made read-only) at a random moment of a transfer: the
/// save that comes next fails and is reported, the next transfer and a TEACH are refused
/// with nothing moved and nothing written, the files stay as they were; once there is room
/// again, the next transfer runs and saves.
pub(super) fn disk_round(
    ctx: &mut Ctx,
    own: &mut Option<OwnCell>,
    read_only: bool,
) -> anyhow::Result<Round> {
    if own.is_none() {
        tmpfs_namespaces_work(&ctx.root).map_err(|why| {
            anyhow::anyhow!("no state directory of its own can be filled here: {why}")
        })?;
        let name = if read_only { "read-only" } else { "disk-full" };
        *own = Some(OwnCell::start(
            ctx,
            name,
            Some(Tmpfs { bytes: TMPFS_BYTES }),
        )?);
    }
    let cell = own.as_mut().context("no cell")?;
    let s = cell.session()?;
    let touched = read_world(&s.world)?.side_collisions();
    let state = s.up.state.clone();
    let (wafers_file, stations_file) = (state.join("wafers.toml"), state.join("stations.toml"));
    let line = s.next_transfer(ctx)?;
    let id = s.host.start(&line)?;
    let delay = ctx.delay(0, 2500);
    std::thread::sleep(delay);
    let mut round = Round::new(format!(
        "{line}, {:.3} s in, the state directory {}",
        delay.as_secs_f64(),
        if read_only { "read-only" } else { "full" }
    ));
    let (log_mark, host_mark) = (s.up.log.mark(), s.host.lines.mark());
    if read_only {
        s.up.remount(true)?;
    } else {
        fill(&state)?;
    }
    let t0 = Instant::now();
    let wafers_before = std::fs::read(&wafers_file)?;
    let stations_before = std::fs::read(&stations_file)?;
    let end = s.host.end_of(id, PATIENCE * 2)?;
    // The next transfer must be refused before it moves: its pending state cannot be saved.
    let next = s.next_transfer(ctx)?;
    let (_, reply) = s.host.request(&next)?;
    let refused = reply.split_whitespace().nth(2) == Some("301");
    let board = s.board()?;
    let from = board.feedback().boards[0].period_count;
    let rest = judge_rest(&board, from);
    // TEACH at the station's own pose (PM2, empty): the stations cannot be saved either.
    let teach = teach_at_station(s, "PM2")?;
    let teach_refused = teach.split_whitespace().nth(1) == Some("301")
        || teach.split_whitespace().nth(2) == Some("301");
    let log = s.up.log.find(log_mark, Duration::ZERO, |l| {
        l.contains("cannot save the wafer map")
    });
    let nak = s.host.lines.find(host_mark, Duration::ZERO, |l| {
        l.starts_with("NAK") && l.split_whitespace().any(|w| w == "301")
    });
    match (log, nak) {
        (Some((_, a, la)), Some((_, b, lb))) => {
            if a <= b {
                round.detected(t0, a, &la)
            } else {
                round.detected(t0, b, &lb)
            }
        }
        (Some((_, a, l)), None) | (None, Some((_, a, l))) => round.detected(t0, a, &l),
        (None, None) => {}
    }
    let rest_ok = rest.is_pass();
    round.stopped = Verdict::from(
        refused && teach_refused && rest_ok,
        format!(
            "the {line} ended `{end}`; the next transfer: `{reply}`; TEACH: `{teach}`; {rest:?}"
        ),
    );
    let wafers_after = std::fs::read(&wafers_file)?;
    let stations_after = std::fs::read(&stations_file)?;
    let intact = wafers_after == wafers_before && stations_after == stations_before;
    let parses =
        WaferMap::from_text(&String::from_utf8_lossy(&wafers_after), "wafers.toml").is_ok();
    let leftovers: Vec<String> = std::fs::read_dir(&state)?
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    // Room again; HOME, then the next transfer must run and save.
    if read_only {
        s.up.remount(false)?;
    } else {
        std::fs::remove_file(state.join("fill"))?;
    }
    let home = s.host.run("HOME").unwrap_or_else(|e| format!("{e:#}"));
    round.recovered = match recover(s, ctx, false) {
        Verdict::Pass(t) => {
            Verdict::from(home.starts_with("INF"), format!("room again; HOME; {t}"))
        }
        other => other,
    };
    let check = s.check_map();
    // Into PM2 and out along its line, HOME, the transfers: the cell felt no touch.
    round.stopped = untouched(round.stopped, &s.world, touched);
    let mut consistent = Vec::new();
    if !intact {
        consistent.push("a state file changed while it could not be saved".to_string());
    }
    if !parses {
        consistent.push("wafers.toml does not read".to_string());
    }
    if !leftovers.is_empty() {
        consistent.push(format!("left behind: {}", leftovers.join(", ")));
    }
    consistent.extend(check.problems);
    round.consistent = Verdict::from(
        consistent.is_empty(),
        if consistent.is_empty() {
            "wafers.toml and stations.toml byte-identical while full; afterwards WAFERS = wafers.toml = the cell".into()
        } else {
            consistent.join("; ")
        },
    );
    Ok(round)
}

/// How a state file is corrupted.
#[derive(Debug, Clone, Copy)]
enum Corruption {
    /// Cut at a random byte.
    Truncate,
    /// Cut at the end of a random line.
    TruncateAtLine,
    /// A few bytes overwritten with bytes no text file holds (controls, invalid UTF-8).
    Overwrite,
    /// A line of random printable text inserted between two lines.
    GarbageLine,
    /// A stretch zeroed, as a lost disk block reads.
    Zeroed,
}

const CORRUPTIONS: [Corruption; 5] = [
    Corruption::Truncate,
    Corruption::TruncateAtLine,
    Corruption::Overwrite,
    Corruption::GarbageLine,
    Corruption::Zeroed,
];

/// `text` corrupted by `how`, past its opening comment (a change there would change nothing).
fn corrupt(text: &[u8], how: Corruption, ctx: &mut Ctx) -> (Vec<u8>, String) {
    let body = comment_end(text);
    let len = text.len();
    let at = ctx.rng.random_range(body..len.max(body + 1));
    let line_ends: Vec<usize> = text
        .iter()
        .enumerate()
        .filter(|(i, &b)| b == b'\n' && *i >= body && *i + 1 < len)
        .map(|(i, _)| i + 1)
        .collect();
    let at_line = if line_ends.is_empty() {
        body
    } else {
        line_ends[ctx.rng.random_range(0..line_ends.len())]
    };
    match how {
        Corruption::Truncate => (
            text[..at].to_vec(),
            format!("truncated to {at} of {len} bytes"),
        ),
        Corruption::TruncateAtLine => (
            text[..at_line].to_vec(),
            format!("truncated at a line's end, {at_line} of {len} bytes"),
        ),
        Corruption::Overwrite => {
            let mut v = text.to_vec();
            let n = ctx.rng.random_range(1..=8usize);
            for k in 0..n {
                let i = (at + k).min(len - 1);
                v[i] = if ctx.rng.random_bool(0.5) {
                    ctx.rng.random_range(0x80..=0xFFu8)
                } else {
                    ctx.rng.random_range(0x00..0x09u8)
                };
            }
            (v, format!("{n} bytes overwritten at {at}"))
        }
        Corruption::GarbageLine => {
            let n = ctx.rng.random_range(3..40usize);
            let mut line: Vec<u8> = (0..n).map(|_| ctx.rng.random_range(b'!'..=b'~')).collect();
            if line[0] == b'#' {
                line[0] = b'%';
            }
            line.push(b'\n');
            let mut v = text[..at_line].to_vec();
            v.extend_from_slice(&line);
            v.extend_from_slice(&text[at_line..]);
            (
                v,
                format!("a line of {n} random characters inserted at {at_line}"),
            )
        }
        Corruption::Zeroed => {
            let n = ctx.rng.random_range(1..=64usize).min(len - at);
            let mut v = text.to_vec();
            v[at..at + n].fill(0);
            (v, format!("{n} bytes zeroed at {at}"))
        }
    }
}

/// Where a file's opening comment lines end.
fn comment_end(text: &[u8]) -> usize {
    let mut i = 0;
    while i < text.len() && text[i] == b'#' {
        match text[i..].iter().position(|&b| b == b'\n') {
            Some(n) => i += n + 1,
            None => return text.len(),
        }
    }
    i.min(text.len().saturating_sub(1))
}

/// A state directory with a homed, mapped cell: what the corrupt-file rounds copy. The
/// shared session's, when it runs (idle between rounds: its files are a consistent
/// snapshot, each written atomically), with the hand's wafer put down first (`wrc up`
/// starts its simulated board afresh, with the vacuum off: a wafer left on the hand would
/// fall); otherwise one made once and stopped cleanly.
fn template(ctx: &mut Ctx, shared: &mut Option<Session>) -> anyhow::Result<PathBuf> {
    if let Some(s) = shared {
        s.park()?;
        // The board writes its world file a moment after each change: wait for it to show
        // the cell the map shows.
        let settled = s.check_map();
        if !settled.problems.is_empty() {
            anyhow::bail!(
                "the shared cell is not consistent to copy: {}",
                settled.problems.join("; ")
            );
        }
        let dir = ctx.dir("corrupt-template-shared")?;
        let state = s.up.state.clone();
        for f in STATE_FILES {
            let (from, to) = (state.join(f), dir.join(f));
            super::harness::poll(PATIENCE, || std::fs::copy(&from, &to).ok())
                .with_context(|| format!("cannot copy {}", from.display()))?;
        }
        return Ok(dir);
    }
    let dir = ctx.root.join("corrupt-template");
    if dir.join("wafers.toml").exists() {
        return Ok(dir);
    }
    let options = UpOptions {
        state: ctx.dir("corrupt-template")?,
        no_rt: !ctx.rt,
        ..UpOptions::default()
    };
    let mut s = Session::start(options, None, false)?;
    s.up.stop();
    Ok(dir)
}

const STATE_FILES: [&str; 3] = ["wafers.toml", "stations.toml", "world.toml"];

/// Copy the template's state files into `dir`.
fn copy_state(from: &Path, dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    for f in STATE_FILES {
        std::fs::copy(from.join(f), dir.join(f)).with_context(|| format!("cannot copy {f}"))?;
    }
    Ok(())
}

/// A state file corrupted before `wrc up` starts: refused, naming the file, nothing
/// written, nothing left running; restored, it starts with the map it had.
pub(super) fn corrupt_round(
    ctx: &mut Ctx,
    file: &str,
    shared: &mut Option<Session>,
) -> anyhow::Result<Round> {
    let template = template(ctx, shared)?;
    let n = std::fs::read_dir(&ctx.root)?.count();
    let dir = ctx.dir(&format!("corrupt-{n}"))?;
    copy_state(&template, &dir)?;
    let original = std::fs::read(template.join(file))?;
    let how = CORRUPTIONS[ctx.rng.random_range(0..CORRUPTIONS.len())];
    let (bytes, what) = corrupt(&original, how, ctx);
    std::fs::write(dir.join(file), &bytes)?;
    let mut round = Round::new(format!("{file} {what}"));
    let options = UpOptions {
        state: dir.clone(),
        no_rt: !ctx.rt,
        ..UpOptions::default()
    };
    let t0 = Instant::now();
    let started = Up::start(&options)?;
    let refused = match started {
        Ok(mut up) => {
            up.stop();
            round.stopped = Verdict::Fail("wrc up started on the corrupt file".into());
            None
        }
        Err(r) => Some((Instant::now(), r)),
    };
    let others_kept = STATE_FILES
        .iter()
        .filter(|f| **f != file)
        .all(|f| std::fs::read(dir.join(f)).ok() == std::fs::read(template.join(f)).ok());
    let kept = std::fs::read(dir.join(file))? == bytes;
    if let Some((at, r)) = &refused {
        let names = r.stderr.contains(file);
        if !r.status.success() && names {
            let first = r
                .stderr
                .lines()
                .find(|l| l.contains(file))
                .unwrap_or_default()
                .to_string();
            round.detected(t0, *at, &format!("exit {}: {first}", r.status));
        } else {
            round.signal = format!(
                "exit {}, the message does not name {file}: {}",
                r.status, r.stderr
            );
        }
        let left = processes(&dir, "board-sim");
        let mut written: Vec<String> = std::fs::read_dir(&dir)?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| !STATE_FILES.contains(&n.as_str()))
            .collect();
        written.sort();
        round.stopped = Verdict::from(
            left.is_empty() && written.is_empty(),
            match (left.is_empty(), written.is_empty()) {
                (true, true) => {
                    "refused before anything started: no process, no file written".into()
                }
                (false, _) => format!("processes left running: {left:?}"),
                (true, false) => format!("refused, but it wrote {}", written.join(", ")),
            },
        );
    }
    round.consistent = Verdict::from(
        kept && others_kept,
        match (kept, others_kept) {
            (true, true) => {
                format!("{file} byte-identical to the corrupt copy, the other files untouched")
            }
            (false, _) => format!("{file} was rewritten"),
            (true, false) => "another state file was rewritten".into(),
        },
    );
    // Restored, it starts with the map it had.
    std::fs::write(dir.join(file), &original)?;
    let expected = WaferMap::load(&template.join("wafers.toml"))?.wafers_line();
    round.recovered = match Up::start(&options)? {
        Err(r) => Verdict::Fail(format!("the restored state is refused: {}", r.stderr)),
        Ok(mut up) => {
            let mut host = up.conn()?;
            let got = super::harness::poll(PATIENCE, || {
                let w = host.wafers().ok()??;
                (!w.contains("pending=")).then_some(w)
            });
            let mut tracking = wrc_cell::Tracking::new();
            let check = check_map(
                &mut host,
                &dir.join("wafers.toml"),
                &dir.join("world.toml"),
                &mut tracking,
                super::session::WAFERS,
            );
            up.stop();
            match got {
                Some(w) if w == expected && check.problems.is_empty() => Verdict::Pass(
                    "restored, wrc up starts with the map it had, which matches the cell".into(),
                ),
                Some(w) if w != expected => {
                    Verdict::Fail(format!("restored, the map reads `{w}`, was `{expected}`"))
                }
                Some(_) => Verdict::Fail(check.problems.join("; ")),
                None => Verdict::Fail("restored, the map did not settle".into()),
            }
        }
    };
    if refused.is_none() {
        round.signal = "wrc up started: the corruption was not detected".into();
    }
    Ok(round)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corruptions_change_the_body_and_are_seeded() {
        let text =
            b"# a comment\n# another\nversion = 1\nnext_id = 3\n[[station]]\nname = \"LP1\"\n";
        let body = comment_end(text);
        assert_eq!(&text[..body], b"# a comment\n# another\n");
        for how in CORRUPTIONS {
            let mut a = Ctx::for_tests(1);
            let mut b = Ctx::for_tests(1);
            let (x, what) = corrupt(text, how, &mut a);
            assert_eq!((x.clone(), what), corrupt(text, how, &mut b));
            assert_ne!(x, text.to_vec(), "{how:?}");
            assert_eq!(
                &x[..body.min(x.len())],
                &text[..body.min(x.len())],
                "{how:?}"
            );
        }
    }
}
