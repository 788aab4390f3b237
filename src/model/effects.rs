//! Which effects a scene calls for, and why (spec section 6).
//!
//! Each effect is a switchable part with a deliberately simple model; the
//! scene's content decides whether it is on. An inactive effect is `None`
//! here and the simulation never evaluates it, so it costs nothing per step.
//!
//! | effect | on when | model and limits |
//! |---|---|---|
//! | cantilever bending + torsion | always | eq. (1) springs, linear (kinematics.rs) |
//! | contact regime | always, per interface | Tabor choice or pinned (contact/) |
//! | rolling, sliding | always | margin criteria, load-dependent areas |
//! | stick-slip hysteresis | always | static vs kinetic thresholds (mode_machine.rs) |
//! | spinning | `push.offset_um != 0` | uniform-pressure friction moment (2/3) a (mu F + tau A); the real pressure shifts 2/3 by <~20 % |
//! | tip riding over | `push.hold_contact_angle = false` | tip slip along the sphere vs the arc to the top, (R_p + R_t) phi; small-displacement geometry |
//! | particle-particle contact | `[[neighbours]]` present | the pushed sphere reaching a neighbour's surface ends the push (outcome `particle-contact`) |
//! | charge build-up | `environment.charge_adhesion_gain > 0` | W_tip(t) = W (1 + g (1 - exp(-t_session/tau))); phenomenological, from the reported ~30 min sticking; no effect while the tip contact is capped at R_t |
//! | capillarity | RH > 40 % | saturated meniscus F = 4 pi R gamma cos(theta_c) added to the substrate load (Israelachvili); ignores meniscus kinetics and the RH dependence above threshold |
//! | piezo drift | `environment.drift_nm_s != 0` | constant drift added to stage travel; creep folded into it |
//! | substrate tilt | `substrate.tilt_deg != 0` | rotates the force angle and the tip's contact normal, as the substrate sees them, by the tilt (the tip's friction cone is unchanged; until 2026-11-29 the force alone, which put 0.93 of friction on a tip of 0.23); gravity neglected (1e-11 N for 5 um PS) |

use super::contact::Interface;
use super::scene::Scene;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Surface tension of water [N/m].
pub const WATER_SURFACE_TENSION_N_PER_M: f64 = 0.072;
/// Humidity above which a meniscus is assumed to form [%].
pub const CAPILLARY_HUMIDITY_THRESHOLD_PERCENT: f64 = 40.0;

/// An effect the simulation applies, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActiveEffect {
    /// Effect name.
    pub name: String,
    /// Why the scene calls for it (or the regime chosen).
    pub reason: String,
}

/// Charge build-up parameters (active only when present).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChargeBuildUp {
    /// Fractional W rise at saturation.
    pub gain: f64,
    /// Time constant (s).
    pub time_constant_s: f64,
    /// Session time before the push (s).
    pub session_time_s: f64,
}

impl ChargeBuildUp {
    /// Multiplier of the tip-particle work of adhesion at push time `t_s`.
    pub fn adhesion_factor(&self, t_s: f64) -> f64 {
        1.0 + self.gain * (1.0 - (-(self.session_time_s + t_s) / self.time_constant_s).exp())
    }
}

/// The decided effects of one push.
#[derive(Debug, Clone, PartialEq)]
pub struct Effects {
    /// Capillary meniscus force on the substrate contact (N).
    pub capillary_force_n: Option<f64>,
    /// Charge build-up on the tip contact.
    pub charge: Option<ChargeBuildUp>,
    /// Piezo drift along the push [m/s].
    pub drift_m_per_s: Option<f64>,
    /// Substrate tilt (rad).
    pub tilt_rad: Option<f64>,
    /// Spinning arm (m).
    pub spin_offset_m: Option<f64>,
    /// Tip riding over is simulated.
    pub tip_ride_over: bool,
    /// Free travel before touching the nearest neighbour (m).
    pub neighbour_gap_m: Option<f64>,
    /// The active effects with reasons (for the report).
    pub active: Vec<ActiveEffect>,
}

fn fx(name: &str, reason: String) -> ActiveEffect {
    ActiveEffect {
        name: name.into(),
        reason,
    }
}

