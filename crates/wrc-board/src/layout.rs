//! The DPRAM layout, version 5: fixed byte offsets, little-endian 32- and 64-bit words, and
//! the header check every user of a mapping runs first. See `docs/dpram.md` for the table.
//!
//! Every word is naturally aligned, so each can be read and written as one atomic access;
//! multi-word records are protected by the protocols in [`crate::dpram`].

/// Magic number at offset 0: the bytes `WRCB` read as a little-endian `u32`.
pub const MAGIC: u32 = u32::from_le_bytes(*b"WRCB");
/// The layout version this crate reads and writes.
pub const VERSION: u32 = 5;
/// Axes on one board (the paper's PCI board drives 4).
pub const AXES_PER_BOARD: usize = 4;
/// Boards one controller drives at most (4 boards × 4 axes = 16 axes).
pub const MAX_BOARDS: usize = 4;
/// Command FIFO slots per axis; the usable depth (`fifo_depth`) is at most this [periods].
pub const FIFO_CAPACITY: usize = 256;
/// Bytes of one FIFO entry: `seq: u32`, `flags: u32`, `increment: i64`.
pub const FIFO_ENTRY_SIZE: usize = 16;

/// Header offsets (written once by the board at start; `magic` last).
pub mod header {
    /// `u32` magic, [`super::MAGIC`]; zero while the board initialises.
    pub const MAGIC: usize = 0x000;
    /// `u32` layout version, [`super::VERSION`].
    pub const VERSION: usize = 0x004;
    /// `u32` size of the layout [byte], [`super::LAYOUT_SIZE`].
    pub const SIZE: usize = 0x008;
    /// `u32` board id (0..4), the board's position in the controller.
    pub const BOARD_ID: usize = 0x00C;
    /// `u32` axes in use on this board (1..=4).
    pub const AXIS_COUNT: usize = 0x010;
    /// `u32` board period: one FIFO entry is consumed per period [µs].
    pub const PERIOD_US: usize = 0x014;
    /// `u32` usable FIFO depth (1..=[`super::FIFO_CAPACITY`]) [periods].
    pub const FIFO_DEPTH: usize = 0x018;
    /// `u32` FIFO slots in the layout, [`super::FIFO_CAPACITY`].
    pub const FIFO_CAPACITY: usize = 0x01C;
    /// `u32` board epoch: incremented every time the board (re)initialises the DPRAM.
    pub const EPOCH: usize = 0x020;
}

