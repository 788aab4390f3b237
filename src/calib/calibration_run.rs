//! A calibration run: the tip moved over a grid of stage positions that
//! covers the camera's view, one frame at each, for the pixel-to-stage map
//! to be fitted from (`nanopush rig calibrate`). The run needs no
//! calibration to keep the tip in view: two small moves first give a rough
//! map, and the grid is laid out in the frame's pixels through it. The user
//! only brings the tip into view.
//!
//! The tip travels at the top of its z travel (clear of the particles) on a
//! stage with a z axis, and the stage is put back where it started, also
//! when the run fails part way.

use super::camera_map::CameraCalibration;
use crate::rig::camera::Camera;
use crate::rig::error::RigError;
use crate::rig::stage::{AxisRange, NanoStage, StageXyz};
use crate::vision::analyse::prepare_frame;
use crate::vision::frame::Frame;
use crate::vision::tip::{TipSettings, detect_tip};

/// Most points a side of the grid: 400 frames, minutes on a rig; a fit
/// gains nothing from more (a grid of 1,000 a side, a million moves, ran
/// on until stopped, half a recording left behind).
pub const MAX_GRID: usize = 20;

/// How a calibration run moves and looks.
#[derive(Debug, Clone)]
pub struct CalibrationRunSettings {
    /// Points per side of the grid laid over the view (at least 2).
    pub grid: usize,
    /// Length of the two first moves that find the rough map, metres: enough
    /// to move the tip's apex by several pixels.
    pub probe_step_m: f64,
    /// Share of the frame's width and height kept clear at each edge: the
    /// probe's silhouette must stay in the frame for its apex to be found.
    pub margin: f64,
    /// Travel speed, m/s.
    pub speed_m_per_s: f64,
    /// Height of the tip during the run, metres; `None`: the top of the
    /// stage's z travel (clear of the particles). Lower is nearer the
    /// height the probe pushes at, and so the apex the loop sees then,
    /// but must still clear every particle on the grid.
    pub travel_z_m: Option<f64>,
    /// Frames asked for at one position before the camera counts as silent
    /// (a camera may drop frames).
    pub grabs: usize,
    /// How the tip is found in a frame.
    pub tip: TipSettings,
}

impl Default for CalibrationRunSettings {
    /// A 4 x 4 grid inside the middle 70 % of the view, 5 um first moves,
    /// 20 um/s.
    fn default() -> Self {
        Self {
            grid: 4,
            probe_step_m: 5e-6,
            margin: 0.15,
            speed_m_per_s: 20e-6,
            travel_z_m: None,
            grabs: 10,
            tip: TipSettings::default(),
        }
    }
}

/// One stop of the run: where the stage was and what the camera saw.
#[derive(Debug, Clone)]
pub struct CalibrationShot {
    /// The stage's own reading of x and y after the move, metres.
    pub stage_m: [f64; 2],
    /// The frame, as the camera gave it.
    pub frame: Frame,
    /// The tip's apex found in it, pixels; `None` when not found.
    pub apex_px: Option<[f64; 2]>,
}

