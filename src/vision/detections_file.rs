//! The `nanopush detect --json` document ("nanopush.detections/1"), written and read back.

use serde::{Deserialize, Serialize};

use super::analyse::FrameAnalysis;
use super::exposure::Exposure;
use super::line_defects::LineDefect;
use crate::calib::camera_map::CameraCalibration;

/// Schema tag of detection files.
pub const DETECTIONS_SCHEMA: &str = "nanopush.detections/1";

/// One particle as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParticleRecord {
    pub x_px: f64,
    pub y_px: f64,
    pub r_px: f64,
    pub sigma_px: f64,
    pub quality: f64,
    /// Cut by the frame's edge (absent in files written before it was
    /// recorded: read as not cut).
    #[serde(default)]
    pub edge_clipped: bool,
    /// `r_px` and `sigma_px` measured, not the size hint and a nominal value
    /// ([`crate::vision::detect::Detection::fitted`]; absent in files written
    /// before it was recorded: read as measured).
    #[serde(default = "measured")]
    pub fitted: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_um: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y_um: Option<f64>,
}

fn measured() -> bool {
    true
}

/// The tip as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TipRecord {
    pub x_px: f64,
    pub y_px: f64,
    pub angle_deg: f64,
    pub score: f64,
    /// The apex on the stage when calibrated, as for the particles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_um: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y_um: Option<f64>,
}

/// The whole document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectionsFile {
    pub schema: String,
    pub particles: Vec<ParticleRecord>,
    pub tip: Option<TipRecord>,
    /// Camera lines filled in before detection (empty: none; absent in
    /// files written before they were recorded).
    #[serde(default)]
    pub repaired_lines: Vec<LineDefect>,
    /// Fractions of the frame's pixels at the full count and at 0 (absent
    /// in files written before they were recorded: read as none).
    #[serde(default)]
    pub exposure: Exposure,
}

/// Where pixel (x, y) lies on the stage in um, when calibrated.
fn on_stage_um(calib: Option<&CameraCalibration>, x_px: f64, y_px: f64) -> [Option<f64>; 2] {
    let um = calib.map(|c| c.pixel_to_stage_m(x_px, y_px));
    [0, 1].map(|i| um.map(|u| u[i] * 1e6))
}

impl DetectionsFile {
    /// Builds the document, adding stage micrometres when calibrated.
    pub fn new(analysis: &FrameAnalysis, calib: Option<&CameraCalibration>) -> Self {
        let particles = analysis
            .particles
            .iter()
            .map(|d| {
                let [x_um, y_um] = on_stage_um(calib, d.x_px, d.y_px);
                ParticleRecord {
                    x_px: d.x_px,
                    y_px: d.y_px,
                    r_px: d.r_px,
                    sigma_px: d.sigma_px,
                    quality: d.quality,
                    edge_clipped: d.edge_clipped,
                    fitted: d.fitted,
                    x_um,
                    y_um,
                }
            })
            .collect();
        Self {
            schema: DETECTIONS_SCHEMA.into(),
            particles,
            tip: analysis.tip.as_ref().map(|t| {
                let [x_um, y_um] = on_stage_um(calib, t.x_px, t.y_px);
                TipRecord {
                    x_px: t.x_px,
                    y_px: t.y_px,
                    angle_deg: t.angle_rad.to_degrees(),
                    score: t.score,
                    x_um,
                    y_um,
                }
            }),
            repaired_lines: analysis.repaired_lines.clone(),
            exposure: analysis.exposure,
        }
    }

    /// Parses a document, checking the schema.
    pub fn from_json(text: &str) -> Result<Self, String> {
        let f: Self = serde_json::from_str(text).map_err(|e| e.to_string())?;
        if f.schema != DETECTIONS_SCHEMA {
            return Err(format!(
                "schema is {:?}, expected {DETECTIONS_SCHEMA:?}",
                f.schema
            ));
        }
        Ok(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::detect::Detection;
    use crate::vision::line_defects::LineAxis;

    #[test]
    fn json_round_trip_with_calibration() {
        let d = Detection {
            x_px: 10.5,
            y_px: 20.25,
            r_px: 8.0,
            sigma_px: 0.03,
            quality: 40.0,
            edge_clipped: false,
            fitted: true,
        };
        let cal = CameraCalibration::from_scale_rotation(0.5e-6, 0.0, [0.0, 0.0]);
        let line = LineDefect {
            axis: LineAxis::Row,
            index: 7,
            mean_counts: 65535.0,
            beside_counts: 1200.5,
        };
        let analysis = FrameAnalysis {
            particles: vec![d],
            tip: None,
            repaired_lines: vec![line],
            exposure: Exposure {
                saturated_fraction: 0.25,
                dark_fraction: 0.0,
            },
        };
        let f = DetectionsFile::new(&analysis, Some(&cal));
        assert_eq!(f.particles[0].x_um, Some(5.25));
        // A script reading the file can tell a cut or unfitted particle.
        let cut_unfitted = FrameAnalysis {
            particles: vec![Detection {
                edge_clipped: true,
                fitted: false,
                ..d
            }],
            ..analysis.clone()
        };
        let text = serde_json::to_string(&DetectionsFile::new(&cut_unfitted, None)).unwrap();
        assert!(
            text.contains("\"edge_clipped\":true,\"fitted\":false"),
            "{text}"
        );
        let back = DetectionsFile::from_json(&text).unwrap();
        assert!(back.particles[0].edge_clipped && !back.particles[0].fitted);
        // The tip on the stage too, and back from the file.
        let tipped = FrameAnalysis {
            tip: Some(crate::vision::tip::TipDetection {
                x_px: 100.0,
                y_px: 40.0,
                angle_rad: 0.5,
                score: 0.9,
                width_px: 30.0,
                taper_length_px: 60.0,
            }),
            ..analysis.clone()
        };
        let t = DetectionsFile::new(&tipped, Some(&cal));
        let tip = t.tip.as_ref().unwrap();
        let (x, y) = (tip.x_um.unwrap(), tip.y_um.unwrap());
        assert!(
            (x - 50.0).abs() < 1e-9 && (y - 20.0).abs() < 1e-9,
            "{x} {y}"
        );
        let back = DetectionsFile::from_json(&serde_json::to_string(&t).unwrap()).unwrap();
        assert_eq!(back, t);
        let text = serde_json::to_string(&f).unwrap();
        assert!(text.contains("\"tip\":null"));
        assert!(text.contains("\"repaired_lines\":[{\"axis\":\"row\",\"index\":7,"));
        assert!(text.contains("\"exposure\":{\"saturated_fraction\":0.25,\"dark_fraction\":0.0}"));
        assert_eq!(DetectionsFile::from_json(&text).unwrap(), f);
        // A document written before lines were recorded reads as none repaired.
        let old = DetectionsFile::from_json(
            "{\"schema\":\"nanopush.detections/1\",\"particles\":[],\"tip\":null}",
        )
        .unwrap();
        assert!(old.repaired_lines.is_empty());
        let old_particle = DetectionsFile::from_json(
            "{\"schema\":\"nanopush.detections/1\",\"particles\":[{\"x_px\":1.0,\"y_px\":2.0,\
             \"r_px\":8.0,\"sigma_px\":0.1,\"quality\":9.0}],\"tip\":null}",
        )
        .unwrap();
        assert!(!old_particle.particles[0].edge_clipped && old_particle.particles[0].fitted);
        assert_eq!(old.exposure, Exposure::default());
        assert!(
            DetectionsFile::from_json("{\"schema\":\"x\",\"particles\":[],\"tip\":null}").is_err()
        );
    }
}