/// Control block offsets: watchdogs, status, the host command mailbox, counters.
pub mod control {
    /// `u32` host watchdog counter; the host increments it every cycle.
    pub const HOST_WATCHDOG: usize = 0x040;
    /// `u32` board watchdog counter; the board increments it every period.
    pub const BOARD_WATCHDOG: usize = 0x044;
    /// `u32` board status bits, [`crate::layout::board_status`].
    pub const BOARD_STATUS: usize = 0x048;
    /// `u32` command sequence: the host bumps it after writing code and argument.
    pub const COMMAND_SEQ: usize = 0x04C;
    /// `u32` command code, [`crate::layout::command`].
    pub const COMMAND_CODE: usize = 0x050;
    /// `u32` command argument (an axis mask for `CLEAR_ALARMS`).
    pub const COMMAND_ARG: usize = 0x054;
    /// `u32` last command sequence the board executed.
    pub const COMMAND_ACK: usize = 0x058;
    /// `u32` number of host-watchdog trips since the board started.
    pub const WATCHDOG_TRIPS: usize = 0x05C;
    /// `u64` board periods since the board started.
    pub const PERIOD_COUNT: usize = 0x060;
    /// `u32` board periods that started late and were caught up (simulated board only).
    pub const LATE_PERIODS: usize = 0x068;
    /// `u32` the last flush sequence (the low half of `FLUSH`) the board acted on.
    pub const FLUSH_ACK: usize = 0x06C;
    /// `u64` flush word: low 32 bits the flush sequence (the host raises it, by a
    /// compare-and-swap of the whole word, to ask for a flush), high 32 bits the board's
    /// period count, odd while the board is inside a period (the board adds 2³² at the start
    /// and at the end of every period). See [`crate::dpram`], "FIFO flush".
    pub const FLUSH: usize = 0x070;
    /// `u32` FIFO index the flushed stretch starts at: the entry the board executes next.
    pub const FLUSH_FROM: usize = 0x078;
    /// `u32` FIFO index the board resumes at after skipping `FLUSH_FROM..FLUSH_TO`.
    pub const FLUSH_TO: usize = 0x07C;
    /// `u32` stop word (host, any thread, by compare-and-swap): [`super::stop::word`] of a
    /// sequence (raised by every stop request) and the brake's level, the percentage of the
    /// axes' brake limits (`axis::BRAKE_ACCEL`, `axis::BRAKE_JERK`) the board brakes with when
    /// it brakes on its own.
    pub const STOP: usize = 0x08C;
    /// `u32` the stop word the board last acted on (board): answered by the host's flush,
    /// or braked on its own.
    pub const STOP_ACK: usize = 0x090;
    /// `u32` the stop sequence a flush answers (host, written before the flush is armed): a
    /// flush answering the pending stop brings the host's brake, so the board does not brake
    /// on its own.
    pub const FLUSH_STOP: usize = 0x094;
    /// `u32` the board's own brake the host releases, by its `BOARD_STOPS` count (host): the
    /// board then skips to `RELEASE_AT` and takes the FIFO again.
    pub const RELEASE: usize = 0x098;
    /// `u32` FIFO index the board resumes at on a release (host, written before `RELEASE`).
    pub const RELEASE_AT: usize = 0x09C;
    /// `u32` brakes the board took on its own since it started (board): stops the host did
    /// not answer in time, and underruns of a moving axis.
    pub const BOARD_STOPS: usize = 0x0B4;
    /// `u32` FIFO index after the brake's first entries (host, written before the flush is
    /// armed): the host writes them into the slots from the FIFO's write index on without
    /// publishing them, and the flush publishes them (the board advances every axis's
    /// `FIFO_WRITE` to it when it takes the flush, if the host has not yet), so the board
    /// never finds the flushed stretch's successor missing. Equal to the write index: nothing
    /// staged.
    pub const FLUSH_END: usize = 0x0B8;
}

/// The stop word ([`control::STOP`]): a 24-bit sequence above an 8-bit brake level.
pub mod stop {
    /// The word of sequence `seq` (24 bits kept) and brake level `level` [% of the brake
    /// limits, 1..=100].
    pub const fn word(seq: u32, level: u8) -> u32 {
        (seq << 8) | level as u32
    }
    /// The sequence of `word`.
    pub const fn seq(word: u32) -> u32 {
        word >> 8
    }
    /// The brake level of `word` [%], at least 1 and at most 100.
    pub const fn level(word: u32) -> u8 {
        let l = (word & 0xFF) as u8;
        if l == 0 {
            1
        } else if l > 100 {
            100
        } else {
            l
        }
    }
    /// The sequence after `seq` (24 bits, never 0: 0 is "no stop yet").
    pub const fn next(seq: u32) -> u32 {
        let n = seq.wrapping_add(1) & 0x00FF_FFFF;
        if n == 0 {
            1
        } else {
            n
        }
    }
}

/// Digital I/O offsets: 32 inputs and 32 outputs.
pub mod io {
    /// `u32` digital inputs, bit n = input n asserted (board writes).
    pub const INPUTS: usize = 0x080;
    /// `u32` digital outputs requested by the host (host writes).
    pub const OUTPUTS: usize = 0x084;
    /// `u32` digital outputs as the board drives them (board writes; read-back).
    pub const OUTPUTS_APPLIED: usize = 0x088;
}

/// Fault-injection mailbox (simulated board only; real hardware leaves it zero).
pub mod fault {
    /// `u32` fault sequence: the injector bumps it after writing code and arguments.
    pub const SEQ: usize = 0x0A0;
    /// `u32` fault code, [`crate::fault::Fault::code`].
    pub const CODE: usize = 0x0A4;
    /// `u32` first argument (axis or input bit).
    pub const ARG0: usize = 0x0A8;
    /// `u32` second argument (1 = on, 0 = off).
    pub const ARG1: usize = 0x0AC;
    /// `u32` last fault sequence the board applied.
    pub const ACK: usize = 0x0B0;
}

