//! The planner's command line: bad input gives a clear error and a non-zero
//! exit (never a panic); plan files and layouts round-trip through the tools.

use std::path::Path;
use std::process::Command;

fn nanopush(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .args(args)
        .output()
        .expect("binary runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!text.contains("panicked"), "panic for {args:?}: {text}");
    (out.status.success(), text)
}

fn write_layout(
    dir: &Path,
    name: &str,
    particles: &[(f64, f64, f64)],
    field: (f64, f64),
) -> String {
    let ps: Vec<String> = particles
        .iter()
        .enumerate()
        .map(|(i, (x, y, r))| {
            format!("{{\"id\": {i}, \"x_um\": {x}, \"y_um\": {y}, \"radius_um\": {r}}}")
        })
        .collect();
    let text = format!(
        "{{\"schema\": \"nanopush.layout/1\", \"field_um\": [{}, {}], \"particles\": [{}]}}",
        field.0,
        field.1,
        ps.join(",")
    );
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// Another tool's plan, the fields the format names only: particle 0 pushed
/// from (20, 20) to (20, 50) um.
fn write_pushing_20_20_to_20_50(dir: &Path) -> String {
    let plan = dir.join("other-tool.json");
    std::fs::write(
        &plan,
        r#"{"schema": "nanopush.plan/1", "sites": [{"id": 0, "x_um": 20, "y_um": 50}],
            "assignment": [{"particle": 0, "site": 0}],
            "steps": [{"kind": "push", "particle": 0, "from_um": [20, 20], "to_um": [20, 50],
                       "approach_um": [20, 14], "contact_angle_deg": 0}]}"#,
    )
    .unwrap();
    plan.display().to_string()
}

/// `verify-plan` exits as diff does: 0 for a plan that replays clean, 1 for
/// one that fails, 2 when it cannot check (a missing plan or layout, a bad
/// flag): both had been 1, a mistyped path taken for a bad plan.
#[test]
fn verify_plan_tells_a_failed_plan_from_one_it_cannot_check() {
    let dir = tempfile::tempdir().unwrap();
    let layout = write_layout(dir.path(), "l.json", &[(20.0, 20.0, 5.0)], (100.0, 100.0));
    let plan = write_pushing_20_20_to_20_50(dir.path());
    let plan = plan.as_str();
    let code = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_nanopush"))
            .arg("verify-plan")
            .args(extra)
            .output()
            .unwrap()
            .status
            .code()
    };
    let missing = dir.path().join("none.json");
    let missing = missing.to_str().unwrap();
    assert_eq!(code(&[plan, "--layout", &layout]), Some(0));
    let short_range = ["--nanostage-range-um", "20"];
    assert_eq!(
        code(&[&[plan, "--layout", &layout], &short_range[..]].concat()),
        Some(1)
    );
    assert_eq!(code(&[missing, "--layout", &layout]), Some(2));
    assert_eq!(code(&[plan, "--layout", missing]), Some(2));
    assert_eq!(
        code(&[plan, "--layout", &layout, "--tolerance-um", "-1"]),
        Some(2)
    );
    assert_eq!(
        code(&[plan, "--layout", &layout, "--tip-radius-um", "0"]),
        Some(2)
    );
}

/// Another tool's plan with only the fields the plan format names (no
/// geometry, no summary) is replayed with `nanopush plan`'s geometry, and
/// says so; a collaborator's plan is checked against one's own probe and
/// stage by flags, which the report names (it trusted the file's numbers
/// and never showed them); a flag of no size is refused by name.
#[test]
fn verify_plan_says_what_geometry_it_replays_and_takes_ones_own() {
    let dir = tempfile::tempdir().unwrap();
    let layout = write_layout(dir.path(), "l.json", &[(20.0, 20.0, 5.0)], (100.0, 100.0));
    let plan = write_pushing_20_20_to_20_50(dir.path());
    let plan = plan.as_str();
    let (ok, text) = nanopush(&["verify-plan", plan, "--layout", &layout]);
    assert!(ok, "{text}");
    assert!(
        text.contains("tip radius 1 um (default: the plan gives none)"),
        "{text}"
    );
    let (ok, text) = nanopush(&[
        "verify-plan",
        plan,
        "--layout",
        &layout,
        "--nanostage-range-um",
        "20",
        "--json",
    ]);
    assert!(!ok, "{text}");
    let report: serde_json::Value =
        serde_json::from_str(text.split("\nerror:").next().unwrap()).unwrap();
    assert_eq!(report["geometry"]["nanostage_range_um"], 20.0);
    assert_eq!(report["geometry_from"]["nanostage_range_um"], "given");
    assert_eq!(
        report["geometry_from"]["tip_radius_um"],
        "default: the plan gives none"
    );
    assert_eq!(report["unreachable"], serde_json::json!([0]));
    let (ok, text) = nanopush(&[
        "verify-plan",
        plan,
        "--layout",
        &layout,
        "--tip-radius-um",
        "0",
    ]);
    assert!(!ok && text.contains("tip_radius_um is 0"), "{text}");
    // A narrower tip than the plan's touches a little later: ok; a wider
    // one would land on the particle (every override had failed the plan).
    let tip = |r: &str| {
        nanopush(&[
            "verify-plan",
            plan,
            "--layout",
            &layout,
            "--tip-radius-um",
            r,
        ])
    };
    let (ok, text) = tip("0.8");
    assert!(ok, "{text}");
    let (ok, text) = tip("1.2");
    assert!(!ok && text.contains("approach"), "{text}");
}

/// Touching particles whose radii another tool measured a little large
/// (overlapping by 30 nm) plan, the pair pushed apart, and `verify-plan`
/// on the same file finds the plan clean: both read the pair as touching
/// (the file had been refused, "particles 0 and 1 overlap by 0.030 um").
#[test]
fn touching_particles_measured_a_little_large_plan_and_verify() {
    let dir = tempfile::tempdir().unwrap();
    let mut particles = vec![(40.0, 40.0, 5.0), (49.97, 40.0, 5.0)];
    particles.extend((0..10).map(|k| (8.0 + 12.0 * k as f64, 85.0, 5.0)));
    let layout = write_layout(dir.path(), "touching.json", &particles, (125.0, 100.0));
    let plan = dir.path().join("plan.json");
    let plan = plan.to_str().unwrap();
    let (ok, text) = nanopush(&[
        "plan", "--text", "I", "--layout", &layout, "--at", "45,40", "--out", plan,
    ]);
    assert!(ok, "{text}");
    assert!(
        text.contains(
            "1 pair of particles overlaps by up to 0.030 um (particles 0 and 1): read as touching"
        ),
        "{text}"
    );
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(plan).unwrap()).unwrap();
    let pushed: std::collections::HashSet<u64> = file["steps"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["kind"] == "push")
        .map(|s| s["particle"].as_u64().unwrap())
        .collect();
    assert!(pushed.contains(&0) || pushed.contains(&1), "{pushed:?}");
    let (ok, text) = nanopush(&["verify-plan", plan, "--layout", &layout]);
    assert!(ok && text.contains("collisions        0"), "{text}");
}

/// What is wrong inside a layout or a plan file is said with the file's
/// name ("layout: particles 0 and 1 overlap" had named none), once.
#[test]
fn errors_in_a_files_content_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let bad_layout = write_layout(
        dir.path(),
        "touching.json",
        &[(20.0, 20.0, 5.0), (29.9, 20.0, 5.0)],
        (100.0, 100.0),
    );
    let (ok, text) = nanopush(&["plan", "--text", "I", "--layout", &bad_layout]);
    assert!(!ok);
    assert!(
        text.contains(&format!(
            "layout file {bad_layout}: particles 0 and 1 overlap by 0.100 um"
        )),
        "{text}"
    );
    let good_layout = write_layout(dir.path(), "one.json", &[(20.0, 20.0, 5.0)], (100.0, 100.0));
    let plan = dir.path().join("steep.json");
    std::fs::write(
        &plan,
        r#"{"schema": "nanopush.plan/1", "sites": [], "assignment": [],
            "steps": [{"kind": "push", "particle": 0, "from_um": [20, 20], "to_um": [20, 50],
                       "approach_um": [20, 14], "contact_angle_deg": 90}]}"#,
    )
    .unwrap();
    let plan = plan.to_str().unwrap();
    let (ok, text) = nanopush(&["verify-plan", plan, "--layout", &good_layout]);
    assert!(!ok);
    assert!(
        text.contains(&format!("plan file {plan}: step 0 contact_angle_deg is 90")),
        "{text}"
    );
    assert_eq!(text.matches(plan).count(), 1, "{text}");
}

/// Three particles at the bottom of an empty 200 x 200 um field.
fn easy_layout(dir: &Path) -> String {
    write_layout(
        dir,
        "easy.json",
        &[
            (20.0, 15.0, 5.0),
            (60.0, 15.0, 5.0),
            (100.0, 15.0, 5.0),
            (140.0, 15.0, 5.0),
        ],
        (200.0, 200.0),
    )
}

