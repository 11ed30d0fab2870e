//! The DPRAM access protocols, both ends: the single-producer/single-consumer command FIFO
//! per axis, the seqlock on each axis's feedback record, the host command and fault mailboxes
//! and plain counters. Every method is one or a few atomic loads and stores on the mapping:
//! no allocation, no lock, no system call, so both the host's real-time cycle and the
//! board's period may call them.
//!
//! Protocols (a writer never leaves a half-written record visible):
//! - **Header**: the board zeroes `magic` first, writes the other fields and the rest of
//!   the DPRAM, then stores `magic` with release ordering; a reader loads `magic` with
//!   acquire ordering first and trusts the header only if it is [`MAGIC`].
//! - **FIFO** (host → board, per axis): the host writes an entry (`seq` = the write index,
//!   the increment) into slot `write % capacity`, then publishes it by storing `write + 1`
//!   with release ordering. The board loads `write` with acquire ordering, reads the entry,
//!   checks its `seq`, then frees the slot by storing `read + 1` with release ordering. The
//!   host pushes only while `write − read < fifo_depth`.
//! - **FIFO flush** (a stop that must not wait for the queued periods): the host replaces
//!   the entries the board has not executed yet by new ones (a brake from the state the
//!   board has reached) without a race. The board adds 2³² to the `FLUSH` word at the start
//!   and at the end of every period (the high half is odd inside a period). The host loads
//!   `FLUSH` (acquire); if the board is between periods and no flush is pending (low half =
//!   `FLUSH_ACK`), it reads `read` and `write` — the board executes entry `read` next — and
//!   pushes the new entries behind the old ones. It stores `FLUSH_FROM = read` and
//!   `FLUSH_TO` = the first new entry, then raises the low half by a compare-and-swap of the
//!   whole word against the value it loaded (release): the swap fails if a period began in
//!   between, and then nothing is asked (the host tries again from the new `read`). At the
//!   start of its next period the board sees the new sequence, checks on every axis that
//!   `read == FLUSH_FROM` and that `FLUSH_TO` is within the published entries, skips the
//!   stretch (`read = FLUSH_TO`, counted in `discarded`), stores `FLUSH_ACK`, and executes
//!   the first new entry in that very period. A check that fails is a FIFO sequence alarm.
//! - **Feedback** (board → host, per axis): a seqlock. The board makes `fb_seq` odd, writes
//!   the record, makes `fb_seq` even again (release). The host reads `fb_seq` (acquire),
//!   the record, `fb_seq` again; equal and even means a consistent snapshot, otherwise it
//!   retries a bounded number of times and then reports [`Torn`].
//! - **Mapping latch** (board → host): the same seqlock on `mapping::SEQ` over the
//!   station, seen and codes words. The host clears it by bumping `CLEAR_SEQ`; the board
//!   clears the latch at its next period, publishes it, then stores `CLEAR_ACK = CLEAR_SEQ`
//!   (release).
//! - **Mailboxes** (host commands, injected faults): the writer stores code and arguments,
//!   then bumps `seq` (release); the board acts once per period when `seq != ack`, then stores
//!   `ack = seq` (release). A writer posts a new command only when `ack == seq`.
//! - **Single words** (watchdogs, status, I/O, counters): one writer each, plain atomic
//!   stores; readers see either the old or the new value.

use std::sync::atomic::{fence, Ordering};

use crate::layout::{self, axis, control, header, Header, LayoutError, FIFO_CAPACITY, MAGIC};
use crate::mapping::Mapping;

/// Where the command FIFO stands between two board periods, for a flush
/// ([`Dpram::flush_position`], [`crate::MotionBoard::fifo_position`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FifoPosition {
    /// The flush word as loaded (the compare-and-swap checks that no period began since).
    pub word: u64,
    /// FIFO index of the entry the board executes next (every axis of the board).
    pub read: u32,
    /// FIFO index the next pushed entry gets.
    pub write: u32,
}