/// Mapping-sensor latch (a board that simulates the cell; a board without one leaves every
/// word 0). The host clears the latch through `CLEAR_SEQ`/`CLEAR_ACK`; the board latches a
/// code for every slot the sensor passes and publishes the latch under the seqlock `SEQ`.
pub mod mapping {
    /// `u32` clear sequence: the host increments it to clear the latch and start a new scan.
    pub const CLEAR_SEQ: usize = 0x0C0;
    /// `u32` the last `CLEAR_SEQ` the board acted on (the latch was cleared).
    pub const CLEAR_ACK: usize = 0x0C4;
    /// `u32` seqlock over `STATION`, `SEEN` and `CODES`: odd while the board writes them.
    pub const SEQ: usize = 0x0C8;
    /// `u32` 1 + the index (stations-file order) of the station whose slots the sensor has
    /// seen since the last clear; 0: none yet.
    pub const STATION: usize = 0x0CC;
    /// `u64` bit `s - 1` set when slot `s` has been scanned.
    pub const SEEN: usize = 0x0D0;
    /// `u32 × 4` slot codes, 2 bits a slot: slot `s` in word `(s - 1) / 16` at bit
    /// `2 · ((s - 1) % 16)`; values [`super::slot_code`].
    pub const CODES: usize = 0x0D8;
    /// Words of `CODES`.
    pub const CODE_WORDS: usize = 4;
    /// Slots the latch holds at most.
    pub const MAX_SLOTS: usize = 64;
}

/// Mapping-sensor slot codes (2 bits, [`mapping::CODES`]), as `wrc_cell::SlotCode`.
pub mod slot_code {
    /// No wafer (`0`).
    pub const ABSENT: u32 = 0;
    /// One wafer, flat (`1`).
    pub const PRESENT: u32 = 1;
    /// Two wafers in one slot (`2`).
    pub const DOUBLE: u32 = 2;
    /// A wafer across two slots (`X`).
    pub const CROSS: u32 = 3;
}

/// Per-axis block offsets, relative to [`axis_base`].
pub mod axis {
    /// `u32` feedback sequence (seqlock): odd while the board writes the record.
    pub const FB_SEQ: usize = 0x00;
    /// `u32` axis status bits, [`crate::layout::axis_status`].
    pub const STATUS: usize = 0x04;
    /// `i64` commanded position [pulse].
    pub const COMMANDED: usize = 0x08;
    /// `i64` encoder position [pulse].
    pub const ENCODER: usize = 0x10;
    /// `i64` following error, commanded − encoder [pulse].
    pub const FOLLOWING_ERROR: usize = 0x18;
    /// `u32` alarm cause bits, [`crate::layout::alarm`]; zero when not alarmed.
    pub const ALARM: usize = 0x20;
    /// `i64` increment executed in the last period [pulse/period].
    pub const INCREMENT: usize = 0x28;
    /// `u32` FIFO underruns (streaming axis found its FIFO empty) since board start.
    pub const UNDERRUNS: usize = 0x40;
    /// `u32` alarms raised since board start.
    pub const ALARMS: usize = 0x44;
    /// `u32` FIFO write index: entries pushed, wrapping (host writes).
    pub const FIFO_WRITE: usize = 0x48;
    /// `u32` FIFO read index: entries consumed, wrapping (board writes).
    pub const FIFO_READ: usize = 0x4C;
    /// `u32` entries consumed but not executed (axis alarmed or stopping).
    pub const DISCARDED: usize = 0x50;
    /// `u64` the axis's brake acceleration limit, written by the host at start-up [pulse/s²]
    /// (0: the board's own setting).
    pub const BRAKE_ACCEL: usize = 0x58;
    /// `u64` the axis's brake jerk limit, written by the host at start-up [pulse/s³] (0:
    /// the board's own setting).
    pub const BRAKE_JERK: usize = 0x60;
    /// First FIFO entry; slot `i` is at `FIFO + (i % FIFO_CAPACITY) * FIFO_ENTRY_SIZE`.
    pub const FIFO: usize = 0x80;
    /// Offsets inside one FIFO entry.
    pub mod entry {
        /// `u32` sequence number: the FIFO write index the entry was pushed at.
        pub const SEQ: usize = 0x0;
        /// `u32` flags, reserved (0).
        pub const FLAGS: usize = 0x4;
        /// `i64` pulse increment for one period [pulse/period].
        pub const INCREMENT: usize = 0x8;
    }
}

