//! Particles that overlap a little, read as touching.
//!
//! Why: no two particles overlap, but measured ones do: touching spheres
//! whose fitted radii come out a little large (the loop's own tracks, or
//! a layout another tool wrote from its detections) overlap by tens of
//! nanometres. Refusing such a layout (as files were, beyond 1 nm) or
//! planning with the overlap (every push between the pair collides from
//! its start) helps no one; each radius is reduced to its share of the
//! distance instead, by radius, so the pair touches.

use super::Particle;
use super::grid::Grid;

/// Largest overlap of two particles read as touching, as a fraction of
/// the smaller radius (50 nm for 5 um particles): beyond it, the radii
/// are not a fit's error but wrong (diameters, say).
pub const TOUCHING_OVERLAP_FRACTION: f64 = 0.01;

/// What is left between two particles settled to touch, as a fraction of
/// their distance: rounding must not bring them back into overlap.
const SETTLED_GAP_FRACTION: f64 = 1e-6;

/// Two particles that overlapped, and by how much (metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Overlap {
    /// One particle's id.
    pub a: u32,
    /// The other's.
    pub b: u32,
    /// How deep their discs overlapped, metres.
    pub depth_m: f64,
}

/// Reduces each radius to its share (by radius) of the distance to every
/// particle it overlaps, so every such pair touches; returns the pairs
/// that overlapped, deepest first. Radii only shrink, so no new overlap
/// forms. Values must be finite.
pub fn settle_overlaps(particles: &mut [Particle]) -> Vec<Overlap> {
    if particles.len() < 2 {
        return Vec::new();
    }
    let reach = 2.0 * particles.iter().map(|p| p.radius_m).fold(0.0, f64::max);
    let grid = Grid::new(particles.iter().map(|p| p.centre_m), reach);
    let mut caps: Vec<f64> = particles.iter().map(|p| p.radius_m).collect();
    let mut overlaps = Vec::new();
    for (i, p) in particles.iter().enumerate() {
        for j in grid.within(p.centre_m, reach) {
            if j <= i {
                continue;
            }
            let q = &particles[j];
            let d = (p.centre_m - q.centre_m).norm();
            let depth = p.radius_m + q.radius_m - d;
            if depth <= 0.0 {
                continue;
            }
            let share = d * (1.0 - SETTLED_GAP_FRACTION) / (p.radius_m + q.radius_m);
            caps[i] = caps[i].min(p.radius_m * share);
            caps[j] = caps[j].min(q.radius_m * share);
            overlaps.push(Overlap {
                a: p.id,
                b: q.id,
                depth_m: depth,
            });
        }
    }
    for (p, cap) in particles.iter_mut().zip(caps) {
        p.radius_m = cap;
    }
    overlaps.sort_by(|x, y| y.depth_m.total_cmp(&x.depth_m));
    overlaps
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    fn at(id: u32, x_um: f64, r_um: f64) -> Particle {
        Particle {
            id,
            centre_m: Vector2::new(x_um * 1e-6, 10e-6),
            radius_m: r_um * 1e-6,
        }
    }

    /// Two overlapping by 30 nm share the distance by radius and touch; a
    /// third, clear of both, keeps its radius; a particle between two
    /// takes the smaller of its caps.
    #[test]
    fn overlapping_particles_shrink_to_touch_by_their_share() {
        let mut ps = vec![at(0, 10.0, 5.0), at(1, 19.97, 5.0), at(2, 40.0, 4.0)];
        let overlaps = settle_overlaps(&mut ps);
        assert_eq!(overlaps.len(), 1);
        assert_eq!((overlaps[0].a, overlaps[0].b), (0, 1));
        assert!((overlaps[0].depth_m - 30e-9).abs() < 1e-12);
        let sum = ps[0].radius_m + ps[1].radius_m;
        assert!(sum < 9.97e-6 && sum > 9.97e-6 * (1.0 - 1e-5), "{sum}");
        assert!((ps[0].radius_m - ps[1].radius_m).abs() < 1e-15);
        assert_eq!(ps[2].radius_m, 4e-6);

        // Unequal radii share by radius; the middle one's deeper overlap rules.
        let mut ps = vec![at(0, 10.0, 3.0), at(1, 17.99, 5.0), at(2, 27.95, 5.0)];
        let overlaps = settle_overlaps(&mut ps);
        assert_eq!(overlaps.len(), 2);
        assert_eq!((overlaps[0].a, overlaps[0].b), (1, 2), "deepest first");
        let ratio = ps[0].radius_m / 3e-6;
        assert!((ratio - 7.99 / 8.0).abs() < 1e-5, "{ratio}");
        assert!((ps[1].radius_m - 5e-6 * 9.96 / 10.0).abs() < 1e-10);
        for (a, b) in [(0, 1), (1, 2)] {
            let d = (ps[a].centre_m - ps[b].centre_m).norm();
            assert!(ps[a].radius_m + ps[b].radius_m < d, "{a} {b}");
        }
    }

    #[test]
    fn particles_apart_are_left_as_they_are() {
        let mut ps = vec![at(0, 10.0, 5.0), at(1, 20.0, 5.0), at(2, 31.0, 5.0)];
        let before = ps.clone();
        assert!(settle_overlaps(&mut ps).is_empty());
        assert_eq!(ps, before);
    }
}
