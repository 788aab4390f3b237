//! A batch whose radii spread: the sites are spaced for its median
//! particle, the particles too wide for that spacing are pushed off the
//! sites but never onto one, and when too few fit the refusal says so.

use nalgebra::Vector2;
use nanopush::plan::pattern::transform::Reachable;
use nanopush::plan::pattern_request::PatternRequest;
use nanopush::plan::placement::{PlacementGoal, place_and_plan};
use nanopush::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
use nanopush::plan::{Layout, Particle, PlanConfig, PlanError, Site, plan_assembly, site_radius_m};

/// 50 particles of 5 um with a 5 % spread of radii in a 120 x 100 um field.
fn spread_layout(seed: u64) -> Layout {
    synth_layout(&SynthParams {
        n: 50,
        field_m: [120e-6, 100e-6],
        radius_m: 5e-6,
        min_gap_m: 1e-6,
        polydisperse: true,
        kind: LayoutKind::Uniform,
        seed,
    })
    .unwrap()
}

/// Held at the largest radius (5.4-5.6 um) CMU's sites overlapped, and
/// spaced for it CMU no longer fitted the field: every such layout was
/// refused. Now it plans with the particles that fit, and no wider one
/// ends on a site.
#[test]
fn a_spread_batch_plans_cmu_with_the_particles_that_fit_its_sites() {
    let config = PlanConfig::default();
    for seed in [3, 4] {
        let layout = spread_layout(seed);
        let pattern = PatternRequest::text("CMU")
            .pattern(layout.median_radius_m())
            .unwrap();
        let area = Reachable::for_field(layout.field_m, layout.max_radius_m());
        let placed =
            place_and_plan(&pattern, &area, &layout, &config, PlacementGoal::LeastPush).unwrap();
        let plan = placed.plan.unwrap().unwrap();
        let fit_m = site_radius_m(&layout, &plan.sites, &config);
        let wider = layout
            .particles
            .iter()
            .filter(|p| p.radius_m > fit_m)
            .count();
        assert!(wider > 0, "seed {seed}: no particle wider than {fit_m}");
        for &(particle, site) in &plan.assignment {
            let r = layout
                .particles
                .iter()
                .find(|p| p.id == particle)
                .unwrap()
                .radius_m;
            assert!(
                r <= fit_m,
                "seed {seed}: particle {particle} of {r} m on site {site}"
            );
        }
        let report = nanopush::plan::verify_plan(&plan, &layout, &config);
        assert!(report.ok, "seed {seed}: {}", report.summary());
        // Its widest two would overlap on neighbouring sites.
        assert!(2.0 * layout.max_radius_m() > 2.0 * layout.median_radius_m() + 0.5e-6);
    }
}

fn particle(id: u32, x_um: f64, radius_um: f64) -> Particle {
    Particle {
        id,
        centre_m: Vector2::new(x_um, 20.0) * 1e-6,
        radius_m: radius_um * 1e-6,
    }
}

fn sites_at(xs_um: &[f64]) -> Vec<Site> {
    xs_um
        .iter()
        .enumerate()
        .map(|(i, x)| Site {
            id: i as u32,
            centre_m: Vector2::new(x * 1e-6, 60e-6),
        })
        .collect()
}

#[test]
fn too_few_particles_that_fit_the_sites_are_refused_with_the_pitch_to_change() {
    let layout = Layout {
        field_m: [120e-6, 100e-6],
        particles: vec![
            particle(0, 10.0, 5.3),
            particle(1, 30.0, 4.9),
            particle(2, 50.0, 5.3),
            particle(3, 70.0, 5.0),
        ],
    };
    let sites = sites_at(&[40.0, 50.5, 61.0]);
    match plan_assembly(&layout, &sites, &PlanConfig::default()) {
        Err(e @ PlanError::TooFewFitting { .. }) => {
            let text = e.to_string();
            assert!(text.contains("only 2 free particles fit"), "{text}");
            assert!(
                text.contains("2 more are wider than the 5.075 um"),
                "{text}"
            );
            assert!(text.contains("pitch"), "{text}");
        }
        other => panic!("{other:?}"),
    }
    // A pitch wide enough for them plans.
    let wide = sites_at(&[40.0, 51.0, 62.0]);
    assert!(plan_assembly(&layout, &wide, &PlanConfig::default()).is_ok());
}

#[test]
fn sites_closer_than_the_smallest_particle_overlap() {
    let layout = Layout {
        field_m: [120e-6, 100e-6],
        particles: vec![particle(0, 10.0, 4.0), particle(1, 30.0, 5.0)],
    };
    let err = plan_assembly(&layout, &sites_at(&[40.0, 47.5]), &PlanConfig::default()).unwrap_err();
    assert!(err.to_string().contains("overlap"), "{err}");
}
