//! Stopping a render by signal: SIGINT or SIGTERM asks it to stop after the
//! tiles in flight and save its checkpoint; the process then exits with 128
//! + the signal number.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use anyhow::Result;

/// SIGINT and SIGTERM: the first asks the render to stop after the tiles
/// in flight (it then saves a checkpoint); a second one exits at once.
pub(super) struct StopSignal {
    stop: Arc<AtomicBool>,
    signal: Arc<AtomicUsize>,
}

impl StopSignal {
    /// Installs the handlers.
    pub fn install() -> Result<Self> {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let stop = Arc::new(AtomicBool::new(false));
        let signal = Arc::new(AtomicUsize::new(0));
        for sig in [SIGINT, SIGTERM] {
            // Registered first, so it sees the flag as the previous signal left it.
            signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, Arc::clone(&stop))?;
            signal_hook::flag::register(sig, Arc::clone(&stop))?;
            signal_hook::flag::register_usize(sig, Arc::clone(&signal), sig as usize)?;
        }
        Ok(Self { stop, signal })
    }

    /// Whether a stop was asked.
    pub fn requested(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// The signal that asked, if any (for the exit code, 128 + signal).
    pub fn signal(&self) -> Option<i32> {
        match self.signal.load(Ordering::Relaxed) {
            0 => None,
            s => Some(s as i32),
        }
    }
}

/// A render stopped by a signal after saving its checkpoint: exits with
/// 128 + the signal number, like a shell reports it.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub(super) struct Interrupted {
    /// The signal that stopped the render.
    pub signal: i32,
    /// What was saved and how to resume.
    pub message: String,
}
