//! Plausible ranges of a scene's values, in the unit each key states: one
//! table, one check. A value orders of magnitude outside its range is a unit
//! slip (Young's modulus in Pa under `youngs_modulus_gpa`, a length in metres
//! under `length_um`), which had given a cantilever ramp of 3.9e16 N/m
//! without a word; the scene refuses it naming the key, the value, the range
//! and the unit the value looks like it was written in.
//!
//! The ranges are generous on purpose: they bound what an AFM push could
//! meet at all (a soft gel to diamond, a nanocluster to a millimetre bead),
//! not what is usual, so only slips of orders of magnitude are refused.

use super::error::ModelError;

/// The plausible range of one or more scene keys that share a quantity.
pub(super) struct Plausible {
    /// Last segments of the dotted keys the row covers (`youngs_modulus_gpa`).
    pub keys: &'static [&'static str],
    /// The keys' unit as messages write it; empty for a plain ratio.
    pub unit: &'static str,
    /// Smallest plausible value (of the magnitude, for a signed key).
    pub lo: f64,
    /// Largest plausible value.
    pub hi: f64,
    /// Whether exactly zero is allowed below `lo` (the effect switched off).
    pub zero_is_off: bool,
    /// Why these bounds, said in the refusal.
    pub why: &'static str,
    /// Units a slip would have written the value in, each with its size in
    /// `unit` (Pa is 1e-9 GPa).
    pub slips: &'static [(&'static str, f64)],
}

const LENGTH_SLIPS_UM: &[(&str, f64)] = &[("m", 1e6), ("mm", 1e3), ("nm", 1e-3)];
const LENGTH_SLIPS_NM: &[(&str, f64)] = &[("m", 1e9), ("mm", 1e6), ("um", 1e3)];
const TIME_SLIPS_MIN: &[(&str, f64)] = &[("s", 1.0 / 60.0), ("ms", 1.0 / 60e3), ("h", 60.0)];

