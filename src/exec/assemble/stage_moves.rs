//! Moving the tip and the stages: parking out of the camera's way,
//! coarse-stage windows, moves on the sample with the drift taken out,
//! where the tip waits after a push, and recovering from a stage fault.

use super::{Assembly, ExecError, PushError, PushIntent};
use crate::calib::camera_map::CameraCalibration;
use crate::exec::drift::APEX_CLEAR_OF_PARTICLES_M;
use crate::exec::events::RunEvent;
use crate::exec::probe_parking::{parking_moves, probe_axis};
use crate::exec::stroke::Stroke;
use crate::rig::stage::StageXyz;
use crate::vision::tip::TipDetection;
use nalgebra::Vector2;

impl Assembly<'_> {
    /// Lifts the tip, brings `point` into the camera's view if it is not, and
    /// moves the tip to the corner of the nanostage's range farthest from it.
    pub(super) fn park_away_from(&mut self, point: [f64; 2]) -> Result<(), ExecError> {
        let range = self.rig.range();
        let here = self.rig.position()?;
        let top = range[2].max_m;
        let speed = self.settings.travel_speed_m_per_s;
        self.move_on_sample_raw([here[0], here[1], top], speed)
            .map_err(ExecError::from)?;
        if let Some(view) = self.view_local()
            && let Some(offset) = offset_fitting(self.coarse_offset, &[(point, view)])
            && offset != self.coarse_offset
        {
            self.move_coarse_lifted(offset).map_err(ExecError::from)?;
        }
        let local = [
            point[0] - self.coarse_offset[0],
            point[1] - self.coarse_offset[1],
        ];
        let far = |i: usize| {
            if (local[i] - range[i].min_m).abs() > (local[i] - range[i].max_m).abs() {
                range[i].min_m
            } else {
                range[i].max_m
            }
        };
        self.move_on_sample_raw([far(0), far(1), top], speed)
            .map_err(ExecError::from)
    }

    /// Lifts the tip and moves it where a run starts and ends: the corner of
    /// the nanostage's range the cantilever comes from, at the top of its
    /// travel, so that the probe's body lies outside the frame and hides no
    /// particle (the origin corner while the probe's direction is unknown).
    pub(super) fn park_at_start(&mut self) -> Result<(), ExecError> {
        let axis = self.probe_seen().map(|p| p.axis);
        let speed = self.settings.travel_speed_m_per_s;
        for target in parking_moves(&self.rig.range(), self.rig.position()?, axis) {
            self.move_on_sample_raw(target, speed)?;
        }
        Ok(())
    }

    /// Moves the coarse stage when the stroke does not fit the nanostage's
    /// range or the camera would not see the particle before and after.
    pub(super) fn fit_window(
        &mut self,
        stroke: &Stroke,
        retreat: StageXyz,
        intent: &PushIntent,
    ) -> Result<(), PushError> {
        let range = self.rig.range();
        let reach = [0, 1].map(|i| [range[i].min_m, range[i].max_m]);
        // The stage is sent to each point less the drift.
        let drift = self.drift_now();
        let mut needs: Vec<([f64; 2], [[f64; 2]; 2])> = [
            stroke.above,
            stroke.approach,
            stroke.end,
            stroke.lift,
            retreat,
        ]
        .iter()
        .map(|p| ([p[0] - drift[0], p[1] - drift[1]], reach))
        .collect();
        if let Some(view) = self.view_local() {
            needs.extend([intent.from, intent.to].map(|p| (p, view)));
        }
        match offset_fitting(self.coarse_offset, &needs) {
            Some(offset) if offset == self.coarse_offset => Ok(()),
            Some(offset) => self.move_coarse_lifted(offset),
            None => Err(PushError::Refused(
                "the stroke and the particle's path do not fit the nanostage's range and the camera's view"
                    .to_owned(),
            )),
        }
    }

    /// The probe as the last frame that found it saw it.
    pub(super) fn probe_seen(&self) -> Option<ProbeSeen<'_>> {
        ProbeSeen::new(self.last_sighting.as_ref()?.probe.as_ref()?)
    }

    /// The part of the nanostage's frame the camera shows whole particles in
    /// (from the last frame), or None before the first frame.
    pub(super) fn view_local(&self) -> Option<[[f64; 2]; 2]> {
        let s = self.last_sighting.as_ref()?;
        let [lo, hi] = s.view_m;
        let o = s.coarse_offset_m;
        Some([[lo[0] - o[0], hi[0] - o[0]], [lo[1] - o[1], hi[1] - o[1]]])
    }

    /// Lifts the tip and moves the coarse stage to `offset`.
    pub(super) fn move_coarse_lifted(&mut self, offset: [f64; 2]) -> Result<(), PushError> {
        let range = self.rig.range();
        let here = self.rig.position()?;
        self.move_on_sample_raw(
            [here[0], here[1], range[2].max_m],
            self.settings.travel_speed_m_per_s,
        )?;
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::CoarseMove {
                offset_um: [offset[0] * 1e6, offset[1] * 1e6],
            },
        )?;
        self.rig.move_coarse(offset)?;
        self.journal_operator_wait()?;
        self.coarse_offset = offset;
        Ok(())
    }

    /// Moves the tip to a point given on the sample: the stage is sent
    /// there less the coarse offset and the tip's drift. The drift is
    /// predicted at the move's own time, a little later than `fit_window`
    /// asked, so a point the window put on the range's edge may come out a
    /// few nanometres beyond it: it is held at the edge (every point the
    /// window checked is otherwise inside the range, where this changes
    /// nothing).
    pub(super) fn move_on_sample(&mut self, target: StageXyz, speed: f64) -> Result<(), PushError> {
        let drift = self.drift_now();
        let range = self.rig.range();
        let on_stage = |i: usize| {
            (target[i] - self.coarse_offset[i] - drift[i]).clamp(range[i].min_m, range[i].max_m)
        };
        let nano = [on_stage(0), on_stage(1), target[2]];
        self.move_on_sample_raw(nano, speed)
    }

    /// Moves the nanostage to `nano` (nanostage coordinates), journalling it first.
    pub(super) fn move_on_sample_raw(
        &mut self,
        nano: StageXyz,
        speed: f64,
    ) -> Result<(), PushError> {
        self.journal.append(
            self.rig.now_s(),
            &RunEvent::Move {
                target_um: [nano[0] * 1e6, nano[1] * 1e6, nano[2] * 1e6],
                speed_um_s: speed * 1e6,
            },
        )?;
        self.stage_targets = [self.stage_targets[1], Some(nano)];
        self.rig.move_to(nano, speed)?;
        self.journal_operator_wait()
    }

    /// Journals the time the last move waited for the operator, if any.
    fn journal_operator_wait(&mut self) -> Result<(), PushError> {
        let waited_s = self.rig.take_operator_wait_s();
        if waited_s > 0.0 {
            let event = RunEvent::OperatorWait { waited_s };
            self.journal.append(self.rig.now_s(), &event)?;
        }
        Ok(())
    }

    /// After a stage fault: halt, lift the tip, and let the next cycle re-observe.
    pub(super) fn recover_from_fault(&mut self, why: String) -> Result<(), ExecError> {
        self.stage_faults += 1;
        let _ = self.rig.halt();
        self.journal
            .append(self.rig.now_s(), &RunEvent::MoveFailed { error: why })?;
        let range = self.rig.range();
        let here = self.rig.position()?;
        if let Err(e) = self.move_on_sample_raw(
            [here[0], here[1], range[2].max_m],
            self.settings.travel_speed_m_per_s,
        ) {
            let _ = self.rig.halt();
            return Err(e.into());
        }
        Ok(())
    }
}

