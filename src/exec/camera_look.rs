//! One frame from a rig's camera, seen as the closed loop sees it
//! (`nanopush rig probe --camera`): before a run, a user sees that frames
//! arrive, in which channel, at what exposure, and whether the particles
//! and the probe are found where the calibration puts them. Before there
//! is a calibration, the frame, the exposure and the tip in pixels: what
//! `nanopush rig calibrate` needs to start.

use std::fmt;

use super::observe::{ObserveError, Perception, SIZE_CHECK, Sighting, grab_frame};
use crate::calib::camera_map::CameraCalibration;
use crate::calib::lens::RadialLens;
use crate::rig::camera::Camera;
use crate::rig::camera_source::CameraSource;
use crate::vision::analyse::{camera_notes, prepare_frame};
use crate::vision::detect::{DetectSettings, detect_particles, model_for};
use crate::vision::exposure::Exposure;
use crate::vision::frame::Frame;
use crate::vision::line_defects::LineDefect;
use crate::vision::profile_fit::ProfileModel;
use crate::vision::size_check::{
    FEWEST_WHOLE, FoundAtHint, LARGER_SIZE_FACTORS, OTHER_SIZE_FACTORS, PIECES_PER_PARTICLE,
    found_at_other_hint, spots_at_smaller_hint,
};
use crate::vision::tip::{TipDetection, TipSettings, detect_tip};

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
    /// What to doubt about the particles' size ([`size_doubt`]), if anything.
    pub size_doubt: Option<String>,
    /// The objective's distortion the calibration corrects, if it has one.
    pub lens: Option<RadialLens>,
}

/// Grabs a frame from `camera` and sees it with the loop's own perception
/// for particles of `radius_m`.
pub fn look(
    source: &CameraSource,
    camera: &mut dyn Camera,
    calibration: &CameraCalibration,
    radius_m: f64,
) -> Result<CameraLook, ObserveError> {
    let m_per_px = calibration.m_per_px();
    let perception = Perception::for_particles(radius_m, m_per_px, LOOK_GRABS);
    let sighting = perception.sight(camera, calibration, [0.0, 0.0])?;
    let size_doubt = size_doubt(&sighting, &perception.detect, m_per_px);
    Ok(CameraLook {
        source: source.describe(),
        sighting,
        radius_m,
        m_per_px,
        size_doubt,
        lens: calibration.lens,
    })
}

/// What one frame showed before the rig had a calibration.
#[derive(Debug, Clone)]
pub struct UncalibratedLook {
    /// Where frames come from, as the rig file says.
    pub source: String,
    /// The frame as the camera gave it.
    pub frame: Frame,
    /// Frames dropped before it.
    pub dropped: usize,
    /// Camera lines filled in from their neighbours.
    pub repaired_lines: Vec<LineDefect>,
    /// How much of the (repaired) frame is clipped at either end.
    pub exposure: Exposure,
    /// The probe's tip, pixels, when found.
    pub tip: Option<TipDetection>,
}

/// Grabs a frame from `camera` and looks for the tip in it, in pixels (no
/// calibration needed; particles are left out: their size in pixels is
/// what the calibration would tell).
pub fn look_uncalibrated(
    source: &CameraSource,
    camera: &mut dyn Camera,
) -> Result<UncalibratedLook, ObserveError> {
    let (timed, dropped) = grab_frame(camera, LOOK_GRABS)?;
    let prepared = prepare_frame(&timed.frame);
    let tip = detect_tip(&prepared.frame, &TipSettings::default());
    Ok(UncalibratedLook {
        source: source.describe(),
        dropped,
        repaired_lines: prepared.repaired_lines,
        exposure: prepared.exposure,
        tip,
        frame: timed.frame,
    })
}