/// Why a calibration run stopped.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationRunError {
    /// A setting out of its range.
    #[error("calibration run: {0}")]
    Settings(String),
    /// The stage or the camera failed.
    #[error(transparent)]
    Rig(#[from] RigError),
    /// The stage starts outside its range (the rig file's soft limits
    /// within the controller's travel), where the run could not put it back.
    #[error(
        "the stage starts at {axis} = {at_um:.3} um, outside the rig file's limits {min_um:.3}..{max_um:.3} um: \
         the calibration ends by putting the stage back where it started; move it inside first (nothing was moved)"
    )]
    StartOutOfRange {
        /// The axis outside.
        axis: char,
        /// Where it is, micrometres.
        at_um: f64,
        /// Its range, micrometres.
        min_um: f64,
        /// Its range, micrometres.
        max_um: f64,
    },
    /// The camera gave no frame.
    #[error("no frame from the camera in {}", crate::wording::counted(*.0, "try"))]
    NoFrame(usize),
    /// No tip in the first frame.
    #[error(
        "no probe tip found in the first frame: bring the tip into the camera's view (`nanopush rig probe --rig FILE --camera` shows what the loop sees) and run again"
    )]
    NoTipAtStart,
    /// The tip left the view (or was not found) after a first move.
    #[error(
        "the probe tip was not found after a {step_um:.1} um move in {axis}: start with the tip nearer the middle of the view, or give a smaller first step"
    )]
    TipLost {
        /// The axis moved.
        axis: char,
        /// The move, micrometres.
        step_um: f64,
    },
    /// The apex hardly moved in the frame when the stage moved.
    #[error(
        "the tip moved {moved_px:.2} px in the frame when the stage moved {step_um:.1} um in {axis}: the camera does not see the stage's motion (is it the probe that is in view, and is the step large enough for the camera's scale?)"
    )]
    NoMotion {
        /// The axis moved.
        axis: char,
        /// How far the apex moved, pixels.
        moved_px: f64,
        /// The move, micrometres.
        step_um: f64,
    },
    /// The x and y moves went (nearly) the same way in the frame.
    #[error(
        "the stage's x and y moves run along one line in the frame ({angle_deg:.1} deg apart): the stage's axes or the camera are not what the rig file says"
    )]
    Parallel {
        /// Angle between the two moves in the frame, degrees.
        angle_deg: f64,
    },
    /// A travel height the stage cannot take.
    #[error(
        "a travel height of {z_um:.3} um is outside the stage's z range {min_um:.3}..{max_um:.3} um"
    )]
    HeightOutOfRange {
        /// The height asked for, micrometres.
        z_um: f64,
        /// The range, micrometres.
        min_um: f64,
        /// The range, micrometres.
        max_um: f64,
    },
    /// The caller's handling of a shot failed (saving it, say); the run
    /// stopped there.
    #[error("{0}")]
    Shot(String),
    /// No room for a first move.
    #[error(
        "no room for a {step_um:.1} um move in {axis} either way within the stage's range (at most {room_um:.1} um fits in x and y from where the stage is)"
    )]
    NoRoom {
        /// The axis.
        axis: char,
        /// The move, micrometres.
        step_um: f64,
        /// The longest first move that fits both axes from the start, micrometres.
        room_um: f64,
    },
}

/// What a stopped run had done with the stage: the user is told where it
/// is and why (a run that had only lifted the tip and lowered it again
/// was said to have "stopped at ...; it was not put back").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageLeft {
    /// Refused before any move was asked of the stage.
    Untouched,
    /// Moved and put back where it started; `xy_moved` is false when only
    /// z moved (the lift to the travel height).
    PutBack {
        /// True when a move in x or y was asked for.
        xy_moved: bool,
    },
    /// Not put back (Ctrl-C, a fault, a refused move back): where it stopped.
    NotPutBack,
}

/// A calibration run that stopped: why, and where it left the stage.
#[derive(Debug, thiserror::Error)]
#[error("{error}")]
pub struct CalibrationRunStop {
    /// Why it stopped.
    #[source]
    pub error: CalibrationRunError,
    /// What it had done with the stage.
    pub left: StageLeft,
}

/// The apex must move at least this far for a first move to count.
const LEAST_MOTION_PX: f64 = 1.0;
/// Grid points closer than this after clipping to the range are one.
const SAME_POINT_M: f64 = 0.5e-6;

/// What a caller does with each shot as it is taken (saves it, say); an
/// error stops the run ([`CalibrationRunError::Shot`]).
pub type ShotSink<'a> = &'a mut dyn FnMut(&CalibrationShot) -> Result<(), String>;

