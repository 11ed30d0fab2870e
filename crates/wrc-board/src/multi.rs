//! [`MultiBoard`]: up to four boards behind one [`MotionBoard`], mapping the controller's
//! axes 0..16 onto (board, channel) pairs. Same real-time promise as the boards it wraps:
//! no allocation or blocking after construction.

use crate::dpram::FifoPosition;
use wrc_robot::MAX_AXES;

use crate::board::{BoardStop, Busy, Feedback, Full, MappingScan, MotionBoard, StopLine, Torn};
use crate::layout::{AXES_PER_BOARD, MAX_BOARDS};

/// Boards and an axis map that do not fit together.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MultiError {
    /// No boards or more than [`MAX_BOARDS`].
    #[error("{0} boards given; expected 1 to {MAX_BOARDS}")]
    BoardCount(usize),
    /// More axes than [`MAX_AXES`].
    #[error("{0} axes mapped; at most {MAX_AXES}")]
    AxisCount(usize),
    /// An axis maps to a board or channel that does not exist.
    #[error("axis {axis} maps to board {board} channel {channel}, which does not exist")]
    NoSuchChannel {
        /// Controller axis.
        axis: usize,
        /// Board index.
        board: usize,
        /// Channel on the board.
        channel: usize,
    },
    /// Two axes map to the same channel.
    #[error("axes {first} and {second} both map to board {board} channel {channel}")]
    SharedChannel {
        /// First axis.
        first: usize,
        /// Second axis.
        second: usize,
        /// Board index.
        board: usize,
        /// Channel.
        channel: usize,
    },
    /// Boards run at different periods.
    #[error("board {board} runs at {found} µs, board 0 at {expected} µs; all boards must share the period")]
    Period {
        /// Board index.
        board: usize,
        /// Its period [µs].
        found: u32,
        /// Board 0's period [µs].
        expected: u32,
    },
}

/// Several boards as one.
#[derive(Debug)]
pub struct MultiBoard<B> {
    boards: Vec<B>,
    /// `map[axis] = (board, channel)` for `axis < axis_count`.
    map: [(u8, u8); MAX_AXES],
    axis_count: usize,
    /// A flush's entries in the board's channels (capacity a whole FIFO, reserved here:
    /// a flush does not allocate).
    remapped: Vec<[i64; MAX_AXES]>,
}

impl<B: MotionBoard> MultiBoard<B> {
    /// Wrap `boards`; `axes[i] = (board, channel)` places controller axis `i`.
    pub fn new(boards: Vec<B>, axes: &[(usize, usize)]) -> Result<MultiBoard<B>, MultiError> {
        if boards.is_empty() || boards.len() > MAX_BOARDS {
            return Err(MultiError::BoardCount(boards.len()));
        }
        if axes.len() > MAX_AXES {
            return Err(MultiError::AxisCount(axes.len()));
        }
        let expected = boards[0].period_us();
        for (board, b) in boards.iter().enumerate() {
            if b.period_us() != expected {
                return Err(MultiError::Period {
                    board,
                    found: b.period_us(),
                    expected,
                });
            }
        }
        let mut map = [(0u8, 0u8); MAX_AXES];
        for (axis, &(board, channel)) in axes.iter().enumerate() {
            if board >= boards.len() || channel >= boards[board].axis_count().min(AXES_PER_BOARD) {
                return Err(MultiError::NoSuchChannel {
                    axis,
                    board,
                    channel,
                });
            }
            if let Some(first) = axes[..axis].iter().position(|&p| p == (board, channel)) {
                return Err(MultiError::SharedChannel {
                    first,
                    second: axis,
                    board,
                    channel,
                });
            }
            map[axis] = (board as u8, channel as u8);
        }
        Ok(MultiBoard {
            boards,
            map,
            axis_count: axes.len(),
            remapped: Vec::with_capacity(crate::layout::FIFO_CAPACITY),
        })
    }

    /// The wrapped boards.
    pub fn boards(&self) -> &[B] {
        &self.boards
    }
}

impl<B: MotionBoard> MotionBoard for MultiBoard<B> {
    fn axis_count(&self) -> usize {
        self.axis_count
    }

    fn board_count(&self) -> usize {
        self.boards.len()
    }

    fn period_us(&self) -> u32 {
        self.boards[0].period_us()
    }

    fn fifo_free(&self) -> usize {
        self.boards.iter().map(|b| b.fifo_free()).min().unwrap_or(0)
    }

    fn push(&mut self, increments: &[i64; MAX_AXES]) -> Result<(), Full> {
        // All boards take the period or none does, so axes stay in step across boards.
        if self.fifo_free() == 0 {
            return Err(Full);
        }
        let mut per_board = [[0i64; MAX_AXES]; MAX_BOARDS];
        for (axis, &(board, channel)) in self.map.iter().enumerate().take(self.axis_count) {
            per_board[board as usize][channel as usize] = increments[axis];
        }
        for (board, increments) in self.boards.iter_mut().zip(per_board.iter()) {
            board.push(increments)?;
        }
        Ok(())
    }