/// The coarse offset nearest `current` that puts every point inside its
/// bounds (points on the sample, bounds in the nanostage's frame, per axis
/// [min, max]); None when no offset does.
pub(super) fn offset_fitting(
    current: [f64; 2],
    needs: &[([f64; 2], [[f64; 2]; 2])],
) -> Option<[f64; 2]> {
    let mut offset = current;
    for (i, o) in offset.iter_mut().enumerate() {
        // point - offset in [min, max]  <=>  offset in [point - max, point - min]
        let lo = needs
            .iter()
            .map(|(p, b)| p[i] - b[i][1])
            .fold(f64::NEG_INFINITY, f64::max);
        let hi = needs
            .iter()
            .map(|(p, b)| p[i] - b[i][0])
            .fold(f64::INFINITY, f64::min);
        if lo > hi {
            return None;
        }
        *o = o.clamp(lo, hi);
    }
    Some(offset)
}

/// The probe as a frame saw it: its fitted silhouette, the calibration it
/// was seen through, and the unit direction from its body to its apex on
/// the sample.
#[derive(Clone, Copy)]
pub(super) struct ProbeSeen<'a> {
    fit: &'a (TipDetection, CameraCalibration),
    axis: Vector2<f64>,
}

impl<'a> ProbeSeen<'a> {
    /// None when the calibration maps the probe's direction to no length.
    pub(super) fn new(fit: &'a (TipDetection, CameraCalibration)) -> Option<Self> {
        probe_axis(fit).map(|axis| Self { fit, axis })
    }

