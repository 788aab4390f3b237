//! Rig files (TOML, `calib/rig-*.toml`): which stage driver at which address,
//! which camera, which pixel-to-stage calibration, and the host-side safety
//! limits, in lab units (micrometres) converted to SI once, here.

use super::safety::{SafetyLimits, SoftLimit};
use super::stage::StageSettings;
pub use crate::rig::camera_source::CameraSource;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The schema tag every rig file carries.
pub const RIG_SCHEMA: &str = "nanopush.rig/1";

/// A rig file, said for a person given another file for one.
const RIG_WANTED: &str =
    "a rig file (nanopush.rig/1: stage, safety, camera, calibration; see calib/rig-*.toml)";

/// A whole rig description as written in TOML.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigFile {
    /// Always [`RIG_SCHEMA`].
    pub schema: String,
    /// Free-text name of the rig.
    #[serde(default)]
    pub name: String,
    /// The stage and how to reach it.
    pub stage: StageSection,
    /// Host-side safety limits.
    pub safety: SafetySection,
    /// Where frames come from.
    pub camera: CameraSource,
    /// Pixel-to-stage calibration file (relative to the rig file).
    pub calibration: PathBuf,
    /// The coarse XY stage, if the rig has one under software control.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coarse: Option<CoarseSection>,
}

/// The motorised coarse XY stage that brings the work area into the
/// nanostage's reach: another GCS controller (a C-884 driving two linear
/// stages, say) with its own link and its own host-side limits. In TOML:
/// `[coarse]` with `sign`, then `[coarse.stage]` and `[coarse.safety]`,
/// laid out as the nanostage's `[stage]` and `[safety]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoarseSection {
    /// Per axis (coarse axes in nanostage order x, y): +1 where a positive
    /// coarse move carries the nanostage's origin positive across the
    /// sample (the coarse stage carries the nanostage and the camera), -1
    /// where it moves the sample positive under them (the usual case: the
    /// coarse stage carries the sample). The coarse axes must be parallel
    /// to the nanostage's.
    pub sign: [i8; 2],
    /// The controller and how to reach it (exactly two axes, x then y).
    pub stage: StageSection,
    /// Host-side limits of the coarse axes, micrometres.
    pub safety: SafetySection,
}

/// How the stage is driven and reached.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSection {
    /// The driver; only PI GCS 2.0 exists so far.
    pub driver: StageDriver,
    /// Link kind.
    pub link: LinkKind,
    /// `host:port` for TCP (PI default port 50000), a tty path for serial.
    pub address: String,
    /// Serial baud rate (ignored for TCP).
    #[serde(default = "default_baud")]
    pub baud: u32,
    /// Reply timeout per command, milliseconds.
    #[serde(default = "default_timeout_ms")]
    pub timeout_ms: u64,
    /// Longest wait for a move to settle, milliseconds.
    #[serde(default = "default_settle_ms")]
    pub settle_timeout_ms: u64,
    /// Controller axis identifiers in stage order (x, y[, z]).
    pub axes: Vec<String>,
    /// Micrometres per controller position unit (1 for PI piezo controllers
    /// that speak um, 1000 for stages that speak mm).
    pub unit_um: f64,
    /// True for real hardware: the first move then needs confirmation.
    pub real_hardware: bool,
    /// The controller's z reading, micrometres, where the tip's apex
    /// touches the substrate: the loop's heights are taken from it. A
    /// nanostage with z on real hardware must give it (and `z_lifts`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z_surface_um: Option<f64>,
    /// Which way of the controller's z lifts the tip off the sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z_lifts: Option<ZLifts>,
}

/// Which way of a controller's z axis lifts the tip off the sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ZLifts {
    /// A larger z reading is a higher tip.
    Increasing,
    /// A larger z reading is a lower tip (the stage extends toward the sample).
    Decreasing,
}

