//! Spec section 6 effects: each is switched on by what the scene contains,
//! is reported with a reason, and changes the push the way its model says.

use nanopush::model::{Outcome, PushResult, Scene, simulate_push};
use std::path::Path;

fn paper() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml")).unwrap()
}

fn run(s: &Scene) -> PushResult {
    simulate_push(s, &s.push).unwrap()
}

fn has(r: &PushResult, name: &str) -> bool {
    r.active_effects
        .iter()
        .any(|e| e.name == name && !e.reason.is_empty())
}

const OPTIONAL: [&str; 7] = [
    "capillarity",
    "charge build-up",
    "piezo drift",
    "substrate tilt",
    "spinning",
    "tip riding over",
    "particle-particle contact",
];

#[test]
fn the_paper_scene_switches_on_no_optional_effect() {
    let r = run(&paper());
    for e in OPTIONAL {
        assert!(!has(&r, e), "{e} is active");
    }
    assert!(has(&r, "substrate contact regime") && has(&r, "tip contact regime"));
    // The paper pins the substrate's model (JKR) and leaves the tip's to its
    // Tabor parameter; each reason says which.
    let reason = |name: &str| {
        r.active_effects
            .iter()
            .find(|e| e.name == name)
            .map(|e| e.reason.clone())
            .unwrap()
    };
    let substrate = reason("substrate contact regime");
    assert!(
        substrate.starts_with("jkr (Tabor parameter ")
            // 4.79 is in Maugis-Dugdale's range (below 5): the pin says so.
            && substrate.ends_with(
                ", pinned by scene; the Tabor parameter alone would choose maugis-dugdale)"
            ),
        "{substrate}"
    );
    let tip = reason("tip contact regime");
    assert!(
        tip.contains("(Tabor parameter ") && !tip.contains("pinned"),
        "{tip}"
    );
}

#[test]
fn humidity_adds_a_meniscus_that_delays_onset() {
    let base = run(&paper());
    let mut s = paper();
    s.environment.relative_humidity_percent = 60.0;
    let r = run(&s);
    assert!(has(&r, "capillarity"));
    assert!(r.onset_s.unwrap() > base.onset_s.unwrap());
    s.environment.relative_humidity_percent = 30.0;
    assert!(!has(&run(&s), "capillarity"));
}

#[test]
fn charge_build_up_raises_tip_adhesion_and_delays_onset() {
    // With the paper's 20 nm tip the tip contact is capped at R_t (a/R ~ 1), so
    // more adhesion cannot grow it: use a blunt 500 nm tip to see the effect.
    let mut blunt = paper();
    blunt.tip_radius_m = 500e-9;
    let base = run(&blunt);
    let mut s = blunt.clone();
    s.environment.charge_adhesion_gain = 5.0;
    s.environment.session_time_s = 1800.0;
    let r = run(&s);
    assert!(has(&r, "charge build-up"));
    assert!(r.critical.rolling.or_inf() > base.critical.rolling.or_inf());
    assert!(r.onset_s.unwrap() > base.onset_s.unwrap());
}

/// With the paper's 20 nm tip its contact is capped at R_t: charge build-up
/// changes no force, and the push says so (it had been listed as acting and
/// cost a critical-force solve per sample, 197 us a push for nothing).
#[test]
fn charge_build_up_that_changes_nothing_says_so() {
    let base = run(&paper());
    let mut s = paper();
    s.environment.charge_adhesion_gain = 5.0;
    s.environment.session_time_s = 1800.0;
    let r = run(&s);
    assert!((r.onset_s.unwrap() - base.onset_s.unwrap()).abs() < 1e-9);
    let (a, b) = (r.critical.rolling.or_inf(), base.critical.rolling.or_inf());
    assert!((a - b).abs() <= 1e-12 * b, "{a} vs {b}");
    assert!(
        r.notes
            .iter()
            .any(|n| n.contains("changes no critical force") && n.contains("capped")),
        "{:?}",
        r.notes
    );
    // Where it acts (a blunt tip), no such note.
    let mut blunt = s.clone();
    blunt.tip_radius_m = 500e-9;
    assert!(
        !run(&blunt)
            .notes
            .iter()
            .any(|n| n.contains("changes no critical force"))
    );
}

