//! The pushing model as the simulated world's physics: each contact is one
//! simulated push of the scene, with the particle's radius, the contact angle
//! the tip height gives, the stage speed and the session time of that contact.

use super::world::{ContactQuery, ContactResponse, PushPhysics};
use crate::model::{Outcome, PushParams, Scene, simulate_push};
use std::cell::RefCell;
use std::collections::BTreeMap;

/// Contact angles are kept inside the model's open interval (0, 90) deg.
const ANGLE_MARGIN_RAD: f64 = 1e-3;

/// Answers contacts with [`simulate_push`] on a scene, counting per effect
/// the contacts whose simulation evaluated it (the model evaluates exactly the
/// effects it reports active).
#[derive(Debug, Clone)]
pub struct ModelPhysics {
    scene: Scene,
    work: RefCell<BTreeMap<String, u64>>,
}

impl ModelPhysics {
    /// Physics of this scene (probe, materials, environment).
    pub fn new(scene: Scene) -> Self {
        Self {
            scene,
            work: RefCell::new(BTreeMap::new()),
        }
    }
}

impl PushPhysics for ModelPhysics {
    fn respond(&self, q: &ContactQuery) -> ContactResponse {
        let mut scene = self.scene.clone();
        scene.particle_radius_m = q.radius_m;
        scene.environment.session_time_s += q.session_time_s;
        let angle = q.contact_angle_rad.clamp(
            ANGLE_MARGIN_RAD,
            std::f64::consts::FRAC_PI_2 - ANGLE_MARGIN_RAD,
        );
        let params = PushParams {
            contact_angle_rad: angle,
            speed_m_per_s: q.speed_m_per_s,
            duration_s: q.travel_after_contact_m / q.speed_m_per_s,
        };
        let result = simulate_push(&scene, &params);
        if let Ok(r) = &result {
            let mut work = self.work.borrow_mut();
            for e in &r.active_effects {
                *work.entry(e.name.clone()).or_insert(0) += 1;
            }
        }
        match result {
            Ok(r) if matches!(r.outcome, Outcome::Rolling | Outcome::Sliding) => {
                ContactResponse::Moves {
                    onset_travel_m: (q.travel_after_contact_m - r.displacement_m).max(0.0),
                }
            }
            // Stuck, detached, tip over, contact lost: the particle stays and the
            // tip passes over it. A push the model refuses is treated alike.
            _ => ContactResponse::Stays,
        }
    }

    fn effect_work(&self) -> BTreeMap<String, u64> {
        self.work.borrow().clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn paper() -> Scene {
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml")).unwrap()
    }

    #[test]
    fn the_paper_push_starts_after_about_nine_micrometres_of_travel() {
        let physics = ModelPhysics::new(paper());
        let q = ContactQuery {
            radius_m: 5e-6,
            contact_angle_rad: 45f64.to_radians(),
            speed_m_per_s: 1e-6,
            travel_after_contact_m: 30e-6,
            session_time_s: 0.0,
        };
        match physics.respond(&q) {
            ContactResponse::Moves { onset_travel_m } => {
                assert!(
                    (onset_travel_m - 9e-6).abs() < 0.5e-6,
                    "onset travel {onset_travel_m}"
                )
            }
            other => panic!("expected motion, got {other:?}"),
        }
    }

    #[test]
    fn a_stroke_too_short_to_reach_onset_moves_nothing() {
        let physics = ModelPhysics::new(paper());
        let q = ContactQuery {
            radius_m: 5e-6,
            contact_angle_rad: 45f64.to_radians(),
            speed_m_per_s: 1e-6,
            travel_after_contact_m: 4e-6,
            session_time_s: 0.0,
        };
        assert_eq!(physics.respond(&q), ContactResponse::Stays);
    }
}
