//! The large-N fast path: an epsilon-scaling forward/reverse auction
//! (Bertsekas & Castanon 1992, asymmetric assignment) on integer costs, with
//! a bucketed search that never reads the whole cost matrix.
//!
//! Why an auction: on a compact block of sites fed from a wide ring of
//! particles, shortest-augmenting-path methods (ours and scipy's) explore a
//! large plateau of equally short paths for every site (measured: about a
//! third of all sites per augmentation at N = 1000). Auction bids are local:
//! a site only needs the particle minimising `cost + price` and a lower bound
//! on the runner-up.
//!
//! Exactness: a cost is the distance rounded to `diag / 1e9` (`diag` is the
//! instance's bounding-box diagonal: a few picometres for millimetre fields)
//! times `K = n + 1`; the last phase runs at epsilon = 1 < K, so the result
//! is the exact optimum of the rounded costs (epsilon-complementary slackness
//! bounds the gap by n * epsilon < K, the smallest nonzero cost difference).
//! Its true cost is within `n * diag / 1e9` of the true optimum.
//!
//! Rectangular problems (fewer sites than particles) need the reverse steps:
//! after the forward auction of a phase, every free particle priced above
//! the lowest assigned price lowers its price or lures a site away, so that
//! at the end free particles are never dearer than assigned ones.
//!
//! Search: particles sit in `Buckets` with the minimum price of every cell
//! and block, sites with the largest value of every cell and block; blocks
//! are visited best bound first and everything whose bound cannot improve
//! the runner-up is skipped. Written by hand: no Rust crate solves sparse or
//! geometric rectangular assignment.

use super::buckets::{Buckets, dist_to_box, dist2_to_box};
use nalgebra::Vector2;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

const NONE: u32 = u32::MAX;
/// Distances are rounded to `diag / RESOLUTION_STEPS`.
const RESOLUTION_STEPS: f64 = 1e9;
/// Epsilon divides by this between phases.
const EPSILON_FACTOR: i64 = 6;
/// Points per cell of the buckets.
const POINTS_PER_CELL: f64 = 2.0;

/// What a solve did (for the study and for tuning).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AuctionStats {
    /// Epsilon phases run.
    pub phases: u32,
    /// Forward bids (a site takes a particle).
    pub bids: u64,
    /// Reverse steps (a free particle lowers its price or lures a site).
    pub reverse_steps: u64,
}

/// Integer costs: rounded distance times `k`.
#[derive(Clone, Copy)]
struct Costs {
    inv_res: f64,
    k: i64,
    /// `res / k` and `res / 2`, each raised by 1e-9 (see [`Costs::costs_at_least`]).
    res_per_cost: f64,
    half_res: f64,
}

impl Costs {
    fn new(inv_res: f64, k: i64) -> Self {
        let margin = 1.0 + 1e-9;
        Costs {
            inv_res,
            k,
            res_per_cost: margin / (inv_res * k as f64),
            half_res: margin * 0.5 / inv_res,
        }
    }

    /// True when every distance `>= sqrt(d2)` costs at least `r`: a cheap
    /// test (no square root, no rounding) that is never true wrongly. With
    /// `of(d) = floor(d / res + 0.5) k`, `d >= (r / k + 0.5) res` gives
    /// `of(d) >= r`; the factor `1 + 1e-9` covers floating-point error.
    #[inline]
    fn costs_at_least(self, d2: f64, r: i64) -> bool {
        if r <= 0 {
            return true;
        }
        // Multiplications by precomputed factors: the two divisions were a
        // tenth of the auction, which runs this test for every cell it skips.
        let d_r = r as f64 * self.res_per_cost + self.half_res;
        d2 >= d_r * d_r
    }

    #[inline]
    fn of(self, d: f64) -> i64 {
        // d >= 0: adding 0.5 and truncating rounds half up, without a libm call.
        (d * self.inv_res + 0.5) as i64 * self.k
    }
}

