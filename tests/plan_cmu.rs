//! Acceptance: "CMU" with 10 um particles on 100 seeded uniform layouts
//! (40-60 particles, 120 x 100 um, gaps >= 1 um) and adversarial layouts.
//!
//! What holds and is asserted always: every plan produced passes the
//! independent replay with zero collisions, every refusal states its
//! reason, all 100 uniform layouts are planned, all 100 push at most 1.05
//! LB_push, and re-planning after every push finishes all 6 executor-style
//! runs. The full targets' last part (push + tip <= 1.2 (LB_push + LB_tip))
//! is NOT met; that test is ignored with the measured figures (run with
//! `--ignored` to see them).

use nanopush::plan::parking;
use nanopush::plan::synth_layout::LayoutKind;
use nanopush::plan::{Layout, PlanConfig, PlanError, Site, plan_assembly, verify_plan};

struct Outcome {
    planned: usize,
    refused: Vec<String>,
    worst_push: f64,
    worst_total: f64,
    /// Push ratio and push+tip ratio of every planned layout.
    ratios: Vec<(f64, f64)>,
}

impl Outcome {
    /// Median push ratio, median push+tip ratio, and how many plans meet 1.05 / 1.2.
    fn spread(&self) -> (f64, f64, usize, usize) {
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(0.0)
        };
        (
            median(self.ratios.iter().map(|r| r.0).collect()),
            median(self.ratios.iter().map(|r| r.1).collect()),
            self.ratios.iter().filter(|r| r.0 <= 1.05).count(),
            self.ratios.iter().filter(|r| r.1 <= 1.2).count(),
        )
    }
}

/// The acceptance scene of `seed` ([`nanopush::plan::cmu_scene`]).
fn cmu_scene(kind: LayoutKind, seed: u64) -> (Layout, Vec<Site>) {
    nanopush::plan::cmu_scene::cmu_scene(kind, seed).expect("the scene builds")
}

fn run_cmu(kind: LayoutKind, seeds: std::ops::Range<u64>) -> Outcome {
    let config = PlanConfig::default();
    let mut o = Outcome {
        planned: 0,
        refused: Vec::new(),
        worst_push: 0.0,
        worst_total: 0.0,
        ratios: Vec::new(),
    };
    for seed in seeds {
        let (layout, sites) = cmu_scene(kind, seed);
        match plan_assembly(&layout, &sites, &config) {
            Ok(plan) => {
                let rep = verify_plan(&plan, &layout, &config);
                assert!(
                    rep.collisions.is_empty(),
                    "seed {seed}: collisions {:?}",
                    rep.collisions
                );
                assert!(rep.ok, "seed {seed}: replay failed {rep:?}");
                let s = &plan.summary;
                let push = s.push_distance_m / s.lb_push_m;
                let total = (s.push_distance_m + s.tip_travel_m) / (s.lb_push_m + s.lb_tip_m);
                o.worst_push = o.worst_push.max(push);
                o.worst_total = o.worst_total.max(total);
                o.ratios.push((push, total));
                o.planned += 1;
            }
            Err(e @ PlanError::Blocked(_)) => o.refused.push(format!("seed {seed}: {e}")),
            Err(e) => panic!("seed {seed}: unexpected error kind: {e}"),
        }
    }
    o
}

