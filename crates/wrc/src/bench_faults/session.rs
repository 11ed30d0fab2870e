//! A controller session of the campaign: `wrc up` with the demo cell on a simulated board,
//! homed, load port LP1 mapped, and a host connection that moves wafers LP1 → LP1 (each
//! `GET` of a randomly chosen wafer, each `PUT` into the first empty slot), so that every
//! fault can fall into a transfer and the map is checked against the cell after it.

use std::os::fd::{AsFd, AsRawFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use rand::Rng;
use wrc_cell::{parse_slot_list, SlotState, Tracking};
use wrc_protocol::reply_field;

use super::harness::{check_map, BoardView, Conn, MapCheck, Up, UpOptions, PATIENCE};
use super::Ctx;

/// The load port the campaign moves wafers in and out of.
pub(super) const STATION: &str = "LP1";
/// Wafers in the demo cell (all in LP1 at the start).
pub(super) const WAFERS: usize = 25;

/// A running controller with the demo cell, and what the campaign knows about it.
pub(super) struct Session {
    pub(super) up: Up,
    pub(super) host: Conn,
    pub(super) tracking: Tracking,
    /// Its options (to start it again on the same state directory).
    pub(super) options: UpOptions,
    /// The board's DPRAM and world file.
    pub(super) dpram: PathBuf,
    pub(super) world: PathBuf,
    /// The teaching pendant's line, when started with one (until it is unplugged).
    pub(super) pendant: Option<Pendant>,
    /// Started with a pendant line (a restart gets a fresh one).
    with_pendant: bool,
}

impl Session {
    /// Start `wrc up` per `options` (the board and world in `board_dir`, or the state
    /// directory when `wrc up` starts the board; with a teaching pendant on a fresh
    /// pseudo-terminal when `pendant`), home the robot and map LP1 when the map does not
    /// know it yet.
    pub(super) fn start(
        options: UpOptions,
        board_dir: Option<&Path>,
        pendant: bool,
    ) -> anyhow::Result<Session> {
        let mut s = Session::start_unprepared(options, board_dir, pendant)?;
        s.prepare()?;
        Ok(s)
    }

    /// Start `wrc up` as [`Session::start`] does, but neither RESET nor HOME nor MAP: the
    /// controller as an operator finds it after a restart.
    pub(super) fn start_unprepared(
        mut options: UpOptions,
        board_dir: Option<&Path>,
        pendant: bool,
    ) -> anyhow::Result<Session> {
        let line = if pendant {
            let (line, path) = PtyLine::open()?;
            options.serial = Some(path);
            Some(line)
        } else {
            options.serial = None;
            None
        };
        let up = match Up::start(&options)? {
            Ok(up) => up,
            Err(refused) => bail!(
                "wrc up refused to start ({}): {}",
                refused.status,
                refused.stderr
            ),
        };
        let host = up.conn()?;
        let dir = board_dir.map_or_else(|| options.state.clone(), Path::to_path_buf);
        Ok(Session {
            up,
            host,
            tracking: Tracking::new(),
            options,
            dpram: dir.join("board0.dpram"),
            world: dir.join("world.toml"),
            pendant: line.map(Pendant::attach).transpose()?,
            with_pendant: pendant,
        })
    }

    /// Clear what a previous controller left (a board watchdog trip), home, map LP1 if the
    /// map does not know it.
    pub(super) fn prepare(&mut self) -> anyhow::Result<()> {
        // The map is reconciled from the vacuum sensor in the first I/O Monitor period.
        let settled = super::harness::poll(PATIENCE, || {
            let w = self.host.wafers().ok()??;
            (!w.contains("pending=")).then_some(w)
        });
        let wafers = settled.context("the wafer map did not settle after start-up")?;
        // As an operator after a restart: RESET, whether or not the controller has seen yet
        // what the board latched meanwhile (a tripped watchdog is reported by Error Check's
        // first period, up to 100 ms after `wrc up` says it is ready).
        self.host
            .reset(Duration::from_secs(10))
            .map_err(|e| anyhow::anyhow!("RESET after start-up refused: {e}"))?;
        self.host.run_ok("HOME")?;
        if reply_field(&wafers, STATION).is_some_and(|l| l.contains('?')) {
            self.host.run_ok(&format!("MAP {STATION}"))?;
        }
        Ok(())
    }

    /// The board, seen through its DPRAM.
    pub(super) fn board(&self) -> anyhow::Result<BoardView> {
        BoardView::open(&self.dpram)
    }

    /// The wafer map file as this process reaches it.
    pub(super) fn wafers_file(&self) -> PathBuf {
        self.up.state.join("wafers.toml")
    }

    /// Compare the map with the cell (see [`check_map`]).
    pub(super) fn check_map(&mut self) -> MapCheck {
        let file = self.wafers_file();
        check_map(
            &mut self.host,
            &file,
            &self.world,
            &mut self.tracking,
            WAFERS,
        )
    }

    /// The next transfer the campaign makes: the hand's wafer into LP1's first empty slot,
    /// or a randomly chosen wafer of LP1 onto the hand.
    pub(super) fn next_transfer(&mut self, ctx: &mut Ctx) -> anyhow::Result<String> {
        let wafers = self
            .host
            .wafers()?
            .context("WAFERS came in parts; the campaign reads it on one line")?;
        next_transfer(&wafers, ctx)
    }

    /// Put a wafer the hand holds back into LP1 (before the board is replaced: a fresh
    /// board powers on with the vacuum off, and the wafer would fall).
    pub(super) fn park(&mut self) -> anyhow::Result<()> {
        let wafers = self.host.wafers()?.unwrap_or_default();
        if reply_field(&wafers, "hand").is_some_and(|h| h.starts_with('W')) {
            self.host.run_ok(&next_put(&wafers)?)?;
        }
        Ok(())
    }

    /// Stop `wrc up` (SIGTERM) with the hand empty, and start it again on the same state
    /// directory (with a fresh pendant line when it had one).
    pub(super) fn restart(mut self) -> anyhow::Result<Session> {
        self.park()?;
        self.up.stop();
        let tracking = std::mem::take(&mut self.tracking);
        let options = self.options.clone();
        let dir = self.dpram.parent().map(Path::to_path_buf);
        let pendant = self.with_pendant;
        drop(self);
        let mut s = Session::start(options, dir.as_deref(), pendant)?;
        s.tracking = tracking;
        Ok(s)
    }
}

/// The slots of `station` in a `WAFERS` body.
fn slots(wafers: &str, station: &str) -> anyhow::Result<Vec<SlotState>> {
    let list = reply_field(wafers, station).with_context(|| format!("no {station} in {wafers}"))?;
    parse_slot_list(list).with_context(|| format!("{station}'s slots do not read: {list}"))
}

/// The `PUT` of the hand's wafer into LP1's first empty slot.
fn next_put(wafers: &str) -> anyhow::Result<String> {
    let lp1 = slots(wafers, STATION)?;
    let free = lp1
        .iter()
        .position(|s| *s == SlotState::Empty)
        .with_context(|| format!("no empty slot in {STATION}: {wafers}"))?;
    Ok(format!("PUT {STATION} {}", free + 1))
}

/// See [`Session::next_transfer`].
fn next_transfer(wafers: &str, ctx: &mut Ctx) -> anyhow::Result<String> {
    if reply_field(wafers, "hand").is_some_and(|h| h.starts_with('W')) {
        return next_put(wafers);
    }
    let lp1 = slots(wafers, STATION)?;
    let full: Vec<usize> = lp1
        .iter()
        .enumerate()
        .filter(|(_, s)| matches!(s, SlotState::Wafer(_)))
        .map(|(i, _)| i + 1)
        .collect();
    if full.is_empty() {
        bail!("no wafer left in {STATION}: {wafers}");
    }
    let slot = full[ctx.rng.random_range(0..full.len())];
    Ok(format!("GET {STATION} {slot}"))
}

/// The pendant's end of a pseudo-terminal (the "cable"), and the slave kept open so the
/// line stays up until it is unplugged.
pub(super) struct PtyLine {
    master: OwnedFd,
    slave: OwnedFd,
}

impl PtyLine {
    /// A new pseudo-terminal pair; the slave's path for `wrc up --serial`.
    pub(super) fn open() -> anyhow::Result<(PtyLine, PathBuf)> {
        let pty = nix::pty::openpty(None, None).context("cannot open a pseudo-terminal")?;
        // Neither end may leak into the processes the campaign starts: the controller
        // holding the master would keep the line up after it is unplugged.
        for fd in [&pty.master, &pty.slave] {
            nix::fcntl::fcntl(
                fd,
                nix::fcntl::FcntlArg::F_SETFD(nix::fcntl::FdFlag::FD_CLOEXEC),
            )
            .context("cannot mark the pseudo-terminal close-on-exec")?;
        }
        let path = std::fs::read_link(format!("/proc/self/fd/{}", pty.slave.as_raw_fd()))
            .context("cannot name the pseudo-terminal")?;
        Ok((
            PtyLine {
                master: pty.master,
                slave: pty.slave,
            },
            path,
        ))
    }
}

/// Reads the pty master until it is told to stop (then its descriptor closes with it).
struct PtyReader {
    fd: OwnedFd,
    stop: Arc<AtomicBool>,
}

impl std::io::Read for PtyReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        loop {
            if self.stop.load(Ordering::Acquire) {
                return Ok(0);
            }
            let mut fds = [PollFd::new(self.fd.as_fd(), PollFlags::POLLIN)];
            let n = poll(&mut fds, PollTimeout::from(20u16)).map_err(std::io::Error::from)?;
            if n == 0 {
                continue;
            }
            return nix::unistd::read(&self.fd, buf).map_err(std::io::Error::from);
        }
    }
}

