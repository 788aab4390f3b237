//! Planner benchmarks: CMU planning on 40-60 particle layouts; assignment
//! (exact = the auction at this size, and greedy) and the full plan on a
//! compact block of N = 1000 sites with 2N particles at 10 % coverage.
//! Run: `cargo bench --bench plan -- assign_block` (short warm-up and
//! measurement times); `-- plan_block` for the full plan (slow).

use criterion::{Criterion, criterion_group, criterion_main};
use nanopush::plan::assignment::block_instance;
use nanopush::plan::assignment::{AssignmentMethod, assign};
use nanopush::plan::cmu_scene::cmu_scene;
use nanopush::plan::pattern::numbered_sites;
use nanopush::plan::synth_layout::LayoutKind;
use nanopush::plan::{PlanConfig, plan_assembly};
use std::time::Duration;

fn cmu(c: &mut Criterion) {
    let config = PlanConfig::default();
    // The 100 uniform acceptance layouts (planned or refused, as they come).
    let cases: Vec<_> = (0..100u64)
        .map(|seed| cmu_scene(LayoutKind::Uniform, seed).unwrap())
        .collect();
    // The counter lives outside the routine, which criterion calls afresh
    // for every sample: inside, each sample began again at layout 0 and the
    // estimate weighed the first layouts most (fixed_detours' first
    // version, up to 24 ms on a few of them, read as +3.3 ms against a
    // true +1 ms mean).
    let mut i = 0;
    c.bench_function("plan_cmu_100_layouts_each", |b| {
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
    let (sites, layout) = block_instance(1_000, 7);
    let parts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
    // `Exact` runs the auction at this size (1000 x 2000 pairs).
    for (name, method) in [
        ("exact_auction_n1000", AssignmentMethod::Exact),
        ("greedy_n1000", AssignmentMethod::Greedy),
    ] {
        g.bench_function(name, |b| b.iter(|| assign(&sites, &parts, method).unwrap()));
    }
    g.finish();
}

fn full_plan(c: &mut Criterion) {
    // Slow while the order stage dominates (see docs/plan.md): run alone with
    // `cargo bench --bench plan -- plan_block`.
    let mut g = c.benchmark_group("plan_block");
    g.sample_size(10);
    let (sites, layout) = block_instance(1_000, 7);
    let sites = numbered_sites(sites.iter().copied());
    let config = PlanConfig::default();
    g.bench_function("full_n1000", |b| {
        b.iter(|| std::hint::black_box(plan_assembly(&layout, &sites, &config)))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
    targets = cmu, blocks, full_plan
}
criterion_main!(benches);
