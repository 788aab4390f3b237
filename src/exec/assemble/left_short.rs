//! Sites filled short: a particle the loop gives up on, or one the
//! planner refuses around, within `left_short_m` of a site no other
//! particle fills is left there, journalled, and the site is no longer
//! planned for (the particle covers it and cannot be moved).

use super::{Assembly, ExecError, track_to_site_m};
use crate::exec::events::RunEvent;
use crate::plan::pattern::Site;

/// A site filled short by a particle the loop left alone near it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct LeftShort {
    /// Index into the run's sites.
    pub(super) site: usize,
    /// Track id of the particle.
    pub(super) particle: usize,
    /// Its distance from the site when it was left, metres.
    pub(super) error_m: f64,
}

impl Assembly<'_> {
    /// Site `index` is filled short by a particle left alone near it.
    pub(super) fn is_left_short(&self, index: usize) -> bool {
        self.left_short.iter().any(|l| l.site == index)
    }

    /// The sites the planner is asked to fill: all but those left short.
    pub(super) fn open_sites(&self) -> Vec<Site> {
        (self.sites.iter().enumerate())
            .filter(|(i, _)| !self.is_left_short(*i))
            .map(|(_, s)| *s)
            .collect()
    }

    /// After a refusal: leaves every particle within `left_short_m` of an
    /// unfilled site there, filling it short. How many were.
    pub(super) fn leave_near_particles_short(&mut self) -> Result<usize, ExecError> {
        let errors = self.site_errors_m();
        let unfilled: Vec<usize> = (0..self.sites.len())
            .filter(|&i| errors[i] > self.settings.placed_tolerance_m && !self.is_left_short(i))
            .collect();
        self.leave_nearest_short(&unfilled)
    }

    /// A resumed run leaves the particle nearest each site it left short
    /// there again, if it still lies within `left_short_m`.
    pub(super) fn leave_short_as_before(&mut self) -> Result<(), ExecError> {
        let sites = std::mem::take(&mut self.left_short_before);
        self.leave_nearest_short(&sites).map(|_| ())
    }

    /// Leaves the particle nearest each of `sites` (indices) short, where
    /// it lies within `left_short_m`. How many fill a site.
    pub(super) fn leave_nearest_short(&mut self, sites: &[usize]) -> Result<usize, ExecError> {
        let near: Vec<usize> = (sites.iter().filter_map(|&i| self.sites.get(i)))
            .filter_map(|s| {
                self.nearest_track(s)
                    .filter(|t| track_to_site_m(t, s) <= self.settings.left_short_m)
            })
            .map(|t| t.id)
            .collect();
        let mut left = 0;
        for particle in near {
            left += usize::from(self.leave_short(particle)?);
        }
        Ok(left)
    }

    /// Journals and keeps the site a particle left alone fills, if any
    /// (`site_left_short_by`), and plans around the particle from then on.
    /// True if it fills one.
    pub(super) fn leave_short(&mut self, particle: usize) -> Result<bool, ExecError> {
        let Some(short) = self.site_left_short_by(particle) else {
            return Ok(false);
        };
        if !self.given_up.contains(&particle) {
            self.given_up.push(particle);
        }
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::LeftShort {
                site: short.site,
                particle,
                error_nm: short.error_m * 1e9,
            },
        )?;
        self.left_short.push(short);
        Ok(true)
    }

    /// The site the particle just left alone fills, if it is within
    /// `left_short_m` of one that no other particle fills. The planner is
    /// then no longer asked to fill that site: the particle covers it and
    /// cannot be moved (one left 0.18 um from its site, within tolerance,
    /// had stopped the run all the same).
    pub(super) fn site_left_short_by(&self, particle: usize) -> Option<LeftShort> {
        let t = self.tracker.track(particle)?;
        let filled_by_another = |s: &Site| {
            self.tracker.tracks().iter().any(|o| {
                o.id != particle && track_to_site_m(o, s) <= self.settings.placed_tolerance_m
            })
        };
        self.sites
            .iter()
            .enumerate()
            .filter(|(i, s)| !self.is_left_short(*i) && !filled_by_another(s))
            .map(|(i, s)| (i, track_to_site_m(t, s)))
            .filter(|(_, d)| *d <= self.settings.left_short_m)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(site, d)| LeftShort {
                site,
                particle,
                error_m: d,
            })
    }
}
