//! Planner benchmarks: CMU planning on 40-60 particle layouts, and exact
//! assignment on compact blocks of N sites with 2N particles at 10 % coverage.
//! Run: `cargo bench --bench plan` (short warm-up and measurement times).

use criterion::{Criterion, criterion_group, criterion_main};
use nanopush::plan::assignment::block_instance;
use nanopush::plan::assignment::{AssignmentMethod, assign};
use nanopush::plan::pattern::transform::{Reachable, place_optimised};
use nanopush::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
use nanopush::plan::{Pattern, PlanConfig, plan_assembly};
use std::time::Duration;

fn cmu(c: &mut Criterion) {
    let pattern = Pattern::from_text("CMU", 10.5e-6).unwrap();
    let config = PlanConfig::default();
    // The 100 uniform acceptance layouts (planned or refused, as they come).
    let mut cases = Vec::new();
    for seed in 0..100u64 {
        let n = 40 + (seed as usize * 7) % 21;
        let p = SynthParams {
            n,
            field_m: [120e-6, 100e-6],
            radius_m: 5e-6,
            min_gap_m: 1e-6,
            polydisperse: false,
            kind: LayoutKind::Uniform,
            seed,
        };
        let layout = synth_layout(&p).unwrap();
        let pts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
        let sites = place_optimised(
            &pattern,
            &Reachable::for_field(layout.field_m, 5e-6),
            5e-6,
            &pts,
        )
        .unwrap();
        cases.push((layout, sites));
    }
    c.bench_function("plan_cmu_100_layouts_each", |b| {
        let mut i = 0;
        b.iter(|| {
            let (l, s) = &cases[i % cases.len()];
            i += 1;
            let _ = std::hint::black_box(plan_assembly(l, s, &config));
        })
    });
}

fn blocks(c: &mut Criterion) {
    let mut g = c.benchmark_group("assign_block");
    g.sample_size(10);
    for n in [1_000usize, 5_000] {
        let (sites, layout) = block_instance(n, 7);
        let parts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
        g.bench_function(format!("exact_n{n}"), |b| {
            b.iter(|| assign(&sites, &parts, AssignmentMethod::Exact).unwrap())
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
    targets = cmu, blocks
}
criterion_main!(benches);
