//! wrc's motion board: the dual-port RAM (DPRAM) through which the host talks to a PCI
//! motion board (the paper's TMS320C3x DSP board, 4 axes a board, up to 4 boards), and the
//! driver that maps it: what the real-time controller links. The simulated board that plays
//! the DSP is the `wrc-board-sim` crate.
//!
//! What it guarantees:
//! - one documented, versioned layout ([`layout`], `docs/dpram.md`), accessed only with
//!   atomic operations under protocols that never expose a half-written record
//!   ([`dpram`]);
//! - one driver code path for a shared-memory file, a PCI BAR resource file or a UIO
//!   device ([`DpramBoard`]), which checks magic, version and size before use and names the
//!   path in every error;
//! - the [`MotionBoard`] trait the controller's real-time tasks use: every method is
//!   non-blocking, allocation-free and system-call-free; [`MultiBoard`] puts up to 16 axes
//!   on up to 4 boards.
#![deny(missing_docs)]

pub mod board;
pub mod dpram;
pub mod driver;
pub mod fault;
pub mod layout;
pub mod mapping;
pub mod multi;

/// The wafer cell crate (the mapping sensor's slot codes are its `SlotCode`).
pub use wrc_cell;

pub use board::{
    AxisFeedback, BoardFeedback, BoardStop, Busy, Feedback, Full, Heartbeat, MappingScan,
    MotionBoard, StopLine, Torn,
};
pub use dpram::{FifoPosition, Flush};
pub use driver::{DpramBoard, Expect, Mapping, OpenError};
pub use fault::Fault;
pub use multi::{MultiBoard, MultiError};
