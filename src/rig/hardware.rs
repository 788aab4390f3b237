//! The hardware rig: a PI GCS 2.0 nanostage, an optional coarse stage, a
//! camera from the rig file, the rig file's pixel-to-stage calibration, and
//! wall-clock time, behind the same [`Rig`] trait the executor drives on the
//! simulated rig.
//!
//! [`GcsNanoStage`] maps stage axes x, y[, z] to the rig file's controller
//! axes, speaks metres, and makes every move a straight line
//! ([`GcsLineStage`]). A two-axis stage does not drive z: its z range is the
//! single point 0. The coarse stage, when the rig file has a `[coarse]`
//! section, is a [`GcsCoarseStage`] on its own controller.
//!
//! Safety is the GCS stage's (soft limits, largest step, top speed checked
//! before any byte is sent; confirmation before the first move on real
//! hardware; Ctrl-C sends `HLT`; a failure or drop while moving halts).

use super::Rig;
use super::camera::{Camera, TimedFrame};
use super::camera_clock::WallClock;
use super::camera_error::CameraError;
use super::camera_open::{BoxedCamera, open_camera};
use super::error::RigError;
use super::gcs::rig_file::ZConvention;
use super::gcs::{
    self, GcsError, GcsStage, OperatorWait, RigFile, RigFileError, SentLog, StageOpening,
};
use super::gcs_coarse_stage::GcsCoarseStage;
use super::gcs_line_stage::{GcsLineStage, snap_into_range};
use super::stage::{AxisRange, CoarseStage, NanoStage, StageXyz, check_in_range};
use crate::calib::camera_map::{CalibError, CameraCalibration};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// A GCS stage as the executor's nanostage.
pub struct GcsNanoStage {
    line: GcsLineStage,
    /// x, y as the controller's; z as the height above the substrate.
    range: [AxisRange; 3],
    z: ZConvention,
}

impl GcsNanoStage {
    /// The rig file's nanostage on a connected `controller`, behind every
    /// check `assemble --rig` opens it with ([`gcs::stage_on`]: its axes on
    /// the controller; its soft limits, in the rig file's `unit_um`, within
    /// their travel): `rig probe` makes the same on the controller it has
    /// queried, where it had checked none.
    pub fn on_controller(
        controller: gcs::GcsController,
        rig: &RigFile,
        opening: &StageOpening,
    ) -> Result<Self, GcsError> {
        let stage = gcs::stage_on(controller, &rig.stage, rig.stage_settings(), opening)?;
        Self::new(stage, Arc::clone(&opening.interrupt), rig.z_convention())
    }

    /// Wraps a stage of two (x, y) or three (x, y, z) axes. The range is the
    /// rig file's soft limits narrowed to the controller's travel (`TMN?`/`TMX?`).
    /// `interrupt` is the stage's Ctrl-C flag: while it is up, moves are
    /// refused before anything (not even `VEL`) is sent.
    pub fn new(
        stage: GcsStage,
        interrupt: Arc<AtomicBool>,
        z: ZConvention,
    ) -> Result<Self, GcsError> {
        let n = stage.settings().axes.len();
        if !(2..=3).contains(&n) {
            return Err(GcsError::InvalidArgument(format!(
                "a nanostage needs 2 (x, y) or 3 (x, y, z) axes, the rig file names {n}"
            )));
        }
        let line = GcsLineStage::new(stage, interrupt, &['x', 'y', 'z'][..n])?;
        let mut range = [AxisRange {
            min_m: 0.0,
            max_m: 0.0,
        }; 3];
        range[..n].copy_from_slice(line.range());
        if n == 3 {
            let (a, b) = (z.height(range[2].min_m), z.height(range[2].max_m));
            range[2] = AxisRange {
                min_m: a.min(b),
                max_m: a.max(b),
            };
        }
        Ok(Self { line, range, z })
    }

    /// The GCS stage underneath (for queries the trait does not cover).
    pub fn gcs(&mut self) -> &mut GcsStage {
        self.line.gcs()
    }

    fn axes(&self) -> usize {
        self.line.range().len()
    }
}

impl NanoStage for GcsNanoStage {
    fn range(&self) -> [AxisRange; 3] {
        self.range
    }

    fn position(&mut self) -> Result<StageXyz, RigError> {
        let p = self.line.position_m()?;
        Ok([p[0], p[1], p.get(2).map_or(0.0, |&z| self.z.height(z))])
    }

