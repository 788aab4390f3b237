//! Ctrl-C handling: the handler only raises a flag. A hardware stage checks
//! it between commands and while waiting for motion, sends `HLT`, and
//! returns [`crate::rig::gcs::GcsError::Interrupted`]; the simulated rig
//! checks it before each frame and move. The run then stops as a run
//! stops (journalled, reported, resumable). A second Ctrl-C ends the
//! program at once, for a run that no longer looks at the flag.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, OnceLock};

static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// Installs the Ctrl-C handler once per process and returns the shared flag
/// it raises. Later calls return the same flag.
pub fn ctrlc_flag() -> Result<Arc<AtomicBool>, ctrlc::Error> {
    if let Some(flag) = FLAG.get() {
        return Ok(Arc::clone(flag));
    }
    let flag = Arc::new(AtomicBool::new(false));
    let raised = Arc::clone(&flag);
    ctrlc::set_handler(move || {
        if raised.swap(true, std::sync::atomic::Ordering::SeqCst) {
            std::process::exit(130);
        }
    })?;
    Ok(Arc::clone(FLAG.get_or_init(|| flag)))
}
