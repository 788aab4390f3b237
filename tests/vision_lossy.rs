//! Frames through a lossy codec: a JPEG (as an MJPG or mp4 recording's
//! frames are) smooths the pixel noise away and leaves blocks a few pixels
//! across. Detection thresholds in units of the pixel noise had taken the
//! blocks for particles (src/vision/band_noise.rs).

use std::path::Path;

use image::codecs::jpeg::JpegEncoder;
use nanopush::render::microscope::{RenderSettings, render_frame};
use nanopush::render::microscope_truth::random_scene;
use nanopush::vision::detect::{DetectSettings, Detection, detect_particles};
use nanopush::vision::frame::Frame;
use nanopush::vision::frame_input::{Channel, decode_image, load_frame};
use nanopush::vision::matching::match_points;

/// JPEG quality of the tests: a camera's or a screen recorder's low setting.
const QUALITY: u8 = 50;

/// `frame` (8-bit) as a JPEG of `QUALITY`, decoded as a file would be.
fn through_jpeg(frame: &Frame) -> Frame {
    assert_eq!(frame.bit_depth(), 8);
    let grey: Vec<u8> = frame.pixels().iter().map(|&v| v.round() as u8).collect();
    let mut bytes = Vec::new();
    JpegEncoder::new_with_quality(&mut bytes, QUALITY)
        .encode(
            &grey,
            frame.width() as u32,
            frame.height() as u32,
            image::ExtendedColorType::L8,
        )
        .unwrap();
    decode_image(&bytes, Path::new("frame.jpg"), Channel::Luminance).unwrap()
}

fn centres(found: &[Detection]) -> Vec<[f64; 2]> {
    found.iter().map(|d| [d.x_px, d.y_px]).collect()
}

/// 40 particles of 8 px radius at SNR 20 on 512 x 512 8-bit frames, three
/// seeds, as JPEGs: every particle found within 1 px, at most one more on
/// any frame. With thresholds in units of the pixel noise alone, seed 1
/// gave 65.
#[test]
fn a_jpeg_of_a_synthetic_frame_gives_its_particles_not_its_blocks() {
    let settings = DetectSettings {
        diameter_px: 17.0,
        ..DetectSettings::default()
    };
    for seed in 1..=3 {
        let scene = random_scene(40, 512, 512, 8.0, seed);
        let frame = render_frame(&scene, &RenderSettings::with_snr(20.0, 8), seed).unwrap();
        let found = detect_particles(&through_jpeg(&frame), &settings).unwrap();
        let truth: Vec<[f64; 2]> = scene.particles.iter().map(|p| [p.x_px, p.y_px]).collect();
        let matched = match_points(&truth, &centres(&found), 1.0).pairs.len();
        println!(
            "seed {seed}: {} found, {matched} of 40 matched",
            found.len()
        );
        assert_eq!(matched, 40, "seed {seed}");
        assert!(found.len() <= 41, "seed {seed}: {} found", found.len());
    }
}

/// The real bright-field frames (5 particles each) as JPEGs: the same 5,
/// within 0.5 px of where the lossless frame puts them. With thresholds in
/// units of the pixel noise alone, bf_0000 gave 37.
#[test]
fn a_jpeg_of_a_real_brightfield_frame_gives_its_five_particles() {
    for name in ["bf_0000", "bf_0025", "bf_0049"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures/real/brightfield")
            .join(format!("{name}.png"));
        let frame = load_frame(&path, Channel::Luminance).unwrap();
        let settings = DetectSettings::default();
        let lossless = detect_particles(&frame, &settings).unwrap();
        let lossy = detect_particles(&through_jpeg(&frame), &settings).unwrap();
        assert_eq!(lossless.len(), 5, "{name}");
        assert_eq!(lossy.len(), 5, "{name}: {} found in the JPEG", lossy.len());
        let matched = match_points(&centres(&lossless), &centres(&lossy), 0.5);
        assert_eq!(matched.pairs.len(), 5, "{name}");
    }
}