#[test]
fn cmu_plans_never_collide_and_refusals_state_a_reason() {
    for (kind, seeds) in [
        (LayoutKind::Uniform, 0..100),
        (LayoutKind::Adversarial, 0..20),
    ] {
        let o = run_cmu(kind, seeds);
        let (med_push, med_total, push_ok, total_ok) = o.spread();
        eprintln!(
            "{kind:?}: planned {}, refused {}, push ratio median {med_push:.3} worst {:.3} ({push_ok} <= 1.05), push+tip ratio median {med_total:.3} worst {:.3} ({total_ok} <= 1.2)",
            o.planned,
            o.refused.len(),
            o.worst_push,
            o.worst_total
        );
        for r in o.refused.iter().take(12) {
            eprintln!("  {r}");
        }
        assert!(
            o.refused
                .iter()
                .all(|r| r.contains("no collision-free order:") && r.len() > 40)
        );
        if kind == LayoutKind::Adversarial {
            // The dense core's particles are boxed in by 1 um gaps for a tip
            // landing 1 um behind them: every layout was refused so. Landing
            // 0.5 um behind (the standoff halved), 14 of 20 plan; 19 since a
            // placement refused at both of the bound's best centres tries
            // others (`placement::FALLBACK_CANDIDATES`). The rest are
            // refused after every try, and say so.
            assert!(o.planned >= 19, "only {} of 20 planned", o.planned);
            assert!(
                o.refused
                    .iter()
                    .all(|r| r.contains("with the tip landing 1, 0.5 um behind")),
                "a refusal did not try the tip landing nearer"
            );
        }
        if kind == LayoutKind::Uniform {
            // Regression floors under the measured figures (see docs/plan.md).
            // Since the fourteenth pass the scenes span 40-60 particles as
            // the issue asks; before, `40 + 7 seed mod 21` gave only 40, 47
            // or 54, where 100 were planned and 99 met 1.05. On the 40-60
            // scenes: 99 planned (seed 66, 58 particles, refused), 88
            // within 1.05; 89 since cycle breaks keep the peel's margin;
            // 100 and 90 since a refused order is tried with wide spots;
            // 92 since the finished order takes shortcuts; 96 since its
            // bends slide and parked pushes turn, 98 since a push bends
            // round an idle particle instead of pushing it (sixteenth pass),
            // 99 since the pattern is placed where the plan pushes least
            // (seventeenth pass; the scenes changed with it), 100 since a
            // parked push may wait for the particle that blocks its way.
            assert!(o.planned >= 100, "only {} of 100 planned", o.planned);
            assert!(push_ok >= 100, "only {push_ok} of 100 meet push ratio 1.05");
        }
    }
}

/// A stage that moves at most 10 um at once (the E-727 templates) gets
/// pushes of at most what its stroke leaves (about 8.5 um): a longer push
/// is cut into pieces by the stage and ends short. Cut pushes are
/// collinear, so the push distance stays what it was.
#[test]
fn pushes_are_no_longer_than_the_stage_step_allows() {
    let longest = 8.5e-6;
    let capped = PlanConfig {
        max_push_m: Some(longest),
        ..PlanConfig::default()
    };
    let free = PlanConfig::default();
    for seed in 0..10 {
        let (layout, sites) = cmu_scene(LayoutKind::Uniform, seed);
        let plan = plan_assembly(&layout, &sites, &capped)
            .unwrap_or_else(|e| panic!("seed {seed}: refused: {e}"));
        let rep = verify_plan(&plan, &layout, &capped);
        assert!(rep.ok, "seed {seed}: {}", rep.summary());
        let pushes: Vec<f64> = plan
            .steps
            .iter()
            .filter_map(|s| s.push_move())
            .map(|(_, from, to)| (to - from).norm())
            .collect();
        let worst = pushes.iter().copied().fold(0.0, f64::max);
        assert!(
            worst <= longest * (1.0 + 1e-9),
            "seed {seed}: a push of {:.3} um",
            worst * 1e6
        );
        let uncapped = plan_assembly(&layout, &sites, &free).unwrap();
        let (n_free, n_capped) = (
            uncapped.steps.iter().filter_map(|s| s.push_move()).count(),
            pushes.len(),
        );
        let push_ratio = |p: &nanopush::plan::Plan| p.summary.push_distance_m / p.summary.lb_push_m;
        eprintln!(
            "seed {seed}: {n_capped} pushes (uncapped {n_free}), push ratio {:.3} (uncapped {:.3})",
            push_ratio(&plan),
            push_ratio(&uncapped)
        );
        assert!(n_capped > n_free, "seed {seed}: no push was cut");
        assert!(
            push_ratio(&plan) <= 1.05,
            "seed {seed}: push ratio {:.3}",
            push_ratio(&plan)
        );
    }
}

