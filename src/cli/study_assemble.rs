//! `nanopush study assemble`: many seeded closed-loop runs of one pattern on the
//! simulated rig, aggregated against the closed-loop acceptance figures (share of
//! runs that fill every site, placement RMS, missed lost contacts, time against
//! the lower bound).
//!
//! Each run is this binary's own `assemble --json` in a child process: a run that
//! panics or is killed cannot take the study down, and the study sees exactly
//! what a user sees.

use super::child_stop::run_stopping_on;
use crate::exec::report::nearer_than_asked;
use crate::exec::time_split::TimeSplit;
use crate::model::Scene;
use crate::rig::interrupt::{CAUSE, ctrlc_flag_answering};
use crate::wording::counted;
use anyhow::{Context, bail};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Arguments of `nanopush study assemble`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Text to assemble.
    #[arg(long, default_value = "CMU")]
    pub text: String,
    /// Number of seeded runs.
    #[arg(long, default_value_t = 50)]
    pub runs: u64,
    /// Seed of the first run; run k uses first_seed + k.
    #[arg(long, default_value_t = 1)]
    pub first_seed: u64,
    /// Scene of every run.
    #[arg(long, default_value = "calib/paper-ps-ito.toml")]
    pub scene: PathBuf,
    /// Output folder: one sub-folder per run, plus study-assemble.{json,md}
    /// (rewritten after every run, so a stopped study keeps what it finished).
    #[arg(long, default_value = "out/study-assemble")]
    pub out: PathBuf,
    /// Replace a study already in --out (its summary and the runs' folders
    /// of the seeds run again); without it such an --out is refused.
    #[arg(long)]
    pub force: bool,
    /// Free space, um, every run's plans keep round the pattern (`assemble
    /// --keep-clear-um`; default: assemble's, half the particle radius; 0
    /// gives the plain plans, to see what keeping it costs).
    #[arg(long)]
    pub keep_clear_um: Option<f64>,
}

/// What `assemble --json` prints, as far as the study needs it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunFigures {
    /// Target sites.
    pub sites: usize,
    /// Sites filled at the end.
    pub filled: usize,
    /// Placement RMS over the sites, nm.
    pub rms_error_nm: f64,
    /// Worst placement error, nm.
    pub max_error_nm: f64,
    /// Pushes executed.
    pub pushes: usize,
    /// Pushes that repeated a failed one.
    pub repushes: usize,
    /// Lost contacts the loop saw.
    pub lost_contacts_detected: usize,
    /// Lost contacts the simulator caused but the loop did not see.
    pub lost_contacts_missed: usize,
    /// Moves that lowered the tip onto a particle, by the simulator's
    /// ground truth (absent in reports from before 2026-12-02).
    #[serde(default)]
    pub tip_landings_on_particles: Option<usize>,
    /// Rig time of the run, s.
    pub time_s: f64,
    /// The planner's lower bound on that time, s.
    pub lower_bound_s: f64,
    /// Least free space between the pattern and a particle on no site
    /// where the run ended, um (absent: none on no site, or a study from
    /// before 2026-11-30).
    #[serde(default)]
    pub nearest_stray_gap_um: Option<f64>,
    /// The gap the run's plans were asked to keep (absent in studies from
    /// before 2026-11-30).
    #[serde(default)]
    pub asked: Option<AskedGap>,
    /// Where `time_s` went (zero in studies from before 2026-12-01).
    #[serde(default)]
    pub time_split: TimeSplit,
    /// `lower_bound_s` by the same parts.
    #[serde(default)]
    pub lower_bound_split: TimeSplit,
}

/// The gap a run's plans were asked to keep: its report's `asked`, as far
/// as the study needs it.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct AskedGap {
    /// um; 0 when none.
    #[serde(default)]
    pub keep_clear_um: f64,
}

/// One run of the study: its seed, figures (or why it has none) and wall time.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunRow {
    /// Seed of the layout and the rig's noise.
    pub seed: u64,
    /// The run's report, when it produced one.
    pub figures: Option<RunFigures>,
    /// Why the run stopped short or has no report (the error it printed).
    pub error: Option<String>,
    /// Wall time of the child process, s.
    pub wall_s: f64,
}

