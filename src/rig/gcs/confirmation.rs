//! The confirmation asked before the first move on real hardware.

use std::io::{BufRead, IsTerminal, Write};

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
    /// ask on the terminal.
    pub fn for_rig(real_hardware: bool, dry_run: bool, waived_by_flag: bool) -> Self {
        if !real_hardware || dry_run || waived_by_flag {
            Self::NotNeeded
        } else {
            Self::Ask(Box::new(ask_on_terminal))
        }
    }
}

/// Prints the move and reads `yes` from standard input; anything else, or no
/// terminal at all (a script, CI), refuses.
pub fn ask_on_terminal(description: &str) -> bool {
    let stdin = std::io::stdin();
    if !stdin.is_terminal() {
        eprintln!(
            "{description}
refused: no terminal to confirm on (pass the explicit flag to waive)"
        );
        return false;
    }
    eprint!(
        "{description}
(nothing has been sent that moves or powers an axis; the command's later moves follow without asking)
Type `yes` to move the real stage: "
    );
    let _ = std::io::stderr().flush();
    let mut answer = String::new();
    stdin.lock().read_line(&mut answer).is_ok() && answer.trim() == "yes"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_real_hardware_without_waiver_asks() {
        assert!(matches!(
            FirstMoveConfirmation::for_rig(false, false, false),
            FirstMoveConfirmation::NotNeeded
        ));
        assert!(matches!(
            FirstMoveConfirmation::for_rig(true, true, false),
            FirstMoveConfirmation::NotNeeded
        ));
        assert!(matches!(
            FirstMoveConfirmation::for_rig(true, false, true),
            FirstMoveConfirmation::NotNeeded
        ));
        assert!(matches!(
            FirstMoveConfirmation::for_rig(true, false, false),
            FirstMoveConfirmation::Ask(_)
        ));
    }
}
