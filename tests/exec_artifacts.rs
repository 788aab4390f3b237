//! What `assemble` leaves in its folder: the files are there, read back, and
//! agree with each other; the final frame, checked by the vision detector
//! alone against sites.json, shows the pattern; bad pattern input is refused
//! before anything is written.

use nalgebra::Vector2;
use nanopush::exec::assemble::AssemblySettings;
use nanopush::exec::events::RunEvent;
use nanopush::exec::journal::read_journal;
use nanopush::exec::recording::open_recording;
use nanopush::exec::report::AssemblyReport;
use nanopush::plan::stray_gap::seen_stray_gap_m;
use nanopush::vision::detect::{DetectSettings, detect_particles};
use nanopush::vision::frame::Frame;
use nanopush::vision::frame_input::{Channel, load_frame, load_frames};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

const RUN: [&str; 6] = ["--text", "L", "--seed", "6", "--particles", "20"];
/// Particle diameter in the simulated camera's pixels (10 um at 0.25 um/px).
const DIAMETER_PX: f64 = 40.0;
/// A site shows its particle when a detection is this close (0.25 um).
const MATCH_PX: f64 = 1.0;

fn binary() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_nanopush"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

/// One run shared by the tests: (temp dir kept alive, output folder, recording folder).
/// `nanopush assemble --out OUT --record REC` with the run's arguments.
fn assemble_recorded(out: &Path, rec: &Path) -> std::process::Output {
    binary()
        .args(["assemble", "--out", out.to_str().unwrap()])
        .args(["--record", rec.to_str().unwrap()])
        .args(RUN)
        .output()
        .unwrap()
}

fn run() -> &'static (tempfile::TempDir, PathBuf, PathBuf) {
    static RUN_DIR: OnceLock<(tempfile::TempDir, PathBuf, PathBuf)> = OnceLock::new();
    RUN_DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let rec = dir.path().join("rec");
        let o = assemble_recorded(&out, &rec);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // Where the recording went, and how to replay it.
        let printed = String::from_utf8_lossy(&o.stdout);
        let said = format!(
            "recording: {} (replay it with nanopush dry-run",
            rec.display()
        );
        assert!(printed.contains(&said), "{printed}");
        (dir, out, rec)
    })
}

#[derive(serde::Deserialize)]
struct SitesFile {
    schema: String,
    sites: Vec<SiteRow>,
}

#[derive(serde::Deserialize)]
struct SiteRow {
    x_um: f64,
    y_um: f64,
    x_px: f64,
    y_px: f64,
}

fn sites(out: &Path) -> SitesFile {
    serde_json::from_str(&std::fs::read_to_string(out.join("sites.json")).unwrap()).unwrap()
}

/// Sites with a detected particle within MATCH_PX of their pixel position.
fn sites_shown(frame: &Frame, sites: &SitesFile) -> usize {
    let found = detect_particles(
        frame,
        &DetectSettings {
            diameter_px: DIAMETER_PX,
            ..DetectSettings::default()
        },
    )
    .unwrap();
    sites
        .sites
        .iter()
        .filter(|s| {
            found
                .iter()
                .any(|d| (d.x_px - s.x_px).hypot(d.y_px - s.y_px) <= MATCH_PX)
        })
        .count()
}

#[test]
fn the_final_frame_checked_by_the_detector_shows_the_pattern() {
    let (_, out, rec) = run();
    let s = sites(out);
    assert_eq!(s.schema, "nanopush.sites/1");
    let last = load_frame(&out.join("final.png"), Channel::Luminance).unwrap();
    assert_eq!(sites_shown(&last, &s), s.sites.len());
    // The same check on the first recorded frame fails: the pattern was built by the run.
    let first = load_frame(&rec.join("frames/frame_00000.png"), Channel::Luminance).unwrap();
    assert!(
        sites_shown(&first, &s) < s.sites.len() / 2,
        "the first frame already shows {} of {} sites",
        sites_shown(&first, &s),
        s.sites.len()
    );
}

