//! `wrc compile`: compile a robot program (`.wrl`), print its diagnostics and a summary, or
//! its bytecode listing or JSON.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, ValueEnum};
use wrc_config::Config;

const EXAMPLES: &str = "\
Examples:
  wrc compile examples/pick_place.wrl                  diagnostics on stderr, a summary on stdout
  wrc compile examples/fig7_ptp.wrl --emit bytecode    the instruction listing
  wrc compile cell.wrl --config my-robot.toml --emit json

Exit codes: 0 compiled (maybe with warnings), 2 errors in the program or unreadable input.
The language: docs/language.md.";

/// Arguments of `wrc compile`.
#[derive(Debug, Args)]
#[command(after_help = EXAMPLES)]
pub struct CompileArgs {
    /// The robot program (.wrl).
    file: PathBuf,
    /// Robot configuration file (TOML); default: the embedded paper robot. Constant targets
    /// are checked against this robot's reach and joint limits.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Print the compiled program instead of the summary.
    #[arg(long, value_enum)]
    emit: Option<Emit>,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Emit {
    /// A human listing: one instruction per line with its source line:column.
    Bytecode,
    /// The program as JSON (tables and instructions).
    Json,
}

/// Compile, print, and exit 2 when the program has errors.
pub fn run(args: CompileArgs) -> anyhow::Result<ExitCode> {
    let config = Config::load(args.config.as_deref())?;
    let name = args.file.display().to_string();
    let source = std::fs::read_to_string(&args.file)
        .with_context(|| format!("cannot read the program {name}"))?;
    // Libraries (INCLUDE), called programs (CALL PROGRAM) and the points file are read
    // next to the program: <dir>/<name>.wrl, <dir>/<stem>.points.toml.
    let dir = args
        .file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    let stem = args
        .file
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("program");
    let sources = wrc_lang::DirSources {
        dir: dir.to_path_buf(),
    };
    let compiled = wrc_lang::compile_with(
        &source,
        &name,
        &config.robot,
        &wrc_lang::CompileOptions {
            name: stem,
            sources: Some(&sources),
        },
    );
    if !compiled.diagnostics.is_empty() {
        eprintln!("{}", compiled.render(&name, &source));
    }
    let Some(program) = compiled.program.as_ref() else {
        let (e, w) = (compiled.errors(), compiled.warnings());
        eprintln!(
            "{name}: {e} error{}, {w} warning{}; nothing compiled",
            plural(e),
            plural(w)
        );
        return Ok(ExitCode::from(2));
    };
    match args.emit {
        None => println!(
            "{name}: ok, {} instructions, {} variables, {} warning{}",
            program.len(),
            program.user_variable_count(),
            compiled.warnings(),
            plural(compiled.warnings())
        ),
        Some(Emit::Bytecode) => print!("{}", program.listing()),
        Some(Emit::Json) => println!("{}", program.to_json()),
    }
    Ok(ExitCode::SUCCESS)
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}
