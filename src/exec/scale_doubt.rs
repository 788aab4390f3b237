//! Whether the particles the loop takes measure the scene's size. The loop
//! takes a whole detection for a particle only within 30 % of the scene's
//! radius; with the radius or the calibration's scale a fifth off, the
//! particles measured beyond that are left out of every plan, which then
//! pushes others through them, and nothing else says so.

use crate::median::upper_median;

/// Relative difference between the particles' median measured radius and
/// the scene's beyond which the loop says so: a batch spread by 5 % keeps
/// its median within a few per cent of its nominal size, and a ring's
/// fitted radius is within 2 % of the truth on synthetic frames.
pub const SCALE_DOUBT_FRACTION: f64 = 0.08;

/// Fewest particles measured for their median to be evidence.
const FEWEST_MEASURED: usize = 5;

/// A median radius too far from the scene's, as said to the user.
#[derive(Debug, Clone, PartialEq)]
pub struct ScaleDoubt {
    /// The particles taken, their median radius, metres.
    pub median_radius_m: f64,
    /// How many were measured.
    pub measured: usize,
    /// The median over the scene's radius, less one (0.25: a quarter larger).
    pub off_fraction: f64,
}

impl ScaleDoubt {
    /// The doubt about `taken_radii_m` (the particles taken, metres) against
    /// `expected_radius_m`, if their median is more than
    /// [`SCALE_DOUBT_FRACTION`] off it.
    pub fn of(taken_radii_m: &[f64], expected_radius_m: f64) -> Option<Self> {
        if taken_radii_m.len() < FEWEST_MEASURED {
            return None;
        }
        let median_radius_m = upper_median(&mut taken_radii_m.to_vec())?;
        let off_fraction = median_radius_m / expected_radius_m - 1.0;
        (off_fraction.abs() > SCALE_DOUBT_FRACTION).then_some(Self {
            median_radius_m,
            measured: taken_radii_m.len(),
            off_fraction,
        })
    }

    /// Coarse enough that a median wobbling between frames is said once
    /// (steps of 5 %).
    pub fn said_as(&self) -> String {
        format!("{:+.0}", self.off_fraction * 20.0)
    }

    /// The warning, with `left_out` (whole detections too far off the
    /// scene's size in this frame) and what to check.
    pub fn message(&self, expected_radius_m: f64, left_out: usize, check: &str) -> String {
        let side = if self.off_fraction > 0.0 {
            "larger"
        } else {
            "smaller"
        };
        format!(
            "the particles found measure {:.2} um in radius (median of {}), {:.0} % {side} than the scene's {:.2} um: {check} \
             A particle more than 30 % off the scene's radius is in no plan ({left_out} in this frame).",
            self.median_radius_m * 1e6,
            self.measured,
            self.off_fraction.abs() * 100.0,
            expected_radius_m * 1e6
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_median_off_the_scenes_radius_by_more_than_the_fraction_is_doubted() {
        let around =
            |r: f64| -> Vec<f64> { (0..9).map(|i| r * (0.97 + 0.0075 * i as f64)).collect() };
        // The real bright-field frames measure 4.8 um in a 5 um scene: taken.
        assert_eq!(ScaleDoubt::of(&around(4.8e-6), 5e-6), None);
        let small_scene = ScaleDoubt::of(&around(5e-6), 4e-6).expect("5 um for 4 um");
        assert!((small_scene.off_fraction - 0.25).abs() < 0.01);
        let text = small_scene.message(4e-6, 3, "check it.");
        assert!(
            text.contains(
                "5.00 um in radius (median of 9), 25 % larger than the scene's 4.00 um: check it."
            ) && text.contains("(3 in this frame)"),
            "{text}"
        );
        let scale = ScaleDoubt::of(&around(5e-6), 5.5e-6).expect("a 10 % scale error");
        assert!(scale.message(5.5e-6, 0, "").contains("9 % smaller"));
        assert_eq!(
            ScaleDoubt::of(&around(5e-6)[..4], 4e-6),
            None,
            "too few to say"
        );
        assert_ne!(small_scene.said_as(), scale.said_as());
    }
}