/// The report's nearest stray is what the final frame shows: the detector
/// alone, on final.png against sites.json, measures the same gap, and it
/// is at least the gap the run's plans keep (assemble's default).
#[test]
fn the_reported_stray_gap_is_the_final_frames() {
    let (_, out, _) = run();
    let text = std::fs::read_to_string(out.join("report.json")).unwrap();
    let report: AssemblyReport = serde_json::from_str(&text).unwrap();
    let gap_um = report.nearest_stray_gap_um.expect("a stray gap");
    let kept_um = report.asked.as_ref().unwrap().keep_clear_um;
    assert!(
        kept_um > 0.0 && gap_um >= kept_um,
        "{gap_um} um, {kept_um} um kept"
    );
    let s = sites(out);
    let (a, b) = (&s.sites[0], &s.sites[1]);
    let um_per_px =
        (a.x_um - b.x_um).hypot(a.y_um - b.y_um) / (a.x_px - b.x_px).hypot(a.y_px - b.y_px);
    let at = |x_px: f64, y_px: f64| Vector2::new(x_px, y_px) * um_per_px;
    let last = load_frame(&out.join("final.png"), Channel::Luminance).unwrap();
    let settings = DetectSettings {
        diameter_px: DIAMETER_PX,
        ..DetectSettings::default()
    };
    let seen: Vec<(Vector2<f64>, f64)> = (detect_particles(&last, &settings).unwrap().iter())
        .map(|d| (at(d.x_px, d.y_px), d.r_px * um_per_px))
        .collect();
    let site_at: Vec<Vector2<f64>> = s.sites.iter().map(|r| at(r.x_px, r.y_px)).collect();
    // In um throughout: the measure does not care for the unit. Within
    // 0.1 um: the detector sizes particles this far apart within 15 nm
    // (tracker.rs, ISOLATED_GAP_M); 0.03 um apart when written.
    let seen_um = seen_stray_gap_m(&site_at, &seen).expect("the frame shows a stray");
    assert!(
        (seen_um - gap_um).abs() < 0.1,
        "the final frame shows {seen_um} um, the report says {gap_um} um"
    );
}

/// The report's time by parts adds up to its time; its moves, timed as
/// commanded (distance at speed), agree with the simulated clock between
/// the journal's entries within 10 % (the rest: settling and coarse
/// moves); each part is at least its part of the bound; report.md says it.
#[test]
fn the_reported_time_splits_into_its_parts() {
    let (_, out, _) = run();
    let text = std::fs::read_to_string(out.join("report.json")).unwrap();
    let report: AssemblyReport = serde_json::from_str(&text).unwrap();
    let (spent, bound) = (report.time_split, report.lower_bound_split);
    let sum = spent.pushing_s + spent.travel_s + spent.other_s;
    assert!(
        (sum - report.time_s).abs() < 1e-6,
        "{spent:?} of {report:?}"
    );
    assert!((bound.pushing_s + bound.travel_s - report.lower_bound_s).abs() < 1e-9);
    assert!(spent.pushing_s >= bound.pushing_s, "{spent:?} {bound:?}");
    assert!(spent.travel_s >= bound.travel_s, "{spent:?} {bound:?}");
    let entries = read_journal::<RunEvent>(&out.join("journal.jsonl"))
        .unwrap()
        .entries;
    let travel_um_s = AssemblySettings::default().travel_speed_m_per_s * 1e6;
    let (mut clock_pushing, mut clock_travel) = (0.0, 0.0);
    for pair in entries.windows(2) {
        let dt = pair[1].t_s - pair[0].t_s;
        match pair[0].event {
            RunEvent::Move { speed_um_s, .. } if speed_um_s == travel_um_s => clock_travel += dt,
            RunEvent::Move { .. } => clock_pushing += dt,
            _ => {}
        }
    }
    let near = |a: f64, b: f64| (a - b).abs() <= 0.1 * b;
    assert!(
        near(spent.pushing_s, clock_pushing),
        "{spent:?}: clock {clock_pushing} s"
    );
    assert!(
        near(spent.travel_s, clock_travel),
        "{spent:?}: clock {clock_travel} s"
    );
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("| time spent | "), "{md}");
}