/// A flush the host asked for, as the board takes it ([`Dpram::period_begin`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Flush {
    /// FIFO index of the first entry to skip (the one the board executes next).
    pub from: u32,
    /// FIFO index the board resumes at.
    pub to: u32,
    /// FIFO index after the entries the flush publishes (staged by the host).
    pub end: u32,
    /// The stop sequence the flush answers.
    pub answers: u32,
}

/// A feedback record could not be read consistently: the board kept rewriting it (or a
/// foreign writer left it odd). Try again next cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the board rewrote the feedback record while it was read; try again next cycle")]
pub struct Torn;

/// One axis's feedback record, as the board publishes it every period.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AxisRecord {
    /// Axis status bits, [`layout::axis_status`].
    pub status: u32,
    /// Commanded position [pulse].
    pub commanded: i64,
    /// Encoder position [pulse].
    pub encoder: i64,
    /// Following error, commanded − encoder [pulse].
    pub following_error: i64,
    /// Alarm cause bits, [`layout::alarm`]; 0 when not alarmed.
    pub alarm: u32,
    /// Increment executed in the last period [pulse/period].
    pub increment: i64,
}

/// The mapping-sensor latch as the board publishes it ([`layout::mapping`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MappingRecord {
    /// 1 + the index of the station whose slots were seen; 0: none yet.
    pub station: u32,
    /// Bit `s - 1` set when slot `s` has been scanned.
    pub seen: u64,
    /// 2 bits a slot, slot `s` in word `(s - 1) / 16` at bit `2 · ((s - 1) % 16)`.
    pub codes: [u32; layout::mapping::CODE_WORDS],
}

/// What the board found at the head of an axis FIFO.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pop {
    /// No entry: the FIFO is empty.
    Empty,
    /// The next period's increment [pulse/period].
    Entry(i64),
    /// The entry's sequence number or the indices are wrong; the FIFO was resynchronised.
    SequenceError,
}

/// Seqlock read attempts before [`Torn`].
const SEQLOCK_TRIES: usize = 8;

/// A mapped DPRAM with a checked header: the protocol operations of both ends.
#[derive(Debug)]
pub struct Dpram {
    map: Mapping,
    header: Header,
}

impl Dpram {
    /// Attach to an initialised DPRAM: check magic (acquire), version, size and fields.
    pub fn attach(map: Mapping) -> Result<Dpram, (Mapping, LayoutError)> {
        let magic = map.u32(header::MAGIC).load(Ordering::Acquire);
        let len = map.len();
        let parsed = Header::from_words(
            |offset| {
                if offset == header::MAGIC {
                    magic
                } else {
                    map.u32(offset).load(Ordering::Relaxed)
                }
            },
            len,
        );
        match parsed {
            Ok(header) => Ok(Dpram { map, header }),
            Err(e) => Err((map, e)),
        }
    }

    /// Board side: initialise the DPRAM (zero everything, write `header`, magic last).
    pub fn initialize(map: Mapping, header: Header) -> Dpram {
        map.u32(header::MAGIC).store(0, Ordering::Release);
        for offset in (4..layout::LAYOUT_SIZE).step_by(4) {
            map.u32(offset).store(0, Ordering::Relaxed);
        }
        for (offset, value) in header.words() {
            map.u32(offset).store(value, Ordering::Relaxed);
        }
        map.u32(header::MAGIC).store(MAGIC, Ordering::Release);
        Dpram { map, header }
    }

    /// The checked header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Give the mapping back.
    pub fn into_mapping(self) -> Mapping {
        self.map
    }

    /// The mapping.
    pub fn mapping(&self) -> &Mapping {
        &self.map
    }

    /// Load a 32-bit word (acquire).
    #[inline]
    pub fn load(&self, offset: usize) -> u32 {
        self.map.u32(offset).load(Ordering::Acquire)
    }

