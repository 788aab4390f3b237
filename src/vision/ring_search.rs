//! The size check's search for larger rings that spots may be pieces of,
//! made cheaply. On a frame of real spots every larger hint finds nothing,
//! and found it by fitting a ring at every candidate of the whole frame:
//! seven such searches took 3.0 s of CPU on T76S3F00001 (744 spots at
//! 7 px), where the detection itself takes 33 ms. A ring the check counts
//! has at least [`PIECES_PER_PARTICLE`] spots on it, so only candidates
//! where that many gather are fitted, and a hint over [`BIN_ABOVE_PX`] is
//! searched on the frame binned 2x2 (again while it stays above), where a
//! ring keeps its shape at a quarter of the pixels.

use super::detect::{DetectError, DetectSettings, Detection, detect_particles};
use super::filter::bin_frame;
use super::frame::Frame;
use super::roi::RoiMask;
use super::size_check::{PIECES_PER_PARTICLE, RADIUS_TOLERANCE};

/// Hint (px) above which the frame is binned for the search: a binned
/// hint stays at or above half of it, 10 px, a ring the ring model fits
/// (at 28, the 28 px search alone took 330 ms of the check's 800 on T76).
pub const BIN_ABOVE_PX: f64 = 20.0;

/// How far from a ring's centre its pieces lie, in hint radii: the 1.2
/// radii a piece is counted within, of a ring up to [`RADIUS_TOLERANCE`]
/// larger than the hint.
const PIECE_REACH: f64 = 1.2 * (1.0 + RADIUS_TOLERANCE);

/// The rings `settings` finds in `frame` where at least
/// [`PIECES_PER_PARTICLE`] of `spots` lie within a ring's reach of the
/// candidate; with no spots, every ring (a plain detection). Pixels of
/// `frame`.
pub fn rings_where_spots_gather(
    frame: &Frame,
    settings: &DetectSettings,
    spots: &[Detection],
) -> Result<Vec<Detection>, DetectError> {
    if spots.is_empty() || settings.roi.is_some() {
        return detect_particles(frame, settings);
    }
    let mut binned = std::borrow::Cow::Borrowed(frame);
    let mut scale = 1.0;
    while settings.diameter_px / scale > BIN_ABOVE_PX {
        binned = std::borrow::Cow::Owned(bin_frame(&binned));
        scale *= 2.0;
    }
    // Binned pixel i covers full pixels scale*i .. scale*(i+1)-1.
    let offset = (scale - 1.0) / 2.0;
    let at_scale = DetectSettings {
        diameter_px: settings.diameter_px / scale,
        roi: Some(gathering_mask(&binned, spots, scale, offset, settings)),
        ..settings.clone()
    };
    Ok(detect_particles(&binned, &at_scale)?
        .into_iter()
        .map(|d| Detection {
            x_px: d.x_px * scale + offset,
            y_px: d.y_px * scale + offset,
            r_px: d.r_px * scale,
            sigma_px: d.sigma_px * scale,
            ..d
        })
        .collect())
}

/// The pixels of `binned` (binned by `scale` from the frame `spots` are
/// in) with [`PIECES_PER_PARTICLE`] spots within a ring's reach.
fn gathering_mask(
    binned: &Frame,
    spots: &[Detection],
    scale: f64,
    offset: f64,
    settings: &DetectSettings,
) -> RoiMask {
    let (w, h) = (binned.width(), binned.height());
    let reach = PIECE_REACH * settings.diameter_px / 2.0 / scale + 2.0;
    let mut near = vec![0u16; w * h];
    for s in spots {
        let (cx, cy) = ((s.x_px - offset) / scale, (s.y_px - offset) / scale);
        let x0 = (cx - reach).floor().max(0.0) as usize;
        let y0 = (cy - reach).floor().max(0.0) as usize;
        let x1 = ((cx + reach).ceil().max(0.0) as usize).min(w.saturating_sub(1));
        let y1 = ((cy + reach).ceil().max(0.0) as usize).min(h.saturating_sub(1));
        for y in y0..=y1 {
            for x in x0..=x1 {
                if (x as f64 - cx).hypot(y as f64 - cy) <= reach {
                    near[y * w + x] = near[y * w + x].saturating_add(1);
                }
            }
        }
    }
    let inside = near
        .iter()
        .map(|&n| {
            if n as usize >= PIECES_PER_PARTICLE {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    match Frame::new(w, h, inside, 8) {
        Ok(mask) => RoiMask::from_frame(&mask),
        Err(e) => unreachable!("a mask of the binned frame's size is a frame: {e}"),
    }
}