#[test]
fn bad_input_is_a_clear_error_with_non_zero_exit() {
    let dir = tempfile::tempdir().unwrap();
    let easy = easy_layout(dir.path());
    // `plan --text TEXT --layout easy MORE...`
    let on_easy = |text: &str, more: &[&str]| -> Vec<String> {
        let head = ["plan", "--text", text, "--layout", &easy];
        head.iter().chain(more).map(|s| s.to_string()).collect()
    };
    let frame = [
        "plan", "--text", "I", "--frame", "f.png", "--calib", "c.toml",
    ];
    let cases: Vec<(Vec<String>, &str)> = vec![
        (on_easy("C?", &[]), "unknown glyph"),
        (on_easy(" ", &[]), "empty pattern"),
        (on_easy("CMU", &[]), "only 4 particles"),
        (on_easy("I", &["--pitch-um", "NaN"]), "pitch-um"),
        (
            on_easy("I", &["--rotation-deg", "1e300"]),
            "--rotation-deg must be within -360 and 360",
        ),
        (
            on_easy("I", &["--contact-angle-deg", "120"]),
            "--contact-angle-deg is 120.000 (must be in 0..90",
        ),
        (
            on_easy("I", &["--speed-um-s", "0"]),
            "--speed-um-s is 0 (must be finite and > 0)",
        ),
        // An infinite predicted time had been written to the plan as null.
        (
            on_easy("I", &["--speed-um-s", "1e-310"]),
            "must be at least 0.001 um/s",
        ),
        (
            on_easy("I", &["--tip-radius-um", "1e9"]),
            "--tip-radius-um is 1000000000 (must be at most half",
        ),
        (
            on_easy("I", &["--keep-clear-um", "-1"]),
            "--keep-clear-um is -1.000 (must be finite, >= 0 and at most 25 um",
        ),
        (
            on_easy("I", &["--keep-clear-um", "NaN"]),
            "--keep-clear-um is NaN",
        ),
        (
            on_easy("I", &["--keep-clear-um", "30"]),
            "--keep-clear-um is 30.000 (must be finite, >= 0 and at most 25 um",
        ),
        (on_easy("I", &["--pitch-um", "5"]), "overlap"),
        (on_easy("I", &["--at", "5,5"]), "outside the reachable area"),
        // Negative numbers reach the checks (not the argument parser).
        (
            on_easy("I", &["--pitch-um", "-3"]),
            "must be finite and > 0",
        ),
        (
            on_easy("I", &["--at", "-5,10"]),
            "outside the reachable area",
        ),
        (on_easy("MMMMMMMMMMMMMMMMMMMMM", &[]), "does not fit"),
        // Flags of --frame given with a layout were taken and ignored.
        (
            on_easy("I", &["--calib", "c.toml"]),
            "--calib is for --frame",
        ),
        // Not "--frame and --calib are required", as if they went with --layout.
        (
            on_easy("I", &["--radius-um", "3"]),
            "--radius-um is for --frame",
        ),
        (
            on_easy("I", &["--channel", "green"]),
            "--channel is for --frame",
        ),
        (
            [
                "plan",
                "--pattern",
                "patterns/hexagon.toml",
                "--layout",
                &easy,
            ]
            .iter()
            .chain(&["--pitch-um", "12"])
            .map(|s| s.to_string())
            .collect(),
            "no pitch applies",
        ),
        (frame.iter().map(|s| s.to_string()).collect(), "c.toml"),
    ];
    // Synthetic layouts: negative numbers reach the checks, and a layout of
    // no particle is refused (it was written, exit 0).
    let synth_out = dir.path().join("synth.json");
    let synth = |more: &[&str]| -> Vec<String> {
        let out = synth_out.to_str().unwrap();
        let head = ["synth", "layout", "--out", out];
        head.iter().chain(more).map(|s| s.to_string()).collect()
    };
    let cases = cases.into_iter().chain([
        (synth(&["--n", "5", "--radius-um", "-5"]), "radius_um is -5"),
        (
            synth(&["--n", "5", "--min-gap-um", "-1"]),
            "min_gap_um is -1",
        ),
        (
            synth(&["--n", "5", "--field-um", "-120x100"]),
            "width_um is -120 (must",
        ),
        (synth(&["--n", "0"]), "at least one particle"),
    ]);
    for (args, expect) in cases {
        let refs: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        let (ok, text) = nanopush(&refs);
        assert!(!ok, "{args:?} should fail");
        assert!(
            text.contains(expect),
            "{args:?}: expected {expect:?} in {text}"
        );
    }
    assert!(!synth_out.exists(), "a refused layout was written");
    let negative = write_layout(
        dir.path(),
        "neg.json",
        &[(20.0, 15.0, -5.0)],
        (200.0, 200.0),
    );
    let (ok, text) = nanopush(&["plan", "--text", "I", "--layout", &negative]);
    assert!(!ok && text.contains("radius_um"), "{text}");
    let overlapping = dir.path().join("sites.toml");
    std::fs::write(
        &overlapping,
        "sites = [{ x_um = 0.0, y_um = 0.0 }, { x_um = 4.0, y_um = 0.0 }]",
    )
    .unwrap();
    let (ok, text) = nanopush(&[
        "plan",
        "--pattern",
        overlapping.to_str().unwrap(),
        "--layout",
        &easy,
    ]);
    assert!(!ok && text.contains("overlap"), "{text}");
    // A missing file is named with its cause, and the cause said once.
    let missing = dir.path().join("missing.json");
    let (ok, text) = nanopush(&["plan", "--text", "I", "--layout", missing.to_str().unwrap()]);
    assert!(!ok && text.contains("missing.json"), "{text}");
    assert_eq!(
        text.matches("No such file or directory").count(),
        1,
        "{text}"
    );
}

