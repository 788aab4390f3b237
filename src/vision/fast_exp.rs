//! exp on f32 that the compiler can vectorise: range reduction to
//! x = k ln2 + r, |r| <= ln2 / 2, a degree-7 polynomial for exp(r) (Cephes
//! `expf` coefficients) and 2^k built from the exponent bits. No branches and
//! no libm call, so a loop over a particle's fit window runs 4 (SSE2) or more
//! lanes at a time; libm's `exp` was a third of the profile fit's time.
//! Hand-written because the few SIMD-math crates either need nightly or a
//! target feature the crate's baseline build does not assume.
//!
//! Accuracy: relative error below 3e-7 (about 2.5 ulp) on [-87, 88]; inputs
//! below -87 give a tiny positive number (~1.6e-38) instead of underflowing, above 88
//! they saturate near f32::MAX (never inf); NaN stays NaN-free (it is clamped).

const LOG2_E: f32 = std::f32::consts::LOG2_E;
/// ln 2 split in two so k * LN2_HI is exact for the k that occur.
const LN2_HI: f32 = 0.693_359_4;
const LN2_LO: f32 = -2.121_944_4e-4;
/// 1.5 * 2^23: adding it rounds a float of magnitude < 2^22 to an integer
/// that sits in the low mantissa bits.
const ROUND_MAGIC: f32 = 12_582_912.0;

/// e^x in f32, branch-free (see the module doc for accuracy and clamping).
#[inline(always)]
pub fn exp_f32(x: f32) -> f32 {
    // Written as comparisons (not f32::clamp) so NaN maps to the lower bound.
    let x = if x > -87.0 { x } else { -87.0 };
    let x = if x < 88.0 { x } else { 88.0 };
    let shifted = x * LOG2_E + ROUND_MAGIC;
    let k = shifted - ROUND_MAGIC;
    let k_int = shifted.to_bits().wrapping_sub(ROUND_MAGIC.to_bits()) as i32;
    let r = x - k * LN2_HI - k * LN2_LO;
    let p = 1.987_569_1e-4_f32;
    let p = p * r + 1.398_199_9e-3;
    let p = p * r + 8.333_452e-3;
    let p = p * r + 4.166_579_6e-2;
    let p = p * r + 0.166_666_65;
    let p = p * r + 0.5;
    let er = p * r * r + r + 1.0;
    // 2^k: k + 127 in the exponent field (k in [-126, 127] after the clamp).
    let scale = f32::from_bits(((k_int + 127) as u32) << 23);
    er * scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_std_exp_to_3e_7_relative_over_the_whole_range() {
        let mut worst = 0.0f64;
        let n = 200_000;
        for i in 0..=n {
            let x = -87.0 + 175.0 * i as f64 / n as f64;
            let want = (x as f32 as f64).exp();
            let got = exp_f32(x as f32) as f64;
            worst = worst.max((got / want - 1.0).abs());
        }
        assert!(worst < 3e-7, "worst relative error {worst:e}");
    }

    #[test]
    fn clamps_out_of_range_and_nan_to_finite_values() {
        assert!(exp_f32(-1000.0) > 0.0 && exp_f32(-1000.0) < 1e-37);
        assert!(exp_f32(1000.0).is_finite() && exp_f32(1000.0) > 1e38);
        assert!(exp_f32(f32::NAN).is_finite());
        assert_eq!(exp_f32(0.0), 1.0);
    }
}
