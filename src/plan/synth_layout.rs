//! Synthetic particle layouts (seeded): uniform random sequential addition,
//! clustered, and adversarial (a dense hexagonal core in the middle of the
//! field, where patterns land, walling sites in, plus uniform filler).

use super::layout::{Layout, Particle, check_finite};
use super::occupancy::Occupancy;
use super::value_sign::Sign;
use nalgebra::Vector2;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Kind of synthetic layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LayoutKind {
    /// Uniform random positions with a minimum gap.
    Uniform,
    /// Gaussian clusters.
    Clustered,
    /// Dense hexagonal core in the field centre plus uniform filler.
    Adversarial,
}

/// Parameters of a synthetic layout (SI).
#[derive(Debug, Clone, PartialEq)]
pub struct SynthParams {
    /// Number of particles.
    pub n: usize,
    /// Field width, height (m).
    pub field_m: [f64; 2],
    /// Mean radius (m).
    pub radius_m: f64,
    /// Minimum free gap between particles (m).
    pub min_gap_m: f64,
    /// Radii drawn with 5 % spread instead of all equal.
    pub polydisperse: bool,
    /// Kind.
    pub kind: LayoutKind,
    /// Seed.
    pub seed: u64,
}

impl SynthParams {
    /// The CMU acceptance scene of issue 4: `n` particles of radius 5 um,
    /// at least 1 um apart, in a 120 x 100 um field.
    pub fn cmu_field(n: usize, kind: LayoutKind, seed: u64) -> Self {
        SynthParams {
            n,
            field_m: [120e-6, 100e-6],
            radius_m: 5e-6,
            min_gap_m: 1e-6,
            polydisperse: false,
            kind,
            seed,
        }
    }
}

/// Why a layout could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// Bad parameter.
    #[error(transparent)]
    Bad(#[from] super::layout::LayoutError),
    /// No particle asked for: a layout of none plans nothing.
    #[error("a layout needs at least one particle (n is 0)")]
    NoParticles,
    /// More particles than any packing holds.
    #[error(
        "{} of radius {r_um:.3} um at least {gap_um:.3} um apart cannot fit in {w_um:.1} x {h_um:.1} um: no packing holds more than {most} (ask for fewer particles, a larger field or a smaller gap)",
        crate::wording::counted(*n, "particle")
    )]
    BeyondPacking {
        /// Requested.
        n: usize,
        /// The most any packing holds.
        most: usize,
        /// Smallest radius drawn.
        r_um: f64,
        /// Gap.
        gap_um: f64,
        /// Width.
        w_um: f64,
        /// Height.
        h_um: f64,
    },
    /// Could not place all particles.
    #[error(
        "could place only {placed} of {} with gap {gap_um:.3} um in {w_um:.1} x {h_um:.1} um: too dense (ask for fewer particles, a larger field or a smaller gap)",
        crate::wording::counted(*n, "particle")
    )]
    TooDense {
        /// Placed.
        placed: usize,
        /// Requested.
        n: usize,
        /// Gap.
        gap_um: f64,
        /// Width.
        w_um: f64,
        /// Height.
        h_um: f64,
    },
}

/// The most particles with centres at least `spacing` apart that fit in a
/// `w` x `h` region of centres (Oler's inequality for points in a convex
/// region: N <= 2/sqrt(3) A / d^2 + P / (2 d) + 1). Above it a request is
/// impossible, not just unlucky, and is refused before any try.
fn most_that_fit(w: f64, h: f64, spacing: f64) -> f64 {
    if w < 0.0 || h < 0.0 {
        return 0.0;
    }
    2.0 / 3f64.sqrt() * w * h / spacing.powi(2) + (w + h) / spacing + 1.0
}

/// Relative margin on the adversarial core's pitch. Its neighbours sit at
/// exactly the minimum gap, so without it the last bit of rounding in the
/// inputs (`5.0 * 1e-6` from the CLI against a literal `5e-6`) decided
/// whether every other core particle was rejected as too close.
const CORE_PITCH_MARGIN: f64 = 1e-9;

