//! Straight pushes and their swept corridors.
//!
//! A move from `from` to `to` is pushed along d = (to - from)/|to - from|: the
//! tip (a disc of `tip_radius`) lands `standoff` behind the contact point
//! `approach = from - d (R + r_tip)`, moves in, pushes the particle to `to`
//! and lifts. Its corridor is the particle disc swept from `from` to `to`
//! plus the tip disc swept from the landing point to its final position;
//! both are parry2d capsules.

use super::{PlanConfig, Step};
use nalgebra::Vector2;
use parry2d::math::Vector;
use parry2d::query::PointQuery;
use parry2d::shape::Capsule;

/// Unit push direction (x axis for a zero-length move, so nothing is NaN).
pub fn direction(from: Vector2<f64>, to: Vector2<f64>) -> Vector2<f64> {
    let d = to - from;
    let n = d.norm();
    if n > 0.0 {
        d / n
    } else {
        Vector2::new(1.0, 0.0)
    }
}

/// Tip centre at contact, behind a particle of `radius_m` at `from`.
pub fn approach_point(
    from: Vector2<f64>,
    to: Vector2<f64>,
    radius_m: f64,
    config: &PlanConfig,
) -> Vector2<f64> {
    from - direction(from, to) * (radius_m + config.tip_radius_m)
}

/// Where the tip lands before moving in to contact.
pub fn landing_point(
    from: Vector2<f64>,
    to: Vector2<f64>,
    approach: Vector2<f64>,
    config: &PlanConfig,
) -> Vector2<f64> {
    approach - direction(from, to) * config.standoff_m
}

/// Tip centre when the push ends (where it lifts).
pub fn tip_end(from: Vector2<f64>, to: Vector2<f64>, approach: Vector2<f64>) -> Vector2<f64> {
    approach + (to - from)
}

/// How much closer than at the start a push may bring a particle it starts
/// within the clearance of, um (f32 rounding of the local shapes).
const APPROACH_TOLERANCE_UM: f32 = 1e-4;

/// The region a push sweeps: particle capsule and tip capsule, local to `origin`
/// (f32 parry shapes in micrometres relative to the push start keep precision).
#[derive(Debug, Clone)]
pub struct Corridor {
    origin: Vector2<f64>,
    particle: Capsule,
    tip: Capsule,
    /// A capsule containing the whole corridor (particle and tip paths are
    /// collinear): segment ends and radius, metres. Spatial queries visit
    /// only the cells near it.
    pub spine_m: (Vector2<f64>, Vector2<f64>, f64),
    /// The spine capsule's bounding box (lower, upper corner), metres: a
    /// disc clear of it is missed without the exact test.
    bounds_m: (Vector2<f64>, Vector2<f64>),
}

/// Widens the bounding-box test beyond the exact one's reach: that one runs
/// in f32 micrometres (about 1e-11 m of rounding across a field).
const BOUNDS_MARGIN_M: f64 = 1e-9;

fn local(origin: Vector2<f64>, p: Vector2<f64>) -> Vector {
    let d = (p - origin) * 1e6;
    Vector::new(d.x as f32, d.y as f32)
}

impl Corridor {
    /// Corridor of pushing a particle of `radius_m` from `from` to `to`.
    pub fn new(from: Vector2<f64>, to: Vector2<f64>, radius_m: f64, config: &PlanConfig) -> Self {
        let approach = approach_point(from, to, radius_m, config);
        let land = landing_point(from, to, approach, config);
        let end = tip_end(from, to, approach);
        let particle = Capsule::new(local(from, from), local(from, to), (radius_m * 1e6) as f32);
        let tip = Capsule::new(
            local(from, land),
            local(from, end),
            (config.tip_radius_m * 1e6) as f32,
        );
        // The spine runs from the landing point to the particle's end; its
        // radius also covers the tip's end and the start (off the spine only
        // when a zero-length push has no direction).
        let off_spine = segment_distance(end, land, to).max(segment_distance(from, land, to));
        let spine_m = (land, to, radius_m.max(config.tip_radius_m) + off_spine);
        let r = Vector2::repeat(spine_m.2);
        let bounds_m = (land.inf(&to) - r, land.sup(&to) + r);
        Corridor {
            origin: from,
            particle,
            tip,
            spine_m,
            bounds_m,
        }
    }

    /// True if a disc at `centre_m` of `radius_m` comes closer than `clearance_m` to the corridor.
    ///
    /// A disc the pushed particle already sits within the clearance of (two
    /// particles left touching by earlier pushes) is hit only when the push
    /// brings them closer still: moving apart, or sideways away, is free.
    pub fn hits(&self, centre_m: Vector2<f64>, radius_m: f64, clearance_m: f64) -> bool {
        let far = radius_m + clearance_m + BOUNDS_MARGIN_M;
        let (lo, hi) = self.bounds_m;
        if centre_m.x < lo.x - far
            || centre_m.y < lo.y - far
            || centre_m.x > hi.x + far
            || centre_m.y > hi.y + far
        {
            return false;
        }
        let p = local(self.origin, centre_m);
        let reach = ((radius_m + clearance_m) * 1e6) as f32;
        let along = self.particle.distance_to_local_point(p, true);
        let at_start = p.length() - self.particle.radius;
        let particle_hits = along < reach && along < at_start - APPROACH_TOLERANCE_UM;
        particle_hits || self.tip.distance_to_local_point(p, true) < reach
    }
}

