//! Tip detection on synthetic frames: random positions and angles, over a
//! particle, and out of focus.

use nanopush::render::microscope::{
    ParticleView, RenderSettings, SceneView, TipView, render_frame,
};
use nanopush::vision::frame::Frame;
use nanopush::vision::tip::{TipSettings, detect_tip};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Uniform};

fn errors(defocus_px: f64, seed: u64, n: usize) -> (Vec<f64>, Vec<f64>) {
    errors_at_gain(defocus_px, 1.0, seed, n)
}

fn errors_at_gain(defocus_px: f64, gain: f64, seed: u64, n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let pos = Uniform::new(90.0, 166.0).unwrap();
    let ang = Uniform::new(-std::f64::consts::PI, std::f64::consts::PI).unwrap();
    let (mut apex, mut angle) = (Vec::new(), Vec::new());
    for k in 0..n {
        let tip = TipView {
            apex_x_px: pos.sample(&mut rng),
            apex_y_px: pos.sample(&mut rng),
            angle_rad: ang.sample(&mut rng),
        };
        // Every other frame: a particle right under the apex.
        let particles = if k % 2 == 0 {
            vec![ParticleView {
                x_px: tip.apex_x_px + 3.0,
                y_px: tip.apex_y_px - 2.0,
                radius_px: 8.0,
            }]
        } else {
            vec![ParticleView {
                x_px: 40.0,
                y_px: 40.0,
                radius_px: 8.0,
            }]
        };
        let scene = SceneView {
            width_px: 256,
            height_px: 256,
            particles,
            tip: Some(tip),
        };
        let mut settings = RenderSettings::with_snr(20.0, 16);
        settings.optics.defocus_px = defocus_px;
        settings.camera.gain_counts_per_e *= gain;
        let frame = render_frame(&scene, &settings, seed * 100 + k as u64).unwrap();
        let t = detect_tip(&frame, &TipSettings::default()).expect("tip found");
        apex.push(((t.x_px - tip.apex_x_px).powi(2) + (t.y_px - tip.apex_y_px).powi(2)).sqrt());
        let mut da = (t.angle_rad - tip.angle_rad).to_degrees();
        da = (da + 180.0).rem_euclid(360.0) - 180.0;
        angle.push(da.abs());
    }
    (apex, angle)
}

fn check(label: &str, apex: &[f64], angle: &[f64]) {
    let mut a = apex.to_vec();
    a.sort_by(f64::total_cmp);
    let median = a[a.len() / 2];
    let worst = a[a.len() - 1];
    let worst_angle = angle.iter().cloned().fold(0.0, f64::max);
    println!(
        "{label}: apex median {median:.3} px, worst {worst:.3} px, worst angle {worst_angle:.3} deg"
    );
    assert!(median <= 0.5, "{label}: median {median}");
    assert!(worst <= 2.0, "{label}: worst {worst}");
    assert!(worst_angle <= 1.0, "{label}: angle {worst_angle}");
}

#[test]
fn tip_apex_and_angle_in_focus_also_over_a_particle() {
    let (apex, angle) = errors(0.0, 1, 8);
    check("in focus", &apex, &angle);
}

#[test]
fn tip_apex_and_angle_out_of_focus() {
    let (apex, angle) = errors(2.5, 2, 6);
    check("defocus 2.5 px", &apex, &angle);
}

#[test]
fn no_tip_in_a_frame_without_probe() {
    let scene = SceneView {
        width_px: 200,
        height_px: 200,
        particles: vec![ParticleView {
            x_px: 100.0,
            y_px: 100.0,
            radius_px: 8.0,
        }],
        tip: None,
    };
    let frame = render_frame(&scene, &RenderSettings::with_snr(20.0, 16), 4).unwrap();
    assert_eq!(detect_tip(&frame, &TipSettings::default()), None);
}