/// A dense core plans only with the tip landing nearer (CMU adversarial
/// seed 0): refused when the standoff may not shrink, the locked particles
/// named; planned at half the standoff otherwise, and the plan file keeps
/// that standoff, so the independent replay of the file lands the tip where
/// the plan does.
/// An order that spends its search effort on repairs, or a fifth of it
/// without completing a move, is refused and says so: adversarial seed 1
/// needs buffer moves and detours, and plans with the default effort.
#[test]
fn an_order_out_of_search_effort_is_refused_with_its_reason() {
    let (layout, sites) = cmu_scene(LayoutKind::Adversarial, 1);
    let config = PlanConfig::default();
    let plan = plan_assembly(&layout, &sites, &config).expect("plans with the default effort");
    assert!(plan.summary.buffer_pushes > 0, "{:?}", plan.summary);
    let thrifty = PlanConfig {
        search_effort: 1,
        ..config
    };
    match plan_assembly(&layout, &sites, &thrifty) {
        Err(PlanError::Blocked(reason)) => {
            assert!(
                reason.contains("when the search effort ran out"),
                "{reason}"
            )
        }
        other => panic!("not refused for its effort: {other:?}"),
    }
    // Adversarial seed 3 at 100 per move and particle: its last order
    // spent a fifth of that without completing a move (`order::STALL_SHARE`).
    let (layout, sites) = cmu_scene(LayoutKind::Adversarial, 3);
    let stalled = PlanConfig {
        search_effort: 100,
        ..PlanConfig::default()
    };
    match plan_assembly(&layout, &sites, &stalled) {
        Err(PlanError::Blocked(reason)) => {
            assert!(reason.contains("made way for none"), "{reason}")
        }
        other => panic!("not refused for its stall: {other:?}"),
    }
    let none = PlanConfig {
        search_effort: 0,
        ..PlanConfig::default()
    };
    assert!(matches!(
        plan_assembly(&layout, &sites, &none),
        Err(PlanError::Config(_))
    ));
}

#[test]
fn a_dense_core_plans_with_the_tip_landing_nearer() {
    use nanopush::plan::plan_file;
    use nanopush::plan::verify::verify_plan_with;
    let (layout, sites) = cmu_scene(LayoutKind::Adversarial, 0);
    let config = PlanConfig::default();
    let fixed = PlanConfig {
        min_standoff_m: config.standoff_m,
        ..config.clone()
    };
    match plan_assembly(&layout, &sites, &fixed) {
        Err(PlanError::Blocked(reason)) => assert!(
            reason.contains("cannot be pushed even 1 um in any direction"),
            "{reason}"
        ),
        other => panic!("planned or failed otherwise at a fixed standoff: {other:?}"),
    }
    let plan = plan_assembly(&layout, &sites, &config).expect("plans landing nearer");
    assert!(
        (plan.standoff_m - 0.5e-6).abs() < 1e-15,
        "{}",
        plan.standoff_m
    );
    assert!(verify_plan(&plan, &layout, &config).ok);
    let (read, geometry) =
        plan_file::from_json(&plan_file::to_json(&plan, &config), "mem").unwrap();
    let geometry = geometry.expect("nanopush writes its geometry");
    assert!((geometry.standoff_um - 0.5).abs() < 1e-12);
    assert_eq!(read.standoff_m, plan.standoff_m);
    let report = verify_plan_with(&read, &layout, &[], &geometry, config.on_site_tolerance_m);
    assert!(report.ok && report.collisions.is_empty(), "{report:?}");
    // The same file read as if the tip landed 1 um behind: the replay
    // finds the tip hitting the core.
    let far = plan_file::PlanGeometry {
        standoff_um: 1.0,
        ..geometry
    };
    let report = verify_plan_with(&read, &layout, &[], &far, config.on_site_tolerance_m);
    assert!(!report.collisions.is_empty(), "{report:?}");
}

#[test]
#[ignore = "target not met: push+tip ratio median 1.315 worst 1.542 (target 1.2, 3/100 meet it); met: 100/100 planned, worst push ratio 1.048 (target 1.05); see docs/plan.md"]
fn cmu_on_100_uniform_layouts_meets_the_acceptance_targets() {
    let o = run_cmu(LayoutKind::Uniform, 0..100);
    assert_eq!(o.planned, 100, "refused: {:?}", o.refused);
    assert!(o.worst_push <= 1.05, "worst push ratio {}", o.worst_push);
    assert!(
        o.worst_total <= 1.2,
        "worst push+tip ratio {}",
        o.worst_total
    );
}

