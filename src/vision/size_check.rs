//! Whether a size hint fits the particles a frame shows. A wrong hint fails
//! quietly: twice the size finds nothing, a fifth of it finds each ring as
//! several spots, and a ring model near the size measures them all the
//! same. The loop's first look and `nanopush detect` ask the same question:
//! which other hint finds most whole particles of its own size.

use super::detect::{DetectSettings, Detection, model_for};
use super::frame::Frame;
use super::profile_fit::ProfileModel;
use super::ring_search::rings_where_spots_gather;
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

/// Smaller hints tried at a ring-model hint, those the spot model fits:
/// 10 px on T76S3F00001's spots 7 px across found 12 "rings" without a
/// word, where 7 px finds 744 spots (trackpy 344).
pub const SPOT_SIZE_FACTORS: [f64; 2] = [0.5, 0.7];

/// Fewest whole particles a larger hint must find for `detect` to doubt
/// its hint: one stray ring is no evidence (bulk_water's 743 spots at 7 px
/// against a single 15 px "ring").
pub const FEWEST_WHOLE: usize = 3;

/// Fewest particles found at the hint for each one a larger hint finds
/// whole that make the hint doubtful: each particle found several times.
pub const PIECES_PER_PARTICLE: usize = 3;

/// Whole particles a hint finds of its own size.
#[derive(Debug, Clone, PartialEq)]
pub struct FoundAtHint {
    /// The hint's radius, pixels.
    pub hint_r_px: f64,
    /// Whole particles within [`RADIUS_TOLERANCE`] of it.
    pub count: usize,
    /// Their median radius, pixels.
    pub median_r_px: f64,
    /// Each one's centre and radius, pixels.
    pub rings: Vec<[f64; 3]>,
}

/// True when `d` lies on one of `rings` (within 1.2 radii of its
/// centre): a piece of it.
fn on_a_ring(d: &Detection, rings: &[[f64; 3]]) -> bool {
    rings
        .iter()
        .any(|[x, y, r]| (d.x_px - x).hypot(d.y_px - y) <= 1.2 * r)
}

/// Of `found`, how many lie on one of `rings`: pieces of them.
fn on_rings(found: &[Detection], rings: &[[f64; 3]]) -> usize {
    found.iter().filter(|d| on_a_ring(d, rings)).count()
}

/// The hints of `factors` (times `detect`'s) that [`found_at_other_hint`]
/// tries, diameters in pixels: "0.5 to 2 times it" was said where half of
/// it had not been tried.
fn ring_hints_px(detect: &DetectSettings, factors: &[f64]) -> Vec<f64> {
    factors
        .iter()
        .map(|f| detect.diameter_px * f)
        .filter(|&d| {
            let settings = DetectSettings {
                diameter_px: d,
                ..detect.clone()
            };
            model_for(&settings) == ProfileModel::Ring
        })
        .collect()
}

/// The hint of `factors` (times `detect`'s) that finds most whole particles
/// of its own size in `frame` (a prepared frame), if any. Only hints the
/// ring model fits: the spot model does not measure a size (its radius is
/// the hint), and at half a 10 px hint it takes the rings of the true
/// particles for 83 spots. Given the `spots` found at the hint, only rings
/// they could be pieces of are looked for ([`rings_where_spots_gather`]).
pub fn found_at_other_hint(
    frame: &Frame,
    detect: &DetectSettings,
    factors: &[f64],
    spots: &[Detection],
) -> Option<FoundAtHint> {
    most_found_at(frame, detect, factors, ProfileModel::Ring, spots, of_size)
}

/// The fitted whole spots a smaller hint of [`SPOT_SIZE_FACTORS`] finds
/// off `rings` (the ring fits at `detect`'s hint, pixels), when `detect`'s
/// hint is one the ring model fits and the hint with most finds at least
/// [`FEWEST_WHOLE`] and [`PIECES_PER_PARTICLE`] times `found_at_hint`: the
/// hint is too large for particles seen as spots. Their median radius is
/// the spots' fitted 1/e^2 radius, the blur's for particles the optics do
/// not resolve.
pub fn spots_at_smaller_hint(
    frame: &Frame,
    detect: &DetectSettings,
    rings: &[[f64; 3]],
    found_at_hint: usize,
) -> Option<FoundAtHint> {
    if model_for(detect) != ProfileModel::Ring {
        return None;
    }
    let off_rings = |d: &Detection, _| d.fitted && !d.edge_clipped && !on_a_ring(d, rings);
    most_found_at(
        frame,
        detect,
        &SPOT_SIZE_FACTORS,
        ProfileModel::Spot,
        &[],
        off_rings,
    )
    .filter(|s| s.count >= FEWEST_WHOLE && s.count >= PIECES_PER_PARTICLE * found_at_hint)
}

/// Smallest hint tried, pixels: `detect` refuses a smaller one.
const SMALLEST_HINT_PX: f64 = 2.0;

/// Of the hints of `factors` (times `detect`'s) that `model` fits, the
/// one whose detections `keep` (given the hint's radius) takes most of,
/// with those kept and their median radius. The other size hints are
/// worth trying only with the model whose answer the caller can read: a
/// ring's measured radius, or a spot's presence. Searched as
/// [`rings_where_spots_gather`] does given `spots`: every detection when
/// there are none.
fn most_found_at(
    frame: &Frame,
    detect: &DetectSettings,
    factors: &[f64],
    model: ProfileModel,
    spots: &[Detection],
    keep: impl Fn(&Detection, f64) -> bool,
) -> Option<FoundAtHint> {
    factors
        .iter()
        .filter_map(|factor| {
            let settings = DetectSettings {
                diameter_px: detect.diameter_px * factor,
                ..detect.clone()
            };
            if model_for(&settings) != model || settings.diameter_px < SMALLEST_HINT_PX {
                return None;
            }
            let hint_r_px = settings.diameter_px / 2.0;
            let found = rings_where_spots_gather(frame, &settings, spots).ok()?;
            let kept: Vec<[f64; 3]> = (found.iter())
                .filter(|d| keep(d, hint_r_px))
                .map(|d| [d.x_px, d.y_px, d.r_px])
                .collect();
            let mut radii: Vec<f64> = kept.iter().map(|r| r[2]).collect();
            Some(FoundAtHint {
                hint_r_px,
                count: kept.len(),
                median_r_px: upper_median(&mut radii)?,
                rings: kept,
            })
        })
        .max_by_key(|found| found.count)
}