/// The aggregate the acceptance list asks for.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StudySummary {
    /// Schema tag of study-assemble.json.
    pub schema: String,
    /// Pattern text.
    pub text: String,
    /// Runs attempted.
    pub runs: usize,
    /// Runs that filled every site.
    pub complete_runs: usize,
    /// Worst per-run placement RMS among complete runs, nm.
    pub worst_rms_nm: Option<f64>,
    /// Median per-run placement RMS among complete runs, nm.
    pub median_rms_nm: Option<f64>,
    /// Lost contacts missed, summed over runs.
    pub missed_lost_contacts: usize,
    /// Lost contacts detected, summed over runs.
    pub detected_lost_contacts: usize,
    /// Moves that lowered the tip onto a particle, summed over the runs
    /// that count them (absent when none does).
    #[serde(default)]
    pub tip_landings_on_particles: Option<usize>,
    /// Median of time / lower bound among complete runs.
    pub median_time_ratio: Option<f64>,
    /// Worst time / lower bound among complete runs.
    pub worst_time_ratio: Option<f64>,
    /// Median wall time of a run, s.
    pub median_wall_s: Option<f64>,
    /// Median, among complete runs, of the free space between the pattern
    /// and the nearest particle on no site, um (absent in studies from
    /// before 2026-11-30).
    #[serde(default)]
    pub median_stray_gap_um: Option<f64>,
    /// The least of those gaps, um.
    #[serde(default)]
    pub least_stray_gap_um: Option<f64>,
    /// Complete runs whose nearest stray is nearer than the gap asked of
    /// their plans.
    #[serde(default)]
    pub runs_nearer_than_asked: usize,
    /// Complete runs whose plans were asked to keep a gap.
    #[serde(default)]
    pub runs_asked_a_gap: usize,
    /// Median, part by part, of the complete runs' time above their bound's
    /// same part, s: which part of the time the ratio's excess is (absent
    /// when no run has the split, as in studies from before 2026-12-01).
    #[serde(default)]
    pub median_over_bound: Option<TimeSplit>,
    /// Every run.
    pub rows: Vec<RunRow>,
}

/// Schema tag of the study's JSON output.
pub const STUDY_ASSEMBLE_SCHEMA: &str = "nanopush.study-assemble/1";

/// Runs the seeds one after the other and writes the table and JSON.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    // Checked once here: each run would fail the same way, after the table's header.
    Scene::load(&args.scene).with_context(|| format!("scene {}", args.scene.display()))?;
    super::assemble::check_text_fits_the_layout(&args.text)?;
    super::assemble::keep_clear_flag_m(args.keep_clear_um)?;
    let last_seed = args
        .first_seed
        .checked_add(args.runs - 1)
        .with_context(|| {
            format!(
                "--first-seed {} + --runs {} passes the largest seed",
                args.first_seed, args.runs
            )
        })?;
    super::folder_flag::check_folder_flag("--out", &args.out, "a folder")?;
    if !args.force
        && let Some(held) = held_study(&args.out)
    {
        bail!(
            "{} holds a study already ({held}): pass --force to replace it, or --out another folder",
            args.out.display()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let exe = std::env::current_exe().context("locating the nanopush binary")?;
    // Ctrl-C stops the run in progress as a run stops (the study passes it
    // on: a `kill -INT` of the study alone had let the seed finish); the
    // study then keeps the runs it finished and stops.
    let interrupt = ctrlc_flag_answering(&format!(
        "stopping the study ({CAUSE}) now: the run in progress is stopped, the seeds finished are kept in {}",
        args.out.display()
    ))
    .context("installing the Ctrl-C handler")?;
    let (json, md) = (
        args.out.join("study-assemble.json"),
        args.out.join("study-assemble.md"),
    );
    let mut summary = summarise(&args.text, Vec::new());
    let mut stopped_seed = None;
    for seed in args.first_seed..=last_seed {
        let row = run_one(&exe, &args, seed, &interrupt)?;
        if interrupt.load(Ordering::SeqCst) {
            stopped_seed = Some(seed);
            break;
        }
        print_row(&row);
        let mut rows = std::mem::take(&mut summary.rows);
        rows.push(row);
        summary = summarise(&args.text, rows);
        std::fs::write(&json, serde_json::to_string_pretty(&summary)?)
            .with_context(|| format!("writing {}", json.display()))?;
        std::fs::write(&md, to_markdown(&summary, &args))
            .with_context(|| format!("writing {}", md.display()))?;
    }
    print!("{}", acceptance_text(&summary));
    if !summary.rows.is_empty() {
        println!("table: {}  data: {}", md.display(), json.display());
    }
    if let Some(seed) = stopped_seed {
        let kept = if summary.rows.is_empty() {
            "no seed had finished, so no summary was written".to_owned()
        } else {
            format!(
                "their results are in {} and {}",
                md.display(),
                json.display()
            )
        };
        let folder = args.out.join(format!("seed-{seed}"));
        let left = if folder.exists() {
            format!(
                "seed {seed}, stopped part way, is left in {} and not counted",
                folder.display()
            )
        } else {
            format!("seed {seed} was stopped before it wrote anything")
        };
        bail!(
            "study interrupted ({CAUSE}) after {} of {}: {kept}; {left}",
            summary.rows.len(),
            counted(args.runs as usize, "seed"),
        );
    }
    if let Some(first) = summary.rows.iter().find(|r| r.figures.is_none())
        && summary.rows.iter().all(|r| r.figures.is_none())
    {
        bail!(
            "no run produced a report; seed {}: {}",
            first.seed,
            first.error.as_deref().unwrap_or("no error printed")
        );
    }
    Ok(())
}

/// What of an earlier study `out` holds (its summary, or runs' folders), if anything.
fn held_study(out: &Path) -> Option<String> {
    if out.join("study-assemble.json").exists() {
        return Some("study-assemble.json".into());
    }
    let runs = std::fs::read_dir(out)
        .ok()?
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().starts_with("seed-"))
        .count();
    (runs > 0).then(|| format!("{runs} seed-* run folders"))
}

