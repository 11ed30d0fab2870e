//! The driver: [`DpramBoard`] maps one board's DPRAM (shared-memory file of a simulated
//! board, PCI BAR resource file or UIO device of a real one), checks it, and implements
//! [`MotionBoard`] on it with the protocols of [`crate::dpram`].

use crate::dpram::FifoPosition;
use std::path::Path;
use std::time::{Duration, Instant};

use wrc_robot::MAX_AXES;

pub use crate::mapping::{Mapping, OpenError};

use crate::board::{
    AxisFeedback, BoardFeedback, BoardStop, Busy, Feedback, Full, Heartbeat, MappingScan,
    MotionBoard, StopLine, Torn,
};
use crate::dpram::{AxisRecord, Dpram, MappingRecord};
use crate::layout::{self, axis, board_status, command, control, io, mapping, stop, Header};

/// What the configuration expects of a board; `None` accepts anything.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Expect {
    /// Board id.
    pub board_id: Option<u32>,
    /// Axes in use.
    pub axis_count: Option<u32>,
    /// Board period [µs].
    pub period_us: Option<u32>,
}

/// One board driven through its mapped DPRAM.
#[derive(Debug)]
pub struct DpramBoard {
    dpram: Dpram,
    host_watchdog: u32,
    outputs: u32,
}

impl DpramBoard {
    /// Map and check the DPRAM at `path`.
    pub fn open(path: &Path, expect: Expect) -> Result<DpramBoard, OpenError> {
        DpramBoard::attach(Mapping::open(path)?, expect)
    }

    /// Check an already-made mapping (for example [`Mapping::anonymous`] shared with a
    /// simulated board in the same process).
    pub fn attach(map: Mapping, expect: Expect) -> Result<DpramBoard, OpenError> {
        let dpram = Dpram::attach(map).map_err(|(map, problem)| OpenError::Layout {
            path: map.path().to_path_buf(),
            problem,
        })?;
        let h = *dpram.header();
        let path = || dpram.mapping().path().to_path_buf();
        for (field, found, expected) in [
            ("board_id", h.board_id, expect.board_id),
            ("axis_count", h.axis_count, expect.axis_count),
            ("period_us", h.period_us, expect.period_us),
        ] {
            if let Some(expected) = expected {
                if found != expected {
                    return Err(OpenError::Mismatch {
                        path: path(),
                        field,
                        found,
                        expected,
                    });
                }
            }
        }
        let outputs = dpram.load(io::OUTPUTS);
        let host_watchdog = dpram.load(control::HOST_WATCHDOG);
        Ok(DpramBoard {
            dpram,
            host_watchdog,
            outputs,
        })
    }

    /// [`DpramBoard::open`], retrying while the file is missing or the board is still
    /// initialising, up to `timeout`. For start-up only (it sleeps).
    pub fn open_waiting(
        path: &Path,
        expect: Expect,
        timeout: Duration,
    ) -> Result<DpramBoard, OpenError> {
        let start = Instant::now();
        loop {
            match DpramBoard::open(path, expect) {
                Err(e) if e.is_not_ready() && start.elapsed() < timeout => {
                    std::thread::sleep(Duration::from_millis(10));
                }
                other => return other,
            }
        }
    }

    /// The checked header.
    pub fn header(&self) -> &Header {
        self.dpram.header()
    }

    /// The DPRAM (protocol-level access, e.g. for fault injection).
    pub fn dpram(&self) -> &Dpram {
        &self.dpram
    }

    /// Fill `axes[..axis_count]` and `board` from this board.
    pub(crate) fn read_into(
        &self,
        axes: &mut [AxisFeedback],
        board: &mut BoardFeedback,
    ) -> Result<(), Torn> {
        let d = &self.dpram;
        let mut record = AxisRecord::default();
        for (channel, out) in axes.iter_mut().enumerate().take(self.axis_count()) {
            d.read_feedback(channel, &mut record)?;
            let base = layout::axis_base(channel);
            *out = AxisFeedback {
                status: record.status,
                alarm: record.alarm,
                commanded: record.commanded,
                encoder: record.encoder,
                following_error: record.following_error,
                increment: record.increment,
                fifo_level: d.fifo_level(channel),
                underruns: d.load(base + axis::UNDERRUNS),
                alarms: d.load(base + axis::ALARMS),
                discarded: d.load(base + axis::DISCARDED),
            };
        }
        *board = BoardFeedback {
            status: d.load(control::BOARD_STATUS),
            board_watchdog: d.load(control::BOARD_WATCHDOG),
            period_count: d.load64(control::PERIOD_COUNT),
            watchdog_trips: d.load(control::WATCHDOG_TRIPS),
            late_periods: d.load(control::LATE_PERIODS),
            inputs: d.load(io::INPUTS),
            outputs: d.load(io::OUTPUTS_APPLIED),
            epoch: d.load(layout::header::EPOCH),
        };
        Ok(())
    }

    fn command(&mut self, code: u32, arg: u32) -> Result<(), Busy> {
        if self
            .dpram
            .post(control::COMMAND_SEQ, control::COMMAND_ACK, code, &[arg])
        {
            Ok(())
        } else {
            Err(Busy)
        }
    }
}

impl MotionBoard for DpramBoard {
    fn fifo_position(&self) -> Option<FifoPosition> {
        self.dpram.flush_position()
    }

