//! Touching particles, as an assembled pattern has them: every sphere of a
//! letter-like cluster (rows and an L-corner at pitch = diameter + gap) is found,
//! each near its true centre, at the simulated rig's size (20 px radius) and at
//! the acceptance tests' size (8 px).
//!
//! Touching costs accuracy: a one-sphere fit on a window cut at the bisector still
//! sees the neighbour's blurred edge. Measured worst bias 0.27 px (20 px radius, 2 px
//! gap) and 0.36 px (8 px radius, touching); the bound below is 0.5 px, which at the
//! simulated rig's 0.25 um/px is 125 nm, inside the 200 nm placement budget.

use nanopush::render::microscope::{ParticleView, RenderSettings, SceneView, render_frame};
use nanopush::vision::detect::{DetectSettings, detect_particles};
use nanopush::vision::matching::match_points;

/// An L of touching spheres: a column of 5 and a row of 3 sharing the corner.
fn l_cluster(radius: f64, gap: f64, size: usize) -> SceneView {
    let pitch = 2.0 * radius + gap;
    let (x0, y0) = (size as f64 * 0.3, size as f64 * 0.2);
    let mut particles: Vec<ParticleView> = (0..5)
        .map(|k| ParticleView {
            x_px: x0,
            y_px: y0 + k as f64 * pitch,
            radius_px: radius,
        })
        .collect();
    particles.extend((1..3).map(|k| ParticleView {
        x_px: x0 + k as f64 * pitch,
        y_px: y0 + 4.0 * pitch,
        radius_px: radius,
    }));
    // A loose particle next to the corner, almost touching.
    particles.push(ParticleView {
        x_px: x0 + pitch + 0.3,
        y_px: y0 + 2.9 * pitch,
        radius_px: radius,
    });
    SceneView {
        width_px: size,
        height_px: size,
        particles,
        tip: None,
    }
}

fn found_all_near_truth(radius: f64, gap: f64, size: usize) {
    let scene = l_cluster(radius, gap, size);
    let frame = render_frame(&scene, &RenderSettings::with_snr(20.0, 16), 5).unwrap();
    let settings = DetectSettings {
        diameter_px: 2.0 * radius,
        ..DetectSettings::default()
    };
    let found = detect_particles(&frame, &settings).unwrap();
    let truth: Vec<[f64; 2]> = scene.particles.iter().map(|p| [p.x_px, p.y_px]).collect();
    let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
    let m = match_points(&truth, &pts, radius);
    assert_eq!(
        found.len(),
        truth.len(),
        "radius {radius} px, gap {gap} px: found {pts:?}"
    );
    assert_eq!(m.pairs.len(), truth.len(), "radius {radius}, gap {gap}");
    for &(_, _, dx, dy) in &m.pairs {
        assert!(
            dx.hypot(dy) < 0.5,
            "radius {radius}, gap {gap}: centre off by {:.3} px",
            dx.hypot(dy)
        );
    }
}

#[test]
fn touching_spheres_at_the_sim_rig_size_are_each_found() {
    for gap in [0.0, 2.0] {
        found_all_near_truth(20.0, gap, 400);
    }
}

#[test]
fn touching_spheres_at_the_acceptance_size_are_each_found() {
    for gap in [0.0, 1.0] {
        found_all_near_truth(8.0, gap, 200);
    }
}
