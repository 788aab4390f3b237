//! `nanopush plan`: pattern + particles -> ordered push plan, with a summary.

use super::distinct_outputs::{flagged, given, prepare_outputs};
use super::pattern_args::PatternArgs;
use anyhow::{Context, bail};
use nanopush_plan_api::*;
use std::path::PathBuf;

mod nanopush_plan_api {
    pub use crate::calib::camera_map::CameraCalibration;
    pub use crate::exec::frame_layout::layout_from_frame;
    pub use crate::plan::layout::MarkedLayout;
    pub use crate::plan::pattern::transform::{Reachable, place_at};
    pub use crate::plan::placement::{PlacementGoal, place_and_plan};
    pub use crate::plan::{
        AssignmentMethod, PlanConfig, PlanError, plan_assembly, plan_file, verify,
    };
    pub use crate::render::plan_on_frame::draw_plan_on_frame;
    pub use crate::render::plan_overlay::{OverlayKind, overlay_kind};
    pub use crate::vision::frame::Frame;
    pub use crate::vision::frame_input::{Channel, first_of_several, load_frame};
    pub use nalgebra::Vector2;
}

/// Arguments of `nanopush plan`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("what").args(["text", "pattern"]).required(true)))]
// Where the particles come from: either is named when neither is given
// (only --layout was).
#[command(group(clap::ArgGroup::new("particles").args(["layout", "frame"]).required(true)))]
pub struct Args {
    /// What to assemble and where.
    #[command(flatten)]
    pub target: PatternArgs,
    /// Particle layout (nanopush.layout/1 JSON); its particles marked
    /// immovable are obstacles, never pushed.
    #[arg(long)]
    pub layout: Option<PathBuf>,
    /// Microscope frame to detect particles in (needs --calib).
    #[arg(long, requires = "calib")]
    pub frame: Option<PathBuf>,
    /// Pixel-to-stage calibration (TOML) for --frame: made on the rig by
    /// `nanopush rig calibrate`, or from frames of known tip moves by
    /// `nanopush calibrate --recording DIR` (format: docs/vision.md).
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// Particle radius in um, for --frame: the detector's size hint, and
    /// the batch's nominal size (each particle found is planned with its
    /// measured one) [default: 5].
    #[arg(long)]
    pub radius_um: Option<f64>,
    /// With --frame, a colour frame: luminance, red, green or blue
    /// [default: luminance].
    #[arg(long)]
    pub channel: Option<Channel>,
    /// With --frame: write the particles found as a layout file (what
    /// `verify-plan --layout` replays the plan on), those the frame's edge
    /// cuts marked immovable; written before planning, so a refused plan
    /// leaves it too.
    #[arg(long)]
    pub save_layout: Option<PathBuf>,
    /// Contact angle of every push, degrees from the substrate normal (0 up to, not including, 90).
    #[arg(long, default_value_t = 0.0)]
    pub contact_angle_deg: f64,
    /// Tip disc radius in um (default: 1 um for particles of 5 um radius
    /// and more, a fifth of the layout's median radius below; the tip's
    /// landing behind the contact point is scaled so too: see docs/plan.md)
    #[arg(long)]
    pub tip_radius_um: Option<f64>,
    /// Pushing speed in um/s (for the predicted time).
    #[arg(long, default_value_t = 1.0)]
    pub speed_um_s: f64,
    /// Assignment method.
    #[arg(long, value_enum, default_value_t = AssignmentMethod::Fast)]
    pub method: AssignmentMethod,
    /// Free space, um, that particles on no site keep from the pattern's
    /// particles where the plan leaves them (so no stray reads as part of a
    /// letter). Default 0: the plain planning problem; `assemble` (and so
    /// `demo`) keeps half the particle radius unless told (2.5 um for 10 um
    /// spheres).
    #[arg(long, default_value_t = 0.0)]
    pub keep_clear_um: f64,
    /// Write the plan here (nanopush.plan/1 JSON).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Draw the plan over the layout (.svg or .png); with --frame, a .png
    /// is drawn over the frame itself, in its pixels.
    #[arg(long)]
    pub overlay: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The particle radius `--frame` assumes without `--radius-um`, um.
const DEFAULT_RADIUS_UM: f64 = 5.0;

/// The particles to plan with: the layout file's, or those found in the
/// frame (written to `--save-layout` when asked), with the tip seen there;
/// either way with those never to be pushed.
fn particles(args: &Args) -> anyhow::Result<Particles> {
    let Some(frame_path) = &args.frame else {
        // Taken and ignored before: the layout's positions are in um already.
        if args.calib.is_some() {
            bail!("--calib is for --frame: a layout's positions are on the stage already");
        }
        // Refused here, not by clap: its "requires" named --frame and --calib
        // as missing, as if they went with --layout.
        let frame_only = [
            ("--radius-um", args.radius_um.is_some()),
            ("--channel", args.channel.is_some()),
            ("--save-layout", args.save_layout.is_some()),
        ];
        if let Some((flag, _)) = frame_only.iter().find(|(_, given)| *given) {
            bail!("{flag} is for --frame: a layout file gives the particles and their sizes");
        }
        let path = args.layout.as_ref().context("give --layout or --frame")?;
        return Ok(Particles {
            marked: MarkedLayout::read(path)?,
            tip_start_m: None,
            seen_in: None,
            beside_probe: 0,
            seen_m: None,
        });
    };
    let calib = args.calib.as_ref().context("--frame needs --calib")?;
    let calibration = CameraCalibration::load(calib)?;
    let frame = load_frame(frame_path, args.channel.unwrap_or(Channel::Luminance))?;
    if let Some(which) = first_of_several(frame_path) {
        eprintln!("{}: planning from {which}", frame_path.display());
    }
    let radius_um = args.radius_um.unwrap_or(DEFAULT_RADIUS_UM);
    let found = layout_from_frame(frame.clone(), &calibration, radius_um * 1e-6)
        .with_context(|| format!("frame {}", frame_path.display()))?;
    // The cut particles, those beside the probe and those beyond the field
    // marked, so that a plan from the saved layout, and its replay, hold
    // them as this one does.
    let beside_probe = found.beside_probe.len();
    let beyond = found.layout.beyond_field_ids();
    let marked = MarkedLayout {
        layout: found.layout,
        immovable: [found.cut_by_edge, found.beside_probe, beyond].concat(),
    };
    // Written before planning: a refused plan still leaves what the frame
    // showed, and says so (it had been left without a word).
    if let Some(path) = &args.save_layout {
        marked.write(path)?;
        if !args.json {
            eprintln!(
                "the particles found are in {} (written before planning)",
                path.display()
            );
        }
    }
    Ok(Particles {
        marked,
        tip_start_m: found.tip_m,
        seen_in: Some((frame, calibration)),
        beside_probe,
        seen_m: Some(found.seen_m),
    })
}

/// Where sites may go: the field less a particle radius, and from a frame
/// only where the camera saw (the field runs from the stage origin, so a
/// calibration putting the frame at (1000, 1000) um had placed sites, and
/// pushed particles, where no particle could have been seen). Says so when
/// `tell` (not with --json, as the other notes).
fn placement_area(
    field_m: [f64; 2],
    radius_m: f64,
    seen_m: Option<[[f64; 2]; 2]>,
    tell: bool,
) -> Reachable {
    let mut area = Reachable::for_field(field_m, radius_m);
    if let Some([lo, _]) = seen_m {
        let seen_lo = Vector2::new(lo[0], lo[1]).add_scalar(radius_m);
        if seen_lo.x > area.lo_m.x || seen_lo.y > area.lo_m.y {
            area.lo_m = area.lo_m.sup(&seen_lo);
            // Said only of a frame a radius or more from the origin: a
            // half-pixel offset of a calibration had been told too.
            if tell && lo[0].max(lo[1]) >= radius_m {
                eprintln!(
                    "the frame starts at ({:.1}, {:.1}) um on the stage: the pattern is placed within what it shows",
                    lo[0] * 1e6,
                    lo[1] * 1e6
                );
            }
        }
    }
    area
}

/// What `nanopush plan` plans with.
struct Particles {
    /// The particles, and the obstacles never pushed: those the frame's
    /// edge cuts, or those the layout file marks.
    marked: MarkedLayout,
    /// The tip seen in the frame.
    tip_start_m: Option<nalgebra::Vector2<f64>>,
    /// The frame the particles were found in, and its calibration.
    seen_in: Option<(Frame, CameraCalibration)>,
    /// How many of the obstacles a frame shows lie beside the probe (the
    /// rest lie beyond the field, `Layout::beyond_field_ids`, or are cut
    /// by its edge).
    beside_probe: usize,
    /// The frame's corners on the stage, when planning from one.
    seen_m: Option<[[f64; 2]; 2]>,
}

/// Refuses, before anything is read or written, outputs that would replace
/// an input or each other, and an overlay of a kind that cannot be drawn
/// (found only after the plan had been written).
fn check_files(args: &Args) -> anyhow::Result<()> {
    let inputs = given([
        flagged("--layout", &args.layout),
        flagged("--frame", &args.frame),
        flagged("--calib", &args.calib),
        flagged("--pattern", &args.target.pattern),
    ]);
    let outputs = given([
        flagged("--out", &args.out),
        flagged("--overlay", &args.overlay),
        flagged("--save-layout", &args.save_layout),
    ]);
    prepare_outputs(&inputs, &outputs)?;
    if let Some(path) = &args.overlay {
        overlay_kind(path)?;
    }
    Ok(())
}

/// `config` checked, its refusal naming the flags that set the values
/// ("push_speed_um_s is 0" had answered --speed-um-s 0); `assemble
/// --keep-clear-um` is checked so too.
pub(super) fn validate_in_flags(config: &PlanConfig) -> anyhow::Result<()> {
    config.validate().map_err(|e| {
        let text = [
            ("tip_radius_um", "--tip-radius-um"),
            ("push_speed_um_s", "--speed-um-s"),
            ("contact_angle_deg", "--contact-angle-deg"),
            ("keep_clear_um", "--keep-clear-um"),
        ]
        .iter()
        .fold(e.to_string(), |t, (name, flag)| t.replace(name, flag));
        anyhow::anyhow!(text)
    })
}

/// Plans and prints the summary; writes the plan and overlay when asked.
pub fn run(args: Args) -> anyhow::Result<()> {
    check_files(&args)?;
    let Particles {
        marked: MarkedLayout { layout, immovable },
        tip_start_m,
        seen_in,
        beside_probe,
        seen_m,
    } = particles(&args)?;
    let radius = layout.max_radius_m();
    if radius <= 0.0 {
        bail!("no particle to plan with");
    }
    let request = args.target.request()?;
    // The pitch of the batch's typical particle, wider when its radii
    // spread; a particle too wide for the sites is left off them
    // (`PlanConfig::site_radius_m`).
    let radii: Vec<f64> = layout.particles.iter().map(|p| p.radius_m).collect();
    let area = placement_area(layout.field_m, radius, seen_m, !args.json);
    let pattern = request.pattern_for_batch(layout.median_radius_m(), &radii, &area)?;
    let scaled = PlanConfig {
        contact_angle_rad: args.contact_angle_deg.to_radians(),
        push_speed_m_per_s: args.speed_um_s * 1e-6,
        method: args.method,
        tip_start_m,
        immovable,
        keep_clear_m: args.keep_clear_um * 1e-6,
        ..PlanConfig::default()
    }
    .with_tip_scaled_to(layout.median_radius_m());
    let config = PlanConfig {
        tip_radius_m: args
            .tip_radius_um
            .map_or(scaled.tip_radius_m, |um| um * 1e-6),
        ..scaled
    };
    validate_in_flags(&config)?;
    let placing = std::time::Instant::now();
    let plan = match request.at_m {
        Some(at) => plan_assembly(&layout, &place_at(&pattern, at, &area, radius)?, &config)?,
        None => {
            let placed =
                place_and_plan(&pattern, &area, &layout, &config, PlacementGoal::LeastPush)?;
            match placed.plan {
                Some(Ok(plan)) => plan,
                Some(Err(e @ PlanError::Blocked(_))) if placed.centres_tried > 1 => {
                    return Err(anyhow::Error::new(e).context(format!(
                        "none of the {} placements tried plans (the refusal at the best by the push bound follows)",
                        placed.centres_tried
                    )));
                }
                Some(Err(e)) => return Err(e.into()),
                None => plan_assembly(&layout, &placed.sites, &config)?,
            }
        }
    };
    let placing_s = placing.elapsed().as_secs_f64();
    if let Some(out) = &args.out {
        plan_file::write(&plan, &config, out)?;
    }
    if let Some(path) = &args.overlay {
        let is_png = overlay_kind(path)? == OverlayKind::Png;
        match &seen_in {
            Some((frame, calibration)) if is_png => {
                draw_plan_on_frame(&plan, &layout, tip_start_m, frame, calibration)
                    .map_err(anyhow::Error::msg)?
                    .save(path)
                    .with_context(|| format!("overlay {}", path.display()))?;
            }
            _ => crate::render::plan_overlay::draw(&plan, &layout, path)?,
        }
    }
    let report = verify::verify_plan(&plan, &layout, &config);
    let mut summary = plan_file::summary_json(&plan.summary);
    summary["schema"] = "nanopush.plan-summary/1".into();
    summary["sites"] = plan.sites.len().into();
    summary["verified"] = report.ok.into();
    summary["placement_and_planning_time_s"] = placing_s.into();
    summary["standoff_um"] = (plan.standoff_m * 1e6).into();
    // Where the pattern went, as `--at` takes it (the centre of the sites'
    // box): the summary had not said, so a user could not keep a placement.
    let centres: Vec<_> = plan.sites.iter().map(|s| s.centre_m).collect();
    let (lo, hi) = crate::plan::pattern::bbox(&centres);
    let centre_um = (lo + hi) * 0.5e6;
    summary["centre_um"] = serde_json::json!([centre_um.x, centre_um.y]);
    summary["nearest_stray_gap_um"] = report.nearest_stray_gap_um.into();
    summary["keep_clear_um"] = args.keep_clear_um.into();
    let held = config.immovable.len();
    let beyond_field = layout.beyond_field_ids().len();
    if args.frame.is_some() {
        summary["particles_found"] = (layout.particles.len() - held).into();
        summary["particles_cut_by_edge"] = (held - beside_probe - beyond_field).into();
        summary["particles_beside_probe"] = beside_probe.into();
        summary["particles_beyond_field"] = beyond_field.into();
    } else {
        summary["particles_immovable"] = held.into();
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        let s = &plan.summary;
        if args.frame.is_some() {
            let beyond = match beyond_field {
                0 => String::new(),
                n => format!(", +{n} beyond the field"),
            };
            println!(
                "particles found  {} (+{} cut by the frame's edge, +{beside_probe} beside the probe{beyond}: obstacles, not pushed)",
                layout.particles.len() - held,
                held - beside_probe - beyond_field,
            );
        } else if held > 0 {
            println!("immovable        {held} (marked in the layout: obstacles, not pushed)");
        }
        let (x, y) = (format!("{:.2}", centre_um.x), format!("{:.2}", centre_um.y));
        println!(
            "sites            {} centred at ({x}, {y}) um (--at {x},{y} places them there again)",
            plan.sites.len(),
        );
        println!(
            "pushes           {} ({} buffer/detour)",
            s.pushes, s.buffer_pushes
        );
        println!(
            "push distance    {:.1} um (LB_push {:.1} um, ratio {:.3})",
            s.push_distance_m * 1e6,
            s.lb_push_m * 1e6,
            plan_file::ratio(s.push_distance_m, s.lb_push_m)
        );
        println!(
            "tip travel       {:.1} um (LB_tip {:.1} um)",
            s.tip_travel_m * 1e6,
            s.lb_tip_m * 1e6
        );
        println!(
            "push + tip ratio {:.3} to LB_push + LB_tip",
            plan_file::ratio(s.push_distance_m + s.tip_travel_m, s.lb_push_m + s.lb_tip_m)
        );
        if plan.standoff_m < config.standoff_m {
            println!(
                "tip landing      {} um behind contact ({} um left particles the tip could not get behind)",
                plan.standoff_m * 1e6,
                config.standoff_m * 1e6
            );
        }
        if let Some(gap) = report.nearest_stray_gap_um {
            println!(
                "nearest stray    {gap:.2} um from the pattern's particles (a particle on no site; --keep-clear-um {} kept)",
                args.keep_clear_um
            );
        }
        println!("coarse moves     {}", s.coarse_moves);
        println!("predicted time   {:.1} s", s.predicted_time_s);
        println!("planning time    {:.2} ms", s.planning_time_s * 1e3);
        println!(
            "with placement   {:.2} ms (the candidate placements planned in full)",
            placing_s * 1e3
        );
        println!(
            "verify-plan      {}",
            if report.ok { "ok" } else { "FAILED" }
        );
        let written = [&args.save_layout, &args.out, &args.overlay];
        for path in written.into_iter().flatten() {
            println!("wrote            {}", path.display());
        }
    }
    if !report.ok {
        bail!("the plan failed its own replay: {}", report.summary());
    }
    Ok(())
}
