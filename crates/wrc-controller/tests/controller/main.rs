//! Controller integration tests, one module per topic.

mod alloc;
mod blend;
mod board_liveness;
mod cell_obstacle;
mod detached;
mod error_check;
mod estop_input;
mod ethernet;
mod host_access;
mod language_docs;
mod map_truth;
mod motion;
mod paths;
mod pipeline;
mod power_cycle;
mod programs;
mod recovery;
mod sessions;
mod stall;
mod stop_end;
mod vhost;
mod virtual_time;
