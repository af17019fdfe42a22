//! The `cirrus` binary: the command line (`cli/`), which parses flags and maps
//! errors to exit codes, and the lab (`lab/`), the benchmarks and studies
//! its `bench` and `converge` commands run, over the `cirrus` library.

mod cli;
mod lab;

fn main() -> std::process::ExitCode {
    cli::run()
}
