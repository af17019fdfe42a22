//! The `cirrus` binary: the command line (`cli/`), which parses flags, calls
//! the `cirrus` library (the renderer, and the lab its `bench` and `converge`
//! commands run) and maps errors to exit codes.

mod cli;

fn main() -> std::process::ExitCode {
    cli::run()
}
