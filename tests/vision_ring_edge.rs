//! Ring-edge centres (`CentreEstimate::RingEdge`) on the synthetic microscope:
//! on symmetric spheres the setting must not cost accuracy against the profile
//! fit (figures of the raw ring-edge locator are printed beside it); on
//! asymmetric spheres (core off the outline's centre) it must find the
//! outline's centre.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use nanopush::render::microscope::{RenderSettings, render_frame};
use nanopush::render::microscope_truth::random_scene;
use nanopush::vision::cramer_rao::centre_crb_px;
use nanopush::vision::detect::{DetectSettings, detect_particles};
use nanopush::vision::frame::Frame;
use nanopush::vision::matching::match_points;
use nanopush::vision::noise::estimate_noise_sigma;
use nanopush::vision::ring_edge::{
    CentreEstimate, RingEdgeOutcome, recentre_on_ring_edges, ring_edge_centre,
};

const RADIUS: f64 = 8.0;

/// SNR 8, 1024x1024 16-bit, 100 symmetric spheres (the acceptance frame of
/// tests/vision_synthetic.rs): the RingEdge setting's centre RMS within 10 %
/// of the profile fit's.
#[test]
fn ring_edge_setting_keeps_the_profile_accuracy_on_symmetric_spheres_at_snr_8() {
    let seed = 12;
    let scene = random_scene(100, 1024, 1024, RADIUS, seed);
    let render = RenderSettings::with_snr(8.0, 16);
    let frame = render_frame(&scene, &render, seed).unwrap();
    let truth: Vec<[f64; 2]> = scene.particles.iter().map(|p| [p.x_px, p.y_px]).collect();
    let settings = |centre| DetectSettings {
        diameter_px: 2.0 * RADIUS + 1.0,
        centre,
        ..DetectSettings::default()
    };
    let profile = detect_particles(&frame, &settings(CentreEstimate::Profile)).unwrap();
    let ring = detect_particles(&frame, &settings(CentreEstimate::RingEdge)).unwrap();
    let rms = |found: &[nanopush::vision::detect::Detection]| {
        let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
        let m = match_points(&truth, &pts, RADIUS);
        assert!(m.recall() >= 0.99, "recall {}", m.recall());
        m.rms_per_axis()
    };
    // The raw ring-edge locator on every profile detection, for the record.
    let noise = estimate_noise_sigma(&frame);
    let raw: Vec<_> = profile
        .iter()
        .filter_map(|d| ring_edge_centre(&frame, d.x_px, d.y_px, d.r_px, &[], noise).ok())
        .collect();
    let raw_pts: Vec<[f64; 2]> = raw.iter().map(|f| [f.x_px, f.y_px]).collect();
    let raw_m = match_points(&truth, &raw_pts, RADIUS);
    let raw_sigma = raw.iter().map(|f| f.sigma_px).sum::<f64>() / raw.len() as f64;
    let mut moved = profile.clone();
    let outcomes = recentre_on_ring_edges(&frame, &mut moved, noise);
    let recentred = outcomes
        .iter()
        .filter(|o| matches!(o, RingEdgeOutcome::Recentred { .. }))
        .count();
    let (rms_p, rms_r) = (rms(&profile), rms(&ring));
    let crb = centre_crb_px(RADIUS, &render).unwrap();
    println!(
        "SNR 8: profile RMS {rms_p:.4} px, ring-edge setting RMS {rms_r:.4} px (ratio {:.3}), \
         CRB {crb:.4} px; raw ring-edge locator RMS {:.4} px on {} particles, mean reported \
         sigma {raw_sigma:.4} px; recentred {recentred} of {}",
        rms_r / rms_p,
        raw_m.rms_per_axis(),
        raw.len(),
        outcomes.len()
    );
    assert!(rms_r <= 1.1 * rms_p, "RMS {rms_r} vs profile {rms_p}");
    // The selection rests on the ring-edge sigma being honest.
    assert!(
        (raw_sigma / raw_m.rms_per_axis() - 1.0).abs() < 0.3,
        "ring-edge sigma {raw_sigma} vs RMS {}",
        raw_m.rms_per_axis()
    );
}