/// Start of the first axis block [byte].
pub const AXIS_BLOCKS: usize = 0x100;
/// Bytes of one axis block: 0x80 of fields, then the FIFO.
pub const AXIS_STRIDE: usize = axis::FIFO + FIFO_CAPACITY * FIFO_ENTRY_SIZE;
/// Total size of the layout [byte]; a mapping must be at least this long.
pub const LAYOUT_SIZE: usize = AXIS_BLOCKS + AXES_PER_BOARD * AXIS_STRIDE;

/// Byte offset of axis `channel`'s block (channel < [`AXES_PER_BOARD`]).
pub const fn axis_base(channel: usize) -> usize {
    AXIS_BLOCKS + channel * AXIS_STRIDE
}

/// Byte offset of the FIFO slot that FIFO index `index` uses on axis `channel`.
pub const fn fifo_slot(channel: usize, index: u32) -> usize {
    axis_base(channel) + axis::FIFO + (index as usize % FIFO_CAPACITY) * FIFO_ENTRY_SIZE
}

/// Board status bits (`control::BOARD_STATUS`).
pub mod board_status {
    /// The board has initialised the DPRAM and is running its period.
    pub const RUNNING: u32 = 1 << 0;
    /// The host has refreshed its watchdog at least once, so the board watches it.
    pub const WATCHDOG_ARMED: u32 = 1 << 1;
    /// The host watchdog went stale; all axes were stopped. Cleared by `RESET`.
    pub const WATCHDOG_TRIPPED: u32 = 1 << 2;
    /// The E-stop input is (or was, until `RESET`) asserted; all axes were stopped.
    pub const ESTOP: u32 = 1 << 3;
    /// At least one axis is in a controlled deceleration to standstill.
    pub const STOPPING: u32 = 1 << 4;
    /// At least one axis is alarmed.
    pub const ALARM: u32 = 1 << 5;
    /// The board braked on its own on a stop the host did not answer in time: it discards
    /// every FIFO entry until the host releases it (`control::RELEASE`).
    pub const BOARD_BRAKE: u32 = 1 << 6;
}

/// Axis status bits (`axis::STATUS`).
pub mod axis_status {
    /// The servo is on (not alarmed).
    pub const SERVO_ON: u32 = 1 << 0;
    /// The axis is alarmed; see the alarm cause bits.
    pub const ALARM: u32 = 1 << 1;
    /// The positive limit switch is active.
    pub const LIMIT_POS: u32 = 1 << 2;
    /// The negative limit switch is active.
    pub const LIMIT_NEG: u32 = 1 << 3;
    /// The axis moved in the last period.
    pub const MOVING: u32 = 1 << 4;
    /// The axis is in a controlled stop (watchdog, E-stop, a stop the board brakes on its
    /// own): decelerating, then holding until the stop ends.
    pub const STOPPING: u32 = 1 << 5;
    /// The axis found its FIFO empty in the last period.
    pub const UNDERRUN: u32 = 1 << 6;
    /// The axis is streaming: it consumed an entry since the last reset and expects one
    /// every period.
    pub const STREAMING: u32 = 1 << 7;
}

/// Alarm cause bits (`axis::ALARM`).
pub mod alarm {
    /// A period's increment exceeded the motor's velocity limit (the paper: overcurrent).
    pub const OVERSPEED: u32 = 1 << 0;
    /// |commanded − encoder| exceeded the following-error limit.
    pub const FOLLOWING_ERROR: u32 = 1 << 1;
    /// Motion into an active positive limit switch.
    pub const LIMIT_POS: u32 = 1 << 2;
    /// Motion into an active negative limit switch.
    pub const LIMIT_NEG: u32 = 1 << 3;
    /// A FIFO entry carried the wrong sequence number.
    pub const FIFO_SEQUENCE: u32 = 1 << 4;
    /// The servo amplifier reported an alarm (injected on the simulated board).
    pub const AMPLIFIER: u32 = 1 << 5;
}

