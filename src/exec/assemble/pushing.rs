//! One push: the pushing model's contact angle and duration for the
//! particle as measured, the stroke laid out, and the stage moved.

use super::miss_lead::led;
use super::stage_moves::{retreat_clear_of_probe, retreat_point};
use super::{Assembly, PushError, PushIntent, PushRecord};
use crate::exec::events::RunEvent;
use crate::exec::journal::JournalError;
use crate::exec::stroke::{StrokeError, StrokeRequest, plan_stroke};
use crate::exec::travel_height::clear_height_m;
use crate::model::advice::{PushAdvice, advise_push};
use crate::model::{ModelError, Scene};

impl Assembly<'_> {
    /// Asks the model, lays out the stroke, moves the stage.
    pub(super) fn push(&mut self, intent: &PushIntent) -> Result<(), PushError> {
        let scene = scene_for_push(&self.scene, intent.radius_m, self.rig.now_s());
        let advice = decide_push(&self.scene, intent, self.rig.now_s())
            .map_err(|e| PushError::Refused(e.to_string()))?;
        let repush = self.repush_next.take() == Some(intent.particle);
        let lead_m = self.lead_for(intent.particle);
        self.journal_decision(intent, &advice, repush, lead_m)?;
        let (from, to) = led(intent.from, intent.to, lead_m);
        let range = self.rig.range();
        let safe_z = clear_height_m(intent.radius_m).min(range[2].max_m);
        let stroke = plan_stroke(&StrokeRequest {
            from,
            to,
            radius_m: intent.radius_m,
            contact_angle_rad: advice.contact_angle_rad,
            travel_after_contact_m: advice.duration_s * scene.push.speed_m_per_s,
            clearance_m: self.landing_gap_m(),
            slow_approach_m: self.settings.slow_approach_m,
            safe_z_m: safe_z,
        })
        .map_err(|e: StrokeError| PushError::Refused(e.to_string()))?;
        let retreat = match self.probe_seen() {
            Some(probe) => {
                let others: Vec<([f64; 2], f64)> = self
                    .tracker
                    .tracks()
                    .iter()
                    .filter(|t| t.id != intent.particle)
                    .map(|t| ([t.last.x_m, t.last.y_m], t.last.radius_m))
                    .collect();
                // Within the nanostage's range where it is now: a farther
                // retreat must not move the coarse stage or refuse the push.
                // And in the camera's view, for the apex to be seen there.
                let (drift, offset) = (self.drift_now(), self.coarse_offset);
                let view = self.view_local();
                let reachable = |p: [f64; 2]| {
                    (0..2).all(|i| {
                        let local = p[i] - offset[i];
                        (range[i].min_m..=range[i].max_m).contains(&(local - drift[i]))
                            && view.is_none_or(|v| (v[i][0]..=v[i][1]).contains(&local))
                    })
                };
                let next = self.next_landing_in_hand();
                retreat_clear_of_probe(&stroke, intent, probe, &others, reachable, next)
            }
            None => retreat_point(&stroke, intent.radius_m),
        };
        self.fit_window(&stroke, retreat, intent)?;
        let t_start_s = self.rig.now_s();
        let travel = self.settings.travel_speed_m_per_s;
        let here = self.rig.position()?;
        if here[2] < safe_z {
            self.move_on_sample_raw([here[0], here[1], safe_z], travel)?;
        }
        self.move_on_sample(stroke.above, travel)?;
        self.move_on_sample(stroke.approach, travel)?;
        if stroke.slow_from != stroke.approach {
            self.move_on_sample(stroke.slow_from, travel)?;
        }
        self.move_on_sample(stroke.end, scene.push.speed_m_per_s)?;
        self.move_on_sample(stroke.lift, travel)?;
        self.move_on_sample(retreat, travel)?;
        self.pushes_done += 1;
        self.records.push(PushRecord {
            t_start_s,
            t_end_s: self.rig.now_s(),
            lost_contact_detected: false,
            from_m: intent.from,
            to_m: intent.to,
        });
        Ok(())
    }

    pub(super) fn journal_decision(
        &mut self,
        intent: &PushIntent,
        a: &PushAdvice,
        repush: bool,
        lead_m: f64,
    ) -> Result<(), JournalError> {
        let um = |p: [f64; 2]| [p[0] * 1e6, p[1] * 1e6];
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::Decision {
                particle: intent.particle,
                from_um: um(intent.from),
                to_um: um(intent.to),
                contact_angle_deg: a.contact_angle_rad.to_degrees(),
                duration_s: a.duration_s,
                onset_s: a.onset_s,
                critical_force_un: a.critical_force_n * 1e6,
                ride_over_margin: a.ride_over_margin,
                mode: format!("{:?}", a.mode).to_lowercase(),
                repush,
                radius_um: Some(intent.radius_m * 1e6),
                lead_nm: (lead_m != 0.0).then_some(lead_m * 1e9),
            },
        )?;
        Ok(())
    }
}

/// The scene as the model sees one push: the particle's measured radius, and
/// the session time grown by the run time so far (charge build-up).
pub fn scene_for_push(scene: &Scene, radius_m: f64, run_time_s: f64) -> Scene {
    let mut scene = scene.clone();
    scene.particle_radius_m = radius_m;
    scene.environment.session_time_s += run_time_s;
    scene
}

/// The executor's decision for one push: the model's contact angle and
/// duration for this particle, this distance, at this point of the run. The
/// loop journals exactly these numbers (a `decision` entry).
pub fn decide_push(
    scene: &Scene,
    intent: &PushIntent,
    run_time_s: f64,
) -> Result<PushAdvice, ModelError> {
    let distance = (intent.to[0] - intent.from[0]).hypot(intent.to[1] - intent.from[1]);
    advise_push(
        &scene_for_push(scene, intent.radius_m, run_time_s),
        distance,
    )
}