/// An interface's contact model and why: its Tabor parameter, or the scene's pin.
/// A pin the Tabor parameter disagrees with is said (the nanoparticle
/// scene pins JKR at a Tabor parameter of 1.87, Maugis-Dugdale's range).
fn regime(interface: &Interface, pinned: bool) -> String {
    let by_tabor =
        super::contact::tabor::regime_for(interface.tabor, interface.work_of_adhesion_j_m2);
    let pin = match (pinned, by_tabor == interface.model) {
        (false, _) => String::new(),
        (true, true) => ", pinned by scene".to_string(),
        (true, false) => format!(
            ", pinned by scene; the Tabor parameter alone would choose {}",
            by_tabor.name()
        ),
    };
    format!(
        "{} (Tabor parameter {:.2}{pin})",
        interface.model.name(),
        interface.tabor
    )
}

/// Decides the effects of `scene` with the interfaces in use.
pub fn decide(scene: &Scene, substrate: &Interface, tip: &Interface) -> Effects {
    let mut active = vec![
        fx(
            "cantilever bending + torsion",
            "always: the probe is a spring".into(),
        ),
        fx(
            "substrate contact regime",
            regime(substrate, scene.substrate_interface.pinned_model.is_some()),
        ),
        fx(
            "tip contact regime",
            regime(tip, scene.tip_interface.pinned_model.is_some()),
        ),
        fx(
            "rolling and sliding",
            "always: the criteria decide which starts first".into(),
        ),
        fx(
            "stick-slip hysteresis",
            format!(
                "kinetic/static ratios rolling {:.2}, sliding {:.2}",
                scene.motion.rolling_kinetic_ratio, scene.motion.sliding_kinetic_ratio
            ),
        ),
    ];
    let env = &scene.environment;
    let capillary_force_n = (env.relative_humidity_percent > CAPILLARY_HUMIDITY_THRESHOLD_PERCENT).then(|| {
        let f = 4.0 * PI * scene.particle_radius_m * WATER_SURFACE_TENSION_N_PER_M * env.water_contact_angle_rad.cos().max(0.0);
        active.push(fx("capillarity", format!("humidity {:.0} % > {CAPILLARY_HUMIDITY_THRESHOLD_PERCENT:.0} %: meniscus adds {:.3} uN", env.relative_humidity_percent, f * 1e6)));
        f
    });
    let charge = (env.charge_adhesion_gain > 0.0).then(|| {
        let c = ChargeBuildUp {
            gain: env.charge_adhesion_gain,
            time_constant_s: env.charge_time_constant_s,
            session_time_s: env.session_time_s,
        };
        active.push(fx(
            "charge build-up",
            format!(
                "session at {:.1} min: tip adhesion x{:.2}",
                env.session_time_s / 60.0,
                c.adhesion_factor(0.0)
            ),
        ));
        c
    });
    let drift_m_per_s = (env.drift_m_per_s != 0.0).then(|| {
        active.push(fx(
            "piezo drift",
            format!("{:.2} nm/s along the push", env.drift_m_per_s * 1e9),
        ));
        env.drift_m_per_s
    });
    let tilt_rad = (scene.substrate_tilt_rad != 0.0).then(|| {
        active.push(fx(
            "substrate tilt",
            format!(
                "{:.2} deg along the push",
                scene.substrate_tilt_rad.to_degrees()
            ),
        ));
        scene.substrate_tilt_rad
    });
    let spin_offset_m = (scene.push_offset_m != 0.0).then(|| {
        active.push(fx(
            "spinning",
            format!(
                "push line {:.2} um off the particle centre",
                scene.push_offset_m * 1e6
            ),
        ));
        scene.push_offset_m
    });
    let tip_ride_over = !scene.hold_contact_angle;
    if tip_ride_over {
        active.push(fx(
            "tip riding over",
            "push.hold_contact_angle = false: the tip may climb over the particle".into(),
        ));
    }
    let neighbour_gap_m = scene
        .neighbour_distances_m
        .iter()
        .map(|d| d - 2.0 * scene.particle_radius_m)
        .fold(None, |m: Option<f64>, g| Some(m.map_or(g, |m| m.min(g))))
        .map(|g| {
            active.push(fx(
                "particle-particle contact",
                format!("neighbour ahead, free gap {:.2} um", g * 1e6),
            ));
            g.max(0.0)
        });
    Effects {
        capillary_force_n,
        charge,
        drift_m_per_s,
        tilt_rad,
        spin_offset_m,
        tip_ride_over,
        neighbour_gap_m,
        active,
    }
}
