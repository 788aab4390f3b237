//! Ctrl-C handling (and SIGTERM and SIGHUP: a `kill`, a closed terminal
//! or a service stop halts the stage the same way, where it had ended the
//! program with the stage moving): the handler only raises a flag. A hardware stage checks
//! it between commands and while waiting for motion, sends `HLT`, and
//! returns [`crate::rig::gcs::GcsError::Interrupted`]; the simulated rig
//! checks it before each frame and move. The run then stops as a run
//! stops (journalled, reported, resumable). A second Ctrl-C ends the
//! program at once, for a run that no longer looks at the flag, but only
//! [`SECOND_PRESS_GRACE`] after the first: two presses in a panic had
//! ended it before the stage was sent `HLT`, the push running on with the
//! tip down, and without a report. A command whose stop is not at once
//! ([`ctrlc_flag_answering`]: a dry-run, a study, `assemble` on the
//! simulated rig) has the first press answered
//! on stderr, so a wait is not taken for a press that went unseen; so has
//! `assemble --rig` ([`ctrlc_flag_answering_halting`]), whose set-up (the rig
//! opened, the first frame, the plan) had run on for seconds unaware of a
//! press, or been ended by it without a word. Such set-up steps look at
//! the flag between them ([`stop_if_raised`]).

use std::io::Write;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// The line the first press is answered with, when a command set one.
static ACKNOWLEDGEMENT: OnceLock<Acknowledgement> = OnceLock::new();

/// A command's answer to the first press, and whether it drives a stage
/// (a second press then sends the user to check it by hand).
struct Acknowledgement {
    line: String,
    drives_stage: bool,
}

/// [`ctrlc_flag`] for a command whose stop is not at once (a dry-run, a
/// study, `assemble` on the simulated rig): the first press is answered on
/// stderr at once with `line`, then "(a second press, 3 s on, ends it at
/// once)", from the handler's own thread, while the run goes on to its
/// stop (a dry-run's frame in analysis had left 8-20 s without a word).
/// The answer is set before the handler goes in: set after, a press
/// between the two had stopped the command unanswered. Set once per
/// process; a later line is ignored.
pub fn ctrlc_flag_answering(line: &str) -> Result<Arc<AtomicBool>, ctrlc::Error> {
    answered_flag(line, false)
}

/// [`ctrlc_flag_answering`] for a command that drives a stage: a second
/// press still says the stage is to be checked by hand.
pub fn ctrlc_flag_answering_halting(line: &str) -> Result<Arc<AtomicBool>, ctrlc::Error> {
    answered_flag(line, true)
}

fn answered_flag(line: &str, drives_stage: bool) -> Result<Arc<AtomicBool>, ctrlc::Error> {
    let _ = ACKNOWLEDGEMENT.set(Acknowledgement {
        line: format!(
            "{line} (a second press, {} s on, ends it at once)",
            SECOND_PRESS_GRACE.as_secs()
        ),
        drives_stage,
    });
    ctrlc_flag()
}

/// A set-up step found the flag raised: the command stops before its next
/// step (the run not begun), `during` saying where, e.g. "at the first frame".
#[derive(Debug, thiserror::Error)]
#[error("interrupted ({CAUSE}) {during}")]
pub struct SetUpInterrupted {
    /// Where the set-up was when it looked.
    pub during: &'static str,
}

/// Fails once `flag` is raised: called between set-up steps that send the
/// stage nothing (so no stage check would see the press) and may take
/// seconds (a camera's first frame, planning).
pub fn stop_if_raised(flag: &AtomicBool, during: &'static str) -> Result<(), SetUpInterrupted> {
    if flag.load(std::sync::atomic::Ordering::SeqCst) {
        return Err(SetUpInterrupted { during });
    }
    Ok(())
}

/// What raised the flag, as messages name it. The ctrlc crate calls one
/// handler for SIGINT, SIGTERM and SIGHUP alike and does not say which
/// arrived, so the words are true for all three: "interrupted by the user
/// (Ctrl-C)" had been written for a `kill` or a closed terminal too.
pub const CAUSE: &str = "Ctrl-C or a termination signal";

/// How long after the first Ctrl-C a second one is taken as a wish to end
/// at once rather than as the same press again: the stop itself (halting
/// the stage, writing the report) takes well under a second.
pub const SECOND_PRESS_GRACE: Duration = Duration::from_secs(3);

/// Installs the Ctrl-C handler once per process and returns the shared flag
/// it raises. Later calls return the same flag.
pub fn ctrlc_flag() -> Result<Arc<AtomicBool>, ctrlc::Error> {
    if let Some(flag) = FLAG.get() {
        return Ok(Arc::clone(flag));
    }
    let flag = Arc::new(AtomicBool::new(false));
    let raised = Arc::clone(&flag);
    let first_press: OnceLock<Instant> = OnceLock::new();
    // The handler writes nothing until it ends the program: with SIGPIPE
    // at its default (cli/mod.rs), a line to a closed pipe (`| tee` of a
    // closed terminal, on SIGHUP) had killed the run mid-push before it
    // could halt the stage; the run's own stop says it was interrupted.
    ctrlc::set_handler(move || {
        let first = *first_press.get_or_init(Instant::now);
        let again = raised.swap(true, std::sync::atomic::Ordering::SeqCst);
        if !again && let Some(said) = ACKNOWLEDGEMENT.get() {
            say_without_sigpipe(&said.line);
        }
        if again && first.elapsed() >= SECOND_PRESS_GRACE {
            let stage = if ACKNOWLEDGEMENT.get().is_some_and(|a| !a.drives_stage) {
                ""
            } else {
                "; check the stage by hand (the tip may be down)"
            };
            let _ = writeln!(
                std::io::stderr(),
                "interrupted again ({CAUSE}): ending now, without waiting for the stop{stage}"
            );
            std::process::exit(130);
        }
    })?;
    Ok(Arc::clone(FLAG.get_or_init(|| flag)))
}

/// Writes `line` to stderr from the handler's thread with SIGPIPE blocked
/// in that thread alone: a closed stderr (a `| tee` gone with its
/// terminal) then fails the write instead of ending the run before it
/// writes what it did.
fn say_without_sigpipe(line: &str) {
    use nix::sys::signal::{SigSet, SigmaskHow, Signal, pthread_sigmask};
    let mut pipe = SigSet::empty();
    pipe.add(Signal::SIGPIPE);
    if pthread_sigmask(SigmaskHow::SIG_BLOCK, Some(&pipe), None).is_ok() {
        let _ = writeln!(std::io::stderr(), "{line}");
    }
}
