//! One call for a whole frame: the tip first, then the particles away from the
//! probe silhouette (its edges would otherwise look like particles). This is
//! what the simulated and real rigs call per frame. A camera's dead or hot
//! lines are filled in first (`line_defects`), and what of the frame is
//! clipped is measured (`exposure`).

use super::detect::{
    DetectError, DetectSettings, Detection, detect_particles, detect_particles_excluding,
};
use std::borrow::Cow;

use super::exposure::{self, Exposure};
use super::frame::Frame;
use super::line_defects::{self, LineDefect, repair_line_defects};
use super::tip::{TipDetection, TipSettings, detect_tip};

/// A frame as every detector sees it: its defective lines repaired, and
/// how much of it clips.
pub struct PreparedFrame<'a> {
    /// The frame, repaired (borrowed unchanged when no line needed it).
    pub frame: Cow<'a, Frame>,
    /// Camera lines filled in from their neighbours.
    pub repaired_lines: Vec<LineDefect>,
    /// How much of the repaired frame is clipped at either end.
    pub exposure: Exposure,
}

/// Repairs `frame`'s defective lines and measures its clipping: the first
/// step of the whole-frame analysis, the Crocker-Grier mode and the loop.
pub fn prepare_frame(frame: &Frame) -> PreparedFrame<'_> {
    let (frame, repaired_lines) = repair_line_defects(frame);
    let exposure = Exposure::of(&frame);
    PreparedFrame {
        frame,
        repaired_lines,
        exposure,
    }
}

/// Warns of `source`'s camera state (repaired lines, clipping), each when it
/// first appears or changes.
pub fn report_camera_state(
    source: &str,
    repaired_lines: &[LineDefect],
    exposure: &Exposure,
    full_count: f32,
) {
    line_defects::report(source, repaired_lines);
    exposure::report(source, exposure, full_count);
}

/// What a one-line account of a frame ends with about the camera:
/// "  (camera lines repaired: column 280)  (camera clipped: 61.0 %
/// saturated, 0.0 % at 0 counts)", each part only when it applies.
pub fn camera_notes(repaired_lines: &[LineDefect], clipped: Option<Exposure>) -> String {
    let mut notes = String::new();
    if !repaired_lines.is_empty() {
        let places: Vec<String> = repaired_lines.iter().map(LineDefect::place).collect();
        notes += &format!("  (camera lines repaired: {})", places.join(", "));
    }
    if let Some(e) = clipped {
        notes += &format!("  (camera clipped: {e})");
    }
    notes
}

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
    let PreparedFrame {
        frame,
        repaired_lines,
        exposure,
    } = prepare_frame(frame);
    let frame = frame.as_ref();
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