fn run_one(exe: &Path, args: &Args, seed: u64, interrupt: &AtomicBool) -> anyhow::Result<RunRow> {
    let dir = args.out.join(format!("seed-{seed}"));
    if dir.exists() {
        std::fs::remove_dir_all(&dir).with_context(|| format!("clearing {}", dir.display()))?;
    }
    let t0 = Instant::now();
    let mut command = Command::new(exe);
    command
        .arg("assemble")
        .args(["--text", &args.text])
        .arg("--scene")
        .arg(&args.scene)
        .args(["--seed", &seed.to_string()])
        .arg("--out")
        .arg(&dir)
        .arg("--json");
    if let Some(um) = args.keep_clear_um {
        command.args(["--keep-clear-um", &um.to_string()]);
    }
    let output = run_stopping_on(command, interrupt)
        .with_context(|| format!("running {} assemble", exe.display()))?;
    let wall_s = t0.elapsed().as_secs_f64();
    let stdout = String::from_utf8_lossy(&output.stdout);
    let parsed = parse_figures(&stdout);
    // A run that stopped short still prints its figures; its exit status and
    // last stderr line say why it stopped.
    let error =
        (!output.status.success()).then(|| last_line(&String::from_utf8_lossy(&output.stderr)));
    Ok(RunRow {
        seed,
        figures: parsed,
        error,
        wall_s,
    })
}

/// The report object `assemble --json` printed (pretty, so over several lines).
fn parse_figures(stdout: &str) -> Option<RunFigures> {
    let start = stdout.find('{')?;
    serde_json::Deserializer::from_str(&stdout[start..])
        .into_iter::<RunFigures>()
        .next()?
        .ok()
}

fn last_line(s: &str) -> String {
    s.lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("no output")
        .trim()
        .to_string()
}

/// The textbook median (the mean of the two middle values of an even count),
/// as the study's tables report it; the crate's robust statistics use
/// [`crate::median::upper_median`], always one of the values.
fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

fn max(v: &[f64]) -> Option<f64> {
    v.iter().copied().max_by(f64::total_cmp)
}