/// Every dimensional scene key's plausible range. Angles, Poisson ratios,
/// friction coefficients, humidity and the motion ratios keep their own
/// (tighter, physical) bounds in `scene.rs`.
pub(super) const PLAUSIBLE: &[Plausible] = &[
    Plausible {
        keys: &["youngs_modulus_gpa", "reduced_modulus_gpa"],
        unit: "GPa",
        lo: 1e-5,
        hi: 2e3,
        zero_is_off: false,
        why: "a soft gel (10 kPa) to diamond (1.2 TPa)",
        slips: &[("Pa", 1e-9), ("kPa", 1e-6), ("MPa", 1e-3)],
    },
    Plausible {
        keys: &["length_um"],
        unit: "um",
        lo: 1.0,
        hi: 1e4,
        zero_is_off: false,
        why: "a 1 um nanolever to a 1 cm macro lever",
        slips: LENGTH_SLIPS_UM,
    },
    Plausible {
        keys: &["width_um", "tip_height_um"],
        unit: "um",
        lo: 0.1,
        hi: 1e4,
        zero_is_off: false,
        why: "a 100 nm nanowire lever or tip stub to 1 cm",
        slips: LENGTH_SLIPS_UM,
    },
    Plausible {
        keys: &["thickness_um"],
        unit: "um",
        lo: 0.01,
        hi: 1e3,
        zero_is_off: false,
        why: "a 10 nm membrane lever to a 1 mm beam",
        slips: LENGTH_SLIPS_UM,
    },
    Plausible {
        keys: &["tip_radius_nm"],
        unit: "nm",
        lo: 0.1,
        hi: 1e5,
        zero_is_off: false,
        why: "an atomically sharp apex to a 100 um colloidal-probe sphere",
        slips: LENGTH_SLIPS_NM,
    },
    Plausible {
        keys: &["radius_um"],
        unit: "um",
        lo: 1e-3,
        hi: 1e3,
        zero_is_off: false,
        why: "a 1 nm cluster to a 1 mm bead",
        slips: LENGTH_SLIPS_UM,
    },
    Plausible {
        keys: &["distance_um"],
        unit: "um",
        lo: 2e-3,
        hi: 1e5,
        zero_is_off: false,
        why: "two touching 1 nm clusters to 10 cm, beyond any stage's travel",
        slips: LENGTH_SLIPS_UM,
    },
    Plausible {
        keys: &["work_of_adhesion_j_m2"],
        unit: "J/m^2",
        lo: 1e-6,
        hi: 10.0,
        zero_is_off: true,
        why: "screened dispersion forces in liquid (1 uJ/m^2) to metallic bonding (10 J/m^2); 0: no adhesion",
        slips: &[("mJ/m^2", 1e-3)],
    },
    Plausible {
        keys: &["equilibrium_separation_nm"],
        unit: "nm",
        lo: 0.01,
        hi: 10.0,
        zero_is_off: false,
        why: "a tenth of a bond length to the range of the longest surface forces",
        slips: LENGTH_SLIPS_NM,
    },
    Plausible {
        keys: &["shear_strength_mpa"],
        unit: "MPa",
        lo: 1e-3,
        hi: 1e5,
        zero_is_off: true,
        why: "a lubricated polymer (1 kPa) to diamond's ideal strength (100 GPa); 0: none",
        slips: &[("Pa", 1e-6), ("kPa", 1e-3), ("GPa", 1e3)],
    },
    Plausible {
        keys: &["rolling_friction_nm"],
        unit: "nm",
        lo: 1e-3,
        hi: 1e5,
        zero_is_off: true,
        why: "a thousandth of a nm to 100 um, a large particle's own size; 0: none",
        slips: LENGTH_SLIPS_NM,
    },
    Plausible {
        keys: &["rolling_shear_pa_m"],
        unit: "Pa m",
        lo: 1e-3,
        hi: 1e5,
        zero_is_off: true,
        why: "a thousandth of a surface tension's order (1 mN/m) to 1000x the paper scene's 98.5; 0: none",
        slips: &[("mN/m", 1e-3), ("N/mm", 1e3)],
    },
    Plausible {
        keys: &["session_time_min"],
        unit: "min",
        lo: 0.0,
        hi: 1e5,
        zero_is_off: true,
        why: "the start of a session to ten weeks into it",
        slips: TIME_SLIPS_MIN,
    },
    Plausible {
        keys: &["charge_time_constant_min"],
        unit: "min",
        lo: 0.01,
        hi: 1e5,
        zero_is_off: false,
        why: "a charge-up within a second to one over ten weeks",
        slips: TIME_SLIPS_MIN,
    },
    Plausible {
        keys: &["charge_adhesion_gain"],
        unit: "",
        lo: 0.0,
        hi: 100.0,
        zero_is_off: true,
        why: "no charging to a tip adhesion 100x its own (sticking probes are ~10x)",
        slips: &[("%", 0.01)],
    },
    Plausible {
        keys: &["drift_nm_s"],
        unit: "nm/s",
        lo: 0.0,
        hi: 1e3,
        zero_is_off: true,
        why: "thermal drift and piezo creep are 0.01-10 nm/s; 1 um/s is a stage moving, not drifting",
        slips: &[("pm/s", 1e-3)],
    },
    Plausible {
        keys: &["speed_um_s"],
        unit: "um/s",
        lo: 1e-4,
        hi: 1e4,
        zero_is_off: false,
        why: "0.1 nm/s, creep-slow, to 1 cm/s, beyond any piezo stage",
        slips: &[("m/s", 1e6), ("mm/s", 1e3), ("nm/s", 1e-3)],
    },
    Plausible {
        keys: &["duration_s"],
        unit: "s",
        lo: 1e-4,
        hi: 1e6,
        zero_is_off: false,
        why: "0.1 ms to eleven days",
        slips: &[("ms", 1e-3), ("us", 1e-6)],
    },
];

/// The row of `field` (a dotted path; its last segment is looked up).
fn row(field: &str) -> Option<&'static Plausible> {
    let leaf = field.rsplit('.').next().unwrap_or(field);
    PLAUSIBLE.iter().find(|p| p.keys.contains(&leaf))
}

