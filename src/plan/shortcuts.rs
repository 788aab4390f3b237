//! Shortcuts through an ordered plan, each kept only when the plan still
//! replays clear (every corridor keeps the clearance, as in the order):
//! - a particle the order pushed along a bent path (parked off a site, then
//!   pushed off another move's way again; buffered, then brought back;
//!   routed through a waypoint) is pushed straight from its start to its
//!   end instead, at the time of its first push or of its last; one that
//!   ends on no site, to any nearer spot off the sites;
//! - else each bend of its path moves towards the straight line between
//!   its neighbours, then slides along what stops it;
//! - a particle that ends on no site (parked off the sites, or pushed off
//!   another move's way) has its last push pulled in: it stops at the
//!   nearest spot off every site found clear (in 48 directions, then on
//!   the push's own line, then turned between the directions), or stays
//!   put;
//! - a particle pushed once off another's way stays put when the one
//!   later push it would block can bend round it for less.
//!
//! The order decides each push with what it knows at that step; only the
//! finished plan shows that a particle's second push undid half of its
//! first (CMU seed 58 of the 40-60 scenes: a particle parked 0.22 um off a
//! site, later 2.25 um further, 0.16 um more than one push to its end), or
//! that a spot kept clear of a corridor no later push used.

use super::grid::Grid;
use super::layout::Layout;
use super::parking::{
    CLEARING_DIRECTIONS, CLEARING_MARGIN_M, SiteDiscs, ring_off_sites, spots_off_sites_along,
};
use super::pushes::{
    Corridor, approach_point, corridor_reach, max_push_len, segment_distance, split_long,
};
use super::{PlanConfig, Step};
use nalgebra::Vector2;
use std::collections::HashMap;

/// Least saving a shortcut is tried for: the collinear pieces of a long
/// push save nothing.
const MIN_SAVING_M: f64 = 1e-8;

/// Most pushes of a plan whose shortcuts are tried: each try replays the
/// whole plan, so the cost grows with pushes times bent paths. CMU plans
/// have 30-100 pushes; at N = 1,000 (2,831 pushes) the shortcuts took the
/// push ratio from 1.002560 to 1.002169 and the full plan from 318 to
/// 626 ms, for a target already met.
pub const MAX_PUSHES: usize = 2_000;

/// `steps` (pushes only, in order) after up to `ROUNDS` rounds of
/// straightened paths, tightened bends, parked particles' last pushes
/// pulled in and pushes bent round particles that then stay put
/// (`site_pts`: every site); and how many pushes fewer it has.
pub fn take_shortcuts(
    steps: Vec<Step>,
    layout: &Layout,
    site_pts: &[Vector2<f64>],
    config: &PlanConfig,
) -> (Vec<Step>, usize) {
    if steps.len() > MAX_PUSHES {
        return (steps, 0);
    }
    let before = steps.len();
    let parking = Parking::new(site_pts, layout, config);
    let index = layout.index_by_id();
    let mut steps = steps;
    for _ in 0..ROUNDS {
        let length = push_length(&steps);
        steps = straighten(steps, layout, &index, &parking, config);
        steps = tighten_bends(steps, layout, &index, config);
        steps = pull_in_parking(steps, layout, &index, &parking, config);
        steps = park_after_blocker(steps, layout, &index, &parking, config);
        steps = bend_round_idle(steps, layout, &index, &parking, config);
        if push_length(&steps) > length - MIN_SAVING_M {
            break;
        }
    }
    let fewer = before.saturating_sub(steps.len());
    (steps, fewer)
}

/// Most rounds of the passes: one can free room for another.
const ROUNDS: usize = 3;

/// The sites as a parked particle must leave them: by the clearance, and
/// a spot it is pushed to by [`CLEARING_MARGIN_M`] more, as the order's
/// spots ([`ring_off_sites`] adds the margin itself).
struct Parking<'a> {
    grid: Grid,
    site_pts: &'a [Vector2<f64>],
    radius_m: f64,
    clearance_m: f64,
}

impl<'a> Parking<'a> {
    fn new(site_pts: &'a [Vector2<f64>], layout: &Layout, config: &PlanConfig) -> Self {
        let radius_m = layout.max_radius_m();
        Parking {
            grid: Grid::new(site_pts.iter().copied(), 2.0 * radius_m),
            site_pts,
            radius_m,
            clearance_m: config.clearance_m,
        }
    }

