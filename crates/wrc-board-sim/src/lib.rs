//! The simulated board: [`SimBoard`] plays the board's DSP on a DPRAM, one board period per
//! [`SimBoard::step`]. It is a plain struct with no clock and no thread: [`runner`] steps it
//! at the board clock in the `wrc board-sim` process, tests step it directly. A step does not
//! allocate, block or make system calls.
//!
//! Each period: execute the host's command and any injected fault; watch the host watchdog;
//! update the digital I/O and the E-stop; then per axis take one FIFO entry (counting an
//! underrun if a streaming axis finds none), check it against the motor's velocity limit,
//! interpolate it over the sub-steps through the servo lag, check following error and limit
//! switches, and publish the feedback record. With a simulated cell attached
//! ([`SimBoard::attach_cell`], [`cell`]) the board also clears the mapping latch when the
//! host asks, steps the cell with the new encoder positions and the outputs, drives the
//! hand's vacuum sensor from it and publishes the mapping latch.
//!
//! # Starting on a DPRAM
//!
//! A board starts in one of three ways (docs/dpram.md, "Board start-up"):
//!
//! | start | call | axes | outputs | epoch |
//! |---|---|---|---|---|
//! | first start | [`SimBoard::new`], or [`SimBoard::take_over`] of a new file | at home | off | 1 |
//! | restart by supervision | [`SimBoard::take_over`] of a wrc DPRAM | where the encoders were | as latched | old + 1 |
//! | power-up after a power loss | [`SimBoard::power_up`] | where the encoders were | off | old + 1 |
//!
//! A restart by supervision is a board processor that restarts under powered drives: the
//! valves stay as the host last set them (the vacuum holds its wafer). A power-up is the
//! whole cell coming back after a power cut: the encoders are absolute (the arm is where it
//! physically stopped), but every valve closed when the power went (the vacuum let go of its
//! wafer, and the simulated cell drops it at the arm's pose at its first step). Old contents
//! that cannot be used (another layout version, another axis count or board, garbage) make
//! a power-up a first start, and [`PowerUp`] says why.
//!
//! The driver side (the DPRAM layout, the driver the controller links) is `wrc-board`; this
//! crate is the other side of the DPRAM, so the controller's real-time build does not link
//! it.
//!
//! ```
//! use wrc_board_sim::{SimBoard, SimSettings};
//! use wrc_board::{DpramBoard, Expect, Feedback, Mapping, MotionBoard};
//!
//! // The embedded default robot on one simulated board, sharing an anonymous mapping.
//! let config = wrc_config::Config::embedded_default();
//! let settings = SimSettings::from_config(&config, &config.boards[0]);
//! let mapping = Mapping::anonymous().unwrap();
//! let mut sim = SimBoard::new(mapping.share(), &settings, 1).unwrap();
//! let mut board = DpramBoard::attach(mapping, Expect::default()).unwrap();
//!
//! // The host pushes one period of increments [pulse/period]; the board executes it.
//! let mut increments = [0i64; 16];
//! increments[0] = 100;
//! board.push(&increments).unwrap();
//! board.refresh_watchdog();
//! sim.step();
//!
//! let mut feedback = Feedback::default();
//! board.read_feedback(&mut feedback).unwrap();
//! assert_eq!(feedback.axes[0].commanded, -75_000 + 100); // home −75° at 1000 pulse/°
//! assert_eq!(feedback.axes[0].alarm, 0);
//! ```
#![deny(missing_docs)]

pub mod cell;
pub mod io;
pub mod runner;
pub mod servo;
pub mod watchdog;
pub mod world_file;

use std::path::Path;
use std::sync::atomic::Ordering;

use wrc_cell::{Blade, MAX_BLADES};
use wrc_config::{BladeB, BoardConfig, Config};

use wrc_board::dpram::{AxisRecord, Dpram, Flush, Pop};
use wrc_board::driver::{Mapping, OpenError};
use wrc_board::fault::Fault;
use wrc_board::layout::{
    self, alarm, axis, axis_status, board_status, command, control, header, mapping, Header,
    LayoutError, AXES_PER_BOARD,
};

use cell::SimCell;
use io::{IoSettings, SimIo, Vacuum};
use servo::{Drive, ServoAxis, ServoSettings};
use watchdog::HostWatchdog;

/// Everything the simulated board needs to know.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSettings {
    /// Board id (0..4).
    pub board_id: u32,
    /// Board period [µs].
    pub period_us: u32,
    /// Usable FIFO depth (1..=64) [periods].
    pub fifo_depth: u32,
    /// Host watchdog limit [periods].
    pub watchdog_periods: u32,
    /// Interpolation sub-steps per period (the DSP's servo rate / board period).
    pub substeps: u32,
    /// Axes in channel order (1..=4).
    pub axes: Vec<ServoSettings>,
    /// Digital I/O.
    pub io: IoSettings,
}

impl SimSettings {
    /// Settings for `board` of `config`: motor limits from the robot's axes
    /// (`max_velocity × pulses_per_unit × overspeed_margin` unless given), limit switches
    /// 1 % of the travel beyond the soft limits, power-on position = home.
    pub fn from_config(config: &Config, board: &BoardConfig) -> SimSettings {
        let period_s = config.motion.period_s;
        let sim = &board.sim;
        let axes = board
            .axes
            .iter()
            .enumerate()
            .map(|(channel, &index)| {
                let a = &config.robot.axes()[index];
                let ppu = a.pulses_per_unit.abs();
                let max_velocity_pps = sim
                    .motor_limit_pps
                    .get(channel)
                    .copied()
                    .flatten()
                    .unwrap_or(a.limits.max_velocity * ppu * sim.overspeed_margin);
                let lag_s = sim.servo_lag_ms / 1000.0;
                let beyond = 0.01 * (a.max - a.min) * ppu;
                let (lo, hi) = {
                    let (p, q) = (a.units_to_pulses(a.min), a.units_to_pulses(a.max));
                    (p.min(q), p.max(q))
                };
                ServoSettings {
                    max_velocity_pps,
                    stop_deceleration_pps2: a.limits.max_acceleration * ppu,
                    stop_jerk_pps3: a.limits.max_jerk * ppu,
                    lag_s,
                    // Twice the steady lag at the motor limit, plus a period of travel.
                    following_error_limit: sim.following_error_limit.unwrap_or(
                        (max_velocity_pps * (2.0 * lag_s + period_s)).ceil() as i64 + 10,
                    ),
                    limit_pos: hi + beyond.ceil() as i64,
                    limit_neg: lo - beyond.ceil() as i64,
                    initial: a.units_to_pulses(a.home),
                }
            })
            .collect();
        SimSettings {
            board_id: board.id,
            period_us: (period_s * 1e6).round() as u32,
            fifo_depth: board.fifo_depth,
            watchdog_periods: board.watchdog_periods,
            substeps: sim.substeps,
            axes,
            io: IoSettings {
                estop_input: sim.estop_input,
                interlock_inputs: sim
                    .interlock_inputs
                    .iter()
                    .fold(0, |m, b| m | 1 << (b & 31)),
                vacuum: sim
                    .vacuum
                    .iter()
                    .map(|v| Vacuum {
                        valve_output: v.valve_output,
                        sensor_input: v.sensor_input,
                        delay_periods: ((v.delay_ms / 1000.0) / period_s).ceil() as u32,
                        wafer: v.wafer,
                    })
                    .collect(),
            },
        }
    }
}

/// Why a simulated board cannot start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// The DPRAM file cannot be created or mapped.
    #[error(transparent)]
    Open(#[from] OpenError),
    /// The file holds something that is not a wrc DPRAM: refusing to overwrite it.
    #[error("DPRAM {path}: {problem}; refusing to overwrite it (remove it or choose another --dpram path)", path = path.display())]
    Foreign {
        /// The path.
        path: std::path::PathBuf,
        /// What is in it.
        problem: LayoutError,
    },
    /// Settings out of range.
    #[error("simulated board settings: {0}")]
    Settings(String),
}

