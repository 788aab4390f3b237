//! `nanopush calibrate --recording DIR`: fit the pixel-to-stage map from frames
//! of known stage moves of the tip.
//!
//! Recording format (docs/vision.md): DIR/stage.csv with the header
//! `frame,x_um,y_um`, one row per frame file in DIR (name relative to DIR)
//! giving the stage position (micrometres) when it was taken.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use crate::calib::camera_fit::{LensModel, fit_camera_map};
use crate::calib::camera_map::{CameraCalibration, PLAUSIBLE_UM_PER_PX};
use crate::vision::analyse::{camera_notes, prepare_frame, report_camera_state};
use crate::vision::frame::check_one_size;
use crate::vision::frame_input::{Channel, load_frame};
use crate::vision::tip::{TipSettings, detect_tip};

use super::distinct_outputs::prepare_outputs;
use super::stage_csv::parse_stage_csv;

/// Arguments of `nanopush calibrate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording folder: frames plus stage.csv (frame,x_um,y_um).
    #[arg(long)]
    pub recording: PathBuf,
    /// Output calibration TOML (default DIR/calibration.toml); an existing
    /// file is kept unless --force.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace an existing output file (never one of the recording's inputs).
    #[arg(long)]
    pub force: bool,
    /// Colour frames: luminance, red, green or blue.
    #[arg(long, default_value = "luminance")]
    pub channel: Channel,
    #[command(flatten)]
    pub fit: FitArgs,
}

/// How the map is fitted to the tip positions (`calibrate` and `rig calibrate`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct FitArgs {
    /// RANSAC inlier threshold, pixels.
    #[arg(long, default_value_t = 2.0)]
    pub threshold_px: f64,
    /// The objective's radial distortion: auto keeps it when at least 8 tip
    /// positions spread over the frame show it clearly (else an affine map,
    /// saying why), radial insists, none fits an affine map only.
    #[arg(long, value_enum, default_value_t = LensModel::Auto)]
    pub lens: LensModel,
}

/// Refuses an output that is one of the recording's `inputs` (label,
/// path), or an existing file without `force` (a good calibration is not
/// lost to a re-run).
pub fn check_output(out: &Path, inputs: &[(&str, &Path)], force: bool) -> anyhow::Result<()> {
    check_output_in(out, inputs, force, "file")
}

/// As [`check_output`], for an output that `--out` names a `kind` ("file",
/// or "folder" when it names the folder `out` is written in), so the
/// refusal's advice names what `--out` takes (`study model` had advised
/// "--out another file" for its folder).
pub fn check_output_in(
    out: &Path,
    inputs: &[(&str, &Path)],
    force: bool,
    kind: &str,
) -> anyhow::Result<()> {
    prepare_outputs(inputs, &[("--out", out)])?;
    anyhow::ensure!(
        force || !out.exists(),
        "{} exists: pass --force to replace it, or --out another {kind}",
        out.display()
    );
    Ok(())
}

impl FitArgs {
    /// Refuses an inlier threshold that is not a positive number of pixels.
    pub fn check(&self) -> anyhow::Result<()> {
        let threshold_px = self.threshold_px;
        anyhow::ensure!(
            threshold_px.is_finite() && threshold_px > 0.0,
            "--threshold-px must be a positive number of pixels, got {threshold_px}"
        );
        Ok(())
    }
}

/// Detects the tip in every frame of the recording, fits and writes the map.
pub fn run(args: Args) -> anyhow::Result<()> {
    args.fit.check()?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.recording.join("calibration.toml"));
    fit_recording(&args.recording, &out, args.channel, &args.fit, args.force).map(|_| ())
}

/// Refuses a fitted scale no microscope has: a stage.csv written in metres
/// or millimetres, not micrometres, was fitted to 5e-7 um/px and written
/// with exit 0.
fn check_scale(m_per_px: f64) -> anyhow::Result<()> {
    let um = m_per_px * 1e6;
    if !PLAUSIBLE_UM_PER_PX.contains(&um) {
        bail!(
            "the fit gives {um:.3e} um/px, outside {}-{} um/px: are stage.csv's x_um and y_um in micrometres? \
             (metres or millimetres give a millionth or a thousandth of the true scale)",
            PLAUSIBLE_UM_PER_PX.start(),
            PLAUSIBLE_UM_PER_PX.end()
        );
    }
    Ok(())
}

