//! Where a study ran: the machine, date and commit line every benchmark
//! table opens with, and the worker pool its renders run on.

use super::Result;

/// "Machine: <cpu>, <cores> cores; <date>; commit <hash>" for benchmark headers.
pub(crate) fn machine_line() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_owned())
        })
        .unwrap_or_else(|| "unknown CPU".to_owned());
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let run = |cmd: &str, args: &[&str]| {
        std::process::Command::new(cmd)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
            .unwrap_or_else(|| "unknown".to_owned())
    };
    format!(
        "Machine: {cpu}, {cores} cores; date {}; commit {}",
        run("date", &["-u", "+%Y-%m-%d"]),
        run("git", &["rev-parse", "--short", "HEAD"])
    )
}

/// Runs `f` on a rayon pool of `threads` workers (at least one).
pub(crate) fn with_threads(threads: usize, f: impl FnOnce() -> Result<()> + Send) -> Result<()> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()?
        .install(f)
}