/// How a board powered up ([`SimBoard::power_up`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum PowerUp {
    /// On the DPRAM of a board that ran before: the axes at its encoders, every output off,
    /// a new epoch.
    Resumed {
        /// The new epoch (the old one + 1).
        epoch: u32,
    },
    /// There was no board before (a new or zeroed DPRAM): a first start, the axes at home.
    Fresh,
    /// The old contents could not be used: a first start, the axes at home.
    Replaced(Unusable),
}

/// Why a power-up could not use the old DPRAM's encoders.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Unusable {
    /// Not a wrc DPRAM of this layout version (or one that was still initialising).
    #[error("the old DPRAM cannot be read: {0}")]
    Layout(LayoutError),
    /// A file too short to hold the layout.
    #[error("the old DPRAM file is {len} bytes, the layout needs {need}", need = layout::LAYOUT_SIZE)]
    Truncated {
        /// Its length [byte].
        len: u64,
    },
    /// A wrc DPRAM of another board.
    #[error("the old DPRAM was board {found}'s, this is board {expected}")]
    BoardId {
        /// The board id it holds.
        found: u32,
        /// This board's id.
        expected: u32,
    },
    /// A wrc DPRAM with another number of axes.
    #[error("the old DPRAM had {found} axes, this board drives {expected}")]
    AxisCount {
        /// Its axis count.
        found: u32,
        /// This board's.
        expected: u32,
    },
}

impl std::fmt::Display for PowerUp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PowerUp::Resumed { epoch } => write!(
                f,
                "powered up where the encoders stood, every output off (epoch {epoch})"
            ),
            PowerUp::Fresh => f.write_str("no board ran here before: a first start, axes at home"),
            PowerUp::Replaced(why) => {
                write!(f, "{why}: a first start instead, axes at home")
            }
        }
    }
}

/// Where a stop the host asked for through the stop word stands on the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum OwnStop {
    /// No stop pending.
    Idle,
    /// A stop word seen in an earlier period, not yet answered by the host's brake: the
    /// board brakes on its own at the next period that finds it still unanswered.
    Seen,
    /// Braking on its own after this stop word, FIFO entries discarded.
    Braking(u32),
    /// At rest after its own brake, FIFO entries discarded until the host releases it.
    Stopped(u32),
}

/// Board periods the host has, from the one in which the E-stop input opens, to take the stop
/// with a flush of its own brake before the board brakes every axis itself (docs/dpram.md,
/// "Stops" 6): that period and the next.
pub const ESTOP_GRACE_PERIODS: u32 = 2;

/// The E-stop input on the board: a time-monitored safe stop (SS1-t). The host's brake
/// along the path first, the board's own brake of every axis when the host does not take
/// the stop in time or its brake outlasts the window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Estop {
    /// The input has not opened since the last RESET.
    Off,
    /// Opened `periods` board periods ago; `answered` once the board took a flush of the
    /// host since (its brake): the FIFO still plays.
    Window { periods: u32, answered: bool },
    /// The board holds every axis itself (braking on its own first if one moves), FIFO
    /// entries discarded, until RESET.
    Hold,
}

/// The simulated board's DSP.
#[derive(Debug)]
pub struct SimBoard {
    dpram: Dpram,
    axes: [Option<ServoAxis>; AXES_PER_BOARD],
    streaming: [bool; AXES_PER_BOARD],
    underrun: [bool; AXES_PER_BOARD],
    io: SimIo,
    watchdog: HostWatchdog,
    estop_latched: bool,
    estop: Estop,
    /// Board periods the host's brake may take after the E-stop input opens before the
    /// board brakes on its own ([`SimBoard::estop_window`]).
    estop_window: u32,
    own_stop: OwnStop,
    /// The `BOARD_STOPS` count of the latest brake the board took on its own: the host
    /// releases it by that number.
    own_token: u32,
    period_s: f64,
    substeps: u32,
    periods: u64,
    /// The simulated cell and the vacuum hand of each of its blades.
    cell: Option<(SimCell, [Option<usize>; MAX_BLADES])>,
    /// Started on the DPRAM of a board that ran before ([`SimBoard::take_over`]): its first
    /// period settles the vacuum sensors at once.
    restarted: bool,
}

/// Delay of the hand's vacuum sensor when `[board.sim] vacuum` does not list the hand [s].
pub const CELL_VACUUM_DELAY_S: f64 = 0.05;

impl SimBoard {
    /// Create (or take over) the DPRAM file at `path` and initialise it. An existing file
    /// that is not a wrc DPRAM is refused, not overwritten.
    pub fn create(path: &Path, settings: &SimSettings) -> Result<SimBoard, SimError> {
        SimBoard::take_over(Mapping::create(path)?, settings)
    }

    /// Initialise `map` as a board with `settings`, or, when it already holds a wrc DPRAM,
    /// restart on it (see below). Memory that is neither is refused, not overwritten.
    pub fn take_over(map: Mapping, settings: &SimSettings) -> Result<SimBoard, SimError> {
        let mut kept = None;
        let (epoch, map) = match Dpram::attach(map) {
            // A board restarting on its own DPRAM: a new epoch tells the host. The axes stay
            // where their encoders were (absolute encoders: the arm did not move while the
            // board was down) and the outputs as they were latched (the vacuum holds its
            // wafer), as on a board whose processor restarts under a powered drive.
            Ok(old) => {
                let mut restarted = settings.clone();
                let mut record = AxisRecord::default();
                for (channel, axis) in restarted.axes.iter_mut().enumerate() {
                    if old.read_feedback(channel, &mut record).is_ok() {
                        axis.initial = record.encoder;
                    }
                }
                kept = Some((restarted, old.load(layout::io::OUTPUTS)));
                (old.header().epoch.wrapping_add(1), old.into_mapping())
            }
            // A new (zeroed) file, or a board that died while initialising.
            Err((map, LayoutError::NotReady))
                if all_zero_header(&map)
                    || map.u32(header::VERSION).load(Ordering::Relaxed) == layout::VERSION =>
            {
                (1, map)
            }
            Err((map, problem)) => {
                let problem = match problem {
                    LayoutError::NotReady => LayoutError::Foreign { found: 0 },
                    other => other,
                };
                return Err(SimError::Foreign {
                    path: map.path().to_path_buf(),
                    problem,
                });
            }
        };
        match kept {
            Some((restarted, outputs)) => {
                let mut board = SimBoard::new(map, &restarted, epoch)?;
                board.dpram.store(layout::io::OUTPUTS, outputs);
                board.restarted = true;
                Ok(board)
            }
            None => SimBoard::new(map, settings, epoch),
        }
    }

    /// Power up on `map` after a power loss (see the crate docs): when it holds a wrc
    /// DPRAM of this layout, board id and axis count, the axes start where its encoders
    /// stood (absolute encoders) with every output off and the next epoch; otherwise the
    /// board starts as a first start, overwriting what was there, and [`PowerUp`] says why.
    /// Fails only on unusable `settings`.
    pub fn power_up(map: Mapping, settings: &SimSettings) -> Result<(SimBoard, PowerUp), SimError> {
        let (map, found) = survey(map, settings);
        match found {
            Ok(OldBoard { epoch, encoders }) => {
                let mut powered = settings.clone();
                for (a, encoder) in powered.axes.iter_mut().zip(encoders) {
                    a.initial = encoder;
                }
                // Every output off: `new` zeroes the DPRAM, the latched outputs with it.
                let board = SimBoard::new(map, &powered, epoch)?;
                Ok((board, PowerUp::Resumed { epoch }))
            }
            Err(how) => Ok((SimBoard::new(map, settings, 1)?, how)),
        }
    }