/// The drawing of a plan from a layout has a key naming its marks (it had
/// none: grey discs, black rings and red and orange arrows were left to
/// guess), under the field, so it hides no particle.
#[test]
fn a_plans_drawing_from_a_layout_has_a_key_of_its_marks() {
    let dir = tempfile::tempdir().unwrap();
    let easy = easy_layout(dir.path());
    let sites = dir.path().join("sites.json");
    std::fs::write(
        &sites,
        r#"{"sites": [{"x_um": 0, "y_um": 0}, {"x_um": 11, "y_um": 0}]}"#,
    )
    .unwrap();
    let svg = dir.path().join("plan.svg");
    let (ok, text) = nanopush(&[
        "plan",
        "--pattern",
        sites.to_str().unwrap(),
        "--layout",
        &easy,
        "--at",
        "100,120",
        "--overlay",
        svg.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let drawing = std::fs::read_to_string(&svg).unwrap();
    let texts: Vec<&str> = drawing
        .split("</text>")
        .filter_map(|piece| piece.rsplit_once('>').map(|(_, t)| t.trim()))
        .filter(|t| !t.is_empty())
        .collect();
    assert_eq!(
        texts,
        [
            "particle",
            "site of the pattern",
            "push onto a site (dot: where it ends)",
            "push to a buffer spot or waypoint",
            "tip travel between pushes (tip lifted)",
        ]
    );
    // The key lies below the field's 200 um at 6 px a um.
    let svg_height = drawing
        .split("height=\"")
        .nth(1)
        .and_then(|h| h.split('"').next())
        .and_then(|h| h.parse::<u32>().ok())
        .unwrap();
    assert!(svg_height > 1200, "{svg_height}");
}

#[test]
fn plan_writes_a_file_that_verify_plan_accepts_and_synth_layout_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let easy = easy_layout(dir.path());
    let plan = dir.path().join("plan.json");
    let svg = dir.path().join("plan.svg");
    let (ok, text) = nanopush(&[
        "plan",
        "--text",
        "I",
        "--layout",
        &easy,
        "--pitch-um",
        "11",
        "--at",
        "100,120",
        "--out",
        plan.to_str().unwrap(),
        "--overlay",
        svg.to_str().unwrap(),
        "--json",
    ]);
    // "I" needs 9 sites but the layout has 4 particles: refused with the counts.
    assert!(!ok && text.contains("9 sites"), "{text}");
    let sites = dir.path().join("sites.json");
    std::fs::write(
        &sites,
        r#"{"sites": [{"x_um": 0, "y_um": 0}, {"x_um": 11, "y_um": 0}, {"x_um": 22, "y_um": 0}]}"#,
    )
    .unwrap();
    // The three-site pattern on the easy layout, with more arguments.
    let plan_sites = |more: &[&str]| {
        let base = ["plan", "--pattern", sites.to_str().unwrap()];
        let at = ["--layout", &easy, "--at", "100,120"];
        nanopush(&[&base[..], &at[..], more].concat())
    };
    let (ok, text) = plan_sites(&[
        "--out",
        plan.to_str().unwrap(),
        "--overlay",
        svg.to_str().unwrap(),
        "--json",
    ]);
    assert!(ok, "{text}");
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(summary["verified"], true);
    assert!(summary["push_ratio"].as_f64().unwrap() >= 1.0 - 1e-9);
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    // The text summary gives the same ratios, to 3 decimals.
    let (ok, text) = plan_sites(&[]);
    assert!(ok, "{text}");
    // A negative rotation is an angle, not an unknown flag; the text
    // summary names the files it wrote (the overlay was written silently).
    let svg_arg = svg.to_str().unwrap();
    let (ok, rotated) = plan_sites(&["--rotation-deg", "-90", "--overlay", svg_arg]);
    assert!(ok && rotated.contains("verify-plan      ok"), "{rotated}");
    assert!(
        rotated.contains(&format!("wrote            {svg_arg}")),
        "{rotated}"
    );
    let push_line = text
        .lines()
        .find(|l| l.starts_with("push distance"))
        .unwrap();
    let shown = push_line
        .split("ratio ")
        .nth(1)
        .unwrap()
        .trim_end_matches(')');
    assert_eq!(
        shown,
        format!("{:.3}", summary["push_ratio"].as_f64().unwrap()),
        "{push_line}"
    );
    let total_line = text
        .lines()
        .find(|l| l.starts_with("push + tip ratio"))
        .unwrap();
    let shown = total_line.split_whitespace().nth(4).unwrap();
    assert_eq!(
        shown,
        format!("{:.3}", summary["total_ratio"].as_f64().unwrap()),
        "{total_line}"
    );
    let (ok, text) = nanopush(&[
        "verify-plan",
        plan.to_str().unwrap(),
        "--layout",
        &easy,
        "--json",
    ]);
    assert!(ok, "{text}");
    let rep: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(rep["collisions"].as_array().unwrap().len(), 0);
    // Tampering: start a push somewhere else and the replay must refuse.
    let tampered = std::fs::read_to_string(&plan).unwrap().replacen(
        "\"from_um\": [\n",
        "\"from_um\": [\n        1.0 +",
        0,
    );
    let bad = dir.path().join("bad.json");
    let original: serde_json::Value = serde_json::from_str(&tampered).unwrap();
    let mut v = original.clone();
    let step = v["steps"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|s| s["kind"] == "push")
        .unwrap();
    step["from_um"][0] = serde_json::json!(30.0);
    std::fs::write(&bad, serde_json::to_string(&v).unwrap()).unwrap();
    let (ok, _) = nanopush(&["verify-plan", bad.to_str().unwrap(), "--layout", &easy]);
    assert!(!ok, "a tampered plan must fail verification");

    let out = dir.path().join("synth.json");
    let (ok, text) = nanopush(&[
        "synth",
        "layout",
        "--n",
        "30",
        "--field-um",
        "120x100",
        "--seed",
        "4",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let layout = nanopush::plan::Layout::read(&out).unwrap();
    assert_eq!(layout.particles.len(), 30);
    let (ok, text) = nanopush(&[
        "synth",
        "layout",
        "--n",
        "500",
        "--out",
        out.to_str().unwrap(),
    ]);
    // No packing holds 500 (refused at once); 100 fit a packing but not
    // random addition (refused after the tries).
    assert!(
        !ok && text.contains("no packing holds more than 113"),
        "{text}"
    );
    let (ok, text) = nanopush(&[
        "synth",
        "layout",
        "--n",
        "100",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("too dense"), "{text}");
}

/// Without `--at`, `nanopush plan` places the pattern where the plan
/// pushes least ([`place_by_plan`] with `LeastPush`, as the CMU acceptance
/// scenes are placed): the same push distance as the library on the layout
/// the file holds, and no more than at the bound's best centre alone. The
/// summary reports the time with the placement.
#[test]
fn plan_without_at_places_where_the_plan_pushes_least() {
    use nanopush::plan::pattern::transform::{Reachable, place_optimised, rotate};
    use nanopush::plan::placement::{PlacementGoal, place_by_plan};
    use nanopush::plan::{DEFAULT_SITE_GAP_M, Layout, Pattern, PlanConfig, plan_assembly};
    let dir = tempfile::tempdir().unwrap();
    let (scene, _) =
        nanopush::plan::cmu_scene::cmu_scene(nanopush::plan::synth_layout::LayoutKind::Uniform, 95)
            .unwrap();
    let path = dir.path().join("layout.json");
    scene.write(&path).unwrap();
    // What the file holds (micrometres, so the last bit may differ).
    let layout = Layout::read(&path).unwrap();
    let (ok, text) = nanopush(&[
        "plan",
        "--text",
        "CMU",
        "--layout",
        path.to_str().unwrap(),
        "--json",
    ]);
    assert!(ok, "{text}");
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let push_um = summary["push_distance_um"].as_f64().unwrap();
    let config = PlanConfig::default();
    // The pattern as the command builds it from the layout's radius.
    let r = layout.max_radius_m();
    let pattern = Pattern::from_text("CMU", 2.0 * r + DEFAULT_SITE_GAP_M).unwrap();
    let pattern = rotate(&pattern, 0.0).unwrap();
    let area = Reachable::for_field(layout.field_m, r);
    let push_at = |sites: &[nanopush::plan::Site]| {
        plan_assembly(&layout, sites, &config)
            .unwrap()
            .summary
            .push_distance_m
            * 1e6
    };
    let chosen =
        place_by_plan(&pattern, &area, &layout, &config, PlacementGoal::LeastPush).unwrap();
    assert!(
        (push_um - push_at(&chosen)).abs() < 1e-6,
        "{push_um} vs {}",
        push_at(&chosen)
    );
    let centres: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
    let by_bound = place_optimised(&pattern, &area, 5e-6, &centres).unwrap();
    assert!(
        push_um <= push_at(&by_bound) + 1e-6,
        "{push_um} > {}",
        push_at(&by_bound)
    );
    let total_s = summary["placement_and_planning_time_s"].as_f64().unwrap();
    assert!(total_s >= summary["planning_time_s"].as_f64().unwrap());
    // It says where it placed the pattern, as --at takes it: the centre of
    // the sites' box, and --at there plans the same pushes.
    let (lo, hi) = chosen.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), s| {
            let c = [s.centre_m.x * 1e6, s.centre_m.y * 1e6];
            (
                [lo[0].min(c[0]), lo[1].min(c[1])],
                [hi[0].max(c[0]), hi[1].max(c[1])],
            )
        },
    );
    let centre = &summary["centre_um"];
    let at = [0, 1].map(|k| centre[k].as_f64().unwrap());
    for k in 0..2 {
        assert!((at[k] - (lo[k] + hi[k]) / 2.0).abs() < 1e-9, "{centre}");
    }
    let (ok, again) = nanopush(&[
        "plan",
        "--text",
        "CMU",
        "--layout",
        path.to_str().unwrap(),
        "--at",
        &format!("{},{}", at[0], at[1]),
        "--json",
    ]);
    assert!(ok, "{again}");
    let again: serde_json::Value = serde_json::from_str(&again).unwrap();
    assert!((again["push_distance_um"].as_f64().unwrap() - push_um).abs() < 1e-6);
}

/// Particles (um) of a layout file.
/// How far the particle of layout `truth` found furthest from where it
/// lies is from the nearest particle of layout `found`, um.
fn worst_miss_um(truth: &Path, found: &Path) -> f64 {
    let seen = centres_um(found);
    centres_um(truth)
        .into_iter()
        .map(|(x, y)| {
            seen.iter()
                .map(|(u, v)| (u - x).hypot(v - y))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

fn centres_um(path: &Path) -> Vec<(f64, f64)> {
    let layout = nanopush::plan::Layout::read(path).unwrap();
    layout
        .particles
        .iter()
        .map(|p| (p.centre_m.x * 1e6, p.centre_m.y * 1e6))
        .collect()
}

/// `nanopush plan --frame` plans on what the frame shows: a synthetic
/// frame of a known layout (0.5 um a pixel) gives back every particle, the
/// one the frame's edge cuts included (kept as an obstacle, never pushed),
/// and a plan that verifies on the layout it writes; with the probe drawn,
/// the tip tour starts at its apex.
#[test]
fn plan_from_a_frame_plans_on_the_particles_it_finds() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (truth, frame, calib) = (at("truth.json"), at("frame.png"), at("calib.toml"));
    let (found, plan) = (at("found.json"), at("plan.json"));
    let (ok, text) = nanopush(&[
        "synth",
        "layout",
        "--n",
        "25",
        "--field-um",
        "120x100",
        "--seed",
        "5",
        "--out",
        &truth,
    ]);
    assert!(ok, "{text}");
    // The layout drawn at 0.5 um a pixel, with `probe` drawn too.
    let synth_frame = |out: &str, probe: &[&str]| {
        let head = ["synth", "frame", "--layout", &truth, "--um-per-px", "0.5"];
        let args: Vec<&str> = head
            .into_iter()
            .chain(["--out", out])
            .chain(probe.iter().copied())
            .collect();
        let (ok, text) = nanopush(&args);
        assert!(ok, "{text}");
    };
    synth_frame(&frame, &[]);
    write_calibration(&calib, 0.5, [0.0, 0.0]);
    let plan_args = |frame: &str| {
        let head = ["plan", "--text", "I", "--frame", frame, "--calib", &calib];
        let tail = ["--save-layout", &found, "--out", &plan, "--json"];
        let args: Vec<String> = head.iter().chain(&tail).map(|s| s.to_string()).collect();
        args
    };
    let args = plan_args(&frame);
    let (ok, text) = nanopush(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(ok, "{text}");
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(summary["verified"], true, "{text}");
    // Seed 5 has a particle 5.3 um from the left edge: its ring is cut.
    assert_eq!(summary["particles_cut_by_edge"], 1, "{text}");
    assert_eq!(summary["particles_found"], 24, "{text}");
    assert_eq!(centres_um(Path::new(&found)).len(), 25);
    let miss = worst_miss_um(Path::new(&truth), Path::new(&found));
    assert!(miss < 0.1, "a particle found {miss:.3} um off");
    let (ok, text) = nanopush(&["verify-plan", &plan, "--layout", &found]);
    assert!(ok, "{text}");
    let plan_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&plan).unwrap()).unwrap();
    let found_layout = nanopush::plan::Layout::read(Path::new(&found)).unwrap();
    let cut = found_layout
        .particles
        .iter()
        .find(|p| p.centre_m.x < 6e-6)
        .expect("the cut particle is in the layout");
    let steps = plan_json["steps"].as_array().unwrap();
    assert!(
        steps
            .iter()
            .all(|s| s["kind"] != "push" || s["particle"] != cut.id),
        "the cut particle is pushed"
    );
    // The probe drawn with its apex at (30, 70) um, its body down to the
    // frame's edge: the tour starts at the apex.
    let tipped = at("tipped.png");
    synth_frame(
        &tipped,
        &[
            "--tip-x-px",
            "60",
            "--tip-y-px",
            "140",
            "--tip-angle-deg",
            "270",
        ],
    );
    let args = plan_args(&tipped);
    let (ok, text) = nanopush(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(ok, "{text}");
    let plan_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&plan).unwrap()).unwrap();
    let first = &plan_json["steps"][0];
    assert_eq!(first["kind"], "tip_travel", "{first}");
    let start = (
        first["from_um"][0].as_f64().unwrap(),
        first["from_um"][1].as_f64().unwrap(),
    );
    assert!(
        (start.0 - 30.0).hypot(start.1 - 70.0) < 1.0,
        "tour starts at {start:?}"
    );
}

/// The files a plan from a synthetic frame uses, in `dir`: the true
/// layout, the frame, its calibration and the layout found in it.
fn frame_files(dir: &Path) -> [String; 4] {
    ["truth.json", "frame.png", "calib.toml", "found.json"]
        .map(|name| dir.join(name).to_str().unwrap().to_string())
}

/// `synth layout` of `n` particles (seed `seed`) in a 120 x 100 um field
/// into `truth`, and its frame at 0.5 um a pixel into `frame`.
fn synth_frame(truth: &str, frame: &str, n: usize, seed: u64) {
    run_line(&format!(
        "synth layout --n {n} --field-um 120x100 --seed {seed} --out {truth}"
    ));
    run_line(&format!(
        "synth frame --layout {truth} --um-per-px 0.5 --out {frame}"
    ));
}

/// Writes a calibration of `um_per_px` (image y along the stage's y) whose
/// pixel (0, 0) lies at stage `[x0, y0]` um.
fn write_calibration(path: &str, um_per_px: f64, [x0, y0]: [f64; 2]) {
    let text = format!(
        "schema = \"nanopush.calibration/1\"\npixel_to_stage_um = [[{um_per_px:?}, 0.0, {x0:?}], [0.0, {um_per_px:?}, {y0:?}]]\n"
    );
    std::fs::write(path, text).unwrap();
}

/// Runs one command line (temporary paths hold no spaces), which must succeed.
fn run_line(line: &str) {
    let (ok, text) = nanopush(&line.split_whitespace().collect::<Vec<_>>());
    assert!(ok, "{line}: {text}");
}

/// `synth frame --layout` writes the calibration its frame is drawn with
/// beside it (`frame.png` -> `frame.calib.toml`): `plan --frame` with that
/// file finds every particle within 0.1 um of where the layout has it (a
/// map guessed with the stage's y up put them up to the field's height
/// off), the file reads back as the map it holds, and a second run keeps
/// it unless --force. At 0.4 um a pixel, not the default 0.5.
#[test]
fn synth_frame_writes_the_calibration_its_frame_is_drawn_with() {
    let dir = tempfile::tempdir().unwrap();
    let [truth, frame, _, found] = frame_files(dir.path());
    let calib = dir.path().join("frame.calib.toml");
    run_line(&format!(
        "synth layout --n 25 --field-um 120x100 --seed 5 --out {truth}"
    ));
    let draw = format!("synth frame --layout {truth} --um-per-px 0.4 --out {frame}");
    let draw: Vec<&str> = draw.split_whitespace().collect();
    let (ok, text) = nanopush(&draw);
    assert!(
        ok && text.contains(&format!("wrote {}", calib.display())),
        "{text}"
    );
    let map = nanopush::calib::camera_map::CameraCalibration::load(&calib).unwrap();
    for [x, y] in [[0.0, 0.0], [299.0, 0.0], [0.0, 249.0], [123.4, 56.7]] {
        let [u, v] = map.pixel_to_stage_m(x, y).map(|m| m * 1e6);
        assert!(
            (u - 0.4 * x).abs() < 1e-9 && (v - 0.4 * y).abs() < 1e-9,
            "({x}, {y}) px at ({u}, {v}) um"
        );
    }
    let written = std::fs::read_to_string(&calib).unwrap();
    let line = "pixel_to_stage_um = [[0.4, 0.0, 0.0], [0.0, 0.4, 0.0]]";
    assert!(written.contains(line), "{written}");
    let calib = calib.to_str().unwrap();
    run_line(&format!(
        "plan --text I --frame {frame} --calib {calib} --save-layout {found}"
    ));
    let miss = worst_miss_um(Path::new(&truth), Path::new(&found));
    assert!(miss < 0.1, "a particle found {miss:.3} um off");
    let (ok, text) = nanopush(&draw);
    assert!(!ok && text.contains("exists: pass --force"), "{text}");
    run_line(&format!("{} --force", draw.join(" ")));
}

/// `plan --frame` lays out the whole frame: the field was the tracked view
/// (a diameter in from the far edges), 109.5 x 89.5 um of a 120 x 100 um
/// frame, so the layout's own particles lay outside it and "CMU" (114.7
/// um wide with its discs), which plans on the same particles' layout
/// file, was refused as too large.
#[test]
fn plan_from_a_frame_lays_out_the_whole_frame() {
    let dir = tempfile::tempdir().unwrap();
    let [truth, frame, calib, found] = frame_files(dir.path());
    run_line(&format!(
        "synth layout --n 60 --field-um 120x100 --seed 2 --out {truth}"
    ));
    run_line(&format!(
        "synth frame --layout {truth} --um-per-px 0.5 --seed 5 --out {frame}"
    ));
    write_calibration(&calib, 0.5, [0.0, 0.0]);
    run_line(&format!(
        "plan --text CMU --frame {frame} --calib {calib} --save-layout {found}"
    ));
    let found = nanopush::plan::Layout::read(Path::new(&found)).unwrap();
    // 240 x 200 pixels: their centres span 119.5 x 99.5 um.
    let [w, h] = found.field_m.map(|m| m * 1e6);
    assert!(
        (w - 119.5).abs() < 1e-6 && (h - 99.5).abs() < 1e-6,
        "{w} x {h} um"
    );
    assert!(
        found.particles.iter().all(|p| {
            let c = p.centre_m * 1e6;
            (0.0..=w).contains(&c.x) && (0.0..=h).contains(&c.y)
        }),
        "a particle outside the layout's field"
    );
}

/// Ids of the particles a layout file marks `"immovable": true`, read
/// from its JSON (not through the library's reader, which it tests).
fn marked_immovable(path: &str) -> Vec<u64> {
    let text = std::fs::read_to_string(path).unwrap();
    let layout: serde_json::Value = serde_json::from_str(&text).unwrap();
    let particles = layout["particles"].as_array().unwrap().iter();
    let marked = particles.filter(|p| p["immovable"] == true);
    marked.map(|p| p["id"].as_u64().unwrap()).collect()
}

/// Push steps of `plan` (a plan file) that move particle `id`.
fn pushes_of(plan: &str, id: u64) -> usize {
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(plan).unwrap()).unwrap();
    let steps = plan["steps"].as_array().unwrap().iter();
    steps
        .filter(|s| s["kind"] == "push" && s["particle"] == id)
        .count()
}

/// The layout `plan --frame --save-layout` writes marks the particle the
/// frame's edge cuts `"immovable"`, so `plan --layout` on it never pushes
/// that particle, as the frame's own plan does not, and `verify-plan
/// --layout` refuses a plan that does. Without the mark the saved layout
/// planned "I" at (20, 40) um by pushing it, and verified.
#[test]
fn a_saved_layout_holds_the_particle_the_frames_edge_cuts() {
    let dir = tempfile::tempdir().unwrap();
    let [truth, frame, calib, found] = frame_files(dir.path());
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (held_plan, free_plan, free) = (at("held.json"), at("free.json"), at("free_layout.json"));
    // Seed 5 has a particle 5.3 um from the left edge: its ring is cut.
    synth_frame(&truth, &frame, 25, 5);
    write_calibration(&calib, 0.5, [0.0, 0.0]);
    run_line(&format!(
        "plan --text I --frame {frame} --calib {calib} --save-layout {found}"
    ));
    let layout = nanopush::plan::Layout::read(Path::new(&found)).unwrap();
    let cut: Vec<u64> = (layout.particles.iter())
        .filter(|p| p.centre_m.x < 6e-6)
        .map(|p| u64::from(p.id))
        .collect();
    assert_eq!(cut.len(), 1, "the particle 5.3 um from the edge");
    assert_eq!(marked_immovable(&found), cut);
    // Planned from the saved layout, where the pattern covers the cut
    // particle's side: it stays, and the plan verifies with it held.
    let plan_i = |layout: &str, out: &str| {
        let line = format!("plan --text I --layout {layout} --at 20,40 --out {out} --json");
        nanopush(&line.split_whitespace().collect::<Vec<_>>())
    };
    let (ok, text) = plan_i(&found, &held_plan);
    assert!(ok, "{text}");
    assert_eq!(
        pushes_of(&held_plan, cut[0]),
        0,
        "the cut particle is pushed"
    );
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(summary["particles_immovable"], 1, "{text}");
    assert_eq!(summary["verified"], true, "{text}");
    let (ok, text) = nanopush(&["verify-plan", &held_plan, "--layout", &found]);
    assert!(ok, "{text}");
    // The same particles unmarked: that plan pushes it, and the replay on
    // the marked layout says so.
    layout.write(Path::new(&free)).unwrap();
    let (ok, text) = plan_i(&free, &free_plan);
    assert!(ok, "{text}");
    assert!(
        pushes_of(&free_plan, cut[0]) > 0,
        "unmarked, it is not pushed either: the scene no longer tests the mark"
    );
    let (ok, text) = nanopush(&["verify-plan", &free_plan, "--layout", &found, "--json"]);
    assert!(!ok, "{text}");
    // The report (stdout), without the error line after it (stderr).
    let report: serde_json::Value =
        serde_json::from_str(&text[..text.rfind('}').unwrap() + 1]).unwrap();
    assert_eq!(report["ok"], false, "{text}");
    assert!(
        !report["moved_immovable"].as_array().unwrap().is_empty(),
        "{text}"
    );
    // The error line says why, not only that it failed.
    assert!(
        text.contains("failed verification: ") && text.contains("must not move"),
        "{text}"
    );
    let (ok, text) = nanopush(&["verify-plan", &free_plan, "--layout", &free]);
    assert!(ok, "{text}");
}

/// A frame whose calibration puts its left 30 um at negative x: the
/// particles there are obstacles, counted apart, never pushed, and marked
/// in the saved layout, which reads back and plans and replays the same.
/// `plan --frame` had panicked (the ids of the cut particles were taken
/// by index from a layout that had left those beyond the field out).
#[test]
fn a_frame_reaching_beyond_the_field_plans_round_what_lies_there() {
    let dir = tempfile::tempdir().unwrap();
    let [truth, frame, calib, found] = frame_files(dir.path());
    let plan = dir.path().join("plan.json").to_str().unwrap().to_string();
    synth_frame(&truth, &frame, 40, 2);
    write_calibration(&calib, 0.5, [-30.0, 0.0]);
    let truth = nanopush::plan::Layout::read(Path::new(&truth)).unwrap();
    // Beyond two radii outside: centres below x = -10 um on the stage.
    let beyond = (truth.particles.iter())
        .filter(|p| p.centre_m.x - 30e-6 < -2.0 * p.radius_m)
        .count();
    assert!(beyond >= 2, "the scene has {beyond} beyond the field");
    let line = format!(
        "plan --text L --frame {frame} --calib {calib} --save-layout {found} --out {plan} --json"
    );
    let (ok, text) = nanopush(&line.split_whitespace().collect::<Vec<_>>());
    assert!(ok, "{text}");
    // The summary (stdout), without the warnings after it (stderr).
    let summary: serde_json::Value = serde_json::Deserializer::from_str(&text)
        .into_iter()
        .next()
        .unwrap()
        .unwrap();
    assert_eq!(summary["particles_beyond_field"], beyond, "{text}");
    assert_eq!(summary["verified"], true, "{text}");
    let saved = nanopush::plan::layout::MarkedLayout::read(Path::new(&found)).unwrap();
    let ids = saved.layout.beyond_field_ids();
    assert_eq!(ids.len(), beyond);
    for id in &ids {
        assert!(saved.immovable.contains(id), "{id} is not marked");
        assert_eq!(pushes_of(&plan, u64::from(*id)), 0, "{id} is pushed");
    }
    let (ok, text) = nanopush(&["verify-plan", &plan, "--layout", &found]);
    assert!(ok, "{text}");
    let (ok, text) = nanopush(&["plan", "--text", "L", "--layout", &found, "--json"]);
    assert!(ok, "{text}");
}

/// `plan --frame` lays a spread batch (radii 5 % apart) out with each
/// particle's measured size, as the rig's first frame is: every particle
/// at least 1 um clear of the others within 0.1 um of its true radius.
/// With `--radius-um` for all, every radius was 5 um.
#[test]
fn plan_from_a_frame_keeps_each_particles_measured_size() {
    let dir = tempfile::tempdir().unwrap();
    let [truth, frame, calib, found] = frame_files(dir.path());
    let run = |line: String| run_line(&line);
    run(format!(
        "synth layout --n 25 --field-um 120x100 --polydisperse --seed 5 --out {truth}"
    ));
    run(format!(
        "synth frame --layout {truth} --um-per-px 0.25 --out {frame}"
    ));
    write_calibration(&calib, 0.25, [0.0, 0.0]);
    run(format!(
        "plan --text I --frame {frame} --calib {calib} --save-layout {found}"
    ));
    let truth = nanopush::plan::Layout::read(Path::new(&truth)).unwrap();
    let found = nanopush::plan::Layout::read(Path::new(&found)).unwrap();
    let clear = |p: &nanopush::plan::Particle| {
        truth.particles.iter().all(|q| {
            q.id == p.id || (q.centre_m - p.centre_m).norm() - q.radius_m - p.radius_m >= 1e-6
        })
    };
    let (mut compared, mut worst_um) = (0, 0.0_f64);
    for t in truth.particles.iter().filter(|p| clear(p)) {
        let f = found
            .particles
            .iter()
            .min_by(|a, b| {
                let d = |p: &nanopush::plan::Particle| (p.centre_m - t.centre_m).norm();
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        // Cut by the frame's edge: not measured, taken at --radius-um.
        if f.centre_m.x < t.radius_m || f.centre_m.y < t.radius_m {
            continue;
        }
        let off_um = (f.radius_m - t.radius_m).abs() * 1e6;
        assert!(
            off_um < 0.1,
            "particle {} found {off_um:.3} um off its size",
            t.id
        );
        compared += 1;
        worst_um = worst_um.max(off_um);
    }
    eprintln!("{compared} particles clear of the others: sizes within {worst_um:.3} um");
    let radii = found.particles.iter().map(|p| p.radius_m * 1e6);
    let spread = radii.clone().fold(f64::MIN, f64::max) - radii.fold(f64::MAX, f64::min);
    assert!(
        compared >= 15,
        "only {compared} particles clear of the others"
    );
    assert!(spread > 0.5, "radii found spread by {spread:.3} um");
}

/// A colour frame whose green channel shows one layout and whose red and
/// blue show another: `--channel` says which is planned on, and every
/// particle of that one is found where it lies (luminance would mix both).
#[test]
fn plan_from_a_colour_frame_plans_on_the_channel_asked_for() {
    use nanopush::vision::frame_input::{Channel, load_frame};
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let calib = at("calib.toml");
    write_calibration(&calib, 0.5, [0.0, 0.0]);
    // Two layouts, each drawn at 0.5 um a pixel as a grey frame.
    let grey = |seed: &str| {
        let (layout, frame) = (at(&format!("l{seed}.json")), at(&format!("f{seed}.png")));
        let layout_args = [
            "synth",
            "layout",
            "--n",
            "20",
            "--field-um",
            "120x100",
            "--seed",
            seed,
            "--out",
            &layout,
        ];
        let frame_args = [
            "synth",
            "frame",
            "--layout",
            &layout,
            "--um-per-px",
            "0.5",
            "--out",
            &frame,
        ];
        for args in [layout_args.as_slice(), frame_args.as_slice()] {
            let (ok, text) = nanopush(args);
            assert!(ok, "{text}");
        }
        (
            layout,
            load_frame(Path::new(&frame), Channel::Luminance).unwrap(),
        )
    };
    let (green_layout, green) = grey("5");
    let (red_layout, red) = grey("8");
    let colour =
        image::ImageBuffer::from_fn(green.width() as u32, green.height() as u32, |x, y| {
            let count = |f: &nanopush::vision::frame::Frame| f.at(x as usize, y as usize) as u16;
            image::Rgb([count(&red), count(&green), count(&red)])
        });
    let frame = at("colour.png");
    colour.save(&frame).unwrap();
    for (channel, truth) in [("green", &green_layout), ("red", &red_layout)] {
        let found = at(&format!("found-{channel}.json"));
        let args = [
            "plan",
            "--text",
            "I",
            "--frame",
            &frame,
            "--calib",
            &calib,
            "--channel",
            channel,
            "--save-layout",
            &found,
        ];
        let (ok, text) = nanopush(&args);
        assert!(ok, "{channel}: {text}");
        let (found, truth) = (Path::new(&found), Path::new(truth));
        assert_eq!(
            centres_um(found).len(),
            centres_um(truth).len(),
            "{channel}"
        );
        let miss = worst_miss_um(truth, found);
        assert!(miss < 0.1, "{channel}: a particle found {miss:.3} um off");
    }
}

/// `nanopush plan --frame` on a real bright-field frame (trackpy-examples,
/// fixtures/recordings/real-brightfield, its assumed calibration): the 5
/// particles the dry-run sees in it, a plan of the recording's 3 sites
/// that verifies on the layout it writes, and an overlay drawn over the
/// frame with every site where the calibration puts it (image y down,
/// stage y up: a flipped or unscaled drawing puts them elsewhere).
#[test]
fn plan_from_a_real_frame_finds_its_five_particles() {
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/recordings/real-brightfield");
    let dir = tempfile::tempdir().unwrap();
    let found = dir.path().join("found.json");
    let plan = dir.path().join("plan.json");
    let overlay = dir.path().join("plan.png");
    let path = |p: &Path| p.to_str().unwrap().to_string();
    let frame = fixture.join("frames").join("bf_0000.png");
    let args = [
        "plan".to_string(),
        "--pattern".into(),
        path(&fixture.join("pattern.toml")),
        "--frame".into(),
        path(&frame),
        "--calib".into(),
        path(&fixture.join("calibration.toml")),
        "--save-layout".into(),
        path(&found),
        "--out".into(),
        path(&plan),
        "--overlay".into(),
        path(&overlay),
        "--json".into(),
    ];
    let (ok, text) = nanopush(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(ok, "{text}");
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(summary["particles_found"], 5, "{text}");
    assert_eq!(summary["sites"], 3, "{text}");
    assert_eq!(summary["verified"], true, "{text}");
    assert_eq!(centres_um(&found).len(), 5);
    let (ok, text) = nanopush(&["verify-plan", &path(&plan), "--layout", &path(&found)]);
    assert!(ok, "{text}");
    // A plan refused still leaves the layout of what was found, and says so.
    let (refused, kept) = (
        dir.path().join("refused.json"),
        dir.path().join("kept.json"),
    );
    let (ok, text) = nanopush(&[
        "plan",
        "--text",
        "HI",
        "--frame",
        &path(&frame),
        "--calib",
        &path(&fixture.join("calibration.toml")),
        "--save-layout",
        &path(&kept),
        "--out",
        &path(&refused),
    ]);
    assert!(!ok && text.contains("written before planning"), "{text}");
    assert_eq!(centres_um(&kept).len(), 5);
    assert!(!refused.exists());
    // The calibration: x_um = 0.588235 x_px, y_um = 294.1176 - 0.588235 y_px.
    let to_px = |x_um: f64, y_um: f64| (x_um / 0.588235, (294.1176 - y_um) / 0.588235);
    let plan_json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&plan).unwrap()).unwrap();
    let sites_px: Vec<(f64, f64)> = plan_json["sites"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| to_px(s["x_um"].as_f64().unwrap(), s["y_um"].as_f64().unwrap()))
        .collect();
    let shot = image::open(&frame).unwrap();
    // The frame's part of the drawing; its key below is checked in
    // `a_plans_drawing_over_a_frame_has_a_key_of_its_marks`.
    let picture = image::open(&overlay).unwrap().to_rgb8();
    assert_eq!(picture.width(), shot.width());
    assert!(picture.height() > shot.height());
    let picture = image::imageops::crop_imm(&picture, 0, 0, shot.width(), shot.height()).to_image();
    // Site circles are drawn in (0, 200, 255), 5 um = 8.5 px round each site.
    let site_pixels: Vec<(f64, f64)> = picture
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0 == [0, 200, 255])
        .map(|(x, y, _)| (x as f64, y as f64))
        .collect();
    let near = |(x, y): (f64, f64), (u, v): (f64, f64)| (x - u).hypot(y - v) <= 10.5;
    for &site in &sites_px {
        assert!(
            site_pixels.iter().any(|&p| near(p, site)),
            "no site circle round pixel {site:?}"
        );
    }
    assert!(
        site_pixels
            .iter()
            .all(|&p| sites_px.iter().any(|&s| near(p, s))),
        "site colour away from every site"
    );
}

/// The drawing of a plan over a camera frame has a key naming its marks
/// under the frame, as the drawing over a layout has (it had none: cyan and
/// green rings and orange arrows over the frame were left to guess). Each
/// line of the key shows its mark in the colour the frame's marks are drawn
/// in, then its label's text.
#[test]
fn a_plans_drawing_over_a_frame_has_a_key_of_its_marks() {
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/recordings/real-brightfield");
    let dir = tempfile::tempdir().unwrap();
    let overlay = dir.path().join("plan.png");
    let path = |p: &Path| p.to_str().unwrap().to_string();
    let frame = fixture.join("frames").join("bf_0000.png");
    let (ok, text) = nanopush(&[
        "plan",
        "--pattern",
        &path(&fixture.join("pattern.toml")),
        "--frame",
        &path(&frame),
        "--calib",
        &path(&fixture.join("calibration.toml")),
        "--overlay",
        &path(&overlay),
    ]);
    assert!(ok, "{text}");
    let shot = image::open(&frame).unwrap();
    let picture = image::open(&overlay).unwrap().to_rgb8();
    let key_top = shot.height();
    assert!(
        picture.height() >= key_top + 16 * 4,
        "{:?}",
        picture.dimensions()
    );
    // Line i of the key is centred 16 (i + 1) px below the frame; its mark
    // lies left of x = 40, its label from x = 44.
    let line_has = |i: u32, x0: u32, x1: u32, hit: &dyn Fn([u8; 3]) -> bool| {
        let y = key_top + 16 * (i + 1);
        (x0..x1).any(|x| (y - 7..y + 8).any(|y| hit(picture.get_pixel(x, y).0)))
    };
    let marks = [
        ("site", [0, 200, 255]),
        ("particle", [40, 220, 40]),
        ("push", [255, 160, 0]),
    ];
    for (i, (name, colour)) in marks.into_iter().enumerate() {
        let i = i as u32;
        assert!(
            line_has(i, 0, 40, &|p| p == colour),
            "no {name} mark on line {i} of the key"
        );
        assert!(
            line_has(i, 44, picture.width(), &|p| p.iter().all(|&c| c < 100)),
            "no label on line {i} of the key"
        );
    }
}

/// A dense field refused at every placement tried says how many were tried
/// and why the best by the push bound was refused, and exits non-zero
/// (`synth layout --n 75 --kind adversarial --seed 3`: about 20 s).
#[test]
fn a_field_refused_at_every_placement_says_how_many_were_tried_and_why() {
    use nanopush::plan::placement::{BOUND_CANDIDATES, FALLBACK_CANDIDATES, UNCROWDED_CANDIDATES};
    let dir = tempfile::tempdir().unwrap();
    let layout = cmu_field_layout(dir.path(), "75", "adversarial", "3");
    let layout = layout.as_str();
    let (ok, text) = nanopush(&["plan", "--text", "CMU", "--layout", layout]);
    assert!(!ok, "a plan was found: {text}");
    let tried: usize = text
        .split("none of the ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no count of placements tried: {text}"));
    assert!(
        tried > BOUND_CANDIDATES
            && tried <= BOUND_CANDIDATES + FALLBACK_CANDIDATES + UNCROWDED_CANDIDATES,
        "{tried} placements tried: {text}"
    );
    assert!(
        text.contains("placements tried plans (the refusal at the best by the push bound follows): no collision-free order:"),
        "{text}"
    );
    assert_eq!(text.matches("no collision-free order").count(), 1, "{text}");
    // About a second of a core per centre: the wait is told every 2 s, by
    // how many centres were tried.
    assert!(
        text.contains(" other centres tried, none plans yet ("),
        "no progress while the centres were tried: {text}"
    );
    assert!(!text.contains("\u{1b}["), "colour codes in a log: {text}");
}