/// Solves the rectangular assignment (sites <= particles, all finite):
/// the particle index of every site.
pub fn solve(sites: &[Vector2<f64>], particles: &[Vector2<f64>]) -> Vec<usize> {
    solve_with_stats(sites, particles).0
}

/// [`solve`], also returning what the auction did.
pub fn solve_with_stats(
    sites: &[Vector2<f64>],
    particles: &[Vector2<f64>],
) -> (Vec<usize>, AuctionStats) {
    let n = sites.len();
    let Some(mut a) = Auction::for_instance(sites, particles) else {
        // No site, or every point coincides: every assignment costs nothing.
        return ((0..n).collect(), AuctionStats::default());
    };
    a.run_phases(0.0);
    (a.site_to_particle(), a.stats)
}

/// An assignment within a proven gap of the optimum.
#[derive(Debug, Clone, PartialEq)]
pub struct WithinGap {
    /// `site_to_particle(s)`: the particle of site `s`.
    pub site_to_particle: Vec<usize>,
    /// A lower bound of the optimal total distance, metres (see [`solve_within`]).
    pub lower_bound_m: f64,
    /// What the auction did.
    pub stats: AuctionStats,
}

/// The auction stopped at the first phase whose epsilon-slackness proves
/// the gap (n * epsilon <= rel_gap * cost): the assignment costs at most
/// the optimum plus that gap, and the lower bound is the dual bound of its
/// prices, `sum over sites of min_j (cost + price_j) - sum of the n largest
/// prices`, which no assignment can beat whatever the prices (weak
/// duality), minus the rounding of the costs. The last phases of epsilon
/// scaling are about half the time at N = 1,000-3,000 (measured at a gap of
/// 1e-4), and a plan's detours cost far more than such a gap.
pub fn solve_within(sites: &[Vector2<f64>], particles: &[Vector2<f64>], rel_gap: f64) -> WithinGap {
    let n = sites.len();
    let Some(mut a) = Auction::for_instance(sites, particles) else {
        return WithinGap {
            site_to_particle: (0..n).collect(),
            lower_bound_m: 0.0,
            stats: AuctionStats::default(),
        };
    };
    a.run_phases(rel_gap);
    WithinGap {
        site_to_particle: a.site_to_particle(),
        lower_bound_m: a.dual_bound_m(),
        stats: a.stats,
    }
}

/// The particles' prices (metres, in the caller's order) when the auction
/// stops at `rel_gap` as in [`solve_within`]: the column prices of a dual
/// bound within about `rel_gap` of the optimum, for
/// [`super::dual_bound::bound_from_prices`] to start from (LB_tip).
pub fn particle_prices_m(
    sites: &[Vector2<f64>],
    particles: &[Vector2<f64>],
    rel_gap: f64,
) -> Vec<f64> {
    let Some(mut a) = Auction::for_instance(sites, particles) else {
        return vec![0.0; particles.len()];
    };
    a.run_phases(rel_gap);
    let per_unit = 1.0 / (a.costs.inv_res * a.costs.k as f64);
    let mut out = vec![0.0; particles.len()];
    for (j, &p) in a.price.iter().enumerate() {
        out[a.parts.slot_to_point[j]] = p as f64 * per_unit;
    }
    out
}

/// Auction state; sites and particles are indexed by their bucket slots.
struct Auction {
    costs: Costs,
    sites: Buckets,
    parts: Buckets,
    price: Vec<i64>,
    owner: Vec<u32>,
    assigned: Vec<u32>,
    /// Value of each assigned site: cost to its particle plus that price.
    value: Vec<i64>,
    cell_min_price: Vec<i64>,
    block_min_price: Vec<i64>,
    cell_max_value: Vec<i64>,
    block_max_value: Vec<i64>,
    /// Block keys of the current query (a reused buffer).
    keys: Vec<Reverse<(i64, u32)>>,
    stats: AuctionStats,
}

