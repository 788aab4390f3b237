//! Acceptance on the synthetic microscope: recall/precision at SNR 4, centre
//! error against the Cramer-Rao bound at SNR 8, radius error, empty frames,
//! bit-depth independence.

use nanopush::render::microscope::{RenderSettings, SceneView, render_frame};
use nanopush::render::microscope_truth::random_scene;
use nanopush::vision::cramer_rao::centre_crb_px;
use nanopush::vision::detect::{DetectSettings, Detection, detect_particles};
use nanopush::vision::exposure::Exposure;
use nanopush::vision::frame::Frame;
use nanopush::vision::matching::{MatchReport, match_points};

const RADIUS: f64 = 8.0;

fn run(
    size: usize,
    n: usize,
    snr: f64,
    bits: u8,
    seed: u64,
) -> (SceneView, Vec<nanopush::vision::detect::Detection>) {
    let scene = random_scene(n, size, size, RADIUS, seed);
    let frame = render_frame(&scene, &RenderSettings::with_snr(snr, bits), seed).unwrap();
    let settings = DetectSettings {
        diameter_px: 2.0 * RADIUS + 1.0,
        ..DetectSettings::default()
    };
    (scene.clone(), detect_particles(&frame, &settings).unwrap())
}

fn truth(scene: &SceneView) -> Vec<[f64; 2]> {
    scene.particles.iter().map(|p| [p.x_px, p.y_px]).collect()
}

#[test]
fn recall_and_precision_at_snr_4_on_1024_16bit() {
    let (scene, found) = run(1024, 100, 4.0, 16, 11);
    assert_eq!(scene.particles.len(), 100);
    let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
    let m = match_points(&truth(&scene), &pts, RADIUS);
    println!(
        "SNR 4: recall {:.3} precision {:.3}",
        m.recall(),
        m.precision()
    );
    assert!(m.recall() >= 0.99, "recall {}", m.recall());
    assert!(m.precision() >= 0.99, "precision {}", m.precision());
}

#[test]
fn centre_error_near_the_cramer_rao_bound_and_radius_within_2_percent_at_snr_8() {
    let (scene, found) = run(1024, 100, 8.0, 16, 12);
    let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
    let m = match_points(&truth(&scene), &pts, RADIUS);
    let crb = centre_crb_px(RADIUS, &RenderSettings::with_snr(8.0, 16)).unwrap();
    let rms = m.rms_per_axis();
    let radius_err: Vec<f64> = m
        .pairs
        .iter()
        .map(|&(_, j, _, _)| (found[j].r_px / RADIUS - 1.0).abs())
        .collect();
    let mean_r = radius_err.iter().sum::<f64>() / radius_err.len() as f64;
    let max_r = radius_err.iter().cloned().fold(0.0, f64::max);
    let mean_sigma = m
        .pairs
        .iter()
        .map(|&(_, j, _, _)| found[j].sigma_px)
        .sum::<f64>()
        / m.pairs.len() as f64;
    println!(
        "SNR 8: centre RMS {rms:.4} px, CRB {crb:.4} px, ratio {:.3}; reported sigma {mean_sigma:.4} px; \
         radius error mean {:.3} % max {:.3} %",
        rms / crb,
        100.0 * mean_r,
        100.0 * max_r
    );
    assert!(m.recall() >= 0.99);
    assert!(rms <= 1.3 * crb, "RMS {rms} vs CRB {crb}");
    assert!(max_r <= 0.02, "radius error up to {} %", 100.0 * max_r);
    // The reported uncertainty is honest: within 30 % of the measured error.
    assert!(
        (mean_sigma / rms - 1.0).abs() < 0.3,
        "sigma {mean_sigma} vs rms {rms}"
    );
}

/// The SNR 8 scene of 100 particles with the camera's gain raised 2.2-fold,
/// so that the brighter particles' cores clip at 65535 (8,945 pixels).
fn clipped_cores_scene() -> (SceneView, Frame) {
    let scene = random_scene(100, 1024, 1024, RADIUS, 12);
    let mut settings = RenderSettings::with_snr(8.0, 16);
    settings.camera.gain_counts_per_e *= 2.2;
    let frame = render_frame(&scene, &settings, 12).unwrap();
    (scene, frame)
}

