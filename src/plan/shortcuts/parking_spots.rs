//! The spots off the sites where a particle that ends on no site may stop:
//! the sites as a parked particle must leave them, and the spots tried,
//! nearest first.

use super::MIN_SAVING_M;
use crate::plan::PlanConfig;
use crate::plan::grid::Grid;
use crate::plan::layout::Layout;
use crate::plan::parking::CLEARING_DIRECTIONS;
use crate::plan::parking::SiteDiscs;
use crate::plan::parking::ring_off_sites;
use crate::plan::parking::spots_off_sites_along;
use nalgebra::Vector2;

/// The sites as a parked particle must leave them: by the clearance and
/// the keep-clear gap ([`PlanConfig::stray_clearance_m`]), and
/// a spot it is pushed to by
/// [`CLEARING_MARGIN_M`](crate::plan::parking::CLEARING_MARGIN_M) more, as
/// the order's spots ([`ring_off_sites`] adds the margin itself).
pub(super) struct Parking<'a> {
    grid: Grid,
    site_pts: &'a [Vector2<f64>],
    radius_m: f64,
    clearance_m: f64,
}

impl<'a> Parking<'a> {
    pub(super) fn new(site_pts: &'a [Vector2<f64>], layout: &Layout, config: &PlanConfig) -> Self {
        let radius_m = config.site_radius_for(layout);
        Parking {
            grid: Grid::new(site_pts.iter().copied(), 2.0 * radius_m),
            site_pts,
            radius_m,
            clearance_m: config.stray_clearance_m(),
        }
    }

    /// The site discs with the clearance.
    pub(super) fn discs(&self) -> SiteDiscs<'_> {
        self.discs_with(0.0)
    }

    /// The site discs with the clearance and `margin_m` more.
    pub(super) fn discs_with(&self, margin_m: f64) -> SiteDiscs<'_> {
        SiteDiscs {
            grid: &self.grid,
            centres: self.site_pts,
            radius_m: self.radius_m,
            clearance_m: self.clearance_m + margin_m,
        }
    }

    /// True when a particle at `p` has ended on a site.
    pub(super) fn on_site(&self, p: Vector2<f64>) -> bool {
        self.grid
            .nearest(p, 1)
            .first()
            .is_some_and(|&(d, _)| d < 1e-9)
    }

    /// Ends off the sites for a particle of `radius_m` leaving `from`,
    /// nearer than `shorter_than`, nearest first: `from` itself when it is
    /// off them, then the first [`SPOTS_TRIED`] spots of [`ring_off_sites`]
    /// (in each of 48 directions the nearest point off the sites and out of
    /// `swept`, then a ring) off the sites and out of `swept`.
    pub(super) fn ends(
        &self,
        from: Vector2<f64>,
        radius_m: f64,
        shorter_than: f64,
        swept: &dyn Fn(Vector2<f64>) -> bool,
    ) -> Vec<Vector2<f64>> {
        let discs = self.discs();
        let stay = (!discs.covered_by(from, radius_m)).then_some(from);
        let spots = ring_off_sites(from, radius_m, &discs, swept, None)
            .into_iter()
            .filter(|&spot| {
                (spot - from).norm() < shorter_than - MIN_SAVING_M
                    && !discs.covered_by(spot, radius_m)
                    && !swept(spot)
            })
            .take(SPOTS_TRIED);
        stay.into_iter().chain(spots).collect()
    }
}

/// Spots tried for a parked particle's end, nearest first: in each of 48
/// directions the nearest point off the sites, then a ring
/// ([`ring_off_sites`]; the order chose among the same with the corridors
/// it knew then, CMU seed 11 of the 40-60 scenes: 8.6 um where 2.2 um
/// replays clear).
const SPOTS_TRIED: usize = 48;

/// Turns tried each way from a parked particle's push, in one of the 48
/// directions' step: the nearest spot off the sites often lies between two
/// of them, where another particle or the tip's landing bounds the way.
const TURN_STEPS: usize = 8;

/// `end` (a push from `from` to a spot off the sites), or the nearest of
/// the spots off the sites and out of `swept` in the directions turned
/// from it by up to one of the 48 directions' step each way
/// ([`TURN_STEPS`]), where `ok` holds.
pub(super) fn turned_nearer(
    parking: &Parking,
    (from, end): (Vector2<f64>, Vector2<f64>),
    radius_m: f64,
    swept: &dyn Fn(Vector2<f64>) -> bool,
    ok: impl Fn(Vector2<f64>) -> bool,
) -> Vector2<f64> {
    let way = end - from;
    if way.norm() < MIN_SAVING_M {
        return end;
    }
    let heading = way.y.atan2(way.x);
    let turn = std::f64::consts::TAU / (CLEARING_DIRECTIONS * TURN_STEPS) as f64;
    let directions = (1..=TURN_STEPS as i32)
        .flat_map(|k| [-k, k])
        .map(|k| heading + turn * f64::from(k))
        .map(|angle| Vector2::new(angle.cos(), angle.sin()));
    let spots = spots_off_sites_along(from, directions, radius_m, &parking.discs(), swept, None);
    let mut best = (way.norm(), end);
    for (len, spot) in spots {
        if len < best.0 - MIN_SAVING_M && ok(spot) {
            best = (len, spot);
        }
    }
    best.1
}
