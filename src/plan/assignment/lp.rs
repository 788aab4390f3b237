//! Assignment as a linear program, solved with clarabel, for side constraints a
//! plain assignment cannot express: forbidden (site, particle) pairs and size
//! classes (a site accepts only particles of its class). The constraint matrix
//! is totally unimodular, so the LP optimum is integral; we round and check.
//! The bottleneck (min-max distance) variant searches the smallest distance
//! threshold for which the constrained LP stays feasible, then minimises the sum.

use super::{AssignmentError, dist};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, ZeroConeT,
};
use nalgebra::Vector2;

/// Side constraints on the assignment.
#[derive(Debug, Clone, Default)]
pub struct SideConstraints {
    /// (site index, particle index) pairs that must not be matched.
    pub forbidden: Vec<(usize, usize)>,
    /// Size class of each site and each particle; a site takes only its class. Empty = no classes.
    pub site_class: Vec<u32>,
    /// Size class of each particle (same length as particles when used).
    pub particle_class: Vec<u32>,
    /// Minimise the largest single distance first (bottleneck), then the sum.
    pub bottleneck: bool,
}

/// Solves with side constraints; returns the particle of each site.
pub fn solve(
    sites: &[Vector2<f64>],
    particles: &[Vector2<f64>],
    side: &SideConstraints,
) -> Result<Vec<usize>, AssignmentError> {
    let allowed = |s: usize, p: usize| {
        if !side.site_class.is_empty() && side.site_class.get(s) != side.particle_class.get(p) {
            return false;
        }
        !side.forbidden.contains(&(s, p))
    };
    if !side.bottleneck {
        return solve_lp(sites, particles, allowed);
    }
    let mut thresholds: Vec<f64> = Vec::new();
    for (s, site) in sites.iter().enumerate() {
        for (p, part) in particles.iter().enumerate() {
            if allowed(s, p) {
                thresholds.push(dist(site, part));
            }
        }
    }
    thresholds.sort_by(f64::total_cmp);
    thresholds.dedup();
    let (mut lo, mut hi) = (0usize, thresholds.len());
    let mut best = None;
    while lo < hi {
        let mid = (lo + hi) / 2;
        let t = thresholds[mid];
        match solve_lp(sites, particles, |s, p| {
            allowed(s, p) && dist(&sites[s], &particles[p]) <= t
        }) {
            Ok(sol) => {
                best = Some(sol);
                hi = mid;
            }
            Err(AssignmentError::Infeasible(_)) => lo = mid + 1,
            Err(e) => return Err(e),
        }
    }
    best.ok_or_else(|| AssignmentError::Infeasible("no threshold admits a full assignment".into()))
}

fn solve_lp(
    sites: &[Vector2<f64>],
    particles: &[Vector2<f64>],
    allowed: impl Fn(usize, usize) -> bool,
) -> Result<Vec<usize>, AssignmentError> {
    let (n, m) = (sites.len(), particles.len());
    let vars: Vec<(usize, usize)> = (0..n)
        .flat_map(|s| (0..m).map(move |p| (s, p)))
        .filter(|&(s, p)| allowed(s, p))
        .collect();
    for s in 0..n {
        if !vars.iter().any(|v| v.0 == s) {
            return Err(AssignmentError::Infeasible(format!(
                "site {s} has no admissible particle"
            )));
        }
    }
    let nv = vars.len();
    // Rows: n equalities (each site once), m inequalities (each particle at most once), nv bounds x >= 0.
    let mut triplets: Vec<(usize, usize, f64)> = Vec::with_capacity(3 * nv);
    for (k, &(s, p)) in vars.iter().enumerate() {
        triplets.push((s, k, 1.0));
        triplets.push((n + p, k, 1.0));
        triplets.push((n + m + k, k, -1.0));
    }
    let a = csc_from_triplets(n + m + nv, nv, &mut triplets);
    let mut b = vec![1.0; n + m];
    b.extend(std::iter::repeat_n(0.0, nv));
    let q: Vec<f64> = vars
        .iter()
        .map(|&(s, p)| dist(&sites[s], &particles[p]) * 1e6)
        .collect();
    let p_mat = CscMatrix::zeros((nv, nv));
    let cones = [ZeroConeT(n), NonnegativeConeT(m + nv)];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .build()
        .map_err(|e| AssignmentError::Solver(format!("{e:?}")))?;
    let mut solver = DefaultSolver::new(&p_mat, &q, &a, &b, &cones, settings)
        .map_err(|e| AssignmentError::Solver(format!("{e:?}")))?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {}
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
            return Err(AssignmentError::Infeasible("the LP is infeasible".into()));
        }
        other => return Err(AssignmentError::Solver(format!("status {other:?}"))),
    }
    let mut s2p = vec![usize::MAX; n];
    let mut taken = vec![false; m];
    for (k, &(s, p)) in vars.iter().enumerate() {
        if solver.solution.x[k] > 0.5 && s2p[s] == usize::MAX && !taken[p] {
            s2p[s] = p;
            taken[p] = true;
        }
    }
    if s2p.contains(&usize::MAX) {
        return Err(AssignmentError::Solver(
            "LP solution is not integral".into(),
        ));
    }
    Ok(s2p)
}

