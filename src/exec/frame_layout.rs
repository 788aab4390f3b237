//! The particles and the tip one microscope frame shows, as a layout to plan
//! on: what `nanopush plan --frame FRAME --calib FILE` plans from.
//!
//! The same perception as the closed loop and the dry-run
//! ([`Perception::sight`]: the size hint from the particle radius, rings cut
//! by the probe left out, those cut by the frame's edge set apart) and the
//! same layout of what it saw ([`layout_measured`]: ids in the order found,
//! each particle with the size the loop would plan it with, the field up to
//! the far corner of the view, stage coordinates), so a plan
//! made here is the plan the loop would start from. One frame is all this
//! plan sees, so the particles the frame's edge cuts (there, their centres
//! not measured) join the layout as particles it never pushes; one whose
//! centre falls below the stage origin makes it no layout (an error, not a
//! particle dropped). So do the particles beside the probe: the loop does
//! not fit a ring that close to the probe's outline (it will see it once
//! the tip has moved), but a plan from this frame would push another
//! particle onto it; a particle under the probe cannot be seen at all.

use super::assemble::layout_measured;
use super::camera_look::warn_of_pieces;
use super::observe::{ObserveError, Perception, RADIUS_TOLERANCE, Sighting};
use super::tracker::Observation;
use crate::calib::camera_map::CameraCalibration;
use crate::plan::layout::{Layout, LayoutError};
use crate::rig::RigError;
use crate::rig::camera::{Camera, TimedFrame};
use crate::vision::analyse::prepare_frame;
use crate::vision::detect::detect_particles_excluding;
use crate::vision::frame::Frame;
use nalgebra::Vector2;

/// What one frame shows, on the sample.
#[derive(Debug, Clone)]
pub struct FrameLayout {
    /// The particles seen whole, then those the frame's edge cuts, in stage
    /// coordinates.
    pub layout: Layout,
    /// Ids of the particles the frame's edge cuts: obstacles, never pushed
    /// (the planner's `immovable`).
    pub cut_by_edge: Vec<u32>,
    /// Ids of the particles found beside the probe, their rings too near its
    /// outline for the loop to measure: obstacles too.
    pub beside_probe: Vec<u32>,
    /// The probe's apex, when found: where the tip tour starts.
    pub tip_m: Option<Vector2<f64>>,
    /// The frame's near and far corners on the stage: what the camera
    /// saw. The layout's field runs from the stage origin to the far one.
    pub seen_m: [[f64; 2]; 2],
}

/// Why a frame gave no layout.
#[derive(Debug, thiserror::Error)]
pub enum FrameLayoutError {
    /// The particle radius is not a positive length.
    #[error("particle radius {0} um must be finite and > 0")]
    Radius(f64),
    /// Detection failed on the frame.
    #[error(transparent)]
    Observe(#[from] ObserveError),
    /// What was seen is not a layout (a particle below the stage origin, say).
    #[error(
        "the particles seen are not a layout: {0} (a layout's coordinates start at the stage origin: does the calibration map the frame onto the stage?)"
    )]
    Layout(#[from] LayoutError),
}

/// The particles (of about radius `radius_m`: the detector's size hint and
/// the batch's nominal size) and the tip in `frame`, placed on the sample
/// by `calibration`.
pub fn layout_from_frame(
    frame: Frame,
    calibration: &CameraCalibration,
    radius_m: f64,
) -> Result<FrameLayout, FrameLayoutError> {
    if !(radius_m.is_finite() && radius_m > 0.0) {
        return Err(FrameLayoutError::Radius(radius_m * 1e6));
    }
    let perception = Perception::for_particles(radius_m, calibration.m_per_px(), 1);
    let mut still = Still(Some(TimedFrame { t_s: 0.0, frame }));
    let sighting = perception.sight(&mut still, calibration, [0.0, 0.0])?;
    warn_of_pieces(
        "frame",
        &sighting,
        &perception.detect,
        calibration.m_per_px(),
    );
    say_spots_are_not_sized(&sighting, radius_m, calibration.m_per_px());
    let beside_probe = beside_the_probe(&sighting, &perception, radius_m)?;
    let seen: Vec<_> = (sighting.particles.iter())
        .chain(&sighting.cut_by_edge)
        .chain(&beside_probe)
        .cloned()
        .collect();
    // Each with the size the loop would plan it with, as a rig's first
    // frame is laid out: a spread batch's wide particles are then kept off
    // the sites here too. A cut particle's size is not measured: it takes
    // `radius_m`.
    // The whole frame: every particle found lies in it (the view the loop
    // tracks in is a diameter in from each edge, and a pattern as wide as
    // the frame less its discs' clearance did not fit).
    let layout = layout_measured(sighting.frame_m[1], &seen, radius_m);
    layout.validate_holding(&layout.beyond_field_ids())?;
    let ids = |from: usize, n: usize| {
        layout.particles[from..from + n]
            .iter()
            .map(|p| p.id)
            .collect()
    };
    let (whole, cut) = (sighting.particles.len(), sighting.cut_by_edge.len());
    Ok(FrameLayout {
        cut_by_edge: ids(whole, cut),
        beside_probe: ids(whole + cut, beside_probe.len()),
        layout,
        tip_m: sighting.tip_m.map(|[x, y]| Vector2::new(x, y)),
        seen_m: sighting.frame_m,
    })
}