/// An SVG drawing is a pattern: its paths sampled at the pitch (an "L" of
/// 42 + 31.5 um at 10.5 um: 8 sites, the corner once), placed at `--at`,
/// planned and verified; the sites lie on the drawing, y up.
#[test]
fn an_svg_drawing_plans_with_sites_along_its_paths() {
    let dir = tempfile::tempdir().unwrap();
    let drawing = dir.path().join("l.svg");
    std::fs::write(
        &drawing,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100"><path d="M 0 0 L 0 42 L 31.5 42" fill="none" stroke="black"/></svg>"#,
    )
    .unwrap();
    let particles: Vec<(f64, f64, f64)> = (0..10)
        .map(|i| (15.0 + 17.0 * i as f64, 15.0, 5.0))
        .collect();
    let layout = write_layout(dir.path(), "row.json", &particles, (200.0, 200.0));
    let plan = dir.path().join("plan.json");
    let (ok, text) = nanopush(&[
        "plan",
        "--pattern",
        drawing.to_str().unwrap(),
        "--layout",
        &layout,
        "--pitch-um",
        "10.5",
        "--at",
        "100,100",
        "--out",
        plan.to_str().unwrap(),
        "--json",
    ]);
    assert!(ok, "{text}");
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(summary["sites"], 8, "{text}");
    assert_eq!(summary["verified"], true, "{text}");
    let (ok, text) = nanopush(&["verify-plan", plan.to_str().unwrap(), "--layout", &layout]);
    assert!(ok, "{text}");
    // The L's box is 31.5 x 42 um centred at (100, 100): its corner, at the
    // bottom left once y points up, is a site.
    let (plan, _) = nanopush::plan::plan_file::read(&plan).unwrap();
    let corner = nalgebra::Vector2::new(100.0 - 15.75, 100.0 - 21.0) * 1e-6;
    assert!(
        plan.sites
            .iter()
            .any(|s| (s.centre_m - corner).norm() < 1e-9),
        "no site at the L's corner"
    );
}