    /// Store a 32-bit word (release).
    #[inline]
    pub fn store(&self, offset: usize, value: u32) {
        self.map.u32(offset).store(value, Ordering::Release)
    }

    /// Load a 64-bit word (acquire).
    #[inline]
    pub fn load64(&self, offset: usize) -> u64 {
        self.map.u64(offset).load(Ordering::Acquire)
    }

    /// Store a 64-bit word (release).
    #[inline]
    pub fn store64(&self, offset: usize, value: u64) {
        self.map.u64(offset).store(value, Ordering::Release)
    }

    /// Add 1 to a 32-bit counter that only the caller writes (wrapping).
    #[inline]
    pub fn bump(&self, offset: usize) {
        let w = self.map.u32(offset);
        w.store(w.load(Ordering::Relaxed).wrapping_add(1), Ordering::Release);
    }

    /// Whether magic still reads [`MAGIC`] (false while the board re-initialises).
    pub fn is_live(&self) -> bool {
        self.load(header::MAGIC) == MAGIC && self.load(header::EPOCH) == self.header.epoch
    }

    // ---- FIFO ----

    /// Entries waiting in axis `channel`'s FIFO [periods] (as the host sees it; a corrupt
    /// index pair reads as full).
    #[inline]
    pub fn fifo_level(&self, channel: usize) -> u32 {
        let base = layout::axis_base(channel);
        let write = self
            .map
            .u32(base + axis::FIFO_WRITE)
            .load(Ordering::Relaxed);
        let read = self.load(base + axis::FIFO_READ);
        write.wrapping_sub(read).min(FIFO_CAPACITY as u32)
    }

    /// Host: free slots in axis `channel`'s FIFO [periods].
    #[inline]
    pub fn fifo_free(&self, channel: usize) -> u32 {
        self.header
            .fifo_depth
            .saturating_sub(self.fifo_level(channel))
    }

    /// Host: write `increment` into the next slot and publish it. The caller has checked
    /// [`Dpram::fifo_free`] (only the host pushes, so the room cannot shrink meanwhile).
    #[inline]
    pub fn fifo_push(&self, channel: usize, increment: i64) {
        let base = layout::axis_base(channel);
        let write = self
            .map
            .u32(base + axis::FIFO_WRITE)
            .load(Ordering::Relaxed);
        self.write_slot(channel, write, increment);
        self.store(base + axis::FIFO_WRITE, write.wrapping_add(1));
    }

    /// Host: fill axis `channel`'s slot for FIFO index `index` (not published).
    #[inline]
    fn write_slot(&self, channel: usize, index: u32, increment: i64) {
        let slot = layout::fifo_slot(channel, index);
        self.map
            .u32(slot + axis::entry::SEQ)
            .store(index, Ordering::Relaxed);
        self.map
            .u32(slot + axis::entry::FLAGS)
            .store(0, Ordering::Relaxed);
        self.map
            .u64(slot + axis::entry::INCREMENT)
            .store(increment as u64, Ordering::Relaxed);
    }

    /// Board: take the entry at the head of axis `channel`'s FIFO.
    #[inline]
    pub fn fifo_pop(&self, channel: usize) -> Pop {
        let base = layout::axis_base(channel);
        let write = self.load(base + axis::FIFO_WRITE);
        let read = self.map.u32(base + axis::FIFO_READ).load(Ordering::Relaxed);
        let available = write.wrapping_sub(read);
        if available == 0 {
            return Pop::Empty;
        }
        if available > FIFO_CAPACITY as u32 {
            self.store(base + axis::FIFO_READ, write);
            return Pop::SequenceError;
        }
        let slot = layout::fifo_slot(channel, read);
        let seq = self
            .map
            .u32(slot + axis::entry::SEQ)
            .load(Ordering::Relaxed);
        let increment = self
            .map
            .u64(slot + axis::entry::INCREMENT)
            .load(Ordering::Relaxed) as i64;
        self.store(base + axis::FIFO_READ, read.wrapping_add(1));
        if seq == read {
            Pop::Entry(increment)
        } else {
            Pop::SequenceError
        }
    }

