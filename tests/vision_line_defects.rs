//! A camera with a dead column and a hot row across the probe: the frame's
//! analysis must find what it finds in the clean frame (without the repair
//! the probe is not found and the lines' ends are taken for particles).

mod deadline;

use nanopush::render::microscope::{RenderSettings, render_frame};
use nanopush::render::microscope_truth::benchmark_scene;
use nanopush::vision::analyse::analyse_frame;
use nanopush::vision::detect::DetectSettings;
use nanopush::vision::detections_file::DetectionsFile;
use nanopush::vision::frame::Frame;
use nanopush::vision::line_defects::LineAxis;
use nanopush::vision::tip::{TipSettings, detect_tip};

#[test]
fn dead_and_hot_lines_across_the_probe_change_nothing_found() {
    let scene = benchmark_scene();
    let (w, h) = (scene.width_px, scene.height_px);
    let clean = render_frame(&scene, &RenderSettings::with_snr(20.0, 16), 5).unwrap();
    let tip = TipSettings::default();
    let settings = DetectSettings::default();
    let before = analyse_frame(&clean, &settings, Some(&tip)).unwrap();
    let apex = before.tip.as_ref().expect("the clean frame's probe");
    assert!(
        before.repaired_lines.is_empty(),
        "{:?}",
        before.repaired_lines
    );
    // A point of the probe's body 120 px behind the apex: the dead column
    // and the hot row cross there.
    let body_x = (apex.x_px - 120.0 * apex.angle_rad.cos()).round() as usize;
    let body_y = (apex.y_px - 120.0 * apex.angle_rad.sin()).round() as usize;
    let mut px = clean.pixels().to_vec();
    for y in 0..h {
        px[y * w + body_x] = 0.0;
    }
    for x in 0..w {
        px[body_y * w + x] = 65_535.0;
    }
    let broken = Frame::new(w, h, px, 16).unwrap();
    assert!(
        detect_tip(&broken, &tip).is_none(),
        "the probe is found even across unrepaired lines: the test shows nothing"
    );

    let after = analyse_frame(&broken, &settings, Some(&tip)).unwrap();
    let lines: Vec<(LineAxis, usize)> = after
        .repaired_lines
        .iter()
        .map(|d| (d.axis, d.index))
        .collect();
    assert_eq!(lines, [(LineAxis::Column, body_x), (LineAxis::Row, body_y)]);
    let found = after.tip.as_ref().expect("the probe across repaired lines");
    let apex_moved = (found.x_px - apex.x_px).hypot(found.y_px - apex.y_px);
    // Particles: the clean frame's, each within 0.05 px, but for those a
    // repaired line crosses (their centre within a radius of it: the
    // repair rests on their neighbouring pixels), within 0.5 px.
    let radius = 0.5 * settings.diameter_px;
    assert_eq!(after.particles.len(), before.particles.len());
    let mut worst_clear: f64 = 0.0;
    let mut worst_crossed: f64 = 0.0;
    for p in &before.particles {
        let moved = after
            .particles
            .iter()
            .map(|q| (q.x_px - p.x_px).hypot(q.y_px - p.y_px))
            .fold(f64::INFINITY, f64::min);
        let crossed = (p.x_px - body_x as f64).abs() <= radius + 2.0
            || (p.y_px - body_y as f64).abs() <= radius + 2.0;
        if crossed {
            worst_crossed = worst_crossed.max(moved);
        } else {
            worst_clear = worst_clear.max(moved);
        }
    }
    println!(
        "column {body_x}, row {body_y}: apex moved {apex_moved:.3} px; particles clear of the lines \
         moved at most {worst_clear:.2e} px, crossed ones {worst_crossed:.3} px"
    );
    assert!(apex_moved < 0.1, "apex moved {apex_moved} px");
    assert!(worst_clear < 0.05, "{worst_clear}");
    assert!(worst_crossed < 0.5, "{worst_crossed}");
}

/// `nanopush detect` on such a frame says which line it repaired, and
/// finds the probe.
#[test]
fn detect_names_the_repaired_line_and_finds_the_probe() {
    use nanopush::vision::frame_input::save_png;
    let scene = benchmark_scene();
    let (w, h) = (scene.width_px, scene.height_px);
    let clean = render_frame(&scene, &RenderSettings::with_snr(20.0, 16), 6).unwrap();
    let apex = detect_tip(&clean, &TipSettings::default()).unwrap();
    let column = (apex.x_px - 120.0 * apex.angle_rad.cos()).round() as usize;
    let mut px = clean.pixels().to_vec();
    for y in 0..h {
        px[y * w + column] = 0.0;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("dead_column.png");
    save_png(&Frame::new(w, h, px, 16).unwrap(), &path).unwrap();
    let ran = deadline::nanopush_within(dir.path(), &["detect", &path.to_string_lossy()], 30);
    assert!(ran.ok, "{}", ran.stderr);
    assert!(
        ran.stderr.contains("camera line defect repaired")
            && ran
                .stderr
                .contains(&format!("column {column} (mean 0 counts")),
        "{}",
        ran.stderr
    );
    assert!(ran.stdout.contains("tip: x"), "{}", ran.stdout);
    // The JSON document carries the repaired line, and reads back.
    let ran = deadline::nanopush_within(
        dir.path(),
        &["detect", &path.to_string_lossy(), "--json"],
        30,
    );
    assert!(ran.ok, "{}", ran.stderr);
    let doc = DetectionsFile::from_json(&ran.stdout).unwrap();
    assert!(doc.tip.is_some());
    assert_eq!(doc.repaired_lines.len(), 1, "{:?}", doc.repaired_lines);
    let line = &doc.repaired_lines[0];
    assert_eq!((line.axis, line.index), (LineAxis::Column, column));
    assert_eq!(line.mean_counts, 0.0);
    assert!(
        ran.stdout.contains("\"axis\": \"column\""),
        "{}",
        ran.stdout
    );
}