/// Runs the calibration: the start, two first moves and the grid, each
/// handed to `on_shot` as it is taken, so a caller can save them as they
/// come. Returns every shot. The stage ends where it started, unless
/// putting it back fails; a stop says which ([`StageLeft`]).
pub fn run_calibration<R: NanoStage + Camera>(
    rig: &mut R,
    settings: &CalibrationRunSettings,
    on_shot: ShotSink<'_>,
) -> Result<Vec<CalibrationShot>, CalibrationRunStop> {
    let untouched = |error| CalibrationRunStop {
        error,
        left: StageLeft::Untouched,
    };
    settings.check().map_err(untouched)?;
    let start = rig.position().map_err(|e| untouched(e.into()))?;
    let range = rig.range();
    let travel_z = travel_height(settings, start, &range).map_err(untouched)?;
    let mut shots = Vec::new();
    let mut keep = |shot: CalibrationShot| {
        on_shot(&shot).map_err(CalibrationRunError::Shot)?;
        shots.push(shot);
        Ok(())
    };
    let mut xy_moved = false;
    let outcome = (|| -> Result<(), CalibrationRunError> {
        rig.move_to([start[0], start[1], travel_z], settings.speed_m_per_s)?;
        let (rough, view) = rough_map(
            rig,
            settings,
            [start[0], start[1]],
            travel_z,
            &mut keep,
            &mut xy_moved,
        )?;
        for target in grid_targets(&rough, view, settings, &range) {
            xy_moved = true;
            rig.move_to([target[0], target[1], travel_z], settings.speed_m_per_s)?;
            keep(take_shot(rig, settings)?)?;
        }
        Ok(())
    })();
    let back = rig
        .move_to([start[0], start[1], travel_z], settings.speed_m_per_s)
        .and_then(|()| rig.move_to(start, settings.speed_m_per_s));
    let left = match back {
        Ok(()) => StageLeft::PutBack { xy_moved },
        Err(_) => StageLeft::NotPutBack,
    };
    match (outcome, back) {
        (Err(error), _) => Err(CalibrationRunStop { error, left }),
        (Ok(()), Err(e)) => Err(CalibrationRunStop {
            error: e.into(),
            left,
        }),
        (Ok(()), Ok(())) => Ok(shots),
    }
}

/// The height the tip travels at: `settings.travel_z_m`, else the top of
/// z travel (the start's on a stage without z). Refused: a start outside
/// the range (the run ends by putting the stage back there: such a start
/// had run the whole grid, then failed to go back and written no
/// calibration) and a height the stage cannot take.
fn travel_height(
    settings: &CalibrationRunSettings,
    start: StageXyz,
    range: &[AxisRange; 3],
) -> Result<f64, CalibrationRunError> {
    if let Some(axis) = (0..3).find(|&i| !(range[i].min_m..=range[i].max_m).contains(&start[i])) {
        return Err(CalibrationRunError::StartOutOfRange {
            axis: ['x', 'y', 'z'][axis],
            at_um: start[axis] * 1e6,
            min_um: range[axis].min_m * 1e6,
            max_um: range[axis].max_m * 1e6,
        });
    }
    let has_z = range[2].max_m > range[2].min_m;
    match settings.travel_z_m {
        Some(z) if !(z >= range[2].min_m && z <= range[2].max_m) => {
            Err(CalibrationRunError::HeightOutOfRange {
                z_um: z * 1e6,
                min_um: range[2].min_m * 1e6,
                max_um: range[2].max_m * 1e6,
            })
        }
        Some(z) => Ok(z),
        None if has_z => Ok(range[2].max_m),
        None => Ok(start[2]),
    }
}