    /// Host: write `increment` into the slot `k` entries after axis `channel`'s write index,
    /// without publishing it: a flush publishes it ([`Dpram::flush_arm`]'s `end`). The
    /// caller has checked [`Dpram::fifo_free`] (the slot is not one the board may read).
    #[inline]
    pub fn fifo_stage(&self, channel: usize, k: u32, increment: i64) {
        let base = layout::axis_base(channel);
        let index = self
            .map
            .u32(base + axis::FIFO_WRITE)
            .load(Ordering::Relaxed)
            .wrapping_add(k);
        self.write_slot(channel, index, increment);
    }

    /// Host and board: publish axis `channel`'s entries up to FIFO index `end` (staged by
    /// [`Dpram::fifo_stage`] and carried by a flush), unless they are already: a
    /// compare-and-swap, so a write index the host has moved on since is kept.
    pub fn fifo_publish_to(&self, channel: usize, end: u32) {
        let write = self.map.u32(layout::axis_base(channel) + axis::FIFO_WRITE);
        let now = write.load(Ordering::Acquire);
        let ahead = end.wrapping_sub(now);
        if ahead != 0 && ahead <= FIFO_CAPACITY as u32 {
            let _ = write.compare_exchange(now, end, Ordering::AcqRel, Ordering::Relaxed);
        }
    }

    /// Board: drop every waiting entry of axis `channel`; returns how many.
    pub fn fifo_drain(&self, channel: usize) -> u32 {
        let base = layout::axis_base(channel);
        let write = self.load(base + axis::FIFO_WRITE);
        let read = self.map.u32(base + axis::FIFO_READ).load(Ordering::Relaxed);
        self.store(base + axis::FIFO_READ, write);
        write.wrapping_sub(read).min(FIFO_CAPACITY as u32)
    }

    // ---- FIFO flush ----

    /// Host: where the FIFO stands, if the board is between two periods and no flush is
    /// pending (else `None`: try again later).
    pub fn flush_position(&self) -> Option<FifoPosition> {
        let word = self.map.u64(control::FLUSH).load(Ordering::Acquire);
        let period_open = (word >> 32) & 1 == 1;
        if period_open || word as u32 != self.load(control::FLUSH_ACK) {
            return None;
        }
        let base = layout::axis_base(0);
        Some(FifoPosition {
            word,
            read: self.load(base + axis::FIFO_READ),
            write: self
                .map
                .u32(base + axis::FIFO_WRITE)
                .load(Ordering::Relaxed),
        })
    }

    /// Host: ask the board to skip the entries from `at.read` up to (not including) `to`
    /// at the start of its next period. False, and nothing asked, if a period began since
    /// `at` was read.
    /// The flush answers the stop pending then (its brake is the host's answer to it).
    /// `end`: the FIFO index after the entries staged with [`Dpram::fifo_stage`] (the FIFO's
    /// write index if none), which the flush publishes.
    pub fn flush_arm(&self, at: &FifoPosition, to: u32, end: u32) -> bool {
        let pending = crate::layout::stop::seq(self.load(control::STOP));
        self.map
            .u32(control::FLUSH_END)
            .store(end, Ordering::Relaxed);
        self.map
            .u32(control::FLUSH_STOP)
            .store(pending, Ordering::Relaxed);
        self.map
            .u32(control::FLUSH_FROM)
            .store(at.read, Ordering::Relaxed);
        self.map.u32(control::FLUSH_TO).store(to, Ordering::Relaxed);
        let next = (at.word & !0xFFFF_FFFF) | u64::from((at.word as u32).wrapping_add(1));
        self.map
            .u64(control::FLUSH)
            .compare_exchange(at.word, next, Ordering::AcqRel, Ordering::Relaxed)
            .is_ok()
    }