/// True when `d` is whole (not cut by the frame's edge) and within
/// [`RADIUS_TOLERANCE`] of `hint_r_px`.
fn of_size(d: &Detection, hint_r_px: f64) -> bool {
    !d.edge_clipped && (d.r_px / hint_r_px - 1.0).abs() <= RADIUS_TOLERANCE
}

/// Fewest found, most of them not fitted, that make the hint doubtful.
const FEWEST_FOR_UNFITTED: usize = 5;

/// What is wrong with `detect`'s hint for `found`, the particles it found
/// in `frame` (prepared), in pixels: "None" when they are of its size.
/// Asked only of the profile fit's own detections.
pub fn hint_doubt(frame: &Frame, detect: &DetectSettings, found: &[Detection]) -> Option<String> {
    let hint_d = detect.diameter_px;
    let whole: Vec<&Detection> = found.iter().filter(|d| !d.edge_clipped).collect();
    let rings: Vec<[f64; 3]> = whole.iter().map(|d| [d.x_px, d.y_px, d.r_px]).collect();
    // Asked after the ring hints when nothing was found: their pieces fit
    // as spots too (a synthetic frame's 20 px rings gave 19 "spots" at a
    // 10 px hint's half).
    let spots = || spots_at_smaller_hint(frame, detect, &rings, whole.len());
    let spots_said = |s: FoundAtHint| {
        format!(
            "{} found at the size hint of {hint_d} px across, but a hint of {:.1} px finds {} spots besides, {:.1} px across (median 1/e^2 width): is --diameter-px their size? A hint near the spots' finds them",
            crate::wording::counted(found.len(), "particle"),
            2.0 * s.hint_r_px,
            s.count,
            2.0 * s.median_r_px
        )
    };
    if !whole.is_empty()
        && let Some(s) = spots()
    {
        return Some(spots_said(s));
    }
    if whole.is_empty() {
        let tried = ring_hints_px(detect, &OTHER_SIZE_FACTORS);
        let tried_text = tried
            .iter()
            .map(|d| format!("{d:.1}"))
            .collect::<Vec<_>>()
            .join(", ");
        let contrast = if detect.polarity.is_some() {
            " Or are their centres of the other contrast than --polarity says?"
        } else {
            ""
        };
        return Some(
            match found_at_other_hint(frame, detect, &OTHER_SIZE_FACTORS, &[]) {
                Some(o) if o.count >= FEWEST_WHOLE => format!(
                    "no whole particle found at the size hint of {hint_d} px across; a hint of {:.1} px finds {} (median diameter {:.1} px): is --diameter-px their size?",
                    2.0 * o.hint_r_px,
                    o.count,
                    2.0 * o.median_r_px
                ),
                _ => match spots() {
                    Some(s) => spots_said(s),
                    None if tried.is_empty() => format!(
                        "no whole particle found at the size hint of {hint_d} px across: is --diameter-px their size in this frame?{contrast}"
                    ),
                    None => format!(
                        "no whole particle found at the size hint of {hint_d} px across, nor at {tried_text} px: is --diameter-px their size in this frame?{contrast}"
                    ),
                },
            },
        );
    }
    if model_for(detect) == ProfileModel::Spot
        && let Some(o) = found_at_other_hint(frame, detect, &PIECE_CHECK_FACTORS, found)
    {
        // Pieces: most of what was found lies on a few larger rings (bulk
        // water's 649 spots at 5 px had been doubted for 3 "rings" at 10).
        let pieces = on_rings(found, &o.rings);
        if o.count >= FEWEST_WHOLE
            && pieces >= PIECES_PER_PARTICLE * o.count
            && 2 * pieces >= found.len()
        {
            return Some(format!(
                "{} particles found at the size hint of {hint_d} px across, {pieces} of them on the {} whole ones a hint of {:.1} px finds (median diameter {:.1} px): each may be found several times over; is --diameter-px their size?",
                found.len(),
                o.count,
                2.0 * o.hint_r_px,
                2.0 * o.median_r_px
            ));
        }
    }
    let unfitted = whole.iter().filter(|d| !d.fitted).count();
    if whole.len() >= FEWEST_FOR_UNFITTED && 10 * unfitted >= 9 * whole.len() {
        return Some(format!(
            "{unfitted} of the {} whole particles found could not be fitted at the size hint of {hint_d} px across (each kept at its centroid): is --diameter-px their size?",
            whole.len()
        ));
    }
    if model_for(detect) == ProfileModel::Spot {
        return None;
    }
    let mut radii: Vec<f64> = whole.iter().filter(|d| d.fitted).map(|d| d.r_px).collect();
    let measured = radii.len();
    let median_r = upper_median(&mut radii)?;
    ((median_r / (hint_d / 2.0) - 1.0).abs() > RADIUS_TOLERANCE).then(|| {
        format!(
            "the particles found measure {:.1} px across (median of {measured}), the size hint {hint_d} px: a hint near their size finds and measures them better"
        , 2.0 * median_r)
    })
}
