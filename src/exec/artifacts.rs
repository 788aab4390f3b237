//! What a run leaves for people, besides the journal: force-vs-time plots of
//! its pushes and `report.md`, which ties the figures, the per-site errors,
//! the effects and the files together.
//!
//! The force curves are the pushing model's for each journalled decision
//! (angle, duration, the session time of the push): the simulated rig moves
//! particles with the same model, and a rig with a probe readout would put
//! its measured curve here instead.

use super::assemble::{AssemblySettings, scene_for_push};
use super::push_log::PushRecord;
use super::report::AssemblyReport;
use crate::model::push_sim::{SolverSettings, simulate_push_series};
use crate::model::{PushParams, Scene};
use crate::render::plot::{LineChart, Series};
use crate::wording::counted;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Pushes drawn per force chart (one colour each).
pub const PUSHES_PER_CHART: usize = 6;

/// Writes `pushes-force-<k>.svg` and `.png` charts (force against time since
/// first touch, [`PUSHES_PER_CHART`] pushes each) of the pushes made, each
/// numbered as in the report's table; returns the files written.
pub fn write_force_plots(
    pushes: &[PushRecord],
    scene: &Scene,
    dir: &Path,
) -> Result<Vec<PathBuf>, String> {
    let made: Vec<(usize, &PushRecord)> =
        pushes.iter().filter_map(|p| p.n.map(|n| (n, p))).collect();
    let mut files = Vec::new();
    for (k, chunk) in made.chunks(PUSHES_PER_CHART).enumerate() {
        let mut series = Vec::new();
        for &(number, p) in chunk {
            let s = scene_for_push(scene, scene.particle_radius_m, p.t_s);
            let params = PushParams {
                contact_angle_rad: p.contact_angle_deg.to_radians(),
                speed_m_per_s: scene.push.speed_m_per_s,
                duration_s: p.duration_s,
            };
            let (_, rows) = simulate_push_series(&s, &params, &SolverSettings::default(), 121)
                .map_err(|e| format!("push {number}: {e}"))?;
            series.push(Series {
                name: format!(
                    "push {number} (particle {}, {:.0} deg{})",
                    p.particle_label(),
                    p.contact_angle_deg,
                    if p.repush { ", re-push" } else { "" }
                ),
                points: rows.iter().map(|r| (r.t_s, r.force_n * 1e6)).collect(),
            });
        }
        let (first, last) = (chunk[0].0, chunk[chunk.len() - 1].0);
        let chart = LineChart {
            title: format!("Pushing force, pushes {first}-{last} (model)"),
            x_label: "time since first touch [s]".into(),
            y_label: "force [uN]".into(),
            series,
            markers: false,
            lines: true,
            log_x: false,
        };
        files.extend(chart.write_both(dir, &format!("pushes-force-{}", k + 1))?);
    }
    Ok(files)
}

/// The files `report.md` links to, relative to its folder.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReportFiles {
    /// The last camera frame.
    pub final_frame: Option<String>,
    /// Animations of the run (one per process: the start and each resume).
    pub animations: Vec<String>,
    /// Force charts (PNG; the SVG sits beside each).
    pub force_plots: Vec<String>,
    /// The journal.
    pub journal: String,
    /// Sites in um and pixels.
    pub sites: String,
    /// The machine-readable report.
    pub report_json: String,
}

/// What the run was asked, the command that made it and, for a stopped
/// run, the one that goes on with it (`journal`), as the report's opening.
fn write_asked(md: &mut String, report: &AssemblyReport, journal: &Path) {
    if let Some(a) = &report.asked {
        let _ = writeln!(
            md,
            "Asked: pattern {}, scene {}{}{}.",
            a.pattern,
            a.scene,
            a.layout
                .as_ref()
                .map_or(String::new(), |l| format!(", layout {l}")),
            a.seed.map_or(String::new(), |s| format!(", seed {s}"))
        );
        if let Some(command) = &a.command {
            let _ = writeln!(md, "Command: `{command}`.");
        }
    }
    if report.resumes > 0 {
        let _ = writeln!(
            md,
            "Resumed {} after a stop; the figures cover the whole run unless they say otherwise.",
            counted(report.resumes, "time")
        );
    }
    if !report.finished() {
        let _ = writeln!(
            md,
            "To go on with it: `nanopush assemble --resume {}`.",
            journal.display()
        );
    }
    md.push('\n');
}

