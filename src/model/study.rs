//! What accuracy costs in time: each solver setting against its error in
//! onset time and displacement (relative to a tight-tolerance reference) and
//! its wall time per push (median of repeats). Used by `nanopush study model`.

use super::contact::ContactModel;
use super::critical_force::AreaFidelity;
use super::error::ModelError;
use super::push_sim::{SolverSettings, simulate_push_with};
use super::scene::Scene;
use crate::median::upper_median;
use crate::render::plot::{LineChart, Series};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// One study row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyRow {
    /// Scene name.
    pub scene: String,
    /// Setting label.
    pub setting: String,
    /// Outcome under this setting.
    pub outcome: String,
    /// Onset (s) (None: nothing moved).
    pub onset_s: Option<f64>,
    /// |onset - reference onset| (s) (None when either is missing).
    pub onset_error_s: Option<f64>,
    /// |displacement - reference| (um).
    pub displacement_error_um: f64,
    /// Median wall time per push (us).
    pub wall_us: f64,
}

/// The settings compared, with labels. The first is the reference.
pub fn settings() -> Vec<(String, SolverSettings)> {
    let d = SolverSettings::default();
    let mut v = vec![(
        "reference (tol 1e-10 s; 512 samples)".to_string(),
        SolverSettings {
            event_tolerance_s: 1e-10,
            samples: 512,
            force_relative_tolerance: 1e-13,
            ..d
        },
    )];
    v.push(("default (tol 1e-6 s; 32 samples)".into(), d));
    for tol in [1e-2, 1e-4, 1e-8] {
        v.push((
            format!("event tol {tol:e} s"),
            SolverSettings {
                event_tolerance_s: tol,
                ..d
            },
        ));
    }
    for n in [2usize, 8, 128] {
        v.push((format!("{n} samples"), SolverSettings { samples: n, ..d }));
    }
    v.push((
        "zero-load areas".into(),
        SolverSettings {
            fidelity: AreaFidelity::ZeroLoad,
            ..d
        },
    ));
    for m in [
        ContactModel::Hertz,
        ContactModel::Dmt,
        ContactModel::Jkr,
        ContactModel::MaugisDugdale,
    ] {
        v.push((
            format!("all contacts {}", m.name()),
            SolverSettings {
                contact_override: Some(m),
                ..d
            },
        ));
    }
    v
}

/// Runs the study on named scenes with `repeats` timing repeats per setting.
pub fn run_study(scenes: &[(String, Scene)], repeats: usize) -> Result<Vec<StudyRow>, ModelError> {
    let mut rows = Vec::new();
    for (name, scene) in scenes {
        let sets = settings();
        let reference = simulate_push_with(scene, &scene.push, &sets[0].1)?;
        for (label, s) in &sets {
            let r = simulate_push_with(scene, &scene.push, s)?;
            let mut times = Vec::with_capacity(repeats);
            for _ in 0..repeats.max(1) {
                let t0 = Instant::now();
                let out = simulate_push_with(scene, &scene.push, s)?;
                times.push(t0.elapsed().as_secs_f64() * 1e6);
                std::hint::black_box(out);
            }
            rows.push(StudyRow {
                scene: name.clone(),
                setting: label.clone(),
                outcome: r.outcome.name().into(),
                onset_s: r.onset_s,
                onset_error_s: r.onset_s.zip(reference.onset_s).map(|(a, b)| (a - b).abs()),
                displacement_error_um: (r.displacement_m - reference.displacement_m).abs() * 1e6,
                wall_us: upper_median(&mut times).unwrap_or(0.0),
            });
        }
    }
    Ok(rows)
}

fn opt(v: Option<f64>) -> String {
    v.map_or("n/a".into(), |v| format!("{v:.3e}"))
}

