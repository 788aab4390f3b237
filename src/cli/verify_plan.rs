//! `nanopush verify-plan`: independent geometric replay of a plan file.

use crate::plan::layout::MarkedLayout;
use crate::plan::{plan_file, verify};
use std::path::PathBuf;

/// Arguments of `nanopush verify-plan`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Plan file (nanopush.plan/1).
    pub plan: PathBuf,
    /// The layout the plan starts from (its particles marked immovable
    /// must not be pushed).
    #[arg(long)]
    pub layout: PathBuf,
    /// Allowed final position error in um.
    #[arg(long, default_value_t = 0.25)]
    pub tolerance_um: f64,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Replays the plan; exits non-zero when anything is wrong.
pub fn run(args: Args) -> anyhow::Result<()> {
    if !args.tolerance_um.is_finite() || args.tolerance_um < 0.0 {
        anyhow::bail!(
            "--tolerance-um must be finite and >= 0, got {}",
            args.tolerance_um
        );
    }
    let marked = MarkedLayout::read(&args.layout)?;
    let (plan, geometry) = plan_file::read(&args.plan)?;
    let rep = verify::verify_plan_with(
        &plan,
        &marked.layout,
        &marked.immovable,
        &geometry,
        args.tolerance_um * 1e-6,
    );
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rep)?);
    } else {
        println!("pushes replayed   {}", rep.pushes);
        println!("collisions        {}", rep.collisions.len());
        for c in rep.collisions.iter().take(20) {
            println!(
                "  step {}: particle {} ({}) hits particle {} by {:.3} um",
                c.step, c.particle, c.by, c.other, c.depth_um
            );
        }
        println!("bad starts        {:?}", rep.bad_starts);
        println!("bad approaches    {:?}", rep.bad_approaches);
        println!("unreachable       {:?}", rep.unreachable);
        println!("left the field    {:?}", rep.left_field);
        println!("moved immovable   {:?}", rep.moved_immovable);
        println!("unfilled sites    {:?}", rep.unfilled_sites);
        println!("max final error   {:.4} um", rep.max_final_error_um);
        println!("result            {}", if rep.ok { "ok" } else { "FAILED" });
    }
    if !rep.ok {
        anyhow::bail!(
            "plan {} failed verification: {}",
            args.plan.display(),
            rep.summary()
        );
    }
    Ok(())
}
