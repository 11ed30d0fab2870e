//! wrc's motion board: the dual-port RAM (DPRAM) through which the host talks to a PCI
//! motion board (the paper's TMS320C3x DSP board, 4 axes a board, up to 4 boards), the
//! driver that maps it, and a simulated board that plays the DSP.
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
//!   on up to 4 boards;
//! - a simulated board ([`sim::SimBoard`]) that is a plain struct stepped one board period at
//!   a time, so tests run it against a mock clock; `wrc board-sim` runs it as a process. It
//!   can simulate the wafer cell ([`sim::cell`]): a `wrc_cell::World` moved by the hand's
//!   encoders and vacuum valve, with the vacuum and mapping sensors read through the DPRAM.
//!
//! ```
//! use wrc_board::sim::{SimBoard, SimSettings};
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

pub mod board;
pub mod dpram;
pub mod driver;
pub mod fault;
pub mod layout;
pub mod multi;
pub mod sim;

/// The wafer cell crate, whose stations and world the simulated cell ([`sim::cell`]) uses.
pub use wrc_cell;

pub use board::{
    AxisFeedback, BoardFeedback, Busy, Feedback, Full, MappingScan, MotionBoard, Torn,
};
pub use dpram::FifoPosition;
pub use driver::{DpramBoard, Expect, Mapping, OpenError};
pub use fault::Fault;
pub use multi::{MultiBoard, MultiError};