/// Generates a layout.
pub fn synth_layout(p: &SynthParams) -> Result<Layout, SynthError> {
    check_finite("field width_um", p.field_m[0] * 1e6, Sign::Positive)?;
    check_finite("field height_um", p.field_m[1] * 1e6, Sign::Positive)?;
    check_finite("radius_um", p.radius_m * 1e6, Sign::Positive)?;
    check_finite("min_gap_um", p.min_gap_m * 1e6, Sign::NonNegative)?;
    if p.n == 0 {
        return Err(SynthError::NoParticles);
    }
    let [w, h] = p.field_m;
    let rmin = p.radius_m * if p.polydisperse { 0.85 } else { 1.0 };
    let most = most_that_fit(w - 2.0 * rmin, h - 2.0 * rmin, 2.0 * rmin + p.min_gap_m);
    if p.n as f64 > most {
        return Err(SynthError::BeyondPacking {
            n: p.n,
            most: most as usize,
            r_um: rmin * 1e6,
            gap_um: p.min_gap_m * 1e6,
            w_um: w * 1e6,
            h_um: h * 1e6,
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(p.seed);
    let spread = Normal::new(1.0, 0.05).expect("valid normal");
    let rmax = p.radius_m * if p.polydisperse { 1.15 } else { 1.0 };
    // Buckets of the cells in use only: a field of a metre has 10^10 cells.
    let mut placed = Occupancy::empty(2.0 * rmax + p.min_gap_m);
    let try_add = |c: Vector2<f64>, r: f64, placed: &mut Occupancy| {
        let inside = c.x >= r && c.y >= r && c.x <= w - r && c.y <= h - r;
        if inside && placed.disc_free(c, r, None, p.min_gap_m) {
            placed.push(c, r);
        }
    };
    let radius = |rng: &mut ChaCha8Rng| {
        if p.polydisperse {
            p.radius_m * Distribution::<f64>::sample(&spread, rng).clamp(0.85, 1.15)
        } else {
            p.radius_m
        }
    };
    if p.kind == LayoutKind::Adversarial {
        // Dense hexagonal core over the central third of the field.
        let pitch = (2.0 * rmax + p.min_gap_m) * (1.0 + CORE_PITCH_MARGIN);
        let (cx, cy) = (w / 2.0, h / 2.0);
        let (hw, hh) = (w / 3.0, h / 3.0);
        let mut row = 0;
        let mut y = cy - hh;
        while y <= cy + hh && placed.pos.len() < p.n.saturating_mul(2) / 3 {
            let x0 = cx - hw + if row % 2 == 1 { pitch / 2.0 } else { 0.0 };
            let mut x = x0;
            let mut column = 0;
            while x <= cx + hw && placed.pos.len() < p.n.saturating_mul(2) / 3 {
                let r = radius(&mut rng);
                try_add(Vector2::new(x, y), r, &mut placed);
                column += 1;
                x = x0 + column as f64 * pitch;
            }
            row += 1;
            y = cy - hh + row as f64 * pitch * 3f64.sqrt() / 2.0;
        }
    }
    let centres: Vec<Vector2<f64>> = (0..4)
        .map(|_| Vector2::new(rng.random::<f64>() * w, rng.random::<f64>() * h))
        .collect();
    let cluster = Normal::new(0.0, w.min(h) / 8.0).expect("valid normal");
    let max_tries = p.n.max(1).saturating_mul(2_000).saturating_add(100_000);
    let mut tries = 0;
    while placed.pos.len() < p.n && tries < max_tries {
        tries += 1;
        let r = radius(&mut rng);
        let c = match p.kind {
            LayoutKind::Clustered if tries < max_tries / 2 => {
                let k = centres[rng.random_range(0..centres.len())];
                k + Vector2::new(cluster.sample(&mut rng), cluster.sample(&mut rng))
            }
            _ => Vector2::new(
                r + rng.random::<f64>() * (w - 2.0 * r),
                r + rng.random::<f64>() * (h - 2.0 * r),
            ),
        };
        try_add(c, r, &mut placed);
    }
    if placed.pos.len() < p.n {
        return Err(SynthError::TooDense {
            placed: placed.pos.len(),
            n: p.n,
            gap_um: p.min_gap_m * 1e6,
            w_um: w * 1e6,
            h_um: h * 1e6,
        });
    }
    let layout = Layout {
        field_m: p.field_m,
        particles: placed
            .pos
            .iter()
            .zip(&placed.radius)
            .enumerate()
            .map(|(i, (&c, &r))| Particle {
                id: i as u32,
                centre_m: c,
                radius_m: r,
            })
            .collect(),
    };
    layout.validate()?;
    Ok(layout)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A negative gap is named with its value (every one read "-1"); no gap
    /// at all is a layout of touching-allowed particles.
    #[test]
    fn a_negative_gap_is_refused_with_its_value_and_none_is_taken() {
        let with_gap = |g: f64| {
            synth_layout(&SynthParams {
                min_gap_m: g,
                ..SynthParams::cmu_field(10, LayoutKind::Uniform, 1)
            })
        };
        let e = with_gap(-5e-6).unwrap_err().to_string();
        assert!(e.contains("min_gap_um is -5 ") && e.contains(">= 0"), "{e}");
        assert!(with_gap(0.0).is_ok());
    }

    #[test]
    fn layouts_are_seeded_and_keep_the_gap() {
        for kind in [
            LayoutKind::Uniform,
            LayoutKind::Clustered,
            LayoutKind::Adversarial,
        ] {
            let p = SynthParams::cmu_field(50, kind, 3);
            let a = synth_layout(&p).unwrap();
            assert_eq!(a, synth_layout(&p).unwrap());
            assert_eq!(a.particles.len(), 50);
            for (i, x) in a.particles.iter().enumerate() {
                for y in &a.particles[i + 1..] {
                    assert!((x.centre_m - y.centre_m).norm() >= 11e-6 - 1e-12);
                }
            }
        }
    }

    /// A count no packing holds is refused at once with the most that fits
    /// (113 in the CMU field: 10 um discs 1 um apart); one that packings
    /// hold but random addition does not reach is refused after the tries.
    /// A hexagonal lattice over the whole CMU field holds 105, under the
    /// bound.
    #[test]
    fn too_many_particles_are_refused_and_the_impossible_at_once() {
        let impossible = SynthParams::cmu_field(100_000_000, LayoutKind::Uniform, 1);
        match synth_layout(&impossible) {
            Err(SynthError::BeyondPacking { most, .. }) => assert_eq!(most, 113),
            other => panic!("{other:?}"),
        }
        let over_the_bound = SynthParams::cmu_field(114, LayoutKind::Adversarial, 1);
        assert!(matches!(
            synth_layout(&over_the_bound),
            Err(SynthError::BeyondPacking { .. })
        ));
        let unlucky = SynthParams::cmu_field(100, LayoutKind::Uniform, 1);
        assert!(matches!(
            synth_layout(&unlucky),
            Err(SynthError::TooDense { .. })
        ));
        // A dense hexagonal lattice over the whole field stays under the bound.
        let pitch = 11e-6;
        let rows = ((90e-6 / (pitch * 3f64.sqrt() / 2.0)) as usize) + 1;
        let lattice = (0..rows)
            .map(|row| {
                ((110e-6 - if row % 2 == 1 { pitch / 2.0 } else { 0.0 }) / pitch) as usize + 1
            })
            .sum::<usize>();
        assert_eq!(lattice, 105);
        assert!(lattice as f64 <= most_that_fit(110e-6, 90e-6, pitch));
    }

    /// A field a metre wide (10^10 cells of a particle's size) is laid out
    /// without allocating a cell for each.
    #[test]
    fn a_huge_field_is_laid_out_without_a_cell_for_every_spot() {
        let p = SynthParams {
            field_m: [1.0, 1.0],
            ..SynthParams::cmu_field(5, LayoutKind::Adversarial, 2)
        };
        assert_eq!(synth_layout(&p).unwrap().particles.len(), 5);
    }

    /// The core is the same dense lattice whether the radius and gap come
    /// as literals or as the CLI's products of um and 1e-6 (they differ in
    /// the last bit; every other core particle used to be dropped).
    #[test]
    fn the_adversarial_core_is_dense_whatever_the_rounding_of_the_inputs() {
        let literal = SynthParams::cmu_field(40, LayoutKind::Adversarial, 0);
        let from_cli = SynthParams {
            radius_m: 5.0 * 1e-6,
            min_gap_m: 1.0 * 1e-6,
            ..literal.clone()
        };
        assert_ne!(literal.radius_m, from_cli.radius_m, "the inputs differ");
        for p in [literal, from_cli] {
            let a = synth_layout(&p).unwrap();
            // The core is the first 2n/3 particles: each has a neighbour at
            // the lattice pitch, 2 r + gap.
            let core = &a.particles[..p.n * 2 / 3];
            let pitch = 2.0 * p.radius_m + p.min_gap_m;
            for x in core {
                let nearest = core
                    .iter()
                    .filter(|y| y.id != x.id)
                    .map(|y| (x.centre_m - y.centre_m).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    (nearest - pitch).abs() < 1e-12,
                    "particle {} has its nearest core neighbour at {nearest}",
                    x.id
                );
            }
        }
    }
}