    /// Board: open a period; returns the pending flush, if any (act on it, then
    /// [`Dpram::flush_done`]).
    pub fn period_begin(&self) -> Option<Flush> {
        let word = self
            .map
            .u64(control::FLUSH)
            .fetch_add(1 << 32, Ordering::AcqRel);
        let seq = word as u32;
        if seq == self.map.u32(control::FLUSH_ACK).load(Ordering::Relaxed) {
            return None;
        }
        Some(Flush {
            from: self.map.u32(control::FLUSH_FROM).load(Ordering::Relaxed),
            to: self.map.u32(control::FLUSH_TO).load(Ordering::Relaxed),
            end: self.map.u32(control::FLUSH_END).load(Ordering::Relaxed),
            answers: self.map.u32(control::FLUSH_STOP).load(Ordering::Relaxed),
        })
    }

    // ---- stop word ----

    /// Host (any thread): ask for a stop whose brake, if the board brakes on its own, uses
    /// `level` % of the brake limits; a stronger level still pending is kept (an ESTOP is
    /// never weakened by a STOP that follows it). A stop still pending at a level at least
    /// as strong already covers this one and is not posted again: a new word would not be
    /// the one the host's flush, perhaps armed already, answers, and the board would brake
    /// on its own, each axis off the path (an ESTOP that ends a job asks for the job's
    /// motion to stop too). Returns the stop sequence that covers the request. Lock-free: a
    /// compare-and-swap of the stop word.
    pub fn post_stop(&self, level: u8) -> u32 {
        use crate::layout::stop;
        let word = self.map.u32(control::STOP);
        let mut old = word.load(Ordering::Acquire);
        let level = level.clamp(1, 100);
        loop {
            let acked = stop::seq(self.load(control::STOP_ACK));
            let pending = stop::seq(old) != acked;
            if pending && stop::level(old) >= level {
                return stop::seq(old);
            }
            let level = if pending {
                level.max(stop::level(old))
            } else {
                level
            };
            let seq = stop::next(stop::seq(old));
            match word.compare_exchange_weak(
                old,
                stop::word(seq, level.clamp(1, 100)),
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => return seq,
                Err(now) => old = now,
            }
        }
    }

    /// Board: the stop word, if its sequence is not the one last acknowledged.
    pub fn stop_pending(&self) -> Option<u32> {
        let word = self.load(control::STOP);
        (crate::layout::stop::seq(word) != crate::layout::stop::seq(self.load(control::STOP_ACK)))
            .then_some(word)
    }

    /// Host: release a board that braked on its own, by the token it counts its own
    /// brakes with (`BOARD_STOPS`): it skips every entry pushed so far (up to the FIFO's
    /// write index now) and takes the FIFO again.
    pub fn release_stop(&self, seq: u32) {
        let write = self.load(layout::axis_base(0) + axis::FIFO_WRITE);
        self.store(control::RELEASE_AT, write);
        self.store(control::RELEASE, seq);
    }

    /// Board: the FIFO index to resume at, if the host released the brake of token `seq`.
    pub fn released(&self, seq: u32) -> Option<u32> {
        (self.load(control::RELEASE) == seq).then(|| self.load(control::RELEASE_AT))
    }

    /// Host: axis `channel`'s brake limits [pulse/s², pulse/s³] (rounded up, at least 1).
    pub fn set_brake_limits(&self, channel: usize, accel: f64, jerk: f64) {
        let base = layout::axis_base(channel);
        let at_least_one = |x: f64| {
            if x.is_finite() && x >= 1.0 {
                x.ceil().min(u64::MAX as f64) as u64
            } else {
                1
            }
        };
        self.store64(base + axis::BRAKE_ACCEL, at_least_one(accel));
        self.store64(base + axis::BRAKE_JERK, at_least_one(jerk));
    }

