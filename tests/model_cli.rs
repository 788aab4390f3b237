//! `nanopush simulate` / `study model` / `demo` from the outside: JSON fields,
//! output files read back, bad scenes refused with the field named.

use nanopush::model::series_csv;
use nanopush::model::summary::PushSummary;
use std::path::{Path, PathBuf};
use std::process::Command;

mod paper_scene;
use paper_scene::{RIDE_OVER, scene_file};

fn nanopush() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_nanopush"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn paper_text() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml"))
        .unwrap()
}

#[test]
fn simulate_json_has_the_required_fields_and_reads_back() {
    let out = nanopush()
        .args(["simulate", "--scene", "calib/paper-ps-ito.toml", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for k in [
        "mode",
        "onset_s",
        "force_at_onset_uN",
        "displacement_um",
        "critical_rolling_uN",
        "critical_sliding_uN",
        "outcome",
        "active_effects",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    let s: PushSummary = serde_json::from_value(v).unwrap();
    assert_eq!(s.schema, "nanopush.push-summary/1");
    assert_eq!(s.outcome, "rolling");
    assert!(s.active_effects.iter().all(|e| !e.reason.is_empty()));
}

/// `nanopush simulate --scene SCENE --json` run from `dir`.
fn simulate_in(dir: &Path, scene: &str) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .current_dir(dir)
        .args(["simulate", "--scene", scene, "--json"])
        .output()
        .unwrap()
}

#[test]
fn the_default_scene_is_built_in_outside_the_project_folder() {
    let elsewhere = tempfile::tempdir().unwrap();
    let project = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (outside, inside) = (
        simulate_in(elsewhere.path(), "calib/paper-ps-ito.toml"),
        simulate_in(project, "calib/paper-ps-ito.toml"),
    );
    assert!(
        outside.status.success(),
        "{}",
        String::from_utf8_lossy(&outside.stderr)
    );
    assert_eq!(outside.stdout, inside.stdout);
    // Any other missing scene is still an error naming it.
    let out = simulate_in(elsewhere.path(), "calib/other.toml");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("scene calib/other.toml: cannot read") && !err.contains("field"),
        "{err}"
    );
}

#[test]
fn simulate_stuck_reports_null_onset() {
    let out = nanopush()
        .args([
            "simulate",
            "--scene",
            "calib/paper-ps-ito.toml",
            "--json",
            "--duration-s",
            "2",
        ])
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["onset_s"].is_null());
    assert_eq!(v["outcome"], "stuck");
}

