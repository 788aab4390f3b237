//! `nanopush study plan`: what accuracy costs in time. For each N, a compact
//! block of N sites with 2N particles at 10 % coverage; greedy, exact sparse,
//! dense (N <= 2000) and LP (N <= 60) assignments with their cost ratio to the
//! exact optimum and their time; then the full plan (assignment + order)
//! with its push ratio to LB_push, or the planner's refusal.

use crate::plan::assignment::{AssignmentMethod, assign, block_instance, instance_json};
use crate::plan::pattern::Site;
use crate::plan::{PlanConfig, plan_assembly};
use std::path::PathBuf;
use std::time::Instant;

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
    /// Also plan fully (assignment + order) for each N.
    #[arg(long)]
    pub full: bool,
    /// Write each instance as JSON here (for scripts/peers/scipy_lsa.py).
    #[arg(long)]
    pub dump_dir: Option<PathBuf>,
    /// Print JSON lines instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Runs the study and prints one row per (N, method).
pub fn run(args: Args) -> anyhow::Result<()> {
    if !args.json {
        println!(
            "{:>6} {:>8} {:>12} {:>10} {:>12}",
            "N", "method", "cost_um", "ratio", "time_ms"
        );
    }
    for &n in &args.sizes {
        anyhow::ensure!(n > 0, "--sizes must be positive");
        let (sites, layout) = block_instance(n, args.seed);
        let parts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
        if let Some(dir) = &args.dump_dir {
            std::fs::create_dir_all(dir)?;
            std::fs::write(
                dir.join(format!("block_n{n}.json")),
                instance_json(&sites, &parts),
            )?;
        }
        let mut exact_cost = None;
        for method in [
            AssignmentMethod::Exact,
            AssignmentMethod::Greedy,
            AssignmentMethod::Dense,
            AssignmentMethod::Lp,
        ] {
            if (method == AssignmentMethod::Dense && n > 2000)
                || (method == AssignmentMethod::Lp && n > 60)
            {
                continue;
            }
            let t = Instant::now();
            let a = assign(&sites, &parts, method)?;
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let base = *exact_cost.get_or_insert(a.cost_m);
            let ratio = a.cost_m / base;
            let name = format!("{method:?}").to_lowercase();
            if args.json {
                println!(
                    "{}",
                    serde_json::json!({"schema": "nanopush.study-plan/1", "n": n, "method": name, "cost_um": a.cost_m * 1e6, "ratio": ratio, "time_ms": ms})
                );
            } else {
                println!(
                    "{n:>6} {name:>8} {:>12.1} {ratio:>10.6} {ms:>12.2}",
                    a.cost_m * 1e6
                );
            }
        }
        if args.full {
            let site_list: Vec<Site> = sites
                .iter()
                .enumerate()
                .map(|(i, c)| Site {
                    id: i as u32,
                    centre_m: *c,
                })
                .collect();
            let t = Instant::now();
            let outcome = plan_assembly(&layout, &site_list, &PlanConfig::default());
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let (ratio, note) = match &outcome {
                Ok(p) => (
                    p.summary.push_distance_m / p.summary.lb_push_m,
                    "planned".to_string(),
                ),
                Err(e) => (f64::NAN, format!("refused: {e}")),
            };
            if args.json {
                println!(
                    "{}",
                    serde_json::json!({"schema": "nanopush.study-plan/1", "n": n, "method": "full-plan", "push_ratio": if ratio.is_finite() { Some(ratio) } else { None }, "time_ms": ms, "outcome": note})
                );
            } else {
                println!(
                    "{n:>6} {:>8} {:>12} {ratio:>10.4} {ms:>12.2}  {note}",
                    "fullplan", ""
                );
            }
        }
    }
    Ok(())
}
