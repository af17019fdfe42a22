//! The `cirrus` command line: subcommands, logging set-up, and the mapping of
//! errors to exit codes. `anyhow` lives here only; the library uses typed errors.

mod bench;
mod info;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Cirrus: a production path tracer for USD scenes and OpenVDB volumes.
#[derive(Parser, Debug)]
#[command(name = "cirrus", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print what a file holds: for a .vdb, its grid table.
    Info {
        /// The file to describe.
        file: PathBuf,
    },
    /// Run a benchmark and print a Markdown table (machine, date, medians).
    #[command(subcommand)]
    Bench(bench::Bench),
}

/// Parses the command line, runs it, and returns the process exit code:
/// 0 on success, 1 on any error (printed with its full cause chain), 2 on bad usage.
pub fn run() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .format_timestamp(None)
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info { file } => info::run(&file),
        Command::Bench(b) => bench::run(b),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
