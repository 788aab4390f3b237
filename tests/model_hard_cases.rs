//! Every hard case of spec section 5 as a named test returning a typed outcome.

use nanopush::model::cantilever::lateral_force_from_twist;
use nanopush::model::contact::{ContactModel, jkr};
use nanopush::model::critical_force::{AreaFidelity, Critical, CriticalSetup};
use nanopush::model::error::ContactError;
use nanopush::model::friction::criteria::PushGeometry;
use nanopush::model::kinematics::literal_twist;
use nanopush::model::mode_machine::{Mode, ModeMachine};
use nanopush::model::push_sim::{SolverSettings, simulate_push_series, simulate_push_with};
use nanopush::model::units::Radians;
use nanopush::model::{Outcome, Scene, simulate_push};
use std::path::Path;

fn paper() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml")).unwrap()
}

fn setup(s: &Scene, psi_deg: f64, phi_deg: f64) -> CriticalSetup {
    let (substrate, tip) = s.interfaces(None);
    CriticalSetup {
        substrate,
        tip,
        friction: s.friction,
        geometry: PushGeometry {
            psi_rad: psi_deg.to_radians(),
            phi_rad: phi_deg.to_radians(),
            particle_radius_m: s.particle_radius_m,
            offset_m: 0.0,
        },
        extra_substrate_load_n: 0.0,
        fidelity: AreaFidelity::LoadDependent,
        relative_tolerance: 1e-10,
    }
}

#[test]
fn case_1_theta_zero_at_push_start_is_finite() {
    let s = paper();
    let springs = s.cantilever.springs();
    assert_eq!(
        lateral_force_from_twist(&springs, s.cantilever.tip_height_m, Radians(0.0)),
        Some(0.0)
    );
    let (_, rows) = simulate_push_series(&s, &s.push, &SolverSettings::default(), 11).unwrap();
    assert_eq!(rows[0].force_n, 0.0);
    assert!(
        rows.iter()
            .all(|r| r.force_n.is_finite() && r.tip_m.is_finite())
    );
}

#[test]
fn case_2_theta_ninety_reports_lost_contact() {
    // Literal kinematics break at t = H/V: typed refusal, no NaN.
    assert!(literal_twist(12e-6, 12e-6).is_none());
    // A push nothing can move: the tip twists to its limit and loses the particle.
    let mut s = paper();
    s.tip_friction_coefficient = 5.0; // tip locked on the particle: full lateral spring
    s.friction.rolling_shear_n_per_m = 1e9;
    s.friction.shear_strength_pa = 1e15;
    let r = simulate_push(&s, &s.push).unwrap();
    assert_eq!(r.outcome, Outcome::ContactLost);
    assert!(r.end_s > 0.0 && r.end_s < s.push.duration_s && r.end_s.is_finite());
}

#[test]
fn case_3_non_positive_denominators_lock_the_mode() {
    let s = paper();
    // psi below atan(mu) = 38.7 deg: sliding locked; at psi = 20, phi = 45 deg the
    // rolling drive is non-positive too.
    let c = setup(&s, 20.0, 45.0).critical_forces().unwrap();
    assert_eq!(c.sliding, Critical::Locked);
    assert_eq!(c.rolling, Critical::Locked);
    assert_eq!(c.rolling.or_inf(), f64::INFINITY);
    // Exactly at the friction angle: still locked, no division by ~0.
    let c = setup(&s, 0.8f64.atan().to_degrees(), 45.0)
        .critical_forces()
        .unwrap();
    assert_eq!(c.sliding, Critical::Locked);
}

#[test]
fn case_4_below_pull_off_is_detached_and_near_it_parametrised_by_a() {
    let s = paper();
    let (sub, _) = s.interfaces(Some(ContactModel::Jkr));
    let pc = sub.pull_off_n();
    assert!(matches!(
        sub.contact(pc * 1.01),
        Err(ContactError::Detached { .. })
    ));
    // Near pull-off: P(a) is smooth and reproduces the load.
    let a = sub.contact(pc * 0.999999).unwrap().radius_m;
    let p = jkr::load_from_radius(sub.radius_m, sub.k(), sub.work_of_adhesion_j_m2, a);
    assert!((p - pc * 0.999999).abs() < 1e-3 * pc.abs(), "{p} vs {pc}");
    // A push that lifts the particle off: outcome detached.
    let mut s = paper();
    s.substrate_tilt_rad = 30f64.to_radians();
    s.tip_friction_coefficient = 5.0; // psi = 90 deg, +30 deg tilt = 120 deg
    s.friction.rolling_shear_n_per_m = 1e9;
    s.friction.shear_strength_pa = 1e15;
    let r = simulate_push(&s, &s.push).unwrap();
    assert_eq!(r.outcome, Outcome::Detached);
}

#[test]
fn case_5_pushing_force_above_the_plane_gives_negative_substrate_load() {
    let s = paper();
    let st = setup(&s, 100.0, 45.0);
    let loads = st.geometry.loads(1e-6, 0.0);
    assert!(loads.substrate_normal_n < 0.0);
    let c = st.critical_forces().unwrap();
    let fd = c
        .detach
        .force()
        .expect("a lifting push detaches at a finite force");
    assert!(fd.is_finite() && fd > 0.0);
}