/// Host command codes (`control::COMMAND_CODE`).
pub mod command {
    /// No command.
    pub const NONE: u32 = 0;
    /// Clear the alarms of the axes in the argument mask; the commanded position is set
    /// to the encoder position so the axis does not jump.
    pub const CLEAR_ALARMS: u32 = 1;
    /// Clear the watchdog trip, the E-stop latch and all alarms; axes stop streaming.
    pub const RESET: u32 = 2;
}

/// A header that cannot be used, found by [`Header::parse`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum LayoutError {
    /// Fewer bytes than the layout needs.
    #[error("truncated: {len} bytes, the DPRAM layout needs {LAYOUT_SIZE}")]
    Truncated {
        /// Bytes available.
        len: usize,
    },
    /// Magic is zero: the board has not finished initialising.
    #[error("not initialised yet (magic is 0): the board has not started or is restarting")]
    NotReady,
    /// Magic is wrong: some other file or device.
    #[error("not a wrc DPRAM: magic is {found:#010x}, expected {MAGIC:#010x} (\"WRCB\")")]
    Foreign {
        /// The magic found.
        found: u32,
    },
    /// A layout version this build does not know.
    #[error("DPRAM layout version {found}, this build reads version {VERSION}")]
    Version {
        /// The version found.
        found: u32,
    },
    /// A header field out of range.
    #[error("bad header field {field}: {value} ({expected})")]
    Field {
        /// The field name.
        field: &'static str,
        /// Its value.
        value: u32,
        /// What was expected.
        expected: &'static str,
    },
}

/// The header, decoded and checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// Board id (0..4).
    pub board_id: u32,
    /// Axes in use (1..=4).
    pub axis_count: u32,
    /// Board period [µs].
    pub period_us: u32,
    /// Usable FIFO depth [periods].
    pub fifo_depth: u32,
    /// Board epoch (restart counter).
    pub epoch: u32,
}

fn word(bytes: &[u8], offset: usize) -> u32 {
    let mut w = [0u8; 4];
    w.copy_from_slice(&bytes[offset..offset + 4]);
    u32::from_le_bytes(w)
}

impl Header {
    /// Decode and check the header from the first bytes of a DPRAM image (`bytes` is the
    /// whole mapping, so its length is checked against [`LAYOUT_SIZE`] too).
    pub fn parse(bytes: &[u8]) -> Result<Header, LayoutError> {
        if bytes.len() < LAYOUT_SIZE {
            return Err(LayoutError::Truncated { len: bytes.len() });
        }
        Header::from_words(|offset| word(bytes, offset), bytes.len())
    }

    /// Decode and check a header given a word reader (offset → little-endian `u32`) and the
    /// mapping length [byte]; used on live mappings, where words are read atomically.
    pub fn from_words(read: impl Fn(usize) -> u32, len: usize) -> Result<Header, LayoutError> {
        if len < LAYOUT_SIZE {
            return Err(LayoutError::Truncated { len });
        }
        match read(header::MAGIC) {
            0 => return Err(LayoutError::NotReady),
            MAGIC => {}
            found => return Err(LayoutError::Foreign { found }),
        }
        let version = read(header::VERSION);
        if version != VERSION {
            return Err(LayoutError::Version { found: version });
        }
        let field = |field, value, ok: bool, expected| {
            if ok {
                Ok(value)
            } else {
                Err(LayoutError::Field {
                    field,
                    value,
                    expected,
                })
            }
        };
        let size = read(header::SIZE);
        field(
            "size",
            size,
            size as usize == LAYOUT_SIZE,
            "must equal the version-1 layout size",
        )?;
        let capacity = read(header::FIFO_CAPACITY);
        field(
            "fifo_capacity",
            capacity,
            capacity as usize == FIFO_CAPACITY,
            "must be 64",
        )?;
        let board_id = read(header::BOARD_ID);
        field(
            "board_id",
            board_id,
            (board_id as usize) < MAX_BOARDS,
            "expected 0 to 3",
        )?;
        let axis_count = read(header::AXIS_COUNT);
        field(
            "axis_count",
            axis_count,
            (1..=AXES_PER_BOARD as u32).contains(&axis_count),
            "expected 1 to 4",
        )?;
        let period_us = read(header::PERIOD_US);
        field(
            "period_us",
            period_us,
            (100..=1_000_000).contains(&period_us),
            "expected 100 to 1000000",
        )?;
        let fifo_depth = read(header::FIFO_DEPTH);
        field(
            "fifo_depth",
            fifo_depth,
            (1..=FIFO_CAPACITY as u32).contains(&fifo_depth),
            "expected 1 to 256",
        )?;
        Ok(Header {
            board_id,
            axis_count,
            period_us,
            fifo_depth,
            epoch: read(header::EPOCH),
        })
    }

