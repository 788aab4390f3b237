//! `nanopush study plan`: what accuracy costs in time. For each N, a compact
//! block of N sites with 2N particles at 10 % coverage; greedy, the exact
//! sparse shortest-augmenting-path method, the dense reference (scipy's
//! algorithm), the large-N auction run to its end, the planner's fast path
//! (the auction stopped at a proven 0.01 % gap) and the LP, each with its
//! cost ratio to the best exact cost found and its time (one pass each: a
//! wall-clock time on a shared machine, not a median); methods too slow for a size are
//! listed as skipped with the limit. With `--full`, the whole plan
//! (assignment + order + bounds) with its push ratio to LB_push and where
//! its time went, or the planner's refusal.

use crate::plan::assignment::{
    AssignmentError, AssignmentMethod, assign, assignment_cost, auction, block_instance, dense_jv,
    dist, greedy, instance_json, lp, sparse_ssp,
};
use crate::plan::pattern::numbered_sites;
use crate::plan::{PlanConfig, bounds, order, plan_assembly, pushes, tour};
use nalgebra::Vector2;
use std::path::PathBuf;
use std::time::Instant;

/// A method the study times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StudyMethod {
    /// Nearest free particle, pairs in order of distance.
    Greedy,
    /// Exact sparse shortest augmenting paths (what plan's exact and fast
    /// methods run up to 5,000 pairs).
    Sparse,
    /// Exact dense Jonker-Volgenant (scipy's algorithm).
    Dense,
    /// Epsilon-scaling auction, run to its exact end (what plan's exact
    /// method runs above 5,000 pairs).
    Auction,
    /// The planner's default, the large-N fast path: exact up to 5,000
    /// pairs, above them the auction stopped at a proven gap of 0.01 %
    /// (its note gives the gap proven by its dual bound).
    Fast,
    /// Linear program through clarabel.
    Lp,
}

impl StudyMethod {
    /// Largest N the study runs the method at (above it: skipped, said so).
    fn max_n(self) -> usize {
        match self {
            StudyMethod::Greedy | StudyMethod::Auction | StudyMethod::Fast => usize::MAX,
            StudyMethod::Sparse => 1_000,
            StudyMethod::Dense => 2_000,
            StudyMethod::Lp => 60,
        }
    }

    fn name(self) -> &'static str {
        match self {
            StudyMethod::Greedy => "greedy",
            StudyMethod::Sparse => "sparse",
            StudyMethod::Dense => "dense",
            StudyMethod::Auction => "auction",
            StudyMethod::Fast => "fast",
            StudyMethod::Lp => "lp",
        }
    }

    /// Exact methods set the ratio's reference (greedy and the fast path,
    /// which stops at a gap, do not).
    fn is_exact(self) -> bool {
        !matches!(self, StudyMethod::Greedy | StudyMethod::Fast)
    }
}

/// Arguments of `nanopush study plan`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Comma-separated site counts.
    #[arg(
        long,
        default_value = "30,100,300,1000,3000,10000",
        value_delimiter = ','
    )]
    pub sizes: Vec<usize>,
    /// Seed of the particle layouts.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Methods to time (comma-separated).
    #[arg(
        long,
        value_enum,
        default_value = "greedy,sparse,dense,auction,fast,lp",
        value_delimiter = ','
    )]
    pub methods: Vec<StudyMethod>,
    /// Run every chosen method at every size, ignoring the affordability limits.
    #[arg(long)]
    pub no_limits: bool,
    /// Also plan fully (assignment + order + bounds) for each N.
    #[arg(long)]
    pub full: bool,
    /// Write each instance as JSON here (for scripts/peers/scipy_lsa.py).
    #[arg(long)]
    pub dump_dir: Option<PathBuf>,
    /// Print JSON lines instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// One timed method on one instance.
struct Row {
    method: StudyMethod,
    cost_m: Option<f64>,
    time_ms: f64,
    note: String,
}