/// Says, when the particles were fitted as spots, that the layout gives
/// each the radius asked for: a spot's width is the blur's. The README
/// promises each particle its own measured size, and a layout of 689
/// radii of exactly 0.5 um had looked measured.
fn say_spots_are_not_sized(sighting: &Sighting, radius_m: f64, m_per_px: f64) {
    if let Some(spot_m) = sighting.spot_radius_m {
        tracing::warn!(
            "frame: particles of {:.2} um radius are {:.1} px across here, too small to size: found as spots \
             (median 1/e^2 radius {:.2} um, the optics' blur more than their size), each is planned at {:.2} um, \
             the radius given (--radius-um)",
            radius_m * 1e6,
            2.0 * radius_m / m_per_px,
            spot_m * 1e6,
            radius_m * 1e6
        );
    }
}

/// `frame` with the pixels `under_probe` holds painted the background's
/// level (the frame's median): a particle the probe's dark body half
/// covers then shows a partial ring the detector finds, where against the
/// body its fit failed and the particle was lost (a plan, verified ok,
/// pushed another 2.1 um into it). Also returns how many pixels were
/// painted.
fn without_probe(
    frame: &Frame,
    under_probe: &dyn Fn(f64, f64) -> bool,
) -> Result<(Frame, usize), FrameLayoutError> {
    let mut sorted: Vec<f64> = frame.pixels().iter().map(|&v| f64::from(v)).collect();
    let background = crate::median::upper_median(&mut sorted).unwrap_or(0.0) as f32;
    let w = frame.width();
    let mut hidden = 0;
    let pixels = (frame.pixels().iter().enumerate())
        .map(|(i, &v)| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            if under_probe(x, y) {
                hidden += 1;
                background
            } else {
                v
            }
        })
        .collect();
    let unveiled = Frame::new(w, frame.height(), pixels, frame.bit_depth())
        .map_err(|e| ObserveError::Detect(e.to_string()))?;
    Ok((unveiled, hidden))
}

/// Says how much of the frame the probe hides (`hidden` of `pixels`): a
/// particle under it is in no layout, and no plan keeps clear of it.
fn warn_of_hidden(hidden: usize, pixels: usize) {
    if hidden > 0 {
        tracing::warn!(
            "the probe hides {:.0} % of the frame: a particle under it cannot be seen, and the plan does not keep clear of it (take the frame with the probe parked clear of the pattern)",
            (100.0 * hidden as f64 / pixels.max(1) as f64).max(1.0)
        );
    }
}

/// The particles of about `radius_m` found beside the probe where the
/// loop's perception leaves them out: centres within the probe's shadow
/// (`Sighting::probe_shadow_px`) but outside its silhouette. Their centres
/// are biased by the outline: each takes `radius_m`, as an obstacle needs
/// no more.
fn beside_the_probe(
    sighting: &Sighting,
    perception: &Perception,
    radius_m: f64,
) -> Result<Vec<Observation>, FrameLayoutError> {
    let Some((probe, calibration)) = &sighting.probe else {
        return Ok(Vec::new());
    };
    let prepared = prepare_frame(&sighting.frame);
    let under_probe = |x: f64, y: f64| probe.signed_distance(x, y) <= 0.0;
    let (unveiled, hidden) = without_probe(&prepared.frame, &under_probe)?;
    warn_of_hidden(hidden, unveiled.width() * unveiled.height());
    let found = detect_particles_excluding(&unveiled, &perception.detect, &under_probe)
        .map_err(|e| ObserveError::Detect(e.to_string()))?;
    let hint_r_px = perception.detect.diameter_px / 2.0;
    Ok(found
        .iter()
        .filter(|d| probe.signed_distance(d.x_px, d.y_px) < sighting.probe_shadow_px)
        // One the frame's edge cuts too: an obstacle needs no measured ring.
        .filter(|d| (d.r_px / hint_r_px - 1.0).abs() <= RADIUS_TOLERANCE)
        .map(|d| {
            let [x_m, y_m] = calibration.pixel_to_stage_m(d.x_px, d.y_px);
            Observation { x_m, y_m, radius_m }
        })
        .collect())
}

/// A camera that gives one frame, then none.
pub(crate) struct Still(pub(crate) Option<TimedFrame>);

impl Camera for Still {
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        Ok(self.0.take())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A calibration ten times too coarse (5.88 um/px for 0.588, a slip of
    /// the decimal point) makes 5 um particles 1.7 px across: the error
    /// names the scale and the radius, not a "diameter hint" the user never
    /// gave.
    #[test]
    fn particles_too_small_at_the_calibrations_scale_are_named_with_it() {
        let frame = Frame::new(64, 64, vec![100.0; 64 * 64], 8).unwrap();
        let calibration = CameraCalibration::from_scale_rotation(5.88e-6, 0.0, [0.0, 0.0]);
        let err = layout_from_frame(frame, &calibration, 5e-6).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("5.000 um radius")
                && text.contains("1.701 px")
                && text.contains("5.8800 um/px"),
            "{text}"
        );
    }
}
