//! Whether a frame shows the stage's reading a constant factor off where
//! the camera sees the probe, on both axes: the rig file's `unit_um` is not
//! the controller's unit (1000, mm, for a controller counting in um), and
//! the stage moves that factor more or less than it is asked. The apex
//! check had blamed the calibration ("make it again"), which fits.

use super::apex_doubt::apex_beyond_doubt_m;
use crate::exec::observe::Sighting;

/// Smallest factor (or its inverse) taken for a wrong unit: a calibration
/// of another camera is off by tens of percent, a unit by 10 or more.
const UNIT_FACTOR_MIN: f64 = 3.0;
/// Most the two axes' factors may differ by (ratio): one unit scales both.
const AXES_AGREE: f64 = 1.1;
/// Nearest the camera may see the probe to the stage's zero on an axis for
/// that axis's factor to be told, metres (the stage's own reading may be
/// far nearer: 0.05 um for 50 um read in nm as um).
const FROM_ZERO_MIN_M: f64 = 1e-6;

/// Why `sighting` says the stage's unit is wrong: the apex past
/// [`CALIBRATION_DOUBT_M`](super::CALIBRATION_DOUBT_M) from where the
/// stage has it, and the camera's position of the nanostage the same
/// factor (at least [`UNIT_FACTOR_MIN`], or its inverse) of the stage's
/// reading on both axes, as if every move from the stage's zero had gone
/// that factor of what was asked.
pub(super) fn stage_unit_doubt(sighting: &Sighting) -> Option<String> {
    apex_beyond_doubt_m(sighting)?;
    let (tip, stage) = (sighting.tip_m?, sighting.stage_m?);
    let seen = [0, 1].map(|k| tip[k] - sighting.coarse_offset_m[k]);
    if (0..2).any(|k| seen[k].abs() < FROM_ZERO_MIN_M) {
        return None;
    }
    let moved = [0, 1].map(|k| seen[k] / stage[k]);
    let (lo, hi) = (moved[0].min(moved[1]), moved[0].max(moved[1]));
    if !(lo > 0.0 && hi.is_finite()) || hi / lo > AXES_AGREE {
        return None;
    }
    let n = (lo * hi).sqrt();
    let times = if n >= UNIT_FACTOR_MIN {
        format!("{n:.0} times")
    } else if n <= 1.0 / UNIT_FACTOR_MIN {
        format!("1/{:.0} of", 1.0 / n)
    } else {
        return None;
    };
    let (too, fix, by) = if n > 1.0 {
        ("small", "multiply", n)
    } else {
        ("large", "divide", 1.0 / n)
    };
    Some(format!(
        "the camera sees the probe's apex at ({:.2}, {:.2}) um where the stage has it at ({:.2}, {:.2}) um: \
         the stage moved {times} what it was asked (x {:.4}, y {:.4} of its readings), as a wrong unit makes it: \
         the rig file's stage unit_um (micrometres per controller unit: 1 for a controller counting in um, \
         1000 in mm) looks {by:.0} times too {too}: {fix} it by {by:.0}, then resume",
        tip[0] * 1e6,
        tip[1] * 1e6,
        (stage[0] + sighting.coarse_offset_m[0]) * 1e6,
        (stage[1] + sighting.coarse_offset_m[1]) * 1e6,
        moved[0],
        moved[1],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::assemble::apex_doubt::tests::sighting;

    /// A stage read 1000 times where the camera sees it (unit_um = 1000 for
    /// a controller in um), or 1/1000, is named by its factor and the unit;
    /// another camera's map (turned, or 2x off in scale) and a stage near
    /// its zero are not.
    #[test]
    fn a_stage_read_a_constant_factor_off_names_its_unit() {
        let why = stage_unit_doubt(&sighting([50.02, 49.98], [50_000.0, 50_000.0])).unwrap();
        assert!(
            why.contains("the stage moved 1/1000 of what it was asked"),
            "{why}"
        );
        assert!(
            why.contains("unit_um") && why.contains("1000 times too large"),
            "{why}"
        );
        assert!(why.contains("divide it by 1000"), "{why}");
        assert!(!why.contains("calibration"), "{why}");
        // The first look's check (rig probe --camera, the dry-run) says the same.
        let first_look =
            super::super::calibration_doubt(&sighting([50.02, 49.98], [50_000.0, 50_000.0]));
        assert_eq!(first_look.as_deref(), Some(why.as_str()));
        let why = stage_unit_doubt(&sighting([50.0, 40.0], [0.05, 0.04])).unwrap();
        assert!(
            why.contains("the stage moved 1000 times what it was asked"),
            "{why}"
        );
        assert!(why.contains("multiply it by 1000"), "{why}");
        for (tip, stage) in [
            ([40.0, 60.0], [50.0, 50.0]),
            ([100.0, 100.0], [50.0, 50.0]),
            ([-50.0, -50.0], [50_000.0, 50_000.0]),
            ([50.0, 5.0], [50_000.0, 50_000.0]),
            ([50.0, 0.5], [50_000.0, 0.0]),
            ([50.0, 50.0], [50.5, 50.5]),
        ] {
            assert_eq!(
                stage_unit_doubt(&sighting(tip, stage)),
                None,
                "{tip:?} {stage:?}"
            );
        }
    }
}