impl Auction {
    /// The auction for an instance (sites <= particles, all finite); None when
    /// there is nothing to optimise (no site, or every point coincides).
    fn for_instance(sites: &[Vector2<f64>], particles: &[Vector2<f64>]) -> Option<Self> {
        let (n, m) = (sites.len(), particles.len());
        assert!(n <= m, "the auction needs sites <= particles");
        if n == 0 {
            return None;
        }
        let all = || sites.iter().chain(particles.iter());
        let lo = all().fold(sites[0], |a, p| a.inf(p));
        let hi = all().fold(sites[0], |a, p| a.sup(p));
        let diag = (hi - lo).norm();
        if diag.is_nan() || diag <= 0.0 {
            return None;
        }
        let costs = Costs::new(RESOLUTION_STEPS / diag, n as i64 + 1);
        Some(Auction::new(sites, particles, costs))
    }

    /// Epsilon of the first phase: a quarter of the largest possible cost.
    fn first_epsilon(&self) -> i64 {
        (self.costs.of(RESOLUTION_STEPS / self.costs.inv_res) / 4).max(1)
    }

    /// Epsilon phases, each `EPSILON_FACTOR` finer, until epsilon is 1 (the
    /// exact optimum of the rounded costs) or `n * epsilon <= rel_gap * cost`.
    fn run_phases(&mut self, rel_gap: f64) {
        let n = self.assigned.len();
        let mut eps = self.first_epsilon();
        loop {
            self.phase(eps);
            if eps == 1 {
                break;
            }
            if rel_gap > 0.0 {
                let primal: i128 = (0..n)
                    .map(|t| self.cost(t, self.assigned[t] as usize) as i128)
                    .sum();
                if (n as f64) * (eps as f64) <= rel_gap * primal as f64 {
                    break;
                }
            }
            eps = (eps / EPSILON_FACTOR).max(1);
        }
    }

    /// The assignment in the caller's indices.
    fn site_to_particle(&self) -> Vec<usize> {
        let n = self.assigned.len();
        let mut out = vec![usize::MAX; n];
        for t in 0..n {
            out[self.sites.slot_to_point[t]] = self.parts.slot_to_point[self.assigned[t] as usize];
        }
        out
    }

    /// Weak-duality bound of the current prices, metres.
    fn dual_bound_m(&mut self) -> f64 {
        let n = self.assigned.len();
        let mut best: i128 = 0;
        for t in 0..n {
            best += self.best_two_particles(t).0 as i128;
        }
        let mut prices = self.price.clone();
        prices.sort_unstable_by(|x, y| y.cmp(x));
        let dual = best - prices[..n].iter().map(|&p| p as i128).sum::<i128>();
        // cost = round(d / res) k, so d >= (cost / k - 0.5) res for every pair.
        let res = 1.0 / self.costs.inv_res;
        (dual as f64 / self.costs.k as f64 * res - 0.5 * n as f64 * res).max(0.0)
    }

    fn new(sites: &[Vector2<f64>], particles: &[Vector2<f64>], costs: Costs) -> Self {
        let sites = Buckets::new(sites, POINTS_PER_CELL);
        let parts = Buckets::new(particles, POINTS_PER_CELL);
        let (n, m) = (sites.xs.len(), parts.xs.len());
        Auction {
            costs,
            price: vec![0; m],
            owner: vec![NONE; m],
            assigned: vec![NONE; n],
            value: vec![0; n],
            cell_min_price: vec![0; parts.cells()],
            block_min_price: vec![0; parts.blocks()],
            cell_max_value: vec![0; sites.cells()],
            block_max_value: vec![0; sites.blocks()],
            keys: Vec::new(),
            stats: AuctionStats::default(),
            sites,
            parts,
        }
    }

    #[inline]
    fn cost(&self, t: usize, j: usize) -> i64 {
        let dx = self.sites.xs[t] - self.parts.xs[j];
        let dy = self.sites.ys[t] - self.parts.ys[j];
        self.costs.of((dx * dx + dy * dy).sqrt())
    }

