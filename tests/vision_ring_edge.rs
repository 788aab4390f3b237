//! Ring-edge centres (`CentreEstimate::RingEdge`) on the synthetic microscope:
//! on symmetric spheres the setting must not cost accuracy against the profile
//! fit; figures of the raw ring-edge locator are printed beside it.

use nanopush::render::microscope::{RenderSettings, render_frame};
use nanopush::render::microscope_truth::random_scene;
use nanopush::vision::cramer_rao::centre_crb_px;
use nanopush::vision::detect::{DetectSettings, detect_particles};
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
}
