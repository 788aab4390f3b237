//! What a run leaves for people, besides the journal: force-vs-time plots of
//! its pushes and `report.md`, which ties the figures, the per-site errors,
//! the effects and the files together.
//!
//! The force curves are the pushing model's for each journalled decision
//! (angle, duration, the session time of the push): the simulated rig moves
//! particles with the same model, and a rig with a probe readout would put
//! its measured curve here instead.

use super::assemble::{AssemblySettings, scene_for_push};
use super::events::RunEvent;
use super::journal::Entry;
use super::report::AssemblyReport;
use crate::model::push_sim::{SolverSettings, simulate_push_series};
use crate::model::{PushParams, Scene};
use crate::render::plot::{LineChart, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Pushes drawn per force chart (one colour each).
pub const PUSHES_PER_CHART: usize = 6;

/// One push as the journal has it, for plots and tables.
#[derive(Debug, Clone, PartialEq)]
pub struct JournalPush {
    /// Rig time of the decision, seconds.
    pub t_s: f64,
    /// Track id.
    pub particle: usize,
    /// Contact angle, degrees.
    pub contact_angle_deg: f64,
    /// Push duration after first touch, seconds.
    pub duration_s: f64,
    /// Push distance, micrometres.
    pub distance_um: f64,
    /// True for a re-push after a lost contact.
    pub repush: bool,
    /// The check that followed, if any ("placed", "fell-short", ...).
    pub result: Option<String>,
}

/// The pushes of a journal, each with the check that followed it.
pub fn journal_pushes(entries: &[Entry<RunEvent>]) -> Vec<JournalPush> {
    let mut out: Vec<JournalPush> = Vec::new();
    for e in entries {
        match &e.event {
            RunEvent::Decision {
                particle,
                from_um,
                to_um,
                contact_angle_deg,
                duration_s,
                repush,
                ..
            } => out.push(JournalPush {
                t_s: e.t_s,
                particle: *particle,
                contact_angle_deg: *contact_angle_deg,
                duration_s: *duration_s,
                distance_um: (to_um[0] - from_um[0]).hypot(to_um[1] - from_um[1]),
                repush: *repush,
                result: None,
            }),
            RunEvent::Check {
                particle, result, ..
            } => {
                if let Some(last) = out
                    .last_mut()
                    .filter(|p| p.particle == *particle && p.result.is_none())
                {
                    last.result = Some(result.clone());
                }
            }
            _ => {}
        }
    }
    out
}

/// Writes `pushes-force-<k>.svg` and `.png` charts (force against time since
/// first touch, [`PUSHES_PER_CHART`] pushes each); returns the files written.
pub fn write_force_plots(
    pushes: &[JournalPush],
    scene: &Scene,
    dir: &Path,
) -> Result<Vec<PathBuf>, String> {
    let mut files = Vec::new();
    for (k, chunk) in pushes.chunks(PUSHES_PER_CHART).enumerate() {
        let first = k * PUSHES_PER_CHART;
        let mut series = Vec::new();
        for (i, p) in chunk.iter().enumerate() {
            let s = scene_for_push(scene, scene.particle_radius_m, p.t_s);
            let params = PushParams {
                contact_angle_rad: p.contact_angle_deg.to_radians(),
                speed_m_per_s: scene.push.speed_m_per_s,
                duration_s: p.duration_s,
            };
            let (_, rows) = simulate_push_series(&s, &params, &SolverSettings::default(), 121)
                .map_err(|e| format!("push {}: {e}", first + i + 1))?;
            series.push(Series {
                name: format!(
                    "push {} (particle {}, {:.0} deg{})",
                    first + i + 1,
                    p.particle,
                    p.contact_angle_deg,
                    if p.repush { ", re-push" } else { "" }
                ),
                points: rows.iter().map(|r| (r.t_s, r.force_n * 1e6)).collect(),
            });
        }
        let chart = LineChart {
            title: format!(
                "Pushing force, pushes {}-{} (model)",
                first + 1,
                first + chunk.len()
            ),
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

/// Writes `report.md`.
pub fn write_report_md(
    path: &Path,
    report: &AssemblyReport,
    pushes: &[JournalPush],
    sites_um: &[[f64; 2]],
    files: &ReportFiles,
) -> std::io::Result<()> {
    let mut md = String::new();
    let _ = writeln!(md, "# Assembly report\n");
    let _ = writeln!(md, "Outcome: **{}**\n", report.outcome);
    let _ = writeln!(md, "| figure | value |\n|---|---|");
    let mut rows = vec![
        (
            "sites filled",
            format!("{}/{}", report.filled, report.sites),
        ),
        (
            "placement error",
            format!(
                "rms {:.0} nm, max {:.0} nm ({})",
                report.rms_error_nm, report.max_error_nm, report.error_source
            ),
        ),
        (
            "pushes",
            format!("{} ({} re-pushes)", report.pushes, report.repushes),
        ),
        (
            "lost contacts",
            format!(
                "{} detected, {} missed",
                report.lost_contacts_detected,
                report
                    .lost_contacts_missed
                    .map_or("unknown".to_owned(), |m| m.to_string())
            ),
        ),
        ("time", report.time_summary()),
    ];
    rows.extend(report.notes());
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
    // The tolerance the report's `filled` counts with (both rigs run the default).
    let tolerance_nm = AssemblySettings::default().placed_tolerance_m * 1e9;
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
        "| # | t [s] | particle | distance [um] | angle [deg] | duration [s] | re-push | result |\n|---|---|---|---|---|---|---|---|"
    );
    for (i, p) in pushes.iter().enumerate() {
        let _ = writeln!(
            md,
            "| {} | {:.1} | {} | {:.2} | {:.1} | {:.2} | {} | {} |",
            i + 1,
            p.t_s,
            p.particle,
            p.distance_um,
            p.contact_angle_deg,
            p.duration_s,
            if p.repush { "yes" } else { "" },
            p.result.as_deref().unwrap_or("-")
        );
    }
    let _ = writeln!(md, "\n## Effects\n");
    let _ = writeln!(
        md,
        "| effect | why | simulated contacts that evaluated it |\n|---|---|---|"
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

#[cfg(test)]
mod tests {
    use super::*;

    fn e(seq: u64, t_s: f64, event: RunEvent) -> Entry<RunEvent> {
        Entry { seq, t_s, event }
    }

    fn decision(particle: usize, repush: bool) -> RunEvent {
        RunEvent::Decision {
            particle,
            from_um: [0.0, 0.0],
            to_um: [3.0, 4.0],
            contact_angle_deg: 45.0,
            duration_s: 8.0,
            onset_s: 1.0,
            critical_force_un: 2.0,
            ride_over_margin: None,
            mode: "rolling".into(),
            repush,
            radius_um: None,
        }
    }

    fn check(particle: usize, result: &str) -> RunEvent {
        RunEvent::Check {
            particle,
            result: result.into(),
            error_nm: 10.0,
            lost_contact: result != "placed",
        }
    }

    #[test]
    fn pushes_are_paired_with_the_check_that_followed() {
        let entries = vec![
            e(0, 1.0, decision(4, false)),
            e(1, 9.0, check(4, "fell-short")),
            e(2, 10.0, decision(4, true)),
            e(3, 19.0, check(4, "placed")),
            e(4, 20.0, decision(7, false)),
        ];
        let p = journal_pushes(&entries);
        assert_eq!(p.len(), 3);
        assert_eq!(p[0].result.as_deref(), Some("fell-short"));
        assert!(p[1].repush && p[1].result.as_deref() == Some("placed"));
        assert_eq!(p[2].result, None);
        assert!((p[0].distance_um - 5.0).abs() < 1e-12);
    }
}
