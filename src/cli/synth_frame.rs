//! `nanopush synth frame`: render a synthetic microscope frame and its truth.

use std::path::PathBuf;

use super::distinct_outputs::{flagged, given, prepare_outputs};

use anyhow::Context;

use crate::plan::Layout;
use crate::render::microscope::{RenderSettings, TipView, check_snr, render_frame};
use crate::render::microscope_truth::{
    Truth, check_particle_fits, layout_pixel_map, random_scene, scene_from_layout,
};
use crate::vision::cramer_rao::centre_crb_px;
use crate::vision::frame_input::{hidden_sibling, save_png};

/// Arguments of `nanopush synth frame`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Particle layout ("nanopush.layout/1" JSON, micrometres).
    #[arg(long, conflicts_with = "n", required_unless_present = "n")]
    pub layout: Option<PathBuf>,
    /// Number of randomly placed particles (instead of --layout).
    #[arg(long)]
    pub n: Option<usize>,
    /// Seed: the same seed gives the same frame.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output image, .png or .tif (8- or 16-bit grey).
    #[arg(long)]
    pub out: PathBuf,
    /// Ground-truth JSON ("nanopush.truth/1").
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Calibration TOML mapping the frame's pixels to the layout's
    /// micrometres, for `plan --frame --calib` or a recording (with
    /// --layout; default: --out with its extension replaced by
    /// .calib.toml). An existing file is kept unless --force.
    #[arg(long, conflicts_with = "n")]
    pub calib_out: Option<PathBuf>,
    /// Replace an existing calibration file.
    #[arg(long, conflicts_with = "n")]
    pub force: bool,
    /// Pixel size for --layout, micrometres per pixel (the frame is the
    /// layout's field at this scale).
    #[arg(long, default_value_t = 0.5, conflicts_with = "n")]
    pub um_per_px: f64,
    /// Frame width for --n, pixels (with --layout: the field at --um-per-px).
    #[arg(long, default_value_t = 1024, conflicts_with = "layout")]
    pub width_px: usize,
    /// Frame height for --n, pixels (with --layout: the field at --um-per-px).
    #[arg(long, default_value_t = 1024, conflicts_with = "layout")]
    pub height_px: usize,
    /// Particle radius for --n, pixels (with --layout: each particle's own).
    #[arg(long, default_value_t = 8.0, conflicts_with = "layout")]
    pub radius_px: f64,
    /// Ring signal-to-noise ratio.
    #[arg(long, default_value_t = 20.0)]
    pub snr: f64,
    /// Camera bit depth (8 or 16).
    #[arg(long, default_value_t = 16)]
    pub bits: u8,
    /// Defocus blur in pixels.
    #[arg(long, default_value_t = 0.0)]
    pub defocus_px: f64,
    /// Inverted contrast (dark core, bright ring).
    #[arg(long)]
    pub inverted: bool,
    /// Tip apex x, pixels (with --tip-y-px draws the probe).
    #[arg(long, requires = "tip_y_px")]
    pub tip_x_px: Option<f64>,
    /// Tip apex y, pixels.
    #[arg(long, requires = "tip_x_px")]
    pub tip_y_px: Option<f64>,
    /// Tip axis angle (body to apex), degrees, image axes (y down).
    #[arg(long, default_value_t = 0.0)]
    pub tip_angle_deg: f64,
}