    /// Free space, metres, between `point` and the silhouette moved to put
    /// its apex at `apex` (negative inside); None when the calibration
    /// cannot be inverted.
    fn body_gap_m(&self, apex: Vector2<f64>, point: Vector2<f64>) -> Option<f64> {
        let (tip, calibration) = self.fit;
        let off = calibration.linear.try_inverse()? * (point - apex);
        let gap_px = tip.signed_distance(tip.x_px + off.x, tip.y_px + off.y);
        Some(gap_px * calibration.m_per_px())
    }
}

/// Where the tip waits after a push: back along the push line, a radius and
/// a few micrometres behind the lift point, so that the probe does not hide
/// the particle in the next frame; kept inside the nanostage's range.
pub(super) fn retreat_point(stroke: &Stroke, radius_m: f64) -> StageXyz {
    let d = [
        stroke.end[0] - stroke.approach[0],
        stroke.end[1] - stroke.approach[1],
    ];
    let len = d[0].hypot(d[1]).max(f64::MIN_POSITIVE);
    let back = radius_m + RETREAT_EXTRA_M;
    [
        stroke.lift[0] - d[0] / len * back,
        stroke.lift[1] - d[1] / len * back,
        stroke.lift[2],
    ]
}

/// Where the tip waits after a push when a frame has seen the probe.
/// The probe's body lies behind its apex, so a point at least a radius and
/// a few micrometres behind the particle's target along the probe's axis
/// leaves the particle in the next frame's view, and no re-look (a lifted
/// trip to the nanostage's far corner and back) is needed. Of those points,
/// up to [`RETREAT_FARTHEST_EXTRA_M`] behind, it takes one whose apex is
/// clear of every other particle (`others`: centre and radius) and
/// `reachable`: the next frame's apex is then a sighting of the tip's
/// drift. Among the letters of a pattern the nearest point seldom is (5
/// sightings in 16 frames on CMU seed 1 at 5 nm/s), and at 5 nm/s the
/// drift's rate was never taken and a push fell 0.2 um short three times.
/// Given where the next push lands the tip (`next`), the clear point on
/// the shortest way there from the lift, the straight way's own points
/// included where the probe's silhouette leaves the particle in view; else
/// the nearest clear point straight behind the target. (Straight behind it
/// always, the waits had doubled the tip's lifted travel: CMU seed 2's plan
/// toured 626 um between pushes, its run 1,352 um.) With no clear point,
/// straight behind the target.
pub(super) fn retreat_clear_of_probe(
    stroke: &Stroke,
    intent: &PushIntent,
    probe: ProbeSeen,
    others: &[([f64; 2], f64)],
    reachable: impl Fn([f64; 2]) -> bool,
    next: Option<[f64; 2]>,
) -> StageXyz {
    let axis = probe.axis;
    let across = Vector2::new(-axis.y, axis.x);
    let target = Vector2::from(intent.to);
    let lift = Vector2::new(stroke.lift[0], stroke.lift[1]);
    // A point `extra` beyond the particle's edge behind the target and
    // `side` across the axis.
    let at = |extra: f64, side: f64| target - axis * (intent.radius_m + extra) + across * side;
    let clear = |p: Vector2<f64>| {
        others.iter().all(|(c, r)| {
            (Vector2::from(*c) - p).norm() >= r + APEX_CLEAR_OF_PARTICLES_M + RETREAT_ROOM_M
        })
    };
    let shows_target = |p: &Vector2<f64>| {
        probe
            .body_gap_m(*p, target)
            .is_some_and(|gap| gap >= intent.radius_m + RETREAT_EXTRA_M)
    };
    let usable = |p: &Vector2<f64>| clear(*p) && reachable([p.x, p.y]);
    let steps = ((RETREAT_FARTHEST_EXTRA_M - RETREAT_EXTRA_M) / RETREAT_STEP_M).round() as usize;
    let extras = (0..=steps).map(|k| RETREAT_EXTRA_M + k as f64 * RETREAT_STEP_M);
    let found = match next.map(Vector2::from) {
        Some(next) => {
            let behind = extras.flat_map(|extra| {
                let best = least_detour_side(lift, next, at(extra, 0.0), across)
                    .clamp(-RETREAT_SIDE_FARTHEST_M, RETREAT_SIDE_FARTHEST_M);
                let (lo, hi) = (best.min(0.0), best.max(0.0));
                let sides =
                    ((hi - lo + 2.0 * RETREAT_SIDE_MARGIN_M) / RETREAT_STEP_M).ceil() as usize;
                let first = lo - RETREAT_SIDE_MARGIN_M;
                (0..=sides)
                    .map(move |k| first + k as f64 * RETREAT_STEP_M)
                    .chain([best])
                    .map(move |side| at(extra, side))
            });
            let n = ((next - lift).norm() / RETREAT_STEP_M).ceil().max(1.0) as usize;
            let on_the_way = (0..=n)
                .map(|k| lift + (next - lift) * (k as f64 / n as f64))
                .filter(shows_target);
            let way = |p: &Vector2<f64>| (p - lift).norm() + (next - p).norm();
            (on_the_way.chain(behind))
                .filter(usable)
                .min_by(|a, b| way(a).total_cmp(&way(b)))
        }
        None => extras.map(|extra| at(extra, 0.0)).find(usable),
    };
    let p = found.unwrap_or_else(|| at(RETREAT_EXTRA_M, 0.0));
    [p.x, p.y, stroke.lift[2]]
}