fn run_method(
    method: StudyMethod,
    sites: &[Vector2<f64>],
    parts: &[Vector2<f64>],
) -> Result<(Vec<usize>, String), AssignmentError> {
    Ok(match method {
        StudyMethod::Greedy => (greedy::solve(sites, parts), String::new()),
        StudyMethod::Sparse => (sparse_ssp::solve(sites, parts), String::new()),
        StudyMethod::Dense => (
            dense_jv::solve(sites, parts, |s, p| dist(&sites[s], &parts[p])),
            String::new(),
        ),
        StudyMethod::Auction => {
            let (a, st) = auction::solve_with_stats(sites, parts);
            let note = format!(
                "{} phases, {} bids, {} reverse steps",
                st.phases, st.bids, st.reverse_steps
            );
            (a, note)
        }
        StudyMethod::Fast => {
            let a = assign(sites, parts, AssignmentMethod::Fast)?;
            let note = match a.lower_bound_m {
                Some(lb) if lb < a.cost_m => {
                    format!(
                        "proven gap {:.4} % (dual bound)",
                        100.0 * (a.cost_m / lb - 1.0)
                    )
                }
                _ => "exact (sparse, at most 5,000 pairs)".to_string(),
            };
            (a.site_to_particle, note)
        }
        StudyMethod::Lp => (
            lp::solve(sites, parts, &lp::SideConstraints::default())?,
            String::new(),
        ),
    })
}

/// Site counts the study takes: 10^8 asked for 1.6 TB and aborted, 2 x 10^7
/// ran past 7 GB.
const STUDY_SIZES: std::ops::RangeInclusive<usize> = 1..=1_000_000;

/// Runs the study and prints one row per (N, method).
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(n) = args.sizes.iter().find(|n| !STUDY_SIZES.contains(n)) {
        anyhow::bail!(
            "--sizes {n} is not in {}..={} (sites of a block instance, with twice as many particles held in memory)",
            STUDY_SIZES.start(),
            STUDY_SIZES.end()
        );
    }
    if let Some(dir) = &args.dump_dir {
        super::folder_flag::check_folder_flag("--dump-dir", dir, "a folder")?;
    }
    if !args.json {
        println!(
            "{:>6} {:>9} {:>12} {:>12} {:>11}  note",
            "N", "method", "cost_um", "ratio", "time_ms"
        );
    }
    for &n in &args.sizes {
        let (sites, layout) = block_instance(n, args.seed);
        let parts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
        if let Some(dir) = &args.dump_dir {
            std::fs::create_dir_all(dir)
                .map_err(|e| anyhow::anyhow!("creating --dump-dir {}: {e}", dir.display()))?;
            let path = dir.join(format!("block_n{n}.json"));
            std::fs::write(&path, instance_json(&sites, &parts))
                .map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
        }
        let mut rows = Vec::new();
        for &method in &args.methods {
            if n > method.max_n() && !args.no_limits {
                rows.push(Row {
                    method,
                    cost_m: None,
                    time_ms: f64::NAN,
                    note: format!("skipped: unaffordable above N = {}", method.max_n()),
                });
                continue;
            }
            let t = Instant::now();
            let (s2p, note) = run_method(method, &sites, &parts)?;
            let time_ms = t.elapsed().as_secs_f64() * 1e3;
            rows.push(Row {
                method,
                cost_m: Some(assignment_cost(&sites, &parts, &s2p)),
                time_ms,
                note,
            });
        }
        let best = rows
            .iter()
            .filter(|r| r.method.is_exact())
            .filter_map(|r| r.cost_m)
            .fold(f64::INFINITY, f64::min);
        for r in &rows {
            // No exact method ran (all skipped): no ratio, not c / inf = 0.
            let ratio = r.cost_m.filter(|_| best.is_finite()).map(|c| c / best);
            if args.json {
                println!(
                    "{}",
                    serde_json::json!({"schema": "nanopush.study-plan/1", "n": n, "method": r.method.name(),
                        "cost_um": r.cost_m.map(|c| c * 1e6), "ratio": ratio,
                        "time_ms": r.cost_m.map(|_| r.time_ms), "note": r.note})
                );
            } else {
                println!(
                    "{n:>6} {:>9} {:>12} {:>12} {:>11}  {}",
                    r.method.name(),
                    r.cost_m.map_or("-".into(), |c| format!("{:.1}", c * 1e6)),
                    ratio.map_or("-".into(), |x| format!("{x:.9}")),
                    r.cost_m.map_or("-".into(), |_| format!("{:.1}", r.time_ms)),
                    r.note
                );
            }
        }
        if args.full {
            full_plan(n, &sites, &layout, args.json);
        }
    }
    Ok(())
}