/// Fits the map to the recording in `dir` and writes it to `out` (kept
/// when it exists, unless `force`; never one of the recording's files),
/// printing each frame's residual and the fit's scale, rotation, lens and
/// RMS. Returns the map written.
pub fn fit_recording(
    dir: &Path,
    out: &Path,
    channel: Channel,
    how: &FitArgs,
    force: bool,
) -> anyhow::Result<CameraCalibration> {
    let csv = dir.join("stage.csv");
    // A run's recording (assemble --record) is another kind of folder: it
    // had been answered "reading DIR/stage.csv: No such file".
    if !csv.exists() && dir.join("recording.toml").exists() {
        anyhow::bail!(
            "{} is a run's recording (recording.toml, stage.jsonl), which `nanopush dry-run --recording` replays; \
             `calibrate` reads a calibration recording: frames of the tip at known stage positions and their stage.csv (frame,x_um,y_um)",
            dir.display()
        );
    }
    let text =
        std::fs::read_to_string(&csv).with_context(|| format!("reading {}", csv.display()))?;
    let rows = parse_stage_csv(&text)?;
    let frames: Vec<PathBuf> = rows.iter().map(|r| dir.join(&r.frame)).collect();
    let inputs: Vec<(&str, &Path)> = std::iter::once(("stage.csv", csv.as_path()))
        .chain(frames.iter().map(|f| ("frame", f.as_path())))
        .collect();
    check_output(out, &inputs, force)?;
    let mut pixels = Vec::new();
    let mut stage = Vec::new();
    let mut used = Vec::new();
    let mut sizes = Vec::new();
    let recording = dir.display().to_string();
    for row in &rows {
        let path = dir.join(&row.frame);
        let frame =
            load_frame(&path, channel).with_context(|| format!("loading {}", path.display()))?;
        sizes.push((frame.width(), frame.height()));
        let prepared = prepare_frame(&frame);
        // A clipped or line-damaged camera is warned of once per recording;
        // the table names the frames (their apexes are what the map is fitted to).
        report_camera_state(
            &recording,
            &prepared.repaired_lines,
            &prepared.exposure,
            frame.max_count(),
        );
        match detect_tip(&prepared.frame, &TipSettings::default()) {
            Some(t) => {
                pixels.push([t.x_px, t.y_px]);
                stage.push([row.x_um * 1e-6, row.y_um * 1e-6]);
                let camera = camera_notes(&prepared.repaired_lines, prepared.exposure.clipped());
                used.push((row.frame.clone(), camera));
            }
            None => eprintln!("{}: no tip found, frame skipped", row.frame),
        }
    }
    check_one_size(&sizes, |k| rows[k].frame.clone()).map_err(anyhow::Error::msg)?;
    let frame_px = sizes.first().copied().unwrap_or_default();
    let fit = fit_camera_map(&pixels, &stage, how.threshold_px, how.lens, frame_px)
        .context("fitting the calibration")?;
    check_scale(fit.calibration.m_per_px())?;
    // Refused now rather than written and then refused by every reader.
    fit.calibration.check_square_pixels().map_err(|e| {
        anyhow::anyhow!(
            "the fit's {e}: are stage.csv's x_um and y_um in one unit, and the stage's axes square to each other?"
        )
    })?;
    println!("frame                          dx_px     dy_px  inlier");
    for ((name, camera), r) in used.iter().zip(&fit.residuals_px) {
        println!(
            "{name:<28} {:9.3} {:9.3}  {}{camera}",
            r.0,
            r.1,
            if r.2 { "yes" } else { "NO" }
        );
    }
    let c = &fit.calibration;
    println!(
        "scale {:.5} um/px, rotation {:.3} deg{}, inliers {}/{}, RMS residual {:.3} px",
        c.m_per_px() * 1e6,
        c.linear[(1, 0)].atan2(c.linear[(0, 0)]).to_degrees(),
        if c.linear.determinant() < 0.0 {
            " (mirrored: the image's y runs against the stage's)"
        } else {
            ""
        },
        fit.inliers,
        pixels.len(),
        fit.rms_px
    );
    let verdict = crate::calib::fit_quality::judge(&fit, &pixels, frame_px);
    if let Some(why) = verdict.refusal {
        anyhow::bail!("the calibration is not written: {why}");
    }
    for warning in &verdict.warnings {
        eprintln!("warning: {warning}");
    }
    match (&c.lens, &fit.lens_skipped) {
        (Some(lens), _) => println!(
            "lens k1 {:+.5}: moves the frame's corners up to {:.2} px; an affine map alone left {:.3} px RMS",
            lens.k1,
            lens.largest_shift_px(frame_px.0, frame_px.1),
            fit.affine_rms_px
        ),
        (None, Some(why)) => println!("lens not fitted: {why}"),
        (None, None) => {}
    }
    std::fs::write(out, c.to_toml(Some((fit.rms_px, fit.inliers))))
        .with_context(|| format!("writing {}", out.display()))?;
    println!("wrote {}", out.display());
    Ok(*c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scale_no_microscope_has_is_refused_naming_the_unit() {
        assert!(check_scale(0.25e-6).is_ok());
        let e = check_scale(0.25e-12).unwrap_err().to_string();
        assert!(
            e.contains("2.500e-7 um/px") && e.contains("micrometres"),
            "{e}"
        );
        assert!(check_scale(0.25e-9).is_err());
        assert!(check_scale(500e-6).is_err());
    }
}
