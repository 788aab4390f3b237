//! Route searches that found nothing, remembered until something changes
//! where they looked.
//!
//! At N = 1,000 most of the scheduler's time went on detour searches that
//! fail (over a thousand corridor tests each), and the same search failed
//! again and again while pushes went on elsewhere. A search depends only on
//! the particles and filled sites inside the box it looked in, so its
//! failure stands until a push or a filled site touches that box.

use super::PlanConfig;
use super::route::search_extent_m;
use nalgebra::Vector2;
use std::collections::HashMap;

/// What a search was: (move, particle, start x bits, start y bits, whether
/// other particles counted, most waypoints).
pub type SearchKey = (usize, usize, u64, u64, bool, usize);

/// Failed searches with the box (lower, upper corner, metres) each looked in.
#[derive(Debug)]
pub struct FailedRoutes<K = SearchKey> {
    boxes: HashMap<K, (Vector2<f64>, Vector2<f64>)>,
}

impl<K> Default for FailedRoutes<K> {
    fn default() -> Self {
        FailedRoutes {
            boxes: HashMap::new(),
        }
    }
}

/// The box a route search from `from` to `to` looked in, as (lower, upper)
/// corners: every corridor it tested lies within its extent of the two ends,
/// and what it could hit within a particle (`max_radius_m`) and the
/// clearances more (the on-site tolerance for a particle on a site).
pub fn search_box(
    from: Vector2<f64>,
    to: Vector2<f64>,
    radius_m: f64,
    max_radius_m: f64,
    config: &PlanConfig,
) -> (Vector2<f64>, Vector2<f64>) {
    let margin = Vector2::repeat(
        search_extent_m(radius_m, config)
            + max_radius_m
            + config.clearance_m
            + config.on_site_tolerance_m,
    );
    (from.inf(&to) - margin, from.sup(&to) + margin)
}

impl<K: std::hash::Hash + Eq> FailedRoutes<K> {
    /// True when this search failed and nothing has changed in its box since.
    pub fn known(&self, key: &K) -> bool {
        self.boxes.contains_key(key)
    }

    /// Remembers a failed search that looked inside `lo`..`hi`.
    pub fn remember(&mut self, key: K, lo: Vector2<f64>, hi: Vector2<f64>) {
        self.boxes.insert(key, (lo, hi));
    }

    /// Forgets every failure whose box meets the box `lo`..`hi` (where a
    /// particle moved, or a site was filled).
    pub fn forget_near(&mut self, lo: Vector2<f64>, hi: Vector2<f64>) {
        self.boxes
            .retain(|_, (l, h)| l.x > hi.x || l.y > hi.y || h.x < lo.x || h.y < lo.y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failure_is_forgotten_only_when_its_box_is_touched() {
        let mut f = FailedRoutes::default();
        let key = (3, 7, 1, 2, true, 2);
        f.remember(key, Vector2::new(0.0, 0.0), Vector2::new(10.0, 10.0));
        assert!(f.known(&key));
        assert!(!f.known(&(3, 7, 1, 2, false, 2)));
        f.forget_near(Vector2::new(11.0, 0.0), Vector2::new(20.0, 5.0));
        assert!(f.known(&key), "a change beside the box keeps it");
        f.forget_near(Vector2::new(9.0, 9.0), Vector2::new(20.0, 20.0));
        assert!(!f.known(&key), "a change inside the box forgets it");
    }
}
