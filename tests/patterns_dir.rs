//! The example patterns in patterns/: each file reads as a pattern at the
//! default pitch with the sites patterns/README.md gives, and plans without
//! collision on a random layout; every file there is in the README's table.

use nanopush::plan::pattern::site_list::read_pattern;
use nanopush::plan::pattern::transform::{Reachable, place_optimised};
use nanopush::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
use nanopush::plan::{DEFAULT_SITE_GAP_M, PlanConfig, plan_assembly, verify_plan};
use std::path::Path;

/// Sites each example holds at the default pitch (10.5 um); the heart's
/// count is the divider's along its outline, measured.
const EXPECTED_SITES: [(&str, usize); 4] = [
    ("hexagon.toml", 7),
    ("arrow.json", 7),
    ("plus.png", 9),
    ("heart.svg", 16),
];

#[test]
fn every_example_pattern_reads_and_plans() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("patterns");
    let readme = std::fs::read_to_string(dir.join("README.md")).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "README.md")
        .collect();
    names.sort();
    let mut expected: Vec<&str> = EXPECTED_SITES.iter().map(|e| e.0).collect();
    expected.sort();
    assert_eq!(
        names, expected,
        "patterns/ holds other files than the test knows"
    );
    let radius = 5e-6;
    let pitch = 2.0 * radius + DEFAULT_SITE_GAP_M;
    let layout = synth_layout(&SynthParams::cmu_field(60, LayoutKind::Uniform, 1)).unwrap();
    let centres: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
    let area = Reachable::for_field(layout.field_m, radius);
    let config = PlanConfig::default();
    for (name, sites) in EXPECTED_SITES {
        assert!(
            readme.contains(&format!("`{name}`")),
            "{name} is not in the README"
        );
        let pattern = read_pattern(&dir.join(name), pitch).unwrap();
        assert_eq!(pattern.offsets_m.len(), sites, "{name}");
        pattern.check_no_overlap(2.0 * radius).unwrap();
        let placed = place_optimised(&pattern, &area, radius, &centres).unwrap();
        let plan =
            plan_assembly(&layout, &placed, &config).unwrap_or_else(|e| panic!("{name}: {e}"));
        let report = verify_plan(&plan, &layout, &config);
        assert!(report.ok, "{name}: {report:?}");
        assert!(plan.summary.pushes >= 1, "{name}: nothing to push?");
    }
}
