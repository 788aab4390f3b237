//! What a stopped `assemble` run tells the user to do next: the exact
//! `--resume` command, and how to follow the tip's drift from here where
//! the run does not (its journal keeps `--no-drift-follow` until a resume
//! with `--drift-follow`; a run that stopped for drift had been told to go
//! on "without --no-drift-follow", which `--resume` refuses). A run stopped
//! because the calibration does not fit is offered no resume: its sites
//! were placed through that map.

use crate::exec::events::RunEvent;
use crate::exec::journal::read_journal;
use crate::exec::resume_point::drift_off;
use crate::exec::stop_cause::{StopCause, instead_of_resuming_for_calibration};
use std::path::{Path, PathBuf};

/// How a run in progress would be gone on with.
pub struct GoOn {
    /// The rig file (`--rig`), on a hardware rig.
    pub rig: Option<PathBuf>,
    /// The run's journal.
    pub journal: PathBuf,
    /// The journal says the run does not follow drift ([`drift_off`]).
    pub drift_off: bool,
}

impl GoOn {
    /// How to go on with the run whose journal is `journal`, as the
    /// journal has it now (whether the run follows drift: [`drift_off`],
    /// false when it cannot be read).
    pub fn of_journal(rig: Option<PathBuf>, journal: PathBuf) -> Self {
        let drift_off = read_journal::<RunEvent>(&journal).is_ok_and(|c| drift_off(&c.entries));
        Self {
            rig,
            journal,
            drift_off,
        }
    }

    /// What to do after the run stopped, for a stop of the kind `cause`.
    pub fn after(&self, cause: StopCause) -> String {
        let rig = self.rig_flag();
        if cause == StopCause::CalibrationUnfit {
            return instead_of_resuming_for_calibration(&rig);
        }
        let resume = format!("nanopush assemble{rig} --resume {}", self.journal.display());
        if self.drift_off {
            format!(
                "go on with it: {resume}; the run does not follow the tip's drift (--no-drift-follow): \
                 to follow it from here: {resume} --drift-follow"
            )
        } else {
            format!("go on with it: {resume}")
        }
    }

    fn rig_flag(&self) -> String {
        rig_flag(self.rig.as_deref())
    }
}

/// " --rig FILE" for a hardware run's rig file, empty on the simulated rig:
/// what a resume of the run needs besides its journal.
pub(super) fn rig_flag(rig: Option<&Path>) -> String {
    rig.map_or(String::new(), |r| format!(" --rig {}", r.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn go_on(drift_off: bool) -> GoOn {
        GoOn {
            rig: Some(PathBuf::from("rig.toml")),
            journal: PathBuf::from("out/journal.jsonl"),
            drift_off,
        }
    }

    /// A run that does not follow drift is shown the command that follows
    /// it from here; one that does (from the start, or since a resume with
    /// --drift-follow, which its journal keeps) just the resume.
    #[test]
    fn a_run_not_following_drift_is_offered_the_resume_that_follows_it() {
        let plain = "nanopush assemble --rig rig.toml --resume out/journal.jsonl";
        let said = go_on(true).after(StopCause::Other);
        assert!(
            said.starts_with(&format!("go on with it: {plain};")),
            "{said}"
        );
        assert!(
            said.ends_with(&format!("from here: {plain} --drift-follow")),
            "{said}"
        );
        assert_eq!(
            go_on(false).after(StopCause::Other),
            format!("go on with it: {plain}")
        );
    }

    /// A stop for the calibration is offered no resume, whatever it says.
    #[test]
    fn a_stop_for_the_calibration_is_offered_no_resume() {
        let said = go_on(true).after(StopCause::CalibrationUnfit);
        assert!(!said.contains("--resume"), "{said}");
        assert!(
            said.ends_with(
                "make the calibration again (nanopush rig calibrate --rig rig.toml), \
                 then start a new run in another --out"
            ),
            "{said}"
        );
    }
}
