//! The paper scene reproduces the source's numbers, and what was not fitted
//! behaves physically (issue 2 acceptance).

use nanopush::model::critical_force::{AreaFidelity, Critical, CriticalSetup};
use nanopush::model::friction::criteria::PushGeometry;
use nanopush::model::mode_machine::Mode;
use nanopush::model::{Outcome, Scene, simulate_push};
use std::path::Path;

fn paper() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml")).unwrap()
}

#[test]
fn paper_scene_rolls_at_9_s_and_3_un_and_moves_21_um() {
    let s = paper();
    let r = simulate_push(&s, &s.push).unwrap();
    assert_eq!(r.outcome, Outcome::Rolling);
    let onset = r.onset_s.unwrap();
    assert!((onset - 9.0).abs() <= 0.5, "onset {onset} s");
    let f = r.force_at_onset_n.unwrap() * 1e6;
    assert!((f - 3.0).abs() <= 0.2, "force at onset {f} uN");
    let d = r.displacement_m * 1e6;
    assert!((d - 21.0).abs() <= 0.5, "displacement {d} um");
}

/// The held angle carries the tip 12.65 um along the sphere by onset, past
/// the top 3.94 um away: said in the notes; with the angle free the push
/// ends when the tip reaches the top, and then nothing needs saying.
#[test]
fn a_held_contact_angle_says_when_the_tip_has_passed_the_top() {
    let s = paper();
    let r = simulate_push(&s, &s.push).unwrap();
    let note = r
        .notes
        .iter()
        .find(|n| n.contains("contact angle held"))
        .unwrap_or_else(|| panic!("no held-angle note in {:?}", r.notes));
    assert!(
        note.contains("past the top") && note.contains("2.81"),
        "{note}"
    );
    let mut free = s.clone();
    free.hold_contact_angle = false;
    let r = simulate_push(&free, &free.push).unwrap();
    assert_eq!(r.outcome, Outcome::TipSlippedOver);
    assert!((r.end_s - 2.81).abs() < 0.01, "{}", r.end_s);
    assert!(!r.notes.iter().any(|n| n.contains("contact angle held")));
    // A short push that stops before the top says nothing either.
    let mut p = s.push;
    p.duration_s = 2.0;
    let r = simulate_push(&s, &p).unwrap();
    assert!(
        !r.notes.iter().any(|n| n.contains("contact angle held")),
        "{:?}",
        r.notes
    );
}

#[test]
fn after_onset_the_particle_follows_the_stage_unfitted() {
    // 21 um = V (30 s - onset) must come out, not be fitted: check it for
    // another duration and speed.
    let s = paper();
    let mut p = s.push;
    p.duration_s = 50.0;
    let r = simulate_push(&s, &p).unwrap();
    let expect = p.speed_m_per_s * (50.0 - r.onset_s.unwrap());
    assert!(
        (r.displacement_m - expect).abs() < 0.02 * expect,
        "{} vs {}",
        r.displacement_m,
        expect
    );
}

#[test]
fn smaller_contact_angle_delays_onset() {
    let s = paper();
    let mut last = 0.0;
    for deg in [60.0, 50.0, 45.0, 40.0, 35.0] {
        let mut p = s.push;
        p.contact_angle_rad = f64::to_radians(deg);
        p.duration_s = 1000.0;
        let t = simulate_push(&s, &p).unwrap().onset_s.unwrap();
        assert!(
            t > last,
            "onset at {deg} deg = {t} s is not later than {last} s"
        );
        last = t;
    }
}

fn mode_at_radius(s: &Scene, r_m: f64) -> Mode {
    let mut s = s.clone();
    s.particle_radius_m = r_m;
    let mut p = s.push;
    p.duration_s = 1e4;
    simulate_push(&s, &p).unwrap().mode
}

#[test]
fn shrinking_the_particle_turns_rolling_into_sliding_near_0_6_um_with_source_parameters() {
    // The spec's ~0.6 um is derived from the source's listed parameters
    // (tau_r = 28 Pa m, force along the contact normal): use those here.
    let mut s = paper();
    s.friction.rolling_shear_n_per_m = 28.0;
    s.tip_friction_coefficient = 0.0;
    assert_eq!(mode_at_radius(&s, 5e-6), Mode::Rolling);
    let mut crossover = None;
    let mut r = 5e-6;
    while r > 0.05e-6 {
        if mode_at_radius(&s, r) == Mode::Sliding {
            crossover = Some(r);
            break;
        }
        r *= 0.97;
    }
    let c = crossover.expect("never slides") * 1e6;
    // Within a factor 1.5 of the spec's ~0.6 um.
    assert!((0.4..=0.9).contains(&c), "crossover at {c} um");
}

#[test]
fn calibrated_scene_also_slides_when_small_and_rolls_when_large() {
    let s = paper();
    assert_eq!(mode_at_radius(&s, 20e-6), Mode::Rolling);
    assert_eq!(mode_at_radius(&s, 5e-6), Mode::Rolling);
    assert_eq!(mode_at_radius(&s, 0.5e-6), Mode::Sliding);
}

#[test]
fn critical_rolling_force_scales_linearly_with_tau_r() {
    let s = paper();
    let (sub, tip) = s.interfaces(None);
    let f_at = |tau_r: f64| {
        let mut friction = s.friction;
        friction.rolling_shear_n_per_m = tau_r;
        let setup = CriticalSetup {
            substrate: sub,
            tip,
            friction,
            geometry: PushGeometry {
                psi_rad: 50f64.to_radians(),
                phi_rad: 45f64.to_radians(),
                particle_radius_m: s.particle_radius_m,
                offset_m: 0.0,
            },
            extra_substrate_load_n: 0.0,
            fidelity: AreaFidelity::ZeroLoad,
            relative_tolerance: 1e-12,
        };
        setup.critical_forces().unwrap().rolling
    };
    let (Critical::Force(a), Critical::Force(b)) = (f_at(10.0), f_at(40.0)) else {
        panic!("locked")
    };
    // With mu_r = 0 and areas at fixed load the relation is exactly linear.
    assert!((b / a - 4.0).abs() < 0.05, "ratio {}", b / a);
}

#[test]
fn critical_rolling_force_with_load_dependent_areas_grows_with_tau_r() {
    let s = paper();
    let mut lo = s.clone();
    lo.friction.rolling_shear_n_per_m = 50.0;
    let a = simulate_push(&lo, &lo.push)
        .unwrap()
        .critical
        .rolling
        .force()
        .unwrap();
    let b = simulate_push(&s, &s.push)
        .unwrap()
        .critical
        .rolling
        .force()
        .unwrap();
    // Load-dependent areas make it super-linear in tau_r (A grows with F).
    assert!(b / a > 1.5, "{a} {b}");
}

#[test]
fn faster_stage_gives_earlier_onset_at_the_same_travel() {
    let s = paper();
    let slow = simulate_push(&s, &s.push).unwrap();
    let mut p = s.push;
    p.speed_m_per_s *= 4.0;
    let fast = simulate_push(&s, &p).unwrap();
    let (ts, tf) = (slow.onset_s.unwrap(), fast.onset_s.unwrap());
    assert!(tf < ts);
    let travel = |t: f64, v: f64| t * v;
    assert!((travel(ts, s.push.speed_m_per_s) - travel(tf, p.speed_m_per_s)).abs() < 1e-9);
}
