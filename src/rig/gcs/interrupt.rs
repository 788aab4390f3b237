//! Ctrl-C handling: the handler only raises a flag; the stage checks it
//! between commands and while waiting for motion, sends `HLT`, and returns
//! [`super::GcsError::Interrupted`] so the program can exit with the stage still.

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
        raised.store(true, std::sync::atomic::Ordering::SeqCst);
    })?;
    Ok(Arc::clone(FLAG.get_or_init(|| flag)))
}