/// How the loop's height above the substrate maps to the controller's z:
/// z = surface + sign * height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZConvention {
    /// The controller's z where the apex touches the substrate, metres.
    pub surface_m: f64,
    /// +1 when z increasing lifts, -1 when it lowers.
    pub sign: f64,
}

impl ZConvention {
    /// The controller's z for a height above the substrate.
    pub fn stage_z(&self, height_m: f64) -> f64 {
        self.surface_m + self.sign * height_m
    }

    /// The height above the substrate of a controller z.
    pub fn height(&self, stage_z_m: f64) -> f64 {
        self.sign * (stage_z_m - self.surface_m)
    }
}

fn default_baud() -> u32 {
    115_200
}
fn default_timeout_ms() -> u64 {
    1000
}
fn default_settle_ms() -> u64 {
    10_000
}

/// Stage drivers nanopush has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StageDriver {
    /// Physik Instrumente GCS 2.0 (E-727, E-709, C-884, ...).
    Gcs,
}

/// How the controller is connected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LinkKind {
    /// TCP/IP.
    Tcp,
    /// RS-232 or USB virtual COM port.
    Serial,
}

/// Host-side limits in lab units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafetySection {
    /// Soft lower limits per axis, micrometres.
    pub soft_min_um: Vec<f64>,
    /// Soft upper limits per axis, micrometres.
    pub soft_max_um: Vec<f64>,
    /// Largest single move, micrometres.
    pub max_step_um: f64,
    /// Top speed, micrometres per second.
    pub top_speed_um_s: f64,
}

/// A rig file that could not be read or makes no sense.
#[derive(Debug, thiserror::Error)]
pub enum RigFileError {
    /// The file could not be read.
    #[error("cannot read rig file {path}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The TOML did not parse into a rig.
    #[error("rig file {path} is not valid")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What the parser said (with line and column).
        source: Box<toml::de::Error>,
    },
    /// The file is another nanopush kind (a calibration, a scene).
    #[error("rig file {path}: {kind}")]
    AnotherKind {
        /// The file.
        path: PathBuf,
        /// What it is.
        kind: crate::file_schema::AnotherKind,
    },
    /// The values are inconsistent.
    #[error("rig file {path}: {reason}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

