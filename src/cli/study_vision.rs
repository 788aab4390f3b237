//! `nanopush study vision`: what accuracy costs in time. Every locator on
//! synthetic frames at several SNRs: recall, precision, centre RMS error against
//! truth and against the Cramer-Rao bound, radius error, time per frame.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use serde::Serialize;

use crate::render::microscope::{RenderSettings, check_snr, render_frame};
use crate::render::microscope_truth::{check_particle_fits, random_scene};
use crate::vision::cramer_rao::centre_crb_px;
use crate::vision::detect::{DetectSettings, Locator, detect_particles};
use crate::vision::matching::match_points;

/// Arguments of `nanopush study vision`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Ring SNRs to study.
    #[arg(long, value_delimiter = ',', default_value = "4,8,16,32")]
    pub snr: Vec<f64>,
    /// Frames per SNR.
    #[arg(long, default_value_t = 3)]
    pub frames: usize,
    /// Frame side, pixels.
    #[arg(long, default_value_t = 512)]
    pub size_px: usize,
    /// Particles per frame.
    #[arg(long, default_value_t = 40)]
    pub particles: usize,
    /// Particle radius, pixels.
    #[arg(long, default_value_t = 8.0)]
    pub radius_px: f64,
    /// Camera bit depth.
    #[arg(long, default_value_t = 16)]
    pub bits: u8,
    /// Seed of the first frame.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the table as Markdown and JSON here (FILE.md, FILE.json).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace FILE.md and FILE.json when they exist (refused without it: a
    /// document holding more than the table would lose the rest).
    #[arg(long)]
    pub force: bool,
}

/// One row of the study.
#[derive(Debug, Serialize)]
pub struct StudyRow {
    pub locator: Locator,
    pub snr: f64,
    pub recall: f64,
    pub precision: f64,
    pub rms_px: f64,
    pub crb_px: f64,
    pub rms_over_crb: f64,
    pub radius_error_pct: f64,
    pub ms_per_frame: f64,
}

/// Runs the study and prints (and optionally writes) the table.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.frames > 0, "--frames must be > 0");
    anyhow::ensure!(args.bits == 8 || args.bits == 16, "--bits must be 8 or 16");
    anyhow::ensure!(
        args.particles > 0,
        "--particles must be > 0 (a frame without particles has no accuracy to study)"
    );
    // Before the bound, whose cost grows with the particle's area.
    check_particle_fits("--radius-px", args.radius_px, args.size_px, args.size_px)?;
    for &snr in &args.snr {
        check_snr("--snr", snr).map_err(anyhow::Error::msg)?;
    }
    let outputs = args
        .out
        .as_deref()
        .map(|out| study_outputs(out, args.force))
        .transpose()?;
    let mut rows = Vec::new();
    let mut placed: Vec<usize> = Vec::new();
    for &snr in &args.snr {
        let settings = RenderSettings::with_snr(snr, args.bits);
        let crb = centre_crb_px(args.radius_px, &settings).unwrap_or(f64::NAN);
        let frames: Vec<_> = (0..args.frames as u64)
            .map(|k| {
                let scene = random_scene(
                    args.particles,
                    args.size_px,
                    args.size_px,
                    args.radius_px,
                    args.seed + k,
                );
                let frame = render_frame(&scene, &settings, args.seed + k)?;
                Ok((scene, frame))
            })
            .collect::<anyhow::Result<_>>()?;
        placed.extend(frames.iter().map(|(scene, _)| scene.particles.len()));
        anyhow::ensure!(
            placed.iter().all(|&n| n > 0),
            "no sphere of --radius-px {} fits a {} px frame clear of its edges: nothing to study",
            args.radius_px,
            args.size_px
        );
        for locator in Locator::ALL {
            let detect = DetectSettings {
                diameter_px: 2.0 * args.radius_px + 1.0,
                locator,
                ..DetectSettings::default()
            };
            let (mut matched, mut nref, mut nfound, mut ss, mut rerr, mut secs) =
                (0, 0, 0, 0.0, 0.0, 0.0);
            for (scene, frame) in &frames {
                let t0 = Instant::now();
                let found = detect_particles(frame, &detect)?;
                secs += t0.elapsed().as_secs_f64();
                let truth: Vec<[f64; 2]> =
                    scene.particles.iter().map(|p| [p.x_px, p.y_px]).collect();
                let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
                let m = match_points(&truth, &pts, args.radius_px);
                for &(i, j, dx, dy) in &m.pairs {
                    ss += dx * dx + dy * dy;
                    rerr += (found[j].r_px / scene.particles[i].radius_px - 1.0).abs();
                }
                matched += m.pairs.len();
                nref += m.n_reference;
                nfound += m.n_found;
            }
            let rms = if matched > 0 {
                (ss / (2.0 * matched as f64)).sqrt()
            } else {
                f64::NAN
            };
            rows.push(StudyRow {
                locator,
                snr,
                recall: matched as f64 / nref.max(1) as f64,
                precision: if nfound > 0 {
                    matched as f64 / nfound as f64
                } else {
                    1.0
                },
                rms_px: rms,
                crb_px: crb,
                rms_over_crb: rms / crb,
                radius_error_pct: 100.0 * rerr / matched.max(1) as f64,
                ms_per_frame: 1e3 * secs / args.frames as f64,
            });
        }
    }
    let mut md = format!(
        "Synthetic {}x{} {}-bit frames, {} spheres of radius {} px, {} frame(s) per SNR, seed {}.\n\n\
         | locator | SNR | recall | precision | centre RMS px | CRB px | RMS/CRB | radius err % | ms/frame |\n\
         |---|---|---|---|---|---|---|---|---|\n",
        args.size_px,
        args.size_px,
        args.bits,
        spheres_text(&placed, args.particles),
        args.radius_px,
        args.frames,
        args.seed
    );
    for r in &rows {
        md += &format!(
            "| {} | {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.2} | {:.2} | {:.2} |\n",
            r.locator,
            r.snr,
            r.recall,
            r.precision,
            r.rms_px,
            r.crb_px,
            r.rms_over_crb,
            r.radius_error_pct,
            r.ms_per_frame
        );
    }
    print!("{md}");
    if let Some([md_path, json_path]) = outputs {
        std::fs::write(&md_path, &md).with_context(|| format!("writing {}", md_path.display()))?;
        let json = serde_json::json!({"schema": "nanopush.study-vision/1", "rows": rows});
        std::fs::write(&json_path, serde_json::to_string_pretty(&json)?)
            .with_context(|| format!("writing {}", json_path.display()))?;
        println!(
            "table: {}  data: {}",
            md_path.display(),
            json_path.display()
        );
    }
    Ok(())
}