    /// One epsilon phase: forward auction until every site holds a particle,
    /// then reverse steps until no free particle is dearer than `lambda`.
    fn phase(&mut self, eps: i64) {
        self.stats.phases += 1;
        self.owner.fill(NONE);
        self.assigned.fill(NONE);
        let mut queue: VecDeque<u32> = (0..self.assigned.len() as u32).collect();
        while let Some(t) = queue.pop_front() {
            if let Some(out) = self.bid(t as usize, eps) {
                queue.push_back(out);
            }
        }
        let lambda = (0..self.price.len())
            .filter(|&j| self.owner[j] != NONE)
            .map(|j| self.price[j])
            .min()
            .unwrap_or(0);
        self.refresh_max_values();
        let mut free: Vec<u32> = (0..self.price.len())
            .filter(|&j| self.owner[j] == NONE && self.price[j] > lambda)
            .map(|j| j as u32)
            .collect();
        while let Some(j) = free.pop() {
            let j = j as usize;
            if self.owner[j] == NONE
                && self.price[j] > lambda
                && let Some(out) = self.reverse(j, lambda, eps)
                && self.price[out] > lambda
            {
                free.push(out as u32);
            }
        }
    }

    /// Site `t` takes its best particle at the price that makes it just
    /// preferable to the runner-up; returns the site it displaced.
    fn bid(&mut self, t: usize, eps: i64) -> Option<u32> {
        self.stats.bids += 1;
        let (w1, j, w2) = self.best_two_particles(t);
        let w2 = if w2 == i64::MAX { w1 } else { w2 };
        let new_price = self.price[j] + (w2 - w1) + eps;
        self.set_price(j, new_price);
        let out = self.owner[j];
        self.owner[j] = t as u32;
        self.assigned[t] = j as u32;
        self.value[t] = w2 + eps;
        (out != NONE).then(|| {
            self.assigned[out as usize] = NONE;
            out
        })
    }

    /// (best cost + price, its particle, runner-up's cost + price or a lower bound).
    fn best_two_particles(&mut self, t: usize) -> (i64, usize, i64) {
        let (x, y) = (self.sites.xs[t], self.sites.ys[t]);
        let c = self.costs;
        let mut keys = std::mem::take(&mut self.keys);
        keys.clear();
        keys.extend(
            self.parts
                .block_box
                .iter()
                .zip(&self.block_min_price)
                .enumerate()
                .map(|(b, (bx, &p))| Reverse((c.of(dist_to_box(bx, x, y)) + p, b as u32))),
        );
        // Blocks cheapest first, from a heap: most queries stop after a few
        // blocks, and sorting every block's key for every bid was a fifth of
        // the LB_tip auction at N = 3,000.
        let mut keys = BinaryHeap::from(keys);
        let (mut w1, mut j1, mut w2) = (i64::MAX, usize::MAX, i64::MAX);
        while let Some(Reverse((key, b))) = keys.pop() {
            if key >= w2 {
                break;
            }
            let b = b as usize;
            for cell in self.parts.block_start[b]..self.parts.block_start[b + 1] {
                if w2 != i64::MAX
                    && c.costs_at_least(
                        dist2_to_box(&self.parts.cell_box[cell], x, y),
                        w2 - self.cell_min_price[cell],
                    )
                {
                    continue;
                }
                for j in self.parts.cell_start[cell]..self.parts.cell_start[cell + 1] {
                    let v = self.cost(t, j) + self.price[j];
                    if v < w1 {
                        w2 = w1;
                        w1 = v;
                        j1 = j;
                    } else if v < w2 {
                        w2 = v;
                    }
                }
            }
        }
        self.keys = keys.into_vec();
        (w1, j1, w2)
    }