/// The tip tour, measured (prints; asserts only what must hold): on every
/// planned CMU layout, the tip travel of the plan, of the same pushes
/// re-sequenced without collision constraints (only each particle's
/// sequence kept), LB_tip, and the assignment bound as it was before self
/// pairs were forbidden (start at the plan's first landing). Shows whether
/// the collision constraints or the search make the gap to LB_tip. Since
/// the thirteenth pass also the constrained optimum (`tour::exact`, a DP
/// over the sets of moves done), which must lie between the constrained
/// assignment bound and the search, and replay cleanly.
#[test]
#[ignore = "a study: prints the tip-tour figures of docs/plan-history.md (thirteenth pass) (about 30-40 min in release: the exact DP)"]
fn tip_tour_study_on_cmu() {
    use nanopush::plan::assignment::{AssignmentMethod, assign};
    use nanopush::plan::pushes::{landing_point, tip_end};
    use nanopush::plan::{Step, bounds, tour};
    let config = PlanConfig::default();
    let (mut plan_r, mut free_r, mut lb_gain, mut total_old, mut total_new, mut cons_b) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let (mut search_r, mut opt_r, mut total_opt, mut exact, mut dp_ms) =
        (vec![], vec![], vec![], 0, vec![]);
    for seed in 0..100u64 {
        let (layout, sites) = cmu_scene(LayoutKind::Uniform, seed);
        let Ok(plan) = plan_assembly(&layout, &sites, &config) else {
            continue;
        };
        let pushes = pushes_of(&plan.steps);
        let t0 = std::time::Instant::now();
        let st = tour::study(&pushes, &layout, None, &config, Some(tour::STUDY_DP))
            .expect("pushes split into moves");
        let study_ms = t0.elapsed().as_secs_f64() * 1e3;
        let s = &plan.summary;
        assert!(
            st.constrained_m <= st.given_m + 1e-12,
            "seed {seed}: {st:?}"
        );
        let optimal_m = st.optimal_m.expect("CMU's moves fit the DP's set");
        assert!(st.optimal_replays, "seed {seed}: the DP's order collides");
        assert!(
            optimal_m <= st.constrained_m + 1e-12 && optimal_m >= st.constrained_bound_m - 1e-12,
            "seed {seed}: the DP's tour outside [bound, search]: {st:?}"
        );
        exact += usize::from(st.exact);
        dp_ms.push(study_ms);
        let lb = bounds::lb_tip(&pushes, None, &config);
        assert!(
            lb <= s.tip_travel_m + 1e-12,
            "seed {seed}: LB_tip above the plan"
        );
        // The bound before this pass: self pairs allowed, start at the first landing.
        let (mut lands, mut ends) = (vec![], vec![]);
        for q in &pushes {
            if let Step::Push {
                from_m,
                to_m,
                approach_m,
                ..
            } = q
            {
                lands.push(landing_point(*from_m, *to_m, *approach_m, &config));
                ends.push(tip_end(*from_m, *to_m, *approach_m));
            }
        }
        ends.push(lands[0]);
        let standoffs = lands.len() as f64 * config.standoff_m;
        let old_lb = assign(&lands, &ends, AssignmentMethod::Exact)
            .unwrap()
            .cost_m
            + standoffs;
        let unconstrained_tip = s.tip_travel_m - st.given_m + st.unconstrained_m;
        let intra_moves = s.tip_travel_m - st.given_m;
        cons_b.push((intra_moves + st.constrained_bound_m) / lb);
        search_r.push((intra_moves + st.constrained_m) / lb);
        opt_r.push((intra_moves + optimal_m) / lb);
        total_opt.push((s.push_distance_m + intra_moves + optimal_m) / (s.lb_push_m + lb));
        eprintln!(
            "seed {seed}: {} moves, DP {} ({} states, {} in the largest layer), study {study_ms:.0} ms; tip / LB_tip: plan {:.3}, search {:.3}, DP {:.3}, bound {:.3}",
            st.moves,
            if st.exact { "exact" } else { "beam" },
            st.dp_states.0,
            st.dp_states.1,
            s.tip_travel_m / lb,
            (intra_moves + st.constrained_m) / lb,
            (intra_moves + optimal_m) / lb,
            (intra_moves + st.constrained_bound_m) / lb,
        );
        plan_r.push(s.tip_travel_m / lb);
        free_r.push(unconstrained_tip / lb);
        lb_gain.push(lb / old_lb);
        total_old.push((s.push_distance_m + s.tip_travel_m) / (s.lb_push_m + old_lb));
        total_new.push((s.push_distance_m + s.tip_travel_m) / (s.lb_push_m + lb));
    }
    let n_layouts = plan_r.len();
    print_spread("plan tip travel / LB_tip", plan_r);
    print_spread("constrained search tip travel / LB_tip", search_r);
    print_spread("constrained optimum (DP) tip travel / LB_tip", opt_r);
    eprintln!("DP exact on {exact} of {n_layouts} layouts (the rest: beam, an upper bound)");
    print_spread("study time per layout, ms", dp_ms);
    print_spread("unconstrained tour tip travel / LB_tip", free_r);
    print_spread("LB_tip / LB_tip with self pairs", lb_gain);
    print_spread("constrained assignment bound / LB_tip", cons_b);
    print_spread("push+tip ratio against the old LB_tip", total_old);
    print_spread("push+tip ratio against LB_tip", total_new);
    print_spread(
        "push+tip ratio with the DP's tour, against LB_tip",
        total_opt,
    );
}