    /// Targets within a picometre outside the range are snapped onto it
    /// ([`snap_into_range`]).
    fn move_to(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), RigError> {
        let target: StageXyz = std::array::from_fn(|i| snap_into_range(target[i], &self.range[i]));
        check_in_range(target, &self.range)?;
        let n = self.axes();
        let stage = [target[0], target[1], self.z.stage_z(target[2])];
        self.line.move_to_m_in_pieces(&stage[..n], speed_m_per_s)
    }

    fn halt(&mut self) -> Result<(), RigError> {
        self.line.halt()
    }
}

/// How [`HardwareRig::open`] opens a rig.
#[derive(Default)]
pub struct HardwareRigOptions {
    /// Open no stage link: log every byte that would be sent (see
    /// [`RigDevices::sent_log`]) while an in-process simulator answers.
    /// The camera is still opened (reading frames moves nothing).
    pub dry_run: bool,
    /// The explicit CLI flag that waives the confirmation before the first
    /// move on a rig file with `real_hardware = true`.
    pub waive_confirmation: bool,
    /// The Ctrl-C flag; `None` installs the process's Ctrl-C handler
    /// ([`crate::rig::interrupt::ctrlc_flag`]). Raising it halts the stage.
    pub interrupt: Option<Arc<AtomicBool>>,
    /// A camera to use instead of the rig file's (required for `kind = "simulated"`).
    pub camera: Option<BoxedCamera>,
    /// A coarse stage to use instead of the rig file's `[coarse]` section;
    /// with neither, coarse moves fail with [`RigError::NoCoarseStage`].
    pub coarse: Option<Box<dyn CoarseStage + Send>>,
    /// Rig time at opening, seconds: 0 for a new run; a resumed run's
    /// journal's last time, so that its times go on rising.
    pub clock_from_s: f64,
}

/// Why a hardware rig could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum HardwareRigError {
    /// The rig file is missing or invalid.
    #[error(transparent)]
    RigFile(#[from] RigFileError),
    /// The calibration the rig file names could not be loaded.
    #[error("calibration {path} named by the rig file: {source}{}", not_made_yet(.source))]
    Calibration {
        /// The calibration file.
        path: PathBuf,
        /// What was wrong.
        source: CalibError,
    },
    /// The stage could not be reached or set up.
    #[error("stage: {0}")]
    Stage(#[from] GcsError),
    /// The coarse stage could not be reached or set up.
    #[error("coarse stage: {0}")]
    Coarse(GcsError),
    /// The camera could not be opened.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// The Ctrl-C handler could not be installed.
    #[error("cannot install the Ctrl-C handler: {0}")]
    Interrupt(#[from] ctrlc::Error),
}

/// The devices a rig file names, opened: the nanostage, the optional coarse
/// stage and the camera, with the rig's clock. What [`HardwareRig`] drives
/// once a calibration maps the camera onto the stage, and what `nanopush
/// rig calibrate` drives to measure that calibration.
pub struct RigDevices {
    stage: GcsNanoStage,
    coarse: Option<Box<dyn CoarseStage + Send>>,
    /// Subtracted from the coarse stage's offsets: moves the sample frame's
    /// origin (see [`RigDevices::reframe_sample`]).
    coarse_shift_m: [f64; 2],
    coarse_sent_log: Option<SentLog>,
    camera: BoxedCamera,
    clock: WallClock,
    rig_file: RigFile,
    sent_log: Option<SentLog>,
    interrupt: Arc<AtomicBool>,
    /// Rig time when the stage last came to rest (a move or halt returned).
    settled_at_s: f64,
    /// True once a move was handed to the coarse stage.
    coarse_asked: bool,
    /// Where the coarse stage last stood for sure, in its own readings (no
    /// shift): its last reading, or the target of its last move that
    /// ended on target; `None` before either, and after a move that failed
    /// (it may have stopped anywhere). See [`RigDevices::coarse_position_known`].
    coarse_known_raw: Option<[f64; 2]>,
    stale_frames: usize,
    /// What the stages' first-move confirmations waited for the operator.
    operator_wait: OperatorWait,
}

/// Loads the pixel-to-stage calibration `rig` names.
pub fn load_rig_calibration(rig: &RigFile) -> Result<CameraCalibration, HardwareRigError> {
    CameraCalibration::load(&rig.calibration).map_err(|source| HardwareRigError::Calibration {
        path: rig.calibration.clone(),
        source,
    })
}

/// How to make a calibration that does not exist yet (empty otherwise).
fn not_made_yet(e: &CalibError) -> &'static str {
    match e {
        CalibError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            " (not made yet? `nanopush rig calibrate --rig FILE` measures it on the rig)"
        }
        _ => "",
    }
}