/// A calibration whose pixels are not square on the sample (one axis 20 %
/// longer) is refused by `plan --frame` and `detect --calib`, as by the
/// dry-run: both take one scale for both axes. Accepted before, it placed
/// and sized every particle wrong with exit 0.
#[test]
fn a_calibration_of_stretched_pixels_is_refused_where_a_frame_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (frame, square, stretched) = (at("frame.png"), at("square.toml"), at("stretched.toml"));
    let (ok, text) = nanopush(&[
        "synth",
        "frame",
        "--n",
        "5",
        "--width-px",
        "256",
        "--height-px",
        "256",
        "--out",
        &frame,
    ]);
    assert!(ok, "{text}");
    let calib = |path: &str, y_um: f64| {
        let text = format!(
            "schema = \"nanopush.calibration/1\"\npixel_to_stage_um = [[0.5, 0.0, 0.0], [0.0, {y_um}, 0.0]]\n"
        );
        std::fs::write(path, text).unwrap();
    };
    calib(&square, 0.5);
    calib(&stretched, 0.6);
    let (ok, text) = nanopush(&["detect", &frame, "--calib", &square, "--no-tip"]);
    assert!(ok, "{text}");
    for args in [
        vec!["detect", &frame, "--calib", &stretched, "--no-tip"],
        vec![
            "plan", "--text", "I", "--frame", &frame, "--calib", &stretched,
        ],
    ] {
        let (ok, text) = nanopush(&args);
        assert!(!ok, "{args:?} accepted: {text}");
        assert!(
            text.contains("0.5000 and 0.6000 um long") && text.contains("pixels are square"),
            "{args:?}: {text}"
        );
    }
}