    /// Board: axis `channel`'s brake limits the host wrote [pulse/s², pulse/s³], 0 when
    /// it wrote none.
    pub fn brake_limits(&self, channel: usize) -> (u64, u64) {
        let base = layout::axis_base(channel);
        (
            self.load64(base + axis::BRAKE_ACCEL),
            self.load64(base + axis::BRAKE_JERK),
        )
    }

    /// Board: the pending flush is done (or refused).
    pub fn flush_done(&self) {
        let seq = self.map.u64(control::FLUSH).load(Ordering::Acquire) as u32;
        self.store(control::FLUSH_ACK, seq);
    }

    /// Board: close the period opened by [`Dpram::period_begin`].
    pub fn period_end(&self) {
        self.map
            .u64(control::FLUSH)
            .fetch_add(1 << 32, Ordering::AcqRel);
    }

    /// Board: whether axis `channel` can skip its entries `from..to`: its next entry is
    /// `from` and `to` is within the published entries.
    pub fn fifo_skippable(&self, channel: usize, from: u32, to: u32) -> bool {
        let base = layout::axis_base(channel);
        let write = self.load(base + axis::FIFO_WRITE);
        let read = self.map.u32(base + axis::FIFO_READ).load(Ordering::Relaxed);
        let skip = to.wrapping_sub(from);
        read == from && skip <= write.wrapping_sub(read) && skip <= FIFO_CAPACITY as u32
    }

    /// Board: skip axis `channel`'s entries up to FIFO index `to` (counted in
    /// `discarded`); entries not yet published are not waited for (at most what is).
    pub fn fifo_skip_to(&self, channel: usize, to: u32) {
        let base = layout::axis_base(channel);
        let write = self.load(base + axis::FIFO_WRITE);
        let read = self.map.u32(base + axis::FIFO_READ).load(Ordering::Relaxed);
        let skip = to
            .wrapping_sub(read)
            .min(write.wrapping_sub(read))
            .min(FIFO_CAPACITY as u32);
        self.store(base + axis::FIFO_READ, read.wrapping_add(skip));
        let d = self.load(base + axis::DISCARDED).wrapping_add(skip);
        self.store(base + axis::DISCARDED, d);
    }

    /// Board: skip axis `channel`'s entries `from..to` (counted in `discarded`), if
    /// [`Dpram::fifo_skippable`]; false otherwise (nothing changed).
    pub fn fifo_skip(&self, channel: usize, from: u32, to: u32) -> bool {
        if !self.fifo_skippable(channel, from, to) {
            return false;
        }
        let base = layout::axis_base(channel);
        let skip = to.wrapping_sub(from);
        self.store(base + axis::FIFO_READ, to);
        let d = self.load(base + axis::DISCARDED).wrapping_add(skip);
        self.store(base + axis::DISCARDED, d);
        true
    }

    // ---- feedback seqlock ----

    /// Board: publish axis `channel`'s feedback record.
    pub fn write_feedback(&self, channel: usize, record: &AxisRecord) {
        let base = layout::axis_base(channel);
        let seq = self.map.u32(base + axis::FB_SEQ);
        let s = seq.load(Ordering::Relaxed);
        let s = if s % 2 == 1 { s.wrapping_add(1) } else { s };
        seq.store(s.wrapping_add(1), Ordering::Relaxed);
        fence(Ordering::Release);
        let m = &self.map;
        m.u32(base + axis::STATUS)
            .store(record.status, Ordering::Relaxed);
        m.u64(base + axis::COMMANDED)
            .store(record.commanded as u64, Ordering::Relaxed);
        m.u64(base + axis::ENCODER)
            .store(record.encoder as u64, Ordering::Relaxed);
        m.u64(base + axis::FOLLOWING_ERROR)
            .store(record.following_error as u64, Ordering::Relaxed);
        m.u32(base + axis::ALARM)
            .store(record.alarm, Ordering::Relaxed);
        m.u64(base + axis::INCREMENT)
            .store(record.increment as u64, Ordering::Relaxed);
        seq.store(s.wrapping_add(2), Ordering::Release);
    }