    /// Reverse step of free particle `j`: lower its price to `lambda`, or lure
    /// the site that values it most; returns the particle that site released.
    fn reverse(&mut self, j: usize, lambda: i64, eps: i64) -> Option<usize> {
        self.stats.reverse_steps += 1;
        let (b1, t, b2) = self.best_two_sites(j);
        if t == usize::MAX || lambda >= b1 - eps {
            self.set_price(j, lambda);
            return None;
        }
        let new_price = lambda.max(b2.saturating_sub(eps));
        let out = self.assigned[t] as usize;
        self.owner[out] = NONE;
        self.owner[j] = t as u32;
        self.assigned[t] = j as u32;
        self.value[t] = self.cost(t, j) + new_price;
        self.set_price(j, new_price);
        Some(out)
    }

    /// (largest site value - cost, its site, runner-up's or an upper bound).
    fn best_two_sites(&mut self, j: usize) -> (i64, usize, i64) {
        let (x, y) = (self.parts.xs[j], self.parts.ys[j]);
        let c = self.costs;
        let mut keys = std::mem::take(&mut self.keys);
        keys.clear();
        keys.extend(
            self.sites
                .block_box
                .iter()
                .zip(&self.block_max_value)
                .enumerate()
                .map(|(b, (bx, &v))| Reverse((c.of(dist_to_box(bx, x, y)) - v, b as u32))),
        );
        let mut keys = BinaryHeap::from(keys);
        let (mut b1, mut t1, mut b2) = (i64::MIN, usize::MAX, i64::MIN);
        while let Some(Reverse((neg_bound, b))) = keys.pop() {
            if -neg_bound <= b2 {
                break;
            }
            let b = b as usize;
            for cell in self.sites.block_start[b]..self.sites.block_start[b + 1] {
                if b2 != i64::MIN
                    && c.costs_at_least(
                        dist2_to_box(&self.sites.cell_box[cell], x, y),
                        self.cell_max_value[cell] - b2,
                    )
                {
                    continue;
                }
                for t in self.sites.cell_start[cell]..self.sites.cell_start[cell + 1] {
                    let v = self.value[t] - self.cost(t, j);
                    if v > b1 {
                        b2 = b1;
                        b1 = v;
                        t1 = t;
                    } else if v > b2 {
                        b2 = v;
                    }
                }
            }
        }
        self.keys = keys.into_vec();
        (b1, t1, b2)
    }

    /// Sets a particle's price and the minimum prices of its cell and block.
    fn set_price(&mut self, j: usize, p: i64) {
        self.price[j] = p;
        let cell = self.parts.cell_of_slot[j] as usize;
        let r = self.parts.cell_start[cell]..self.parts.cell_start[cell + 1];
        self.cell_min_price[cell] = self.price[r].iter().copied().min().unwrap_or(p);
        let b = self.parts.block_of_cell[cell] as usize;
        let cells = self.parts.block_start[b]..self.parts.block_start[b + 1];
        self.block_min_price[b] = self.cell_min_price[cells]
            .iter()
            .copied()
            .min()
            .unwrap_or(p);
    }