/// A rig of real (or simulated-controller) hardware with its pixel-to-stage
/// calibration, driven through [`Rig`]. Its devices' queries
/// ([`RigDevices`]) are reached through it.
pub struct HardwareRig {
    devices: RigDevices,
    calibration: CameraCalibration,
}

/// Lowest the tip may be below the top of its z travel for a coarse move:
/// the coarse stage would drag a lowered tip through the sample.
const RETRACTED_TOLERANCE_M: f64 = 0.1e-6;

/// Longest a grab keeps discarding frames exposed before the stage settled.
const STALE_FRAME_PATIENCE: std::time::Duration = std::time::Duration::from_secs(5);

impl HardwareRig {
    /// Opens everything a rig file names: the calibration, then its devices
    /// ([`RigDevices::open`]).
    pub fn open(rig_file: &Path, opts: HardwareRigOptions) -> Result<Self, HardwareRigError> {
        Self::from_rig_file(RigFile::load(rig_file)?, opts)
    }

    /// [`HardwareRig::open`] of a rig file already read (and checked by
    /// the caller before anything is connected).
    pub fn from_rig_file(rig: RigFile, opts: HardwareRigOptions) -> Result<Self, HardwareRigError> {
        let calibration = load_rig_calibration(&rig)?;
        Ok(Self {
            devices: RigDevices::open(rig, opts)?,
            calibration,
        })
    }
}

impl std::ops::Deref for HardwareRig {
    type Target = RigDevices;
    fn deref(&self) -> &RigDevices {
        &self.devices
    }
}

impl std::ops::DerefMut for HardwareRig {
    fn deref_mut(&mut self) -> &mut RigDevices {
        &mut self.devices
    }
}

impl RigDevices {
    /// Opens the devices of a loaded rig file: the stage (behind the safety
    /// checks, in dry run if asked), the coarse stage if it has one, and the
    /// camera (unless one is given in `opts`). Rig time starts now, at
    /// `opts.clock_from_s`. The calibration the rig file names is not read.
    pub fn open(rig: RigFile, opts: HardwareRigOptions) -> Result<Self, HardwareRigError> {
        let clock = WallClock::continuing_from(opts.clock_from_s);
        let interrupt = match opts.interrupt {
            Some(flag) => flag,
            None => crate::rig::interrupt::ctrlc_flag()?,
        };
        let mut camera = match opts.camera {
            Some(camera) => camera,
            None => open_camera(&rig.camera, clock)?,
        };
        camera.stop_waiting_on(Arc::clone(&interrupt));
        let opening = StageOpening {
            dry_run: opts.dry_run,
            waive_confirmation: opts.waive_confirmation,
            interrupt: Arc::clone(&interrupt),
            operator_wait: OperatorWait::default(),
        };
        let operator_wait = opening.operator_wait.clone();
        let (controller, sent_log) = gcs::connect(&rig, opts.dry_run)?;
        let stage = GcsNanoStage::on_controller(controller, &rig, &opening)?;
        let (coarse, coarse_sent_log) = match (opts.coarse, &rig.coarse) {
            (Some(given), _) => (Some(given), None),
            (None, Some(section)) => {
                let (coarse, log) = gcs::connect_coarse(section, opts.dry_run)
                    .and_then(|(controller, log)| {
                        Ok((
                            GcsCoarseStage::on_controller(controller, section, &opening)?,
                            log,
                        ))
                    })
                    .map_err(HardwareRigError::Coarse)?;
                let boxed: Box<dyn CoarseStage + Send> = Box::new(coarse);
                (Some(boxed), log)
            }
            (None, None) => (None, None),
        };
        Ok(Self {
            stage,
            coarse,
            coarse_shift_m: [0.0, 0.0],
            coarse_known_raw: None,
            coarse_sent_log,
            camera,
            clock,
            rig_file: rig,
            sent_log,
            interrupt,
            settled_at_s: f64::NEG_INFINITY,
            coarse_asked: false,
            stale_frames: 0,
            operator_wait,
        })
    }

    /// Frames discarded so far because they were exposed before the stage
    /// had settled after its last move.
    pub fn stale_frames(&self) -> usize {
        self.stale_frames
    }

