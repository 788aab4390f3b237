//! Effects are simulated only when the scene calls for them: a scene that
//! turns an effect off does none of its work (counted per simulated contact
//! by the simulated rig), and the report lists the active effects.

use nanopush::exec::report::AssemblyReport;
use std::path::Path;
use std::process::Command;

const RUN: [&str; 6] = ["--text", "L", "--seed", "6", "--particles", "20"];

fn paper_text() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml"))
        .unwrap()
}

/// Runs assemble on a scene given as text and returns report.json and report.md.
fn run(scene_text: &str) -> (AssemblyReport, String) {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, scene_text).unwrap();
    let out = dir.path().join("o");
    Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .args(["assemble", "--json", "--scene", scene.to_str().unwrap()])
        .args(["--out", out.to_str().unwrap()])
        .args(RUN)
        .output()
        .unwrap();
    let report: AssemblyReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    (report, md)
}

fn listed(r: &AssemblyReport, name: &str) -> bool {
    r.active_effects
        .iter()
        .any(|e| e.name == name && !e.reason.is_empty())
}

#[test]
fn capillarity_works_only_in_the_humid_scene_and_the_report_lists_it() {
    let (dry, dry_md) = run(&paper_text());
    let (humid, humid_md) = run(&format!(
        "{}\n[environment]\nrelative_humidity_percent = 60.0\n",
        paper_text()
    ));
    let dry_work = dry.effect_work.clone().unwrap();
    let humid_work = humid.effect_work.clone().unwrap();
    // Positive control: the always-on effects did work in both runs, once per contact.
    let dry_contacts = dry_work["rolling and sliding"];
    let humid_contacts = humid_work["rolling and sliding"];
    assert!(dry_contacts >= dry.pushes as u64 && dry.pushes > 0);
    assert!(humid_contacts >= humid.pushes as u64 && humid.pushes > 0);
    // Off: not listed, never evaluated.
    assert!(!listed(&dry, "capillarity"));
    assert!(!dry_work.contains_key("capillarity"), "{dry_work:?}");
    assert!(!dry_md.contains("| capillarity |"));
    // On: listed with its reason, evaluated in every contact.
    assert!(listed(&humid, "capillarity"));
    assert_eq!(humid_work.get("capillarity"), Some(&humid_contacts));
    assert!(humid_md.contains("| capillarity |"));
    // No other optional effect did any work in either run.
    for name in [
        "charge build-up",
        "piezo drift",
        "substrate tilt",
        "spinning",
        "tip riding over",
        "particle-particle contact",
    ] {
        assert!(
            !dry_work.contains_key(name) && !humid_work.contains_key(name),
            "{name}"
        );
        assert!(!listed(&dry, name) && !listed(&humid, name), "{name}");
    }
}