/// The table as Markdown.
pub fn to_markdown(rows: &[StudyRow]) -> String {
    let mut s = String::from(
        "| scene | setting | outcome | onset [s] | onset error [s] | displacement error [um] | wall time [us] |\n|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.3e} | {:.1} |",
            r.scene,
            r.setting,
            r.outcome,
            r.onset_s.map_or("none".into(), |v| format!("{v:.6}")),
            opt(r.onset_error_s),
            r.displacement_error_um,
            r.wall_us
        );
    }
    s
}

/// The table as CSV (empty cell = not applicable).
pub fn to_csv(rows: &[StudyRow]) -> String {
    let mut s =
        String::from("scene,setting,outcome,onset_s,onset_error_s,displacement_error_um,wall_us\n");
    let o = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{}",
            r.scene,
            r.setting,
            r.outcome,
            o(r.onset_s),
            o(r.onset_error_s),
            r.displacement_error_um,
            r.wall_us
        );
    }
    s
}

/// Reads CSV written by [`to_csv`].
pub fn from_csv(text: &str) -> Result<Vec<StudyRow>, String> {
    let mut lines = text.lines();
    lines.next().ok_or("empty study CSV")?;
    let num = |s: &str| -> Result<Option<f64>, String> {
        if s.is_empty() {
            Ok(None)
        } else {
            s.parse().map(Some).map_err(|e| format!("{s}: {e}"))
        }
    };
    lines
        .filter(|l| !l.is_empty())
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            if c.len() != 7 {
                return Err(format!("expected 7 columns: {l}"));
            }
            Ok(StudyRow {
                scene: c[0].into(),
                setting: c[1].into(),
                outcome: c[2].into(),
                onset_s: num(c[3])?,
                onset_error_s: num(c[4])?,
                displacement_error_um: num(c[5])?.ok_or("missing displacement error")?,
                wall_us: num(c[6])?.ok_or("missing wall time")?,
            })
        })
        .collect()
}

/// Error-vs-time chart: one line per scene, points = settings (sorted by time).
pub fn chart(rows: &[StudyRow]) -> LineChart {
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    let series = scenes
        .iter()
        .map(|s| {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.scene == *s)
                .map(|r| {
                    (
                        r.wall_us,
                        r.onset_error_s.map_or(f64::NAN, |e| e.max(1e-12).log10()),
                    )
                })
                .collect();
            Series {
                name: s.to_string(),
                points: pts,
            }
        })
        .collect();
    LineChart {
        title: "pushing model: onset error vs wall time per push (one point per solver setting)"
            .into(),
        x_label: "wall time per push [us] (log)".into(),
        y_label: "log10 onset error [s] (floor 1e-12)".into(),
        series,
        markers: true,
        lines: false,
        log_x: true,
    }
}

/// The name every file of [`write_outputs`] starts with.
const OUTPUT_STEM: &str = "study-model";

/// The files [`write_outputs`] writes into `dir`: the table (Markdown, CSV)
/// and the plot (SVG, PNG).
pub fn output_paths(dir: &Path) -> [std::path::PathBuf; 4] {
    ["md", "csv", "svg", "png"].map(|ext| dir.join(format!("{OUTPUT_STEM}.{ext}")))
}

/// Writes `study-model.md`, `study-model.csv` and `study-model.{svg,png}` into `dir`.
pub fn write_outputs(dir: &Path, rows: &[StudyRow]) -> Result<Vec<std::path::PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let [md, csv, ..] = output_paths(dir);
    let write = |path: &Path, text: String| {
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    write(
        &md,
        format!(
            "# Pushing-model study: accuracy vs time\n\nGenerated by `nanopush study model --out docs --force`. Errors are against the reference row of each scene; wall time is the median of repeats on this machine.\n\n{}",
            to_markdown(rows)
        ),
    )?;
    write(&csv, to_csv(rows))?;
    let mut out = vec![md, csv];
    out.extend(chart(rows).write_both(dir, OUTPUT_STEM)?);
    Ok(out)
}
