//! The paper scene (calib/paper-ps-ito.toml) with lines of it replaced,
//! written for a test: one way of making a scene variant for every test
//! binary that needs one.
// Each test binary that includes this module uses only part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The edits that let the tip ride over the particle, and make rolling so
/// hard that it rides over at every contact angle: no push is safe.
pub const RIDE_OVER: [(&str, &str); 3] = [
    ("hold_contact_angle = true", "hold_contact_angle = false"),
    ("shear_strength_mpa = 28.0", "shear_strength_mpa = 200.0"),
    ("rolling_shear_pa_m = 98.5", "rolling_shear_pa_m = 300.0"),
];

/// The paper scene with each `(from, to)` edit made (each `from` must be
/// in it exactly once), written as `dir/name`.
pub fn scene_file(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let paper = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml");
    let mut text = std::fs::read_to_string(paper).unwrap();
    for (from, to) in edits {
        assert_eq!(text.matches(from).count(), 1, "{from} in the paper scene");
        text = text.replace(from, to);
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}
