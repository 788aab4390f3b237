use nanopush::plan::cmu_scene::cmu_scene;
use nanopush::plan::synth_layout::LayoutKind;
use nanopush::plan::{PlanConfig, plan_assembly, verify_plan};

#[test]
fn scratch_standoff() {
    for standoff in [1.0e-6, 0.5e-6, 0.3e-6, 0.15e-6] {
        let config = PlanConfig {
            standoff_m: standoff,
            ..PlanConfig::default()
        };
        let mut planned = 0;
        let mut msgs = vec![];
        let t = std::time::Instant::now();
        for seed in 0..20 {
            let (layout, sites) = cmu_scene(LayoutKind::Adversarial, seed).unwrap();
            match plan_assembly(&layout, &sites, &config) {
                Ok(plan) => {
                    let rep = verify_plan(&plan, &layout, &config);
                    assert!(rep.ok && rep.collisions.is_empty());
                    planned += 1;
                    let s = &plan.summary;
                    msgs.push(format!(
                        "seed {seed} push {:.3}",
                        s.push_distance_m / s.lb_push_m
                    ));
                }
                Err(e) => msgs.push(format!(
                    "seed {seed}: {}",
                    &e.to_string()[..e.to_string().len().min(300)]
                )),
            }
        }
        eprintln!(
            "standoff {standoff:e}: planned {planned}/20 in {:?}",
            t.elapsed()
        );
        for m in msgs.iter().take(4) {
            eprintln!("  {m}");
        }
    }
}
