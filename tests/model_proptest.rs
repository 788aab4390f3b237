//! Wide-range property test of the push simulation (issue 2 acceptance):
//! no NaN; the pushing force is continuous and non-decreasing before onset;
//! the onset lies inside the run or is reported as none.

use nanopush::model::push_sim::{SolverSettings, simulate_push_series};
use nanopush::model::{PushParams, Scene};
use proptest::prelude::*;
use std::path::Path;

fn paper() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml")).unwrap()
}

fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo.ln()..hi.ln()).prop_map(f64::exp)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]
    #[test]
    fn push_is_finite_monotone_before_onset_and_onset_in_run(
        radius in log_uniform(10e-9, 50e-6),
        work in log_uniform(0.001, 1.0),
        e_star in log_uniform(0.1e9, 500e9),
        angle_deg in 1.0f64..89.0,
        speed in log_uniform(1e-9, 100e-6),
        mu in 0.0f64..2.0,
    ) {
        let mut s = paper();
        s.particle_radius_m = radius;
        for i in [&mut s.substrate_interface, &mut s.tip_interface] {
            i.work_of_adhesion_j_m2 = work;
            i.reduced_modulus_pa = e_star;
        }
        s.friction.sliding_coefficient = mu;
        let p = PushParams { contact_angle_rad: angle_deg.to_radians(), speed_m_per_s: speed, duration_s: 30.0 };
        let (r, rows) = simulate_push_series(&s, &p, &SolverSettings::default(), 64).unwrap();
        prop_assert!(r.displacement_m.is_finite() && r.force_at_end_n.is_finite() && r.end_s.is_finite());
        prop_assert!(!r.force_angle_rad.is_nan() && r.force_per_travel_n_per_m.is_finite());
        if let Some(t) = r.onset_s {
            prop_assert!((0.0..=p.duration_s).contains(&t), "onset {} outside the run", t);
            prop_assert!(r.force_at_onset_n.is_some_and(f64::is_finite));
        }
        let onset = r.onset_s.unwrap_or(f64::INFINITY);
        let max_step = r.force_per_travel_n_per_m * speed * (r.end_s / 63.0) * (1.0 + 1e-9) + 1e-30;
        for w in rows.windows(2) {
            prop_assert!(!w[0].force_n.is_nan() && !w[0].particle_m.is_nan() && !w[0].tip_m.is_nan());
            if w[1].t_s <= onset {
                prop_assert!(w[1].force_n >= w[0].force_n, "force decreased before onset");
                prop_assert!(w[1].force_n - w[0].force_n <= max_step, "force jumped before onset");
            }
        }
    }
}