fn csc_from_triplets(rows: usize, cols: usize, t: &mut [(usize, usize, f64)]) -> CscMatrix<f64> {
    t.sort_by_key(|a| (a.1, a.0));
    let mut colptr = vec![0usize; cols + 1];
    let mut rowval = Vec::with_capacity(t.len());
    let mut nzval = Vec::with_capacity(t.len());
    for &(r, c, v) in t.iter() {
        colptr[c + 1] += 1;
        rowval.push(r);
        nzval.push(v);
    }
    for c in 0..cols {
        colptr[c + 1] += colptr[c];
    }
    CscMatrix::new(rows, cols, colptr, rowval, nzval)
}

#[cfg(test)]
mod tests {
    use super::super::test_support::random_points;
    use super::super::{assignment_cost, sparse_ssp};
    use super::*;

    #[test]
    fn unconstrained_lp_matches_exact_and_constraints_hold() {
        let sites = random_points(8, 50.0, 3);
        let parts = random_points(12, 50.0, 4);
        let lp = solve(&sites, &parts, &SideConstraints::default()).unwrap();
        let ex = sparse_ssp::solve(&sites, &parts);
        let (a, b) = (
            assignment_cost(&sites, &parts, &lp),
            assignment_cost(&sites, &parts, &ex),
        );
        assert!((a - b).abs() < 1e-6 * b, "lp {a} exact {b}");

        let forbidden = vec![(0, ex[0]), (1, ex[1])];
        let side = SideConstraints {
            forbidden: forbidden.clone(),
            ..Default::default()
        };
        let con = solve(&sites, &parts, &side).unwrap();
        assert_ne!(con[0], ex[0]);
        assert_ne!(con[1], ex[1]);
        assert!(assignment_cost(&sites, &parts, &con) >= b - 1e-9);

        let side = SideConstraints {
            bottleneck: true,
            ..Default::default()
        };
        let bott = solve(&sites, &parts, &side).unwrap();
        let max_of = |s2p: &[usize]| {
            s2p.iter()
                .enumerate()
                .map(|(s, &p)| dist(&sites[s], &parts[p]))
                .fold(0.0, f64::max)
        };
        assert!(max_of(&bott) <= max_of(&ex) + 1e-9);
    }

    #[test]
    fn size_classes_without_matching_particles_are_infeasible() {
        let sites = random_points(2, 10.0, 1);
        let parts = random_points(3, 10.0, 2);
        let side = SideConstraints {
            site_class: vec![1, 1],
            particle_class: vec![0, 0, 1],
            ..Default::default()
        };
        assert!(matches!(
            solve(&sites, &parts, &side),
            Err(AssignmentError::Infeasible(_))
        ));
    }
}
