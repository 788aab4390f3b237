//! `nanopush verify-plan`: independent geometric replay of a plan file.

use crate::plan::layout::MarkedLayout;
use crate::plan::plan_file::PlanGeometry;
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
    /// Replay with this tip radius (um) instead of the plan's: a
    /// collaborator's plan checked against your own probe.
    #[arg(long)]
    pub tip_radius_um: Option<f64>,
    /// Replay with the tip landing this far (um) behind the contact point
    /// instead of the plan's standoff.
    #[arg(long)]
    pub standoff_um: Option<f64>,
    /// Replay with this nanostage range (um) instead of the plan's.
    #[arg(long)]
    pub nanostage_range_um: Option<f64>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The geometry to replay with, and where each value came from: a flag,
/// the plan, or `nanopush plan`'s default for the layout's particles
/// (median radius `radius_m`) when the plan gives none.
fn replayed_geometry(
    args: &Args,
    in_plan: Option<PlanGeometry>,
    radius_m: f64,
) -> anyhow::Result<(PlanGeometry, [&'static str; 3])> {
    let base = in_plan.unwrap_or_else(|| PlanGeometry::for_particle_radius(radius_m));
    let from_plan = if in_plan.is_some() {
        "the plan's"
    } else {
        "default: the plan gives none"
    };
    let pick = |flag: Option<f64>, planned: f64| match flag {
        Some(v) => (v, "given"),
        None => (planned, from_plan),
    };
    let (tip, tip_from) = pick(args.tip_radius_um, base.tip_radius_um);
    let (standoff, standoff_from) = pick(args.standoff_um, base.standoff_um);
    let (range, range_from) = pick(args.nanostage_range_um, base.nanostage_range_um);
    let geometry = PlanGeometry {
        tip_radius_um: tip,
        standoff_um: standoff,
        nanostage_range_um: range,
    };
    geometry
        .check()
        .map_err(|e| anyhow::anyhow!("geometry to replay with: {e}"))?;
    Ok((geometry, [tip_from, standoff_from, range_from]))
}

/// A plan that was replayed and failed: the one error `verify-plan` exits
/// 1 for.
#[derive(Debug, thiserror::Error)]
#[error("plan {plan} failed verification: {summary}")]
pub struct FailedVerification {
    plan: String,
    summary: String,
}

/// `verify-plan`'s exit code for `err`, as diff and cmp do: 1 when the plan
/// was replayed and failed, 2 when it could not be checked (a file missing
/// or unreadable, a bad flag). Both had been 1, and a script gating on the
/// check took a mistyped path for a bad plan.
pub fn exit_code(err: &anyhow::Error) -> u8 {
    if err.is::<FailedVerification>() { 1 } else { 2 }
}

/// Replays the plan; exits non-zero when anything is wrong ([`exit_code`]).
pub fn run(args: Args) -> anyhow::Result<()> {
    if !args.tolerance_um.is_finite() || args.tolerance_um < 0.0 {
        anyhow::bail!(
            "--tolerance-um must be finite and >= 0, got {}",
            args.tolerance_um
        );
    }
    let marked = MarkedLayout::read(&args.layout)?;
    let (plan, in_plan) = plan_file::read(&args.plan)?;
    let (geometry, sources) = replayed_geometry(&args, in_plan, marked.layout.median_radius_m())?;
    let rep = verify::verify_plan_with(
        &plan,
        &marked.layout,
        &marked.immovable,
        &geometry,
        args.tolerance_um * 1e-6,
    );
    if args.json {
        let mut doc = serde_json::to_value(&rep)?;
        let names = geometry.named().map(|(name, _)| name);
        doc["geometry_from"] = names
            .iter()
            .zip(sources)
            .map(|(n, s)| (n.to_string(), serde_json::Value::from(s)))
            .collect();
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        let g = &geometry;
        // To the picometre: a tip scaled to the particles read 0.09999999999999998 um.
        let um = |v: f64| (v * 1e6).round() / 1e6;
        println!(
            "geometry          tip radius {} um ({}), standoff {} um ({}), nanostage range {} um ({})",
            um(g.tip_radius_um),
            sources[0],
            um(g.standoff_um),
            sources[1],
            um(g.nanostage_range_um),
            sources[2]
        );
        println!("pushes replayed   {}", rep.pushes);
        println!("collisions        {}", rep.collisions.len());
        for c in rep.collisions.iter().take(20) {
            println!("  step {}: {}", c.step, c.describe());
        }
        println!("bad starts        {:?}", rep.bad_starts);
        if !rep.unknown_particles.is_empty() {
            println!("unknown particles {:?}", rep.unknown_particles);
        }
        println!("bad approaches    {:?}", rep.bad_approaches);
        println!("unreachable       {:?}", rep.unreachable);
        println!("left the field    {:?}", rep.left_field);
        println!("moved immovable   {:?}", rep.moved_immovable);
        println!("unfilled sites    {:?}", rep.unfilled_sites);
        for (site, particle) in &rep.held_by_others {
            println!(
                "  site {site} has particle {particle} on it, which the assignment pairs otherwise"
            );
        }
        println!("max final error   {:.4} um", rep.max_final_error_um);
        if let Some(gap) = rep.nearest_stray_gap_um {
            println!(
                "nearest stray     {gap:.2} um from a site's particle (a particle on no site)"
            );
        }
        println!("result            {}", if rep.ok { "ok" } else { "FAILED" });
    }
    if !rep.ok {
        return Err(FailedVerification {
            plan: args.plan.display().to_string(),
            summary: rep.summary(),
        }
        .into());
    }
    Ok(())
}