/// An output that is one of the command's inputs, or another of its
/// outputs, is refused before anything is written: `plan --layout L --out
/// L` had replaced the layout with the plan, `detect F --overlay F` the
/// frame with the drawing, both with exit 0; and an overlay of an unknown
/// kind was refused only after the plan file had been written.
#[test]
fn outputs_that_would_replace_an_input_or_each_other_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let layout = write_layout(
        dir.path(),
        "layout.json",
        &[(20.0, 20.0, 5.0), (60.0, 20.0, 5.0), (100.0, 20.0, 5.0)],
        (200.0, 200.0),
    );
    let before = std::fs::read(&layout).unwrap();
    let plan = dir.path().join("plan.json").display().to_string();
    let spelt_again = dir.path().join(".").join("layout.json");
    let spelt_again = spelt_again.to_str().unwrap();
    let frame = dir.path().join("frame.png").display().to_string();
    let (ok, text) = nanopush(&["synth", "frame", "--n", "3", "--out", &frame]);
    assert!(ok, "{text}");
    let frame_before = std::fs::read(&frame).unwrap();
    let plan_i = ["plan", "--text", "I", "--layout", &layout];
    for (extra, says) in [
        (vec!["--out", spelt_again], "--out"),
        (vec!["--out", &plan, "--overlay", &plan], "also --out"),
        (
            vec!["--out", &plan, "--overlay", "plan.txt"],
            "unknown extension",
        ),
    ] {
        let args: Vec<&str> = plan_i.iter().copied().chain(extra).collect();
        let (ok, text) = nanopush(&args);
        assert!(!ok && text.contains(says), "{args:?}: {text}");
        assert!(!Path::new(&plan).exists(), "{args:?} wrote the plan");
    }
    let (ok, text) = nanopush(&["detect", &frame, "--overlay", &frame]);
    assert!(!ok && text.contains("the input FRAME"), "{text}");
    assert_eq!(std::fs::read(&layout).unwrap(), before);
    assert_eq!(std::fs::read(&frame).unwrap(), frame_before);
}

