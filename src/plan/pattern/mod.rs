//! Target patterns: where particles should end up, as sites in stage metres.
//!
//! Sources: the built-in font ([`font`]), site lists ([`site_list`]),
//! bitmap images ([`bitmap`]) and SVG paths ([`svg_path`]); [`transform`] applies pitch, rotation and
//! placement (given, or optimised for push distance inside the reachable area).

pub mod bitmap;
pub mod font;
pub mod site_list;
pub mod svg_path;
pub mod transform;

use crate::plan::layout::um_text;
use crate::plan::value_sign::Sign;
use nalgebra::Vector2;

/// A target position for one particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Site {
    /// Identifier, dense from 0 in pattern order.
    pub id: u32,
    /// Centre in stage coordinates, metres.
    pub centre_m: Vector2<f64>,
}

/// Sites at `centres_m`, numbered from 0 in that order.
pub fn numbered_sites(centres_m: impl IntoIterator<Item = Vector2<f64>>) -> Vec<Site> {
    centres_m
        .into_iter()
        .enumerate()
        .map(|(i, centre_m)| Site {
            id: i as u32,
            centre_m,
        })
        .collect()
}

/// Site centres in micrometres, as files and the journal write them.
pub fn sites_um(sites: &[Site]) -> Vec<[f64; 2]> {
    sites
        .iter()
        .map(|s| [s.centre_m.x * 1e6, s.centre_m.y * 1e6])
        .collect()
}

/// A pattern before placement: site offsets in metres around the origin.
#[derive(Debug, Clone, PartialEq)]
pub struct Pattern {
    /// Site offsets (metres), centred on the bounding-box centre.
    pub offsets_m: Vec<Vector2<f64>>,
}

/// "pattern placed at (x, y) um leaves sites outside the reachable area
/// (its centre may lie from (..) to (..) um)", to one decimal, or up to
/// three where one would read an axis asked outside the range the same as
/// its nearer end ("placed at (57.5, ...) ... may lie from (57.5, ...)"
/// had refused 57.5 against 57.504).
fn outside_at_text(at_um: [f64; 2], lo_um: [f64; 2], hi_um: [f64; 2]) -> String {
    let apart = |d: usize| {
        (0..2).all(|i| {
            let end = if at_um[i] < lo_um[i] {
                lo_um[i]
            } else if at_um[i] > hi_um[i] {
                hi_um[i]
            } else {
                return true;
            };
            um_text(at_um[i], d) != um_text(end, d)
        })
    };
    let d = (1..3).find(|&d| apart(d)).unwrap_or(3);
    let pair = |p: [f64; 2]| format!("({}, {})", um_text(p[0], d), um_text(p[1], d));
    format!(
        "pattern placed at {} um leaves sites outside the reachable area \
         (its centre may lie from {} to {} um)",
        pair(at_um),
        pair(lo_um),
        pair(hi_um)
    )
}

/// Everything that can be wrong with a pattern.
#[derive(Debug, thiserror::Error)]
pub enum PatternError {
    /// A character the font does not have.
    #[error("unknown glyph {0:?} in --text (the font has A-Z, 0-9 and space)")]
    UnknownGlyph(char),
    /// A pattern with no site.
    #[error("empty pattern: {0}")]
    Empty(String),
    /// Two sites closer than a particle diameter.
    #[error(
        "sites {a} and {b} overlap: {} um apart, need at least {} um",
        um_text(*.distance_um, 3),
        um_text(*.needed_um, 3)
    )]
    OverlappingSites {
        /// First site index.
        a: usize,
        /// Second site index.
        b: usize,
        /// Their distance.
        distance_um: f64,
        /// Minimum distance (particle diameter).
        needed_um: f64,
    },
    /// A value is not finite or not positive where it must be.
    #[error("pattern: {what} is {value} (must be finite{extra})")]
    BadValue {
        /// Which value.
        what: String,
        /// The value.
        value: f64,
        /// Extra requirement.
        extra: &'static str,
    },
    /// The pattern does not fit the reachable area.
    #[error(
        "pattern of {} x {} um does not fit the reachable area of {} x {} um{}",
        um_text(*.w_um, 1),
        um_text(*.h_um, 1),
        um_text(*.aw_um, 1),
        um_text(*.ah_um, 1),
        if *.h_um <= *.aw_um && *.w_um <= *.ah_um {
            "; turned a quarter turn from this orientation it would (add 90 deg to the rotation)"
        } else {
            ""
        }
    )]
    DoesNotFit {
        /// Pattern width including particle radius.
        w_um: f64,
        /// Pattern height including particle radius.
        h_um: f64,
        /// Reachable width.
        aw_um: f64,
        /// Reachable height.
        ah_um: f64,
    },
    /// A placement point leaves part of the pattern outside the reachable area.
    #[error("{}", outside_at_text([*.x_um, *.y_um], *.lo_um, *.hi_um))]
    OutsideAtPlacement {
        /// Requested centre x.
        x_um: f64,
        /// Requested centre y.
        y_um: f64,
        /// Lowest centre that keeps every site inside, x and y.
        lo_um: [f64; 2],
        /// Highest centre that keeps every site inside, x and y.
        hi_um: [f64; 2],
    },
    /// A file could not be read or parsed.
    #[error("pattern file {path}: {message}")]
    File {
        /// Path of the file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// The interrupt flag was raised while centres were planned (Ctrl-C:
    /// a crowded field can take a minute to refuse them all).
    #[error(
        "interrupted ({}) while the pattern was placed",
        crate::rig::interrupt::CAUSE
    )]
    Interrupted,
}