/// Large particles of inverted contrast (dark discs of 30 px radius) are
/// not the probe: it comes into the frame from an edge, and they do not
/// reach one. Before, each such disc (2,800 px, over the 400 px a dark
/// region needs) was reported as the tip on 10 of 10 synthetic frames.
#[test]
fn large_dark_particles_are_not_the_probe() {
    let particles = [(60.0, 70.0), (150.0, 140.0), (190.0, 60.0)]
        .map(|(x_px, y_px)| ParticleView {
            x_px,
            y_px,
            radius_px: 30.0,
        })
        .to_vec();
    let scene = SceneView {
        width_px: 256,
        height_px: 256,
        particles,
        tip: None,
    };
    let mut settings = RenderSettings::with_snr(20.0, 16);
    settings.optics.inverted = true;
    for seed in 0..3 {
        let frame = render_frame(&scene, &settings, seed).unwrap();
        assert_eq!(
            detect_tip(&frame, &TipSettings::default()),
            None,
            "seed {seed}"
        );
    }
}

/// The speed benchmark's frame (100 spheres and the probe, SNR 10): every
/// particle found beside the probe lies as near its true centre as those far
/// from it. A ring fit on the square window around a particle 7 px from the
/// probe's shaft took the shaft's edge in the window's corner for the core
/// and put the centre 0.57 px off; the fit's window is now the disc that
/// the ring model needs (worst 0.08 px).
#[test]
fn particles_beside_the_probe_are_located_as_well_as_the_others() {
    use nanopush::render::microscope_truth::benchmark_scene;
    use nanopush::vision::analyse::analyse_frame;
    use nanopush::vision::detect::DetectSettings;
    use nanopush::vision::matching::match_points;
    let scene = benchmark_scene();
    let frame = render_frame(&scene, &RenderSettings::with_snr(10.0, 16), 42).unwrap();
    let seen = analyse_frame(
        &frame,
        &DetectSettings::default(),
        Some(&TipSettings::default()),
    )
    .unwrap();
    let truth: Vec<[f64; 2]> = scene.particles.iter().map(|p| [p.x_px, p.y_px]).collect();
    let found: Vec<[f64; 2]> = seen.particles.iter().map(|d| [d.x_px, d.y_px]).collect();
    let m = match_points(&truth, &found, 4.0);
    assert_eq!(m.pairs.len(), found.len(), "a detection matches no sphere");
    // The probe hides a few spheres; the rest are found.
    assert!(found.len() >= 90, "{} of 100 found", found.len());
    let worst = m
        .pairs
        .iter()
        .map(|&(_, _, dx, dy)| dx.hypot(dy))
        .fold(0.0, f64::max);
    eprintln!("{} found, worst centre error {worst:.3} px", found.len());
    // SNR 10, 8 px spheres: the CRB is about 0.03 px; 5 sigma is 0.15 px.
    assert!(worst < 0.15, "worst centre error {worst:.3} px");
}

/// The frame with its contrast about the background (the median) halved:
/// a bright-field probe seen through a thin cantilever.
fn half_contrast(frame: &Frame) -> Frame {
    let mut sorted = frame.pixels().to_vec();
    sorted.sort_by(f32::total_cmp);
    let background = sorted[sorted.len() / 2];
    let px = (frame.pixels().iter())
        .map(|&v| (background + 0.5 * (v - background)).round())
        .collect();
    Frame::new(frame.width(), frame.height(), px, frame.bit_depth()).unwrap()
}

