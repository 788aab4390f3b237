//! Whether a frame shows the probe's apex where the stage (and the drift
//! the run follows) put it. An apex far off says the calibration is not
//! this rig's, and every move would go astray: the loop stops.

use super::stage_unit::stage_unit_doubt;
use crate::exec::observe::Sighting;
use crate::exec::stop_cause::StopCause;

/// Why a frame stops the run, typed by what it blames: the kind goes with
/// the stop to where the user is told how to go on (a calibration that
/// does not fit is not to be resumed), the words to the user.
#[derive(Debug, Clone, PartialEq)]
pub enum ApexDoubt {
    /// The calibration does not fit this camera and stage (its message
    /// says [`CALIBRATION_UNFIT`]).
    CalibrationUnfit(String),
    /// Drift the run does not follow (`--no-drift-follow`) has taken the
    /// apex past [`CALIBRATION_DOUBT_M`], a little at a time.
    UnfollowedDrift(String),
    /// The stage's unit in the rig file is not the controller's
    /// (`stage_unit::stage_unit_doubt`): the
    /// calibration may fit, and the run goes on once the unit is set.
    StageUnit(String),
}

impl ApexDoubt {
    /// What the stop it makes means for going on with the run.
    pub fn cause(&self) -> StopCause {
        match self {
            ApexDoubt::CalibrationUnfit(_) => StopCause::CalibrationUnfit,
            ApexDoubt::UnfollowedDrift(_) | ApexDoubt::StageUnit(_) => StopCause::Other,
        }
    }
}

impl std::fmt::Display for ApexDoubt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (ApexDoubt::CalibrationUnfit(why)
        | ApexDoubt::UnfollowedDrift(why)
        | ApexDoubt::StageUnit(why)) = self;
        f.write_str(why)
    }
}

/// Farthest the first frame's apex may lie from where the stage has it
/// before the run stops for the calibration. The calibration maps the apex
/// onto the stage's position (RMS 0.2 px on the simulated rig); drift of a
/// few nm/s since it was made adds a few um an hour; a map of another
/// camera or a turned one puts the apex tens of um off.
pub const CALIBRATION_DOUBT_M: f64 = 5e-6;

/// Why `sighting` says the calibration is not this rig's (see
/// [`CALIBRATION_DOUBT_M`]): the loop stops on it at its first frame, and
/// the dry-run says the loop would. (Another camera's map, 0.30 um/px
/// turned 90 deg, put the apex 17 um off; the run pushed three times, lost
/// contact three times and stopped on "no collision-free order", naming no
/// calibration.) A stage whose unit is wrong reads as such a calibration
/// and is named instead (`stage_unit.rs`), in `rig probe --camera`
/// and the dry-run as in the loop.
pub fn calibration_doubt(sighting: &Sighting) -> Option<String> {
    stage_unit_doubt(sighting).or_else(|| apex_doubt(sighting, [0.0, 0.0]))
}

/// [`calibration_doubt`] of any frame of a run, `drift_m` (the tip's drift
/// the run follows, as estimated so far) taken out: an apex farther than
/// [`CALIBRATION_DOUBT_M`] from where the stage and the drift put it is no
/// drift. (A rig file with x and y swapped passed the first frame, the
/// stage starting where x = y, and the run pushed at mirrored places,
/// taking 9.4 um of the difference for drift.)
pub fn apex_doubt(sighting: &Sighting, drift_m: [f64; 2]) -> Option<String> {
    let said = if drift_m == [0.0, 0.0] {
        String::new()
    } else {
        format!(" and its drift so far {}", um(drift_m))
    };
    astray(sighting, drift_m, &said)
}

/// [`apex_doubt`] for a run that does not follow the drift
/// (`--no-drift-follow`): the apex against where the last frame that found
/// it had it (`before`, [`Sighting::apex_offset_m`]),
/// since a calibration that does not fit jumps with the first move; then
/// against the stage alone, where an offset past [`CALIBRATION_DOUBT_M`]
/// grown a little at a time is drift this run does not take out, and is
/// named so (it had been blamed on the calibration).
pub fn apex_doubt_unfollowed(sighting: &Sighting, before: Option<[f64; 2]>) -> Option<ApexDoubt> {
    let Some(before) = before else {
        return calibration_doubt(sighting).map(ApexDoubt::CalibrationUnfit);
    };
    let said = format!(" with the apex's last offset {}", um(before));
    if let Some(why) = astray(sighting, before, &said) {
        return Some(ApexDoubt::CalibrationUnfit(why));
    }
    let off = apex_beyond_doubt_m(sighting)?;
    let now = sighting.apex_offset_m()?;
    Some(ApexDoubt::UnfollowedDrift(format!(
        "the probe's apex has drifted {:.1} um from where the stage has it (by {}), a little at a time: \
             the run does not follow drift (--no-drift-follow), so every push would miss by as much; \
             go on following it (--resume with --drift-follow), or make the calibration again (nanopush rig calibrate)",
        off * 1e6,
        um(now)
    )))
}

/// How far the apex lies from where the stage was sent (no drift or offset
/// taken out), when farther than [`CALIBRATION_DOUBT_M`]: drift this run
/// does not follow, or a calibration a run cannot check (a dry run's stage
/// is not the real one).
pub fn apex_beyond_doubt_m(sighting: &Sighting) -> Option<f64> {
    apex_off_m(sighting, [0.0, 0.0]).filter(|off| *off > CALIBRATION_DOUBT_M)
}

