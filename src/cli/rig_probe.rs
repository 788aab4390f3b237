//! `nanopush rig probe --rig FILE`: read-only look at a rig's stage
//! controller: identity, syntax version, axes, travel ranges, positions,
//! targets, servo and on-target state, velocities and the pending error.
//! It sends queries only (and `ERR?`, which clears the error it reports).
//! A rig file with a `[coarse]` section gets the same look at the coarse
//! stage's controller.

use crate::rig::gcs::{self, GcsController, RigFile};
use anyhow::Context;
use std::path::PathBuf;

/// Arguments of `nanopush rig probe`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Rig file (TOML, e.g. calib/rig-gcs-sim.toml).
    #[arg(long)]
    pub rig: PathBuf,
    /// Do not open the link: log the bytes that would be sent, answer from a simulator.
    #[arg(long)]
    pub dry_run: bool,
}

/// Connects, queries and prints; never moves anything.
pub fn run(args: Args) -> anyhow::Result<()> {
    let rig = RigFile::load(&args.rig)?;
    let (ctrl, log) = gcs::connect(&rig, args.dry_run)
        .with_context(|| format!("connecting to the stage of {}", args.rig.display()))?;
    show("stage", ctrl, log)?;
    if let Some(coarse) = &rig.coarse {
        let (ctrl, log) = gcs::connect_coarse(coarse, args.dry_run)
            .with_context(|| format!("connecting to the coarse stage of {}", args.rig.display()))?;
        println!();
        show("coarse stage", ctrl, log)?;
    }
    Ok(())
}

/// Probes one controller and prints the report (and, in a dry run, the bytes).
fn show(what: &str, mut ctrl: GcsController, log: Option<gcs::SentLog>) -> anyhow::Result<()> {
    let report =
        probe(&mut ctrl).with_context(|| format!("probing the {what} at {}", ctrl.endpoint()))?;
    println!("{what}:");
    print!("{report}");
    if let Some(log) = log {
        println!("dry run: bytes that would have been sent to the {what}:");
        for bytes in log
            .lock()
            .map_err(|_| anyhow::anyhow!("dry-run log poisoned"))?
            .iter()
        {
            println!("  {:?}", String::from_utf8_lossy(bytes));
        }
    }
    Ok(())
}

fn probe(ctrl: &mut GcsController) -> Result<String, gcs::GcsError> {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "endpoint:       {}", ctrl.endpoint());
    let _ = writeln!(s, "identity:       {}", ctrl.identify()?);
    let _ = writeln!(s, "GCS syntax:     {}", ctrl.syntax_version()?);
    let _ = writeln!(s, "ready (#7):     {}", ctrl.is_ready()?);
    let axes = ctrl.axes()?;
    let refs: Vec<&str> = axes.iter().map(String::as_str).collect();
    let _ = writeln!(s, "axes:           {}", axes.join(" "));
    let (tmn, tmx) = (ctrl.travel_min(&refs)?, ctrl.travel_max(&refs)?);
    let (pos, target) = (ctrl.positions(&refs)?, ctrl.targets(&refs)?);
    let (servo, ont, vel) = (
        ctrl.servo(&refs)?,
        ctrl.on_target(&refs)?,
        ctrl.velocity(&refs)?,
    );
    let _ = writeln!(s, "moving (#5):    0x{:X}", ctrl.motion_mask()?);
    let _ = writeln!(
        s,
        "axis  range (controller units)   position     target       servo  on-target  velocity/s"
    );
    for i in 0..axes.len() {
        let _ = writeln!(
            s,
            "{:<5} [{:>10}, {:>10}]     {:<12} {:<12} {:<6} {:<10} {}",
            axes[i], tmn[i], tmx[i], pos[i], target[i], servo[i], ont[i], vel[i]
        );
    }
    let pending = match ctrl.last_error()? {
        None => "none".to_string(),
        Some(e) => e.to_string(),
    };
    let _ = writeln!(s, "pending error:  {pending}");
    Ok(s)
}