#[test]
fn case_6_nanoscale_tip_contact_is_capped_and_said() {
    let s = paper();
    let r = simulate_push(&s, &s.push).unwrap();
    assert!(r.critical.tip_contact_capped);
    assert!(r.notes.iter().any(|n| n.contains("capped")));
    let (_, tip) = s.interfaces(None);
    let c = tip.contact(3e-6).unwrap();
    assert!(c.radius_m <= s.tip_radius_m && c.capped);
}

#[test]
fn case_7_millisecond_onsets_are_bracketed_not_stepped_over() {
    let s = paper();
    let mut p = s.push;
    p.speed_m_per_s = 100e-6; // onset ~ 0.09 s in a 30 s run
    let coarse = simulate_push_with(
        &s,
        &p,
        &SolverSettings {
            samples: 2,
            event_tolerance_s: 1e-9,
            ..Default::default()
        },
    )
    .unwrap();
    let fine = simulate_push_with(
        &s,
        &p,
        &SolverSettings {
            samples: 1024,
            event_tolerance_s: 1e-9,
            ..Default::default()
        },
    )
    .unwrap();
    let (a, b) = (coarse.onset_s.unwrap(), fine.onset_s.unwrap());
    assert!(a < 0.2, "onset {a}");
    assert!((a - b).abs() < 1e-8, "{a} vs {b}");
    // The stiffness ratio k_y/K_z is ~185 here; a stiffer lateral spring still works.
    let mut s2 = s.clone();
    s2.cantilever.tip_height_m = 1.2e-6; // k_y x100: ratio ~1.8e4
    let r = simulate_push(&s2, &p).unwrap();
    assert!(r.onset_s.is_some_and(f64::is_finite));
}

#[test]
fn case_8_near_tie_does_not_chatter() {
    // Sweep the radius across the calibrated rolling/sliding crossover: every
    // push ends in the mode it started with.
    let s = paper();
    for i in 0..20 {
        let mut s = s.clone();
        s.particle_radius_m = (1.4 + 0.02 * i as f64) * 1e-6;
        let r = simulate_push(&s, &s.push).unwrap();
        assert!(matches!(r.mode, Mode::Rolling | Mode::Sliding));
        let (start, _) = ModeMachine::cheapest(&r.critical);
        assert_eq!(start, r.mode, "radius {}", s.particle_radius_m);
    }
}

#[test]
fn case_9_extreme_magnitudes_stay_finite() {
    let mut s = paper();
    s.particle_radius_m = 10e-9;
    s.substrate_interface.reduced_modulus_pa = 500e9;
    s.substrate_interface.work_of_adhesion_j_m2 = 1.0;
    let r = simulate_push(&s, &s.push).unwrap();
    assert!(r.displacement_m.is_finite() && r.critical.rolling.or_inf() > 0.0);
    let (sub, _) = s.interfaces(None);
    let c = sub.contact(1e-15).unwrap();
    assert!(c.radius_m.is_finite() && c.indentation_m.is_finite());
    let mut big = paper();
    big.particle_radius_m = 50e-6;
    big.substrate_interface.reduced_modulus_pa = 0.1e9;
    let r = simulate_push(&big, &big.push).unwrap();
    assert!(r.force_per_travel_n_per_m.is_finite());
}

/// A push longer than any stage's travel (a unit slip in the duration or
/// the speed) is refused by name; at 1e300 s it once overflowed into an
/// onset of 3.9e238 s that looked like a result.
#[test]
fn a_push_longer_than_any_stage_travel_is_refused() {
    use nanopush::model::error::ModelError;
    let s = paper();
    for (duration_s, speed_m_per_s) in [(1e300, s.push.speed_m_per_s), (10.0, 1e300), (2e6, 1e-6)] {
        let mut p = s.push;
        p.duration_s = duration_s;
        p.speed_m_per_s = speed_m_per_s;
        match simulate_push_with(&s, &p, &SolverSettings::default()) {
            Err(ModelError::Push { field, problem }) => {
                assert_eq!(field, "duration_s");
                assert!(problem.contains("unit slip"), "{problem}");
            }
            other => panic!("{duration_s} s at {speed_m_per_s} m/s: {other:?}"),
        }
    }
    let mut p = s.push;
    p.duration_s = 1e5; // 0.1 m at 1 um/s: long, but a push
    p.speed_m_per_s = 1e-6;
    assert!(simulate_push_with(&s, &p, &SolverSettings::default()).is_ok());
    // Drift travels with the stage: 1e15 nm/s had pushed 3e13 um.
    let mut drifting = s.clone();
    drifting.environment.drift_m_per_s = 1e6;
    match simulate_push_with(&drifting, &s.push, &SolverSettings::default()) {
        Err(ModelError::Scene { field, problem }) => {
            assert_eq!(field, "environment.drift_nm_s");
            assert!(problem.contains("unit slip"), "{problem}");
        }
        other => panic!("drift 1e15 nm/s: {other:?}"),
    }
}
