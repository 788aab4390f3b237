//! The executor's API: push advice (contact angle, duration) from the model.

use nanopush::model::advice::{MIN_RIDE_OVER_MARGIN, advise_push};
use nanopush::model::{ModelError, Outcome, PushParams, Scene, simulate_push};
use std::path::Path;

fn paper() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml")).unwrap()
}

/// A scene where the tip may ride over (stiffer lever so that it does not always).
fn ride_over_scene(tau_r: f64) -> Scene {
    let mut s = paper();
    s.hold_contact_angle = false;
    s.cantilever.thickness_m = 3e-6;
    s.friction.shear_strength_pa = 200e6;
    s.friction.rolling_shear_n_per_m = tau_r;
    s
}

#[test]
fn higher_rolling_resistance_gets_a_longer_push() {
    for (lo, hi) in [
        (paper(), {
            let mut s = paper();
            s.friction.rolling_shear_n_per_m *= 2.0;
            s
        }),
        (ride_over_scene(98.5), ride_over_scene(1000.0)),
    ] {
        let a = advise_push(&lo, 10e-6).unwrap();
        let b = advise_push(&hi, 10e-6).unwrap();
        assert!(b.onset_s > a.onset_s, "{} vs {}", b.onset_s, a.onset_s);
        assert!(
            b.duration_s > a.duration_s,
            "{} vs {}",
            b.duration_s,
            a.duration_s
        );
        assert!(b.critical_force_n > a.critical_force_n);
    }
}

#[test]
fn advised_angle_is_the_earliest_safe_onset_and_moves_the_particle_the_distance() {
    let s = ride_over_scene(1000.0);
    let adv = advise_push(&s, 10e-6).unwrap();
    let p = PushParams {
        contact_angle_rad: adv.contact_angle_rad,
        speed_m_per_s: s.push.speed_m_per_s,
        duration_s: adv.duration_s,
    };
    let r = simulate_push(&s, &p).unwrap();
    assert!(matches!(r.outcome, Outcome::Rolling | Outcome::Sliding));
    assert!(
        (r.displacement_m - 10e-6).abs() < 0.05e-6,
        "moved {} um",
        r.displacement_m * 1e6
    );
    assert!(adv.ride_over_margin.unwrap() >= MIN_RIDE_OVER_MARGIN);
    // No other allowed angle is safe with an earlier onset.
    let (lo, hi) = s.angle_range_rad;
    for i in 0..=10 {
        let phi = lo + (hi - lo) * i as f64 / 10.0;
        let r = simulate_push(
            &s,
            &PushParams {
                contact_angle_rad: phi,
                speed_m_per_s: s.push.speed_m_per_s,
                duration_s: 100.0,
            },
        )
        .unwrap();
        let safe = matches!(r.outcome, Outcome::Rolling | Outcome::Sliding)
            && r.ride_over_margin.is_none_or(|m| m >= MIN_RIDE_OVER_MARGIN);
        if safe {
            assert!(
                r.onset_s.unwrap() >= adv.onset_s - 1e-9,
                "{} deg is earlier",
                phi.to_degrees()
            );
        }
    }
}

#[test]
fn riding_over_everywhere_is_a_typed_refusal() {
    let mut s = ride_over_scene(300.0);
    s.cantilever.thickness_m = 1e-6;
    let e = advise_push(&s, 10e-6).unwrap_err();
    assert!(matches!(e, ModelError::NoSafeAngle { .. }), "{e}");
}

#[test]
fn bad_distance_is_refused() {
    assert!(advise_push(&paper(), -1.0).is_err());
    assert!(advise_push(&paper(), f64::NAN).is_err());
}
