//! What a run's stop means for going on with it, typed where the stop is
//! made and journalled beside its wording: a stop for a calibration that
//! does not fit is not to be resumed. It had been recognised by its text,
//! so a rewording of the message would have offered (and allowed) the
//! resume again.

use serde::{Deserialize, Serialize};

/// Why a run stopped, as far as it decides what may follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopCause {
    /// The calibration does not fit this camera and stage (the apex
    /// astray, or its offsets growing with the stage's position): the
    /// run's sites were placed through it, so it is not to be resumed.
    CalibrationUnfit,
    /// Any other stop (Ctrl-C, a stage fault, the planner, pushes spent):
    /// the run may go on with `--resume`.
    Other,
}

/// The wording every stop for the calibration carried in journals written
/// before the cause was journalled (2026-11-29 to 2026-11-30), frozen here
/// so that rewording today's message does not change how they are read.
const OLDER_CALIBRATION_UNFIT: &str = "the calibration does not fit this camera and stage";

impl StopCause {
    /// The cause of a stop journalled as `cause` beside `reason`; a journal
    /// from before the cause was journalled (`cause` absent) is judged by
    /// the wording it was written with.
    pub fn journalled(cause: Option<StopCause>, reason: &str) -> StopCause {
        cause.unwrap_or(if reason.contains(OLDER_CALIBRATION_UNFIT) {
            StopCause::CalibrationUnfit
        } else {
            StopCause::Other
        })
    }
}

/// What to do instead of resuming a run stopped for its calibration, for
/// the rig flag `rig` (" --rig FILE", or empty on the simulated rig): said
/// when it stops and when its resume is refused.
pub fn instead_of_resuming_for_calibration(rig: &str) -> String {
    format!(
        "the run's sites were placed through that calibration, so it is not to be resumed: \
         make the calibration again (nanopush rig calibrate{rig}), then start a new run in another --out"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A journalled cause is read as written; without one (an older
    /// journal) the stop's wording decides.
    #[test]
    fn a_stop_cause_is_read_from_the_journal_and_older_ones_from_their_wording() {
        let older = "the camera sees the probe's apex at (1.00, 2.00) um, 9.0 um from where the stage has it \
                     (1.00, 11.00) um: the calibration does not fit this camera and stage (another rig's)";
        assert_eq!(
            StopCause::journalled(None, older),
            StopCause::CalibrationUnfit
        );
        assert_eq!(
            StopCause::journalled(None, "3 stage faults in a row"),
            StopCause::Other
        );
        // A journalled cause is taken as it is, whatever the words.
        assert_eq!(
            StopCause::journalled(Some(StopCause::Other), older),
            StopCause::Other
        );
        assert_eq!(
            StopCause::journalled(Some(StopCause::CalibrationUnfit), "reworded"),
            StopCause::CalibrationUnfit
        );
        let text = serde_json::to_string(&StopCause::CalibrationUnfit).unwrap();
        assert_eq!(text, r#""calibration_unfit""#);
        assert_eq!(
            serde_json::from_str::<StopCause>(&text).unwrap(),
            StopCause::CalibrationUnfit
        );
    }
}