/// Refuses a value that is NaN, infinite or of the wrong `sign`, naming it.
pub(crate) fn check_value(what: &str, value: f64, sign: Sign) -> Result<(), PatternError> {
    match sign.broken_by(value) {
        Some(extra) => Err(PatternError::BadValue {
            what: what.into(),
            value,
            extra,
        }),
        None => Ok(()),
    }
}

impl Pattern {
    /// Builds a pattern from offsets, recentring it on its bounding-box centre.
    pub fn from_offsets(
        mut offsets_m: Vec<Vector2<f64>>,
        what: &str,
    ) -> Result<Self, PatternError> {
        if offsets_m.is_empty() {
            return Err(PatternError::Empty(what.to_string()));
        }
        for (i, p) in offsets_m.iter().enumerate() {
            check_value(&format!("site {i} x"), p.x, Sign::Any)?;
            check_value(&format!("site {i} y"), p.y, Sign::Any)?;
        }
        let (lo, hi) = bbox(&offsets_m);
        let c = (lo + hi) / 2.0;
        offsets_m.iter_mut().for_each(|p| *p -= c);
        Ok(Pattern { offsets_m })
    }

    /// Pattern of `text` in the built-in font at `pitch_m` (rows go down the page = -y).
    pub fn from_text(text: &str, pitch_m: f64) -> Result<Self, PatternError> {
        check_value("pitch_um", pitch_m * 1e6, Sign::Positive)?;
        let cells = font::text_cells(text).map_err(PatternError::UnknownGlyph)?;
        let offsets = cells
            .iter()
            .map(|&(c, r)| Vector2::new(c as f64 * pitch_m, -(r as f64) * pitch_m))
            .collect();
        Self::from_offsets(offsets, &format!("text {text:?} has no site"))
    }

    /// Fails when two sites are closer than `min_distance_m` (a particle diameter).
    pub fn check_no_overlap(&self, min_distance_m: f64) -> Result<(), PatternError> {
        let grid = crate::plan::grid::Grid::new(self.offsets_m.iter().copied(), min_distance_m);
        for (i, p) in self.offsets_m.iter().enumerate() {
            for j in grid.within(*p, min_distance_m * (1.0 - 1e-9)) {
                if j > i {
                    return Err(PatternError::OverlappingSites {
                        a: i,
                        b: j,
                        distance_um: (self.offsets_m[j] - p).norm() * 1e6,
                        needed_um: min_distance_m * 1e6,
                    });
                }
            }
        }
        Ok(())
    }

    /// Width and height of the site centres' bounding box, metres.
    pub fn extent_m(&self) -> Vector2<f64> {
        let (lo, hi) = bbox(&self.offsets_m);
        hi - lo
    }
}

pub(crate) fn bbox(points: &[Vector2<f64>]) -> (Vector2<f64>, Vector2<f64>) {
    let first = points.first().copied().unwrap_or_else(Vector2::zeros);
    points
        .iter()
        .fold((first, first), |(lo, hi), p| (lo.inf(p), hi.sup(p)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A centre asked just outside the range reads apart from the range's
    /// end (57.5 against 57.504 had read "placed at (57.5, ..) ... from
    /// (57.5, ..)"); one well outside keeps one decimal.
    #[test]
    fn a_centre_just_outside_the_range_reads_apart_from_its_end() {
        let outside = |x_um| PatternError::OutsideAtPlacement {
            x_um,
            y_um: 54.125,
            lo_um: [57.504, 26.0],
            hi_um: [62.5, 74.0],
        };
        assert_eq!(
            outside(57.5).to_string(),
            "pattern placed at (57.500, 54.125) um leaves sites outside the reachable area \
             (its centre may lie from (57.504, 26.000) to (62.500, 74.000) um)"
        );
        assert_eq!(
            outside(57.45).to_string(),
            "pattern placed at (57.45, 54.12) um leaves sites outside the reachable area \
             (its centre may lie from (57.50, 26.00) to (62.50, 74.00) um)"
        );
        assert_eq!(
            outside(20.0).to_string(),
            "pattern placed at (20.0, 54.1) um leaves sites outside the reachable area \
             (its centre may lie from (57.5, 26.0) to (62.5, 74.0) um)"
        );
    }

    /// Sizes read as typed, and an absurd one in exponent form instead of
    /// three hundred digits.
    #[test]
    fn a_pattern_too_large_is_told_in_readable_numbers() {
        let err = PatternError::DoesNotFit {
            w_um: 2e300,
            h_um: 115.25,
            aw_um: 120.0,
            ah_um: 100.0,
        };
        assert_eq!(
            err.to_string(),
            "pattern of 2.000e300 x 115.2 um does not fit the reachable area of 120.0 x 100.0 um"
        );
    }

    /// A tall pattern in a wide field is told that turning it would fit.
    #[test]
    fn a_pattern_that_fits_turned_says_so() {
        let tall = PatternError::DoesNotFit {
            w_um: 52.0,
            h_um: 115.0,
            aw_um: 120.0,
            ah_um: 100.0,
        };
        assert!(tall.to_string().ends_with(
            "; turned a quarter turn from this orientation it would (add 90 deg to the rotation)"
        ));
        let long = PatternError::DoesNotFit {
            w_um: 451.0,
            h_um: 52.0,
            aw_um: 120.0,
            ah_um: 100.0,
        };
        assert!(long.to_string().ends_with("100.0 um"), "{long}");
    }
}