/// A 256x256 16-bit frame of 9 asymmetric spheres (outline radius 8.5 px at
/// known centres, bright core 1 px off the outline's centre in a different
/// direction for each, the dark ring broader on the side away from the core,
/// as under oblique light), Gaussian noise 10 counts on 1000 (ring depth
/// 400: SNR 40, about the real fixtures' 33).
fn asymmetric_frame(seed: u64) -> (Frame, Vec<[f64; 2]>) {
    let size = 256;
    let centres: Vec<[f64; 2]> = (0..9)
        .map(|k| {
            let (i, j) = ((k % 3) as f64, (k / 3) as f64);
            [
                48.0 + 80.0 * i + 0.13 * k as f64,
                48.0 + 80.0 * j - 0.29 * k as f64,
            ]
        })
        .collect();
    let directions: Vec<f64> = (0..9).map(|k| (40.0 * k as f64).to_radians()).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 10.0).unwrap();
    let pixels = (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f64, (i / size) as f64);
            let mut v = 1000.0;
            for (c, &t) in centres.iter().zip(&directions) {
                let (dx, dy) = (x - c[0], y - c[1]);
                let r = dx.hypot(dy);
                if r > 20.0 {
                    continue;
                }
                let (ux, uy) = (t.cos(), t.sin());
                let away = if r > 0.0 {
                    -(dx * ux + dy * uy) / r
                } else {
                    0.0
                };
                let width = 1.2 + 0.8 * away.max(0.0);
                let ring = 400.0 * (-0.5 * ((r - 8.5) / width).powi(2)).exp();
                let core_r2 = (dx - ux).powi(2) + (dy - uy).powi(2);
                let core = 600.0 * (-0.5 * core_r2 / 3.8f64.powi(2)).exp();
                v += core - ring;
            }
            (v + noise.sample(&mut rng)).clamp(0.0, 65535.0) as f32
        })
        .collect();
    (Frame::new(size, size, pixels, 16).unwrap(), centres)
}

/// Asymmetric spheres: the profile centre is pulled towards the core, the
/// RingEdge setting reports the outline's centre.
#[test]
fn ring_edge_setting_finds_the_outline_centre_of_asymmetric_spheres() {
    for seed in [1, 2] {
        let (frame, truth) = asymmetric_frame(seed);
        let settings = |centre| DetectSettings {
            diameter_px: 17.0,
            centre,
            ..DetectSettings::default()
        };
        let worst = |centre| {
            let found = detect_particles(&frame, &settings(centre)).unwrap();
            let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
            let m = match_points(&truth, &pts, 4.0);
            assert_eq!(
                (found.len(), m.pairs.len()),
                (9, 9),
                "seed {seed} {centre:?}"
            );
            m.pairs.iter().map(|p| p.2.hypot(p.3)).fold(0.0, f64::max)
        };
        let (profile, ring) = (
            worst(CentreEstimate::Profile),
            worst(CentreEstimate::RingEdge),
        );
        println!(
            "seed {seed}: worst distance from the outline centre: profile {profile:.3} px, \
             ring edge {ring:.3} px"
        );
        assert!(profile > 0.2, "profile {profile}");
        assert!(ring < 0.1, "ring edge {ring}");
    }
}

/// Frames with nothing to find give nothing, with the RingEdge setting too.
#[test]
fn ring_edge_setting_on_empty_black_and_saturated_frames_finds_nothing() {
    let settings = DetectSettings {
        centre: CentreEstimate::RingEdge,
        ..DetectSettings::default()
    };
    for value in [0.0f32, 1000.0, 65535.0] {
        let frame = Frame::new(128, 128, vec![value; 128 * 128], 16).unwrap();
        assert!(
            detect_particles(&frame, &settings).unwrap().is_empty(),
            "{value}"
        );
    }
}