impl RigFile {
    /// Parses and validates rig TOML; `path` is only used in messages.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, RigFileError> {
        // A file of another kind is named by its schema (a calibration given
        // as --rig had said "unknown field `inliers`").
        if let Some(kind) = crate::file_schema::other_toml_kind(text, RIG_SCHEMA, RIG_WANTED) {
            return Err(RigFileError::AnotherKind {
                path: path.to_path_buf(),
                kind,
            });
        }
        let rig: RigFile = toml::from_str(text).map_err(|e| RigFileError::Parse {
            path: path.to_path_buf(),
            source: Box::new(crate::rig::camera_table::at_its_key(text, e)),
        })?;
        rig.validate().map_err(|reason| RigFileError::Invalid {
            path: path.to_path_buf(),
            reason,
        })?;
        Ok(rig)
    }

    /// Reads and validates a rig file; relative paths inside it are resolved
    /// against its folder.
    pub fn load(path: &Path) -> Result<Self, RigFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| RigFileError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let mut rig = Self::from_toml(&text, path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        rig.calibration = base.join(&rig.calibration);
        rig.camera.resolve_paths(base);
        Ok(rig)
    }

    /// Writes the rig as TOML.
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string(self)
    }

    fn validate(&self) -> Result<(), String> {
        if self.schema != RIG_SCHEMA {
            return Err(format!(
                "schema is {:?}, expected {RIG_SCHEMA:?}",
                self.schema
            ));
        }
        validate_controller(&self.stage, &self.safety, "stage", "safety")?;
        self.validate_z()?;
        if let Some(coarse) = &self.coarse {
            coarse.validate()?;
        }
        self.camera.validate()
    }

    /// A z convention only with a z axis; on real hardware, never guessed:
    /// taking the controller's z as the height above the substrate (as
    /// before 2026-11-29, and still for simulators without the keys) drives
    /// the tip into the sample on a stage whose z extends toward it.
    fn validate_z(&self) -> Result<(), String> {
        let has_z = self.stage.has_z();
        let given = (self.stage.z_surface_um, self.stage.z_lifts);
        match given {
            (Some(_), _) | (_, Some(_)) if !has_z => Err(
                "stage.z_surface_um and stage.z_lifts are for a stage with a z axis (axes x, y, z)"
                    .into(),
            ),
            (Some(z), _) if !z.is_finite() => Err(format!("stage.z_surface_um must be a number, got {z}")),
            (None, _) | (_, None) if has_z && self.stage.real_hardware => Err(
                "a nanostage with z on real hardware needs stage.z_surface_um (the controller's z, um, where the tip touches the substrate) and stage.z_lifts (\"increasing\" or \"decreasing\": which way of z lifts the tip); a wrong guess drives the tip into the sample"
                    .into(),
            ),
            _ => Ok(()),
        }
    }

    /// The nanostage's z convention: as the rig file gives it, else the
    /// controller's z taken as the height (simulators).
    pub fn z_convention(&self) -> ZConvention {
        ZConvention {
            surface_m: self.stage.z_surface_um.unwrap_or(0.0) * 1e-6,
            sign: match self.stage.z_lifts {
                Some(ZLifts::Decreasing) => -1.0,
                _ => 1.0,
            },
        }
    }

    /// The safety limits in SI units.
    pub fn safety_limits(&self) -> SafetyLimits {
        self.safety.limits()
    }

    /// Stage settings in SI units.
    pub fn stage_settings(&self) -> StageSettings {
        self.stage.settings(&self.safety)
    }

    /// Reply timeout per command.
    pub fn reply_timeout(&self) -> Duration {
        self.stage.reply_timeout()
    }
}

impl CoarseSection {
    fn validate(&self) -> Result<(), String> {
        if self.stage.axes.len() != 2 {
            return Err(format!(
                "coarse.stage.axes needs 2 axes (x, y), got {}",
                self.stage.axes.len()
            ));
        }
        if self.stage.z_surface_um.is_some() || self.stage.z_lifts.is_some() {
            return Err("coarse.stage has no z: z_surface_um and z_lifts belong in [stage]".into());
        }
        if let Some(bad) = self.sign.iter().find(|s| s.abs() != 1) {
            return Err(format!("coarse.sign entries must be 1 or -1, got {bad}"));
        }
        validate_controller(&self.stage, &self.safety, "coarse.stage", "coarse.safety")
    }

    /// The coarse controller's settings in SI units.
    pub fn stage_settings(&self) -> StageSettings {
        self.stage.settings(&self.safety)
    }

    /// `sign` as factors.
    pub fn sign_factors(&self) -> [f64; 2] {
        self.sign.map(f64::from)
    }
}

impl StageSection {
    /// True when the stage drives z (axes x, y, z): only then can the tip
    /// be lifted off the sample.
    pub fn has_z(&self) -> bool {
        self.axes.len() == 3
    }

    /// Reply timeout per command.
    pub fn reply_timeout(&self) -> Duration {
        Duration::from_millis(self.timeout_ms)
    }

    /// Settings in SI units under `safety`'s limits.
    pub fn settings(&self, safety: &SafetySection) -> StageSettings {
        StageSettings {
            axes: self.axes.clone(),
            unit_m: self.unit_um * 1e-6,
            limits: safety.limits(),
            settle_timeout: Duration::from_millis(self.settle_timeout_ms),
            poll_interval: Duration::from_millis(10),
        }
    }
}

impl SafetySection {
    /// The limits in SI units.
    pub fn limits(&self) -> SafetyLimits {
        SafetyLimits {
            soft_limits: self
                .soft_min_um
                .iter()
                .zip(&self.soft_max_um)
                .map(|(&lo, &hi)| SoftLimit {
                    min_m: lo * 1e-6,
                    max_m: hi * 1e-6,
                })
                .collect(),
            max_step_m: self.max_step_um * 1e-6,
            max_speed_m_per_s: self.top_speed_um_s * 1e-6,
        }
    }
}