impl CalibrationRunSettings {
    /// Refuses settings out of their range (what [`run_calibration`] does
    /// first; a caller may ask before it opens a rig).
    pub fn check(&self) -> Result<(), CalibrationRunError> {
        let bad = |what: String| Err(CalibrationRunError::Settings(what));
        if !(2..=MAX_GRID).contains(&self.grid) {
            return bad(format!(
                "the grid needs 2 to {MAX_GRID} points a side, got {}",
                self.grid
            ));
        }
        if !(self.probe_step_m.is_finite() && self.probe_step_m > 0.0) {
            return bad(format!(
                "the first step must be a positive length, got {} um",
                self.probe_step_m * 1e6
            ));
        }
        if !(0.0..0.5).contains(&self.margin) {
            return bad(format!(
                "the margin must lie in 0..0.5 of the frame, got {}",
                self.margin
            ));
        }
        if self.grabs == 0 {
            return bad("at least one frame must be asked for".into());
        }
        Ok(())
    }
}

/// A frame at the stage's present position, with the apex found in it.
fn take_shot<R: NanoStage + Camera>(
    rig: &mut R,
    settings: &CalibrationRunSettings,
) -> Result<CalibrationShot, CalibrationRunError> {
    let frame = (0..settings.grabs)
        .find_map(|_| rig.grab().transpose())
        .ok_or(CalibrationRunError::NoFrame(settings.grabs))??
        .frame;
    let here = rig.position()?;
    let prepared = prepare_frame(&frame);
    let apex_px = detect_tip(&prepared.frame, &settings.tip).map(|t| [t.x_px, t.y_px]);
    Ok(CalibrationShot {
        stage_m: [here[0], here[1]],
        frame,
        apex_px,
    })
}

/// Pixel -> stage from the start and one small move along each axis, and
/// the frame's size (width, height) in pixels; `xy_moved` is raised before
/// the first of those moves is asked for.
fn rough_map<R: NanoStage + Camera>(
    rig: &mut R,
    settings: &CalibrationRunSettings,
    start: [f64; 2],
    z: f64,
    keep: &mut dyn FnMut(CalibrationShot) -> Result<(), CalibrationRunError>,
    xy_moved: &mut bool,
) -> Result<(CameraCalibration, (usize, usize)), CalibrationRunError> {
    let first = take_shot(rig, settings)?;
    let apex0 = first.apex_px.ok_or(CalibrationRunError::NoTipAtStart)?;
    let stage0 = first.stage_m;
    let view = (first.frame.width(), first.frame.height());
    keep(first)?;
    let range = rig.range();
    let mut columns = [[0.0; 2]; 2];
    for (axis, name) in ['x', 'y'].into_iter().enumerate() {
        let step = settings.probe_step_m;
        let fits = |t: f64| t >= range[axis].min_m && t <= range[axis].max_m;
        let signed = if fits(start[axis] + step) {
            step
        } else if fits(start[axis] - step) {
            -step
        } else {
            return Err(CalibrationRunError::NoRoom {
                axis: name,
                step_um: step * 1e6,
                room_um: first_move_room_m(start, &range) * 1e6,
            });
        };
        let mut target = [start[0], start[1], z];
        target[axis] += signed;
        *xy_moved = true;
        rig.move_to(target, settings.speed_m_per_s)?;
        let shot = take_shot(rig, settings)?;
        let apex = shot.apex_px.ok_or(CalibrationRunError::TipLost {
            axis: name,
            step_um: signed * 1e6,
        })?;
        let moved = [apex[0] - apex0[0], apex[1] - apex0[1]];
        let moved_px = moved[0].hypot(moved[1]);
        let actual = shot.stage_m[axis] - stage0[axis];
        if moved_px < LEAST_MOTION_PX || actual.abs() < 0.5 * step {
            return Err(CalibrationRunError::NoMotion {
                axis: name,
                moved_px,
                step_um: actual * 1e6,
            });
        }
        columns[axis] = [moved[0] / actual, moved[1] / actual];
        keep(shot)?;
    }
    // Stage -> pixel has the columns found; the rough map is its inverse.
    let stage_to_px =
        nalgebra::Matrix2::new(columns[0][0], columns[1][0], columns[0][1], columns[1][1]);
    let (a, b) = (columns[0], columns[1]);
    let sin = (a[0] * b[1] - a[1] * b[0]) / (a[0].hypot(a[1]) * b[0].hypot(b[1]));
    let inverse = stage_to_px.try_inverse().filter(|_| sin.abs() >= 0.1);
    let Some(linear) = inverse else {
        return Err(CalibrationRunError::Parallel {
            angle_deg: sin.clamp(-1.0, 1.0).asin().abs().to_degrees(),
        });
    };
    let offset = nalgebra::Vector2::from(stage0) - linear * nalgebra::Vector2::from(apex0);
    let rough = CameraCalibration::affine(linear, offset);
    Ok((rough, view))
}