    /// [`SimBoard::power_up`] on the DPRAM file at `path` (created when missing). A regular
    /// file too short for the layout is garbage and is replaced; anything but a regular file
    /// (a device) is refused.
    pub fn power_up_file(
        path: &Path,
        settings: &SimSettings,
    ) -> Result<(SimBoard, PowerUp), SimError> {
        match Mapping::create(path) {
            Ok(map) => SimBoard::power_up(map, settings),
            Err(OpenError::Truncated { len, .. }) => {
                std::fs::remove_file(path).map_err(|error| OpenError::Io {
                    path: path.to_path_buf(),
                    what: "cannot remove the truncated file",
                    error,
                })?;
                let (board, _) = SimBoard::power_up(Mapping::create(path)?, settings)?;
                Ok((board, PowerUp::Replaced(Unusable::Truncated { len })))
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Initialise `map` as a board with `settings`; `epoch` goes into the header.
    pub fn new(map: Mapping, settings: &SimSettings, epoch: u32) -> Result<SimBoard, SimError> {
        let bad = |what: String| Err(SimError::Settings(what));
        if settings.axes.is_empty() || settings.axes.len() > AXES_PER_BOARD {
            return bad(format!(
                "{} axes; a board drives 1 to 4",
                settings.axes.len()
            ));
        }
        if !(1..=layout::FIFO_CAPACITY as u32).contains(&settings.fifo_depth) {
            return bad(format!(
                "fifo depth {}; expected 1 to {} periods",
                settings.fifo_depth,
                layout::FIFO_CAPACITY
            ));
        }
        if !(100..=1_000_000).contains(&settings.period_us) {
            return bad(format!(
                "period {} µs; expected 100 to 1000000",
                settings.period_us
            ));
        }
        if settings.board_id as usize >= layout::MAX_BOARDS {
            return bad(format!("board id {}; expected 0 to 3", settings.board_id));
        }
        let header = Header {
            board_id: settings.board_id,
            axis_count: settings.axes.len() as u32,
            period_us: settings.period_us,
            fifo_depth: settings.fifo_depth,
            epoch,
        };
        let dpram = Dpram::initialize(map, header);
        let mut axes = [None; AXES_PER_BOARD];
        for (slot, s) in axes.iter_mut().zip(&settings.axes) {
            *slot = Some(ServoAxis::new(*s));
        }
        let board = SimBoard {
            watchdog: HostWatchdog::new(
                settings.watchdog_periods,
                dpram.load(control::HOST_WATCHDOG),
            ),
            dpram,
            axes,
            streaming: [false; AXES_PER_BOARD],
            underrun: [false; AXES_PER_BOARD],
            io: SimIo::new(&settings.io),
            estop_latched: false,
            estop: Estop::Off,
            estop_window: estop_window(settings),
            own_stop: OwnStop::Idle,
            own_token: 0,
            period_s: f64::from(settings.period_us) / 1e6,
            substeps: settings.substeps.max(1),
            periods: 0,
            cell: None,
            restarted: false,
        };
        board.publish();
        Ok(board)
    }

    /// The DPRAM the board plays on.
    pub fn dpram(&self) -> &Dpram {
        &self.dpram
    }

    /// Board period [µs].
    pub fn period_us(&self) -> u32 {
        self.dpram.header().period_us
    }

    /// Axis `channel`'s model (for tests and diagnostics).
    pub fn axis(&self, channel: usize) -> Option<&ServoAxis> {
        self.axes.get(channel).and_then(|a| a.as_ref())
    }

    /// Simulate `cell` on this board from the next period on: the hand's vacuum sensor
    /// (the `[board.sim] vacuum` hand with the cell's `vacuum_output` and `vacuum_input`,
    /// added with a [`CELL_VACUUM_DELAY_S`] delay when there is none) senses a wafer only
    /// when the cell has one on the hand, and the mapping latch is published. Fails when all
    /// vacuum hands are taken by others.
    pub fn attach_cell(&mut self, cell: SimCell) -> Result<(), SimError> {
        let hand = *cell.hand();
        let delay = (CELL_VACUUM_DELAY_S / self.period_s).ceil() as u32;
        // One vacuum hand per blade: the hand, and blade B of a dual-blade robot.
        let mut indices = [None; MAX_BLADES];
        for (b, index) in indices.iter_mut().enumerate() {
            let Some(BladeB {
                vacuum_output: output,
                vacuum_input: input,
                ..
            }) = hand.blade(b)
            else {
                continue;
            };
            let Some(i) = self.io.ensure_vacuum(output, input, delay) else {
                return Err(SimError::Settings(format!(
                    "[board.sim] vacuum lists {} hands, none with valve output {output} and \
                     sensor input {input} of [hand]; there is no room for the simulated cell's \
                     blade {}",
                    io::MAX_VACUUM,
                    Blade::ALL[b]
                )));
            };
            *index = Some(i);
        }
        for (b, index) in indices.iter().enumerate() {
            if let Some(i) = *index {
                self.io.set_wafer(i, cell.wafer_on(Blade::ALL[b]));
            }
        }
        self.dpram.write_mapping(cell.latch());
        self.cell = Some((cell, indices));
        Ok(())
    }

    /// The simulated cell, if one is attached.
    pub fn cell(&self) -> Option<&SimCell> {
        self.cell.as_ref().map(|(c, _)| c)
    }

    /// Take the simulated cell off this board (to attach it to the board that restarts in
    /// its place: the wafers stay where they are).
    pub fn take_cell(&mut self) -> Option<SimCell> {
        self.cell.take().map(|(c, _)| c)
    }

    /// The simulated cell's event of the last period that had one, once (see
    /// [`SimCell::take_event`]); for the runner loop to report outside [`SimBoard::step`].
    pub fn take_cell_event(&mut self) -> Option<wrc_cell::WorldEvent> {
        self.cell.as_mut().and_then(|(c, _)| c.take_event())
    }

    /// Apply a fault directly (the mailbox path does the same).
    pub fn apply_fault(&mut self, fault: Fault) {
        match fault {
            Fault::Alarm { axis } => {
                let channel = usize::from(axis);
                self.raise(channel, alarm::AMPLIFIER);
            }
            Fault::EncoderStuck { axis, on } => {
                if let Some(a) = self
                    .axes
                    .get_mut(usize::from(axis))
                    .and_then(|a| a.as_mut())
                {
                    a.encoder_stuck = on;
                }
            }
            Fault::SensorFlip { input, on } => {
                let bit = 1u32 << (input & 31);
                self.io.flipped = if on {
                    self.io.flipped | bit
                } else {
                    self.io.flipped & !bit
                };
            }
            Fault::Estop { on } => self.io.estop_pressed = on,
            Fault::Clear => {
                self.io.flipped = 0;
                self.io.estop_pressed = false;
                for a in self.axes.iter_mut().flatten() {
                    a.encoder_stuck = false;
                }
            }
        }
    }

    /// Count a period the runner started late (it is caught up by stepping).
    pub fn note_late(&self) {
        self.dpram.bump(control::LATE_PERIODS);
    }

    /// Run one board period.
    pub fn step(&mut self) {
        if let Some(flush) = self.dpram.period_begin() {
            // The host's brake answers the stop it was computed for: the board does not
            // brake on its own for it. Acknowledged before the flush is done, so a host
            // that sees the flush done sees the stop answered (docs/dpram.md, "Stops").
            if let Some(word) = self.dpram.stop_pending() {
                let waiting = matches!(self.own_stop, OwnStop::Idle | OwnStop::Seen);
                if layout::stop::seq(word) == flush.answers && waiting {
                    self.dpram.store(control::STOP_ACK, word);
                    self.own_stop = OwnStop::Idle;
                }
            }
            // After the E-stop input opened, the host's flush is its brake: the board plays
            // it (within the window) instead of braking each axis off the path.
            if let Estop::Window { answered, .. } = &mut self.estop {
                *answered = true;
            }
            self.flush(flush);
        }
        self.period();
        self.dpram.period_end();
    }

    /// A flush the host asked for: every axis in use publishes the entries the host staged
    /// up to `end` (if the host has not yet: it may be preempted right after asking) and
    /// skips `from..to`, or none does and each axis that cannot is alarmed (the host and the
    /// board disagree on the FIFO).
    fn flush(&mut self, flush: Flush) {
        let Flush { from, to, end, .. } = flush;
        let used = |c: usize| self.axes[c].is_some();
        let ok = (0..AXES_PER_BOARD)
            .filter(|&c| used(c))
            .all(|c| self.dpram.fifo_skippable(c, from, to));
        for channel in 0..AXES_PER_BOARD {
            let Some(a) = self.axes[channel].as_mut() else {
                continue;
            };
            if ok {
                self.dpram.fifo_publish_to(channel, end);
                self.dpram.fifo_skip(channel, from, to);
            } else if a.raise(alarm::FIFO_SEQUENCE) {
                self.dpram.bump(layout::axis_base(channel) + axis::ALARMS);
            }
        }
        self.dpram.flush_done();
    }

    fn period(&mut self) {
        self.periods += 1;
        self.dpram.store64(control::PERIOD_COUNT, self.periods);
        self.dpram.bump(control::BOARD_WATCHDOG);

        if let Some((code, arg, _)) = self
            .dpram
            .pending(control::COMMAND_SEQ, control::COMMAND_ACK)
        {
            self.execute(code, arg);
            self.dpram
                .acknowledge(control::COMMAND_SEQ, control::COMMAND_ACK);
        }
        if let Some((code, a0, a1)) = self.dpram.pending(layout::fault::SEQ, layout::fault::ACK) {
            if let Some(fault) = Fault::decode(code, a0, a1) {
                self.apply_fault(fault);
            }
            self.dpram
                .acknowledge(layout::fault::SEQ, layout::fault::ACK);
        }

        if let Some((cell, _)) = self.cell.as_mut() {
            let seq = self.dpram.load(mapping::CLEAR_SEQ);
            if seq != self.dpram.load(mapping::CLEAR_ACK) {
                cell.clear_latch();
                if let Some(latch) = cell.take_latch_change() {
                    self.dpram.write_mapping(&latch);
                }
                self.dpram.store(mapping::CLEAR_ACK, seq);
            }
        }

        if self.watchdog.step(self.dpram.load(control::HOST_WATCHDOG)) {
            self.dpram.bump(control::WATCHDOG_TRIPS);
        }

        let outputs = self.dpram.load(layout::io::OUTPUTS);
        if std::mem::take(&mut self.restarted) {
            // The sensors of a restarted board read the hand as it has been all along.
            self.io.settle(outputs);
        }
        let inputs = self.io.step(outputs);
        self.dpram.store(layout::io::OUTPUTS_APPLIED, outputs);
        self.dpram.store(layout::io::INPUTS, inputs);
        self.step_estop(self.io.estop(inputs));
        self.underrun = [false; AXES_PER_BOARD];
        self.take_stop_word();
        let ready = self.record_ready();
        let hold = self.estop == Estop::Hold;
        if !self.watchdog.is_tripped() && !hold {
            self.brake_on_underrun(ready);
        }
        let own = matches!(self.own_stop, OwnStop::Braking(_) | OwnStop::Stopped(_));
        if own && self.estop != Estop::Off {
            // A brake of the board's own after the E-stop input opened ends in the E-stop's
            // hold: the host's release does not start the FIFO again.
            self.estop = Estop::Hold;
        }
        let hold = self.estop == Estop::Hold;
        let stop = self.watchdog.is_tripped() || hold || own;
        // A watchdog trip or the E-stop input brakes with the full limits; a stop the board
        // takes on its own with the level the host asked for.
        let level = match self.own_stop {
            OwnStop::Braking(w) | OwnStop::Stopped(w) if !self.watchdog.is_tripped() && !hold => {
                f64::from(layout::stop::level(w)) / 100.0
            }
            _ => 1.0,
        };

        for channel in 0..AXES_PER_BOARD {
            let Some(a) = self.axes[channel].as_mut() else {
                continue;
            };
            let base = layout::axis_base(channel);
            let drive = if a.alarm() != 0 || stop || a.is_stopping() {
                let dropped = self.dpram.fifo_drain(channel);
                if dropped > 0 {
                    let d = self
                        .dpram
                        .load(base + axis::DISCARDED)
                        .wrapping_add(dropped);
                    self.dpram.store(base + axis::DISCARDED, d);
                }
                let (accel_pps2, jerk_pps3) = brake_limits(&self.dpram, channel, a, level);
                Drive::Stop {
                    accel_pps2,
                    jerk_pps3,
                }
            } else if !ready {
                // The record is not whole: every axis waits for it (at rest, or braked
                // by `brake_on_underrun` if one moves).
                Drive::Hold
            } else {
                match self.dpram.fifo_pop(channel) {
                    Pop::Entry(increment) => {
                        self.streaming[channel] = true;
                        Drive::Increment(increment)
                    }
                    // An axis at rest that finds no entry holds: nothing was due, so it is
                    // no underrun (a host keeps only a short queue at rest, and a stall
                    // then only starts the next move later). A moving one was braked by
                    // `brake_on_underrun`, and counted there.
                    Pop::Empty => Drive::Hold,
                    Pop::SequenceError => {
                        if a.raise(alarm::FIFO_SEQUENCE) {
                            self.dpram.bump(base + axis::ALARMS);
                        }
                        Drive::Hold
                    }
                }
            };
            if a.step(drive, self.period_s, self.substeps) {
                self.dpram.bump(base + axis::ALARMS);
            }
            if !stop {
                a.end_stop();
            }
        }
        if let OwnStop::Braking(word) = self.own_stop {
            if self.axes.iter().flatten().all(|a| !a.is_braking()) {
                self.own_stop = OwnStop::Stopped(word);
            }
        }
        if let Some((cell, hands)) = self.cell.as_mut() {
            let mut encoders = [0i64; AXES_PER_BOARD];
            for (e, a) in encoders.iter_mut().zip(&self.axes) {
                if let Some(a) = a {
                    *e = a.encoder();
                }
            }
            cell.step(&encoders, outputs);
            // The sensor input follows at the next periods, after the hand's delay.
            for (b, index) in hands.iter().enumerate() {
                if let Some(i) = *index {
                    self.io.set_wafer(i, cell.wafer_on(Blade::ALL[b]));
                }
            }
            if let Some(latch) = cell.take_latch_change() {
                self.dpram.write_mapping(&latch);
            }
        }
        self.publish();
    }

    /// The host's stop word: a stop not answered by the host's brake (a flush) within one
    /// board period is braked by the board on its own; a stronger one during its brake
    /// brakes again from where the axes are; a released stop ends it (the entries pushed
    /// before the release are skipped).
    fn take_stop_word(&mut self) {
        if let Some(word) = self.dpram.stop_pending() {
            match self.own_stop {
                OwnStop::Idle => self.own_stop = OwnStop::Seen,
                OwnStop::Seen => {
                    self.brake_on_own(word);
                    self.dpram.store(control::STOP_ACK, word);
                }
                OwnStop::Braking(before) | OwnStop::Stopped(before) => {
                    self.dpram.store(control::STOP_ACK, word);
                    if layout::stop::level(word) > layout::stop::level(before) {
                        let level = f64::from(layout::stop::level(word)) / 100.0;
                        for (channel, a) in self.axes.iter_mut().enumerate() {
                            let Some(a) = a.as_mut().filter(|a| a.is_braking()) else {
                                continue;
                            };
                            let (accel, jerk) = brake_limits(&self.dpram, channel, a, level);
                            a.begin_stop(accel, jerk, self.period_s);
                        }
                    }
                    self.own_stop = match self.own_stop {
                        OwnStop::Stopped(_) => OwnStop::Stopped(word),
                        _ => OwnStop::Braking(word),
                    };
                }
            }
        }
        if let OwnStop::Stopped(_) = self.own_stop {
            if let Some(at) = self.dpram.released(self.own_token) {
                for channel in 0..AXES_PER_BOARD {
                    if let Some(a) = self.axes[channel].as_mut() {
                        self.dpram.fifo_skip_to(channel, at);
                        self.streaming[channel] = false;
                        if !self.watchdog.is_tripped() && self.estop != Estop::Hold {
                            a.end_stop();
                        }
                    }
                }
                self.own_stop = OwnStop::Idle;
            }
        }
    }

    /// The E-stop input this period (`open`): latched when it opens (the status shows it
    /// until RESET), then the window of the host's brake (docs/dpram.md, "Stops"
    /// 6): the board holds every axis itself once the host has not flushed its brake
    /// within [`ESTOP_GRACE_PERIODS`], or once the window ends.
    fn step_estop(&mut self, open: bool) {
        if open && !self.estop_latched {
            self.estop_latched = true;
            self.estop = Estop::Window {
                periods: 0,
                answered: false,
            };
            return;
        }
        if let Estop::Window { periods, answered } = &mut self.estop {
            *periods += 1;
            let limit = if *answered {
                self.estop_window
            } else {
                ESTOP_GRACE_PERIODS
            };
            if *periods >= limit {
                self.estop = Estop::Hold;
            }
        }
    }

    /// Start a brake of the board's own at the level of `word` (counted; the count is the
    /// token the host releases it by). The status shows it (braking) at once, before the
    /// stop word is acknowledged: a host that sees the stop taken sees how.
    fn brake_on_own(&mut self, word: u32) {
        self.dpram.bump(control::BOARD_STOPS);
        self.own_token = self.dpram.load(control::BOARD_STOPS);
        self.own_stop = OwnStop::Braking(word);
        let status = self.dpram.load(control::BOARD_STATUS);
        self.dpram.store(
            control::BOARD_STATUS,
            status | board_status::BOARD_BRAKE | board_status::STOPPING,
        );
    }

    /// Whether the next record is whole: every axis that takes FIFO entries (not alarmed,
    /// not stopping) has one. The board executes one record a period, an entry of each
    /// axis; the host publishes the axes one after the other, and a record it is still
    /// publishing is not there yet (an axis that took its entry alone would run a period
    /// ahead of the others for the rest of the move).
    fn record_ready(&self) -> bool {
        (0..AXES_PER_BOARD).all(|c| {
            self.axes[c]
                .as_ref()
                .is_none_or(|a| a.alarm() != 0 || a.is_stopping() || self.dpram.fifo_level(c) > 0)
        })
    }

    /// A streaming axis that is moving finds no record (`ready` false: the host has fallen
    /// behind by more than its look-ahead): holding the position would stop the axis in
    /// one period, so the board brakes every axis on its own with the full limits instead,
    /// as for a stop the host did not answer, and the host takes it from there.
    fn brake_on_underrun(&mut self, ready: bool) {
        if ready || !matches!(self.own_stop, OwnStop::Idle | OwnStop::Seen) {
            return;
        }
        let starved = (0..AXES_PER_BOARD).any(|c| {
            self.axes[c].as_ref().is_some_and(|a| {
                self.streaming[c] && a.alarm() == 0 && !a.is_stopping() && a.increment() != 0
            })
        });
        if starved {
            for c in 0..AXES_PER_BOARD {
                if self.axes[c].is_some() && self.streaming[c] && self.dpram.fifo_level(c) == 0 {
                    self.underrun[c] = true;
                    self.dpram.bump(layout::axis_base(c) + axis::UNDERRUNS);
                }
            }
            self.brake_on_own(layout::stop::word(0, 100));
        }
    }

    fn raise(&mut self, channel: usize, cause: u32) {
        if let Some(a) = self.axes.get_mut(channel).and_then(|a| a.as_mut()) {
            if a.raise(cause) {
                self.dpram.bump(layout::axis_base(channel) + axis::ALARMS);
            }
        }
    }

    fn execute(&mut self, code: u32, arg: u32) {
        match code {
            command::CLEAR_ALARMS => {
                for (channel, a) in self.axes.iter_mut().enumerate() {
                    if let Some(a) = a.as_mut().filter(|_| arg & (1 << channel) != 0) {
                        a.clear_alarm();
                        self.streaming[channel] = false;
                    }
                }
            }
            command::RESET => {
                self.watchdog.reset();
                self.estop_latched = false;
                self.estop = Estop::Off;
                // A stop braked on its own ends too (a host that restarted does not know
                // of it): what was queued before is dropped.
                if !matches!(self.own_stop, OwnStop::Idle) {
                    if let Some(word) = self.dpram.stop_pending() {
                        self.dpram.store(control::STOP_ACK, word);
                    }
                    for channel in 0..AXES_PER_BOARD {
                        if self.axes[channel].is_some() {
                            let dropped = self.dpram.fifo_drain(channel);
                            let base = layout::axis_base(channel);
                            let d = self
                                .dpram
                                .load(base + axis::DISCARDED)
                                .wrapping_add(dropped);
                            self.dpram.store(base + axis::DISCARDED, d);
                        }
                    }
                    self.own_stop = OwnStop::Idle;
                }
                for (channel, a) in self.axes.iter_mut().enumerate() {
                    if let Some(a) = a.as_mut() {
                        a.clear_alarm();
                        self.streaming[channel] = false;
                    }
                }
            }
            _ => {}
        }
    }

    /// Write every axis's feedback record and the board status.
    fn publish(&self) {
        let mut status = board_status::RUNNING;
        if self.watchdog.is_armed() {
            status |= board_status::WATCHDOG_ARMED;
        }
        if self.watchdog.is_tripped() {
            status |= board_status::WATCHDOG_TRIPPED;
        }
        if self.estop_latched {
            status |= board_status::ESTOP;
        }
        if matches!(self.own_stop, OwnStop::Braking(_) | OwnStop::Stopped(_)) {
            status |= board_status::BOARD_BRAKE;
        }
        for (channel, a) in self.axes.iter().enumerate() {
            let Some(a) = a else { continue };
            let mut s = a.status();
            if self.underrun[channel] {
                s |= axis_status::UNDERRUN;
            }
            if self.streaming[channel] {
                s |= axis_status::STREAMING;
            }
            if a.alarm() != 0 {
                status |= board_status::ALARM;
            }
            if a.is_braking() {
                status |= board_status::STOPPING;
            }
            self.dpram.write_feedback(
                channel,
                &AxisRecord {
                    status: s,
                    commanded: a.commanded(),
                    encoder: a.encoder(),
                    following_error: a.commanded() - a.encoder(),
                    alarm: a.alarm(),
                    increment: a.increment(),
                },
            );
        }
        self.dpram.store(control::BOARD_STATUS, status);
    }
}

/// The E-stop window in board periods: the grace, then twice the longest time-optimal brake
/// of an axis from its motor limit with its stop limits, and at least a second (the host's
/// brake along a path is slower than each axis's own, and a path's limits may be lower).
fn estop_window(settings: &SimSettings) -> u32 {
    let brake_s = settings
        .axes
        .iter()
        .map(|s| {
            let a = s.stop_deceleration_pps2.max(1.0);
            s.max_velocity_pps / a + a / s.stop_jerk_pps3.max(1.0)
        })
        .fold(0.0, f64::max);
    let period_s = f64::from(settings.period_us.max(1)) / 1e6;
    let periods = ((2.0 * brake_s).clamp(1.0, 60.0) / period_s).ceil();
    ESTOP_GRACE_PERIODS + periods as u32
}

/// The brake limits of axis `channel` at `level` (a fraction of them, 0..=1): those the host
/// wrote, or the axis's own when it wrote none; acceleration scaled by level², jerk by level³
/// (a brake played at the level's speed) [pulse/s², pulse/s³].
fn brake_limits(dpram: &Dpram, channel: usize, axis: &ServoAxis, level: f64) -> (f64, f64) {
    let (accel, jerk) = dpram.brake_limits(channel);
    let s = axis.settings();
    let accel = if accel > 0 {
        accel as f64
    } else {
        s.stop_deceleration_pps2
    };
    let jerk = if jerk > 0 {
        jerk as f64
    } else {
        s.stop_jerk_pps3
    };
    (accel * level * level, jerk * level.powi(3))
}

/// What [`SimBoard::power_up_file`] will do with the DPRAM file at `path`, found without
/// changing it: [`PowerUp::Resumed`] with the epoch it will take, [`PowerUp::Fresh`] for a
/// missing, empty or zeroed file, or [`PowerUp::Replaced`] with why the old contents are
/// unusable. A path that cannot be opened at all is reported as it will fail.
pub fn power_up_outlook(path: &Path, settings: &SimSettings) -> Result<PowerUp, SimError> {
    let map = match Mapping::open(path) {
        Ok(map) => map,
        Err(OpenError::Io { error, .. }) if error.kind() == std::io::ErrorKind::NotFound => {
            return Ok(PowerUp::Fresh)
        }
        Err(OpenError::Truncated { len: 0, .. }) => return Ok(PowerUp::Fresh),
        Err(OpenError::Truncated { len, .. }) => {
            return Ok(PowerUp::Replaced(Unusable::Truncated { len }))
        }
        Err(e) => return Err(e.into()),
    };
    Ok(match survey(map, settings).1 {
        Ok(old) => PowerUp::Resumed { epoch: old.epoch },
        Err(how) => how,
    })
}

/// What a power-up takes over from the board that ran before.
struct OldBoard {
    /// The epoch the powered-up board takes (the old one + 1).
    epoch: u32,
    /// The old board's encoders [pulse], channel order.
    encoders: [i64; AXES_PER_BOARD],
}

/// Read the DPRAM in `map` for a power-up with `settings` (nothing is written): the next
/// epoch and the encoders [pulse, channel order] of a board of the same layout, id and axis
/// count, or what the power-up is instead.
fn survey(map: Mapping, settings: &SimSettings) -> (Mapping, Result<OldBoard, PowerUp>) {
    let expected_axes = settings.axes.len() as u32;
    match Dpram::attach(map) {
        Ok(old) => {
            let h = *old.header();
            let found = if h.board_id != settings.board_id {
                Err(PowerUp::Replaced(Unusable::BoardId {
                    found: h.board_id,
                    expected: settings.board_id,
                }))
            } else if h.axis_count != expected_axes {
                Err(PowerUp::Replaced(Unusable::AxisCount {
                    found: h.axis_count,
                    expected: expected_axes,
                }))
            } else {
                let mut encoders = [0i64; AXES_PER_BOARD];
                for (channel, e) in encoders.iter_mut().enumerate() {
                    // One word, written whole by the board: no torn value even when it died
                    // in the middle of publishing its record.
                    *e = old.load64(layout::axis_base(channel) + axis::ENCODER) as i64;
                }
                Ok(OldBoard {
                    epoch: h.epoch.wrapping_add(1),
                    encoders,
                })
            };
            (old.into_mapping(), found)
        }
        Err((map, LayoutError::NotReady)) if all_zero_header(&map) => (map, Err(PowerUp::Fresh)),
        Err((map, problem)) => (map, Err(PowerUp::Replaced(Unusable::Layout(problem)))),
    }
}

fn all_zero_header(map: &Mapping) -> bool {
    (0..0x40)
        .step_by(4)
        .all(|o| map.u32(o).load(Ordering::Relaxed) == 0)
}

#[cfg(test)]
pub(crate) mod tests {
    use wrc_robot::MAX_AXES;

    use super::*;
    use wrc_board::board::{Feedback, MotionBoard};
    use wrc_board::driver::{DpramBoard, Expect};

    /// Two axes at 10 ms: 100 000 pulse/s limit, 500 000 pulse/s² stop deceleration.
    pub(crate) fn settings() -> SimSettings {
        let axis = ServoSettings {
            max_velocity_pps: 100_000.0,
            stop_deceleration_pps2: 500_000.0,
            stop_jerk_pps3: 5_000_000.0,
            lag_s: 0.004,
            following_error_limit: 3_000,
            limit_pos: 1_000_000,
            limit_neg: -1_000_000,
            initial: 0,
        };
        SimSettings {
            board_id: 0,
            period_us: 10_000,
            fifo_depth: 4,
            watchdog_periods: 5,
            substeps: 10,
            axes: vec![axis, axis],
            io: IoSettings {
                estop_input: Some(15),
                interlock_inputs: 0,
                vacuum: vec![],
            },
        }
    }

    fn pair() -> (SimBoard, DpramBoard) {
        pair_with(&settings())
    }

    fn pair_with(settings: &SimSettings) -> (SimBoard, DpramBoard) {
        let map = Mapping::anonymous().unwrap();
        let sim = SimBoard::new(map.share(), settings, 1).unwrap();
        let host = DpramBoard::attach(map, Expect::default()).unwrap();
        (sim, host)
    }

    fn inc(a: i64, b: i64) -> [i64; MAX_AXES] {
        let mut i = [0; MAX_AXES];
        i[0] = a;
        i[1] = b;
        i
    }

    fn feedback(host: &DpramBoard) -> Feedback {
        let mut f = Feedback::default();
        host.read_feedback(&mut f).unwrap();
        f
    }

    #[test]
    fn fifo_fills_to_depth_and_drains_one_per_period() {
        let (mut sim, mut host) = pair();
        for _ in 0..4 {
            host.push(&inc(10, -10)).unwrap();
        }
        assert_eq!(host.push(&inc(10, -10)), Err(wrc_board::Full));
        for n in 1..=4 {
            sim.step();
            let f = feedback(&host);
            assert_eq!(
                (f.axes[0].commanded, f.axes[1].commanded),
                (10 * n, -10 * n)
            );
            assert_eq!(f.axes[0].fifo_level, 4 - n as u32);
        }
        assert_eq!(host.fifo_free(), 4);
    }

    /// The configuration accepts the FIFO depths the layout has slots for, no more.
    #[test]
    fn the_configurations_deepest_fifo_is_the_layouts_capacity() {
        assert_eq!(
            wrc_config::MAX_FIFO_DEPTH as usize,
            layout::FIFO_CAPACITY,
            "wrc-config's MAX_FIFO_DEPTH and the DPRAM layout disagree"
        );
    }

    #[test]
    fn an_empty_fifo_is_an_underrun_only_for_an_axis_that_moves() {
        let (mut sim, mut host) = pair();
        for _ in 0..3 {
            sim.step(); // idle before the first push
        }
        assert_eq!(feedback(&host).underruns(), 0);
        host.push(&inc(5, 5)).unwrap();
        host.push(&inc(0, 0)).unwrap();
        sim.step();
        sim.step(); // at rest from here on
        sim.step(); // empty, at rest: nothing was due
        sim.step();
        let f = feedback(&host);
        assert_eq!(f.underruns(), 0, "an axis at rest without an entry ran dry");
        assert!(f.axes[0].status & axis_status::UNDERRUN == 0);
        assert_eq!(f.axes[0].commanded, 5, "an axis at rest holds its position");
        assert!(f.boards[0].status & board_status::BOARD_BRAKE == 0);
        host.push(&inc(5, 5)).unwrap(); // a move starts late: no harm
        sim.step();
        assert_eq!(feedback(&host).underruns(), 0);
        sim.step(); // moving, and nothing queued: starved
        let f = feedback(&host);
        assert_eq!((f.axes[0].underruns, f.axes[1].underruns), (1, 1));
        assert!(f.axes[0].status & axis_status::UNDERRUN != 0);
        assert!(
            f.boards[0].status & board_status::BOARD_BRAKE != 0,
            "a moving axis run dry is braked, not held"
        );
    }

    #[test]
    fn overspeed_alarms_only_that_axis_and_clears() {
        let (mut sim, mut host) = pair();
        // 1001 pulses in 10 ms = 100 100 pulse/s > 100 000.
        host.push(&inc(1_001, 1_000)).unwrap();
        host.push(&inc(500, 500)).unwrap();
        sim.step();
        let f = feedback(&host);
        assert_eq!(f.axes[0].alarm, alarm::OVERSPEED);
        assert_eq!(f.axes[0].alarms, 1);
        assert_eq!(
            f.axes[0].commanded, 0,
            "the over-speed entry is not executed"
        );
        assert_eq!((f.axes[1].alarm, f.axes[1].commanded), (0, 1_000));
        assert!(f.boards[0].status & board_status::ALARM != 0);
        sim.step();
        assert_eq!(feedback(&host).axes[0].discarded, 1);
        host.clear_alarms(0b01).unwrap();
        assert_eq!(host.clear_alarms(0b01), Err(wrc_board::Busy));
        host.push(&inc(0, 0)).unwrap(); // the host streams at rest
        sim.step();
        let f = feedback(&host);
        assert_eq!(f.axes[0].alarm, 0);
        assert!(f.axes[0].status & axis_status::SERVO_ON != 0);
        host.push(&inc(100, 0)).unwrap();
        sim.step();
        assert_eq!(feedback(&host).axes[0].increment, 100);
    }

    #[test]
    fn stale_host_watchdog_stops_all_axes_with_controlled_deceleration() {
        // A FIFO deeper than the watchdog limit, so the axes are still moving when it trips.
        let (mut sim, mut host) = pair_with(&SimSettings {
            fifo_depth: 8,
            ..settings()
        });
        // Cruise at 900 pulse/period (90 000 pulse/s) with the watchdog refreshed.
        for _ in 0..8 {
            host.push(&inc(900, -900)).unwrap();
        }
        for _ in 0..10 {
            host.refresh_watchdog();
            let _ = host.push(&inc(900, -900));
            sim.step();
        }
        assert_eq!(feedback(&host).axes[0].increment, 900);
        // The host dies: the FIFO still holds entries, but the board stops after 5 periods.
        let decel_per_period = 500_000.0 * 0.01 * 0.01; // 50 pulse/period²
        let mut velocities = vec![];
        for _ in 0..40 {
            sim.step();
            let f = feedback(&host);
            velocities.push(f.axes[0].increment);
            assert_eq!(f.axes[1].increment, -f.axes[0].increment);
        }
        let f = feedback(&host);
        assert!(f.boards[0].status & board_status::WATCHDOG_TRIPPED != 0);
        assert_eq!(f.boards[0].watchdog_trips, 1);
        assert_eq!(*velocities.last().unwrap(), 0);
        let trip = velocities.iter().position(|v| *v < 900).unwrap();
        assert!(trip <= 6, "{velocities:?}");
        for w in velocities[trip - 1..].windows(2) {
            let dv = (w[0] - w[1]) as f64;
            assert!(
                (0.0..=decel_per_period + 1.0).contains(&dv),
                "not a controlled deceleration: {velocities:?}"
            );
        }
        assert_eq!(f.axes[0].alarm, 0, "a watchdog stop is not a servo alarm");
        // No new motion is taken until the host resets.
        host.refresh_watchdog();
        host.push(&inc(10, 10)).unwrap();
        sim.step();
        assert_eq!(feedback(&host).axes[0].increment, 0);
        host.reset().unwrap();
        host.refresh_watchdog();
        sim.step();
        host.refresh_watchdog();
        host.push(&inc(10, 10)).unwrap();
        sim.step();
        let f = feedback(&host);
        assert_eq!(f.axes[0].increment, 10);
        assert!(f.boards[0].status & board_status::WATCHDOG_TRIPPED == 0);
    }

    /// Cruise at 400 pulses a period on axis 0 with the FIFO kept full; the increments of
    /// `n` more periods, the FIFO topped up after each.
    fn cruise(sim: &mut SimBoard, host: &mut DpramBoard, n: usize) -> Vec<i64> {
        let mut incs = Vec::with_capacity(n);
        for _ in 0..n {
            while host.push(&inc(400, 0)).is_ok() {}
            sim.step();
            incs.push(feedback(host).axes[0].increment);
        }
        incs
    }

    #[test]
    fn the_estop_input_waits_its_grace_for_the_hosts_brake_then_brakes_every_axis_itself() {
        let (mut sim, mut host) = pair();
        cruise(&mut sim, &mut host, 5);
        assert!(Fault::Estop { on: true }.inject(sim.dpram()));
        // The period it opens and the next play the FIFO: the host has them to flush its
        // brake along the path. It does not: the board brakes on its own.
        let incs = cruise(&mut sim, &mut host, 40);
        assert_eq!(incs[..ESTOP_GRACE_PERIODS as usize], [400, 400]);
        assert!(incs[2] < 400, "{incs:?}");
        assert!(incs.windows(2).all(|w| w[1] <= w[0]), "{incs:?}");
        assert_eq!(incs[30..], [0; 10]);
        let f = feedback(&host);
        assert!(f.boards[0].inputs & (1 << 15) != 0);
        assert!(f.boards[0].status & board_status::ESTOP != 0);
        assert!(host.board_stop().estop);
        // Held until RESET: what the host pushes is discarded.
        let at = f.axes[0].commanded;
        cruise(&mut sim, &mut host, 3);
        assert_eq!(feedback(&host).axes[0].commanded, at);
        sim.apply_fault(Fault::Estop { on: false });
        host.reset().unwrap();
        sim.step();
        assert!(feedback(&host).boards[0].status & board_status::ESTOP == 0);
        assert!(!host.board_stop().estop);
        host.push(&inc(5, 0)).unwrap();
        sim.step();
        assert_eq!(feedback(&host).axes[0].commanded, at + 5);
    }

    #[test]
    fn the_estop_input_plays_the_hosts_brake_flushed_in_its_grace_and_holds_after_the_window() {
        let (mut sim, mut host) = pair();
        cruise(&mut sim, &mut host, 5);
        assert!(Fault::Estop { on: true }.inject(sim.dpram()));
        assert_eq!(cruise(&mut sim, &mut host, 1), [400]);
        assert!(host.board_stop().estop);
        // The host sees the input and flushes its brake (a ramp down, as along a path): its
        // first period with the flush, the rest behind it.
        let at = host.fifo_position().unwrap();
        assert!(host.flush_queued(&at, at.write, &[inc(300, 0)]));
        let mut incs = run(&mut sim, &host, 1);
        for i in [200, 100, 0] {
            host.push(&inc(i, 0)).unwrap();
        }
        incs.extend(run(&mut sim, &host, 3));
        assert_eq!(incs, [300, 200, 100, 0], "the host's brake, as flushed");
        assert_eq!(sim.dpram().load(control::BOARD_STOPS), 0);
        // Within the window the FIFO still plays (a time-monitored stop: the host's brake
        // may take that long); after it the board holds every axis itself.
        let window = estop_window(&settings()) as usize;
        assert_eq!(window, 2 + 100, "grace, then at least 1 s");
        let before = feedback(&host).axes[0].commanded;
        host.push(&inc(7, 0)).unwrap();
        host.push(&inc(0, 0)).unwrap();
        run(&mut sim, &host, 2);
        let played = feedback(&host).axes[0].commanded;
        assert_eq!(played, before + 7);
        run(&mut sim, &host, window);
        assert_eq!(feedback(&host).axes[0].commanded, played);
        host.push(&inc(7, 0)).unwrap();
        sim.step();
        let f = feedback(&host);
        assert_eq!(
            f.axes[0].commanded, played,
            "moved after the E-stop's window"
        );
        assert!(f.boards[0].status & board_status::ESTOP != 0);
    }

    #[test]
    fn injected_faults_reach_the_axes() {
        let (mut sim, host) = pair();
        assert!(Fault::Alarm { axis: 1 }.inject(sim.dpram()));
        assert!(
            !Fault::Clear.inject(sim.dpram()),
            "one fault at a time until acknowledged"
        );
        sim.step();
        assert_eq!(feedback(&host).axes[1].alarm, alarm::AMPLIFIER);
        assert!(Fault::SensorFlip { input: 3, on: true }.inject(sim.dpram()));
        sim.step();
        assert!(host.read_inputs(0) & (1 << 3) != 0);
    }

    #[test]
    fn a_corrupt_fifo_entry_is_a_sequence_alarm() {
        let (mut sim, mut host) = pair();
        host.push(&inc(1, 1)).unwrap();
        // Overwrite the entry's sequence number as a foreign writer would.
        sim.dpram().store(layout::fifo_slot(0, 0), 77);
        sim.step();
        let f = feedback(&host);
        assert_eq!(f.axes[0].alarm, alarm::FIFO_SEQUENCE);
        assert_eq!(f.axes[1].alarm, 0);
    }

    #[test]
    fn from_config_derives_motor_limits_from_the_robot() {
        let config = Config::embedded_default();
        let s = SimSettings::from_config(&config, &config.boards[0]);
        assert_eq!(s.axes.len(), 4);
        // j1: 180 °/s × 1000 pulse/° × 1.2.
        assert!((s.axes[0].max_velocity_pps - 216_000.0).abs() < 1e-6);
        assert_eq!(s.axes[0].initial, -75_000);
        assert_eq!(s.period_us, 10_000);
        assert_eq!(s.io.vacuum[0].delay_periods, 5);
    }
    /// One axis at 1 kHz driven by a host that keeps `LEAD` periods queued, accelerating at
    /// constant jerk: the increments of the pulse stream p(t) = J·t³/6.
    const LEAD: u32 = 20;

    fn khz() -> SimSettings {
        SimSettings {
            period_us: 1_000,
            fifo_depth: 64,
            watchdog_periods: 1_000,
            ..settings()
        }
    }

    /// Push the jerk-limited ramp's periods `from..to` (J = 2e6 pulse/s³, 1 ms).
    fn push_ramp(host: &mut DpramBoard, from: u32, to: u32) {
        let p = |k: u32| {
            let t = f64::from(k) * 1e-3;
            (2e6 * t * t * t / 6.0).round() as i64
        };
        for k in from..to {
            let i = p(k + 1) - p(k);
            host.push(&inc(i, -i)).unwrap();
        }
    }

    /// Run `n` periods; the increments of axis 0.
    fn run(sim: &mut SimBoard, host: &DpramBoard, n: usize) -> Vec<i64> {
        (0..n)
            .map(|_| {
                sim.step();
                feedback(host).axes[0].increment
            })
            .collect()
    }

    #[test]
    fn a_stop_the_host_does_not_answer_is_braked_by_the_board_a_period_after_it_saw_it() {
        let (mut sim, mut host) = pair_with(&khz());
        // Accelerate for 120 ms with the look-ahead queued, the host refreshing as it goes.
        push_ramp(&mut host, 0, LEAD);
        for k in 0..120 {
            host.refresh_watchdog();
            sim.step();
            push_ramp(&mut host, LEAD + k, LEAD + k + 1);
        }
        let before = feedback(&host).axes[0];
        // The state the board is in when it sees the stop word (at its next period):
        // position, velocity and acceleration of the ramp at 120 ms [pulse, /s, /s²].
        let t = 0.120;
        let (v0, a0) = (2e6 * t * t / 2.0, 2e6 * t);
        // The host stalls: a stop is asked (ESTOP: 100 %) and nobody answers it.
        let line = host.stop_line().unwrap();
        line.post(100);
        let incs = run(&mut sim, &host, 400);
        let f = feedback(&host);
        let moving = incs.iter().rposition(|&i| i != 0).unwrap() + 1;
        let distance = (f.axes[0].commanded - before.commanded) as f64;
        assert_eq!(f.axes[1].commanded, -f.axes[0].commanded);
        // Against the time-optimal brake from the state the board saw (the settings' own
        // limits: the host wrote none): at most 1.05 times it plus one period.
        let reference = wrc_motion::Brake1d::new(0.0, v0, a0, 500_000.0, 5_000_000.0);
        let (t_ref, d_ref) = (reference.duration(), reference.stop_position());
        assert!(
            moving as f64 * 1e-3 <= 1.05 * t_ref + 1e-3 + 1e-9,
            "{moving} ms against {t_ref} s"
        );
        // Distance: the period it waits for the host's brake is travelled, and the brake
        // starts from the state a period later (on a ramp a longer brake than from the
        // state it saw): within 1.05 times that brake, plus the period.
        let t1 = t + 1e-3;
        let later =
            wrc_motion::Brake1d::new(0.0, 2e6 * t1 * t1 / 2.0, 2e6 * t1, 500_000.0, 5_000_000.0);
        let d_later = later.stop_position();
        assert!(
            distance <= 1.05 * d_later + v0 * 1e-3,
            "{distance} pulses against {d_later} (+{v0} pulse/s for a period)"
        );
        assert!(
            distance >= 0.95 * d_ref,
            "{distance} pulses against {d_ref}"
        );
        // Never beyond the acceleration limit, read over 10 periods (an increment is
        // rounded to a pulse, so a one-period difference reads 10⁶ pulse/s² at 1 kHz).
        for w in incs[..moving + 1].windows(11) {
            let a = (w[10] - w[0]) as f64 / (10.0 * 1e-6);
            assert!(a.abs() <= 500_000.0 * 1.05 + 1e5, "{a}: {incs:?}");
        }
        assert_eq!(f.boards[0].period_count, 120 + 400);
        assert_eq!(sim.dpram().load(control::BOARD_STOPS), 1);
        // Entries pushed before the release never run; those after it do.
        let at = f.axes[0].commanded;
        host.push(&inc(7, -7)).unwrap();
        sim.step();
        assert_eq!(feedback(&host).axes[0].commanded, at, "ran while braked");
        host.push(&inc(7, -7)).unwrap();
        assert!(host.board_stop().settled);
        host.release_stop();
        // Until its next period the board still shows the brake; a host that looks again
        // meanwhile (a late Pulse Generator catching up) must not take it for a new one.
        assert!(f.boards[0].status & board_status::BOARD_BRAKE != 0);
        let stop = host.board_stop();
        assert!(
            !stop.braking_own && !stop.settled && !stop.braking,
            "{stop:?}"
        );
        host.push(&inc(3, -3)).unwrap();
        sim.step();
        let f = feedback(&host);
        assert_eq!(f.axes[0].commanded, at + 3);
        assert!(f.boards[0].status & board_status::BOARD_BRAKE == 0);
        assert!(!host.board_stop().braking_own);
    }

    #[test]
    fn a_flush_that_answers_the_stop_brings_the_hosts_brake_and_the_board_takes_it() {
        let (mut sim, mut host) = pair_with(&khz());
        push_ramp(&mut host, 0, LEAD);
        for k in 0..50 {
            sim.step();
            push_ramp(&mut host, LEAD + k, LEAD + k + 1);
        }
        host.stop_line().unwrap().post(100);
        // The host answers at once: skip the queued periods, push its own (here: rest).
        let at = host.fifo_position().unwrap();
        assert!(host.flush_queued(&at, at.write, &[inc(0, 0)]));
        let incs = run(&mut sim, &host, 5);
        assert_eq!(incs, vec![0; 5]);
        let f = feedback(&host);
        assert_eq!(f.boards[0].status & board_status::BOARD_BRAKE, 0);
        assert_eq!(sim.dpram().load(control::BOARD_STOPS), 0);
        assert_eq!(
            layout::stop::seq(sim.dpram().load(control::STOP_ACK)),
            layout::stop::seq(sim.dpram().load(control::STOP))
        );
    }

    #[test]
    fn a_moving_axis_that_runs_out_of_periods_is_braked_not_held() {
        let (mut sim, mut host) = pair_with(&khz());
        push_ramp(&mut host, 0, 60);
        let mut incs = run(&mut sim, &host, 40);
        push_ramp(&mut host, 60, 100);
        incs.extend(run(&mut sim, &host, 260));
        let f = feedback(&host);
        assert!(f.axes[0].underruns >= 1);
        assert!(f.boards[0].status & board_status::BOARD_BRAKE != 0);
        // No step to zero: the increments after the last queued one fall off gradually.
        let last = incs[99];
        assert!(last >= 8, "{last}");
        assert!(
            incs[100] > last / 2,
            "held instead of braked: {:?}",
            &incs[95..110]
        );
        assert_eq!(*incs.last().unwrap(), 0);
        assert_eq!(sim.dpram().load(control::BOARD_STOPS), 1);
    }
}