/// A particle beside the probe in the frame, its ring too near the probe's
/// outline for the loop to measure, is still an obstacle of the plan made
/// from that frame: a site on it is refused, naming it, and a site
/// elsewhere plans without pushing it. Before, it was left out of the
/// layout altogether, and a plan (verified "ok") pushed another particle
/// onto it.
#[test]
fn a_particle_beside_the_probe_is_an_obstacle_of_the_frames_plan() {
    let dir = tempfile::tempdir().unwrap();
    let [truth, frame, calib, found] = frame_files(dir.path());
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (site, plan) = (at("site.toml"), at("plan.json"));
    // Particle 0 touches the probe's apex at (90, 50) um (its centre a radius off).
    std::fs::write(
        &truth,
        r#"{"schema": "nanopush.layout/1", "field_um": [120, 100], "particles": [
            {"id": 0, "x_um": 85.1, "y_um": 50.5, "radius_um": 5},
            {"id": 1, "x_um": 30.0, "y_um": 30.0, "radius_um": 5},
            {"id": 2, "x_um": 20.0, "y_um": 70.0, "radius_um": 5},
            {"id": 3, "x_um": 55.0, "y_um": 25.0, "radius_um": 5}]}"#,
    )
    .unwrap();
    std::fs::write(&site, "sites = [ { x_um = 0.0, y_um = 0.0 } ]\n").unwrap();
    write_calibration(&calib, 0.5, [0.0, 0.0]);
    run_line(&format!(
        "synth frame --layout {truth} --um-per-px 0.5 --seed 1 --tip-x-px 180 --tip-y-px 100 --tip-angle-deg 90 --out {frame}"
    ));
    let args = |at_um: &str| {
        format!(
            "plan --pattern {site} --at {at_um} --frame {frame} --calib {calib} --save-layout {found} --out {plan}"
        )
    };
    let (ok, text) = nanopush(&args("85.1,50.5").split_whitespace().collect::<Vec<_>>());
    assert!(
        !ok,
        "a site on the particle beside the probe planned: {text}"
    );
    assert!(text.contains("cannot be moved (immovable)"), "{text}");
    let held = marked_immovable(&found);
    let layout = nanopush::plan::Layout::read(Path::new(&found)).unwrap();
    let beside: Vec<u64> = (layout.particles.iter())
        .filter(|p| (p.centre_m * 1e6 - nalgebra::Vector2::new(85.1, 50.5)).norm() < 2.0)
        .map(|p| p.id as u64)
        .collect();
    assert!(
        beside.len() == 1 && held.contains(&beside[0]),
        "held {held:?}, beside {beside:?}"
    );
    run_line(&args("40,80"));
    assert_eq!(
        pushes_of(&plan, beside[0]),
        0,
        "the particle beside the probe was pushed"
    );
    run_line(&format!("verify-plan {plan} --layout {found}"));
}

/// A frame the calibration puts at (1000, 1000) um: the pattern is placed
/// where the camera saw, and the user told so. The field runs from the
/// stage origin, and half of CMU's sites had gone where no particle could
/// be seen (1,361 um of pushing against 291 um from the same frame at the
/// origin); `--at` outside the frame is refused with the centres allowed.
#[test]
fn a_frame_far_from_the_stage_origin_places_its_pattern_in_the_frame() {
    let dir = tempfile::tempdir().unwrap();
    let [truth, frame, calib, _] = frame_files(dir.path());
    let plan = dir.path().join("plan.json").to_str().unwrap().to_string();
    synth_frame(&truth, &frame, 25, 5);
    write_calibration(&calib, 0.5, [1000.0, 1000.0]);
    let line = format!("plan --text L --frame {frame} --calib {calib} --out {plan}");
    let (ok, text) = nanopush(&line.split_whitespace().collect::<Vec<_>>());
    assert!(ok, "{text}");
    assert!(
        text.contains("the frame starts at (1000.0, 1000.0) um"),
        "{text}"
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&plan).unwrap()).unwrap();
    for s in doc["sites"].as_array().unwrap() {
        let (x, y) = (s["x_um"].as_f64().unwrap(), s["y_um"].as_f64().unwrap());
        assert!(x >= 1005.0 && y >= 1005.0, "site at ({x}, {y}) um: {text}");
    }
    let line = format!("plan --text L --at 60,50 --frame {frame} --calib {calib}");
    let (ok, text) = nanopush(&line.split_whitespace().collect::<Vec<_>>());
    assert!(!ok, "{text}");
    // A calibration's half-pixel offset is no frame far away.
    write_calibration(&calib, 0.5, [0.0, 0.6]);
    let line = format!("plan --text L --frame {frame} --calib {calib}");
    let (ok, text) = nanopush(&line.split_whitespace().collect::<Vec<_>>());
    assert!(ok && !text.contains("the frame starts at"), "{text}");
}

/// A particle the probe's body half covers (its centre 2.5 px off the
/// outline) is found and held: the body is painted over with the
/// background before the second look, so its visible part is a ring the
/// detector fits. Against the dark body the fit failed, the particle was
/// in no layout, and a plan "I" at (100, 60) um (verified ok) pushed
/// another particle 2.1 um into it. The user is told how much the probe
/// hides.
#[test]
fn a_particle_the_probe_half_covers_is_an_obstacle_of_the_frames_plan() {
    let dir = tempfile::tempdir().unwrap();
    let [_, frame, calib, found] = frame_files(dir.path());
    // Particle 0 under the probe's body's edge, 12 more far from it.
    let mut particles = vec![(106.76, 55.96, 5.0)];
    for y in [15.0, 27.0, 39.0] {
        for x in [10.0, 22.0, 34.0, 46.0] {
            particles.push((x, y, 5.0));
        }
    }
    let truth = write_layout(dir.path(), "truth.json", &particles, (120.0, 100.0));
    write_calibration(&calib, 0.5, [0.0, 0.0]);
    run_line(&format!(
        "synth frame --layout {truth} --um-per-px 0.5 --tip-x-px 200 --tip-y-px 120 --tip-angle-deg 180 --out {frame}"
    ));
    let line =
        format!("plan --text I --at 40,60 --frame {frame} --calib {calib} --save-layout {found}");
    let (ok, text) = nanopush(&line.split_whitespace().collect::<Vec<_>>());
    assert!(ok, "{text}");
    assert!(text.contains("the probe hides"), "{text}");
    let layout = nanopush::plan::Layout::read(Path::new(&found)).unwrap();
    let near: Vec<u64> = (layout.particles.iter())
        .filter(|p| (p.centre_m * 1e6 - nalgebra::Vector2::new(106.76, 55.96)).norm() < 1.0)
        .map(|p| u64::from(p.id))
        .collect();
    assert_eq!(
        near.len(),
        1,
        "the half-covered particle: {:?}",
        layout.particles
    );
    assert!(marked_immovable(&found).contains(&near[0]));
    // A site on it is refused, naming it, not pushed through.
    let line = format!("plan --text I --at 100,60 --frame {frame} --calib {calib}");
    let (ok, text) = nanopush(&line.split_whitespace().collect::<Vec<_>>());
    assert!(!ok, "{text}");
    assert!(text.contains("cannot be moved (immovable)"), "{text}");
}

