//! Whether a size hint fits the particles a frame shows. A wrong hint fails
//! quietly: twice the size finds nothing, a fifth of it finds each ring as
//! several spots, and a ring model near the size measures them all the
//! same. The loop's first look and `nanopush detect` ask the same question:
//! which other hint finds most whole particles of its own size.

use super::detect::{DetectSettings, Detection, detect_particles, model_for};
use super::frame::Frame;
use super::profile_fit::ProfileModel;
use crate::median::upper_median;

/// Relative radius error beyond which a detection is not taken for a
/// particle of the hint's size.
pub const RADIUS_TOLERANCE: f64 = 0.3;

/// Hints tried, as factors of the given one, when it finds nothing.
pub const OTHER_SIZE_FACTORS: [f64; 4] = [0.5, 0.7, 1.4, 2.0];

/// Larger hints tried when the hint is one the spot model fits, which
/// takes any blob of about its size for a particle: 1 um for particles of
/// 5 um found each real frame's 5 particles as 49 pieces of their rings.
pub const LARGER_SIZE_FACTORS: [f64; 3] = [2.0, 4.0, 8.0];

/// Larger hints `detect` tries at a spot-model hint: steps of a square
/// root of two, so that one lands within [`RADIUS_TOLERANCE`] of any ring
/// size (of [`LARGER_SIZE_FACTORS`], 3 px reached neither the 12 px nor
/// the 24 px hint near 17 px rings).
pub const PIECE_CHECK_FACTORS: [f64; 7] = [2.0, 2.8, 4.0, 5.7, 8.0, 11.3, 16.0];

/// Fewest whole particles a larger hint must find for `detect` to doubt
/// its hint: one stray ring is no evidence (bulk_water's 743 spots at 7 px
/// against a single 15 px "ring").
pub const FEWEST_WHOLE: usize = 3;

/// Fewest particles found at the hint for each one a larger hint finds
/// whole that make the hint doubtful: each particle found several times.
pub const PIECES_PER_PARTICLE: usize = 3;

/// Whole particles a hint finds of its own size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FoundAtHint {
    /// The hint's radius, pixels.
    pub hint_r_px: f64,
    /// Whole particles within [`RADIUS_TOLERANCE`] of it.
    pub count: usize,
    /// Their median radius, pixels.
    pub median_r_px: f64,
}

/// The hint of `factors` (times `detect`'s) that finds most whole particles
/// of its own size in `frame` (a prepared frame), if any. Only hints the
/// ring model fits: the spot model does not measure a size (its radius is
/// the hint), and at half a 10 px hint it takes the rings of the true
/// particles for 83 spots.
pub fn found_at_other_hint(
    frame: &Frame,
    detect: &DetectSettings,
    factors: &[f64],
) -> Option<FoundAtHint> {
    factors
        .iter()
        .filter_map(|factor| {
            let settings = DetectSettings {
                diameter_px: detect.diameter_px * factor,
                ..detect.clone()
            };
            if model_for(&settings) != ProfileModel::Ring {
                return None;
            }
            let hint_r_px = settings.diameter_px / 2.0;
            let found = detect_particles(frame, &settings).ok()?;
            let mut radii = whole_radii_px(&found, hint_r_px);
            Some(FoundAtHint {
                hint_r_px,
                count: radii.len(),
                median_r_px: upper_median(&mut radii)?,
            })
        })
        .max_by_key(|found| found.count)
}

/// The radii of the whole detections (not cut by the frame's edge) within
/// [`RADIUS_TOLERANCE`] of `hint_r_px`.
fn whole_radii_px(found: &[Detection], hint_r_px: f64) -> Vec<f64> {
    found
        .iter()
        .filter(|d| !d.edge_clipped && (d.r_px / hint_r_px - 1.0).abs() <= RADIUS_TOLERANCE)
        .map(|d| d.r_px)
        .collect()
}

/// What is wrong with `detect`'s hint for `found`, the particles it found
/// in `frame` (prepared), in pixels: "None" when they are of its size.
/// Asked only of the profile fit's own detections.
pub fn hint_doubt(frame: &Frame, detect: &DetectSettings, found: &[Detection]) -> Option<String> {
    let hint_d = detect.diameter_px;
    let whole: Vec<&Detection> = found.iter().filter(|d| !d.edge_clipped).collect();
    if whole.is_empty() {
        return Some(
            match found_at_other_hint(frame, detect, &OTHER_SIZE_FACTORS) {
                Some(o) if o.count > 0 => format!(
                    "no whole particle found at the size hint of {hint_d} px across; a hint of {:.1} px finds {} (median diameter {:.1} px): give --diameter-px",
                    2.0 * o.hint_r_px,
                    o.count,
                    2.0 * o.median_r_px
                ),
                _ => format!(
                    "no whole particle found at the size hint of {hint_d} px across, nor at half or twice it: is --diameter-px the particles' size in this frame?{}",
                    if detect.polarity.is_some() {
                        " Or are their centres of the other contrast than --polarity says?"
                    } else {
                        ""
                    }
                ),
            },
        );
    }
    if model_for(detect) == ProfileModel::Spot {
        return found_at_other_hint(frame, detect, &PIECE_CHECK_FACTORS)
            .filter(|o| o.count >= FEWEST_WHOLE && found.len() >= PIECES_PER_PARTICLE * o.count)
            .map(|o| {
                format!(
                    "{} particles found at the size hint of {hint_d} px across, but a hint of {:.1} px finds {} whole (median diameter {:.1} px): each may be found several times over; give --diameter-px",
                    found.len(),
                    2.0 * o.hint_r_px,
                    o.count,
                    2.0 * o.median_r_px
                )
            });
    }
    let mut radii: Vec<f64> = whole.iter().filter(|d| d.fitted).map(|d| d.r_px).collect();
    let measured = radii.len();
    let median_r = upper_median(&mut radii)?;
    ((median_r / (hint_d / 2.0) - 1.0).abs() > RADIUS_TOLERANCE).then(|| {
        format!(
            "the particles found measure {:.1} px across (median of {measured}), the size hint {hint_d} px: a hint near their size finds and measures them better; give --diameter-px",
            2.0 * median_r
        )
    })
}