    /// Recomputes the largest site value per cell and block. Values only fall
    /// during reverse steps, so these stay upper bounds until the next phase.
    fn refresh_max_values(&mut self) {
        for cell in 0..self.sites.cells() {
            let r = self.sites.cell_start[cell]..self.sites.cell_start[cell + 1];
            self.cell_max_value[cell] = self.value[r].iter().copied().max().unwrap_or(i64::MIN);
        }
        for b in 0..self.sites.blocks() {
            let r = self.sites.block_start[b]..self.sites.block_start[b + 1];
            self.block_max_value[b] = self.cell_max_value[r]
                .iter()
                .copied()
                .max()
                .unwrap_or(i64::MIN);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::random_points;
    use super::super::{assignment_cost, block_instance, dense_jv, dist};
    use super::*;

    fn check_against_dense(sites: &[Vector2<f64>], parts: &[Vector2<f64>], what: &str) {
        let a = solve(sites, parts);
        let mut used = a.clone();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used.len(), sites.len(), "{what}: a particle used twice");
        let b = dense_jv::solve(sites, parts, |s, p| dist(&sites[s], &parts[p]));
        let (ca, cb) = (
            assignment_cost(sites, parts, &a),
            assignment_cost(sites, parts, &b),
        );
        // Rounding to diag / 1e9 per pair bounds the excess by n * diag / 1e9.
        assert!(
            ca <= cb * (1.0 + 1e-9) + 1e-12,
            "{what}: auction {ca} dense {cb}"
        );
    }

    #[test]
    fn matches_dense_on_random_rectangular_and_square_instances() {
        for seed in 0..15 {
            let n = 5 + (seed as usize * 13) % 60;
            let m = n + (seed as usize * 7) % (2 * n);
            let sites = random_points(n, 100.0, seed);
            let parts = random_points(m, 100.0, seed + 500);
            check_against_dense(&sites, &parts, &format!("seed {seed} n {n} m {m}"));
        }
    }

    #[test]
    fn matches_dense_on_compact_blocks_fed_from_around() {
        for seed in 0..3 {
            let (sites, layout) = block_instance(150, seed);
            let parts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
            check_against_dense(&sites, &parts, &format!("block seed {seed}"));
        }
    }

    #[test]
    fn the_early_lower_bound_is_below_the_optimum_and_close_to_it() {
        for seed in 0..4 {
            let (sites, layout) = block_instance(120, seed);
            let parts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
            let b = dense_jv::solve(&sites, &parts, |s, p| dist(&sites[s], &parts[p]));
            let opt = assignment_cost(&sites, &parts, &b);
            for rel_gap in [1e-2, 1e-3, 0.0] {
                let lb = solve_within(&sites, &parts, rel_gap).lower_bound_m;
                assert!(
                    lb <= opt * (1.0 + 1e-12),
                    "seed {seed} gap {rel_gap}: lb {lb} > opt {opt}"
                );
                // Rounding: n * diag / 1e9 = 120 * 1.4 mm / 1e9, 2e-8 of this optimum.
                assert!(
                    lb >= opt * (1.0 - 2.0 * rel_gap - 1e-7),
                    "seed {seed} gap {rel_gap}: lb {lb} far below opt {opt}"
                );
            }
        }
        // Square, random: the bound also holds when every particle is used.
        let sites = random_points(40, 50.0, 8);
        let parts = random_points(40, 50.0, 9);
        let b = dense_jv::solve(&sites, &parts, |s, p| dist(&sites[s], &parts[p]));
        let opt = assignment_cost(&sites, &parts, &b);
        let lb = solve_within(&sites, &parts, 1e-3).lower_bound_m;
        assert!(
            lb <= opt * (1.0 + 1e-12) && lb >= opt * 0.997,
            "lb {lb} opt {opt}"
        );
    }

    #[test]
    fn degenerate_inputs_are_solved() {
        // Coincident points, a single site, collinear points, duplicates.
        let same = vec![Vector2::new(1.0, 1.0); 4];
        assert_eq!(solve(&same[..2], &same).len(), 2);
        let one = [Vector2::new(0.0, 0.0)];
        let parts = [Vector2::new(5.0, 0.0), Vector2::new(1.0, 0.0)];
        assert_eq!(solve(&one, &parts), vec![1]);
        let line: Vec<_> = (0..30).map(|i| Vector2::new(i as f64, 0.0)).collect();
        let line_sites: Vec<_> = (0..10)
            .map(|i| Vector2::new(i as f64 * 3.0 + 0.5, 0.0))
            .collect();
        check_against_dense(&line_sites, &line, "collinear");
        let mut dup = random_points(20, 10.0, 3);
        dup.extend(dup.clone());
        check_against_dense(&random_points(15, 10.0, 9), &dup, "duplicated particles");
    }
}
