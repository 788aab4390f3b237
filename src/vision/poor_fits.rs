//! Drops ring fits that are both far worse than the frame's typical fit and
//! overlapping another particle: in crowded frames a candidate between
//! three rings can fit a ring-like patch of their arcs (15 phantoms in 280
//! detections of 20-45 particle synthetic frames, none missed). A phantom's
//! centre uncertainty was 7.6-58x the frame's median; a real particle's at
//! most 2.4x. Spheres on a substrate cannot overlap, so a poor fit whose
//! disc overlaps a good one is the good one's neighbourhood seen twice.
//! An isolated poor fit (dirt, a deformed particle) is kept.

use super::detect::Detection;

/// A fit whose centre uncertainty is this many times the frame's median is
/// poor (phantoms measured 7.6x and more, real particles 2.4x at most).
const POOR_FIT_SIGMA_RATIO: f64 = 5.0;

/// Fewer fits than this give no typical uncertainty to compare with.
const MIN_FITS_FOR_MEDIAN: usize = 8;

/// Removes every poor fit whose disc (its fitted radius) overlaps the disc
/// of a fit that is not poor; returns how many were removed.
pub fn drop_poor_overlapping_fits(found: &mut Vec<Detection>) -> usize {
    if found.len() < MIN_FITS_FOR_MEDIAN {
        return 0;
    }
    let mut sigmas: Vec<f64> = found.iter().map(|d| d.sigma_px).collect();
    sigmas.sort_by(f64::total_cmp);
    let median = sigmas[sigmas.len() / 2];
    let poor = |d: &Detection| d.sigma_px > POOR_FIT_SIGMA_RATIO * median;
    let overlaps =
        |a: &Detection, b: &Detection| (a.x_px - b.x_px).hypot(a.y_px - b.y_px) < a.r_px + b.r_px;
    let drop: Vec<bool> = found
        .iter()
        .map(|d| poor(d) && found.iter().any(|o| !poor(o) && overlaps(d, o)))
        .collect();
    let before = found.len();
    let mut k = drop.iter();
    found.retain(|_| !*k.next().unwrap_or(&false));
    before - found.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(x_px: f64, sigma_px: f64) -> Detection {
        Detection {
            x_px,
            y_px: 0.0,
            r_px: 8.0,
            sigma_px,
            quality: 10.0,
            edge_clipped: false,
            fitted: true,
        }
    }

    #[test]
    fn a_poor_fit_is_dropped_only_where_it_overlaps_a_good_one() {
        // Nine good fits 20 px apart; a poor one 10 px from the first
        // (overlapping it) and a poor one far from all.
        let mut found: Vec<Detection> = (0..9).map(|i| ring(20.0 * i as f64, 0.02)).collect();
        found.push(ring(10.0, 0.3));
        found.push(ring(1000.0, 0.3));
        assert_eq!(drop_poor_overlapping_fits(&mut found), 1);
        assert_eq!(found.len(), 10);
        assert!(found.iter().all(|d| d.x_px != 10.0));
        // Touching good fits (discs meeting, not overlapping) all stay.
        let mut touching: Vec<Detection> = (0..9).map(|i| ring(16.0 * i as f64, 0.02)).collect();
        touching[3].sigma_px = 0.04;
        assert_eq!(drop_poor_overlapping_fits(&mut touching), 0);
    }

    #[test]
    fn too_few_fits_give_no_median_and_nothing_is_dropped() {
        let mut found = vec![ring(0.0, 0.02), ring(10.0, 0.5)];
        assert_eq!(drop_poor_overlapping_fits(&mut found), 0);
        assert_eq!(found.len(), 2);
    }
}
