//! The simulated rig's physical world: spheres on a flat substrate and the
//! probe tip that the nanostage sweeps through them.
//!
//! Geometry is done here; how long the cantilever loads before a particle
//! starts to move, and whether the tip rides over it instead, is asked of a
//! [`PushPhysics`] (the pushing model, in the rig). Two failure modes are
//! geometric and live here:
//!
//! * **Turning around the tip.** The tip is a point on the sphere's horizontal
//!   cross-section at the tip's height. A push whose line misses the centre
//!   by `b` meets the surface at the angle `asin(b / r_c)` from the push line.
//!   Inside the tip-particle friction cone (`atan mu_tip`) the contact sticks and
//!   the particle is carried straight; outside it the contact slides, the
//!   particle moves along the contact normal, drifts sideways and leaves the
//!   line (quasi-static point pushing of a disc; Mason, "Mechanics of pushing",
//!   1986). Integrated in small steps of travel.
//! * **Particle-particle contact.** A carried particle that meets another stops
//!   there, touching it (no chain pushing: the simple, conservative choice), and
//!   the tip slides off it: a lost contact.

use super::super::stage::StageXyz;

/// A sphere lying on the substrate, as the world knows it (ground truth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimParticle {
    /// Identity in the world (ground truth, never shown to the executor).
    pub id: usize,
    /// Centre x, metres.
    pub x_m: f64,
    /// Centre y, metres.
    pub y_m: f64,
    /// Radius, metres.
    pub radius_m: f64,
}

/// What the physics is asked about one contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactQuery {
    /// Particle radius, metres.
    pub radius_m: f64,
    /// Contact angle from the substrate normal, from the tip height.
    pub contact_angle_rad: f64,
    /// Stage speed during the push.
    pub speed_m_per_s: f64,
    /// Stage travel left after the tip touched the particle.
    pub travel_after_contact_m: f64,
    /// Seconds since the session started (charge build-up grows with it).
    pub session_time_s: f64,
}

/// The physics' answer for one contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactResponse {
    /// The particle starts to move after this much stage travel and then follows.
    Moves { onset_travel_m: f64 },
    /// The particle does not move during this travel (the stroke ends before
    /// onset, or the tip rides over it).
    Stays,
}

/// The pushing model as the world needs it.
pub trait PushPhysics {
    /// Answers one contact.
    fn respond(&self, query: &ContactQuery) -> ContactResponse;
    /// Contacts so far that evaluated each effect (name -> count), so a test
    /// can see that an effect a scene turns off did no work; empty when the
    /// physics does not count.
    fn effect_work(&self) -> std::collections::BTreeMap<String, u64> {
        std::collections::BTreeMap::new()
    }
}

/// How a contact ended, as ground truth for tests and reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactOutcome {
    /// Carried to the end of the stroke.
    Carried,
    /// Never moved: the tip brushed over it or let go before onset.
    LeftBehind,
    /// Slid off the tip sideways and left the push line.
    TurnedAroundTip,
    /// Stopped against another particle.
    Blocked { by: usize },
}

/// One contact during a sweep, for the ground-truth log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactEvent {
    /// Which particle was touched.
    pub particle: usize,
    /// Where its centre was when the tip touched it, metres (tells the
    /// particle a push aimed at from one the tip met on the way).
    pub at_m: [f64; 2],
    /// How far it moved, metres.
    pub moved_m: f64,
    /// How the contact ended.
    pub outcome: ContactOutcome,
}

impl ContactEvent {
    /// True when the particle did not follow the tip to the end of the stroke.
    pub fn lost_contact(&self) -> bool {
        self.outcome != ContactOutcome::Carried
    }
}

/// Particles and the tip.
#[derive(Debug, Clone)]
pub struct World {
    /// Every particle on the substrate.
    pub particles: Vec<SimParticle>,
    /// Tangent of the tip-particle friction angle (sticking cone half-angle).
    pub tip_friction: f64,
}

/// Travel per integration step while a contact slides, as a fraction of the radius.
const SLIDE_STEP_FRACTION: f64 = 0.02;