/// Checks one controller's link and limits; `stage` and `safety` name the
/// sections in messages (`stage` / `coarse.stage`, ...).
fn validate_controller(
    section: &StageSection,
    safety: &SafetySection,
    stage: &str,
    safety_name: &str,
) -> Result<(), String> {
    let n = section.axes.len();
    if n == 0 {
        return Err(format!("{stage}.axes is empty"));
    }
    for axis in &section.axes {
        super::protocol::validate_axis(axis).map_err(|e| format!("{stage}.axes: {e}"))?;
    }
    if let Some(axis) = super::protocol::repeated_axis(&section.axes) {
        return Err(format!(
            "{stage}.axes names axis {axis:?} twice ({:?}): each stage axis needs its own controller axis",
            section.axes
        ));
    }
    if safety.soft_min_um.len() != n || safety.soft_max_um.len() != n {
        return Err(format!(
            "{safety_name}.soft_min_um and soft_max_um need {n} entries (one per axis)"
        ));
    }
    if !(section.unit_um.is_finite() && section.unit_um > 0.0) {
        return Err(format!(
            "{stage}.unit_um must be positive, got {}",
            section.unit_um
        ));
    }
    if section.timeout_ms == 0 || section.settle_timeout_ms == 0 {
        return Err(format!(
            "{stage}.timeout_ms and {stage}.settle_timeout_ms must be positive"
        ));
    }
    if section.link == LinkKind::Serial && super::serial_link::baud_rate(section.baud).is_none() {
        return Err(format!(
            "{stage}.baud {} is not a supported rate",
            section.baud
        ));
    }
    safety
        .limits()
        .validate()
        .map_err(|e| format!("{safety_name}: {e}"))?;
    check_micrometre_scale(safety, safety_name)
}

/// Narrowest soft range per axis a rig file may give, micrometres. The
/// smallest stage nanopush drives travels 15 um (a nanostage's z) and must
/// hold a particle's height in it; a range under 1 um is a range written in
/// metres (98e-6 for 98 um), which had been accepted and planned a pattern
/// into a "reachable area of -1.0 x -1.0 um".
pub const MIN_SOFT_RANGE_UM: f64 = 1.0;

/// Shortest largest step a rig file may give, micrometres: 10 nm, the
/// nanostage's own precision; no real stage is limited to moves it cannot
/// resolve, while a step written in metres (20e-6 for 20 um) falls far below.
pub const MIN_MAX_STEP_UM: f64 = 0.01;

/// Slowest top speed a rig file may give, micrometres a second: 10 nm/s,
/// about the drift of a warm probe, so no stage pushes usefully below it,
/// while a speed written in metres a second (200e-6 for 200 um/s) falls
/// far below; it had crawled `rig calibrate`'s moves at 0.2 nm/s.
pub const MIN_TOP_SPEED_UM_S: f64 = 0.01;

