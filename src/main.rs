//! The `cirrus` binary: parses the command line and maps errors to exit codes.

fn main() -> std::process::ExitCode {
    cirrus::cli::run()
}
