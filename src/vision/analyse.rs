//! One call for a whole frame: the tip first, then the particles away from the
//! probe silhouette (its edges would otherwise look like particles). This is
//! what the simulated and real rigs call per frame. A camera's dead or hot
//! lines are filled in first (`line_defects`), and what of the frame is
//! clipped is measured (`exposure`).

use super::detect::{
    DetectError, DetectSettings, Detection, detect_particles, detect_particles_excluding,
};
use super::exposure::Exposure;
use super::frame::Frame;
use super::line_defects::{LineDefect, repair_line_defects};
use super::tip::{TipDetection, TipSettings, detect_tip};

/// Everything found in one frame, in pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameAnalysis {
    /// Particles not covered by or touching the probe silhouette.
    pub particles: Vec<Detection>,
    /// The probe tip, if in view.
    pub tip: Option<TipDetection>,
    /// Camera lines filled in from their neighbours before detection.
    pub repaired_lines: Vec<LineDefect>,
    /// How much of the (repaired) frame is clipped at either end.
    pub exposure: Exposure,
}

/// Finds the tip (unless `tip` is `None`) and the particles clear of it,
/// in the frame with its defective lines repaired.
pub fn analyse_frame(
    frame: &Frame,
    settings: &DetectSettings,
    tip: Option<&TipSettings>,
) -> Result<FrameAnalysis, DetectError> {
    let (frame, repaired_lines) = repair_line_defects(frame);
    let frame = frame.as_ref();
    let exposure = Exposure::of(frame);
    let tip = tip.and_then(|t| detect_tip(frame, t));
    let margin = 0.5 * settings.diameter_px;
    let mut particles = match &tip {
        Some(t) => {
            detect_particles_excluding(frame, settings, &|x, y| t.signed_distance(x, y) <= margin)?
        }
        None => detect_particles(frame, settings)?,
    };
    if let Some(t) = &tip {
        particles.retain(|d| t.signed_distance(d.x_px, d.y_px) > 0.5 * settings.diameter_px);
    }
    Ok(FrameAnalysis {
        particles,
        tip,
        repaired_lines,
        exposure,
    })
}