/// Where, across the axis from `on_axis` along `across`, the line through
/// `on_axis` meets the shortest way from `from` to `to` that touches it:
/// where the segment crosses the line, else where the way bounces off it.
fn least_detour_side(
    from: Vector2<f64>,
    to: Vector2<f64>,
    on_axis: Vector2<f64>,
    across: Vector2<f64>,
) -> f64 {
    let normal = Vector2::new(across.y, -across.x);
    let (a, b) = ((from - on_axis).dot(&normal), (to - on_axis).dot(&normal));
    // Both on one side: reflect the far end through the line (a mirror's path).
    let b = if a * b > 0.0 { -b } else { b };
    let t = if (a - b).abs() > f64::EPSILON {
        a / (a - b)
    } else {
        0.5
    };
    let (sa, sb) = ((from - on_axis).dot(&across), (to - on_axis).dot(&across));
    sa + (sb - sa) * t
}

/// Extra distance of the retreat beyond one particle radius.
const RETREAT_EXTRA_M: f64 = 3e-6;
/// Farthest the retreat goes back for an apex clear of the other particles:
/// 12 um more is 0.25 s at the travel speed, against pushes of seconds.
const RETREAT_FARTHEST_EXTRA_M: f64 = 15e-6;
/// Steps of the search back along the probe's line.
const RETREAT_STEP_M: f64 = 0.5e-6;
/// How far either side of the shortest way's point, and of the point
/// straight behind the target, the search looks for a clear apex.
const RETREAT_SIDE_MARGIN_M: f64 = 5e-6;
/// Farthest aside the search looks: the nanostage's range.
const RETREAT_SIDE_FARTHEST_M: f64 = 100e-6;
/// Room beyond [`APEX_CLEAR_OF_PARTICLES_M`] for the apex's placement
/// error and the drift left in the move, so the frame's apex still counts.
const RETREAT_ROOM_M: f64 = 0.5e-6;

#[cfg(test)]
mod tests {
    use super::*;

    /// A particle pushed from (40, 50) to (50, 50) um, 5 um in radius, the
    /// tip lifted at (44, 50) um.
    fn pushed_to_50_50() -> (Stroke, PushIntent) {
        let stroke = Stroke {
            above: [34e-6, 50e-6, 12e-6],
            approach: [34e-6, 50e-6, 6e-6],
            slow_from: [34e-6, 50e-6, 6e-6],
            end: [44e-6, 50e-6, 6e-6],
            lift: [44e-6, 50e-6, 12e-6],
            travel_after_contact_m: 0.0,
        };
        let intent = PushIntent {
            particle: 0,
            from: [40e-6, 50e-6],
            to: [50e-6, 50e-6],
            radius_m: 5e-6,
        };
        (stroke, intent)
    }

    /// After a push the tip waits on the probe's line behind the target:
    /// 3 um beyond the particle's edge when that is clear of the others,
    /// else at the first point 3 um clear of them, else (nothing clear
    /// within reach) at the nearest.
    #[test]
    fn the_tip_waits_where_its_apex_is_clear_of_the_other_particles() {
        let (stroke, intent) = pushed_to_50_50();
        // The cantilever comes from -x: the apex points +x.
        let fit = probe_seen();
        let probe = ProbeSeen::new(&fit).unwrap();
        let wait = |others: &[([f64; 2], f64)], reach: f64| {
            retreat_clear_of_probe(&stroke, &intent, probe, others, |p| p[0] >= reach, None)[0]
                * 1e6
        };
        assert!((wait(&[], 0.0) - 42.0).abs() < 1e-9);
        // A particle at x = 40.2 um: the apex must be at x <= 40.2 - 5 - 3,
        // and the search steps 0.5 um from x = 42.
        let left = [([40.2e-6, 50e-6], 5e-6)];
        assert!(
            (wait(&left, 0.0) - 32.0).abs() < 1e-9,
            "{}",
            wait(&left, 0.0)
        );
        assert!((wait(&left, 33e-6) - 42.0).abs() < 1e-9);
        // At x = 35 um the first clear point (27) is beyond the 15 um searched.
        assert!((wait(&[([35e-6, 50e-6], 5e-6)], 0.0) - 42.0).abs() < 1e-9);
    }