/// A number as messages write it: plain when short, else in e-notation.
fn number(v: f64) -> String {
    if v == 0.0 || (1e-3..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

impl Plausible {
    fn contains(&self, v: f64) -> bool {
        let m = v.abs();
        (self.zero_is_off && m == 0.0) || (self.lo..=self.hi).contains(&m)
    }

    /// `v` with the unit, as messages write it.
    fn with_unit(&self, v: f64) -> String {
        if self.unit.is_empty() {
            number(v)
        } else {
            format!("{} {}", number(v), self.unit)
        }
    }

    /// The slip that brings `v` into range, nearest the range's middle
    /// (in orders of magnitude) when several do.
    fn slip(&self, v: f64) -> Option<&'static str> {
        let middle = (self.lo.max(self.hi * 1e-12) * self.hi).sqrt().log10();
        self.slips
            .iter()
            .filter(|(_, size)| self.contains(v * size))
            .min_by(|a, b| {
                let off = |size: f64| ((v * size).abs().log10() - middle).abs();
                off(a.1).total_cmp(&off(b.1))
            })
            .map(|(name, _)| *name)
    }
}

/// `v` (finite, its sign already checked) if it is plausible for `field`'s
/// quantity in its unit, else the refusal naming the key, the value, the
/// range, why, and the likely slip.
pub(crate) fn plausible(v: f64, field: &str) -> Result<f64, ModelError> {
    let Some(p) = row(field) else {
        return Err(ModelError::scene(
            field,
            "has no plausible range (a bug: add it to model::plausible::PLAUSIBLE)",
        ));
    };
    if p.contains(v) {
        return Ok(v);
    }
    let range = format!(
        "{}..{}{}",
        number(p.lo),
        number(p.hi),
        if p.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", p.unit)
        }
    );
    let slip = match p.slip(v) {
        Some(s) if p.unit.is_empty() => format!("; looks like {s}: the key is a plain ratio"),
        Some(s) => format!("; looks like {s}: the key is in {}", p.unit),
        None => String::new(),
    };
    Err(ModelError::scene(
        field,
        format!(
            "{} is implausible: the plausible range is {range} ({}){slip}",
            p.with_unit(v),
            p.why
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each row is a real range, its slips lead out of it, and no key is in
    /// two rows.
    #[test]
    fn every_row_is_a_range_and_each_key_has_one() {
        let mut keys: Vec<&str> = PLAUSIBLE
            .iter()
            .flat_map(|p| p.keys.iter().copied())
            .collect();
        let n = keys.len();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), n, "a key is in two rows");
        for p in PLAUSIBLE {
            assert!(
                p.lo >= 0.0 && p.lo < p.hi && p.hi.is_finite(),
                "{:?}",
                p.keys
            );
            assert!(!p.why.is_empty(), "{:?}", p.keys);
            for (name, size) in p.slips {
                assert!(*size > 0.0 && *size != 1.0, "{:?} {name}", p.keys);
            }
        }
    }

    /// The likely slip is named; a value no slip explains is refused all
    /// the same, without a guess; zero passes only where it means "off".
    #[test]
    fn the_refusal_names_the_range_and_the_slip() {
        let err = plausible(169e9, "materials.si.youngs_modulus_gpa")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("materials.si.youngs_modulus_gpa")
                && err.contains("1.69e11 GPa")
                && err.contains("1e-5..2000 GPa")
                && err.contains("looks like Pa: the key is in GPa"),
            "{err}"
        );
        let err = plausible(1e30, "probe.length_um").unwrap_err().to_string();
        assert!(
            err.contains("implausible") && !err.contains("looks like"),
            "{err}"
        );
        let err = plausible(300.0, "environment.charge_adhesion_gain")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("looks like %: the key is a plain ratio"),
            "{err}"
        );
        assert_eq!(
            plausible(0.0, "interfaces.x.work_of_adhesion_j_m2"),
            Ok(0.0)
        );
        assert!(plausible(0.0, "particle.radius_um").is_err());
        assert_eq!(plausible(-2.0, "environment.drift_nm_s"), Ok(-2.0));
        assert!(plausible(5.0, "probe.unknown_um").is_err());
    }
}