/// How far from the segment `from`-`to` a push's corridor reaches at most
/// (the tip lands a standoff and a tip diameter behind the particle's
/// back): a disc farther than this plus its radius and the clearance is
/// missed, with no corridor built.
pub fn corridor_reach(radius_m: f64, config: &PlanConfig) -> f64 {
    radius_m + 2.0 * config.tip_radius_m + config.standoff_m
}

/// Distance from `p` to the segment a-b, metres.
pub fn segment_distance(p: Vector2<f64>, a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).norm()
}

/// Splits a long move into collinear pushes no longer than `max_len_m`.
pub fn split_long(
    from: Vector2<f64>,
    to: Vector2<f64>,
    max_len_m: f64,
) -> Vec<(Vector2<f64>, Vector2<f64>)> {
    let len = (to - from).norm();
    let pieces = if max_len_m > 0.0 && len > max_len_m {
        (len / max_len_m).ceil() as usize
    } else {
        1
    };
    (0..pieces)
        .map(|k| {
            (
                from + (to - from) * (k as f64 / pieces as f64),
                from + (to - from) * ((k + 1) as f64 / pieces as f64),
            )
        })
        .collect()
}

/// Longest single push: one that fits the nanostage range with its
/// approach, and no longer than `config.max_push_m`.
pub fn max_push_len(radius_m: f64, config: &PlanConfig) -> f64 {
    let in_range = (config.nanostage_range_m
        - 2.0 * (radius_m + config.tip_radius_m + config.standoff_m))
        .max(config.nanostage_range_m / 4.0);
    config.max_push_m.map_or(in_range, |m| in_range.min(m))
}

/// Inserts lifted tip travel before every push (from the previous push's end,
/// or from `start`), dropping zero-length travel.
pub fn with_tip_travel(
    steps: Vec<Step>,
    start: Option<Vector2<f64>>,
    config: &PlanConfig,
) -> Vec<Step> {
    let mut out = Vec::with_capacity(steps.len() * 2);
    let mut tip = start;
    for step in steps {
        if let Step::Push {
            from_m,
            to_m,
            approach_m,
            ..
        } = &step
        {
            let land = landing_point(*from_m, *to_m, *approach_m, config);
            if let Some(t) = tip
                && (land - t).norm() > 0.0
            {
                out.push(Step::TipTravel {
                    from_m: t,
                    to_m: land,
                });
            }
            tip = Some(tip_end(*from_m, *to_m, *approach_m));
        }
        out.push(step);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corridor_hits_what_is_on_the_path_and_not_beside_it() {
        let cfg = PlanConfig::default();
        let c = Corridor::new(Vector2::new(0.0, 0.0), Vector2::new(50e-6, 0.0), 5e-6, &cfg);
        assert!(c.hits(Vector2::new(25e-6, 9.5e-6), 5e-6, 0.1e-6));
        assert!(!c.hits(Vector2::new(25e-6, 10.5e-6), 5e-6, 0.1e-6));
        // Behind the particle: only the tip corridor reaches there.
        assert!(c.hits(Vector2::new(-7e-6 - 5.5e-6, 0.0), 5e-6, 0.1e-6));
        assert!(!c.hits(Vector2::new(-7e-6 - 6.5e-6, 0.0), 5e-6, 0.1e-6));
        // Touching at the start (gap 0.04 um < clearance): moving away is free
        // where the tip fits in, moving closer is not.
        let behind_left: Vector2<f64> = Vector2::new(-7.1e-6, -7.1e-6);
        assert!((behind_left.norm() - 10.04e-6).abs() < 0.01e-6);
        assert!(!c.hits(behind_left, 5e-6, 0.1e-6));
        let straight_behind = Vector2::new(-10.04e-6, 0.0);
        assert!(c.hits(straight_behind, 5e-6, 0.1e-6), "the tip lands in it");
        let sideways = Corridor::new(Vector2::zeros(), Vector2::new(50e-6, 0.0), 5e-6, &cfg);
        assert!(!sideways.hits(Vector2::new(0.0, 10.04e-6), 5e-6, 0.1e-6));
        let closer = Corridor::new(Vector2::zeros(), Vector2::new(0.0, 50e-6), 5e-6, &cfg);
        assert!(closer.hits(Vector2::new(3e-6, 10.04e-6), 5e-6, 0.1e-6));
        // The spine holds the corridor: from the landing point (7 um behind
        // the start) to the end, as wide as the particle.
        let (a, b, r) = c.spine_m;
        assert!((a - Vector2::new(-7e-6, 0.0)).norm() < 1e-12);
        assert!((b - Vector2::new(50e-6, 0.0)).norm() < 1e-12);
        assert!((r - 5e-6).abs() < 1e-12);
        let parts = split_long(Vector2::zeros(), Vector2::new(250e-6, 0.0), 90e-6);
        assert_eq!(parts.len(), 3);
        assert!((parts[2].1.x - 250e-6).abs() < 1e-15);
    }
}