    fn read_feedback(&self, out: &mut Feedback) -> Result<(), Torn> {
        let mut one = Feedback::default();
        out.axis_count = self.axis_count;
        out.board_count = self.boards.len();
        for (index, board) in self.boards.iter().enumerate() {
            board.read_feedback(&mut one)?;
            out.boards[index] = one.boards[0];
            for (axis, &(b, channel)) in self.map.iter().enumerate().take(self.axis_count) {
                if b as usize == index {
                    out.axes[axis] = one.axes[channel as usize];
                }
            }
        }
        Ok(())
    }

    fn read_inputs(&self, board: usize) -> u32 {
        self.boards.get(board).map_or(0, |b| b.read_inputs(0))
    }

    fn write_outputs(&mut self, board: usize, outputs: u32) {
        if let Some(b) = self.boards.get_mut(board) {
            b.write_outputs(0, outputs);
        }
    }

    fn outputs(&self, board: usize) -> u32 {
        self.boards.get(board).map_or(0, |b| b.outputs(0))
    }

    fn heartbeat(&self, board: usize) -> Option<crate::board::Heartbeat> {
        self.boards.get(board).and_then(|b| b.heartbeat(0))
    }

    fn refresh_watchdog(&mut self) {
        for b in &mut self.boards {
            b.refresh_watchdog();
        }
    }

    fn clear_alarms(&mut self, axes: u16) -> Result<(), Busy> {
        let mut masks = [0u16; MAX_BOARDS];
        for (axis, &(board, channel)) in self.map.iter().enumerate().take(self.axis_count) {
            if axes & (1 << axis) != 0 {
                masks[board as usize] |= 1 << channel;
            }
        }
        let mut result = Ok(());
        for (b, mask) in self.boards.iter_mut().zip(masks) {
            if mask != 0 && b.clear_alarms(mask).is_err() {
                result = Err(Busy);
            }
        }
        result
    }

    fn reset(&mut self) -> Result<(), Busy> {
        let mut result = Ok(());
        for b in &mut self.boards {
            if b.reset().is_err() {
                result = Err(Busy);
            }
        }
        result
    }

    fn command_pending(&self) -> bool {
        self.boards.iter().any(|b| b.command_pending())
    }

    /// The mapping sensor is board 0's.
    fn clear_mapping(&mut self) {
        self.boards[0].clear_mapping();
    }

    /// The mapping sensor is board 0's.
    fn read_mapping(&self, out: &mut MappingScan) -> Result<(), Torn> {
        self.boards[0].read_mapping(out)
    }

    // Boards keep their own time, so a flush cannot be armed on several at once: only a
    // single board flushes (several brake behind their queued periods).
    fn fifo_position(&self) -> Option<FifoPosition> {
        match &self.boards[..] {
            [one] => one.fifo_position(),
            _ => None,
        }
    }

    fn flush_queued(&mut self, at: &FifoPosition, to: u32, next: &[[i64; MAX_AXES]]) -> bool {
        let [one] = &mut self.boards[..] else {
            return false;
        };
        if next.len() > self.remapped.capacity() {
            return false;
        }
        self.remapped.clear();
        for increments in next {
            let mut own = [0i64; MAX_AXES];
            for (axis, &(_, channel)) in self.map.iter().enumerate().take(self.axis_count) {
                own[channel as usize] = increments[axis];
            }
            self.remapped.push(own);
        }
        one.flush_queued(at, to, &self.remapped)
    }

    /// One line to every board, if every board has one.
    fn stop_line(&self) -> Option<StopLine> {
        let mut boards = Vec::with_capacity(self.boards.len());
        for b in &self.boards {
            boards.extend(b.stop_line()?.boards);
        }
        Some(StopLine::new(boards))
    }

    fn set_brake_limits(&mut self, axis: usize, accel_pps2: f64, jerk_pps3: f64) {
        if axis < self.axis_count {
            let (board, channel) = self.map[axis];
            self.boards[usize::from(board)].set_brake_limits(
                usize::from(channel),
                accel_pps2,
                jerk_pps3,
            );
        }
    }

    fn board_stop(&self) -> BoardStop {
        let mut all = BoardStop {
            braking_own: false,
            settled: true,
            braking: false,
            answered: true,
            estop: false,
        };
        for b in &self.boards {
            let s = b.board_stop();
            if s.braking_own {
                all.braking_own = true;
                all.settled &= s.settled;
            }
            all.answered &= s.answered;
            all.braking |= s.braking;
            all.estop |= s.estop;
        }
        all.settled &= all.braking_own;
        all.answered &= !all.braking_own;
        all
    }

    fn release_stop(&mut self) {
        for b in &mut self.boards {
            b.release_stop();
        }
    }
}