    /// Encode the header into `bytes` (at least [`LAYOUT_SIZE`] long), magic included.
    /// Live boards write the words atomically instead, magic last ([`crate::dpram`]).
    pub fn encode(&self, bytes: &mut [u8]) {
        for (offset, value) in self.words() {
            bytes[offset..offset + 4].copy_from_slice(&value.to_le_bytes());
        }
        bytes[header::MAGIC..header::MAGIC + 4].copy_from_slice(&MAGIC.to_le_bytes());
    }

    /// The header words except magic, as (offset, value).
    pub fn words(&self) -> [(usize, u32); 8] {
        [
            (header::VERSION, VERSION),
            (header::SIZE, LAYOUT_SIZE as u32),
            (header::BOARD_ID, self.board_id),
            (header::AXIS_COUNT, self.axis_count),
            (header::PERIOD_US, self.period_us),
            (header::FIFO_DEPTH, self.fifo_depth),
            (header::FIFO_CAPACITY, FIFO_CAPACITY as u32),
            (header::EPOCH, self.epoch),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Header {
        Header {
            board_id: 2,
            axis_count: 3,
            period_us: 1000,
            fifo_depth: 8,
            epoch: 7,
        }
    }

    #[test]
    fn layout_is_fixed() {
        // Pinned numbers: changing any of them is a new layout version.
        assert_eq!(AXIS_STRIDE, 0x1080);
        assert_eq!(LAYOUT_SIZE, 0x4300);
        assert_eq!(axis_base(3), 0x3280);
        assert_eq!(fifo_slot(0, 257), 0x100 + 0x80 + 16);
        assert_eq!(MAGIC.to_le_bytes(), *b"WRCB");
        // The mapping latch lives in the control block's free space, after the fault
        // mailbox and before the first axis block; nothing else moved.
        assert_eq!(
            [
                mapping::CLEAR_SEQ,
                mapping::CLEAR_ACK,
                mapping::SEQ,
                mapping::STATION,
                mapping::SEEN,
                mapping::CODES
            ],
            [0x0C0, 0x0C4, 0x0C8, 0x0CC, 0x0D0, 0x0D8]
        );
        const {
            assert!(fault::ACK + 4 <= mapping::CLEAR_SEQ);
            assert!(mapping::SEEN % 8 == 0);
            assert!(mapping::CODES + 4 * mapping::CODE_WORDS <= AXIS_BLOCKS);
            assert!(mapping::MAX_SLOTS == 16 * mapping::CODE_WORDS);
        }
    }

    #[test]
    fn header_round_trip() {
        let mut bytes = vec![0u8; LAYOUT_SIZE];
        sample().encode(&mut bytes);
        assert_eq!(&bytes[0..4], b"WRCB");
        assert_eq!(Header::parse(&bytes), Ok(sample()));
    }

    #[test]
    fn bad_headers_are_named() {
        let mut bytes = vec![0u8; LAYOUT_SIZE];
        assert_eq!(Header::parse(&bytes), Err(LayoutError::NotReady));
        sample().encode(&mut bytes);
        assert_eq!(
            Header::parse(&bytes[..100]),
            Err(LayoutError::Truncated { len: 100 })
        );
        let mut foreign = bytes.clone();
        foreign[0..4].copy_from_slice(b"\x7fELF");
        assert!(matches!(
            Header::parse(&foreign),
            Err(LayoutError::Foreign { .. })
        ));
        // A board of layout 1 (no FIFO flush) is refused, by its version.
        let mut v1 = bytes.clone();
        v1[header::VERSION] = 1;
        assert_eq!(Header::parse(&v1), Err(LayoutError::Version { found: 1 }));
        let mut axes = bytes.clone();
        axes[header::AXIS_COUNT] = 5;
        let e = Header::parse(&axes).unwrap_err().to_string();
        assert!(e.contains("axis_count") && e.contains('5'), "{e}");
    }
}