/// A camera's dead pixel (0 counts) must not hide a probe of low contrast
/// (half the background: a bright-field probe seen through a thin
/// cantilever): the dark-region threshold starts from the darkest level.
#[test]
fn a_dead_pixel_does_not_hide_a_low_contrast_probe() {
    let tip = TipView {
        apex_x_px: 128.0,
        apex_y_px: 120.0,
        angle_rad: 0.7,
    };
    let scene = SceneView {
        width_px: 256,
        height_px: 256,
        particles: vec![],
        tip: Some(tip),
    };
    let frame = render_frame(&scene, &RenderSettings::with_snr(20.0, 8), 3).unwrap();
    let low = half_contrast(&frame).pixels().to_vec();
    let mut dead = low.clone();
    dead[5 * 256 + 250] = 0.0;
    for (name, px) in [
        ("low contrast", low),
        ("low contrast, one dead pixel", dead),
    ] {
        let f = Frame::new(256, 256, px, 8).unwrap();
        let t = detect_tip(&f, &TipSettings::default())
            .unwrap_or_else(|| panic!("{name}: no tip found"));
        let err = (t.x_px - tip.apex_x_px).hypot(t.y_px - tip.apex_y_px);
        println!("{name}: apex error {err:.3} px");
        assert!(err < 1.0, "{name}: apex error {err} px");
    }
}

/// A probe lying along a pixel diagonal (45, 135, 225, 315 degrees: how a
/// cantilever is often mounted) must be found as any other: the rough
/// width from the dark region's pixel counts came out 1/sqrt(2) of the
/// probe's there, and the fit diverged (9 of these 12 frames gave "no tip").
#[test]
fn a_probe_along_a_pixel_diagonal_is_found() {
    let mut worst: f64 = 0.0;
    for angle_deg in [45.0f64, 135.0, 225.0, 315.0] {
        for (k, (x, y)) in [(256.0, 256.0), (200.3, 300.7), (310.0, 190.5)]
            .into_iter()
            .enumerate()
        {
            let tip = TipView {
                apex_x_px: x,
                apex_y_px: y,
                angle_rad: angle_deg.to_radians(),
            };
            let scene = SceneView {
                width_px: 512,
                height_px: 512,
                particles: vec![],
                tip: Some(tip),
            };
            let seed = angle_deg as u64 * 2 + k as u64;
            let frame = render_frame(&scene, &RenderSettings::with_snr(20.0, 16), seed).unwrap();
            let t = detect_tip(&frame, &TipSettings::default())
                .unwrap_or_else(|| panic!("{angle_deg} deg at ({x}, {y}): no tip found"));
            let err = (t.x_px - x).hypot(t.y_px - y);
            let mut da = (t.angle_rad.to_degrees() - angle_deg + 180.0).rem_euclid(360.0) - 180.0;
            da = da.abs();
            assert!(
                err < 0.5 && da < 0.5,
                "{angle_deg} deg at ({x}, {y}): apex {err} px, angle {da} deg"
            );
            worst = worst.max(err);
        }
    }
    println!("probe along a pixel diagonal: worst apex error {worst:.3} px");
}

/// An over-exposed camera: at 2.7x, 3x and 4x the gain the background
/// clips (67 %, 93 % and 93 % of the frame at the full count; 8 frames
/// each, probes at random places and angles, every other one over a
/// particle). The model is the camera's mean of a clipped noisy value, so
/// the apex stays put: medians 0.107, 0.126 and 0.239 px, worst 0.37, 0.42
/// and 0.75 px. Before the model clipped: medians 0.321, 0.671 and 1.484
/// px, worst 0.58, 0.91 and 1.71 px (the edge bent to meet the flat
/// clipped level); clipped without the noise (min(f, full count)): worst
/// 0.575 px at 2.7x, where the background sits at the clip level. Gains
/// up to 2.2x give the same apexes as 1x.
#[test]
fn an_over_exposed_probe_keeps_its_apex() {
    for (gain, max_median, max_worst) in [(2.7, 0.2, 0.45), (3.0, 0.2, 0.6), (4.0, 0.35, 1.0)] {
        let (apex, angle) = errors_at_gain(0.0, gain, 1, 8);
        let mut a = apex.clone();
        a.sort_by(f64::total_cmp);
        let (median, worst) = (a[a.len() / 2], a[a.len() - 1]);
        let worst_angle = angle.iter().copied().fold(0.0, f64::max);
        println!(
            "gain {gain}x: apex median {median:.3} px, worst {worst:.3} px, worst angle {worst_angle:.3} deg"
        );
        assert!(median <= max_median, "gain {gain}x: median {median} px");
        assert!(worst <= max_worst, "gain {gain}x: worst {worst} px");
        assert!(worst_angle <= 1.0, "gain {gain}x: angle {worst_angle} deg");
    }
}