/// The bench frame (100 particles, the probe) at `gain` times the SNR 8
/// camera's gain.
fn bench_frame_at_gain(gain: f64) -> Frame {
    let mut settings = RenderSettings::with_snr(8.0, 16);
    settings.camera.gain_counts_per_e *= gain;
    let scene = nanopush::render::microscope_truth::benchmark_scene();
    render_frame(&scene, &settings, 3).unwrap()
}

/// Pixels at the full count.
fn clipped_pixels(frame: &Frame) -> usize {
    (Exposure::of(frame).saturated_fraction * frame.pixels().len() as f64).round() as usize
}

/// The particles found in `frame`, their matching to the scene's, and the
/// worst centre error in pixels.
fn located(scene: &SceneView, frame: &Frame) -> (Vec<Detection>, MatchReport, f64) {
    let found = detect_particles(
        frame,
        &DetectSettings {
            diameter_px: 2.0 * RADIUS + 1.0,
            ..DetectSettings::default()
        },
    )
    .unwrap();
    let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
    let m = match_points(&truth(scene), &pts, RADIUS);
    let worst = m.pairs.iter().map(|p| p.2.hypot(p.3)).fold(0.0, f64::max);
    (found, m, worst)
}

/// How the particles found in `frame` sit on the scene's: every one found
/// and nothing else, centre RMS within 1.3 the (unclipped) Cramer-Rao bound
/// and the worst within 0.3 px. Returns the detections and their matching.
fn assert_centres_near_the_bound(
    what: &str,
    scene: &SceneView,
    frame: &Frame,
) -> (Vec<Detection>, MatchReport) {
    let (found, m, worst) = located(scene, frame);
    let rms = m.rms_per_axis();
    let crb = centre_crb_px(RADIUS, &RenderSettings::with_snr(8.0, 16)).unwrap();
    println!(
        "{what} ({} pixels at the full count): centre RMS {rms:.4} px (unclipped CRB {crb:.4}), worst {worst:.3} px",
        clipped_pixels(frame)
    );
    assert_eq!((m.recall(), m.precision()), (1.0, 1.0), "{what}");
    assert!(rms <= 1.3 * crb, "{what}: RMS {rms} vs CRB {crb}");
    assert!(worst <= 0.3, "{what}: worst centre {worst} px");
    (found, m)
}