/// The pushes of a plan's steps, in order.
fn pushes_of(steps: &[nanopush::plan::Step]) -> Vec<nanopush::plan::Step> {
    steps
        .iter()
        .filter(|s| matches!(s, nanopush::plan::Step::Push { .. }))
        .cloned()
        .collect()
}

/// What each class of collision constraint costs push+tip on CMU (prints;
/// asserts what must hold): the plan's pushes re-sequenced with the
/// constraints of moving particles where they start dropped (the ceiling of
/// any first leg that clears particles out of other pushes' way, were such
/// legs free of push distance and tip travel), with those where they end
/// dropped, and with every collision dropped. Each relaxed search starts
/// from the constrained search's order, so none may be longer than it.
#[test]
#[ignore = "a study: prints the relaxed tours of docs/plan-history.md's twenty-third pass (about 5 s in release)"]
fn tip_tour_relaxations_on_cmu() {
    use nanopush::plan::{bounds, tour};
    let config = PlanConfig::default();
    let mut ratios: [Vec<f64>; 4] = Default::default();
    let mut tip_bound_over_push_bound = vec![];
    for seed in 0..100u64 {
        let (layout, sites) = cmu_scene(LayoutKind::Uniform, seed);
        let Ok(plan) = plan_assembly(&layout, &sites, &config) else {
            continue;
        };
        let pushes = pushes_of(&plan.steps);
        let st =
            tour::study(&pushes, &layout, None, &config, None).expect("pushes split into moves");
        let tours = [
            st.constrained_m,
            st.without_moving_starts_m,
            st.without_final_places_m,
            st.unconstrained_m,
        ];
        for t in &tours[1..] {
            assert!(
                *t <= st.constrained_m + 1e-12,
                "seed {seed}: a relaxed tour is longer than the constrained one: {st:?}"
            );
        }
        let s = &plan.summary;
        let within_moves_m = s.tip_travel_m - st.given_m;
        let lb_tip = bounds::lb_tip(&pushes, None, &config);
        tip_bound_over_push_bound.push(lb_tip / s.lb_push_m);
        let lb = s.lb_push_m + lb_tip;
        for (r, t) in ratios.iter_mut().zip(tours) {
            r.push((s.push_distance_m + within_moves_m + t) / lb);
        }
    }
    let names = [
        "constrained (the plan's tour searched again)",
        "without moving particles' starts",
        "without moving particles' final places",
        "without any collision",
    ];
    assert_eq!(ratios[0].len(), 100, "every uniform CMU layout plans");
    print_spread("LB_tip / LB_push", tip_bound_over_push_bound);
    for (name, r) in names.into_iter().zip(ratios) {
        let within = r.iter().filter(|&&x| x <= 1.2).count();
        print_spread(
            &format!("push+tip / (LB_push + LB_tip), {name}, {within} <= 1.2"),
            r,
        );
    }
}