/// A probe that comes into the frame only a little, pointing down from
/// the top edge with its body beyond it and its apex 20-30 px inside, is
/// found within half a pixel on most frames: 31 of 36 here (12 noise
/// seeds each at 20, 25 and 30 px). Before, on none: the visible piece was
/// below the 400 px a dark region needed, and where it was not, the
/// reweighted fit failed and took the whole tip with it. A probe crossing
/// the frame with its apex beyond the edge is not a tip in view.
#[test]
fn a_probe_barely_in_the_frame_is_found_and_one_beyond_it_is_not() {
    let frame_of = |y: f64, seed: u64| {
        let tip = TipView {
            apex_x_px: 120.3,
            apex_y_px: y,
            angle_rad: 90f64.to_radians(),
        };
        let scene = SceneView {
            width_px: 240,
            height_px: 200,
            particles: vec![],
            tip: Some(tip),
        };
        render_frame(&scene, &RenderSettings::with_snr(20.0, 16), seed).unwrap()
    };
    let mut found = 0;
    for y in [20.0, 25.0, 30.0] {
        for seed in 0..12 {
            let t = detect_tip(&frame_of(y, seed), &TipSettings::default());
            found += usize::from(t.is_some_and(|t| (t.x_px - 120.3).hypot(t.y_px - y) < 0.5));
        }
    }
    println!("probe barely in the frame: {found} of 36 found within 0.5 px");
    assert!(found >= 27, "{found} of 36");
    // The apex 40 px above the frame: only the taper crosses its top.
    assert!(detect_tip(&frame_of(-40.0, 7), &TipSettings::default()).is_none());
}

/// The frame under soft dark dirt (out-of-focus dust on the optics): a disc
/// centred at (x, y) of radius r taking `depth` of the light at its centre,
/// its edge a logistic of a quarter of r.
fn under_dirt(frame: &Frame, (x0, y0, r, depth): (f64, f64, f64, f64)) -> Frame {
    let w = frame.width();
    let px = (frame.pixels().iter().enumerate())
        .map(|(i, &v)| {
            let d = ((i % w) as f64 - x0).hypot((i / w) as f64 - y0);
            let transmitted = 1.0 - depth / (1.0 + ((d - r) / (0.25 * r)).exp());
            (f64::from(v) * transmitted).round() as f32
        })
        .collect();
    Frame::new(w, frame.height(), px, frame.bit_depth()).unwrap()
}

/// The whole frame blurred by a Gaussian of `sigma` px (out of focus), the
/// edges extended.
fn out_of_focus(frame: &Frame, sigma: f64) -> Frame {
    let (w, h) = (frame.width(), frame.height());
    let reach = (3.0 * sigma).ceil() as usize;
    let kernel: Vec<f64> = (0..=2 * reach)
        .map(|i| (-0.5 * ((i as f64 - reach as f64) / sigma).powi(2)).exp())
        .collect();
    let total: f64 = kernel.iter().sum();
    // One pass along x (step 1) or y (step w) over a buffer of w x h.
    let pass = |src: &[f64], along_x: bool| -> Vec<f64> {
        let mut out = vec![0.0; w * h];
        for (i, o) in out.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            let (at, n) = if along_x { (x, w) } else { (y, h) };
            *o = (kernel.iter().enumerate())
                .map(|(k, kv)| {
                    let j = (at + k).saturating_sub(reach).min(n - 1);
                    kv * src[if along_x { y * w + j } else { j * w + x }]
                })
                .sum::<f64>()
                / total;
        }
        out
    };
    let src: Vec<f64> = frame.pixels().iter().map(|&v| f64::from(v)).collect();
    let px = pass(&pass(&src, true), false);
    Frame::new(
        w,
        h,
        px.iter().map(|&v| v.round() as f32).collect(),
        frame.bit_depth(),
    )
    .unwrap()
}