/// An over-exposed camera (`clipped_cores_scene`). The clipped pixels are
/// censored samples of the profile fit (at least the full count), not left
/// out: left out, the core's place was lost and one centre came out 1.235
/// px off (RMS 0.096 px, 3x the bound, radius error up to 13 %); censored,
/// worst 0.087 px, RMS 0.031 px, radius error up to 3.8 %.
#[test]
fn clipped_particle_cores_keep_their_centres_near_the_bound() {
    let (scene, frame) = clipped_cores_scene();
    assert!(clipped_pixels(&frame) > 5_000);
    let (found, m) = assert_centres_near_the_bound("clipped cores", &scene, &frame);
    let max_r = m
        .pairs
        .iter()
        .map(|&(_, j, _, _)| (found[j].r_px / RADIUS - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(max_r <= 0.05, "radius error up to {} %", 100.0 * max_r);
}

/// The over-exposed frame above, exported as floats (counts / 1000, as a
/// lab's software may write a 32-bit TIFF): the clip level its 8,945
/// pixels share maps onto the full count, so the fit censors them as it
/// does in the camera's own frame (RMS 0.031 px, worst 0.116 px). Before,
/// the float frame was fitted as if unclipped: RMS 0.047 px (1.46x the
/// bound), worst 0.396 px.
#[test]
fn a_float_export_of_a_clipped_frame_is_fitted_as_clipped() {
    use nanopush::vision::wide_samples::frame_from_wide;
    let (scene, frame) = clipped_cores_scene();
    let floats: Vec<f32> = frame.pixels().iter().map(|v| v / 1000.0).collect();
    let mapped = frame_from_wide(1024, 1024, &floats).unwrap();
    assert_eq!(clipped_pixels(&mapped), clipped_pixels(&frame));
    assert_centres_near_the_bound("float export of the clipped frame", &scene, &mapped);
}

/// A badly over-exposed camera: the bench scene (100 particles, 5 under the
/// probe) at 2.7x and 3x the SNR 8 gain, where the background itself clips
/// over 61 % and 92 % of the frame and only the particles' dark rings stay
/// below the full count. Before clipped pixels were censored samples and a
/// clipped core started the fit as bright as its ring is dark: at 2.7x,
/// centre RMS 0.309 px and one centre 3.1 px off; at 3x, 58 of 100 found.
/// Now 88 and 80 found, RMS 0.089 and 0.079 px, worst 0.93 and 0.52 px.
#[test]
fn a_clipped_background_keeps_most_particles_and_their_centres() {
    use nanopush::render::microscope_truth::benchmark_scene;
    let scene = benchmark_scene();
    for (gain, min_recall) in [(2.7, 0.85), (3.0, 0.75)] {
        let frame = bench_frame_at_gain(gain);
        let clipped = clipped_pixels(&frame);
        let (_, m, worst) = located(&scene, &frame);
        println!(
            "gain {gain}x ({clipped} pixels clipped): recall {:.2}, precision {:.2}, centre RMS {:.4} px, worst {worst:.3} px",
            m.recall(),
            m.precision(),
            m.rms_per_axis()
        );
        assert!(clipped > 600_000, "only {clipped} clipped");
        assert!(m.recall() >= min_recall, "recall {}", m.recall());
        assert_eq!(m.precision(), 1.0);
        assert!(m.rms_per_axis() <= 0.1, "RMS {}", m.rms_per_axis());
        assert!(worst <= 1.0, "worst centre {worst} px");
    }
}

/// `nanopush detect` tells an over-exposed camera once, and its JSON
/// carries the clipped fraction; clipped particle cores alone (the 2.2x
/// frame, 0.85 % of the pixels) are no warning: the fit censors them.
#[test]
fn detect_warns_of_a_clipped_background_not_of_clipped_cores() {
    use nanopush::vision::detections_file::DetectionsFile;
    use nanopush::vision::frame_input::save_png;
    let dir = tempfile::tempdir().unwrap();
    let detect = |frame: &Frame, name: &str, json: bool| {
        let path = dir.path().join(name);
        save_png(frame, &path).unwrap();
        let mut args = vec!["detect", path.to_str().unwrap()];
        if json {
            args.push("--json");
        }
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
            .args(&args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (_, cores) = clipped_cores_scene();
    let (_, said) = detect(&cores, "cores.png", false);
    assert!(!said.contains("full count"), "{said}");
    let over = bench_frame_at_gain(2.7);
    let (_, said) = detect(&over, "over.png", false);
    assert_eq!(
        said.matches("of the pixels at the camera's full count (65535): over-exposed")
            .count(),
        1,
        "{said}"
    );
    let (printed, _) = detect(&over, "over.png", true);
    let doc = DetectionsFile::from_json(&printed).unwrap();
    let expected = Exposure::of(&over);
    assert!(expected.saturated_fraction > 0.6, "{expected:?}");
    assert_eq!(doc.exposure, expected);
}

/// A 12-bit camera's frame in a 16-bit file, as its counts or shifted to
/// the top bits: read as 12 bits, so its clipped background warns and is
/// censored like a 16-bit camera's (without, no warning and 11 of 30
/// particles on a like frame).
#[test]
fn a_twelve_bit_camera_in_a_sixteen_bit_file_clips_at_its_own_full_count() {
    use nanopush::vision::detections_file::DetectionsFile;
    use nanopush::vision::frame_input::save_png;
    let dir = tempfile::tempdir().unwrap();
    let over = bench_frame_at_gain(2.7);
    let twelve = |scale: f32| {
        let px = over
            .pixels()
            .iter()
            .map(|v| (v / 16.0).round().min(4095.0) * scale)
            .collect();
        Frame::new(over.width(), over.height(), px, 16).unwrap()
    };
    let found = |frame: &Frame, name: &str| {
        let path = dir.path().join(name);
        save_png(frame, &path).unwrap();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
            .args(["detect", path.to_str().unwrap(), "--json"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let doc = DetectionsFile::from_json(&String::from_utf8_lossy(&o.stdout)).unwrap();
        (
            doc.particles.len(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (sixteen, _) = found(&over, "sixteen.png");
    for (name, scale) in [("counts.png", 1.0), ("shifted.png", 16.0)] {
        let (n, said) = found(&twelve(scale), name);
        assert!(
            said.contains("of the pixels at the camera's full count (4095): over-exposed"),
            "{name}: {said}"
        );
        assert!(
            n + 3 >= sixteen,
            "{name}: {n} particles, {sixteen} in 16 bits"
        );
    }
}

#[test]
fn empty_frames_give_no_detections_at_any_bit_depth() {
    for bits in [8u8, 16] {
        let scene = SceneView {
            width_px: 256,
            height_px: 256,
            ..SceneView::default()
        };
        let frame = render_frame(&scene, &RenderSettings::with_snr(8.0, bits), 3).unwrap();
        let found = detect_particles(&frame, &DetectSettings::default()).unwrap();
        assert!(
            found.is_empty(),
            "{bits}-bit: {} false detections",
            found.len()
        );
    }
}

#[test]
fn same_particles_found_in_8_and_16_bit_frames() {
    let (scene16, found16) = run(256, 12, 10.0, 16, 5);
    let (_, found8) = run(256, 12, 10.0, 8, 5);
    let t = truth(&scene16);
    for found in [&found16, &found8] {
        let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
        let m = match_points(&t, &pts, RADIUS);
        assert_eq!(m.pairs.len(), t.len());
        assert_eq!(m.n_found, t.len());
    }
}

/// A lab's software exports the same frame as a normalised, offset 32-bit
/// float TIFF (ImageJ's "32-bit") with hot and dead pixels: read back, it
/// must give the particles and the probe the 16-bit frame gives. Fails when such a TIFF cannot be read, or when its
/// values are taken as counts (a 0..1 frame is below the noise floor of one
/// count's quantisation, and its negative half would read as clipped).
#[test]
fn a_float_tiff_of_a_frame_gives_the_frames_particles() {
    use nanopush::vision::frame_input::{Channel, load_frame};
    use opencv::core::{Mat, MatTrait, Scalar, Vector};
    // The vision bench's scene: 100 particles and the probe, 1024 x 1024.
    let scene = nanopush::render::microscope_truth::benchmark_scene();
    let size = scene.width_px;
    let frame = render_frame(&scene, &RenderSettings::with_snr(8.0, 16), 21).unwrap();
    let mut mat = Mat::new_rows_cols_with_default(
        size as i32,
        size as i32,
        opencv::core::CV_32FC1,
        Scalar::all(0.0),
    )
    .unwrap();
    for y in 0..size {
        for x in 0..size {
            *mat.at_2d_mut::<f32>(y as i32, x as i32).unwrap() = frame.at(x, y) / 65535.0 - 0.25;
        }
    }
    // Hot and dead pixels of the camera, along two rows of a corner, at
    // 1000 times the frame's range: read as values they would squeeze the
    // rest into 65 counts. (A row, so that the range's strided sample of
    // every 16th pixel meets some of them, as it would on a real camera.)
    for x in 1..=32 {
        *mat.at_2d_mut::<f32>(1, x).unwrap() = 1000.0;
        *mat.at_2d_mut::<f32>(2, x).unwrap() = -1000.0;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("float.tif");
    let params = Vector::<i32>::new();
    assert!(opencv::imgcodecs::imwrite(&path.to_string_lossy(), &mat, &params).unwrap());
    let back = load_frame(&path, Channel::Luminance).unwrap();

    let settings = DetectSettings {
        diameter_px: 2.0 * RADIUS + 1.0,
        ..DetectSettings::default()
    };
    let counts = detect_particles(&frame, &settings).unwrap();
    let floats = detect_particles(&back, &settings).unwrap();
    // The same particles as the 16-bit frame (the probe's body hides a few
    // of the 100 in both).
    let matched = |found: &[nanopush::vision::detect::Detection]| {
        let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
        match_points(&truth(&scene), &pts, RADIUS).pairs.len()
    };
    assert!(matched(&counts) >= 95, "{}", matched(&counts));
    assert_eq!(matched(&floats), matched(&counts));
    assert_eq!(floats.len(), counts.len());
    let worst = counts
        .iter()
        .map(|c| {
            floats
                .iter()
                .map(|f| (f.x_px - c.x_px).hypot(f.y_px - c.y_px) + (f.r_px - c.r_px).abs())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    let tip = |f, name: &str| {
        let t = nanopush::vision::tip::detect_tip(f, &Default::default());
        let t = t.unwrap_or_else(|| panic!("no tip found in the {name} frame"));
        (t.x_px, t.y_px)
    };
    let (a, b) = (tip(&frame, "16-bit"), tip(&back, "float"));
    let apex = (a.0 - b.0).hypot(a.1 - b.1);
    println!(
        "float TIFF against the 16-bit frame: worst centre + radius difference {worst:.2e} px, tip apex {apex:.2e} px"
    );
    assert!(apex < 0.01, "tip apex {a:?} and {b:?}");
    assert!(worst < 0.01, "worst difference {worst} px");
}

/// Crowded frames (45 particles of radius 8 px on 256 x 256, 14 % covered)
/// under size hints from 14 to 22 px: a candidate between three rings
/// once fitted a ring-like patch of their arcs (15 phantoms in 280 runs of
/// `detect`); every particle is found once and nothing else.
#[test]
fn crowded_frames_give_no_phantom_between_rings_under_any_size_hint() {
    let mut phantoms = Vec::new();
    for seed in 21..41 {
        let scene = random_scene(45, 256, 256, RADIUS, seed);
        let frame = render_frame(&scene, &RenderSettings::with_snr(20.0, 16), seed).unwrap();
        for diameter_px in [14.0, 16.0, 18.0, 20.0, 22.0] {
            let settings = DetectSettings {
                diameter_px,
                ..DetectSettings::default()
            };
            let found = detect_particles(&frame, &settings).unwrap();
            let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
            let m = match_points(&truth(&scene), &pts, 2.0);
            if m.pairs.len() != scene.particles.len() || found.len() != m.pairs.len() {
                phantoms.push((
                    seed,
                    diameter_px,
                    scene.particles.len(),
                    found.len(),
                    m.pairs.len(),
                ));
            }
        }
    }
    assert!(
        phantoms.is_empty(),
        "(seed, hint px, particles, found, matched): {phantoms:?}"
    );
}

/// The locators without a fit (pixel peak, centroid, radial symmetry) get
/// no ring-core candidates: most cores are arcs of a ring, which a fit
/// merges or rejects but these locators reported as particles, up to 5
/// for each sphere (pixel peak's precision 0.195 on this frame; without
/// the cores 0.80, 0.83 and 0.87). And their energy window holds the whole
/// ring (0.5 diameter, not the fit's 0.3), so that its maximum sits at the
/// centre: at 0.3 the pixel peak's centre RMS was 2.6 px and the centroid's
/// 1.5 px; now 0.30, 0.17 and 0.26 px per axis, precision 1.0 for all three.
/// At SNR 32 the band-pass's edges made maxima in the frame's corners (5 of
/// 45 detections on this frame); a maximum whose window leaves the frame is
/// no longer taken without a fit.
#[test]
fn locators_without_a_fit_find_ring_centres_not_ring_arcs() {
    use nanopush::vision::detect::Locator;
    let scene = random_scene(40, 512, 512, RADIUS, 1);
    for (snr, locator) in [8.0, 32.0].into_iter().flat_map(|snr| {
        [
            Locator::PixelPeak,
            Locator::Centroid,
            Locator::RadialSymmetry,
        ]
        .map(|l| (snr, l))
    }) {
        let frame = render_frame(&scene, &RenderSettings::with_snr(snr, 16), 1).unwrap();
        let settings = DetectSettings {
            diameter_px: 2.0 * RADIUS + 1.0,
            locator,
            ..DetectSettings::default()
        };
        let found = detect_particles(&frame, &settings).unwrap();
        let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
        let m = match_points(&truth(&scene), &pts, RADIUS);
        eprintln!(
            "{locator:?} at SNR {snr}: recall {:.3} precision {:.3} centre RMS {:.3} px per axis",
            m.recall(),
            m.precision(),
            m.rms_per_axis()
        );
        assert!(m.recall() >= 0.99, "{locator:?}: recall {}", m.recall());
        assert!(
            m.precision() >= 0.95,
            "{locator:?}: precision {}",
            m.precision()
        );
        let rms = m.rms_per_axis();
        assert!(rms <= 0.5, "{locator:?}: centre RMS {rms} px per axis");
    }
}