/// Prints the median, best and worst of `v` (lower is better).
fn print_spread(name: &str, mut v: Vec<f64>) {
    v.sort_by(f64::total_cmp);
    eprintln!(
        "{name}: median {:.3}, best {:.3}, worst {:.3} ({} layouts)",
        v[v.len() / 2],
        v[0],
        v[v.len() - 1],
        v.len()
    );
}

/// Where the push distance above LB_push goes on CMU: the executed
/// assignment's straight distance above the optimum (repairs that trade
/// sites, re-assignments), and the path above the executed straight lines
/// (detours, buffer pushes, particles pushed off a site first). Also a
/// tighter bound than LB_push: a particle left without a site must still
/// end clear of every site's particle, so the optimal assignment that
/// charges each unassigned particle its least way out
/// ([`parking::clearing_lower_bound`]) bounds every plan's push distance.
#[test]
#[ignore = "a study: prints the push-excess breakdown of docs/plan-history.md (about 10 s in release)"]
fn push_excess_study_on_cmu() {
    let config = PlanConfig::default();
    let (mut assign_x, mut path_x, mut ratio) = (vec![], vec![], vec![]);
    let (mut clearing_lb, mut over_clearing) = (vec![], vec![]);
    let (mut buffers, mut idle_m, mut plan_ms) = (0, 0.0, vec![]);
    for seed in 0..100u64 {
        let (layout, sites) = cmu_scene(LayoutKind::Uniform, seed);
        let Ok(plan) = plan_assembly(&layout, &sites, &config) else {
            continue;
        };
        let by_id = layout.index_by_id();
        let executed: f64 = plan
            .assignment
            .iter()
            .map(|&(pid, sid)| {
                let site = plan.sites.iter().find(|s| s.id == sid).unwrap().centre_m;
                (layout.particles[by_id[&pid]].centre_m - site).norm()
            })
            .sum();
        let s = &plan.summary;
        assert!(
            executed >= s.lb_push_m * (1.0 - 1e-9),
            "seed {seed}: below LB_push"
        );
        let assigned: std::collections::HashSet<u32> =
            plan.assignment.iter().map(|a| a.0).collect();
        for step in &plan.steps {
            if let nanopush::plan::Step::Push {
                particle,
                from_m,
                to_m,
                ..
            } = step
            {
                if !assigned.contains(particle) {
                    idle_m += (to_m - from_m).norm() / s.lb_push_m;
                }
            }
        }
        let lb = lb_push_with_clearing(&layout, &sites);
        assert!(
            lb >= s.lb_push_m * (1.0 - 1e-9) && s.push_distance_m >= lb * (1.0 - 1e-9),
            "seed {seed}: the clearing bound {lb} is not between LB_push {} and the plan's push {}",
            s.lb_push_m,
            s.push_distance_m
        );
        clearing_lb.push(lb / s.lb_push_m);
        over_clearing.push(s.push_distance_m / lb);
        if s.push_distance_m > 1.05 * s.lb_push_m {
            eprintln!(
                "seed {seed}: push / LB_push {:.4}, clearing bound / LB_push {:.4}, push / clearing bound {:.4}",
                s.push_distance_m / s.lb_push_m,
                lb / s.lb_push_m,
                s.push_distance_m / lb
            );
        }
        assign_x.push(executed / s.lb_push_m - 1.0);
        path_x.push((s.push_distance_m - executed) / s.lb_push_m);
        ratio.push(s.push_distance_m / s.lb_push_m);
        buffers += s.buffer_pushes;
        plan_ms.push(s.planning_time_s * 1e3);
    }
    let show = |name: &str, mut v: Vec<f64>| {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        v.sort_by(f64::total_cmp);
        eprintln!(
            "{name}: mean {mean:.4}, median {:.4}, worst {:.4} ({} layouts)",
            v[v.len() / 2],
            v[v.len() - 1],
            v.len()
        );
    };
    show("planning time per layout, ms", plan_ms);
    show("push ratio", ratio);
    show("clearing bound / LB_push", clearing_lb);
    show("push / clearing bound", over_clearing);
    show("executed assignment above LB_push (/ LB_push)", assign_x);
    show("path above the executed straight lines (/ LB_push)", path_x);
    eprintln!("buffer or waypoint pushes: {buffers}");
    eprintln!(
        "pushes of unassigned particles, mean per layout (/ LB_push): {:.4}",
        idle_m / 100.0
    );
}

