//! The radius the loop plans and strokes each particle with.
//!
//! A batch's radii spread (5 % is common: 4.3-5.4 um for 5 um spheres);
//! one radius for all put the tip's contact 0.2 um off on the outliers at
//! a 70 deg contact angle, and their pushes and every re-push fell short.
//! A particle's own measured radius is good to about 10 nm when it is clear
//! of the others, so where the batch's spread is well above that each
//! particle gets its own; where the batch is one size (spread within the
//! measurement's noise) the batch's median, which is good to a few
//! nanometres, serves every particle better than its own noisy one. In
//! between, each radius is shrunk towards the median by the spread's share
//! of the variance (an empirical-Bayes estimate). A particle never seen
//! clear of the others has only its latest sighting's radius, which a
//! neighbour within a micrometre biases by up to about 120 nm: it is
//! shrunk the same way with that noise (the median for all of them had
//! put a 5.28 um particle of a 5 % spread batch at 5.01 um, and a plan
//! from the frame, verified ok, pushed it 0.2 um into its neighbour).

use super::tracker::Track;

/// How far one particle's own radius ([`Track::own_radius_m`]) scatters
/// about its size: on a synthetic frame at the simulated rig's 0.25 um a
/// pixel the measured radius was within 15 nm of the truth at gaps of 1 um
/// and more.
pub const OWN_RADIUS_NOISE_M: f64 = 10e-9;

/// How far a sighting's radius scatters about the particle's size when a
/// neighbour lies within [`super::tracker::ISOLATED_GAP_M`]: up to 120 nm
/// at gaps of 0.1-0.75 um (see the tracker).
pub const NEAR_RADIUS_NOISE_M: f64 = 120e-9;

/// The batch's sizes as seen so far.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleSizes {
    /// The tracks' median radius (the nominal one before any track).
    pub median_m: f64,
    /// How much of a particle's offset from the median is its own: 0 for a
    /// batch of one size, towards 1 for a spread batch.
    pub own_share: f64,
    /// The same share for a sighting beside a neighbour
    /// ([`NEAR_RADIUS_NOISE_M`]): about 0.8 for a 5 % spread batch.
    pub near_share: f64,
}

impl ParticleSizes {
    /// The sizes of `tracks`: each one's own radius where known, its
    /// latest sighting's otherwise; `nominal_m` without tracks.
    pub fn of(tracks: &[Track], nominal_m: f64) -> Self {
        let mut radii: Vec<f64> = tracks
            .iter()
            .map(|t| t.own_radius_m().unwrap_or(t.last.radius_m))
            .collect();
        let Some(median_m) = crate::median::upper_median(&mut radii) else {
            return ParticleSizes {
                median_m: nominal_m,
                own_share: 0.0,
                near_share: 0.0,
            };
        };
        let mut deviations: Vec<f64> = radii.iter().map(|r| (r - median_m).abs()).collect();
        // The median absolute deviation scaled to a normal spread's sigma.
        let spread_m = 1.4826 * crate::median::upper_median(&mut deviations).unwrap_or(0.0);
        let share = |noise_m: f64| {
            let noise2 = noise_m * noise_m;
            let true_spread2 = (spread_m * spread_m - noise2).max(0.0);
            true_spread2 / (true_spread2 + noise2)
        };
        ParticleSizes {
            median_m,
            own_share: share(OWN_RADIUS_NOISE_M),
            near_share: share(NEAR_RADIUS_NOISE_M),
        }
    }

    /// The radius to plan and stroke `track` with: its own shrunk towards
    /// the median, its latest sighting's shrunk further while it was never
    /// seen clear of the others.
    pub fn radius_m(&self, track: &Track) -> f64 {
        match track.own_radius_m() {
            Some(own) => self.median_m + self.own_share * (own - self.median_m),
            None => self.median_m + self.near_share * (track.last.radius_m - self.median_m),
        }
    }

    /// [`Self::radius_m`] of the track `id` of `tracks`, the median without it.
    pub fn radius_of(&self, tracks: &[Track], id: usize) -> f64 {
        tracks
            .iter()
            .find(|t| t.id == id)
            .map_or(self.median_m, |t| self.radius_m(t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::tracker::{Observation, Tracker};

    /// Tracks of particles `seen`, each seen twice.
    fn tracks_of(seen: &[Observation]) -> Vec<Track> {
        let mut tracker = Tracker::new(1e-6);
        for _ in 0..2 {
            tracker.update(seen, &[], &|_, _| true);
        }
        tracker.tracks().to_vec()
    }

    /// Particles of `radii_um` on a line, 30 um apart.
    fn spaced(radii_um: &[f64]) -> Vec<Observation> {
        (radii_um.iter().enumerate())
            .map(|(i, r)| Observation {
                x_m: 30e-6 * i as f64,
                y_m: 0.0,
                radius_m: r * 1e-6,
            })
            .collect()
    }

    /// Tracks of particles of `radii_um`, each seen twice 30 um from the rest.
    fn tracks(radii_um: &[f64]) -> Vec<Track> {
        tracks_of(&spaced(radii_um))
    }

    #[test]
    fn a_batch_of_one_size_gives_every_particle_the_median() {
        let t = tracks(&[4.995, 5.0, 5.004, 5.002, 4.998]);
        let sizes = ParticleSizes::of(&t, 6e-6);
        assert!((sizes.median_m - 5.0e-6).abs() < 1e-12, "{sizes:?}");
        assert_eq!(sizes.own_share, 0.0);
        assert!(t.iter().all(|t| sizes.radius_m(t) == sizes.median_m));
    }

    #[test]
    fn a_spread_batch_gives_each_particle_nearly_its_own() {
        let radii = [4.5, 4.8, 5.0, 5.2, 5.4];
        let t = tracks(&radii);
        let sizes = ParticleSizes::of(&t, 6e-6);
        assert!(sizes.own_share > 0.99, "{sizes:?}");
        for (track, r) in t.iter().zip(radii) {
            assert!((sizes.radius_m(track) - r * 1e-6).abs() < 5e-9, "{r}");
        }
    }

    /// A particle of a spread batch seen only 0.5 um from a neighbour has
    /// no own radius; it keeps most of its sighting's offset from the
    /// median (it had taken the median: 5.28 um planned as 5.01 um).
    #[test]
    fn a_spread_batch_particle_beside_another_keeps_most_of_its_size() {
        let mut seen = spaced(&[4.5, 4.8, 5.0, 5.2, 5.4, 4.9, 5.1]);
        let (wide, beside) = (5.5e-6, 5.0e-6);
        for (x, r) in [(300e-6, wide), (300e-6 + wide + beside + 0.5e-6, beside)] {
            seen.push(Observation {
                x_m: x,
                y_m: 0.0,
                radius_m: r,
            });
        }
        let tracks = tracks_of(&seen);
        let sizes = ParticleSizes::of(&tracks, 6e-6);
        let pair: Vec<&Track> = tracks.iter().filter(|t| t.last.x_m >= 300e-6).collect();
        assert!(pair.iter().all(|t| t.own_radius_m().is_none()));
        let planned = sizes.radius_m(pair[0]);
        assert!(
            (planned - wide).abs() < 0.3 * (wide - sizes.median_m),
            "planned {planned:e}, median {:e}",
            sizes.median_m
        );
        assert!(
            sizes.near_share > 0.7 && sizes.near_share < sizes.own_share,
            "{sizes:?}"
        );
    }

    #[test]
    fn without_tracks_the_nominal_size_serves() {
        let sizes = ParticleSizes::of(&[], 5e-6);
        assert_eq!(sizes.median_m, 5e-6);
    }
}
