//! The synthetic microscope: what the camera sees of a scene of spheres and the
//! probe, with uneven illumination, blur and camera noise. Ground truth for the
//! vision tests and the camera of the simulated rig. Same seed, same frame.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::noise::CameraNoise;
use super::probe::{ProbeShape, ProbeSilhouette};
use super::sphere::{SphereOptics, SphereProfile};
use crate::vision::frame::Frame;

/// One sphere in the view, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ParticleView {
    /// Centre x in pixels.
    pub x_px: f64,
    /// Centre y in pixels.
    pub y_px: f64,
    /// Apparent radius (the dark ring) in pixels.
    pub radius_px: f64,
}

/// The probe in the view: where its apex is and where it points.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TipView {
    /// Apex x in pixels.
    pub apex_x_px: f64,
    /// Apex y in pixels.
    pub apex_y_px: f64,
    /// Direction from the cantilever body to the apex, radians (image axes).
    pub angle_rad: f64,
}

/// What is in front of the camera, in pixels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SceneView {
    /// Frame width in pixels.
    pub width_px: usize,
    /// Frame height in pixels.
    pub height_px: usize,
    /// Spheres.
    pub particles: Vec<ParticleView>,
    /// The probe, if in view.
    pub tip: Option<TipView>,
}

/// How the microscope and camera render; defaults give a clean 16-bit frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// How spheres look (contrast, ring width, defocus, inversion).
    pub optics: SphereOptics,
    /// Probe shape.
    pub probe: ProbeShape,
    /// Gaussian PSF width in pixels.
    pub blur_sigma_px: f64,
    /// Mean photo-electrons per pixel at the brightest background.
    pub background_e: f64,
    /// Relative illumination drop from the frame centre to its corners.
    pub illumination_falloff: f64,
    /// Camera noise, gain and bit depth.
    pub camera: CameraNoise,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self::with_snr(20.0, 16)
    }
}

/// Ways a render request can be invalid.
#[derive(Debug, Error, PartialEq)]
pub enum RenderError {
    /// Zero or absurd frame size.
    #[error("frame size {width}x{height} must be between 1 and 16384 on each side")]
    Size { width: usize, height: usize },
    /// A setting is negative or not finite.
    #[error("render setting {name} = {value} is invalid ({why})")]
    Setting {
        name: &'static str,
        value: f64,
        why: &'static str,
    },
    /// A particle or tip coordinate is not finite, or a radius not positive.
    #[error("scene item {index} has a non-finite position or non-positive radius")]
    Scene { index: usize },
}

/// Highest SNR a frame may be rendered at: far beyond any camera, and below
/// where the background's photon count overflows (about 1e77).
pub const MAX_SNR: f64 = 1e6;

/// Refuses an SNR outside (0, [`MAX_SNR`]], naming the flag it came from.
/// The value is printed as typed where it reads so ("0", "2.5"), in
/// exponent form only where plain digits would run long ("1e300").
pub fn check_snr(flag: &str, snr: f64) -> Result<(), String> {
    if snr > 0.0 && snr <= MAX_SNR {
        return Ok(());
    }
    let plain = snr == 0.0 || (1e-3..1e7).contains(&snr.abs());
    let got = if plain || !snr.is_finite() {
        format!("{snr}")
    } else {
        format!("{snr:e}")
    };
    Err(format!(
        "{flag} must be > 0 and at most {MAX_SNR:e}, got {got}"
    ))
}

impl RenderSettings {
    /// Settings whose ring signal-to-noise ratio is `snr`: the in-focus ring
    /// depth over the background noise, both in electrons. Gain puts the
    /// background at 40 % of full scale whatever the bit depth.
    pub fn with_snr(snr: f64, bit_depth: u8) -> Self {
        let optics = SphereOptics::default();
        let read = 2.0;
        let c = optics.ring_contrast;
        let s2 = snr * snr;
        let background_e = (s2 + (s2 * s2 + 4.0 * c * c * s2 * read * read).sqrt()) / (2.0 * c * c);
        let max = ((1u32 << bit_depth.clamp(1, 16)) - 1) as f64;
        let offset = if bit_depth > 8 { 100.0 } else { 5.0 };
        Self {
            optics,
            probe: ProbeShape::default(),
            blur_sigma_px: 0.8,
            background_e,
            illumination_falloff: 0.15,
            camera: CameraNoise {
                read_noise_e: read,
                gain_counts_per_e: 0.4 * max / background_e,
                offset_counts: offset,
                bit_depth,
            },
        }
    }

    /// The ring SNR these settings give (see [`RenderSettings::with_snr`]).
    pub fn snr(&self) -> f64 {
        let b = self.background_e;
        self.optics.ring_contrast * b / (b + self.camera.read_noise_e.powi(2)).sqrt()
    }

    fn validate(&self) -> Result<(), RenderError> {
        let checks = [
            ("blur_sigma_px", self.blur_sigma_px),
            ("background_e", self.background_e),
            ("illumination_falloff", self.illumination_falloff),
            ("read_noise_e", self.camera.read_noise_e),
            ("gain_counts_per_e", self.camera.gain_counts_per_e),
            ("offset_counts", self.camera.offset_counts),
            ("defocus_px", self.optics.defocus_px),
            ("probe.width_px", self.probe.width_px),
            ("probe.taper_length_px", self.probe.taper_length_px),
        ];
        for (name, value) in checks {
            if !value.is_finite() || value < 0.0 {
                return Err(RenderError::Setting {
                    name,
                    value,
                    why: "must be finite and >= 0",
                });
            }
        }
        if !(1..=16).contains(&self.camera.bit_depth) {
            return Err(RenderError::Setting {
                name: "bit_depth",
                value: self.camera.bit_depth as f64,
                why: "must be 1..=16",
            });
        }
        Ok(())
    }

