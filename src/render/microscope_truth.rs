//! Ground truth of a synthetic frame ("nanopush.truth/1"), random scenes, and
//! scenes of the layout file a planner writes ("nanopush.layout/1").

use nalgebra::{Matrix2, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Uniform};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::calib::camera_map::CameraCalibration;
use crate::plan::layout::{Layout, UM_PER_M, um_text};

use super::microscope::{ParticleView, SceneView, TipView};

/// Schema tag of truth files.
pub const TRUTH_SCHEMA: &str = "nanopush.truth/1";

/// One particle of the truth file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthParticle {
    pub id: usize,
    pub x_px: f64,
    pub y_px: f64,
    pub r_px: f64,
}

/// The tip of the truth file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthTip {
    pub x_px: f64,
    pub y_px: f64,
    pub angle_deg: f64,
}

/// What was rendered, exactly.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    pub schema: String,
    pub width_px: usize,
    pub height_px: usize,
    pub seed: u64,
    pub snr: f64,
    /// Per-axis centre Cramer-Rao bound for the nominal radius, pixels.
    pub crb_px: Option<f64>,
    pub particles: Vec<TruthParticle>,
    pub tip: Option<TruthTip>,
}

impl Truth {
    /// Truth of a scene.
    pub fn of(scene: &SceneView, seed: u64, snr: f64, crb_px: Option<f64>) -> Self {
        Self {
            schema: TRUTH_SCHEMA.into(),
            width_px: scene.width_px,
            height_px: scene.height_px,
            seed,
            snr,
            crb_px,
            particles: scene
                .particles
                .iter()
                .enumerate()
                .map(|(id, p)| TruthParticle {
                    id,
                    x_px: p.x_px,
                    y_px: p.y_px,
                    r_px: p.radius_px,
                })
                .collect(),
            tip: scene.tip.map(|t| TruthTip {
                x_px: t.apex_x_px,
                y_px: t.apex_y_px,
                angle_deg: t.angle_rad.to_degrees(),
            }),
        }
    }

    /// Parses a truth file, checking its schema.
    pub fn from_json(text: &str) -> Result<Self, SceneFileError> {
        let t: Self = serde_json::from_str(text).map_err(|e| SceneFileError(e.to_string()))?;
        if t.schema != TRUTH_SCHEMA {
            return Err(SceneFileError(format!(
                "schema {:?}, expected {TRUTH_SCHEMA:?}",
                t.schema
            )));
        }
        Ok(t)
    }
}

/// A scene or truth file that cannot be used.
#[derive(Debug, Error, PartialEq)]
#[error("{0}")]
pub struct SceneFileError(pub String);

/// Scene of a layout at `um_per_px`, origin at pixel (0, 0). A layout read
/// from a file was checked as the planner checks it (finite, unique ids,
/// every particle in and narrower than the field), so a mistyped position
/// or radius is refused rather than drawn.
pub fn scene_from_layout(layout: &Layout, um_per_px: f64) -> Result<SceneView, SceneFileError> {
    if !(um_per_px.is_finite() && um_per_px > 0.0) {
        return Err(SceneFileError(format!(
            "pixel size {um_per_px} um must be > 0"
        )));
    }
    let px = |m: f64| m * UM_PER_M / um_per_px;
    let (w, h) = (px(layout.field_m[0]), px(layout.field_m[1]));
    if !(w >= 1.0 && h >= 1.0 && w <= 16384.0 && h <= 16384.0) {
        return Err(SceneFileError(format!(
            "field {} x {} um at {um_per_px} um/px gives {w:.0}x{h:.0} px (1..16384 allowed)",
            layout.field_m[0] * UM_PER_M,
            layout.field_m[1] * UM_PER_M
        )));
    }
    let (width_px, height_px) = (w.round() as usize, h.round() as usize);
    let mut particles = Vec::with_capacity(layout.particles.len());
    for p in &layout.particles {
        let radius_px = px(p.radius_m);
        check_particle_fits(
            &format!("particle {}", p.id),
            radius_px,
            width_px,
            height_px,
        )?;
        particles.push(ParticleView {
            x_px: px(p.centre_m.x),
            y_px: px(p.centre_m.y),
            radius_px,
        });
    }
    Ok(SceneView {
        width_px,
        height_px,
        particles,
        tip: None,
    })
}

/// The calibration of a frame [`scene_from_layout`] drew at `um_per_px`:
/// pixel (x, y), integer at pixel centres, lies at (x, y) times the pixel
/// size in the layout's micrometres, y down as the image's. Without it a
/// user guessed the map, and one with the stage's y up put the particles
/// the field's height off.
pub fn layout_pixel_map(um_per_px: f64) -> CameraCalibration {
    CameraCalibration::affine(
        Matrix2::identity() * (um_per_px / UM_PER_M),
        Vector2::zeros(),
    )
}

/// Refuses a radius that is not finite and positive, or a particle whose
/// image is wider than the frame: rendering and the Cramer-Rao bound work
/// over the whole image, so a mistyped radius would cost minutes for a
/// frame with nothing recognisable in it. `what` names the particle or flag.
pub fn check_particle_fits(
    what: &str,
    radius_px: f64,
    width_px: usize,
    height_px: usize,
) -> Result<(), SceneFileError> {
    if !(radius_px.is_finite() && radius_px > 0.0) {
        return Err(SceneFileError(format!(
            "{what}: radius {radius_px} px must be finite and > 0"
        )));
    }
    if width_px == 0 || height_px == 0 {
        // Said of the frame, not of the particle that would not fit it.
        return Err(SceneFileError(format!(
            "the frame is {width_px}x{height_px} px: it needs at least one pixel a side"
        )));
    }
    if 2.0 * radius_px > width_px.min(height_px) as f64 {
        return Err(SceneFileError(format!(
            "{what}: its image is {} px across, larger than the {width_px}x{height_px} px frame",
            um_text(2.0 * radius_px, 1)
        )));
    }
    Ok(())
}

