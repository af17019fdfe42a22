//! Stopping a job by signal: SIGINT or SIGTERM asks it to stop after the
//! tiles in flight and save its checkpoint; a second one ends the process at
//! once with 128 + the signal number.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

/// SIGINT and SIGTERM, once [`install`](Self::install)ed: the first asks
/// the job to stop (poll [`requested`](Self::requested) as
/// [`JobControl::stop`](super::JobControl::stop)); a second one exits the
/// process at once.
pub struct StopSignal {
    stop: Arc<AtomicBool>,
    signal: Arc<AtomicUsize>,
}

impl StopSignal {
    /// Installs the handlers, for the rest of the process.
    pub fn install() -> std::io::Result<Self> {
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

    /// The signal that asked (SIGINT when none did), for the exit code,
    /// 128 + signal.
    pub fn signal(&self) -> i32 {
        match self.signal.load(Ordering::Relaxed) {
            0 => signal_hook::consts::SIGINT,
            s => s as i32,
        }
    }
}