/// FILE.md and FILE.json for `--out FILE`: a given `.md` or `.json` is
/// dropped, any other dot kept (`run.2026.11.29` had written
/// `run.2026.11.md`); refused, before the study's minutes of work, when
/// FILE is a folder or either file exists without `force`; their folder
/// made.
fn study_outputs(out: &std::path::Path, force: bool) -> anyhow::Result<[PathBuf; 2]> {
    let text = out.to_string_lossy();
    anyhow::ensure!(
        !out.is_dir() && !text.ends_with('/'),
        "--out {text} is a folder: give a file name (FOLDER/study-vision writes study-vision.md and .json there)"
    );
    let stem = match out.extension().and_then(|e| e.to_str()) {
        Some("md" | "json") => out.with_extension(""),
        _ => out.to_path_buf(),
    };
    let with = |ext: &str| {
        let mut name = stem.clone().into_os_string();
        name.push(ext);
        PathBuf::from(name)
    };
    let paths = [with(".md"), with(".json")];
    for path in &paths {
        // Makes the folder, as every command does before it works.
        super::calibrate::check_output(path, &[], force)?;
    }
    Ok(paths)
}

/// How many spheres the frames hold: the number asked for, or as many as
/// fitted without overlap when that is fewer (the header must not claim
/// spheres that were never drawn).
fn spheres_text(placed: &[usize], asked: usize) -> String {
    let lo = placed.iter().copied().min().unwrap_or(0);
    let hi = placed.iter().copied().max().unwrap_or(0);
    match (lo == asked, lo == hi) {
        (true, _) => asked.to_string(),
        (false, true) => format!("{lo} (of {asked} asked; no more fit)"),
        (false, false) => format!("{lo} to {hi} (of {asked} asked; no more fit)"),
    }
}

#[cfg(test)]
mod tests {
    use super::{spheres_text, study_outputs};
    use std::path::PathBuf;

    #[test]
    fn the_outputs_keep_the_name_given_and_refuse_to_replace() {
        let dir = tempfile::tempdir().unwrap();
        let at = |name: &str| dir.path().join(name);
        let paths = study_outputs(&at("run.2026.11.29"), false).unwrap();
        assert_eq!(paths, [at("run.2026.11.29.md"), at("run.2026.11.29.json")]);
        let paths = study_outputs(&at("table.md"), false).unwrap();
        assert_eq!(paths, [at("table.md"), at("table.json")]);
        assert!(study_outputs(dir.path(), false).is_err());
        std::fs::write(at("table.json"), "{}").unwrap();
        let err = study_outputs(&at("table"), false).unwrap_err().to_string();
        assert!(
            err.contains("table.json exists") && err.contains("--force"),
            "{err}"
        );
        assert!(study_outputs(&at("table"), true).is_ok());
        assert_eq!(
            study_outputs(&PathBuf::from("docs/study-vision"), true).unwrap()[0],
            PathBuf::from("docs/study-vision.md")
        );
    }

    #[test]
    fn the_header_counts_the_spheres_drawn() {
        assert_eq!(spheres_text(&[40, 40], 40), "40");
        assert_eq!(
            spheres_text(&[91, 91], 100000),
            "91 (of 100000 asked; no more fit)"
        );
        assert_eq!(
            spheres_text(&[90, 93], 100000),
            "90 to 93 (of 100000 asked; no more fit)"
        );
    }
}
