//! Ctrl-C and durations: the one process-wide "interrupted" flag every loop checks, and seconds
//! from the command line as a [`Duration`]. A leaf module: it imports nothing of the crate.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Whether Ctrl-C (SIGINT/SIGTERM) was received.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// Marks the run as interrupted (Ctrl-C read as a key in raw mode).
pub fn interrupt() {
    INTERRUPTED.store(true, Ordering::Relaxed);
}

/// Installs the Ctrl-C handler: the first Ctrl-C sets [`interrupted`]; a second one, while a
/// command is winding down, exits at once (status 130).
pub fn install_handler() {
    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::Relaxed) {
            std::process::exit(130);
        }
    });
}

/// A duration from seconds (negative or non-finite: zero; huge: about a century).
pub fn secs(s: f64) -> Duration {
    if s.is_finite() && s > 0.0 { Duration::from_secs_f64(s.min(3.0e9)) } else { Duration::ZERO }
}