    /// Host: read axis `channel`'s feedback record consistently into `out`.
    pub fn read_feedback(&self, channel: usize, out: &mut AxisRecord) -> Result<(), Torn> {
        let base = layout::axis_base(channel);
        let m = &self.map;
        let seq = m.u32(base + axis::FB_SEQ);
        for _ in 0..SEQLOCK_TRIES {
            let s1 = seq.load(Ordering::Acquire);
            if s1 % 2 == 1 {
                std::hint::spin_loop();
                continue;
            }
            let record = AxisRecord {
                status: m.u32(base + axis::STATUS).load(Ordering::Relaxed),
                commanded: m.u64(base + axis::COMMANDED).load(Ordering::Relaxed) as i64,
                encoder: m.u64(base + axis::ENCODER).load(Ordering::Relaxed) as i64,
                following_error: m.u64(base + axis::FOLLOWING_ERROR).load(Ordering::Relaxed) as i64,
                alarm: m.u32(base + axis::ALARM).load(Ordering::Relaxed),
                increment: m.u64(base + axis::INCREMENT).load(Ordering::Relaxed) as i64,
            };
            fence(Ordering::Acquire);
            if seq.load(Ordering::Relaxed) == s1 {
                *out = record;
                return Ok(());
            }
        }
        Err(Torn)
    }

    // ---- mapping latch seqlock ----

    /// Board: publish the mapping latch (seqlock, like the feedback records).
    pub fn write_mapping(&self, record: &MappingRecord) {
        use layout::mapping as m;
        let seq = self.map.u32(m::SEQ);
        let s = seq.load(Ordering::Relaxed);
        let s = if s % 2 == 1 { s.wrapping_add(1) } else { s };
        seq.store(s.wrapping_add(1), Ordering::Relaxed);
        fence(Ordering::Release);
        self.map
            .u32(m::STATION)
            .store(record.station, Ordering::Relaxed);
        self.map.u64(m::SEEN).store(record.seen, Ordering::Relaxed);
        for (i, code) in record.codes.iter().enumerate() {
            self.map
                .u32(m::CODES + 4 * i)
                .store(*code, Ordering::Relaxed);
        }
        seq.store(s.wrapping_add(2), Ordering::Release);
    }

    /// Host: read the mapping latch consistently into `out`; [`Torn`] after a bounded number
    /// of attempts that found the board writing.
    pub fn read_mapping(&self, out: &mut MappingRecord) -> Result<(), Torn> {
        use layout::mapping as m;
        let seq = self.map.u32(m::SEQ);
        for _ in 0..SEQLOCK_TRIES {
            let s1 = seq.load(Ordering::Acquire);
            if s1 % 2 == 1 {
                std::hint::spin_loop();
                continue;
            }
            let mut record = MappingRecord {
                station: self.map.u32(m::STATION).load(Ordering::Relaxed),
                seen: self.map.u64(m::SEEN).load(Ordering::Relaxed),
                codes: [0; m::CODE_WORDS],
            };
            for (i, code) in record.codes.iter_mut().enumerate() {
                *code = self.map.u32(m::CODES + 4 * i).load(Ordering::Relaxed);
            }
            fence(Ordering::Acquire);
            if seq.load(Ordering::Relaxed) == s1 {
                *out = record;
                return Ok(());
            }
        }
        Err(Torn)
    }

    // ---- mailboxes ----

    /// Writer: post (`code`, `args`) to the mailbox at `seq_offset` (code and arguments
    /// follow it, the ack word is `ack_offset`). False when the previous one is not yet
    /// acknowledged.
    pub fn post(&self, seq_offset: usize, ack_offset: usize, code: u32, args: &[u32]) -> bool {
        let seq = self.load(seq_offset);
        if self.load(ack_offset) != seq {
            return false;
        }
        self.map.u32(seq_offset + 4).store(code, Ordering::Relaxed);
        for (i, arg) in args.iter().enumerate() {
            self.map
                .u32(seq_offset + 8 + 4 * i)
                .store(*arg, Ordering::Relaxed);
        }
        self.store(seq_offset, seq.wrapping_add(1));
        true
    }

