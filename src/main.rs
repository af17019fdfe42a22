//! The `cirrus` binary: the command line (`cli/`), which parses flags and maps
//! errors to exit codes, over the `cirrus` library.

mod cli;

fn main() -> std::process::ExitCode {
    cli::run()
}