/// Aggregates the runs; figures of incomplete runs count only in the lost-contact sums.
pub fn summarise(text: &str, rows: Vec<RunRow>) -> StudySummary {
    let complete: Vec<&RunFigures> = rows
        .iter()
        .filter_map(|r| r.figures.as_ref())
        .filter(|f| f.sites > 0 && f.filled == f.sites)
        .collect();
    let rms: Vec<f64> = complete.iter().map(|f| f.rms_error_nm).collect();
    let ratios: Vec<f64> = complete
        .iter()
        .filter(|f| f.lower_bound_s > 0.0)
        .map(|f| f.time_s / f.lower_bound_s)
        .collect();
    // (gap, gap asked) of the complete runs that have both.
    let asked_gap: Vec<(f64, f64)> = (complete.iter())
        .filter_map(|f| Some((f.nearest_stray_gap_um?, f.asked?.keep_clear_um)))
        .collect();
    let gaps: Vec<f64> = (complete.iter())
        .filter_map(|f| f.nearest_stray_gap_um)
        .collect();
    let split: Vec<&RunFigures> = (complete.iter().copied())
        .filter(|f| f.time_split.pushing_s + f.time_split.travel_s > 0.0)
        .collect();
    let over = |part: fn(&TimeSplit) -> f64| {
        median(
            split
                .iter()
                .map(|f| part(&f.time_split) - part(&f.lower_bound_split))
                .collect(),
        )
    };
    let median_over_bound = (!split.is_empty()).then(|| TimeSplit {
        pushing_s: over(|t| t.pushing_s).unwrap_or(0.0),
        travel_s: over(|t| t.travel_s).unwrap_or(0.0),
        other_s: over(|t| t.other_s).unwrap_or(0.0),
    });
    let all = || rows.iter().filter_map(|r| r.figures.as_ref());
    StudySummary {
        schema: STUDY_ASSEMBLE_SCHEMA.to_string(),
        text: text.to_string(),
        runs: rows.len(),
        complete_runs: complete.len(),
        worst_rms_nm: max(&rms),
        median_rms_nm: median(rms.clone()),
        missed_lost_contacts: all().map(|f| f.lost_contacts_missed).sum(),
        detected_lost_contacts: all().map(|f| f.lost_contacts_detected).sum(),
        tip_landings_on_particles: all()
            .filter_map(|f| f.tip_landings_on_particles)
            .reduce(|a, b| a + b),
        median_time_ratio: median(ratios.clone()),
        worst_time_ratio: max(&ratios),
        median_wall_s: median(rows.iter().map(|r| r.wall_s).collect()),
        median_stray_gap_um: median(gaps.clone()),
        least_stray_gap_um: gaps.iter().copied().min_by(f64::total_cmp),
        runs_nearer_than_asked: (asked_gap.iter())
            .filter(|(gap, kept)| nearer_than_asked(*gap, *kept))
            .count(),
        runs_asked_a_gap: asked_gap.iter().filter(|(_, kept)| *kept > 0.0).count(),
        median_over_bound,
        rows,
    }
}

fn print_row(r: &RunRow) {
    match (&r.figures, &r.error) {
        (Some(f), _) => println!(
            "seed {:>3}: {}/{}, rms {:.0} nm, stray {} um, {} ({} re), lost {} seen {} missed, tip landings {}, time {:.0} s / LB {:.0} s, wall {:.1} s",
            r.seed,
            f.filled,
            counted(f.sites, "site"),
            f.rms_error_nm,
            fmt_opt(f.nearest_stray_gap_um, 2),
            counted(f.pushes, "push"),
            f.repushes,
            f.lost_contacts_detected,
            f.lost_contacts_missed,
            landings_of(f),
            f.time_s,
            f.lower_bound_s,
            r.wall_s
        ),
        (None, e) => println!(
            "seed {:>3}: no report: {}",
            r.seed,
            e.as_deref().unwrap_or("?")
        ),
    }
}

/// A run's tip landings on particles, "-" where its report does not count them.
fn landings_of(f: &RunFigures) -> String {
    fmt_opt(f.tip_landings_on_particles.map(|n| n as f64), 0)
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map(|x| format!("{x:.digits$}"))
        .unwrap_or_else(|| "-".to_string())
}