/// Straight-line distance of the plan's (executed) assignment: above
/// LB_push by what swaps and re-assignments cost; the push distance above
/// it is detours and buffer pushes.
fn executed_assignment_m(plan: &crate::plan::Plan, layout: &crate::plan::Layout) -> f64 {
    let index = layout.index_by_id();
    let sites: std::collections::HashMap<u32, Vector2<f64>> =
        plan.sites.iter().map(|s| (s.id, s.centre_m)).collect();
    plan.assignment
        .iter()
        .map(|(p, s)| (layout.particles[index[p]].centre_m - sites[s]).norm())
        .sum()
}

/// Plans the instance fully and prints the push ratio and where the time went:
/// the planner's own total, and the stages re-run one by one (assignment,
/// order, LB_tip) from the public stage functions. The re-run orders the
/// plain assignment's pairs, not the plan's (which the parking costs,
/// swaps and re-assignments change), so its order time is not the plan's;
/// the planner logs its own stage times at debug level.
fn full_plan(n: usize, sites: &[Vector2<f64>], layout: &crate::plan::Layout, json: bool) {
    let site_list = numbered_sites(sites.iter().copied());
    let config = PlanConfig::default();
    let t = Instant::now();
    let outcome = plan_assembly(layout, &site_list, &config);
    let total_ms = t.elapsed().as_secs_f64() * 1e3;
    let (ratio, note) = match &outcome {
        Ok(p) => (
            Some(p.summary.push_distance_m / p.summary.lb_push_m),
            format!(
                "planned, {} ({} to buffer spots or waypoints), push+tip ratio {:.3}, executed assignment {:.4} LB_push",
                crate::wording::counted(p.summary.pushes, "push"),
                p.summary.buffer_pushes,
                (p.summary.push_distance_m + p.summary.tip_travel_m)
                    / (p.summary.lb_push_m + p.summary.lb_tip_m),
                executed_assignment_m(p, layout) / p.summary.lb_push_m
            ),
        ),
        Err(e) => (None, format!("refused: {e}")),
    };
    // The stages on their own (the block has no particle on a site).
    let parts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
    let t = Instant::now();
    let assigned = crate::plan::assignment::assign(sites, &parts, config.method);
    let assign_ms = t.elapsed().as_secs_f64() * 1e3;
    let (mut order_ms, mut tour_ms, mut lb_tip_ms) = (f64::NAN, f64::NAN, f64::NAN);
    if let Ok(a) = &assigned {
        let pairs: Vec<(usize, usize)> = a
            .site_to_particle
            .iter()
            .enumerate()
            .map(|(s, &p)| (p, s))
            .collect();
        let t = Instant::now();
        let ordered = order::order_moves(
            layout,
            &site_list,
            &pairs,
            &[],
            &[],
            &config,
            order::Repairs::Thrifty,
        );
        order_ms = t.elapsed().as_secs_f64() * 1e3;
        if let Ok(o) = ordered {
            let t = Instant::now();
            let steps = tour::shorten_tip_travel(o.steps, layout, None, &config);
            tour_ms = t.elapsed().as_secs_f64() * 1e3;
            let steps = pushes::with_tip_travel(steps, None, &config);
            let t = Instant::now();
            let _ = bounds::lb_tip(&steps, None, &config);
            lb_tip_ms = t.elapsed().as_secs_f64() * 1e3;
        }
    }
    if json {
        println!(
            "{}",
            serde_json::json!({"schema": "nanopush.study-plan/1", "n": n, "method": "full-plan",
                "push_ratio": ratio, "time_ms": total_ms, "assign_ms": assign_ms,
                "order_ms": order_ms, "tour_ms": tour_ms, "lb_tip_ms": lb_tip_ms, "note": note})
        );
    } else {
        println!(
            "{n:>6} {:>9} {:>12} {:>12} {total_ms:>11.1}  {note}; stages re-run alone on the plain assignment (the planner's own: RUST_LOG=nanopush=debug): assignment {assign_ms:.1} ms, order {order_ms:.1} ms, tour {tour_ms:.1} ms, LB_tip {lb_tip_ms:.1} ms",
            "full-plan",
            "",
            ratio.map_or("-".into(), |x| format!("{x:.6}")),
        );
    }
}