/// A size hint too small for the frame's particles (1 um for the real
/// bright-field frame's 4.8 um) finds each one several times over, as
/// pieces of its ring (49 for 5): `plan --frame` says so, naming the size
/// a larger hint finds. At the right size it says nothing of the kind.
#[test]
fn plan_from_a_frame_warns_of_a_size_hint_that_finds_pieces_of_particles() {
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/recordings/real-brightfield");
    let path = |p: &Path| p.to_str().unwrap().to_string();
    let (frame, calib, pattern) = (
        path(&fixture.join("frames").join("bf_0000.png")),
        path(&fixture.join("calibration.toml")),
        path(&fixture.join("pattern.toml")),
    );
    let plan = |radius_um: &str| {
        nanopush(&[
            "plan",
            "--pattern",
            &pattern,
            "--frame",
            &frame,
            "--calib",
            &calib,
            "--radius-um",
            radius_um,
        ])
        .1
    };
    let small = plan("1");
    assert!(
        small.contains("49 particles found near the size hint")
            && small.contains("finds 5 whole")
            && small.contains("several times over"),
        "{small}"
    );
    let right = plan("5");
    assert!(!right.contains("several times over"), "{right}");
}

/// Real 1 um spheres (bulk_water_000, 2.85 px/um) are spots 7-8 px
/// across. At 2.3 um the plan ended "7 sites but only 1 particle" with no
/// word of the size; now a smaller radius finding hundreds of spots is
/// named. At a radius the spot model fits, the layout gives every
/// particle the radius asked for, and `plan` says so (a spot's width is
/// the blur's): 689 radii of exactly 0.5 um had looked measured.
#[test]
fn plan_from_a_frame_of_spots_names_their_size_and_says_it_does_not_size_them() {
    let dir = tempfile::tempdir().unwrap();
    let calib = dir.path().join("bulk_water.toml");
    // The frame's README: 2.85 px/um.
    std::fs::write(
        &calib,
        "schema = \"nanopush.calibration/1\"\npixel_to_stage_um = [[0.350877, 0.0, 0.0], [0.0, 0.350877, 0.0]]\n",
    )
    .unwrap();
    let frame = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/real/bulk_water/bulk_water_000.png"
    );
    let layout = dir.path().join("layout.json");
    let plan = |radius_um: &str| {
        let args = [
            "plan",
            "--text",
            "L",
            "--frame",
            frame,
            "--channel",
            "green",
            "--calib",
            calib.to_str().unwrap(),
            "--radius-um",
            radius_um,
            "--save-layout",
            layout.to_str().unwrap(),
        ];
        nanopush(&args).1
    };
    let large = plan("2.3");
    assert!(
        large.contains("1 particle found near the size hint, but a hint of radius")
            && large.contains("spots, 1.4"),
        "{large}"
    );
    let small = plan("0.5");
    assert!(
        small.contains("too small to size") && small.contains("each is planned at 0.50 um"),
        "{small}"
    );
    assert!(!small.contains("found near the size hint"), "{small}");
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&layout).unwrap()).unwrap();
    let radii: Vec<f64> = (saved["particles"].as_array().unwrap().iter())
        .map(|p| p["radius_um"].as_f64().unwrap())
        .collect();
    assert!(
        radii.len() > 500 && radii.iter().all(|&r| r == 0.5),
        "{radii:?}"
    );
}

/// `plan --frame` on a folder plans from its first image and says which,
/// as `detect` does (a helper walking recorded videos had to guess).
#[test]
fn plan_from_a_folder_names_the_frame_it_plans_from() {
    let rec = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/recordings/sim-L-seed6"
    );
    let frames = format!("{rec}/frames");
    let calib = format!("{rec}/calibration.toml");
    let (ok, text) = nanopush(&["plan", "--text", "L", "--frame", &frames, "--calib", &calib]);
    assert!(ok, "{text}");
    assert!(
        text.contains("planning from its first image of 4, frame_00000.png"),
        "{text}"
    );
}

/// A particle the plan does not need may lie 0.15 um beside a letter and
/// read as part of it (the demo's 'CMU' had one bridging the C and the M);
/// `--keep-clear-um` moves such strays that far off the pattern's
/// particles, and the plan still verifies.
#[test]
fn keep_clear_leaves_no_stray_beside_the_pattern() {
    let dir = tempfile::tempdir().unwrap();
    let layout = cmu_field_layout(dir.path(), "50", "uniform", "4");
    let layout = layout.as_str();
    let stray_gap = |more: &[&str]| -> (f64, f64) {
        let head = ["plan", "--text", "CMU", "--layout", layout, "--json"];
        let args: Vec<&str> = head.iter().chain(more).copied().collect();
        let (ok, text) = nanopush(&args);
        assert!(ok, "{text}");
        let json: serde_json::Value = serde_json::from_str(&text).expect("summary JSON");
        assert_eq!(json["verified"], true, "{text}");
        (
            json["nearest_stray_gap_um"].as_f64().expect("a stray gap"),
            json["push_distance_um"].as_f64().unwrap(),
        )
    };
    let (plain_gap, plain_push) = stray_gap(&[]);
    assert!(
        plain_gap < 1.0,
        "this layout's plain plan left its nearest stray {plain_gap} um off"
    );
    let (kept_gap, kept_push) = stray_gap(&["--keep-clear-um", "2.5"]);
    assert!(
        kept_gap >= 2.5,
        "nearest stray {kept_gap} um with --keep-clear-um 2.5"
    );
    assert!(
        kept_push > plain_push,
        "clearing strays pushed no farther: {kept_push} um"
    );
}

/// `synth layout` of `n` 10 um particles at 1 um gaps in the 120 x 100 um
/// field of the CMU scenes, of `kind` and `seed`: its path.
fn cmu_field_layout(dir: &Path, n: &str, kind: &str, seed: &str) -> String {
    let path = dir.join(format!("{kind}-{n}-{seed}.json"));
    let out = path.to_str().unwrap();
    let (ok, text) = nanopush(&[
        "synth",
        "layout",
        "--n",
        n,
        "--field-um",
        "120x100",
        "--radius-um",
        "5",
        "--min-gap-um",
        "1",
        "--kind",
        kind,
        "--seed",
        seed,
        "--out",
        out,
    ]);
    assert!(ok, "{text}");
    out.to_owned()
}

/// The tip is scaled to the particles: a field of 1 um spheres 0.1 um
/// apart plans with a 0.1 um tip disc landing 0.1 um behind the contact
/// point (the 10 um spheres' 1 um disc, as wide as the particles, was
/// refused there after 7.5 s of placements), and the plan does need the
/// narrow disc: replayed with the old 1 um one it fails. A plan without a
/// geometry block is replayed with the disc scaled to the layout.
#[test]
fn a_dense_field_of_micron_spheres_plans_with_the_tip_scaled_to_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let (layout, plan) = (path("micron.json"), path("plan.json"));
    let (ok, text) = nanopush(&[
        "synth",
        "layout",
        "--n",
        "250",
        "--field-um",
        "40x40",
        "--radius-um",
        "0.5",
        "--min-gap-um",
        "0.1",
        "--seed",
        "1",
        "--out",
        &layout,
    ]);
    assert!(ok, "{text}");
    let (ok, text) = nanopush(&[
        "plan", "--text", "I", "--layout", &layout, "--out", &plan, "--json",
    ]);
    assert!(ok, "refused: {text}");
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&plan).unwrap()).unwrap();
    for (key, um) in [
        ("tip_radius_um", &file["geometry"]["tip_radius_um"]),
        ("standoff_um", &summary["standoff_um"]),
    ] {
        let um = um.as_f64().unwrap();
        assert!((um - 0.1).abs() < 1e-12, "{key} {um}");
    }
    let verify = |plan: &str, extra: &[&str]| {
        nanopush(&[&["verify-plan", plan, "--layout", &layout][..], extra].concat())
    };
    let (ok, text) = verify(&plan, &[]);
    assert!(ok, "{text}");
    let (ok, text) = verify(&plan, &["--tip-radius-um", "1"]);
    assert!(!ok, "the 1 um disc fits this plan too: {text}");
    file.as_object_mut().unwrap().remove("geometry");
    let bare = path("bare.json");
    std::fs::write(&bare, file.to_string()).unwrap();
    let (ok, text) = verify(&bare, &[]);
    assert!(
        ok && text.contains("tip radius 0.1 um (default: the plan gives none)"),
        "{text}"
    );
}