impl World {
    /// Sweeps the tip in a straight line at height `from[2]` (= `to[2]`) and
    /// lets it push what it meets. Returns the contacts, in order.
    pub fn sweep(
        &mut self,
        from: StageXyz,
        to: StageXyz,
        speed_m_per_s: f64,
        session_time_s: f64,
        physics: &dyn PushPhysics,
    ) -> Vec<ContactEvent> {
        let z = from[2].min(to[2]);
        let mut start = [from[0], from[1]];
        let end = [to[0], to[1]];
        let mut events = Vec::new();
        // Each particle is pushed at most once per stroke: after a contact ends
        // the tip is past it or above it.
        let mut touched: Vec<usize> = Vec::new();
        while let Some((index, s_contact)) = self.first_hit(start, end, z, &touched) {
            let p = self.particles[index];
            let total = dist(start, end);
            let u = [(end[0] - start[0]) / total, (end[1] - start[1]) / total];
            let contact_tip = [start[0] + u[0] * s_contact, start[1] + u[1] * s_contact];
            let travel = total - s_contact;
            let query = ContactQuery {
                radius_m: p.radius_m,
                contact_angle_rad: contact_angle_at_height(z, p.radius_m),
                speed_m_per_s,
                travel_after_contact_m: travel,
                session_time_s,
            };
            touched.push(index);
            let event = match physics.respond(&query) {
                ContactResponse::Stays => ContactEvent {
                    particle: p.id,
                    at_m: [p.x_m, p.y_m],
                    moved_m: 0.0,
                    outcome: ContactOutcome::LeftBehind,
                },
                ContactResponse::Moves { onset_travel_m } if onset_travel_m >= travel => {
                    ContactEvent {
                        particle: p.id,
                        at_m: [p.x_m, p.y_m],
                        moved_m: 0.0,
                        outcome: ContactOutcome::Carried,
                    }
                }
                ContactResponse::Moves { onset_travel_m } => {
                    let tip_at_onset = [
                        contact_tip[0] + u[0] * onset_travel_m,
                        contact_tip[1] + u[1] * onset_travel_m,
                    ];
                    self.carry(index, tip_at_onset, u, travel - onset_travel_m, z)
                }
            };
            events.push(event);
            start = contact_tip;
        }
        events
    }

    /// The particle (its id) the apex comes down on when lowered from above
    /// at `xy` to height `z`: one whose sphere reaches above `z` there. The
    /// world moves nothing for it (how a tip landing on a particle knocks it
    /// is not modelled); the stage logs it as ground truth, so that a test
    /// can tell the executor lowered the tip where its plan had not checked.
    pub fn landed_on(&self, xy: [f64; 2], z: f64) -> Option<usize> {
        self.particles
            .iter()
            .find(|p| {
                let d = dist(xy, [p.x_m, p.y_m]);
                d < p.radius_m && z < p.radius_m + (p.radius_m * p.radius_m - d * d).sqrt()
            })
            .map(|p| p.id)
    }

    /// The first particle the tip meets on start -> end at height z, not yet touched.
    fn first_hit(
        &self,
        start: [f64; 2],
        end: [f64; 2],
        z: f64,
        skip: &[usize],
    ) -> Option<(usize, f64)> {
        let total = dist(start, end);
        if total <= 0.0 {
            return None;
        }
        let u = [(end[0] - start[0]) / total, (end[1] - start[1]) / total];
        let mut best: Option<(usize, f64)> = None;
        for (i, p) in self.particles.iter().enumerate() {
            if skip.contains(&i) {
                continue;
            }
            let Some(rc) = section_radius(z, p.radius_m) else {
                continue;
            };
            let w = [p.x_m - start[0], p.y_m - start[1]];
            let along = w[0] * u[0] + w[1] * u[1];
            let offset = u[0] * w[1] - u[1] * w[0];
            if offset.abs() >= rc {
                continue;
            }
            let s = (along - (rc * rc - offset * offset).sqrt()).max(0.0);
            let still_ahead = along + rc > 0.0;
            if s < total && still_ahead && best.is_none_or(|(_, b)| s < b) {
                best = Some((i, s));
            }
        }
        best
    }

