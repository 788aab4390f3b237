//! Where the particles are while a plan is being built: positions that
//! change as pushes are added, bucketed for corridor queries.
//!
//! Written by hand: a dynamic bucket grid of a few dozen moving discs is
//! smaller than wiring a spatial-index crate for it.

use super::grid::{floor_to_i64, for_each_cell_near_segment};
use super::layout::Layout;
use super::pushes::Corridor;
use nalgebra::Vector2;
use rustc_hash::FxHashMap;

/// Cells by key, hashed without the std hasher's DoS resistance, which
/// bought nothing here and cost a tenth of the scheduler's time at N = 1,000.
type Cells = FxHashMap<(i64, i64), Vec<usize>>;

/// Particle positions that change as pushes are executed, bucketed for queries.
pub struct Occupancy {
    /// Current centres.
    pub pos: Vec<Vector2<f64>>,
    /// Radii.
    pub radius: Vec<f64>,
    cell_m: f64,
    cells: Cells,
    /// Largest radius.
    pub max_radius_m: f64,
    /// Cells read and particles tested so far: the work of the queries.
    work: std::cell::Cell<u64>,
}

impl Occupancy {
    /// Positions of the layout's particles.
    pub fn new(layout: &Layout) -> Self {
        let max_radius_m = layout.max_radius_m();
        let mut o = Occupancy {
            pos: layout.particles.iter().map(|p| p.centre_m).collect(),
            radius: layout.particles.iter().map(|p| p.radius_m).collect(),
            cell_m: (4.0 * max_radius_m).max(1e-9),
            cells: Cells::default(),
            max_radius_m,
            work: Default::default(),
        };
        for i in 0..o.pos.len() {
            let k = o.key(o.pos[i]);
            o.cells.entry(k).or_default().push(i);
        }
        o
    }
    /// No particles yet, bucketed in cells of `cell_m` (at least the
    /// distance queries look within, so a query reads 3 x 3 cells): for
    /// placing particles one at a time ([`Occupancy::push`]).
    pub fn empty(cell_m: f64) -> Self {
        Occupancy {
            pos: Vec::new(),
            radius: Vec::new(),
            cell_m: cell_m.max(1e-9),
            cells: Cells::default(),
            max_radius_m: 0.0,
            work: Default::default(),
        }
    }
    /// Adds a particle at `p` of radius `r`; its index.
    pub fn push(&mut self, p: Vector2<f64>, r: f64) -> usize {
        let i = self.pos.len();
        self.pos.push(p);
        self.radius.push(r);
        self.max_radius_m = self.max_radius_m.max(r);
        let k = self.key(p);
        self.cells.entry(k).or_default().push(i);
        i
    }
    /// Cells read and particles tested by the queries so far: what a
    /// search spent, in units that take about the same time whatever the
    /// particles' size (a long corridor among small particles reads many
    /// cells).
    pub fn work(&self) -> u64 {
        self.work.get()
    }
    fn count(&self, n: usize) {
        self.work.set(self.work.get() + n as u64);
    }
    fn key(&self, p: Vector2<f64>) -> (i64, i64) {
        (
            floor_to_i64(p.x / self.cell_m),
            floor_to_i64(p.y / self.cell_m),
        )
    }
    /// Moves particle i to p.
    pub fn set(&mut self, i: usize, p: Vector2<f64>) {
        let old = self.key(self.pos[i]);
        if let Some(v) = self.cells.get_mut(&old) {
            v.retain(|&x| x != i);
        }
        self.pos[i] = p;
        let k = self.key(p);
        self.cells.entry(k).or_default().push(i);
    }
    /// Replays one push of a finished plan: moves particle i from `from` to
    /// `to` when it is at `from` and the push's corridor keeps
    /// `clearance_m` from every other particle where it is now (the
    /// scheduler's own test); false, nothing moved, otherwise.
    pub fn replay_push(
        &mut self,
        i: usize,
        (from, to): (Vector2<f64>, Vector2<f64>),
        config: &super::PlanConfig,
    ) -> bool {
        if (self.pos[i] - from).norm() > 1e-12 {
            return false;
        }
        let corridor = Corridor::new(from, to, self.radius[i], config);
        if self.first_hit(&corridor, i, config.clearance_m).is_some() {
            return false;
        }
        self.set(i, to);
        true
    }
    /// Calls f on particles in cells near the square of half-side r around c until f returns false.
    pub fn for_each_near(&self, c: Vector2<f64>, r: f64, mut f: impl FnMut(usize) -> bool) {
        let (x0, y0) = self.key(c - Vector2::new(r, r));
        let (x1, y1) = self.key(c + Vector2::new(r, r));
        for x in x0..=x1 {
            for y in y0..=y1 {
                self.count(1);
                if let Some(v) = self.cells.get(&(x, y)) {
                    self.count(v.len());
                    for &i in v {
                        if !f(i) {
                            return;
                        }
                    }
                }
            }
        }
    }
    /// Calls f on the particles of the cells a corridor may reach (those
    /// within `clearance` plus the largest radius of its spine) until f
    /// returns false.
    fn for_each_near_corridor(
        &self,
        c: &Corridor,
        clearance: f64,
        mut f: impl FnMut(usize) -> bool,
    ) {
        let (a, b, r) = c.spine_m;
        let reach = r + self.max_radius_m + clearance;
        let anywhere = [i64::MIN..=i64::MAX, i64::MIN..=i64::MAX];
        for_each_cell_near_segment(
            Vector2::zeros(),
            self.cell_m,
            a,
            b,
            reach,
            anywhere,
            |x, y| {
                self.count(1);
                self.cells.get(&(x, y)).is_none_or(|v| {
                    self.count(v.len());
                    v.iter().all(|&i| f(i))
                })
            },
        );
    }
    /// First particle other than `except` that the corridor hits.
    pub fn first_hit(&self, c: &Corridor, except: usize, clearance: f64) -> Option<usize> {
        let mut hit = None;
        self.for_each_near_corridor(c, clearance, |i| {
            if i != except && c.hits(self.pos[i], self.radius[i], clearance) {
                hit = Some(i);
                return false;
            }
            true
        });
        hit
    }
    /// Every particle other than `except` that the corridor hits.
    pub fn all_hits(&self, c: &Corridor, except: usize, clearance: f64) -> Vec<usize> {
        let mut hits = Vec::new();
        self.for_each_near_corridor(c, clearance, |i| {
            if i != except && c.hits(self.pos[i], self.radius[i], clearance) {
                hits.push(i);
            }
            true
        });
        hits
    }
    /// True when a disc at p of radius r keeps clearance from every particle
    /// but `except` (None: every particle).
    pub fn disc_free(
        &self,
        p: Vector2<f64>,
        r: f64,
        except: Option<usize>,
        clearance: f64,
    ) -> bool {
        let mut free = true;
        self.for_each_near(p, r + self.max_radius_m + clearance, |i| {
            if Some(i) != except && (self.pos[i] - p).norm() < r + self.radius[i] + clearance {
                free = false;
                return false;
            }
            true
        });
        free
    }
}