    /// The Gaussian width of a blurred straight edge (PSF + pixel box).
    pub fn edge_sigma_px(&self) -> f64 {
        (self.blur_sigma_px.powi(2) + self.optics.defocus_px.powi(2) + 1.0 / 12.0).sqrt()
    }
}

/// Mean photo-electrons per pixel, noise-free (row-major). The CRB and tests use it.
pub fn expected_electrons(
    scene: &SceneView,
    settings: &RenderSettings,
) -> Result<Vec<f64>, RenderError> {
    let (w, h) = (scene.width_px, scene.height_px);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(RenderError::Size {
            width: w,
            height: h,
        });
    }
    settings.validate()?;
    for (index, p) in scene.particles.iter().enumerate() {
        if !(p.x_px.is_finite()
            && p.y_px.is_finite()
            && p.radius_px.is_finite()
            && p.radius_px > 0.0)
        {
            return Err(RenderError::Scene { index });
        }
    }
    if let Some(t) = scene.tip
        && !(t.apex_x_px.is_finite() && t.apex_y_px.is_finite() && t.angle_rad.is_finite())
    {
        return Err(RenderError::Scene {
            index: scene.particles.len(),
        });
    }
    // Illumination: quadratic fall-off from the centre, tilted slightly.
    let (cx, cy) = (0.5 * (w as f64 - 1.0), 0.5 * (h as f64 - 1.0));
    let r2max = cx * cx + cy * cy + 1e-9;
    let mut modulation = vec![0.0f64; w * h];
    for p in &scene.particles {
        let prof = SphereProfile::new(
            p.x_px,
            p.y_px,
            p.radius_px,
            &settings.optics,
            settings.blur_sigma_px,
        );
        let s = prof.support_px();
        let x0 = ((p.x_px - s).floor().max(0.0)) as usize;
        let x1 = ((p.x_px + s).ceil().min(w as f64 - 1.0)).max(-1.0) as isize;
        let y0 = ((p.y_px - s).floor().max(0.0)) as usize;
        let y1 = ((p.y_px + s).ceil().min(h as f64 - 1.0)).max(-1.0) as isize;
        for y in y0 as isize..=y1 {
            for x in x0 as isize..=x1 {
                modulation[y as usize * w + x as usize] += prof.modulation(x as f64, y as f64);
            }
        }
    }
    let probe = scene.tip.map(|t| ProbeSilhouette {
        apex_x_px: t.apex_x_px,
        apex_y_px: t.apex_y_px,
        angle_rad: t.angle_rad,
        shape: settings.probe,
    });
    let edge = settings.edge_sigma_px();
    let mut out = vec![0.0f64; w * h];
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f64 - cx, y as f64 - cy);
            let illum = 1.0 - settings.illumination_falloff * (dx * dx + dy * dy) / r2max;
            let transmit = probe.map_or(1.0, |p| p.transmission(x as f64, y as f64, edge));
            let i = y * w + x;
            out[i] = (settings.background_e * illum * transmit * (1.0 + modulation[i])).max(0.0);
        }
    }
    Ok(out)
}

/// Renders one noisy camera frame of `scene`; the same seed gives the same frame.
pub fn render_frame(
    scene: &SceneView,
    settings: &RenderSettings,
    seed: u64,
) -> Result<Frame, RenderError> {
    let mean = expected_electrons(scene, settings)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let pixels: Vec<f32> = mean
        .iter()
        .map(|&m| settings.camera.sample(m, &mut rng))
        .collect();
    Frame::new(
        scene.width_px,
        scene.height_px,
        pixels,
        settings.camera.bit_depth,
    )
    .map_err(|_| RenderError::Size {
        width: scene.width_px,
        height: scene.height_px,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> SceneView {
        SceneView {
            width_px: 64,
            height_px: 48,
            particles: vec![ParticleView {
                x_px: 20.3,
                y_px: 24.7,
                radius_px: 8.0,
            }],
            tip: Some(TipView {
                apex_x_px: 50.0,
                apex_y_px: 20.0,
                angle_rad: 0.3,
            }),
        }
    }

    #[test]
    fn same_seed_same_frame_other_seed_other_frame() {
        let s = RenderSettings::with_snr(10.0, 16);
        let a = render_frame(&scene(), &s, 7).unwrap();
        let b = render_frame(&scene(), &s, 7).unwrap();
        let c = render_frame(&scene(), &s, 8).unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn snr_setting_round_trips_and_fits_bit_depth() {
        for bits in [8u8, 16] {
            let s = RenderSettings::with_snr(6.0, bits);
            assert!((s.snr() - 6.0).abs() < 1e-9);
            let f = render_frame(&scene(), &s, 1).unwrap();
            let max = f.pixels().iter().cloned().fold(0.0f32, f32::max);
            assert!(max < f.max_count(), "saturated at {bits} bits");
        }
    }

    #[test]
    fn bad_settings_and_scenes_are_errors() {
        let s = RenderSettings {
            blur_sigma_px: f64::NAN,
            ..RenderSettings::default()
        };
        assert!(matches!(
            render_frame(&scene(), &s, 1),
            Err(RenderError::Setting { .. })
        ));
        let mut sc = scene();
        sc.particles[0].radius_px = 0.0;
        assert_eq!(
            render_frame(&sc, &RenderSettings::default(), 1),
            Err(RenderError::Scene { index: 0 })
        );
        sc.width_px = 0;
        assert!(matches!(
            render_frame(&sc, &RenderSettings::default(), 1),
            Err(RenderError::Size { .. })
        ));
    }
}