/// The teaching pendant on the serial line: a host connection over the pty master that
/// can be unplugged (every descriptor of the master closed: the controller's end hangs up).
pub(super) struct Pendant {
    pub(super) conn: Conn,
    stop: Arc<AtomicBool>,
    slave: Option<OwnedFd>,
}

impl Pendant {
    fn attach(line: PtyLine) -> anyhow::Result<Pendant> {
        let stop = Arc::new(AtomicBool::new(false));
        let reader = PtyReader {
            fd: line.master.try_clone()?,
            stop: stop.clone(),
        };
        let writer = std::fs::File::from(line.master);
        Ok(Pendant {
            conn: Conn::on(Box::new(writer), reader),
            stop,
            slave: Some(line.slave),
        })
    }

    /// Unplug the line: close the master everywhere; the instant it was done.
    pub(super) fn unplug(mut self) -> anyhow::Result<Instant> {
        self.stop.store(true, Ordering::Release);
        // The reader ends within a poll timeout and closes its descriptor.
        let ended = super::harness::poll(PATIENCE, || self.conn.lines.is_closed().then_some(()));
        ended.context("the pendant's reader did not end")?;
        let t = Instant::now();
        drop(self.conn);
        self.slave.take();
        Ok(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_next_transfer_puts_the_hand_s_wafer_in_the_first_free_slot_or_gets_one() {
        let mut ctx = Ctx::for_tests(7);
        let put = next_transfer("hand=W3 LP1=W1,W2,-,W4..W25 LP2=?x25", &mut ctx).unwrap();
        assert_eq!(put, "PUT LP1 3");
        for _ in 0..20 {
            let get = next_transfer("hand=- LP1=-x2,W3,-x21,W25 AL=?", &mut ctx).unwrap();
            assert!(get == "GET LP1 3" || get == "GET LP1 25", "{get}");
        }
        assert!(next_transfer("hand=- LP1=-x25", &mut ctx).is_err());
    }
}