/// The longest first move that fits, one way or the other, along both x
/// and y from `start` within `range`: the `--step-um` to name when the one
/// asked for does not.
fn first_move_room_m(start: [f64; 2], range: &[AxisRange; 3]) -> f64 {
    (0..2)
        .map(|a| (range[a].max_m - start[a]).max(start[a] - range[a].min_m))
        .fold(f64::INFINITY, f64::min)
        .max(0.0)
}

/// An n x n grid over the frame inside its margin, mapped onto the stage by
/// `rough` and clipped to its range; points that clipping made one are one.
/// Row by row, every other row backwards, so that each move is short.
fn grid_targets(
    rough: &CameraCalibration,
    (w, h): (usize, usize),
    settings: &CalibrationRunSettings,
    range: &[AxisRange; 3],
) -> Vec<[f64; 2]> {
    let n = settings.grid;
    let along = |size: usize, k: usize| {
        let (lo, hi) = (settings.margin, 1.0 - settings.margin);
        (lo + (hi - lo) * k as f64 / (n - 1) as f64) * (size.max(1) - 1) as f64
    };
    let mut out: Vec<[f64; 2]> = Vec::new();
    for j in 0..n {
        for k in 0..n {
            let i = if j % 2 == 0 { k } else { n - 1 - k };
            let p = rough.pixel_to_stage_m(along(w, i), along(h, j));
            let t = [0, 1].map(|a| p[a].clamp(range[a].min_m, range[a].max_m));
            if out
                .iter()
                .all(|q| (q[0] - t[0]).hypot(q[1] - t[1]) >= SAME_POINT_M)
            {
                out.push(t);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Scene;
    use crate::plan::Layout;
    use crate::render::microscope::RenderSettings;
    use crate::rig::sim::build::world_for;
    use crate::rig::sim::model_physics::ModelPhysics;
    use crate::rig::sim::rig::{SimCameraConfig, SimRig};
    use crate::rig::sim::stage::{SimStage, SimStageConfig};
    use crate::rig::stage::{AxisRange, StageXyz};

    /// A simulated rig whose camera is turned 7 degrees and mirrored in y
    /// against the stage, 0.4 um a pixel, with a few particles in view.
    fn rig(truth: &CameraCalibration) -> SimRig {
        let scene = Scene::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/calib/paper-ps-ito.toml"
        )))
        .unwrap();
        let layout = Layout::of_test_centres_um(&[(20.0, 20.0), (80.0, 30.0), (50.0, 85.0)]);
        let stage = SimStage::new(
            world_for(&scene, &layout),
            Box::new(ModelPhysics::new(scene.clone())),
            SimStageConfig::default(),
            3,
        );
        let camera = SimCameraConfig {
            width_px: 300,
            height_px: 300,
            calibration: *truth,
            render: RenderSettings::with_snr(30.0, 16),
            tip_angle_rad: 60f64.to_radians(),
            frame_time_s: 0.05,
        };
        SimRig::new(stage, camera, 3)
    }

    /// [`rig`] with the tip lifted over the middle of the stage, and where that is.
    fn rig_at_middle(truth: &CameraCalibration) -> (SimRig, StageXyz) {
        let mut rig = rig(truth);
        let top = rig.range()[2].max_m;
        rig.move_to([50e-6, 50e-6, top], 1e-4).unwrap();
        let start = rig.position().unwrap();
        (rig, start)
    }

    /// A rig whose z range ends below where the stage is (a stage left at
    /// the top of its travel, soft limits 1 um under it).
    struct Narrowed(SimRig);

    impl NanoStage for Narrowed {
        fn range(&self) -> [AxisRange; 3] {
            let mut r = self.0.range();
            r[2].max_m -= 1e-6;
            r
        }
        fn position(&mut self) -> Result<StageXyz, RigError> {
            self.0.position()
        }
        fn move_to(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), RigError> {
            self.0.move_to(target, speed_m_per_s)
        }
        fn halt(&mut self) -> Result<(), RigError> {
            self.0.halt()
        }
    }

    impl Camera for Narrowed {
        fn grab(&mut self) -> Result<Option<crate::rig::camera::TimedFrame>, RigError> {
            self.0.grab()
        }
    }

    #[test]
    fn a_stage_starting_outside_its_limits_is_refused_before_any_move() {
        let (rig, start) = rig_at_middle(&truth());
        let mut rig = Narrowed(rig);
        let mut shots = 0;
        let err = run_calibration(&mut rig, &CalibrationRunSettings::default(), &mut |_| {
            shots += 1;
            Ok(())
        })
        .unwrap_err();
        assert!(
            matches!(
                err.error,
                CalibrationRunError::StartOutOfRange { axis: 'z', .. }
            ),
            "{err}"
        );
        assert_eq!(err.left, StageLeft::Untouched);
        assert_eq!((shots, rig.position().unwrap()), (0, start));
    }

    fn truth() -> CameraCalibration {
        let (s, c) = 7f64.to_radians().sin_cos();
        let k = 0.4e-6;
        CameraCalibration::affine(
            nalgebra::Matrix2::new(k * c, k * s, k * s, -k * c),
            nalgebra::Vector2::new(-5e-6, 105e-6),
        )
    }

    #[test]
    fn the_grid_covers_the_view_and_every_apex_maps_onto_its_stage_position() {
        let truth = truth();
        let (mut rig, start) = rig_at_middle(&truth);
        let mut seen = 0;
        let shots = run_calibration(&mut rig, &CalibrationRunSettings::default(), &mut |_| {
            seen += 1;
            Ok(())
        })
        .unwrap();
        assert_eq!(seen, shots.len());
        // Start, two first moves, and a 4 x 4 grid (none clipped into another here).
        assert_eq!(shots.len(), 3 + 16);
        assert!(same_place(rig.position().unwrap(), start));
        let mut xs: Vec<f64> = Vec::new();
        for s in &shots {
            let apex = s.apex_px.expect("the tip is found at every stop");
            let p = truth.pixel_to_stage_m(apex[0], apex[1]);
            let err = (p[0] - s.stage_m[0]).hypot(p[1] - s.stage_m[1]);
            assert!(err < 0.1e-6, "apex {apex:?} maps {err:e} m off the stage");
            xs.push(apex[0]);
        }
        // The grid spans the view inside its margin: 15 % to 85 % of 299 px.
        let (lo, hi) = xs
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
        assert!(lo < 0.16 * 299.0 && hi > 0.84 * 299.0, "{lo} .. {hi}");
    }

    /// Within five sigmas of the simulated stage's 10 nm precision.
    fn same_place(a: StageXyz, b: StageXyz) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 50e-9)
    }

    #[test]
    fn without_a_tip_in_view_the_run_says_so_and_the_stage_goes_back() {
        // The camera looks at the sample 500 um away from the stage's travel.
        let off_view = CameraCalibration {
            offset_m: nalgebra::Vector2::new(-500e-6, 600e-6),
            ..truth()
        };
        let mut rig = rig(&off_view);
        let start = rig.position().unwrap();
        let err = run_calibration(
            &mut rig,
            &CalibrationRunSettings::default(),
            &mut |_| Ok(()),
        )
        .unwrap_err();
        assert!(
            matches!(err.error, CalibrationRunError::NoTipAtStart),
            "{err}"
        );
        // Lifted and lowered again: x and y never moved.
        assert_eq!(err.left, StageLeft::PutBack { xy_moved: false });
        assert!(same_place(rig.position().unwrap(), start));
    }

    /// A rig that remembers every target it was sent.
    struct Logged {
        rig: SimRig,
        targets: Vec<StageXyz>,
    }

    impl NanoStage for Logged {
        fn range(&self) -> [crate::rig::stage::AxisRange; 3] {
            self.rig.range()
        }
        fn position(&mut self) -> Result<StageXyz, RigError> {
            self.rig.position()
        }
        fn move_to(&mut self, target: StageXyz, speed: f64) -> Result<(), RigError> {
            self.targets.push(target);
            self.rig.move_to(target, speed)
        }
        fn halt(&mut self) -> Result<(), RigError> {
            self.rig.halt()
        }
    }

    impl Camera for Logged {
        fn grab(&mut self) -> Result<Option<crate::rig::camera::TimedFrame>, RigError> {
            self.rig.grab()
        }
    }

    #[test]
    fn the_tip_travels_at_the_height_asked_and_one_off_the_range_is_refused() {
        let mut rig = rig(&truth());
        rig.move_to([50e-6, 50e-6, 3e-6], 1e-4).unwrap();
        let mut logged = Logged {
            rig,
            targets: Vec::new(),
        };
        let settings = CalibrationRunSettings {
            grid: 2,
            travel_z_m: Some(12e-6),
            ..Default::default()
        };
        let shots = run_calibration(&mut logged, &settings, &mut |_| Ok(())).unwrap();
        assert_eq!(shots.len(), 3 + 4);
        // Up to 12 um first, every move there, and down to 3 um last.
        let (last, travel) = logged.targets.split_last().unwrap();
        assert!(travel.iter().all(|t| t[2] == 12e-6), "{travel:?}");
        assert_eq!(last[2], 3e-6);
        logged.targets.clear();
        let err = run_calibration(
            &mut logged,
            &CalibrationRunSettings {
                travel_z_m: Some(16e-6),
                ..Default::default()
            },
            &mut |_| Ok(()),
        )
        .unwrap_err();
        assert!(
            matches!(err.error, CalibrationRunError::HeightOutOfRange { .. }),
            "{err}"
        );
        assert!(logged.targets.is_empty());
    }

    #[test]
    fn a_shot_that_cannot_be_kept_stops_the_run_and_the_stage_goes_back() {
        let (mut rig, start) = rig_at_middle(&truth());
        let mut kept = 0;
        let err = run_calibration(&mut rig, &CalibrationRunSettings::default(), &mut |_| {
            kept += 1;
            if kept == 5 {
                Err("disk full".into())
            } else {
                Ok(())
            }
        })
        .unwrap_err();
        assert!(
            matches!(&err.error, CalibrationRunError::Shot(m) if m == "disk full"),
            "{err}"
        );
        assert_eq!(err.left, StageLeft::PutBack { xy_moved: true });
        // Start, two first moves, two grid stops: no stop after the failed one.
        assert_eq!(kept, 5);
        assert!(same_place(rig.position().unwrap(), start));
    }

    #[test]
    fn bad_settings_are_refused_before_anything_moves() {
        let mut rig = rig(&truth());
        let start = rig.position().unwrap();
        for settings in [
            CalibrationRunSettings {
                grid: 1,
                ..Default::default()
            },
            CalibrationRunSettings {
                probe_step_m: f64::NAN,
                ..Default::default()
            },
            CalibrationRunSettings {
                margin: 0.5,
                ..Default::default()
            },
        ] {
            let err = run_calibration(&mut rig, &settings, &mut |_| Ok(())).unwrap_err();
            assert!(
                matches!(err.error, CalibrationRunError::Settings(_)),
                "{err}"
            );
        }
        assert_eq!(rig.frames(), 0);
        assert_eq!(rig.position().unwrap(), start);
    }
}
