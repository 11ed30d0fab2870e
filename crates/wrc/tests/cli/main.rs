//! The `wrc` binary driven as a user would, one module per subcommand.

mod bench_stop;
mod compile;
mod hold;
mod lines;
mod plan;
mod program;
mod stations;
mod ui;
mod up;
mod wafer_cycle;
mod wafers;

use std::process::{Command, Output};

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