    fn settled(&mut self) {
        self.settled_at_s = self.clock.now_s();
    }

    /// The rig file as loaded (paths resolved).
    pub fn rig_file(&self) -> &RigFile {
        &self.rig_file
    }

    /// In a dry run, every byte that would have gone to the stage.
    pub fn sent_log(&self) -> Option<&SentLog> {
        self.sent_log.as_ref()
    }

    /// In a dry run, every byte that would have gone to the coarse stage's controller.
    pub fn coarse_sent_log(&self) -> Option<&SentLog> {
        self.coarse_sent_log.as_ref()
    }

    /// True when the rig has a coarse stage.
    pub fn has_coarse(&self) -> bool {
        self.coarse.is_some()
    }

    /// Moves the sample frame (not the stage): from now on the coarse stage,
    /// where it stands, reads `offset_m`. A run chooses its own frame this
    /// way (the planner's field starts at the origin); the sample frame a
    /// rig opens with is the nanostage's (offset zero).
    pub fn reframe_sample(&mut self, offset_m: [f64; 2]) -> Result<(), RigError> {
        let Some(c) = &mut self.coarse else {
            return Err(RigError::NoCoarseStage);
        };
        let raw = c.coarse_position()?;
        self.coarse_known_raw = Some(raw);
        self.coarse_shift_m = [raw[0] - offset_m[0], raw[1] - offset_m[1]];
        Ok(())
    }

    /// Where the coarse stage stands, in the sample frame, as last known
    /// without asking it: its last reading, or the target of its last move
    /// that ended on target. `None` without a coarse stage, before either,
    /// or after a coarse move that failed. What a run that lost the coarse
    /// stage's link still knows of it (its sites' pixels need it).
    pub fn coarse_position_known(&self) -> Option<[f64; 2]> {
        self.coarse.as_ref()?;
        let raw = self.coarse_known_raw?;
        Some([0, 1].map(|k| raw[k] - self.coarse_shift_m[k]))
    }

    /// What the run's sample frame subtracts from the coarse stage's
    /// readings, in the stage's own fixed coordinates (metres, see
    /// [`CoarseStage::coarse_zero_m`]), so that it means the same to
    /// another process; `None` without a coarse stage.
    pub fn sample_frame_shift_m(&self) -> Option<[f64; 2]> {
        let zero = self.coarse.as_ref()?.coarse_zero_m();
        Some([0, 1].map(|k| self.coarse_shift_m[k] + zero[k]))
    }

    /// Puts back a sample frame that [`RigDevices::sample_frame_shift_m`]
    /// read, maybe in another process (a resumed run's): the coarse
    /// stage's readings then mean what they meant to the run.
    pub fn restore_sample_frame(&mut self, shift_m: [f64; 2]) -> Result<(), RigError> {
        let Some(c) = &self.coarse else {
            return Err(RigError::NoCoarseStage);
        };
        let zero = c.coarse_zero_m();
        self.coarse_shift_m = [0, 1].map(|k| shift_m[k] - zero[k]);
        Ok(())
    }

    /// The nanostage (for GCS queries beyond the trait).
    pub fn nanostage(&mut self) -> &mut GcsNanoStage {
        &mut self.stage
    }

    /// True when the operator declined the nanostage's first move and the
    /// coarse stage was never asked to move: nothing moved, so a command
    /// may leave its output as it found it.
    pub fn declined_before_any_move(&mut self) -> bool {
        !self.coarse_asked && self.stage.gcs().first_move_refused()
    }

    /// True once a move was sent to the nanostage or handed to the coarse
    /// stage: a command that ends before tells that nothing moved
    /// (`rig calibrate` had said "the stage stopped at ...; it was not put
    /// back").
    pub fn moved_any(&mut self) -> bool {
        self.coarse_asked || self.stage.gcs().move_sent()
    }

    /// The Ctrl-C flag the stage watches.
    pub fn interrupt_flag(&self) -> &Arc<AtomicBool> {
        &self.interrupt
    }
}

impl Rig for HardwareRig {
    /// Wall time since the rig was opened.
    fn now_s(&self) -> f64 {
        self.devices.clock.now_s()
    }
    fn calibration(&self) -> &CameraCalibration {
        &self.calibration
    }
    fn take_operator_wait_s(&mut self) -> f64 {
        self.devices.operator_wait.take_s()
    }
}

