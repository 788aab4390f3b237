//! Cost of the ring-edge centre stage (`CentreEstimate::RingEdge`): recentring
//! the 100 detections of the vision bench's 1024x1024 16-bit frame (SNR 10),
//! and the 5 of a real brightfield frame. Wall clock on a shared machine:
//! compare medians run against run, not against other benches.

use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use nanopush::render::microscope::{RenderSettings, render_frame};
use nanopush::render::microscope_truth::random_scene;
use nanopush::vision::detect::{DetectSettings, detect_particles};
use nanopush::vision::frame::Frame;
use nanopush::vision::frame_input::{Channel, load_frame};
use nanopush::vision::noise::estimate_noise_sigma;
use nanopush::vision::ring_edge::recentre_on_ring_edges;

/// Benchmarks recentring every profile detection of `frame`.
fn bench_frame(c: &mut Criterion, name: &str, frame: &Frame, diameter_px: f64) {
    let settings = DetectSettings {
        diameter_px,
        ..DetectSettings::default()
    };
    let found = detect_particles(frame, &settings).expect("detect");
    let noise = estimate_noise_sigma(frame);
    let mut g = c.benchmark_group("ring_edge");
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(3));
    g.sample_size(20);
    g.bench_function(format!("recentre_{name}_{}_particles", found.len()), |b| {
        b.iter(|| {
            let mut work = found.clone();
            recentre_on_ring_edges(frame, &mut work, noise)
        })
    });
    g.finish();
}

fn bench(c: &mut Criterion) {
    let scene = random_scene(100, 1024, 1024, 8.0, 42);
    let frame = render_frame(&scene, &RenderSettings::with_snr(10.0, 16), 42).expect("render");
    bench_frame(c, "synthetic_1024", &frame, 17.0);
    let bf = load_frame(
        std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/real/brightfield/bf_0000.png"
        )),
        Channel::Luminance,
    )
    .expect("fixture");
    bench_frame(c, "brightfield_bf_0000", &bf, 17.0);
}

criterion_group!(benches, bench);
criterion_main!(benches);