/// LB_push tightened by the particles left without a site
/// ([`parking::clearing_bound`], touching allowed).
fn lb_push_with_clearing(layout: &Layout, sites: &[Site]) -> f64 {
    let site_pts: Vec<_> = sites.iter().map(|s| s.centre_m).collect();
    let part_pts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
    let r = layout.max_radius_m();
    let reach: Vec<f64> = layout.particles.iter().map(|p| r + p.radius_m).collect();
    parking::clearing_bound(
        &site_pts,
        &part_pts,
        &reach,
        PlanConfig::default().on_site_tolerance_m,
    )
}

/// The executor's loop: plan, execute only the first push (landing a little
/// off target, within the on-site tolerance), re-plan from the new state.
/// Every re-plan must succeed without collisions until the pattern is done
/// (the replay of each plan is asserted collision-free inside).
/// Returns (re-plans, refusals with their reasons).
fn replan_after_every_push(seed: u64, immovable_idle: bool) -> (usize, Vec<String>) {
    use nanopush::plan::Step;
    use rand::{RngExt, SeedableRng};
    let (mut layout, sites) = cmu_scene(LayoutKind::Uniform, seed);
    let mut config = PlanConfig {
        on_site_tolerance_m: 0.1e-6,
        ..PlanConfig::default()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut replans = 0;
    for round in 0..200 {
        let plan = match plan_assembly(&layout, &sites, &config) {
            Ok(plan) => plan,
            Err(e) => return (replans, vec![format!("seed {seed} round {round}: {e}")]),
        };
        replans += 1;
        let rep = verify_plan(&plan, &layout, &config);
        assert!(
            rep.collisions.is_empty(),
            "seed {seed} round {round}: {rep:?}"
        );
        if immovable_idle && round == 0 {
            // Freeze one particle the plan does not use, as the executor does
            // when it gives up on one; one clear of every site's disc (one
            // on a disc makes the pattern infeasible, refused by name:
            // plan::tests::an_immovable_particle_on_a_site_disc_is_refused_by_name).
            let used: Vec<u32> = plan.assignment.iter().map(|a| a.0).collect();
            let clear_of_sites = |q: &&nanopush::plan::Particle| {
                sites
                    .iter()
                    .all(|s| (s.centre_m - q.centre_m).norm() >= 2.0 * q.radius_m)
            };
            if let Some(q) = layout
                .particles
                .iter()
                .filter(clear_of_sites)
                .find(|q| !used.contains(&q.id))
            {
                config.immovable.push(q.id);
            }
        }
        let Some((id, to)) = plan.steps.iter().find_map(|s| match s {
            Step::Push { particle, to_m, .. } => Some((*particle, *to_m)),
            _ => None,
        }) else {
            return (replans, Vec::new());
        };
        let ang: f64 = rng.random::<f64>() * std::f64::consts::TAU;
        let err = 0.05e-6 * rng.random::<f64>();
        let q = layout.particles.iter_mut().find(|q| q.id == id).unwrap();
        q.centre_m = to + nalgebra::Vector2::new(ang.cos(), ang.sin()) * err;
    }
    (
        replans,
        vec![format!("seed {seed}: not done after 200 pushes")],
    )
}

#[test]
fn replanning_after_every_push_finishes_the_pattern() {
    let mut refused = Vec::new();
    let mut replans = 0;
    for seed in 0..6 {
        let (n, r) = replan_after_every_push(seed, seed % 2 == 1);
        replans += n;
        refused.extend(r);
    }
    eprintln!("re-plans {replans}, refused {}: {refused:?}", refused.len());
    assert!(refused.is_empty(), "runs not finished: {refused:?}");
}