/// How far the apex lies from where the stage was sent, `offset_m` added.
fn apex_off_m(sighting: &Sighting, offset_m: [f64; 2]) -> Option<f64> {
    let now = sighting.apex_offset_m()?;
    Some((now[0] - offset_m[0]).hypot(now[1] - offset_m[1]))
}

/// Says why the apex lies farther than [`CALIBRATION_DOUBT_M`] from where
/// the stage was sent, `offset_m` added (`offset_said` tells the user what
/// that offset is).
fn astray(sighting: &Sighting, offset_m: [f64; 2], offset_said: &str) -> Option<String> {
    let (tip, stage) = (sighting.tip_m?, sighting.stage_m?);
    let expected = [0, 1].map(|i| stage[i] + sighting.coarse_offset_m[i] + offset_m[i]);
    let off = apex_off_m(sighting, offset_m)?;
    (off > CALIBRATION_DOUBT_M).then(|| {
        format!(
            "the camera sees the probe's apex at {}, {:.1} um from where the stage{offset_said} \
             has it {}: {CALIBRATION_UNFIT} (another rig's, \
             the rig file's stage axes or unit_um not the controller's, or the camera, lens or probe moved \
             since it was made); make it again (nanopush rig calibrate) before pushing",
            um(tip),
            off * 1e6,
            um(expected)
        )
    })
}

/// What every stop for a calibration that does not fit says: the apex
/// astray here, or its offsets growing with the stage's position
/// (`exec::calibration_fit`). Only words: such a stop is known by its type
/// ([`ApexDoubt::CalibrationUnfit`], `StopCause::CalibrationUnfit`).
pub const CALIBRATION_UNFIT: &str = "the calibration does not fit this camera and stage";

/// A point in um as the messages print it.
fn um(p: [f64; 2]) -> String {
    format!("({:.2}, {:.2}) um", p[0] * 1e6, p[1] * 1e6)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::vision::exposure::Exposure;
    use crate::vision::frame::Frame;

    /// A frame's sighting of the apex at `tip_um` with the stage sent to `stage_um`.
    pub(in crate::exec::assemble) fn sighting(tip_um: [f64; 2], stage_um: [f64; 2]) -> Sighting {
        Sighting {
            frame: Frame::new(1, 1, vec![0.0], 8).unwrap(),
            t_s: 0.0,
            particles: Vec::new(),
            cut_by_edge: Vec::new(),
            off_size: Vec::new(),
            spot_radius_m: None,
            tip_m: Some(tip_um.map(|v| v * 1e-6)),
            dropped: 0,
            repaired_lines: Vec::new(),
            exposure: Exposure::default(),
            view_m: [[0.0; 2]; 2],
            frame_m: [[0.0; 2]; 2],
            coarse_offset_m: [0.0, 0.0],
            stage_m: Some([stage_um[0] * 1e-6, stage_um[1] * 1e-6, 0.0]),
            probe: None,
            probe_shadow_px: 0.0,
        }
    }

    /// Not following the drift, an offset grown a little at a time past
    /// the doubt is named as drift; a jump between frames (x and y
    /// swapped: the stage moved along x, the apex along y) is the
    /// calibration's, as on the first frame.
    #[test]
    fn an_unfollowed_drift_is_told_from_a_calibration_that_does_not_fit() {
        let before = sighting([45.2, 50.0], [40.0, 50.0]);
        let drifted = sighting([55.4, 50.0], [50.0, 50.0]);
        let doubt = apex_doubt_unfollowed(&drifted, before.apex_offset_m()).unwrap();
        assert_eq!(doubt.cause(), StopCause::Other, "{doubt}");
        let why = doubt.to_string();
        assert!(why.contains("has drifted 5.4 um"), "{why}");
        assert!(why.contains("--no-drift-follow"), "{why}");
        assert!(why.contains("--resume with --drift-follow"), "{why}");
        assert!(!why.contains("calibration does not fit"), "{why}");
        // Under the doubt: nothing said.
        let near = sighting([54.9, 50.0], [50.0, 50.0]);
        assert_eq!(apex_doubt_unfollowed(&near, before.apex_offset_m()), None);
        let swapped = sighting([40.0, 60.0], [50.0, 50.0]);
        let before = sighting([40.0, 50.0], [40.0, 50.0]);
        let doubt = apex_doubt_unfollowed(&swapped, before.apex_offset_m()).unwrap();
        assert_eq!(doubt.cause(), StopCause::CalibrationUnfit, "{doubt}");
        let why = doubt.to_string();
        assert!(why.contains("calibration does not fit"), "{why}");
        assert!(
            why.contains("with the apex's last offset (0.00, 0.00) um"),
            "{why}"
        );
        let first = sighting([52.0, 57.0], [50.0, 50.0]);
        let doubt = apex_doubt_unfollowed(&first, None).unwrap();
        assert_eq!(
            doubt,
            ApexDoubt::CalibrationUnfit(calibration_doubt(&first).unwrap())
        );
        assert!(doubt.to_string().contains(CALIBRATION_UNFIT), "{doubt}");
    }

    /// Followed, the drift estimate is taken out of where the apex should be.
    #[test]
    fn a_followed_drift_is_taken_out_before_the_doubt() {
        let s = sighting([56.0, 50.0], [50.0, 50.0]);
        assert!(calibration_doubt(&s).is_some());
        assert_eq!(apex_doubt(&s, [5.5e-6, 0.0]), None);
        let why = apex_doubt(&s, [-1e-6, 0.0]).unwrap();
        assert!(why.contains("its drift so far (-1.00, 0.00) um"), "{why}");
    }
}