#[test]
fn files_read_back_and_agree() {
    let (_, out, rec) = run();
    let entries = read_journal::<RunEvent>(&out.join("journal.jsonl"))
        .unwrap()
        .entries;
    let RunEvent::Start(spec) = &entries[0].event else {
        panic!("no run spec first");
    };
    // sites.json carries the journal's sites.
    let s = sites(out);
    assert_eq!(s.sites.len(), spec.sites_um.len());
    // Written without float noise (35.00000000000001): at most 9 decimals.
    let text = std::fs::read_to_string(out.join("sites.json")).unwrap();
    let longest_decimals = text
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter_map(|n| n.split_once('.').map(|(_, d)| d.len()))
        .max();
    assert!(longest_decimals <= Some(9), "{text}");
    for (row, want) in s.sites.iter().zip(&spec.sites_um) {
        assert!((row.x_um - want[0]).abs() < 1e-9 && (row.y_um - want[1]).abs() < 1e-9);
    }
    // report.json round-trips and agrees with the journal.
    let text = std::fs::read_to_string(out.join("report.json")).unwrap();
    let report: AssemblyReport = serde_json::from_str(&text).unwrap();
    assert_eq!(serde_json::to_string_pretty(&report).unwrap(), text);
    let decisions = entries
        .iter()
        .filter(|e| matches!(e.event, RunEvent::Decision { .. }))
        .count();
    assert_eq!(report.pushes, decisions);
    // The simulated rig counts the tip's landings on particles: none here.
    assert_eq!(report.tip_landings_on_particles, Some(0), "{text}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("| tip lowered onto a particle | 0 times (ground truth) |"),
        "{md}"
    );
    // Its push log: every push decided, those made numbered 1.. as the
    // force charts and report.md's table number them.
    assert_eq!(report.push_log.len(), decisions);
    let numbers: Vec<Option<usize>> = report.push_log.iter().map(|p| p.n).collect();
    assert_eq!(numbers, (1..=decisions).map(Some).collect::<Vec<_>>());
    for p in &report.push_log {
        let row = format!(
            "| {} | {:.1} | {} | ",
            p.n.unwrap(),
            p.t_s,
            p.particle_label()
        );
        assert!(md.contains(&row), "report.md has no row {row}");
    }
    let to_sites = report
        .push_log
        .iter()
        .filter(|p| p.to_site.is_some())
        .count();
    assert!(to_sites > 0, "no push ends on a site");
    assert_eq!(report.filled, report.sites);
    // What was asked, enough to make the run again.
    let asked = report
        .asked
        .as_ref()
        .expect("the report says what was asked");
    assert_eq!((&asked.pattern, asked.seed), (&spec.pattern, spec.seed));
    assert!(
        asked
            .command
            .as_ref()
            .is_some_and(|c| c.contains("nanopush assemble --out")),
        "{asked:?}"
    );
    assert_eq!(report.placed_tolerance_nm, Some(200.0));
    // The animation has one picture per analysed frame.
    let observations = entries
        .iter()
        .filter(|e| matches!(e.event, RunEvent::Observation { .. }))
        .count();
    let video = load_frames(&out.join("run.mp4"), Channel::Luminance).unwrap();
    assert_eq!(video.len(), observations);
    // The recording reads back with one frame per observation, and the
    // recorded first frame is the journal's first observation.
    let recording = open_recording(rec).unwrap();
    assert_eq!(
        recording.frames().unwrap().map(Result::unwrap).count(),
        observations
    );
    let first_obs_t = entries
        .iter()
        .find(|e| matches!(e.event, RunEvent::Observation { .. }))
        .unwrap()
        .t_s;
    assert_eq!(recording.time_s(0), first_obs_t);
    // Force plots: one chart per six pushes, SVG and PNG.
    let charts = decisions.div_ceil(6);
    for k in 1..=charts {
        for ext in ["svg", "png"] {
            assert!(out.join(format!("pushes-force-{k}.{ext}")).is_file());
        }
    }
    assert!(
        !out.join(format!("pushes-force-{}.svg", charts + 1))
            .exists()
    );
}