/// `n` non-overlapping spheres of radius `radius_px` placed at random (seeded),
/// at least one radius from the edges; fewer if the frame is too crowded.
pub fn random_scene(
    n: usize,
    width_px: usize,
    height_px: usize,
    radius_px: f64,
    seed: u64,
) -> SceneView {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let margin = radius_px + 2.0;
    let mut particles: Vec<ParticleView> = Vec::with_capacity(n);
    let (w, h) = (width_px as f64, height_px as f64);
    if w > 2.0 * margin && h > 2.0 * margin {
        let ux = Uniform::new(margin, w - 1.0 - margin).ok();
        let uy = Uniform::new(margin, h - 1.0 - margin).ok();
        if let (Some(ux), Some(uy)) = (ux, uy) {
            let min_d = 2.6 * radius_px;
            for _ in 0..n * 200 {
                if particles.len() == n {
                    break;
                }
                let (x, y) = (ux.sample(&mut rng), uy.sample(&mut rng));
                if particles
                    .iter()
                    .all(|p| (p.x_px - x).powi(2) + (p.y_px - y).powi(2) >= min_d * min_d)
                {
                    particles.push(ParticleView {
                        x_px: x,
                        y_px: y,
                        radius_px,
                    });
                }
            }
        }
    }
    SceneView {
        width_px,
        height_px,
        particles,
        tip: None,
    }
}

/// Adds the tip to a scene.
pub fn with_tip(mut scene: SceneView, tip: TipView) -> SceneView {
    scene.tip = Some(tip);
    scene
}

/// The vision speed benchmark's scene (issue 3's "1024 x 1024, 100
/// particles + tip"): 100 spheres of 8 px (seed 42) and the probe's apex at
/// (600, 500) px, pointing at 0.4 rad. Tests check the detections the
/// benchmark times.
pub fn benchmark_scene() -> SceneView {
    with_tip(
        random_scene(100, 1024, 1024, 8.0, 42),
        TipView {
            apex_x_px: 600.0,
            apex_y_px: 500.0,
            angle_rad: 0.4,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scene of a layout document, read as a file is.
    fn scene_of(text: &str, um_per_px: f64) -> Result<SceneView, SceneFileError> {
        let layout =
            Layout::from_json(text, "layout").map_err(|e| SceneFileError(e.to_string()))?;
        scene_from_layout(&layout, um_per_px)
    }

    #[test]
    fn truth_round_trip_and_layout_parse() {
        let s = random_scene(5, 200, 100, 6.0, 3);
        assert_eq!(s.particles.len(), 5);
        assert_eq!(random_scene(5, 200, 100, 6.0, 3), s);
        let t = Truth::of(&s, 3, 10.0, Some(0.05));
        let text = serde_json::to_string(&t).unwrap();
        assert_eq!(Truth::from_json(&text).unwrap(), t);
        let layout = r#"{"schema":"nanopush.layout/1","field_um":[100,50],
            "particles":[{"id":0,"x_um":10,"y_um":20,"radius_um":5}]}"#;
        let sc = scene_of(layout, 0.5).unwrap();
        assert_eq!((sc.width_px, sc.height_px), (200, 100));
        assert_eq!(sc.particles[0].x_px, 20.0);
        assert!(scene_of(layout, 0.0).is_err());
        assert!(scene_of("{}", 0.5).is_err());
    }

    #[test]
    fn a_layout_the_planner_would_refuse_is_not_drawn() {
        let one = |x: &str, y: &str, r: &str| {
            format!(
                r#"{{"schema":"nanopush.layout/1","field_um":[100,100],
                "particles":[{{"id":4,"x_um":{x},"y_um":{y},"radius_um":{r}}}]}}"#
            )
        };
        let err = |text: &str| scene_of(text, 0.5).unwrap_err().0;
        assert!(err(&one("50", "50", "1e4")).contains("particle 4 radius_um"));
        assert!(err(&one("50", "50", "1e300")).contains("particle 4 radius_um"));
        assert!(err(&one("5000", "-50", "5")).contains("particle 4 at (5000.000, -50.000) um"));
        let twice = one("20", "20", "5").replace(
            r#"}]}"#,
            r#"},{"id":4,"x_um":60,"y_um":60,"radius_um":5}]}"#,
        );
        assert!(
            err(&twice).contains("particle id 4 appears twice"),
            "{}",
            err(&twice)
        );
        // Half the field wide: its image is the whole 200 px frame.
        assert!(scene_of(&one("50", "50", "50"), 0.5).is_ok());
    }

    #[test]
    fn a_particle_wider_than_its_frame_is_named_with_its_size() {
        let e = check_particle_fits("--radius-px", 1e4, 128, 128)
            .unwrap_err()
            .0;
        assert!(
            e.contains(
                "--radius-px: its image is 20000.0 px across, larger than the 128x128 px frame"
            ),
            "{e}"
        );
        for r in [f64::NAN, f64::INFINITY, 0.0, -1.0] {
            let e = check_particle_fits("particle 3", r, 128, 128)
                .unwrap_err()
                .0;
            assert!(
                e.contains("particle 3: radius") && e.contains("finite and > 0"),
                "{e}"
            );
        }
        assert!(check_particle_fits("p", 64.0, 128, 200).is_ok());
    }
}
