//! The `wrc` binary driven as a user would, one module per subcommand.

mod bench_stop;
mod compile;
mod crate_graph;
mod faults;
mod hold;
mod lines;
mod plan;
mod program;
mod sim;
mod soak;
mod stations;
mod trace;
mod ui;
mod up;
mod wafer_cycle;
mod wafers;

#[path = "../common/mod.rs"]
mod common;

use std::path::Path;
use std::process::{Command, Output};

pub use common::{poll_until, wait_until, PATIENCE};
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard};

/// Run `wrc` with `args`.
pub fn wrc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("the wrc binary runs")
}

/// Standard output and error as text.
pub fn text(out: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A simulated board seen through its DPRAM file, read only, as `wrc board-sim status` sees
/// it: the board's own period count (the clock the arm moves on) and every axis's
/// commanded and encoder counts. Tests count these periods, not milliseconds, to show that
/// something does not happen.
pub struct BoardView(DpramBoard);

impl BoardView {
    /// The board on the DPRAM file `dpram` (waits until the board has set it up).
    pub fn open(dpram: &Path) -> BoardView {
        wait_until("the board's DPRAM", || {
            DpramBoard::open(dpram, Expect::default())
                .map(BoardView)
                .map_err(|e| e.to_string())
        })
    }

    /// The board's feedback (a read torn by the board's own update is read again).
    pub fn feedback(&self) -> Feedback {
        let mut f = Feedback::default();
        wait_until("an untorn read of the board's feedback", || {
            self.0.read_feedback(&mut f).map_err(|e| format!("{e:?}"))
        });
        f
    }

    /// Wait until the board has run `n` more periods.
    pub fn wait_periods(&self, n: u64) {
        let start = self.feedback().boards[0].period_count;
        wait_until(&format!("{n} board periods"), || {
            let now = self.feedback().boards[0].period_count;
            if now >= start + n {
                Ok(())
            } else {
                Err(format!("period {now}, counting from {start}"))
            }
        });
    }

    /// Wait until the arm stands still on the board, once nothing is in flight at the
    /// controller any more (WAIT answered) or the board stopped the arm itself: the board
    /// has executed whatever its command FIFO held (as many periods as the FIFO is deep),
    /// and then every axis executed no pulse in its last period and has its encoder on its
    /// commanded count (the servo has caught up).
    pub fn wait_at_rest(&self) {
        self.wait_periods(u64::from(self.0.header().fifo_depth));
        wait_until("every axis at rest on the board", || {
            let f = self.feedback();
            let axes = &f.axes[..f.axis_count];
            if axes
                .iter()
                .all(|a| a.increment == 0 && a.encoder == a.commanded)
            {
                Ok(())
            } else {
                Err(format!("{axes:?}"))
            }
        });
    }
}

/// The side collisions the simulated cell of state directory `dir` has counted (its
/// `world.toml`, read with its `stations.toml`), and the station or obstacle of the latest:
/// a body of the arm that touched a station off its line, or an obstacle. The board writes
/// the file a moment after each change and when it stops: read it once the board has
/// stopped.
pub fn side_collisions(dir: &Path) -> (u32, Option<String>) {
    let stations = wrc_cell::Stations::load(&dir.join("stations.toml"))
        .unwrap_or_else(|e| panic!("the stations in {}: {e}", dir.display()));
    let world = dir.join("world.toml");
    let text = std::fs::read_to_string(&world)
        .unwrap_or_else(|e| panic!("the simulated cell {}: {e}", world.display()));
    let world = wrc_cell::World::from_text(&text, &stations)
        .unwrap_or_else(|e| panic!("the simulated cell {}: {e}", world.display()));
    (
        world.side_collisions(),
        world.last_side_collision().map(|n| n.to_string()),
    )
}