#[test]
fn report_md_links_only_to_files_that_exist() {
    let (_, out, _) = run();
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let links: Vec<&str> = md
        .split("](")
        .skip(1)
        .filter_map(|rest| rest.split(')').next())
        .collect();
    for want in [
        "final.png",
        "run.mp4",
        "pushes-force-1.png",
        "journal.jsonl",
        "sites.json",
        "report.json",
    ] {
        assert!(links.contains(&want), "report.md does not link {want}");
    }
    for l in links {
        assert!(out.join(l).is_file(), "report.md links to missing {l}");
    }
    assert!(md.contains("| 6 |"), "a row per site");
    assert!(
        md.contains("Asked: pattern") && md.contains("Command: `nanopush"),
        "{md}"
    );
    assert!(md.contains("(a particle within 200 nm)"), "{md}");
}

#[test]
fn the_pattern_is_built_where_asked_at_the_pitch_and_turn_asked() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // `nanopush assemble --out OUT` with the run's arguments and `flags`.
    let assemble = |out: &Path, flags: &[&str]| {
        binary()
            .args(["assemble", "--out", out.to_str().unwrap()])
            .args(RUN)
            .args(flags)
            .output()
            .unwrap()
    };
    let placed = [
        "--at",
        "60,50",
        "--pitch-um",
        "11.5",
        "--rotation-deg",
        "90",
    ];
    let o = assemble(&out, &placed);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = sites(&out);
    let xs: Vec<f64> = s.sites.iter().map(|r| r.x_um).collect();
    let ys: Vec<f64> = s.sites.iter().map(|r| r.y_um).collect();
    let span = |v: &[f64]| {
        let (lo, hi) = v
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        ((lo + hi) / 2.0, hi - lo)
    };
    let ((cx, w), (cy, h)) = (span(&xs), span(&ys));
    assert!(
        (cx - 60.0).abs() < 1e-6 && (cy - 50.0).abs() < 1e-6,
        "centre ({cx}, {cy})"
    );
    // L stands 4 pitches tall and 2 wide; a quarter turn lays it down.
    assert!(
        (w - 46.0).abs() < 1e-6 && (h - 23.0).abs() < 1e-6,
        "{w} x {h} um"
    );
    for (i, a) in s.sites.iter().enumerate() {
        let nearest = s
            .sites
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, b)| (a.x_um - b.x_um).hypot(a.y_um - b.y_um))
            .fold(f64::MAX, f64::min);
        assert!((nearest - 11.5).abs() < 1e-6, "site {i}: {nearest} um");
    }
    // The camera shows the pattern built there.
    let last = load_frame(&out.join("final.png"), Channel::Luminance).unwrap();
    assert_eq!(sites_shown(&last, &s), s.sites.len());

    // Asked for what cannot be: refused before the folder is made.
    let refused = [
        (
            &["--at", "5,50"][..],
            "outside the reachable area (its centre may lie from (",
        ),
        (
            &["--pitch-um", "0"][..],
            "--pitch-um must be finite and > 0",
        ),
        (&["--pitch-um", "8"][..], "does not fit the scene"),
    ];
    for (flags, why) in refused {
        let out = dir.path().join("refused");
        let o = assemble(&out, flags);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(why), "{flags:?}: {err}");
        assert!(!out.exists(), "{flags:?} made the output folder");
    }
    // A resumed run keeps its journal's sites, scene, seed and world: a
    // flag that would change them is refused, not ignored.
    for flag in [
        ["--at", "60,50"],
        ["--seed", "5"],
        ["--particles", "30"],
        ["--scene", "calib/hard-high-adhesion.toml"],
    ] {
        let o = binary()
            .args(["assemble", "--resume"])
            .arg(out.join("journal.jsonl"))
            .args(flag)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains("cannot be used with"),
            "{flag:?}: {err}"
        );
    }
    // A hardware run has no simulated noise: its --seed was taken and ignored.
    let o = binary()
        .args(["assemble", "--rig", "calib/rig-gcs-sim-folder.toml"])
        .args(["--text", "L", "--seed", "3"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("cannot be used with") && err.contains("--seed"),
        "{err}"
    );
}