    /// `next` is written into the free slots unpublished, the flush armed with their end,
    /// and then published by this thread too (whichever of it and the board comes first).
    fn flush_queued(&mut self, at: &FifoPosition, to: u32, next: &[[i64; MAX_AXES]]) -> bool {
        if next.len() > self.fifo_free() {
            return false;
        }
        let axes = self.axis_count();
        for (k, increments) in next.iter().enumerate() {
            for (channel, increment) in increments.iter().enumerate().take(axes) {
                self.dpram.fifo_stage(channel, k as u32, *increment);
            }
        }
        // Only this thread pushes: the write index is still the one `at` saw.
        let end = at.write.wrapping_add(next.len() as u32);
        if !self.dpram.flush_arm(at, to, end) {
            return false;
        }
        for channel in 0..axes {
            self.dpram.fifo_publish_to(channel, end);
        }
        true
    }

    fn stop_line(&self) -> Option<StopLine> {
        let map = self.dpram.mapping().share();
        Dpram::attach(map).ok().map(|d| StopLine::new(vec![d]))
    }

    fn set_brake_limits(&mut self, axis: usize, accel_pps2: f64, jerk_pps3: f64) {
        if axis < self.axis_count() {
            self.dpram.set_brake_limits(axis, accel_pps2, jerk_pps3);
        }
    }

    /// A brake the host has released already is not one to wait for, though the board
    /// shows it until its next period takes the release: the host that looked again before
    /// then would otherwise wait for a brake that ends without settling, for ever.
    ///
    /// The words are read in the reverse of the order the board writes them (docs/dpram.md,
    /// "Stops"), so each one read is at least as new as the one read before it: the flush's
    /// acknowledgement, then the stop's, then the status, then the count of own brakes.
    fn board_stop(&self) -> BoardStop {
        let d = &self.dpram;
        let flush_pending = d.load64(control::FLUSH) as u32 != d.load(control::FLUSH_ACK);
        let stop = stop::seq(d.load(control::STOP));
        let acked = stop::seq(d.load(control::STOP_ACK)) == stop;
        let status = d.load(control::BOARD_STATUS);
        let token = d.load(control::BOARD_STOPS);
        let released = d.load(control::RELEASE) == token;
        let braking_own = status & board_status::BOARD_BRAKE != 0 && !released;
        BoardStop {
            braking_own,
            settled: braking_own && status & board_status::STOPPING == 0,
            braking: status & board_status::STOPPING != 0,
            answered: !braking_own && acked && !flush_pending,
            estop: status & board_status::ESTOP != 0,
        }
    }

    fn release_stop(&mut self) {
        let status = self.dpram.load(control::BOARD_STATUS);
        if status & board_status::BOARD_BRAKE != 0 {
            let token = self.dpram.load(control::BOARD_STOPS);
            self.dpram.release_stop(token);
        }
    }

    fn axis_count(&self) -> usize {
        self.dpram.header().axis_count as usize
    }

    fn board_count(&self) -> usize {
        1
    }

    fn period_us(&self) -> u32 {
        self.dpram.header().period_us
    }

    fn fifo_free(&self) -> usize {
        (0..self.axis_count())
            .map(|c| self.dpram.fifo_free(c))
            .min()
            .unwrap_or(0) as usize
    }

    fn push(&mut self, increments: &[i64; MAX_AXES]) -> Result<(), Full> {
        if self.fifo_free() == 0 {
            return Err(Full);
        }
        for (channel, increment) in increments.iter().enumerate().take(self.axis_count()) {
            self.dpram.fifo_push(channel, *increment);
        }
        Ok(())
    }

    fn read_feedback(&self, out: &mut Feedback) -> Result<(), Torn> {
        out.axis_count = self.axis_count();
        out.board_count = 1;
        let (axes, boards) = (&mut out.axes, &mut out.boards);
        self.read_into(axes, &mut boards[0])
    }

    fn read_inputs(&self, board: usize) -> u32 {
        if board == 0 {
            self.dpram.load(io::INPUTS)
        } else {
            0
        }
    }

    fn write_outputs(&mut self, board: usize, outputs: u32) {
        if board == 0 {
            self.outputs = outputs;
            self.dpram.store(io::OUTPUTS, outputs);
        }
    }

    fn outputs(&self, board: usize) -> u32 {
        if board == 0 {
            self.outputs
        } else {
            0
        }
    }

    fn heartbeat(&self, board: usize) -> Option<Heartbeat> {
        (board == 0).then(|| Heartbeat {
            epoch: self.dpram.load(layout::header::EPOCH),
            beat: self.dpram.load(control::BOARD_WATCHDOG),
        })
    }

    fn refresh_watchdog(&mut self) {
        self.host_watchdog = self.host_watchdog.wrapping_add(1);
        self.dpram.store(control::HOST_WATCHDOG, self.host_watchdog);
    }

    fn clear_alarms(&mut self, axes: u16) -> Result<(), Busy> {
        self.command(command::CLEAR_ALARMS, u32::from(axes))
    }

    fn reset(&mut self) -> Result<(), Busy> {
        self.command(command::RESET, 0)
    }

    fn command_pending(&self) -> bool {
        self.dpram.load(control::COMMAND_ACK) != self.dpram.load(control::COMMAND_SEQ)
    }

    fn clear_mapping(&mut self) {
        self.dpram.bump(mapping::CLEAR_SEQ);
    }

    fn read_mapping(&self, out: &mut MappingScan) -> Result<(), Torn> {
        // Acknowledgement first (acquire): when it matches, the cleared latch the board
        // published before it is visible, so the record read next is the new scan's.
        let cleared = self.dpram.load(mapping::CLEAR_ACK) == self.dpram.load(mapping::CLEAR_SEQ);
        let mut record = MappingRecord::default();
        self.dpram.read_mapping(&mut record)?;
        *out = MappingScan::from_record(cleared, &record);
        Ok(())
    }
}