/// What to doubt when the particles a sighting found are not the scene's
/// size: whole detections of another size, or none at all (and then which
/// other hint than `detect`'s finds particles, 0.5 to 2 times it), or, at
/// a hint the spot model fits, a larger hint that finds whole particles
/// `PIECES_PER_PARTICLE` (3) times fewer (the hint's particles are pieces of
/// them), or, at a hint the ring model fits, a smaller hint that finds
/// that many times more spots (the hint is too large for particles seen
/// as spots); `None` when particles of the size were found.
pub fn size_doubt(s: &Sighting, detect: &DetectSettings, m_per_px: f64) -> Option<String> {
    let um_per_px = m_per_px * 1e6;
    if let Some(radius_m) = s.off_size_median_radius_m() {
        return Some(format!(
            "{} found whole at another size (median radius {:.2} um) and left out: {SIZE_CHECK}",
            s.off_size.len(),
            radius_m * 1e6
        ));
    }
    let frame = prepare_frame(&s.frame).frame;
    let found = s.particles.len();
    // Spots a smaller hint finds in numbers: the radius is too large for
    // particles seen as spots (2.3 um on bulk_water's 1 um spheres planned
    // "7 sites but only 1 particle" without a word), the rings it found
    // left out (their arcs fit as spots too): the sighting keeps no
    // pixels, so they are found again. Asked after the ring hints when
    // nothing was found: larger rings' pieces are spots too.
    let spots = || {
        let rings: Vec<[f64; 3]> = (detect_particles(&frame, detect).unwrap_or_default().iter())
            .filter(|d| !d.edge_clipped)
            .map(|d| [d.x_px, d.y_px, d.r_px])
            .collect();
        spots_at_smaller_hint(&frame, detect, &rings, found)
    };
    let spots_said = |o: FoundAtHint| {
        format!(
            "{} found near the size hint, but a hint of radius {:.2} um finds {} spots, \
             {:.2} um in radius (median 1/e^2 width; for particles the optics do not resolve, the blur's): {SIZE_CHECK}",
            crate::wording::counted(found, "particle"),
            o.hint_r_px * um_per_px,
            o.count,
            o.median_r_px * um_per_px
        )
    };
    if found > 0 || !s.cut_by_edge.is_empty() {
        if model_for(detect) == ProfileModel::Ring {
            return spots().map(spots_said);
        }
        return found_at_other_hint(&frame, detect, &LARGER_SIZE_FACTORS, &[])
            .filter(|o| o.count > 0 && found >= PIECES_PER_PARTICLE * o.count)
            .map(|o| {
                format!(
                    "{found} particles found near the size hint, but a hint of radius {:.2} um finds {} whole \
                     (median radius {:.2} um): each may be found several times over; {SIZE_CHECK}",
                    o.hint_r_px * um_per_px,
                    o.count,
                    o.median_r_px * um_per_px
                )
            });
    }
    let rings_said = |o: FoundAtHint| {
        format!(
            "no particle found near the size hint; with a hint of radius {:.2} um, {} found whole (median radius {:.2} um): {SIZE_CHECK}",
            o.hint_r_px * um_per_px,
            o.count,
            o.median_r_px * um_per_px
        )
    };
    Some(
        match found_at_other_hint(&frame, detect, &OTHER_SIZE_FACTORS, &[]) {
            Some(o) if o.count >= FEWEST_WHOLE => rings_said(o),
            other => match (spots(), other) {
                (Some(o), _) => spots_said(o),
                (None, Some(o)) => rings_said(o),
                (None, None) => format!(
                    "no particle found near the size hint, nor at half or twice it: {SIZE_CHECK}"
                ),
            },
        },
    )
}

/// Warns, naming `source`, when a first frame's particles look like
/// pieces of larger ones ([`size_doubt`] with nothing left out for its
/// size: that the sighting tells itself). A plan on them pushes pieces of
/// rings, and nothing else would show it.
pub fn warn_of_pieces(source: &str, s: &Sighting, detect: &DetectSettings, m_per_px: f64) {
    if s.off_size.is_empty()
        && let Some(doubt) = size_doubt(s, detect, m_per_px)
    {
        tracing::warn!("{source}: {doubt}");
    }
}

/// The source, frame and camera-state lines both looks begin with.
fn write_frame_lines(
    f: &mut fmt::Formatter<'_>,
    source: &str,
    frame: &Frame,
    dropped: usize,
    (repaired_lines, exposure): (&[LineDefect], &Exposure),
) -> fmt::Result {
    writeln!(f, "source:         {source}")?;
    let grabs = match dropped {
        0 => String::new(),
        n => format!(
            " (after {} without a frame)",
            crate::wording::counted(n, "grab")
        ),
    };
    writeln!(
        f,
        "frame:          {} x {} px, {}-bit{grabs}",
        frame.width(),
        frame.height(),
        frame.bit_depth()
    )?;
    let notes = camera_notes(repaired_lines, exposure.clipped());
    let state = if notes.is_empty() {
        "no line repaired, under 1 % clipped".to_string()
    } else {
        notes.trim().to_string()
    };
    writeln!(f, "camera state:   {state}")
}

impl fmt::Display for UncalibratedLook {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let camera = (&self.repaired_lines[..], &self.exposure);
        write_frame_lines(f, &self.source, &self.frame, self.dropped, camera)?;
        match &self.tip {
            Some(t) => writeln!(
                f,
                "tip:            apex at ({:.1}, {:.1}) px, angle {:.1} deg (no calibration yet: pixels only)",
                t.x_px,
                t.y_px,
                t.angle_rad.to_degrees()
            ),
            None => writeln!(
                f,
                "tip:            not seen (`rig calibrate` starts with the tip in view)"
            ),
        }
    }
}

impl fmt::Display for CameraLook {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.sighting;
        let um = |m: f64| m * 1e6;
        let camera = (&s.repaired_lines[..], &s.exposure);
        write_frame_lines(f, &self.source, &s.frame, s.dropped, camera)?;
        writeln!(
            f,
            "particles:      {} whole, {} cut by the frame's edge (size hint: radius {:.2} um = {:.1} px at {:.4} um/px)",
            s.particles.len(),
            s.cut_by_edge.len(),
            um(self.radius_m),
            self.radius_m / self.m_per_px,
            um(self.m_per_px)
        )?;
        if let Some(line) = &self.size_doubt {
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
        let [lo, hi] = s.frame_m;
        let [whole_lo, whole_hi] = s.view_m;
        writeln!(
            f,
            "view:           x {:.1} .. {:.1} um, y {:.1} .. {:.1} um (the calibration's stage coordinates, no coarse offset); \
             particles are tracked whole within x {:.1} .. {:.1}, y {:.1} .. {:.1} um",
            um(lo[0]),
            um(hi[0]),
            um(lo[1]),
            um(hi[1]),
            um(whole_lo[0]),
            um(whole_hi[0]),
            um(whole_lo[1]),
            um(whole_hi[1])
        )?;
        match &self.lens {
            Some(lens) => writeln!(
                f,
                "lens:           k1 {:+.5}: the calibration moves this frame's corners up to {:.2} px",
                lens.k1,
                lens.largest_shift_px(s.frame.width(), s.frame.height())
            ),
            None => Ok(()),
        }
    }
}