    /// Board: the pending (code, arg0, arg1) of a mailbox, or `None`; call
    /// [`Dpram::acknowledge`] after acting on it.
    pub fn pending(&self, seq_offset: usize, ack_offset: usize) -> Option<(u32, u32, u32)> {
        let seq = self.load(seq_offset);
        if self.map.u32(ack_offset).load(Ordering::Relaxed) == seq {
            return None;
        }
        let m = &self.map;
        Some((
            m.u32(seq_offset + 4).load(Ordering::Relaxed),
            m.u32(seq_offset + 8).load(Ordering::Relaxed),
            m.u32(seq_offset + 12).load(Ordering::Relaxed),
        ))
    }

    /// Board: mark the mailbox's pending entry done.
    pub fn acknowledge(&self, seq_offset: usize, ack_offset: usize) {
        let seq = self.load(seq_offset);
        self.store(ack_offset, seq);
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicBool, Ordering};

    use super::*;
    use crate::layout::mapping;

    fn dpram() -> Dpram {
        let header = Header {
            board_id: 0,
            axis_count: 1,
            period_us: 1_000,
            fifo_depth: 4,
            epoch: 1,
        };
        Dpram::initialize(Mapping::anonymous().unwrap(), header)
    }

    /// A record whose words all derive from `n`, so a mix of two writes is detectable.
    fn record(n: u32) -> MappingRecord {
        MappingRecord {
            station: n,
            seen: u64::from(n) * 0x1_0000_0001,
            codes: [n, !n, n.rotate_left(7), n ^ 0x5555_5555],
        }
    }

    #[test]
    fn a_mapping_record_being_written_is_not_read() {
        let d = dpram();
        d.write_mapping(&record(7));
        let mut out = MappingRecord::default();
        d.read_mapping(&mut out).unwrap();
        assert_eq!(out, record(7));
        // The board died half-way through a write: odd sequence, never a half record.
        let seq = d.load(mapping::SEQ);
        d.store(mapping::SEQ, seq + 1);
        d.store(mapping::STATION, 99);
        assert_eq!(d.read_mapping(&mut out), Err(Torn));
        assert_eq!(out, record(7), "out is untouched by a torn read");
        // The board's next write starts from an even sequence again.
        d.write_mapping(&record(8));
        assert_eq!(d.load(mapping::SEQ) % 2, 0);
        d.read_mapping(&mut out).unwrap();
        assert_eq!(out, record(8));
    }

    #[test]
    fn reads_racing_a_busy_writer_are_retried_and_never_mixed() {
        let d = dpram();
        d.write_mapping(&record(0));
        let done = AtomicBool::new(false);
        let (mut ok, mut torn) = (0u32, 0u32);
        std::thread::scope(|s| {
            s.spawn(|| {
                let mut n = 0u32;
                while !done.load(Ordering::Relaxed) {
                    n = n.wrapping_add(1);
                    d.write_mapping(&record(n));
                    if n % 64 == 0 {
                        std::thread::yield_now();
                    }
                }
            });
            let mut out = MappingRecord::default();
            let mut mixed = None;
            for _ in 0..200_000 {
                match d.read_mapping(&mut out) {
                    Ok(()) if out != record(out.station) => mixed = Some(out),
                    Ok(()) => ok += 1,
                    Err(Torn) => torn += 1,
                }
            }
            done.store(true, Ordering::Relaxed);
            assert_eq!(mixed, None, "a mixed record was returned");
        });
        assert!(ok > 0, "no read succeeded ({torn} torn)");
    }
}