    /// A probe seen pointing +x on the sample at 0.25 um a pixel: its body
    /// 10 um wide, reached 15 um behind the apex.
    fn probe_seen() -> (TipDetection, CameraCalibration) {
        let tip = TipDetection {
            x_px: 200.0,
            y_px: 200.0,
            angle_rad: 0.0,
            score: 1.0,
            width_px: 40.0,
            taper_length_px: 60.0,
        };
        (
            tip,
            CameraCalibration::from_scale_rotation(0.25e-6, 0.0, [0.0, 0.0]),
        )
    }

    /// Given the next landing, the tip waits on its way there where the
    /// probe leaves the particle in view and its apex is clear of the
    /// others; else behind the target where the way there bends least.
    #[test]
    fn the_tip_waits_on_its_way_to_the_next_landing() {
        let (stroke, intent) = pushed_to_50_50();
        let fit = probe_seen();
        let probe = ProbeSeen::new(&fit).unwrap();
        let wait = |next_um: [f64; 2], others: &[([f64; 2], f64)]| {
            let p = retreat_clear_of_probe(
                &stroke,
                &intent,
                probe,
                others,
                |_| true,
                Some(next_um.map(|v| v * 1e-6)),
            );
            [p[0] * 1e6, p[1] * 1e6]
        };
        // The next push lands the tip at (44, 80) um: the apex on the
        // straight way 5.29 um or more above the particle's centre keeps 3
        // um from its edge, and the body lies away.
        let [x, y] = wait([44.0, 80.0], &[]);
        assert!(
            (x - 44.0).abs() < 1e-9 && (55.29..=80.0).contains(&y),
            "({x}, {y})"
        );
        // A particle at (44, 70): the apex keeps 8 um from its centre.
        let [x, y] = wait([44.0, 80.0], &[([44e-6, 70e-6], 5e-6)]);
        assert!(
            (x - 44.0).abs() < 1e-9 && (55.29..=62.0).contains(&y),
            "({x}, {y})"
        );
        // To (70, 60) um every point of the straight way is within 3 um of
        // the particle or puts the body over it: the tip waits 8 um behind
        // the particle's centre (x = 42), where the way there touching that
        // line is shortest, mirrored: 2 um to it of 30 across, y = 50 + 10 /
        // 15.
        let [x, y] = wait([70.0, 60.0], &[]);
        assert!(
            (x - 42.0).abs() < 1e-9 && (y - (50.0 + 10.0 / 15.0)).abs() < 1e-6,
            "({x}, {y})"
        );
    }

    /// The free space between a point and the probe's silhouette, its apex
    /// moved to a place: from the apex in front of it, from the taper's and
    /// the body's edges beside it, negative under it.
    #[test]
    fn the_body_gap_is_measured_from_the_moved_silhouette() {
        let fit = probe_seen();
        let probe = ProbeSeen::new(&fit).unwrap();
        let um = |x: f64, y: f64| Vector2::new(x * 1e-6, y * 1e-6);
        let gap = |apex: Vector2<f64>| probe.body_gap_m(apex, um(50.0, 50.0)).unwrap() * 1e6;
        assert!(
            (gap(um(41.5, 50.0)) - 8.5).abs() < 0.05,
            "{}",
            gap(um(41.5, 50.0))
        );
        assert!(gap(um(60.0, 50.0)) < 0.0, "under the body");
        // The taper's edge runs from the apex to its corner 15 um back and
        // 5 um aside: 6.32 um from the particle's centre 10 um back and 10
        // um aside; the corner sqrt(5^2 + 20^2) um from it 25 um aside.
        assert!(
            (gap(um(60.0, 60.0)) - 6.32).abs() < 0.05,
            "{}",
            gap(um(60.0, 60.0))
        );
        assert!(
            (gap(um(60.0, 75.0)) - 20.62).abs() < 0.05,
            "{}",
            gap(um(60.0, 75.0))
        );
    }
}