    /// Moves particle `index` with the tip from `tip` along `u` for `travel`.
    fn carry(
        &mut self,
        index: usize,
        mut tip: [f64; 2],
        u: [f64; 2],
        travel: f64,
        z: f64,
    ) -> ContactEvent {
        let p0 = self.particles[index];
        let rc = section_radius(z, p0.radius_m).unwrap_or(p0.radius_m);
        let step = (p0.radius_m * SLIDE_STEP_FRACTION).max(1e-12);
        let mut left = travel;
        let mut outcome = ContactOutcome::Carried;
        while left > 0.0 {
            let ds = step.min(left);
            left -= ds;
            tip = [tip[0] + u[0] * ds, tip[1] + u[1] * ds];
            let p = self.particles[index];
            let mut n = [p.x_m - tip[0], p.y_m - tip[1]];
            let gap = n[0].hypot(n[1]);
            if gap >= rc || (p.x_m - tip[0]) * u[0] + (p.y_m - tip[1]) * u[1] <= 0.0 {
                // The particle slid round to the side of the tip: contact lost.
                outcome = ContactOutcome::TurnedAroundTip;
                break;
            }
            n = [n[0] / gap, n[1] / gap];
            let cos_contact = n[0] * u[0] + n[1] * u[1];
            let sticking = cos_contact > 0.0
                && (1.0 - cos_contact * cos_contact).sqrt() <= self.tip_friction * cos_contact;
            // Sticking: carried with the tip. Sliding: pushed out along the normal
            // just far enough to keep the tip on its surface.
            let target = if sticking {
                [p.x_m + u[0] * ds, p.y_m + u[1] * ds]
            } else {
                [tip[0] + n[0] * rc, tip[1] + n[1] * rc]
            };
            if let Some(by) = self.blocker(index, target) {
                outcome = ContactOutcome::Blocked { by };
                break;
            }
            self.particles[index].x_m = target[0];
            self.particles[index].y_m = target[1];
        }
        let p = self.particles[index];
        ContactEvent {
            particle: p.id,
            at_m: [p0.x_m, p0.y_m],
            moved_m: dist([p.x_m, p.y_m], [p0.x_m, p0.y_m]),
            outcome,
        }
    }

    /// Another particle that `index` would overlap at `target`.
    fn blocker(&self, index: usize, target: [f64; 2]) -> Option<usize> {
        let r = self.particles[index].radius_m;
        self.particles
            .iter()
            .enumerate()
            .find(|(i, q)| *i != index && dist(target, [q.x_m, q.y_m]) < r + q.radius_m)
            .map(|(_, q)| q.id)
    }
}

/// Contact angle from the substrate normal for a tip apex at height `z` on a
/// sphere of radius `r`: the contact normal points from the centre (height r)
/// to the apex. Below the equator the tip pushes horizontally (90 deg).
pub fn contact_angle_at_height(z: f64, r: f64) -> f64 {
    ((z - r) / r).clamp(0.0, 1.0).acos()
}

/// The tip height that gives contact angle `angle_rad` on a sphere of radius `r`.
pub fn height_for_contact_angle(angle_rad: f64, r: f64) -> f64 {
    r * (1.0 + angle_rad.cos())
}