impl NanoStage for HardwareRig {
    fn range(&self) -> [AxisRange; 3] {
        self.devices.range()
    }
    fn position(&mut self) -> Result<StageXyz, RigError> {
        self.devices.position()
    }
    fn move_to(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), RigError> {
        self.devices.move_to(target, speed_m_per_s)
    }
    fn halt(&mut self) -> Result<(), RigError> {
        self.devices.halt()
    }
}

impl CoarseStage for HardwareRig {
    fn coarse_position(&mut self) -> Result<[f64; 2], RigError> {
        self.devices.coarse_position()
    }
    fn move_coarse(&mut self, target: [f64; 2]) -> Result<(), RigError> {
        self.devices.move_coarse(target)
    }
    fn halt_coarse(&mut self) -> Result<(), RigError> {
        self.devices.halt_coarse()
    }
}

impl Camera for HardwareRig {
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        self.devices.grab()
    }
}

impl NanoStage for RigDevices {
    fn range(&self) -> [AxisRange; 3] {
        self.stage.range()
    }
    fn position(&mut self) -> Result<StageXyz, RigError> {
        self.stage.position()
    }
    fn move_to(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), RigError> {
        let moved = self.stage.move_to(target, speed_m_per_s);
        self.settled();
        moved
    }
    /// Halts the nanostage and the coarse stage.
    fn halt(&mut self) -> Result<(), RigError> {
        let halted = self.stage.halt();
        let coarse = self.halt_coarse();
        self.settled();
        halted.and(coarse)
    }
}

impl CoarseStage for RigDevices {
    fn coarse_position(&mut self) -> Result<[f64; 2], RigError> {
        let shift = self.coarse_shift_m;
        match &mut self.coarse {
            Some(c) => {
                let raw = c.coarse_position()?;
                self.coarse_known_raw = Some(raw);
                Ok([raw[0] - shift[0], raw[1] - shift[1]])
            }
            None => Err(RigError::NoCoarseStage),
        }
    }

    /// Refused before anything moves unless the tip is retracted (the
    /// nanostage at the top of its z travel): the coarse stage would drag a
    /// lowered tip through the sample. Frames exposed before the move ended
    /// are stale afterwards.
    fn move_coarse(&mut self, target: [f64; 2]) -> Result<(), RigError> {
        if self.coarse.is_none() {
            return Err(RigError::NoCoarseStage);
        }
        let top = self.stage.range()[2].max_m;
        let z = self.stage.position()?[2];
        if z < top - RETRACTED_TOLERANCE_M {
            return Err(RigError::StageFault(format!(
                "coarse move refused: the tip is not retracted (z = {:.3} um, top of travel {:.3} um)",
                z * 1e6,
                top * 1e6
            )));
        }
        let shift = self.coarse_shift_m;
        self.coarse_asked = true;
        let raw = [target[0] + shift[0], target[1] + shift[1]];
        let moved = match &mut self.coarse {
            Some(c) => c.move_coarse(raw),
            None => Err(RigError::NoCoarseStage),
        };
        // A move that failed may have stopped anywhere on its way.
        self.coarse_known_raw = moved.is_ok().then_some(raw);
        self.settled();
        moved
    }

    fn halt_coarse(&mut self) -> Result<(), RigError> {
        match &mut self.coarse {
            Some(c) => c.halt_coarse(),
            None => Ok(()),
        }
    }
}

impl Camera for RigDevices {
    /// The next frame exposed after the stage last came to rest: a frame
    /// from before (a camera program's backlog, or one exposed while the
    /// stage was still moving) shows particles where they no longer are and
    /// is discarded. After `STALE_FRAME_PATIENCE` of stale frames, `Ok(None)`.
    /// Once Ctrl-C is pressed, [`RigError::Interrupted`] before asking the
    /// camera: a camera giving no frame is asked again and again, each for
    /// its timeout, where a press had gone unseen (no stage command checks).
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        let started = std::time::Instant::now();
        loop {
            if self.interrupt.load(std::sync::atomic::Ordering::SeqCst) {
                return Err(RigError::Interrupted);
            }
            match self.camera.grab()? {
                Some(f) if f.t_s < self.settled_at_s => {
                    self.stale_frames += 1;
                    tracing::debug!(
                        "frame exposed at {:.3} s, before the stage settled at {:.3} s: discarded",
                        f.t_s,
                        self.settled_at_s
                    );
                    if started.elapsed() >= STALE_FRAME_PATIENCE {
                        return Ok(None);
                    }
                }
                other => return Ok(other),
            }
        }
    }
}
