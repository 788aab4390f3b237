//! One-to-one matching of detections to reference points (truth, trackpy),
//! nearest pairs first, for recall/precision and error statistics.

/// Result of matching found points to reference points.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchReport {
    /// (reference index, found index, dx = found - reference, dy).
    pub pairs: Vec<(usize, usize, f64, f64)>,
    /// Reference points count.
    pub n_reference: usize,
    /// Found points count.
    pub n_found: usize,
}

impl MatchReport {
    /// Fraction of reference points matched (1 when there are none).
    pub fn recall(&self) -> f64 {
        if self.n_reference == 0 {
            1.0
        } else {
            self.pairs.len() as f64 / self.n_reference as f64
        }
    }
    /// Fraction of found points matched (1 when none were found).
    pub fn precision(&self) -> f64 {
        if self.n_found == 0 {
            1.0
        } else {
            self.pairs.len() as f64 / self.n_found as f64
        }
    }
    /// Per-axis RMS of the matched offsets (0 when nothing matched).
    pub fn rms_per_axis(&self) -> f64 {
        if self.pairs.is_empty() {
            return 0.0;
        }
        let ss: f64 = self.pairs.iter().map(|p| p.2 * p.2 + p.3 * p.3).sum();
        (ss / (2.0 * self.pairs.len() as f64)).sqrt()
    }
}

/// Greedy nearest-first one-to-one matching within `max_dist`.
pub fn match_points(reference: &[[f64; 2]], found: &[[f64; 2]], max_dist: f64) -> MatchReport {
    let mut cand: Vec<(f64, usize, usize)> = Vec::new();
    for (i, r) in reference.iter().enumerate() {
        for (j, f) in found.iter().enumerate() {
            let d2 = (f[0] - r[0]).powi(2) + (f[1] - r[1]).powi(2);
            if d2 <= max_dist * max_dist {
                cand.push((d2, i, j));
            }
        }
    }
    cand.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut used_r = vec![false; reference.len()];
    let mut used_f = vec![false; found.len()];
    let mut pairs = Vec::new();
    for (_, i, j) in cand {
        if !used_r[i] && !used_f[j] {
            used_r[i] = true;
            used_f[j] = true;
            pairs.push((
                i,
                j,
                found[j][0] - reference[i][0],
                found[j][1] - reference[i][1],
            ));
        }
    }
    MatchReport {
        pairs,
        n_reference: reference.len(),
        n_found: found.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_nearest_first_one_to_one() {
        let r = [[0.0, 0.0], [10.0, 0.0]];
        let f = [[0.5, 0.0], [0.2, 0.0], [30.0, 0.0]];
        let m = match_points(&r, &f, 2.0);
        assert_eq!(m.pairs.len(), 1);
        assert_eq!(m.pairs[0].1, 1);
        assert_eq!(m.recall(), 0.5);
        assert!((m.precision() - 1.0 / 3.0).abs() < 1e-12);
    }
}
