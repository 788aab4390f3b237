//! One frame from a rig's camera, seen as the closed loop sees it
//! (`nanopush rig probe --camera`): before a run, a user sees that frames
//! arrive, in which channel, at what exposure, and whether the particles
//! and the probe are found where the calibration puts them.

use std::fmt;

use super::observe::{ObserveError, Perception, Sighting};
use crate::calib::affine::AffineCalibration;
use crate::rig::camera::Camera;
use crate::rig::camera_source::CameraSource;
use crate::vision::analyse::camera_notes;

/// Grabs tried before the look gives up: a camera's own timeout applies
/// to each (a watched folder's `timeout_ms`).
pub const LOOK_GRABS: usize = 2;

/// What one frame of the camera showed.
#[derive(Debug, Clone)]
pub struct CameraLook {
    /// Where frames come from, as the rig file says.
    pub source: String,
    /// The loop's sighting of the frame (coarse offset taken as zero).
    pub sighting: Sighting,
    /// The particles' radius the size hint was made from, metres.
    pub radius_m: f64,
    /// The calibration's pixel size, metres.
    pub m_per_px: f64,
}

/// Grabs a frame from `camera` and sees it with the loop's own perception
/// for particles of `radius_m`.
pub fn look(
    source: &CameraSource,
    camera: &mut dyn Camera,
    calibration: &AffineCalibration,
    radius_m: f64,
) -> Result<CameraLook, ObserveError> {
    let m_per_px = calibration.m_per_px();
    let perception = Perception::for_particles(radius_m, m_per_px, LOOK_GRABS);
    let sighting = perception.sight(camera, calibration, [0.0, 0.0])?;
    Ok(CameraLook {
        source: source.describe(),
        sighting,
        radius_m,
        m_per_px,
    })
}

impl CameraLook {
    /// What to doubt when the particles found are not the scene's size:
    /// whole detections of another size, or none at all.
    fn size_doubt(&self) -> Option<String> {
        let s = &self.sighting;
        let check = "is the scene's particle radius right, and the calibration's um/px?";
        if s.off_size.is_empty() {
            return (s.particles.is_empty() && s.cut_by_edge.is_empty())
                .then(|| format!("no particle found near the size hint: {check}"));
        }
        let median = s.off_size_median_radius_m()?;
        Some(format!(
            "{} more found whole at another size (median radius {:.2} um) and left out: {check}",
            s.off_size.len(),
            median * 1e6
        ))
    }
}

impl fmt::Display for CameraLook {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.sighting;
        let um = |m: f64| m * 1e6;
        writeln!(f, "source:         {}", self.source)?;
        let grabs = match s.dropped {
            0 => String::new(),
            n => format!(" (after {n} grabs without a frame)"),
        };
        writeln!(
            f,
            "frame:          {} x {} px, {}-bit{grabs}",
            s.frame.width(),
            s.frame.height(),
            s.frame.bit_depth()
        )?;
        let notes = camera_notes(&s.repaired_lines, s.exposure.clipped());
        let state = if notes.is_empty() {
            "no line repaired, under 1 % clipped".to_string()
        } else {
            notes.trim().to_string()
        };
        writeln!(f, "camera state:   {state}")?;
        writeln!(
            f,
            "particles:      {} whole, {} cut by the frame's edge (size hint: radius {:.2} um = {:.1} px at {:.4} um/px)",
            s.particles.len(),
            s.cut_by_edge.len(),
            um(self.radius_m),
            self.radius_m / self.m_per_px,
            um(self.m_per_px)
        )?;
        if let Some(line) = self.size_doubt() {
            writeln!(f, "size:           {line}")?;
        }
        match (&s.probe, s.tip_m) {
            (Some((tip, _)), Some([x, y])) => writeln!(
                f,
                "tip:            apex at ({:.1}, {:.1}) px = ({:.2}, {:.2}) um, angle {:.1} deg",
                tip.x_px,
                tip.y_px,
                um(x),
                um(y),
                tip.angle_rad.to_degrees()
            )?,
            _ => writeln!(f, "tip:            not seen")?,
        }
        let [lo, hi] = s.view_m;
        writeln!(
            f,
            "view:           x {:.1} .. {:.1} um, y {:.1} .. {:.1} um (the calibration's stage coordinates, no coarse offset)",
            um(lo[0]),
            um(hi[0]),
            um(lo[1]),
            um(hi[1])
        )
    }
}
