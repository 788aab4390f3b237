//! Where a run parks the probe so that its body hides no particle, and the
//! first looks a run takes: the loop parks the probe before it plans, and
//! the simulated rig places the pattern on what those looks show.

use super::observe::{ObserveError, Perception, Sighting};
use crate::calib::camera_map::CameraCalibration;
use crate::rig::Rig;
use crate::rig::error::RigError;
use crate::rig::stage::{AxisRange, StageXyz};
use crate::vision::tip::TipDetection;
use nalgebra::Vector2;

/// The probe's direction on the sample, from its body to its apex, as a
/// frame found it; None when the calibration maps it to no length.
pub fn probe_axis(fit: &(TipDetection, CameraCalibration)) -> Option<Vector2<f64>> {
    let (tip, calibration) = fit;
    let v = calibration.linear * Vector2::new(tip.angle_rad.cos(), tip.angle_rad.sin());
    (v.norm() > 0.0).then(|| v / v.norm())
}

/// The probe's direction in `look` when the loop would park it for that
/// look ([`probe_axis`] of the probe it shows), None when it would not.
pub fn parking_axis(look: &Sighting) -> Option<Vector2<f64>> {
    look.probe.as_ref().and_then(probe_axis)
}

/// The moves that park the probe from `here`: straight up to the top of
/// the nanostage's `range`, then across to the corner the cantilever comes
/// from (farthest back along `axis`), where its body lies outside the
/// frame; the origin corner while the probe's direction is unknown.
pub fn parking_moves(
    range: &[AxisRange; 3],
    here: StageXyz,
    axis: Option<Vector2<f64>>,
) -> [StageXyz; 2] {
    let top = range[2].max_m;
    let corner = match axis {
        Some(axis) => [0, 1].map(|i| {
            if axis[i] > 0.0 {
                range[i].min_m
            } else {
                range[i].max_m
            }
        }),
        None => [range[0].min_m, range[1].min_m],
    };
    [[here[0], here[1], top], [corner[0], corner[1], top]]
}

/// The run's first looks at the field, as its loop will take them.
pub struct FirstLooks {
    /// The first frame, when it showed the probe (which may hide particles).
    pub before_parking: Option<Sighting>,
    /// The frame the loop plans from: the first, or with the probe parked.
    pub last: Sighting,
}

impl FirstLooks {
    /// One look, taken where the probe stands.
    pub fn one(look: Sighting) -> Self {
        FirstLooks {
            before_parking: None,
            last: look,
        }
    }

    /// The looks in the order taken.
    pub fn in_order(&self) -> impl Iterator<Item = &Sighting> {
        self.before_parking.iter().chain([&self.last])
    }

    /// Every look in a sample frame whose origin lies at `origin_m`
    /// ([`Sighting::reframe`]).
    pub fn reframe(&mut self, origin_m: [f64; 2]) {
        let looks = self.before_parking.iter_mut().chain([&mut self.last]);
        looks.for_each(|look| look.reframe(origin_m));
    }
}

/// A frame, and when it shows the probe, the probe lifted and parked at
/// [`parking_moves`] and a second frame, as the loop looks before its
/// first plan. Placed on a frame with a particle under the probe's body,
/// the pattern's sites (5 um adversarial 'HI', seed 1) had left the loop,
/// which saw that particle once parked, with no order at its first plan.
pub fn first_looks(
    rig: &mut dyn Rig,
    perception: &Perception,
    calibration: &CameraCalibration,
    coarse_offset_m: [f64; 2],
    travel_speed_m_per_s: f64,
) -> Result<FirstLooks, ObserveError> {
    let first = perception.sight(rig, calibration, coarse_offset_m)?;
    if !park_if_seen(rig, &first, travel_speed_m_per_s)? {
        return Ok(FirstLooks::one(first));
    }
    Ok(FirstLooks {
        last: perception.sight(rig, calibration, coarse_offset_m)?,
        before_parking: Some(first),
    })
}

/// Parks the probe at [`parking_moves`] as the loop does before its first
/// plan, when `first` shows it with a direction the calibration maps to a
/// length (the loop leaves any other where it is); true when it moved.
pub fn park_if_seen(
    rig: &mut dyn Rig,
    first: &Sighting,
    travel_speed_m_per_s: f64,
) -> Result<bool, RigError> {
    let Some(axis) = parking_axis(first) else {
        return Ok(false);
    };
    for target in parking_moves(&rig.range(), rig.position()?, Some(axis)) {
        rig.move_to(target, travel_speed_m_per_s)?;
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Scene;
    use crate::model::scene::DEFAULT_SCENE_PATH;
    use crate::plan::{Layout, Particle};
    use crate::rig::sim::build::build_sim_rig;

    /// A particle near the origin corner, under the probe where the
    /// simulated rig starts, and one in the open.
    #[test]
    fn a_particle_under_the_probe_at_the_start_is_seen_once_it_is_parked() {
        let scene = Scene::load(DEFAULT_SCENE_PATH.as_ref()).unwrap();
        let particle = |id, x_um: f64, y_um: f64| Particle {
            id,
            centre_m: Vector2::new(x_um, y_um) * 1e-6,
            radius_m: 5e-6,
        };
        let layout = Layout {
            field_m: [120e-6, 100e-6],
            particles: vec![particle(0, 9.2, 7.5), particle(1, 70.0, 60.0)],
        };
        let mut rig = build_sim_rig(&scene, &layout, 1).unwrap();
        let calibration = *rig.calibration();
        let offset = rig.stage.coarse_offset();
        let perception = Perception::for_run(5e-6, &calibration);
        let looks = first_looks(&mut rig, &perception, &calibration, offset, 50e-6).unwrap();
        let before = looks
            .before_parking
            .expect("the probe in view where the rig starts");
        assert_eq!(before.particles.len(), 1, "the probe hides one");
        assert_eq!(looks.last.particles.len(), 2);
        let near =
            |o: &crate::exec::tracker::Observation| (o.x_m - 9.2e-6).hypot(o.y_m - 7.5e-6) < 0.1e-6;
        assert!(looks.last.particles.iter().any(near));
    }

    #[test]
    fn the_probe_parks_where_its_body_comes_from() {
        let axis = |deg: f64| Some(Vector2::new(deg.to_radians().cos(), deg.to_radians().sin()));
        let range = [
            AxisRange {
                min_m: 0.0,
                max_m: 100e-6,
            },
            AxisRange {
                min_m: 0.0,
                max_m: 100e-6,
            },
            AxisRange {
                min_m: 0.0,
                max_m: 20e-6,
            },
        ];
        let here = [30e-6, 40e-6, 5e-6];
        let up = [30e-6, 40e-6, 20e-6];
        // A cantilever pointing down and to the right comes from the top left.
        let parked = |to: [f64; 2]| [up, [to[0], to[1], 20e-6]];
        assert_eq!(
            parking_moves(&range, here, axis(-45.0)),
            parked([0.0, 100e-6])
        );
        assert_eq!(
            parking_moves(&range, here, axis(135.0)),
            parked([100e-6, 0.0])
        );
        assert_eq!(parking_moves(&range, here, None), parked([0.0, 0.0]));
    }
}