#[test]
fn simulate_out_writes_plots_and_a_csv_that_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = nanopush()
        .args(["simulate", "--scene", "calib/paper-ps-ito.toml", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "push-force.svg",
        "push-force.png",
        "push-position.svg",
        "push-position.png",
    ] {
        assert!(dir.path().join(f).metadata().unwrap().len() > 1000, "{f}");
    }
    let rows =
        series_csv::from_csv(&std::fs::read_to_string(dir.path().join("push-series.csv")).unwrap())
            .unwrap();
    assert_eq!(rows.len(), 601);
    let last = rows.last().unwrap();
    assert!((last.t_s - 30.0).abs() < 1e-9);
    assert!((last.particle_m * 1e6 - 21.0).abs() < 0.5);
    // rows -> CSV -> rows is stable to rounding of the unit conversion.
    let again = series_csv::from_csv(&series_csv::to_csv(&rows)).unwrap();
    let close = |a: f64, b: f64| a == b || (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
    for (a, b) in rows.iter().zip(&again) {
        assert!(
            close(a.t_s, b.t_s)
                && close(a.stage_m, b.stage_m)
                && close(a.tip_m, b.tip_m)
                && close(a.particle_m, b.particle_m)
        );
        assert!(
            close(a.force_n, b.force_n)
                && close(a.critical_rolling_n, b.critical_rolling_n)
                && close(a.critical_sliding_n, b.critical_sliding_n)
        );
    }
}

fn bad_scene(edit: impl Fn(String) -> String) -> (bool, String) {
    let dir = tempfile::tempdir().unwrap();
    let p: PathBuf = dir.path().join("bad.toml");
    std::fs::write(&p, edit(paper_text())).unwrap();
    let out = nanopush()
        .args(["simulate", "--scene"])
        .arg(&p)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

/// A text edit turning the paper scene into a bad one.
type Edit = Box<dyn Fn(String) -> String>;

#[test]
fn bad_scenes_exit_non_zero_naming_the_field() {
    let cases: Vec<(&str, Edit)> = vec![
        (
            "particle.radius_um",
            Box::new(|s: String| s.replace("radius_um = 5.0", "radius_um = -5.0")),
        ),
        (
            "particle.radius_um",
            Box::new(|s: String| s.replace("radius_um = 5.0", "radius_um = nan")),
        ),
        (
            "particle.radius_um",
            Box::new(|s: String| s.replace("radius_um = 5.0          # R_p", "")),
        ),
        (
            "probe.material",
            Box::new(|s: String| s.replace("material = \"silicon\"", "material = \"unobtainium\"")),
        ),
        (
            "interfaces.particle_substrate.contact_model",
            Box::new(|s: String| s.replace("contact_model = \"jkr\"", "contact_model = \"magic\"")),
        ),
        (
            "push.angle_deg",
            Box::new(|s: String| s.replace("angle_deg = 45.0", "angle_deg = 95.0")),
        ),
        (
            "push.angle_deg",
            Box::new(|s: String| s.replace("angle_deg = 45.0", "angle_deg = 0.0")),
        ),
        (
            "push",
            Box::new(|s: String| s.split("[push]").next().unwrap().to_string()),
        ),
        (
            "radius_mm",
            Box::new(|s: String| s.replace("radius_um = 5.0", "radius_mm = 5.0")),
        ),
        (
            // A unit slip: Pa under a GPa key (simulated a 3.9e16 N/m ramp).
            "materials.silicon.youngs_modulus_gpa",
            Box::new(|s: String| {
                s.replace("youngs_modulus_gpa = 169.0", "youngs_modulus_gpa = 169e9")
            }),
        ),
        (
            // Metres under a um key.
            "probe.length_um",
            Box::new(|s: String| s.replace("length_um = 225.0", "length_um = 225e-6")),
        ),
    ];
    for (field, edit) in cases {
        let (ok, err) = bad_scene(edit);
        assert!(!ok, "accepted a bad scene ({field})");
        assert!(err.contains(field), "error does not name `{field}`: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn bad_flags_exit_non_zero() {
    let out = nanopush()
        .args([
            "simulate",
            "--scene",
            "calib/paper-ps-ito.toml",
            "--angle-deg",
            "90",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let out = nanopush()
        .args(["simulate", "--scene", "no/such/scene.toml"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    // A negative value is said to be one (it had been "unexpected argument '-1'").
    for flag in ["--speed-um-s", "--duration-s", "--radius-um"] {
        let out = nanopush()
            .args(["simulate", "--scene", "calib/paper-ps-ito.toml", flag, "-1"])
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && said.contains("must be positive") && said.contains(flag),
            "{said}"
        );
    }
    // A flag's unit slip is refused as the scene file's would be (a speed
    // in m/s had simulated a push at 1 pm/s without a word).
    for (flag, value, slip) in [
        ("--speed-um-s", "1e-6", "looks like m/s"),
        ("--duration-s", "2e-5", "plausible range is"),
        ("--radius-um", "5e-6", "looks like m"),
    ] {
        let out = nanopush()
            .args([
                "simulate",
                "--scene",
                "calib/paper-ps-ito.toml",
                flag,
                value,
            ])
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success()
                && said.contains(flag)
                && said.contains("implausible")
                && said.contains(slip),
            "{flag} {value}: {said}"
        );
    }
}

#[test]
fn study_writes_a_table_that_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    // Run from outside the project folder: the default scenes are built in.
    let out = nanopush()
        .current_dir(dir.path())
        .args(["study", "model", "--repeats", "1", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = nanopush::model::study::from_csv(
        &std::fs::read_to_string(dir.path().join("study-model.csv")).unwrap(),
    )
    .unwrap();
    assert_eq!(rows.len(), 3 * nanopush::model::study::settings().len());
    assert!(rows.iter().all(|r| r.wall_us > 0.0));
    assert!(
        dir.path().join("study-model.png").exists() && dir.path().join("study-model.md").exists()
    );
    assert_eq!(
        nanopush::model::study::from_csv(&nanopush::model::study::to_csv(&rows)).unwrap(),
        rows
    );
    // Run again into the same folder: refused before any work, the table
    // kept, unless --force (it had been replaced without a word). The advice
    // names a folder, as --out takes (it had said "another file").
    let table = std::fs::read(dir.path().join("study-model.csv")).unwrap();
    let again = |force: bool| {
        let mut cmd = nanopush();
        cmd.args(["study", "model", "--repeats", "1", "--out"])
            .arg(dir.path());
        if force {
            cmd.arg("--force");
        }
        cmd.output().unwrap()
    };
    let refused = again(false);
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success()
            && said.contains("study-model.md exists")
            && said.contains("--force")
            && said.contains("or --out another folder"),
        "{said}"
    );
    assert_eq!(
        std::fs::read(dir.path().join("study-model.csv")).unwrap(),
        table
    );
    assert!(again(true).status.success());
}

/// Requests that cannot run fail at once, say why, and write nothing.
#[test]
fn bad_study_and_demo_requests_fail_before_writing_anything() {
    let dir = tempfile::tempdir().unwrap();
    let fails = |args: &[&str], says: &str| {
        let out = nanopush().args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    };
    fails(&["study", "model", "--repeats", "0"], "1..=10000");
    fails(
        &["study", "model", "--repeats", "18446744073709551615"],
        "--repeats",
    );
    let a_file = dir.path().join("a-file");
    std::fs::write(&a_file, "").unwrap();
    let a_file = a_file.to_str().unwrap();
    fails(
        &["study", "model", "--repeats", "1", "--out", a_file],
        a_file,
    );
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    fails(
        &["study", "assemble", "--text", "é", "--out", out],
        "unknown glyph",
    );
    fails(&["demo", "--text", "é", "--out", out], "unknown glyph");
    assert!(!Path::new(out).exists(), "a refused request wrote {out}");
}

/// A demo whose assembly stops short (a scene where the tip rides over the
/// particle at every contact angle, so no push is safe) says where its
/// report is, then exits non-zero: a script had read the stop as success.
#[test]
fn a_demo_that_stops_short_fails_after_saying_where_its_report_is() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_file(dir.path(), "ride-over.toml", &RIDE_OVER);
    let out = nanopush()
        .args(["demo", "--scene"])
        .arg(&scene)
        .args(["--seed", "4", "--out"])
        .arg(dir.path().join("demo"))
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{said}");
    assert!(err.contains("the assembly stopped short"), "{err}");
    let report = dir.path().join("demo").join("assemble").join("report.md");
    assert!(report.is_file());
    assert!(
        said.contains(&format!("report: {}", report.display())),
        "{said}"
    );
}

#[test]
fn demo_writes_the_paper_scene_plots_and_runs_the_assembly() {
    let dir = tempfile::tempdir().unwrap();
    let out = nanopush()
        .args(["demo", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let push = dir.path().join("paper-push");
    assert!(push.join("push-force.png").exists());
    let s: PushSummary =
        serde_json::from_str(&std::fs::read_to_string(push.join("push-summary.json")).unwrap())
            .unwrap();
    assert_eq!(s.outcome, "rolling");
    // The assembly ran on the simulated rig and left its report and journal.
    let assembly = dir.path().join("assemble");
    assert!(assembly.join("report.json").exists());
    assert!(assembly.join("journal.jsonl").exists());
    // Where the report is, said once.
    let said = String::from_utf8_lossy(&out.stdout);
    let report = format!("report: {}", assembly.join("report.md").display());
    assert_eq!(said.matches(&report).count(), 1, "{said}");
}
