//! The confirmation asked before the first move on real hardware.

use std::io::{IsTerminal, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::{Duration, Instant};

/// Who, if anyone, must approve the first move.
pub enum FirstMoveConfirmation {
    /// No confirmation: a simulator, a dry run, or the operator passed the
    /// explicit flag that waives it.
    NotNeeded,
    /// Ask this callback once, with a description of the move; `false` refuses.
    Ask(Box<dyn FnMut(&str) -> bool + Send>),
    /// The operator refused: this stage moves nothing more in this process
    /// (a command's clean-up move after a refusal must not ask again).
    Refused,
}

impl FirstMoveConfirmation {
    /// What a command should use: nothing to confirm for a simulator, a dry
    /// run, or when the operator passed the explicit waiver flag; otherwise
    /// ask on the terminal, where Ctrl-C (`interrupt` raised) refuses.
    /// The time the question waits for its answer is added to `waited`.
    pub fn for_rig(
        real_hardware: bool,
        dry_run: bool,
        waived_by_flag: bool,
        interrupt: Arc<AtomicBool>,
        waited: OperatorWait,
    ) -> Self {
        if !real_hardware || dry_run || waived_by_flag {
            Self::NotNeeded
        } else {
            Self::Ask(Box::new(move |d| {
                let asked = Instant::now();
                let yes = ask_on_terminal(d, &interrupt);
                waited.add(asked.elapsed());
                yes
            }))
        }
    }
}

/// Time spent waiting for the operator's answer, shared by a rig's stages
/// (each asks before its own first move): a run's report leaves it out of
/// the run's time, which had counted however long the operator took to
/// type `yes` as the rig's work.
#[derive(Debug, Clone, Default)]
pub struct OperatorWait(Arc<AtomicU64>);

impl OperatorWait {
    fn add(&self, waited: Duration) {
        let ns = u64::try_from(waited.as_nanos()).unwrap_or(u64::MAX);
        self.0.fetch_add(ns, Ordering::SeqCst);
    }

    /// Seconds waited since the last take, and back to zero.
    pub fn take_s(&self) -> f64 {
        self.0.swap(0, Ordering::SeqCst) as f64 * 1e-9
    }
}

/// Prints the move and reads `yes` from standard input; anything else, no
/// terminal at all (a script, CI), the input's end or Ctrl-C (`interrupt`
/// raised) refuses.
pub fn ask_on_terminal(description: &str, interrupt: &AtomicBool) -> bool {
    let stdin = std::io::stdin();
    if !stdin.is_terminal() {
        eprintln!(
            "{description}
refused: no terminal to confirm on; to move without asking, run the command again with --yes-move-hardware"
        );
        return false;
    }
    eprint!(
        "{description}
(nothing has been sent that moves or powers an axis; the command's later moves follow without asking)
Type `yes` (the word) to move the real stage: "
    );
    let _ = std::io::stderr().flush();
    let read = move || {
        let mut answer = String::new();
        stdin.read_line(&mut answer).map(|_| answer)
    };
    let yes = answer_unless_interrupted(read, interrupt);
    if interrupt.load(Ordering::SeqCst) {
        eprintln!("\nCtrl-C at the question: refused");
    }
    yes
}

/// Whether the line `read` gives (on a thread of its own) is `yes`; `false`
/// as soon as `interrupt` is raised. Ctrl-C at the question had only raised
/// the flag while the read went on waiting; a second Ctrl-C then ended the
/// program, leaving the run's journal behind though nothing had moved.
fn answer_unless_interrupted(
    read: impl FnOnce() -> std::io::Result<String> + Send + 'static,
    interrupt: &AtomicBool,
) -> bool {
    let (sent, answer) = channel();
    std::thread::spawn(move || {
        let _ = sent.send(read().is_ok_and(|a| a.trim() == "yes"));
    });
    while !interrupt.load(Ordering::SeqCst) {
        match answer.recv_timeout(Duration::from_millis(20)) {
            Ok(yes) => return yes,
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return false,
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_real_hardware_without_waiver_asks() {
        let for_rig = |real, dry, waived| {
            let interrupt = Arc::new(AtomicBool::new(false));
            FirstMoveConfirmation::for_rig(real, dry, waived, interrupt, OperatorWait::default())
        };
        assert!(matches!(
            for_rig(false, false, false),
            FirstMoveConfirmation::NotNeeded
        ));
        assert!(matches!(
            for_rig(true, true, false),
            FirstMoveConfirmation::NotNeeded
        ));
        assert!(matches!(
            for_rig(true, false, true),
            FirstMoveConfirmation::NotNeeded
        ));
        assert!(matches!(
            for_rig(true, false, false),
            FirstMoveConfirmation::Ask(_)
        ));
    }

    #[test]
    fn ctrl_c_or_the_inputs_end_at_the_question_refuses() {
        let calm = AtomicBool::new(false);
        assert!(answer_unless_interrupted(|| Ok("yes\n".into()), &calm));
        assert!(!answer_unless_interrupted(|| Ok("no\n".into()), &calm));
        // The input's end (Ctrl-D): an empty read.
        assert!(!answer_unless_interrupted(|| Ok(String::new()), &calm));
        // Ctrl-C while nobody answers: refused at once, not after the answer.
        let pressed = Arc::new(AtomicBool::new(false));
        let press = Arc::clone(&pressed);
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            press.store(true, Ordering::SeqCst);
        });
        let started = std::time::Instant::now();
        let late_yes = || {
            std::thread::sleep(Duration::from_secs(5));
            Ok("yes\n".to_string())
        };
        assert!(!answer_unless_interrupted(late_yes, &pressed));
        assert!(
            started.elapsed() < Duration::from_secs(2),
            "{:?}",
            started.elapsed()
        );
    }
}