    /// The site discs with the clearance.
    fn discs(&self) -> SiteDiscs<'_> {
        self.discs_with(0.0)
    }

    /// The site discs with the clearance and `margin_m` more.
    fn discs_with(&self, margin_m: f64) -> SiteDiscs<'_> {
        SiteDiscs {
            grid: &self.grid,
            centres: self.site_pts,
            radius_m: self.radius_m,
            clearance_m: self.clearance_m + margin_m,
        }
    }

    /// True when a particle at `p` has ended on a site.
    fn on_site(&self, p: Vector2<f64>) -> bool {
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
    fn ends(
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

/// Total length of the pushes of `steps`.
fn push_length(steps: &[Step]) -> f64 {
    steps
        .iter()
        .filter_map(Step::push_move)
        .map(|(_, from_m, to_m)| (to_m - from_m).norm())
        .sum()
}

/// `steps` with every bent path that can be straightened so (at its first
/// push or its last), largest saving first; a particle that ends on no
/// site may end at any spot off the sites nearer than its path's length
/// (CMU seed 3 of the 40-60 scenes: a particle pushed off a site, then
/// later off a corridor, 2.5 um where 0.25 um leaves the site).
fn straighten(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &HashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Vec<Step> {
    for (particle, excess) in bent_paths(&steps) {
        let Some(path) = PathOf::find(&steps, particle) else {
            continue;
        };
        let x = index[&particle];
        let length = (path.end - path.start).norm() + excess;
        let parked = !parking.on_site(path.end);
        let checks = [path.first, path.last].map(|at| {
            let unchanged_before = at == path.first;
            let c = SinglePushCheck::new(
                &steps,
                (x, path.start),
                at,
                unchanged_before,
                layout,
                index,
                config,
            );
            (at, c)
        });
        // (length, which check, end), shortest first: the path's own end,
        // then for a parked particle any spot off the sites.
        let mut tries: Vec<(f64, usize, Vector2<f64>)> = Vec::new();
        for (which, (_, check)) in checks.iter().enumerate() {
            tries.push((length - excess, which, path.end));
            if parked {
                let swept = |p: Vector2<f64>| check.swept_later(p, config);
                for end in parking.ends(path.start, check.radius, length, &swept) {
                    tries.push(((end - path.start).norm(), which, end));
                }
            }
        }
        tries.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let found = tries
            .into_iter()
            .find(|&(_, which, end)| checks[which].1.allows(end, config));
        if let Some((_, which, end)) = found {
            let (at, check) = &checks[which];
            let end = if parked {
                let swept = |p: Vector2<f64>| check.swept_later(p, config);
                turned_nearer(parking, (path.start, end), check.radius, &swept, |spot| {
                    check.allows(spot, config)
                })
            } else {
                end
            };
            steps = path.straightened(&steps, *at, end, check.radius, config);
        }
    }
    steps
}

/// Bisection steps when pulling a bend or a parked particle's push in.
const PULL_IN_STEPS: usize = 7;

/// A push step of `particle` from `from` to `to`, its approach behind it.
fn push_step(
    particle: u32,
    from: Vector2<f64>,
    to: Vector2<f64>,
    radius_m: f64,
    config: &PlanConfig,
) -> Step {
    Step::Push {
        particle,
        from_m: from,
        to_m: to,
        approach_m: approach_point(from, to, radius_m, config),
        contact_angle_rad: config.contact_angle_rad,
    }
}

/// `steps` with the pushes `i` and `j` of `particle` (of `radius_m`),
/// from `p` to `n`, meeting at `bend` instead.
fn with_bend(
    steps: &[Step],
    (i, j): (usize, usize),
    (particle, p, n): (u32, Vector2<f64>, Vector2<f64>),
    bend: Vector2<f64>,
    radius_m: f64,
    config: &PlanConfig,
) -> Vec<Step> {
    let mut out = steps.to_vec();
    out[i] = push_step(particle, p, bend, radius_m, config);
    out[j] = push_step(particle, bend, n, radius_m, config);
    out
}

/// [`PULL_IN_STEPS`] bisections between the fractions `valid` (`ok`) and
/// `invalid`: the fraction nearest `invalid` found `ok`; None when only
/// `valid` is.
fn bisect((mut valid, mut invalid): (f64, f64), ok: impl Fn(f64) -> bool) -> Option<f64> {
    let mut best = None;
    for _ in 0..PULL_IN_STEPS {
        let mid = 0.5 * (valid + invalid);
        if ok(mid) {
            valid = mid;
            best = Some(mid);
        } else {
            invalid = mid;
        }
    }
    best
}

/// `steps` with each bend of a particle's path (where one of its pushes
/// ends and its next begins: a waypoint, a buffer spot) moved towards the
/// straight line between the bend's neighbours, as far as the plan still
/// replays clear: the route search picks waypoints from a coarse set.
fn tighten_bends(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &HashMap<u32, usize>,
    config: &PlanConfig,
) -> Vec<Step> {
    let wide = with_room(config);
    for (particle, _) in bent_paths(&steps) {
        let x = index[&particle];
        let radius = layout.particles[x].radius_m;
        let own: Vec<usize> = (0..steps.len())
            .filter(|&k| matches!(steps[k], Step::Push { particle: id, .. } if id == particle))
            .collect();
        for pair in own.windows(2) {
            let (i, j) = (pair[0], pair[1]);
            let (Some((_, p, v)), Some((_, _, n))) = (steps[i].push_move(), steps[j].push_move())
            else {
                continue;
            };
            if (v - p).norm() + (n - v).norm() - (n - p).norm() < MIN_SAVING_M {
                continue;
            }
            let pn = n - p;
            let along = if pn.norm_squared() > 0.0 {
                ((v - p).dot(&pn) / pn.norm_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let straight = p + pn * along;
            let candidate = |t: f64| {
                let bend = v + (straight - v) * t;
                with_bend(&steps, (i, j), (particle, p, n), bend, radius, config)
            };
            let full = candidate(1.0);
            if clear_for(&full, layout, index, config, x) {
                steps = full;
            } else if let Some(t) = bisect((0.0, 1.0), |t| {
                clear_for(&candidate(t), layout, index, config, x)
            }) {
                steps = candidate(t);
            }
            let clear = |s: &[Step]| clear_for(s, layout, index, &wide, x);
            steps = slide_bend(steps, (i, j), radius, clear, config);
        }
    }
    steps
}

/// Room beyond the clearance that a slid bend, or a push bent round a
/// particle left in place, keeps from every particle: they end where the
/// room runs out, and the closed loop re-plans from where the particles
/// are seen after each push, tens of nanometres off the plan (CMU seed 33
/// of `nanopush study assemble`: with bent pushes at the bare clearance,
/// the plan in hand stopped verifying mid-run and the re-plan from there
/// was refused).
const EXECUTION_ROOM_M: f64 = 0.05e-6;

/// `config` with [`EXECUTION_ROOM_M`] added to its clearance.
fn with_room(config: &PlanConfig) -> PlanConfig {
    PlanConfig {
        clearance_m: config.clearance_m + EXECUTION_ROOM_M,
        ..config.clone()
    }
}

/// Step sizes of [`slide_bend`]'s pattern search, metres.
const SLIDE_STEPS_M: [f64; 6] = [0.5e-6, 0.25e-6, 0.12e-6, 0.06e-6, 0.03e-6, 0.015e-6];

/// Least a slide must shorten a path, metres: a bend that follows the
/// edge of a particle's corridor gains little per step.
const SLIDE_GAIN_M: f64 = 1e-12;

/// Most moves of a bend per step size.
const SLIDE_MOVES: usize = 16;

/// `steps` with the bend between the pushes `i` and `j` of one particle
/// (of `radius_m`) slid in 8 directions and along either push's line, by
/// shrinking steps (a pattern search), while the two pushes get shorter
/// and `clear` holds. Pulled towards its neighbours' line, a bend stops
/// where a leg touches a particle; slid along that particle, the path
/// still gets shorter (CMU seed 8 of the 40-60 scenes: a path round a
/// filled site 1.8 um above its straight line, where a smooth way round
/// is 0.8 um above it).
fn slide_bend(
    mut steps: Vec<Step>,
    (i, j): (usize, usize),
    radius_m: f64,
    clear: impl Fn(&[Step]) -> bool,
    config: &PlanConfig,
) -> Vec<Step> {
    let (Some((particle, p, _)), Some((_, _, n))) = (steps[i].push_move(), steps[j].push_move())
    else {
        return steps;
    };
    let length = |b: Vector2<f64>| (b - p).norm() + (n - b).norm();
    // A push stays within the nanostage's reach, as the order's pieces.
    let longest = max_push_len(radius_m, config);
    let compass: Vec<Vector2<f64>> = (0..4)
        .map(|a| {
            let angle = std::f64::consts::TAU * f64::from(a) / 8.0;
            Vector2::new(angle.cos(), angle.sin())
        })
        .collect();
    for h in SLIDE_STEPS_M {
        for _ in 0..SLIDE_MOVES {
            let Some((_, _, v)) = steps[i].push_move() else {
                return steps;
            };
            // Along either leg too: a leg that touches a particle keeps
            // its line, so the bend follows that edge of the free space.
            let legs = [v - p, n - v].map(|leg| leg.try_normalize(0.0));
            let mut tries: Vec<(f64, Vector2<f64>)> = compass
                .iter()
                .chain(legs.iter().flatten())
                .flat_map(|&u| [v + u * h, v - u * h])
                .filter(|&b| (b - p).norm().max((n - b).norm()) <= longest)
                .map(|b| (length(b), b))
                .filter(|&(len, _)| len < length(v) - SLIDE_GAIN_M)
                .collect();
            tries.sort_by(|a, b| a.0.total_cmp(&b.0));
            let moved = tries.into_iter().find_map(|(_, b)| {
                let out = with_bend(&steps, (i, j), (particle, p, n), b, radius_m, config);
                clear(&out).then_some(out)
            });
            match moved {
                Some(out) => steps = out,
                None => break,
            }
        }
    }
    steps
}

/// Spots tried for a parked particle's end, nearest first: in each of 48
/// directions the nearest point off the sites, then a ring
/// ([`ring_off_sites`]; the order chose among the same with the corridors
/// it knew then, CMU seed 11 of the 40-60 scenes: 8.6 um where 2.2 um
/// replays clear).
const SPOTS_TRIED: usize = 48;

/// `steps` with each push that leaves a particle on no site (its last)
/// shortened to the nearest end found that keeps the parking margin from
/// every site ([`SiteDiscs`] with [`CLEARING_MARGIN_M`], as the order's
/// spots) and replays clear: no push at all, a nearer spot off the sites
/// in another direction, or the nearest fraction of the push off the
/// sites, else by bisection towards the full push.
fn pull_in_parking(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &HashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Vec<Step> {
    // Last first: dropping a push leaves the earlier indices as they are.
    for k in parked_pushes(&steps, parking).into_iter().rev() {
        let Some(end) = nearer_parking_end(&steps, k, layout, index, parking, config) else {
            continue;
        };
        end_push_at(&mut steps, k, end, layout, index, config);
    }
    steps
}

/// Ends the push `k` of `steps` at `end`, or drops it when `end` is where
/// it starts.
fn end_push_at(
    steps: &mut Vec<Step>,
    k: usize,
    end: Vector2<f64>,
    layout: &Layout,
    index: &HashMap<u32, usize>,
    config: &PlanConfig,
) {
    let (particle, from_m, _) = steps[k].push_move().expect("a push");
    if (end - from_m).norm() < MIN_SAVING_M {
        steps.remove(k);
    } else {
        let r = layout.particles[index[&particle]].radius_m;
        steps[k] = push_step(particle, from_m, end, r, config);
    }
}

/// Indices of the pushes that leave a particle on no site for good (its
/// last push), in order.
fn parked_pushes(steps: &[Step], parking: &Parking) -> Vec<usize> {
    let mut last: HashMap<u32, usize> = HashMap::new();
    for (k, step) in steps.iter().enumerate() {
        if let Some((particle, _, _)) = step.push_move() {
            last.insert(particle, k);
        }
    }
    let mut parked: Vec<usize> = last
        .into_values()
        .filter(|&k| {
            !steps[k]
                .push_move()
                .is_some_and(|(_, _, to)| parking.on_site(to))
        })
        .collect();
    parked.sort_unstable();
    parked
}

/// A nearer end for the parked push `k` ([`pull_in_parking`]'s rule), or
/// None when none replays clear.
fn nearer_parking_end(
    steps: &[Step],
    k: usize,
    layout: &Layout,
    index: &HashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Option<Vector2<f64>> {
    let (particle, from_m, to_m) = steps[k].push_move()?;
    let discs = parking.discs_with(CLEARING_MARGIN_M);
    let x = index[&particle];
    let check = SinglePushCheck::new(steps, (x, from_m), k, true, layout, index, config);
    let len = (to_m - from_m).norm();
    let shorter = |spot: Vector2<f64>| (spot - from_m).norm() < len - MIN_SAVING_M;
    let at = |t: f64| from_m + (to_m - from_m) * t;
    let swept = |p: Vector2<f64>| check.swept_later(p, config);
    let spots = parking.ends(from_m, check.radius, len, &swept);
    let end = spots
        .into_iter()
        .find(|&spot| check.allows(spot, config))
        .or_else(|| {
            // The nearest fraction (in 32nds) from which the rest of the
            // push stays off the sites.
            let mut t_off = 1.0;
            for n in (0..32).rev() {
                let t = n as f64 / 32.0;
                if discs.covered_by(at(t), check.radius) {
                    break;
                }
                t_off = t;
            }
            if !shorter(at(t_off)) {
                return None;
            }
            if check.allows(at(t_off), config) {
                return Some(at(t_off));
            }
            bisect((1.0, t_off), |t| check.allows(at(t), config)).map(at)
        });
    // The push as it is, or as found, may turn to a nearer spot.
    let turned = turned_nearer(
        parking,
        (from_m, end.unwrap_or(to_m)),
        check.radius,
        &swept,
        |spot| check.allows(spot, config),
    );
    (end.is_some() || turned != to_m).then_some(turned)
}

/// Least a parked push must shorten for [`park_after_blocker`] to reorder
/// the plan: the tour re-sequences the pushes after the shortcuts anyway,
/// but a reordered plan is harder to follow for little.
const REORDER_GAIN_M: f64 = 0.1e-6;

/// `steps` where a parked particle's push, whose nearer spots are blocked
/// by a particle that only moves later (another's tip landing, or its
/// disc, in the way), waits until that particle has moved: the other's
/// pushes go first, when they replay clear there, and the parked push
/// ends at the nearer spot then found ([`nearer_parking_end`]). CMU seed
/// 95 of the 40-60 scenes: p32, pushed 3.88 um off site 15 between p53
/// (on the tip's landing of the radial way out) and p3 (on the spot of a
/// way 30 degrees round), where 2.9 um would do once p3 is on its site.
fn park_after_blocker(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &HashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Vec<Step> {
    for k in parked_pushes(&steps, parking).into_iter().rev() {
        let Some((particle, from, to)) = steps[k].push_move() else {
            continue;
        };
        let x = index[&particle];
        let len = (to - from).norm();
        let reach = len + corridor_reach(layout.particles[x].radius_m, config) + config.clearance_m;
        // Particles that first move after push k, near enough to bound it.
        let mut first_start: HashMap<u32, (usize, Vector2<f64>)> = HashMap::new();
        for (j, step) in steps.iter().enumerate() {
            if let Some((id, start, _)) = step.push_move() {
                first_start.entry(id).or_insert((j, start));
            }
        }
        let mut blockers: Vec<u32> = first_start
            .into_iter()
            .filter(|&(id, (j, start))| {
                j > k && (start - from).norm() < reach + layout.particles[index[&id]].radius_m
            })
            .map(|(id, _)| id)
            .collect();
        blockers.sort_unstable();
        let found = blockers.into_iter().find_map(|id| {
            // Their pushes all come after k: they go just before it.
            let theirs = |s: &&Step| s.push_move().is_some_and(|(p, _, _)| p == id);
            let mut hoisted: Vec<Step> = steps[..k].to_vec();
            hoisted.extend(steps[k..].iter().filter(theirs).cloned());
            let moved = hoisted.len() - k;
            hoisted.extend(steps[k..].iter().filter(|s| !theirs(s)).cloned());
            if !clear_for(&hoisted, layout, index, config, index[&id]) {
                return None;
            }
            let at = k + moved;
            let end = nearer_parking_end(&hoisted, at, layout, index, parking, config)?;
            if (end - from).norm() > len - REORDER_GAIN_M {
                return None;
            }
            end_push_at(&mut hoisted, at, end, layout, index, config);
            clear_for(&hoisted, layout, index, config, x).then_some(hoisted)
        });
        if let Some(shorter) = found {
            steps = shorter;
        }
    }
    steps
}

/// Turns tried each way from a parked particle's push, in one of the 48
/// directions' step: the nearest spot off the sites often lies between two
/// of them, where another particle or the tip's landing bounds the way.
const TURN_STEPS: usize = 8;

/// `end` (a push from `from` to a spot off the sites), or the nearest of
/// the spots off the sites and out of `swept` in the directions turned
/// from it by up to one of the 48 directions' step each way
/// ([`TURN_STEPS`]), where `ok` holds.
fn turned_nearer(
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

/// Where a bend is first tried on a push it replaces: fractions of the
/// way along it, and distances aside (either side), metres.
const BEND_ALONG: [f64; 5] = [0.2, 0.35, 0.5, 0.65, 0.8];
const BEND_ASIDE_M: [f64; 6] = [0.5e-6, 1e-6, 2e-6, 3e-6, 4e-6, 6e-6];

/// `steps` where a particle pushed once, from a spot off the sites to no
/// site (off another's way), stays put instead, and the one later push its
/// stay would block bends round it (a bend from a coarse set, then slid),
/// when the bent push is shorter than the two. The order moves an idle
/// blocker before it reroutes (CMU seed 50 of the 40-60 scenes: p54
/// pushed 2.33 um out of the tip's landing behind p3, where p3's push
/// bent by about 30 degrees lands its tip clear for about 1 um more).
fn bend_round_idle(
    mut steps: Vec<Step>,
    layout: &Layout,
    index: &HashMap<u32, usize>,
    parking: &Parking,
    config: &PlanConfig,
) -> Vec<Step> {
    let radius = |i: usize| layout.particles[i].radius_m;
    let wide = with_room(config);
    let mut pushes_of: HashMap<u32, usize> = HashMap::new();
    for (id, _, _) in steps.iter().filter_map(Step::push_move) {
        *pushes_of.entry(id).or_insert(0) += 1;
    }
    let mut once: Vec<u32> = pushes_of
        .into_iter()
        .filter(|&(_, n)| n == 1)
        .map(|(id, _)| id)
        .collect();
    once.sort_unstable();
    for id in once {
        let Some(k) = steps
            .iter()
            .position(|s| s.push_move().is_some_and(|(p, _, _)| p == id))
        else {
            continue;
        };
        let (_, start, end) = steps[k].push_move().expect("a push");
        let q = index[&id];
        if parking.on_site(end) || parking.discs().covered_by(start, radius(q)) {
            continue;
        }
        let mut without = steps.clone();
        without.remove(k);
        let blocked: Vec<usize> = (k..without.len())
            .filter(|&j| {
                without[j].push_move().is_some_and(|(p, a, b)| {
                    corridor_hits((a, b, radius(index[&p])), start, radius(q), config)
                })
            })
            .collect();
        let [j] = blocked[..] else {
            continue;
        };
        let (pid, a, b) = without[j].push_move().expect("a push");
        let x = index[&pid];
        let rx = radius(x);
        let budget = (b - a).norm() + (end - start).norm() - MIN_SAVING_M;
        let longest = max_push_len(rx, config);
        let ab = b - a;
        if ab.norm() < MIN_SAVING_M {
            continue;
        }
        let aside = Vector2::new(-ab.y, ab.x).normalize();
        let mut bends: Vec<(f64, Vector2<f64>)> = BEND_ALONG
            .iter()
            .flat_map(|&t| {
                BEND_ASIDE_M
                    .iter()
                    .flat_map(move |&h| [a + ab * t + aside * h, a + ab * t - aside * h])
            })
            .filter(|&w| (w - a).norm().max((b - w).norm()) <= longest)
            .map(|w| ((w - a).norm() + (b - w).norm(), w))
            .filter(|&(len, _)| len < budget)
            .collect();
        bends.sort_by(|u, v| u.0.total_cmp(&v.0));
        let clear = |s: &[Step]| {
            clear_for(s, layout, index, &wide, x) && clear_for(s, layout, index, &wide, q)
        };
        // Push j in two pieces, then bent where they meet.
        let mut split = without;
        split.insert(j + 1, split[j].clone());
        let found = bends.into_iter().find_map(|(_, w)| {
            let bent = with_bend(&split, (j, j + 1), (pid, a, b), w, rx, config);
            clear(&bent).then_some(bent)
        });
        if let Some(bent) = found {
            steps = slide_bend(bent, (j, j + 1), rx, clear, config);
        }
    }
    steps
}

/// What a particle's one push, put where step `at` is in place of all its
/// own pushes, must keep clear of: the other particles where they are at
/// `at`, and their later pushes' corridors (it then lies at its end for
/// good). When its earlier pushes are dropped, it also stays at its start
/// until `at`: the other particles' pushes before `at` must miss it there.
struct SinglePushCheck {
    from: Vector2<f64>,
    radius: f64,
    /// The pushes before `at` miss the particle at its start.
    clear_before: bool,
    /// Centres and radii of the other particles at the push.
    others: Vec<(Vector2<f64>, f64)>,
    /// The other particles' later pushes: start, end, radius.
    later: Vec<(Vector2<f64>, Vector2<f64>, f64)>,
}

impl SinglePushCheck {
    /// For particle `particle` (index in `layout`) leaving `from` where
    /// step `at` is; `unchanged_before`: its pushes before `at` stay, so
    /// nothing before `at` changes.
    fn new(
        steps: &[Step],
        (particle, from): (usize, Vector2<f64>),
        at: usize,
        unchanged_before: bool,
        layout: &Layout,
        index: &HashMap<u32, usize>,
        config: &PlanConfig,
    ) -> Self {
        let radius_of = |i: usize| layout.particles[i].radius_m;
        let radius = radius_of(particle);
        let others_push = |step: &Step| {
            let (id, from_m, to_m) = step.push_move()?;
            let i = *index.get(&id).filter(|&&i| i != particle)?;
            Some((from_m, to_m, radius_of(i), i))
        };
        let mut pos: Vec<Vector2<f64>> = layout.particles.iter().map(|p| p.centre_m).collect();
        let mut clear_before = true;
        for (a, b, r, i) in steps[..at].iter().filter_map(others_push) {
            clear_before = clear_before
                && (unchanged_before || !corridor_hits((a, b, r), from, radius, config));
            pos[i] = b;
        }
        SinglePushCheck {
            from,
            radius,
            clear_before,
            others: (0..pos.len())
                .filter(|&i| i != particle)
                .map(|i| (pos[i], radius_of(i)))
                .collect(),
            later: steps[at..]
                .iter()
                .filter_map(others_push)
                .map(|(a, b, r, _)| (a, b, r))
                .collect(),
        }
    }

    /// True when a later push of another particle sweeps over `end`.
    fn swept_later(&self, end: Vector2<f64>, config: &PlanConfig) -> bool {
        self.later
            .iter()
            .any(|&push| corridor_hits(push, end, self.radius, config))
    }

    /// True when pushing the particle to `end` (not at all, at its start)
    /// keeps the clearance from every particle at every push.
    fn allows(&self, end: Vector2<f64>, config: &PlanConfig) -> bool {
        if !self.clear_before || self.swept_later(end, config) {
            return false;
        }
        let own = (self.from, end, self.radius);
        (end - self.from).norm() < MIN_SAVING_M
            || self
                .others
                .iter()
                .all(|&(c, r)| !corridor_hits(own, c, r, config))
    }
}

/// True when the corridor of pushing a particle of radius `r` from `a` to
/// `b` comes within the clearance of a disc of `radius` at `centre`
/// (built only when the disc is within [`corridor_reach`]).
fn corridor_hits(
    (a, b, r): (Vector2<f64>, Vector2<f64>, f64),
    centre: Vector2<f64>,
    radius: f64,
    config: &PlanConfig,
) -> bool {
    let clearance = config.clearance_m;
    segment_distance(centre, a, b) < corridor_reach(r, config) + clearance + radius
        && Corridor::new(a, b, r, config).hits(centre, radius, clearance)
}

/// Particle ids whose pushes add up to more than their straight line,
/// largest excess first.
fn bent_paths(steps: &[Step]) -> Vec<(u32, f64)> {
    let mut path: HashMap<u32, (Vector2<f64>, Vector2<f64>, f64)> = HashMap::new();
    for step in steps {
        if let Some((particle, from_m, to_m)) = step.push_move() {
            let e = path.entry(particle).or_insert((from_m, from_m, 0.0));
            e.1 = to_m;
            e.2 += (to_m - from_m).norm();
        }
    }
    let mut bent: Vec<(u32, f64)> = path
        .into_iter()
        .map(|(id, (start, end, len))| (id, len - (end - start).norm()))
        .filter(|&(_, saving)| saving > MIN_SAVING_M)
        .collect();
    bent.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    bent
}

/// One particle's pushes in a plan: where they start and end, and the
/// indices of its first and last.
struct PathOf {
    particle: u32,
    start: Vector2<f64>,
    end: Vector2<f64>,
    first: usize,
    last: usize,
}

impl PathOf {
    fn find(steps: &[Step], particle: u32) -> Option<Self> {
        let mut found: Option<PathOf> = None;
        for (k, step) in steps.iter().enumerate() {
            if let Some((id, from_m, to_m)) = step.push_move()
                && id == particle
            {
                let p = found.get_or_insert(PathOf {
                    particle,
                    start: from_m,
                    end: to_m,
                    first: k,
                    last: k,
                });
                p.end = to_m;
                p.last = k;
            }
        }
        found
    }

    /// `steps` without this particle's pushes (radius `r`), and its
    /// straight push to `end` (split to fit the nanostage; none when `end`
    /// is its start) where step `at` was.
    fn straightened(
        &self,
        steps: &[Step],
        at: usize,
        end: Vector2<f64>,
        r: f64,
        config: &PlanConfig,
    ) -> Vec<Step> {
        let pieces = if (end - self.start).norm() < MIN_SAVING_M {
            Vec::new()
        } else {
            split_long(self.start, end, max_push_len(r, config))
        };
        let straight = pieces
            .into_iter()
            .map(|(a, b)| push_step(self.particle, a, b, r, config));
        let mut out = Vec::with_capacity(steps.len());
        let mut straight = Some(straight);
        for (k, step) in steps.iter().enumerate() {
            if k == at {
                out.extend(straight.take().into_iter().flatten());
            }
            match step {
                Step::Push { particle, .. } if *particle == self.particle => {}
                other => out.push(other.clone()),
            }
        }
        out
    }
}

/// True when the pushes of `steps` that involve particle `x` (its index in
/// `layout`: its own pushes, and every other push while it lies where it
/// does then) start where their particle is and keep the clearance: the
/// whole replay's answer for a plan that replayed clear before only `x`'s
/// pushes changed, since the positions of every other pair at every push
/// are the same. Linear in the pushes, plus the particles for each push of
/// `x`.
fn clear_for(
    steps: &[Step],
    layout: &Layout,
    index: &HashMap<u32, usize>,
    config: &PlanConfig,
    x: usize,
) -> bool {
    let mut pos: Vec<Vector2<f64>> = layout.particles.iter().map(|p| p.centre_m).collect();
    let radius = |j: usize| layout.particles[j].radius_m;
    steps.iter().all(|step| {
        let Some((id, from_m, to_m)) = step.push_move() else {
            return true;
        };
        let Some(&i) = index.get(&id) else {
            return false;
        };
        let push = (from_m, to_m, radius(i));
        let clear = if i == x {
            (pos[x] - from_m).norm() <= 1e-12
                && (0..pos.len()).all(|j| j == x || !corridor_hits(push, pos[j], radius(j), config))
        } else {
            !corridor_hits(push, pos[x], radius(x), config)
        };
        pos[i] = to_m;
        clear
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::layout::Layout;
    use crate::plan::occupancy::Occupancy;

    /// True when every push of `steps`, replayed from `layout`, starts where
    /// its particle is and its corridor (particle and tip) keeps the clearance
    /// from every other particle where it is then: the order's own test.
    fn replays_clear(steps: &[Step], layout: &Layout) -> bool {
        let config = PlanConfig::default();
        let index = layout.index_by_id();
        let mut occ = Occupancy::new(layout);
        steps.iter().all(|step| {
            step.push_move().is_none_or(|(particle, from_m, to_m)| {
                index
                    .get(&particle)
                    .is_some_and(|&i| occ.replay_push(i, (from_m, to_m), &config))
            })
        })
    }

    /// A push of `particle` of 5 um radius from `from` to `to` (um).
    fn push(particle: u32, from: (f64, f64), to: (f64, f64)) -> Step {
        let (a, b) = (
            Vector2::new(from.0, from.1) * 1e-6,
            Vector2::new(to.0, to.1) * 1e-6,
        );
        push_step(particle, a, b, 5e-6, &PlanConfig::default())
    }

    /// `steps` (which must replay clear) after the shortcuts, with the
    /// sites at `sites` (um), checked to replay clear; and how many pushes
    /// fewer they have.
    fn shortened(layout: &Layout, steps: Vec<Step>, sites: &[(f64, f64)]) -> (Vec<Step>, usize) {
        assert!(
            replays_clear(&steps, layout),
            "the plan given does not replay clear"
        );
        let sites: Vec<Vector2<f64>> = sites
            .iter()
            .map(|&(x, y)| Vector2::new(x, y) * 1e-6)
            .collect();
        let (out, fewer) = take_shortcuts(steps, layout, &sites, &PlanConfig::default());
        assert!(replays_clear(&out, layout), "the shortened plan does not");
        (out, fewer)
    }

    /// Particle, start and end (um) of the push at `k`.
    fn push_at(steps: &[Step], k: usize) -> (u32, Vector2<f64>, Vector2<f64>) {
        let (particle, from_m, to_m) = steps[k].push_move().expect("a push");
        (particle, from_m * 1e6, to_m * 1e6)
    }

    #[test]
    fn a_bent_path_in_open_space_goes_straight() {
        let layout = Layout::of_test_centres_um(&[(50.0, 50.0), (150.0, 150.0)]);
        let steps = vec![
            push(0, (50.0, 50.0), (60.0, 50.0)),
            push(1, (150.0, 150.0), (150.0, 140.0)),
            push(0, (60.0, 50.0), (60.0, 60.0)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(60.0, 60.0), (150.0, 140.0)]);
        assert_eq!(fewer, 1);
        let expected = 200f64.sqrt() + 10.0;
        assert!((push_length(&out) * 1e6 - expected).abs() < 1e-9);
        let (particle, _, to) = push_at(&out, 0);
        assert_eq!(particle, 0);
        assert!((to - Vector2::new(60.0, 60.0)).norm() < 1e-9);
    }

    #[test]
    fn a_detour_around_a_particle_stays_bent_but_tighter() {
        // Particle 1 sits on the straight line from (20, 50) to (80, 50).
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 50.0)]);
        let steps = vec![
            push(0, (20.0, 50.0), (50.0, 65.0)),
            push(0, (50.0, 65.0), (80.0, 50.0)),
        ];
        let (out, fewer) = shortened(&layout, steps.clone(), &[(80.0, 50.0)]);
        assert_eq!(fewer, 0);
        // The bend moves towards the line, not onto it: the two particles
        // need 10 um between centres plus the clearance.
        let y = push_at(&out, 0).2.y;
        assert!(y > 60.0 && y < 62.0, "{y}");
        assert!(push_length(&out) < push_length(&steps));
    }

    #[test]
    fn a_bend_off_centre_slides_round_the_particle_to_the_shortest_way() {
        // Particle 1 sits on the straight line from (20, 50) to (80, 50);
        // the bend starts off centre, at (30, 75). Pulled towards the line
        // alone it stops where its second leg touches particle 1; slid, it
        // ends where both legs touch: the shortest one-bend way round,
        // 2 sqrt(30^2 + h^2) with h = 30 rho / sqrt(30^2 - rho^2), rho the
        // 10 um between centres plus the clearance and the execution room.
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 50.0)]);
        let steps = vec![
            push(0, (20.0, 50.0), (30.0, 75.0)),
            push(0, (30.0, 75.0), (80.0, 50.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(80.0, 50.0)]);
        let rho = 10.0 + (PlanConfig::default().clearance_m + EXECUTION_ROOM_M) * 1e6;
        let h = 30.0 * rho / (900.0 - rho * rho).sqrt();
        let shortest = 2.0 * (900.0 + h * h).sqrt();
        let len = push_length(&out) * 1e6;
        assert!(
            len > shortest - 1e-6 && len < shortest + 0.05,
            "{len} {shortest}"
        );
    }

    #[test]
    fn a_particle_pushed_out_of_a_tip_landing_stays_and_the_push_bends_round_it() {
        // Particle 1 lies 4 um from where the tip lands behind particle 0's
        // push up to the site at (50, 40); the order pushed it 14.5 um
        // aside. Pushed straight away from the landing, its own tip would
        // land on particle 0; bending particle 0's push round it costs
        // under 1.5 um, and particle 1 stays.
        let layout = Layout::of_test_centres_um(&[(50.0, 20.0), (50.5, 9.0)]);
        let steps = vec![
            push(1, (50.5, 9.0), (65.0, 9.0)),
            push(0, (50.0, 20.0), (50.0, 40.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(50.0, 40.0)]);
        assert!(out.iter().all(|s| s.push_move().is_some_and(|m| m.0 == 0)));
        let len = push_length(&out) * 1e6;
        assert!(len > 20.0 && len < 21.5, "{len}");
    }

    #[test]
    fn a_parked_push_waits_for_the_particle_that_blocks_its_nearer_way() {
        // Particle 0 lies 2 um from the site at (52, 50); particle 1, at
        // (34, 50), leaves for its site at (34, 30) only after particle 0
        // was pushed up, 9.95 um at least. With particle 1 gone, the way
        // out to the left is 8.15 um: particle 1 goes first, then particle
        // 0 is pushed left.
        let layout = Layout::of_test_centres_um(&[(50.0, 50.0), (34.0, 50.0)]);
        let steps = vec![
            push(0, (50.0, 50.0), (50.0, 61.0)),
            push(1, (34.0, 50.0), (34.0, 30.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(52.0, 50.0), (34.0, 30.0)]);
        let k = |id: u32| {
            out.iter()
                .position(|s| s.push_move().is_some_and(|m| m.0 == id))
        };
        assert!(k(1) < k(0), "particle 1 still moves after particle 0");
        let (_, from, to) = push_at(&out, k(0).unwrap());
        let len = (to - from).norm();
        assert!(len > 8.1 && len < 8.3 && to.x < 50.0, "{len} to {to:?}");
    }

    #[test]
    fn a_buffered_particle_waits_where_it_is_when_that_is_clear() {
        // Particle 0 steps aside and back while particle 1 passes well clear
        // of it: staying put until the last push is clear too, and shorter.
        let layout = Layout::of_test_centres_um(&[(20.0, 20.0), (100.0, 100.0)]);
        let steps = vec![
            push(0, (20.0, 20.0), (20.0, 40.0)),
            push(1, (100.0, 100.0), (100.0, 150.0)),
            push(0, (20.0, 40.0), (20.0, 20.5)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(20.0, 20.5), (100.0, 150.0)]);
        assert_eq!(fewer, 1);
        assert!((push_length(&out) * 1e6 - 50.5).abs() < 1e-9);
    }

    #[test]
    fn a_replay_that_hits_a_particle_is_not_clear() {
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 50.0)]);
        let steps = vec![push(0, (20.0, 50.0), (80.0, 50.0))];
        assert!(!replays_clear(&steps, &layout));
        let wrong_start = vec![push(0, (21.0, 50.0), (20.0, 80.0))];
        assert!(!replays_clear(&wrong_start, &layout));
    }

    #[test]
    fn a_parked_particle_stops_where_it_is_off_the_sites() {
        // Particle 1 covers the site at (50, 50) (3 um off its centre) and
        // was parked 20 um away; 10.15 um plus the margin is enough.
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (53.0, 50.0)]);
        let steps = vec![
            push(1, (53.0, 50.0), (73.0, 50.0)),
            push(0, (20.0, 50.0), (50.0, 50.0)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(50.0, 50.0)]);
        assert_eq!(fewer, 0);
        let clearance = PlanConfig::default().clearance_m * 1e6;
        let off = (push_at(&out, 0).2.x - 50.0) - 10.0 - clearance;
        // Within one 32nd of the 20 um push beyond the least distance.
        assert!((0.0..=20.0 / 32.0).contains(&off), "{off}");
    }

    #[test]
    fn a_particle_pushed_off_a_way_no_push_uses_stays_put() {
        // Particle 1 was pushed aside for nothing: particle 0 passes far
        // from it. The push is dropped.
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 150.0)]);
        let steps = vec![
            push(1, (50.0, 150.0), (50.0, 170.0)),
            push(0, (20.0, 50.0), (80.0, 50.0)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(80.0, 50.0)]);
        assert_eq!(fewer, 1);
        assert_eq!(out.len(), 1);
    }

    #[test]
    fn a_particle_pushed_off_a_way_keeps_clear_of_it() {
        // Particle 1 sits on particle 0's line and is pushed 20 um aside:
        // pulled in, it stops just clear of the corridor (about 10.15 um).
        let layout = Layout::of_test_centres_um(&[(20.0, 50.0), (50.0, 50.0)]);
        let steps = vec![
            push(1, (50.0, 50.0), (50.0, 70.0)),
            push(0, (20.0, 50.0), (80.0, 50.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(80.0, 50.0)]);
        let y = push_at(&out, 0).2.y;
        assert!(y > 60.0 && y < 62.0, "{y}");
    }

    #[test]
    fn a_parked_particle_takes_a_nearer_way_off_the_sites() {
        // Particle 1 lies 3 um above the site at (50, 50) and was parked
        // 20 um to the left; straight up, 7.2 um, clears the site.
        let layout = Layout::of_test_centres_um(&[(50.0, 20.0), (50.0, 53.0)]);
        let steps = vec![
            push(1, (50.0, 53.0), (30.0, 53.0)),
            push(0, (50.0, 20.0), (50.0, 50.0)),
        ];
        let (out, _) = shortened(&layout, steps, &[(50.0, 50.0)]);
        let (_, from, to) = push_at(&out, 0);
        let len = (to - from).norm();
        // Least: 10.15 um clearance plus the margin, less the 3 um.
        let least = 10.0 + (PlanConfig::default().clearance_m + CLEARING_MARGIN_M) * 1e6 - 3.0;
        assert!(len >= least - 1e-6 && len < least + 0.5, "{len}");
        assert!((to - Vector2::new(50.0, 50.0)).norm() >= least + 3.0 - 1e-6);
    }

    #[test]
    fn a_particle_pushed_off_a_site_then_off_a_way_goes_once_where_neither_needs_it() {
        // Particle 1 covers the site at (50, 50); the order pushed it just
        // off, then up and right off particle 0's later way (y = 62):
        // 19.4 um. One push at the start, off the site and below the way,
        // is about 11.8 um.
        let layout = Layout::of_test_centres_um(&[(20.0, 62.0), (50.0, 58.0)]);
        let steps = vec![
            push(1, (50.0, 58.0), (50.0, 60.3)),
            push(1, (50.0, 60.3), (62.0, 72.5)),
            push(0, (20.0, 62.0), (80.0, 62.0)),
        ];
        let (out, fewer) = shortened(&layout, steps, &[(50.0, 50.0), (80.0, 62.0)]);
        assert_eq!(fewer, 1);
        let (particle, from, to) = push_at(&out, 0);
        assert_eq!(particle, 1);
        let len = (to - from).norm();
        assert!(len < 13.0, "{len}");
    }
}