/// Renders the frame and writes it with its truth.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.bits != 8 && args.bits != 16 {
        anyhow::bail!("--bits must be 8 or 16, got {}", args.bits);
    }
    let ext = args.out.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !["png", "tif", "tiff"].contains(&ext.to_ascii_lowercase().as_str()) {
        anyhow::bail!(
            "--out must end in .png or .tif (lossless, so the counts are the ones the truth describes), got {}",
            args.out.display()
        );
    }
    let calib_out = args
        .layout
        .as_ref()
        .map(|_| (args.calib_out.clone()).unwrap_or_else(|| args.out.with_extension("calib.toml")));
    prepare_outputs(
        &given([flagged("--layout", &args.layout)]),
        &given([
            Some(("--out", args.out.as_path())),
            flagged("--truth", &args.truth),
            flagged("--calib-out", &calib_out),
        ]),
    )?;
    if let Some(path) = calib_out.as_ref().filter(|p| p.exists() && !args.force) {
        anyhow::bail!(
            "{} exists: pass --force to replace it, or --calib-out another file",
            path.display()
        );
    }
    check_snr("--snr", args.snr).map_err(anyhow::Error::msg)?;
    let tip = [args.tip_x_px, args.tip_y_px, Some(args.tip_angle_deg)];
    if let Some(bad) = tip.into_iter().flatten().find(|v| !v.is_finite()) {
        anyhow::bail!("--tip-x-px, --tip-y-px and --tip-angle-deg must be numbers, got {bad}");
    }
    // Checked with --layout too: it is the radius of the bound without particles.
    if !(args.radius_px.is_finite() && args.radius_px > 0.0) {
        anyhow::bail!("--radius-px must be finite and > 0, got {}", args.radius_px);
    }
    let mut scene = match (&args.layout, args.n) {
        (Some(path), _) => {
            // Its own errors name the file ("layout file PATH: ...").
            let layout = Layout::read(path)?;
            scene_from_layout(&layout, args.um_per_px)
                .with_context(|| format!("layout {}", path.display()))?
        }
        (None, Some(n)) => {
            check_particle_fits("--radius-px", args.radius_px, args.width_px, args.height_px)?;
            let s = random_scene(n, args.width_px, args.height_px, args.radius_px, args.seed);
            if s.particles.len() < n {
                eprintln!(
                    "note: only {} of {} fit without overlap",
                    s.particles.len(),
                    crate::wording::counted(n, "particle")
                );
            }
            s
        }
        (None, None) => anyhow::bail!("give --layout FILE or --n N"),
    };
    if let (Some(x), Some(y)) = (args.tip_x_px, args.tip_y_px) {
        scene.tip = Some(TipView {
            apex_x_px: x,
            apex_y_px: y,
            angle_rad: args.tip_angle_deg.to_radians(),
        });
    }
    let mut settings = RenderSettings::with_snr(args.snr, args.bits);
    settings.optics.defocus_px = args.defocus_px;
    settings.optics.inverted = args.inverted;
    let frame = render_frame(&scene, &settings, args.seed).context("rendering the frame")?;
    let truth = match &args.truth {
        None => None,
        Some(path) => {
            let r = scene
                .particles
                .first()
                .map_or(args.radius_px, |p| p.radius_px);
            let truth = Truth::of(&scene, args.seed, args.snr, centre_crb_px(r, &settings));
            Some((path, serde_json::to_string_pretty(&truth)?))
        }
    };
    let calib = calib_out
        .as_ref()
        .map(|path| (path, layout_pixel_map(args.um_per_px).to_toml(None)));
    // All files or none: each is written under a hidden name first, and
    // renamed once all are (a frame without its truth passes for a study's input).
    let frame_tmp = hidden_sibling(&args.out);
    let mut written = vec![(frame_tmp.clone(), args.out.clone())];
    let mut renamed = Vec::new();
    let mut write = || -> anyhow::Result<()> {
        save_png(&frame, &frame_tmp).with_context(|| format!("writing {}", args.out.display()))?;
        for (path, text) in truth.iter().chain(&calib) {
            let tmp = hidden_sibling(path);
            written.push((tmp.clone(), path.to_path_buf()));
            std::fs::write(&tmp, text).with_context(|| format!("writing {}", path.display()))?;
        }
        for (tmp, path) in &written {
            std::fs::rename(tmp, path).with_context(|| format!("writing {}", path.display()))?;
            renamed.push(path.clone());
        }
        Ok(())
    };
    if let Err(e) = write() {
        // A truth or calibration that cannot take its name (a folder there)
        // takes the files renamed before it along.
        for path in written.iter().map(|(tmp, _)| tmp).chain(&renamed) {
            let _ = std::fs::remove_file(path);
        }
        return Err(e);
    }
    eprintln!(
        "wrote {} ({}x{}, {}, {}-bit, SNR {})",
        args.out.display(),
        frame.width(),
        frame.height(),
        crate::wording::counted(scene.particles.len(), "particle"),
        args.bits,
        args.snr
    );
    if let Some(path) = &calib_out {
        eprintln!(
            "wrote {}: pixel (x, y), whole at pixel centres and y down, is at ({u} x, {u} y) um in the layout; for `plan --frame --calib` or a recording's `calibration`",
            path.display(),
            u = args.um_per_px
        );
    }
    Ok(())
}
