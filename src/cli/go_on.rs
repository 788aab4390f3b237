//! What a stopped `assemble` run tells the user to do next: the exact
//! `--resume` command, with `--drift-follow` where the run did not follow
//! the tip's drift (its journal keeps `--no-drift-follow`, and a run that
//! stopped for drift had been told to go on "without --no-drift-follow",
//! which `--resume` refuses). A run stopped because the calibration does
//! not fit is offered no resume: its sites were placed through that map.

use crate::exec::assemble::blames_calibration;
use std::path::PathBuf;

/// How a run in progress would be gone on with.
pub struct GoOn {
    /// The rig file (`--rig`), on a hardware rig.
    pub rig: Option<PathBuf>,
    /// The run's journal.
    pub journal: PathBuf,
    /// The journal says the run does not follow drift (`drift_off`).
    pub journal_drift_off: bool,
    /// This command follows it anyway (`--resume --drift-follow`).
    pub drift_follow: bool,
}

impl GoOn {
    /// What to do after the run stopped for `reason`.
    pub fn after(&self, reason: &str) -> String {
        let rig = self.rig_flag();
        if blames_calibration(reason) {
            return format!(
                "the run's sites were placed through that calibration, so it is not to be resumed: \
                 make the calibration again (nanopush rig calibrate{rig}), then start a new run in another --out"
            );
        }
        let resume = format!("nanopush assemble{rig} --resume {}", self.journal.display());
        match (self.journal_drift_off, self.drift_follow) {
            (true, false) => format!(
                "go on with it: {resume}; the run does not follow the tip's drift (--no-drift-follow): \
                 to follow it from here: {resume} --drift-follow"
            ),
            (true, true) => format!("go on with it: {resume} --drift-follow"),
            (false, _) => format!("go on with it: {resume}"),
        }
    }

    fn rig_flag(&self) -> String {
        self.rig
            .as_deref()
            .map_or(String::new(), |r| format!(" --rig {}", r.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn go_on(journal_drift_off: bool, drift_follow: bool) -> GoOn {
        GoOn {
            rig: Some(PathBuf::from("rig.toml")),
            journal: PathBuf::from("out/journal.jsonl"),
            journal_drift_off,
            drift_follow,
        }
    }

    /// A run that does not follow drift is shown the command that follows
    /// it from here, and one resumed so keeps the flag in its own line.
    #[test]
    fn a_run_not_following_drift_is_offered_the_resume_that_follows_it() {
        let plain = "nanopush assemble --rig rig.toml --resume out/journal.jsonl";
        let said = go_on(true, false).after("stopped: lost contact");
        assert!(
            said.starts_with(&format!("go on with it: {plain};")),
            "{said}"
        );
        assert!(
            said.ends_with(&format!("from here: {plain} --drift-follow")),
            "{said}"
        );
        let said = go_on(true, true).after("interrupted");
        assert_eq!(said, format!("go on with it: {plain} --drift-follow"));
        assert_eq!(
            go_on(false, false).after("x"),
            format!("go on with it: {plain}")
        );
    }
}