/// The acceptance figures with their targets, one line each; time ratios
/// to 3 decimals (a worst of 1.5018 had read "1.50 (target <= 1.5)"). The RMS and
/// time figures are of the complete runs only, and say so when some runs
/// are not (a stopped run's errors are microns: its worst is in the table).
pub fn acceptance_text(s: &StudySummary) -> String {
    let share = s.complete_runs as f64 / s.runs.max(1) as f64;
    let of = if s.complete_runs < s.runs {
        format!(" of the {}", counted(s.complete_runs, "complete run"))
    } else {
        String::new()
    };
    format!(
        "{text}: {c}/{n} filled every site ({pct:.0} %, target >= 98 %)\n\
         placement RMS{of}: median {mr} nm, worst {wr} nm (target <= 200 nm)\n\
         nearest stray off the pattern{of}: median {mg} um, least {lg} um{nearer}\n\
         lost contacts: {d} detected, {m} missed (target 0 missed)\n{landings}\
         time / lower bound{of}: median {mt}, worst {wt} (target <= 1.5){over}\n\
         wall time per run: median {mw} s\n",
        text = s.text,
        c = s.complete_runs,
        n = counted(s.runs, "run"),
        pct = 100.0 * share,
        mr = fmt_opt(s.median_rms_nm, 0),
        wr = fmt_opt(s.worst_rms_nm, 0),
        mg = fmt_opt(s.median_stray_gap_um, 2),
        lg = fmt_opt(s.least_stray_gap_um, 2),
        nearer = if s.runs_asked_a_gap > 0 {
            format!(
                "; {} of {} nearer than the gap asked of its plans",
                s.runs_nearer_than_asked, s.runs_asked_a_gap
            )
        } else {
            String::new()
        },
        d = s.detected_lost_contacts,
        m = s.missed_lost_contacts,
        landings = s.tip_landings_on_particles.map_or(String::new(), |n| format!(
            "tip lowered onto a particle: {n} times (ground truth, target 0)\n"
        )),
        mt = fmt_opt(s.median_time_ratio, 3),
        wt = fmt_opt(s.worst_time_ratio, 3),
        mw = fmt_opt(s.median_wall_s, 1),
        over = s.median_over_bound.map_or(String::new(), |o| format!(
            "\ntime above the bound's same part, median per run: {:.0} s pushing, {:.0} s lifted, {:.0} s else",
            o.pushing_s, o.travel_s, o.other_s
        )),
    )
}

