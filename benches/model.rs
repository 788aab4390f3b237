//! Pushing-model benchmarks: one paper-scene push (30 s of stage travel),
//! target <= 50 us median; 10,000 pushes with random parameters, target <= 1 s.

use criterion::{Criterion, criterion_group, criterion_main};
use nanopush::model::{PushParams, Scene, simulate_push};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn paper() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml"))
        .expect("paper scene")
}

fn random_pushes(n: usize, seed: u64) -> Vec<(Scene, PushParams)> {
    let base = paper();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let mut s = base.clone();
            s.particle_radius_m = 10f64.powf(rng.random_range(-8.0..-4.7));
            let w = 10f64.powf(rng.random_range(-3.0..0.0));
            let e = 10f64.powf(rng.random_range(8.0..11.7));
            for i in [&mut s.substrate_interface, &mut s.tip_interface] {
                i.work_of_adhesion_j_m2 = w;
                i.reduced_modulus_pa = e;
            }
            s.friction.sliding_coefficient = rng.random_range(0.0..2.0);
            let p = PushParams {
                contact_angle_rad: rng.random_range(1.0f64..89.0).to_radians(),
                speed_m_per_s: 10f64.powf(rng.random_range(-9.0..-4.0)),
                duration_s: 30.0,
            };
            (s, p)
        })
        .collect()
}

fn benches(c: &mut Criterion) {
    let s = paper();
    let mut g = c.benchmark_group("model");
    g.warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    g.bench_function("paper_push_30s", |b| {
        b.iter(|| simulate_push(black_box(&s), black_box(&s.push)).unwrap())
    });
    let pushes = random_pushes(10_000, 7);
    g.sample_size(10);
    g.bench_function("random_pushes_10k", |b| {
        b.iter(|| {
            let mut moved = 0usize;
            for (s, p) in &pushes {
                if simulate_push(s, p).unwrap().onset_s.is_some() {
                    moved += 1;
                }
            }
            black_box(moved)
        })
    });
    g.finish();
}

criterion_group!(model, benches);
criterion_main!(model);
