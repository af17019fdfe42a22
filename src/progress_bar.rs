//! A long render's progress as its user sees it: a bar with ETA on a
//! terminal (indicatif), a log line every 10% anywhere else (a farm log).

use std::io::IsTerminal;
use std::sync::Mutex;

use indicatif::ProgressStyle;

/// A progress bar with ETA on a terminal; on anything else, a log line
/// every 10%.
pub struct ProgressDisplay {
    bar: Option<indicatif::ProgressBar>,
    logged: Mutex<u32>,
}

impl Default for ProgressDisplay {
    /// A bar on a terminal's stderr, else log lines.
    fn default() -> Self {
        Self::new()
    }
}

impl ProgressDisplay {
    /// A bar on a terminal's stderr, else log lines.
    pub fn new() -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = indicatif::ProgressBar::new(1000);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed_precise} ETA {eta}")
                    .expect("valid template"),
            );
            bar
        });
        Self {
            bar,
            logged: Mutex::new(0),
        }
    }

    /// Shows `fraction` (0 to 1) done.
    pub fn update(&self, fraction: f64) {
        let fraction = fraction.clamp(0.0, 1.0);
        match &self.bar {
            Some(bar) => bar.set_position((fraction * 1000.0) as u64),
            None => {
                let tenth = (fraction * 10.0) as u32;
                let mut logged = self.logged.lock().expect("progress lock");
                if tenth > *logged {
                    *logged = tenth;
                    log::info!("{}% rendered", tenth * 10);
                }
            }
        }
    }

    /// Clears the bar.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