#[test]
fn forward_drift_brings_onset_earlier() {
    let base = run(&paper());
    let mut s = paper();
    s.environment.drift_m_per_s = 0.1e-6;
    let r = run(&s);
    assert!(has(&r, "piezo drift"));
    assert!(r.onset_s.unwrap() < base.onset_s.unwrap());
}

#[test]
fn substrate_tilt_changes_the_force_angle() {
    let base = run(&paper());
    let mut s = paper();
    s.substrate_tilt_rad = 5f64.to_radians();
    let r = run(&s);
    assert!(has(&r, "substrate tilt"));
    assert!((r.force_angle_rad - base.force_angle_rad - 5f64.to_radians()).abs() < 1e-12);
}

/// A tilt turns the force and the tip's contact normal alike (both are
/// taken from the substrate's normal): the critical forces are those of the
/// untilted criteria at psi + tilt and phi + tilt. With the tilt on psi
/// alone, -30 deg at phi 45 had given F_r* 96.2 uN and "stuck" where the
/// particle rolls at 6.3 uN.
#[test]
fn substrate_tilt_turns_the_force_and_the_contact_normal_alike() {
    use nanopush::model::critical_force::{AreaFidelity, CriticalSetup};
    use nanopush::model::friction::criteria::PushGeometry;
    for tilt_deg in [-30.0f64, 30.0] {
        let mut s = paper();
        s.substrate_tilt_rad = tilt_deg.to_radians();
        let r = run(&s);
        let base = run(&paper());
        let (substrate, tip) = s.interfaces(None);
        let expected = CriticalSetup {
            substrate,
            tip,
            friction: s.friction,
            geometry: PushGeometry {
                psi_rad: base.force_angle_rad + tilt_deg.to_radians(),
                phi_rad: s.push.contact_angle_rad + tilt_deg.to_radians(),
                particle_radius_m: s.particle_radius_m,
                offset_m: 0.0,
            },
            extra_substrate_load_n: 0.0,
            fidelity: AreaFidelity::LoadDependent,
            relative_tolerance: 1e-10,
        }
        .critical_forces()
        .unwrap();
        let (got, want) = (r.critical.rolling.or_inf(), expected.rolling.or_inf());
        assert!(
            (got - want).abs() <= 1e-6 * want.abs(),
            "tilt {tilt_deg}: F_r* {got} vs {want}"
        );
    }
    let mut s = paper();
    s.substrate_tilt_rad = (-30f64).to_radians();
    assert_eq!(run(&s).outcome, Outcome::Rolling);
}

#[test]
fn an_off_axis_push_spins_the_particle() {
    let mut s = paper();
    s.push_offset_m = 4e-6;
    let r = run(&s);
    assert!(has(&r, "spinning"));
    assert_eq!(r.outcome, Outcome::Spinning);
}

#[test]
fn a_neighbour_ahead_ends_the_push_on_contact() {
    let mut s = paper();
    s.neighbour_distances_m = vec![15e-6]; // 5 um free gap
    let r = run(&s);
    assert!(has(&r, "particle-particle contact"));
    assert_eq!(r.outcome, Outcome::ParticleContact);
    assert!(
        (r.displacement_m - 5e-6).abs() < 1e-9,
        "{}",
        r.displacement_m
    );
}

/// A neighbour touching or nearly touching stops the particle where they
/// meet: the drop from the static to the kinetic threshold at onset had
/// carried it 0.09 um on, through the neighbour.
#[test]
fn a_touching_neighbour_is_not_pushed_through() {
    for gap_um in [0.0, 0.05] {
        let mut s = paper();
        s.neighbour_distances_m = vec![(10.0 + gap_um) * 1e-6];
        let r = run(&s);
        assert_eq!(r.outcome, Outcome::ParticleContact, "{gap_um}");
        assert!(
            r.displacement_m <= gap_um * 1e-6 + 1e-12,
            "{gap_um} um gap: moved {} um",
            r.displacement_m * 1e6
        );
    }
}

#[test]
fn a_soft_lever_without_held_angle_rides_over_the_particle() {
    let mut s = paper();
    s.hold_contact_angle = false;
    let r = run(&s);
    assert!(has(&r, "tip riding over"));
    assert_eq!(r.outcome, Outcome::TipSlippedOver);
    assert!(r.ride_over_margin.unwrap() <= 1e-6);
}
