//! Integration tests of the simulated board with the driver (wrc-board) on the other side of
//! the DPRAM: one test binary, a module per topic.

mod alloc;
mod files;
mod in_process;
mod multi;

use std::path::Path;

use wrc_board_sim::{SimBoard, SimSettings};
use wrc_config::Config;

/// A simulated board of the embedded default robot on a DPRAM file at `path`.
pub fn sim_on(path: &Path) -> SimBoard {
    let config = Config::embedded_default();
    let settings = SimSettings::from_config(&config, &config.boards[0]);
    SimBoard::create(path, &settings).unwrap()
}