#[test]
fn a_pattern_that_does_not_fit_the_scene_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("keep.txt"), "earlier work").unwrap();
    // Sites 6 um apart cannot hold 10 um spheres.
    let pattern = dir.path().join("tight.toml");
    std::fs::write(
        &pattern,
        "sites = [ { x_um = 0.0, y_um = 0.0 }, { x_um = 6.0, y_um = 0.0 } ]\n",
    )
    .unwrap();
    let o = binary()
        .args(["assemble", "--pattern", pattern.to_str().unwrap()])
        .args([
            "--out",
            out.to_str().unwrap(),
            "--seed",
            "6",
            "--particles",
            "20",
        ])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("does not fit the scene"), "{err}");
    let names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("keep.txt")]);
    assert_eq!(
        std::fs::read_to_string(out.join("keep.txt")).unwrap(),
        "earlier work"
    );
}

#[test]
fn a_record_folder_that_cannot_be_made_leaves_out_unwritten_and_retryable() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let blocker = dir.path().join("blocker");
    std::fs::write(&blocker, "a file, not a folder").unwrap();
    let record = blocker.join("rec");
    for attempt in 0..2 {
        let o = assemble_recorded(&out, &record);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "attempt {attempt}: {err}");
        assert!(!out.join("journal.jsonl").exists(), "attempt {attempt}");
        assert!(!err.contains("journal"), "attempt {attempt}: {err}");
        assert!(err.contains("--record") && err.contains("blocker"), "{err}");
    }
}

/// An --out that holds a run, or is a file, is refused before the
/// --record folder is made: made first, it had refused the corrected
/// command ("already holds recording.toml").
#[test]
fn an_out_holding_a_run_is_refused_before_the_recording_is_made() {
    let (_, out, _) = run();
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let o = assemble_recorded(out, &rec);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    // A finished run: --resume, which would be refused, is not offered.
    assert!(err.contains("holds a finished run"), "{err}");
    assert!(!rec.exists(), "{err}");
    let file = dir.path().join("a-file");
    std::fs::write(&file, "notes").unwrap();
    let o = assemble_recorded(&file, &rec);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("is a file: give a folder"), "{err}");
    assert!(!rec.exists(), "{err}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "notes");
}

#[test]
fn resuming_a_finished_run_is_refused_and_leaves_its_journal_alone() {
    let (_, out, _) = run();
    let dir = tempfile::tempdir().unwrap();
    for entry in std::fs::read_dir(out).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            std::fs::copy(&path, dir.path().join(path.file_name().unwrap())).unwrap();
        }
    }
    let journal = dir.path().join("journal.jsonl");
    let before = std::fs::read(&journal).unwrap();
    let o = binary()
        .args(["assemble", "--resume", journal.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("run already finished at"), "{err}");
    assert!(err.contains("nothing to resume"), "{err}");
    assert_eq!(std::fs::read(&journal).unwrap(), before, "journal changed");
    // --out is not where a resumed run writes: refused, not ignored.
    let o = binary()
        .args(["assemble", "--resume", journal.to_str().unwrap()])
        .args(["--out", dir.path().join("elsewhere").to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("--out"), "{err}");
    assert_eq!(std::fs::read(&journal).unwrap(), before, "journal changed");
}

/// `--keep-clear-um` is checked before any work, in the flag's name; a
/// run keeps half the particle radius unless told (the default scene's
/// spheres are 5 um in radius), and its gap is in its journal's start
/// entry, where a resume reads it.
#[test]
fn keep_clear_is_checked_first_and_journalled() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = |gap: &[&str]| {
        let _ = std::fs::remove_dir_all(&out);
        binary()
            .args(["assemble", "--text", "I"])
            .args(gap)
            .args(["--out", out.to_str().unwrap(), "--seed", "6"])
            .output()
            .unwrap()
    };
    let o = run(&["--keep-clear-um", "-1"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("--keep-clear-um is -1.000 (must be finite, >= 0"),
        "{err}"
    );
    assert!(!out.exists(), "--out made for a refused flag");
    for (gap, journalled) in [(&[][..], "2.5"), (&["--keep-clear-um", "1.5"][..], "1.5")] {
        let o = run(gap);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let journal = std::fs::read_to_string(out.join("journal.jsonl")).unwrap();
        let start = journal.lines().nth(1).unwrap();
        let wanted = format!(r#""keep_clear_um":{journalled}"#);
        assert!(start.contains(&wanted), "{gap:?}: {start}");
    }
}