/// Radius of the sphere's horizontal cross-section at height z, if the tip there can touch it.
fn section_radius(z: f64, r: f64) -> Option<f64> {
    let h = z - r;
    (z >= 0.0 && h.abs() < r).then(|| (r * r - h * h).sqrt())
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 5e-6;

    struct FixedOnset(f64);
    impl PushPhysics for FixedOnset {
        fn respond(&self, _: &ContactQuery) -> ContactResponse {
            ContactResponse::Moves {
                onset_travel_m: self.0,
            }
        }
    }
    struct NeverMoves;
    impl PushPhysics for NeverMoves {
        fn respond(&self, _: &ContactQuery) -> ContactResponse {
            ContactResponse::Stays
        }
    }

    fn world(ps: &[(f64, f64)]) -> World {
        World {
            particles: ps
                .iter()
                .enumerate()
                .map(|(id, &(x, y))| SimParticle {
                    id,
                    x_m: x * 1e-6,
                    y_m: y * 1e-6,
                    radius_m: R,
                })
                .collect(),
            tip_friction: 0.3,
        }
    }

    fn z45() -> f64 {
        height_for_contact_angle(std::f64::consts::FRAC_PI_4, R)
    }

    #[test]
    fn a_tip_lowered_within_a_spheres_outline_below_its_surface_lands_on_it() {
        let w = world(&[(50.0, 50.0)]);
        // 3 um from the centre the surface is 5 + 4 = 9 um up.
        assert_eq!(w.landed_on([53e-6, 50e-6], 8.9e-6), Some(0));
        assert_eq!(w.landed_on([53e-6, 50e-6], 9.1e-6), None);
        // Beside the sphere the tip comes down to the substrate.
        assert_eq!(w.landed_on([55.1e-6, 50e-6], 0.0), None);
        assert_eq!(w.landed_on([50e-6, 54.9e-6], 5e-6), Some(0));
    }

    #[test]
    fn contact_angle_and_height_are_inverse() {
        for deg in [5.0_f64, 30.0, 45.0, 80.0, 90.0] {
            let a = deg.to_radians();
            let back = contact_angle_at_height(height_for_contact_angle(a, R), R);
            assert!((back - a).abs() < 1e-12, "{deg} deg came back as {back}");
        }
    }

    #[test]
    fn a_centred_push_carries_the_particle_by_travel_minus_onset() {
        let mut w = world(&[(20.0, 0.0)]);
        let z = z45();
        let rc = section_radius(z, R).unwrap();
        let ev = w.sweep([0.0, 0.0, z], [40e-6, 0.0, z], 1e-6, 0.0, &FixedOnset(3e-6));
        assert_eq!(ev.len(), 1);
        assert_eq!(ev[0].outcome, ContactOutcome::Carried);
        let travel_after_contact = 40e-6 - (20e-6 - rc);
        let expected = travel_after_contact - 3e-6;
        assert!(
            (ev[0].moved_m - expected).abs() < 1e-9,
            "moved {} expected {expected}",
            ev[0].moved_m
        );
        assert!(w.particles[0].y_m.abs() < 1e-12);
    }

    #[test]
    fn a_push_far_off_centre_turns_the_particle_around_the_tip() {
        let mut w = world(&[(20.0, 2.8)]);
        let z = z45();
        let ev = w.sweep([0.0, 0.0, z], [40e-6, 0.0, z], 1e-6, 0.0, &FixedOnset(0.0));
        assert_eq!(ev[0].outcome, ContactOutcome::TurnedAroundTip);
        assert!(
            w.particles[0].y_m > 2.8e-6,
            "the particle should leave the line sideways"
        );
    }

    #[test]
    fn a_slightly_off_centre_push_inside_the_friction_cone_still_carries() {
        let mut w = world(&[(20.0, 0.3)]);
        let z = z45();
        let ev = w.sweep([0.0, 0.0, z], [40e-6, 0.0, z], 1e-6, 0.0, &FixedOnset(0.0));
        assert_eq!(ev[0].outcome, ContactOutcome::Carried);
        assert!((w.particles[0].y_m - 0.3e-6).abs() < 1e-12);
    }

    #[test]
    fn a_particle_that_never_starts_is_ridden_over_and_stays() {
        let mut w = world(&[(20.0, 0.0)]);
        let z = z45();
        let ev = w.sweep([0.0, 0.0, z], [40e-6, 0.0, z], 1e-6, 0.0, &NeverMoves);
        assert_eq!(ev[0].outcome, ContactOutcome::LeftBehind);
        assert_eq!(w.particles[0], world(&[(20.0, 0.0)]).particles[0]);
    }

    #[test]
    fn a_carried_particle_stops_against_another() {
        let mut w = world(&[(20.0, 0.0), (40.0, 0.0)]);
        let z = z45();
        // The stroke ends before the tip, riding over the blocked particle, reaches the other.
        let ev = w.sweep([0.0, 0.0, z], [35e-6, 0.0, z], 1e-6, 0.0, &FixedOnset(0.0));
        assert_eq!(ev.len(), 1);
        assert_eq!(ev[0].outcome, ContactOutcome::Blocked { by: 1 });
        let gap = w.particles[1].x_m - w.particles[0].x_m;
        assert!(
            (2.0 * R..2.0 * R + 0.2e-6).contains(&gap),
            "stopped {gap} m apart"
        );
        assert_eq!(
            w.particles[1],
            world(&[(20.0, 0.0), (40.0, 0.0)]).particles[1],
            "no chain pushing"
        );
    }

    #[test]
    fn a_tip_above_the_particles_touches_nothing() {
        let mut w = world(&[(20.0, 0.0)]);
        let z = 2.0 * R + 1e-6;
        let ev = w.sweep([0.0, 0.0, z], [40e-6, 0.0, z], 1e-6, 0.0, &FixedOnset(0.0));
        assert!(ev.is_empty());
    }
}