/// Writes `report.md`.
pub fn write_report_md(
    path: &Path,
    report: &AssemblyReport,
    sites_um: &[[f64; 2]],
    files: &ReportFiles,
) -> std::io::Result<()> {
    let mut md = String::new();
    let _ = writeln!(md, "# Assembly report\n");
    let _ = writeln!(md, "Outcome: **{}**\n", report.outcome);
    write_asked(&mut md, report, &path.with_file_name(&files.journal));
    let _ = writeln!(md, "| figure | value |\n|---|---|");
    let since_resume = if report.resumes > 0 {
        " (since the last resume)"
    } else {
        ""
    };
    let tolerance_nm = report
        .placed_tolerance_nm
        .unwrap_or(AssemblySettings::default().placed_tolerance_m * 1e9);
    let mut rows = vec![
        (
            "sites filled",
            format!(
                "{}/{} (a particle within {tolerance_nm:.0} nm)",
                report.filled, report.sites
            ),
        ),
        ("placement error", report.placement_error_summary()),
        (
            "pushes",
            format!(
                "{} ({}){}",
                report.pushes,
                counted(report.repushes, "re-push"),
                if report.pushes_not_made > 0 {
                    format!(
                        "; {} more decided but not made (cut off by a stop or a stage fault before the tip went down, or refused)",
                        report.pushes_not_made
                    )
                } else {
                    String::new()
                }
            ),
        ),
        (
            "lost contacts",
            format!(
                "{} detected, {} missed{}",
                report.lost_contacts_detected,
                report
                    .lost_contacts_missed
                    .map_or("unknown".to_owned(), |m| m.to_string()),
                if report.lost_contacts_missed.is_some() {
                    since_resume
                } else {
                    ""
                }
            ),
        ),
        ("time", report.time_summary()),
    ];
    if let Some(n) = report.tip_landings_on_particles {
        rows.push((
            "tip lowered onto a particle",
            format!("{n} times (ground truth){since_resume}"),
        ));
    }
    // The drift estimate is the last process's (it starts again at a resume).
    rows.extend(report.notes().into_iter().map(|(what, note)| match what {
        "tip drift" => (what, format!("{note}{since_resume}")),
        _ => (what, note),
    }));
    for (k, v) in rows {
        let _ = writeln!(md, "| {k} | {v} |");
    }
    let _ = writeln!(md, "\n## Final frame\n");
    match &files.final_frame {
        Some(f) => {
            let _ = writeln!(md, "![final frame]({f})\n");
        }
        None => {
            let _ = writeln!(md, "No frame was analysed.\n");
        }
    }
    let _ = writeln!(md, "## Animation\n");
    if files.animations.is_empty() {
        let _ = writeln!(md, "No animation was written.\n");
    }
    for a in &files.animations {
        let _ = writeln!(
            md,
            "- [{a}]({a}): every analysed frame with sites (cyan), tracked particles (green), the plan (orange), the push being checked (magenta) and the tip (red)"
        );
    }
    let _ = writeln!(md, "\n## Pushing force\n");
    for f in &files.force_plots {
        let _ = writeln!(md, "![pushing force]({f})\n");
    }
    let _ = writeln!(md, "## Per-site placement error\n");
    let _ = writeln!(
        md,
        "| site | x [um] | y [um] | error [nm] | filled |\n|---|---|---|---|---|"
    );
    for (i, (s, e)) in sites_um.iter().zip(&report.site_errors_nm).enumerate() {
        let ok = if *e <= tolerance_nm {
            "yes"
        } else if report.left_short.iter().any(|l| l.site == i) {
            "short"
        } else {
            "no"
        };
        let _ = writeln!(md, "| {i} | {:.2} | {:.2} | {e:.0} | {ok} |", s[0], s[1]);
    }
    let _ = writeln!(md, "\n## Pushes\n");
    let _ = writeln!(
        md,
        "A push is one straight stroke: a particle whose route bends round others is pushed once a leg. \
         \"to\" is the site the push ends on (none: a leg, or a push out of the way); \
         \"#\" numbers the pushes made, as the force charts do (\"-\": not made).{}\n",
        if report.resumes > 0 {
            " Track ids start again at each resume: r1:18 is track 18 after the first."
        } else {
            ""
        }
    );
    let _ = writeln!(
        md,
        "| # | t [s] | particle | to | distance [um] | contact angle [deg] | duration [s] | re-push | result |\n|---|---|---|---|---|---|---|---|---|"
    );
    for p in &report.push_log {
        let _ = writeln!(
            md,
            "| {} | {:.1} | {} | {} | {:.2} | {:.1} | {:.2} | {} | {} |",
            p.n.map_or("-".to_owned(), |n| n.to_string()),
            p.t_s,
            p.particle_label(),
            p.to_site.map_or("-".to_owned(), |s| format!("site {s}")),
            p.distance_um,
            p.contact_angle_deg,
            p.duration_s,
            if p.repush { "yes" } else { "" },
            p.result
        );
    }
    let _ = writeln!(md, "\n## Effects\n");
    let _ = writeln!(
        md,
        "| effect | why | simulated contacts that evaluated it{since_resume} |\n|---|---|---|"
    );
    for e in &report.active_effects {
        let work = report.effect_work.as_ref().map_or("-".to_owned(), |w| {
            w.get(&e.name).copied().unwrap_or(0).to_string()
        });
        let _ = writeln!(md, "| {} | {} | {work} |", e.name, e.reason);
    }
    let _ = writeln!(md, "\n## Files\n");
    let _ = writeln!(
        md,
        "- [{0}]({0}): every command, observation and decision (JSON Lines)",
        files.journal
    );
    let _ = writeln!(
        md,
        "- [{0}]({0}): target sites in um and in the final frame's pixels",
        files.sites
    );
    let _ = writeln!(
        md,
        "- [{0}]({0}): this report, machine-readable",
        files.report_json
    );
    std::fs::write(path, md)
}