/// Soft dark shapes at the frame's edge are not the probe (2026-11-30):
/// dirt cut by the edge, sharp or not, and the shaded corners of a frame
/// out of focus (sigma 3 and 6 px) each gave a tip on these 12 probe-free
/// frames, scores 0.58-0.93. A fit is a probe's only with its apex sharper
/// than its blur, an occluder's opacity and its apex where the dark region
/// ends (`tip.rs`, `probe_like`): no tip on any of them now, while the same
/// frames with the probe in view, at full and at half the contrast, give
/// its apex within 0.07 px under the dirt, and 2.0 and 6.0 px off out of
/// focus at 3 and 6 px (the blurred apex's bias, the same before).
#[test]
fn soft_dark_shapes_at_the_edge_are_not_the_probe() {
    let particles = (0..20)
        .map(|i| ParticleView {
            x_px: f64::from(20 + (i * 97) % 220),
            y_px: f64::from(20 + (i * 53) % 220),
            radius_px: 8.0,
        })
        .collect();
    let tip = TipView {
        apex_x_px: 140.0,
        apex_y_px: 110.0,
        angle_rad: 0.6,
    };
    // Illumination falloff, what is done to the rendered frame, and how
    // near the probe's apex must be found (blurs of 3 and 6 px move the
    // fitted apex 2.0 and 6.0 px, as they did before).
    type Change = fn(&Frame) -> Frame;
    let cases: [(f64, &str, Change, f64); 4] = [
        (
            0.15,
            "dirt cut by the bottom edge",
            |f| under_dirt(f, (130.0, 262.0, 40.0, 0.6)),
            2.0,
        ),
        (
            0.15,
            "dirt cut by the left edge",
            |f| under_dirt(f, (-5.0, 40.0, 35.0, 0.4)),
            2.0,
        ),
        (
            0.15,
            "out of focus, sigma 6 px",
            |f| out_of_focus(f, 6.0),
            8.0,
        ),
        (
            0.3,
            "shaded, out of focus, sigma 3 px",
            |f| out_of_focus(f, 3.0),
            2.0,
        ),
    ];
    let mut worst: f64 = 0.0;
    for (falloff, name, change, tolerance) in cases {
        let mut settings = RenderSettings::with_snr(20.0, 16);
        settings.illumination_falloff = falloff;
        for seed in 0..3 {
            let render = |tip| {
                let scene = SceneView {
                    width_px: 256,
                    height_px: 256,
                    particles: Vec::clone(&particles),
                    tip,
                };
                change(&render_frame(&scene, &settings, seed).unwrap())
            };
            let found = detect_tip(&render(None), &TipSettings::default());
            assert_eq!(found, None, "{name}, seed {seed}: a tip without a probe");
            let with_probe = render(Some(tip));
            let half = half_contrast(&with_probe);
            for (how, frame) in [("", with_probe), (", half contrast", half)] {
                let t = detect_tip(&frame, &TipSettings::default())
                    .unwrap_or_else(|| panic!("{name}{how}, seed {seed}: no tip"));
                let err = (t.x_px - tip.apex_x_px).hypot(t.y_px - tip.apex_y_px);
                assert!(
                    err <= tolerance,
                    "{name}{how}, seed {seed}: apex {err} px off"
                );
                worst = worst.max(err);
            }
        }
    }
    println!(
        "soft dark shapes: no tip on 12 probe-free frames; the probe's apex at worst {worst:.2} px off"
    );
}