fn to_markdown(s: &StudySummary, args: &Args) -> String {
    let mut out = format!(
        "# Closed-loop study: {} on the simulated rig\n\nGenerated by `nanopush study assemble --text {} --runs {} --first-seed {} --scene {} --out {}{}`{}.\n\n```\n{}```\n\n| seed | filled | rms [nm] | max [nm] | stray gap [um] | pushes | re-pushes | lost seen | lost missed | tip landings | time [s] | LB [s] | wall [s] | error |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        s.text,
        s.text,
        args.runs,
        args.first_seed,
        args.scene.display(),
        args.out.display(),
        args.keep_clear_um
            .map_or(String::new(), |um| format!(" --keep-clear-um {um}")),
        if s.runs as u64 == args.runs {
            String::new()
        } else {
            format!(
                " ({} of its {} so far)",
                s.runs,
                counted(args.runs as usize, "run")
            )
        },
        acceptance_text(s)
    );
    for r in &s.rows {
        match &r.figures {
            Some(f) => out.push_str(&format!(
                "| {} | {}/{} | {:.0} | {:.0} | {} | {} | {} | {} | {} | {} | {:.0} | {:.0} | {:.1} | {} |\n",
                r.seed,
                f.filled,
                f.sites,
                f.rms_error_nm,
                f.max_error_nm,
                fmt_opt(f.nearest_stray_gap_um, 2),
                f.pushes,
                f.repushes,
                f.lost_contacts_detected,
                f.lost_contacts_missed,
                landings_of(f),
                f.time_s,
                f.lower_bound_s,
                r.wall_s,
                r.error.as_deref().unwrap_or("").replace('|', "/")
            )),
            None => out.push_str(&format!(
                "| {} | - | - | - | - | - | - | - | - | - | - | - | {:.1} | {} |\n",
                r.seed,
                r.wall_s,
                r.error.as_deref().unwrap_or("").replace('|', "/")
            )),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figures(filled: usize, rms: f64, missed: usize, time: f64) -> RunFigures {
        RunFigures {
            sites: 3,
            filled,
            rms_error_nm: rms,
            max_error_nm: rms * 2.0,
            pushes: 5,
            repushes: 1,
            lost_contacts_detected: 1,
            lost_contacts_missed: missed,
            tip_landings_on_particles: Some(missed),
            time_s: time,
            lower_bound_s: 100.0,
            nearest_stray_gap_um: Some(time / 100.0),
            asked: Some(AskedGap { keep_clear_um: 1.5 }),
            time_split: TimeSplit {
                pushing_s: time * 0.8,
                travel_s: time * 0.15,
                other_s: time * 0.05,
            },
            lower_bound_split: TimeSplit {
                pushing_s: 90.0,
                travel_s: 10.0,
                other_s: 0.0,
            },
        }
    }

    fn row(seed: u64, f: Option<RunFigures>) -> RunRow {
        RunRow {
            seed,
            error: f.is_none().then(|| "planner refused".to_string()),
            figures: f,
            wall_s: seed as f64,
        }
    }

    #[test]
    fn incomplete_runs_do_not_count_in_rms_or_time_but_do_in_missed_contacts() {
        let s = summarise(
            "CMU",
            vec![
                row(1, Some(figures(3, 100.0, 0, 120.0))),
                row(2, Some(figures(3, 300.0, 0, 200.0))),
                row(3, Some(figures(2, 900.0, 2, 900.0))),
                row(4, None),
            ],
        );
        assert_eq!((s.runs, s.complete_runs), (4, 2));
        assert_eq!(s.worst_rms_nm, Some(300.0));
        assert_eq!(s.median_rms_nm, Some(200.0));
        assert_eq!(s.missed_lost_contacts, 2);
        assert_eq!(s.detected_lost_contacts, 3);
        assert_eq!(s.tip_landings_on_particles, Some(2));
        assert_eq!(s.worst_time_ratio, Some(2.0));
        assert_eq!(s.median_time_ratio, Some(1.6));
        // Gaps of 1.2 and 2.0 um; the stopped run's 9.0 is not counted.
        assert_eq!(s.median_stray_gap_um, Some(1.6));
        assert_eq!(s.least_stray_gap_um, Some(1.2));
        // Asked 1.5 um: the 1.2 um run is nearer, the 2.0 um one not.
        assert_eq!((s.runs_nearer_than_asked, s.runs_asked_a_gap), (1, 2));
        let text = acceptance_text(&s);
        assert!(
            text.contains("nearest stray off the pattern of the 2 complete runs: median 1.60 um, least 1.20 um; 1 of 2 nearer than the gap asked of its plans"),
            "{text}"
        );
        assert!(text.contains("2/4 runs filled every site (50 %"), "{text}");
        assert!(
            text.contains("tip lowered onto a particle: 2 times (ground truth, target 0)\n"),
            "{text}"
        );
        // 96 and 160 s pushing against 90 s; 18 and 30 s lifted against 10.
        assert!(
            text.contains("time above the bound's same part, median per run: 38 s pushing, 14 s lifted, 8 s else"),
            "{text}"
        );
        assert!(
            text.contains("placement RMS of the 2 complete runs: median 200 nm, worst 300 nm")
                && text.contains("time / lower bound of the 2 complete runs: median 1.600"),
            "{text}"
        );
    }

    /// A study of one run, or of one complete run, says "run" once.
    #[test]
    fn one_run_is_counted_in_the_singular() {
        let s = summarise(
            "L",
            vec![
                row(1, Some(figures(3, 50.0, 0, 150.0))),
                row(2, Some(figures(2, 900.0, 0, 900.0))),
            ],
        );
        let text = acceptance_text(&s);
        assert!(text.contains("L: 1/2 runs filled every site"), "{text}");
        assert!(
            text.contains("placement RMS of the 1 complete run: median 50 nm"),
            "{text}"
        );
        let text = acceptance_text(&summarise(
            "L",
            vec![row(1, Some(figures(3, 50.0, 0, 150.0)))],
        ));
        assert!(text.contains("L: 1/1 run filled every site"), "{text}");
    }

    #[test]
    fn study_json_reads_back() {
        let s = summarise("L", vec![row(1, Some(figures(3, 50.0, 0, 150.0)))]);
        let text = serde_json::to_string(&s).unwrap();
        let back: StudySummary = serde_json::from_str(&text).unwrap();
        assert_eq!(back.schema, STUDY_ASSEMBLE_SCHEMA);
        assert_eq!(back.rows.len(), 1);
        assert_eq!(back.rows[0].figures.as_ref().unwrap().filled, 3);
        assert_eq!(back.median_time_ratio, Some(1.5));
    }

    #[test]
    fn figures_are_read_from_pretty_json_after_other_output() {
        let f = figures(3, 50.0, 0, 150.0);
        let out = format!(
            "warming up\n{}\n",
            serde_json::to_string_pretty(&f).unwrap()
        );
        assert_eq!(parse_figures(&out).unwrap().filled, 3);
        assert!(parse_figures("error: no such scene").is_none());
    }

    /// The stray gap and the gap asked are read off the report `assemble
    /// --json` prints, by its own field names.
    #[test]
    fn the_stray_gap_and_the_gap_asked_are_read_off_a_runs_report() {
        let mut report = crate::exec::report::tests::small_report();
        report.nearest_stray_gap_um = Some(0.75);
        report.asked = Some(crate::exec::report::RunAsked {
            pattern: "CMU".into(),
            scene: "s.toml".into(),
            layout: None,
            seed: Some(5),
            command: None,
            keep_clear_um: 2.5,
        });
        let printed = serde_json::to_string_pretty(&report).unwrap();
        let f = parse_figures(&printed).unwrap();
        assert_eq!(f.nearest_stray_gap_um, Some(0.75));
        assert_eq!(f.asked.map(|a| a.keep_clear_um), Some(2.5));
    }

    #[test]
    fn markdown_lists_every_run_with_its_error() {
        let landed = RunFigures {
            tip_landings_on_particles: Some(4),
            ..figures(3, 50.0, 0, 150.0)
        };
        let uncounted = RunFigures {
            tip_landings_on_particles: None,
            ..figures(3, 50.0, 0, 150.0)
        };
        let s = summarise(
            "L",
            vec![row(1, Some(landed)), row(2, None), row(3, Some(uncounted))],
        );
        let args = Args {
            text: "L".into(),
            runs: 5,
            first_seed: 7,
            scene: "calib/paper-ps-ito.toml".into(),
            out: "out/x".into(),
            force: false,
            keep_clear_um: None,
        };
        let md = to_markdown(&s, &args);
        // The command that regenerates the table, whole, and how far it got.
        assert!(
            md.contains("--runs 5 --first-seed 7 --scene calib/paper-ps-ito.toml --out out/x` (3 of its 5 runs so far)"),
            "{md}"
        );
        assert!(md.contains("| 1 | 3/3 |"));
        assert!(md.contains("planner refused"));
        // Every row has the header's cells; a run's tip landings have their
        // own column, "-" where its report does not count them.
        let rows: Vec<&str> = md.lines().filter(|l| l.starts_with('|')).collect();
        let cells = |l: &str| l.matches('|').count();
        assert!(rows.iter().all(|l| cells(l) == cells(rows[0])), "{md}");
        assert!(md.contains("| lost missed | tip landings |"), "{md}");
        assert!(md.contains("| 1 | 0 | 4 | 150 |"), "{md}");
        assert!(md.contains("| 1 | 0 | - | 150 |"), "{md}");
        // A run that stopped short has figures and says why it stopped.
        let mut short = row(3, Some(figures(3, 50.0, 0, 150.0)));
        short.error = Some("stopped: walled in | edge".to_string());
        let md = to_markdown(&summarise("L", vec![short]), &args);
        assert!(md.contains("| stopped: walled in / edge |"), "{md}");
        // A gap given is part of the command that regenerates the table.
        let plain = Args {
            keep_clear_um: Some(0.0),
            ..args
        };
        let md = to_markdown(&s, &plain);
        assert!(md.contains("--out out/x --keep-clear-um 0` (3 of"), "{md}");
    }
}
