//! The wrc controller: the paper's eight real-time tasks wired together (Fig. 1, Table 1).
//!
//! Data flows one way: command sources ([`ethernet`], [`rs232c`]) → [`command_interpreter`]
//! → [`velocity_generator`] (plans ahead, fills a per-period pulse ring) →
//! [`pulse_generator`] (one batch per period into the board FIFO) and
//! [`simulator_manager`] (UDP state datagrams). [`error_check`] and [`io_monitor`] watch the
//! board. Every task's cycle is allocation-free and never blocks; tasks talk through
//! `wrc_rt::ipc` queues and the atomics of [`shared::Shared`]. [`controller`] starts it all.
#![deny(missing_docs)]

pub mod cell_service;
pub mod clients;
pub mod command_interpreter;
pub mod controller;
pub mod error_check;
pub mod ethernet;
mod host;
pub mod host_access;
pub mod io_monitor;
pub mod messages;
pub mod pulse_generator;
pub mod queries;
pub mod recorder;
pub mod rs232c;
pub mod service;
pub mod shared;
#[cfg(feature = "sim")]
pub mod simulation;
pub mod simulator_manager;
mod start_error;
pub mod upload;
pub mod velocity_generator;