/// Refuses limits too small for a micrometre field, naming the field and
/// the likely slip: values in metres where the file wants micrometres.
fn check_micrometre_scale(safety: &SafetySection, safety_name: &str) -> Result<(), String> {
    let slip = "values look like metres; the rig file wants micrometres (98.0 for 98 um)";
    let ranges = safety.soft_min_um.iter().zip(&safety.soft_max_um);
    if let Some((axis, (lo, hi))) = ranges
        .enumerate()
        .find(|(_, (lo, hi))| *hi - *lo < MIN_SOFT_RANGE_UM)
    {
        return Err(format!(
            "{safety_name}.soft_min_um and soft_max_um give axis {axis} a range [{lo}, {hi}] um, under {MIN_SOFT_RANGE_UM} um: {slip}"
        ));
    }
    if safety.max_step_um < MIN_MAX_STEP_UM {
        return Err(format!(
            "{safety_name}.max_step_um is {} um, under {MIN_MAX_STEP_UM} um: {slip}",
            safety.max_step_um
        ));
    }
    if safety.top_speed_um_s < MIN_TOP_SPEED_UM_S {
        return Err(format!(
            "{safety_name}.top_speed_um_s is {} um/s, under {MIN_TOP_SPEED_UM_S} um/s: {slip}",
            safety.top_speed_um_s
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = include_str!("../../../calib/rig-gcs-sim.toml");

    #[test]
    fn example_rig_round_trips() {
        let rig = RigFile::from_toml(EXAMPLE, Path::new("rig-gcs-sim.toml")).unwrap();
        assert_eq!(rig.stage.axes, vec!["1", "2"]);
        let text = rig.to_toml().unwrap();
        let back = RigFile::from_toml(&text, Path::new("again.toml")).unwrap();
        assert_eq!(rig, back);
        let limits = rig.safety_limits();
        assert!((limits.soft_limits[0].max_m - rig.safety.soft_max_um[0] * 1e-6).abs() < 1e-15);
    }

    #[test]
    fn every_shipped_rig_file_loads() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib");
        let mut count = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if name.starts_with("rig-") && name.ends_with(".toml") {
                let rig = RigFile::load(&path).unwrap_or_else(|e| panic!("{name}: {e:?}"));
                assert!(
                    rig.calibration.starts_with(&dir),
                    "calibration resolved against calib/"
                );
                count += 1;
            }
        }
        assert!(count >= 3, "found {count} rig files");
    }

    #[test]
    fn inconsistent_rigs_are_refused_with_a_reason() {
        let bad = EXAMPLE.replace("soft_min_um = [", "soft_min_um = [1.0, ");
        let err = RigFile::from_toml(&bad, Path::new("bad.toml")).unwrap_err();
        assert!(matches!(err, RigFileError::Invalid { .. }), "{err}");
        let bad = EXAMPLE.replace("nanopush.rig/1", "nanopush.rig/9");
        assert!(RigFile::from_toml(&bad, Path::new("bad.toml")).is_err());
        let bad = EXAMPLE.replace("link = \"tcp\"", "link = \"carrier-pigeon\"");
        assert!(matches!(
            RigFile::from_toml(&bad, Path::new("bad.toml")),
            Err(RigFileError::Parse { .. })
        ));
    }

    #[test]
    fn a_repeated_axis_is_refused_naming_file_field_and_axis() {
        let xyz = include_str!("../../../calib/rig-gcs-sim-xyz.toml");
        let bad = xyz.replace(r#"axes = ["1", "2", "3"]"#, r#"axes = ["1", "1", "3"]"#);
        assert_ne!(bad, xyz, "the replacement did not apply");
        let err = RigFile::from_toml(&bad, Path::new("dup.toml")).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, RigFileError::Invalid { .. }), "{text}");
        for needle in ["dup.toml", "stage.axes", "\"1\" twice"] {
            assert!(text.contains(needle), "no {needle:?} in: {text}");
        }
        let coarse = COARSE.replace(
            "axes = [\"1\", \"2\"]\nunit_um = 1000.0",
            "axes = [\"2\", \"2\"]\nunit_um = 1000.0",
        );
        assert_ne!(coarse, COARSE, "the replacement did not apply");
        let err = RigFile::from_toml(&coarse, Path::new("dup.toml")).unwrap_err();
        assert!(err.to_string().contains("coarse.stage.axes"), "{err}");
        let empty = xyz.replace(r#"axes = ["1", "2", "3"]"#, r#"axes = ["1", "", "3"]"#);
        let err = RigFile::from_toml(&empty, Path::new("empty.toml")).unwrap_err();
        assert!(err.to_string().contains("stage.axes"), "{err}");
    }

    const COARSE: &str = include_str!("../../../calib/rig-gcs-sim-coarse-folder.toml");

    /// Limits written in metres are refused naming the field and the slip;
    /// the smallest plausible ones (just at the thresholds) still load.
    #[test]
    fn limits_written_in_metres_are_refused_as_a_unit_slip() {
        let xyz = include_str!("../../../calib/rig-gcs-sim-xyz.toml");
        let cases = [
            (
                xyz.replace(
                    "soft_max_um = [98.0, 98.0, 15.0]",
                    "soft_max_um = [98e-6, 98e-6, 15e-6]",
                )
                .replace(
                    "soft_min_um = [2.0, 2.0, 0.0]",
                    "soft_min_um = [2e-6, 2e-6, 0.0]",
                ),
                "safety.soft_min_um and soft_max_um give axis 0",
            ),
            (
                xyz.replace("max_step_um = 150.0", "max_step_um = 150e-6"),
                "safety.max_step_um is 0.00015 um",
            ),
            (
                xyz.replace("top_speed_um_s = 200.0", "top_speed_um_s = 200e-6"),
                "safety.top_speed_um_s is 0.0002 um/s",
            ),
            (
                COARSE.replace(
                    "soft_max_um = [24000.0, 24000.0]",
                    "soft_max_um = [1000.5, 24000.0]",
                ),
                "coarse.safety.soft_min_um and soft_max_um give axis 0 a range [1000, 1000.5] um",
            ),
        ];
        for (text, field) in cases {
            assert!(
                text != xyz && text != COARSE,
                "the replacement did not apply"
            );
            let err = RigFile::from_toml(&text, Path::new("metres.toml")).unwrap_err();
            let msg = err.to_string();
            assert!(matches!(err, RigFileError::Invalid { .. }), "{msg}");
            for needle in [
                "metres.toml",
                field,
                "look like metres",
                "wants micrometres",
            ] {
                assert!(msg.contains(needle), "no {needle:?} in: {msg}");
            }
        }
        let smallest = xyz
            .replace(
                "soft_max_um = [98.0, 98.0, 15.0]",
                &format!("soft_max_um = [98.0, 98.0, {MIN_SOFT_RANGE_UM}]"),
            )
            .replace(
                "max_step_um = 150.0",
                &format!("max_step_um = {MIN_MAX_STEP_UM}"),
            );
        assert_ne!(smallest, xyz, "the replacement did not apply");
        RigFile::from_toml(&smallest, Path::new("small.toml")).unwrap();
    }

    #[test]
    fn a_coarse_section_round_trips_and_is_checked() {
        let rig = RigFile::from_toml(COARSE, Path::new("coarse.toml")).unwrap();
        let coarse = rig.coarse.as_ref().expect("a [coarse] section");
        assert_eq!(coarse.sign, [-1, -1]);
        assert_eq!(coarse.stage.axes, vec!["1", "2"]);
        let limits = coarse.stage_settings().limits;
        assert!((limits.soft_limits[1].max_m - 24e-3).abs() < 1e-15);
        assert!((coarse.stage_settings().unit_m - 1e-3).abs() < 1e-18);
        let back = RigFile::from_toml(&rig.to_toml().unwrap(), Path::new("again.toml")).unwrap();
        assert_eq!(rig, back);
        let bad = [
            COARSE.replace(
                "axes = [\"1\", \"2\"]\nunit_um = 1000.0",
                "axes = [\"1\", \"2\", \"3\"]\nunit_um = 1000.0",
            ),
            COARSE.replace("sign = [-1, -1]", "sign = [-1, 2]"),
            COARSE.replace("soft_min_um = [1000.0, 1000.0]", "soft_min_um = [1000.0]"),
        ];
        for text in bad {
            assert_ne!(text, COARSE, "the replacement did not apply");
            let err = RigFile::from_toml(&text, Path::new("bad.toml")).unwrap_err();
            assert!(matches!(err, RigFileError::Invalid { .. }), "{err}");
            assert!(err.to_string().contains("coarse"), "{err}");
        }
    }
}
