//! `wrc`: argument parsing and wiring of the wrc crates; no logic of its own.

mod bench;
mod bench_cell;
mod bench_controller;
mod bench_faults;
mod bench_motion;
mod bench_rt;
mod bench_soak;
mod bench_stop;
mod bench_ui;
mod board_sim;
mod cli;
mod compile;
mod connection;
mod plan;
mod plot;
mod run;
mod send;
mod sim;
mod trace;
mod trace_replay;
mod ui;
mod up;
mod up_process;

/// The unit tests count heap allocations per thread (`bench_rt`'s zero-allocation test).
#[cfg(test)]
#[global_allocator]
static GLOBAL: wrc_alloc_count::CountingAllocator = wrc_alloc_count::CountingAllocator;

use std::process::ExitCode;

fn main() -> ExitCode {
    // A bug must still reach the user as one sentence, not a backtrace.
    std::panic::set_hook(Box::new(|info| {
        eprintln!("wrc: internal error (a bug in wrc, please report it): {info}");
    }));
    match cli::run() {
        Ok(code) => code,
        Err(err) => {
            // One clear sentence (and its causes), never a panic or a backtrace.
            eprintln!("wrc: error: {err}");
            for cause in err.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::from(2)
        }
    }
}
