//! The hardware rig: a PI GCS 2.0 nanostage, an optional coarse stage, a
//! camera from the rig file, the rig file's pixel-to-stage calibration, and
//! wall-clock time, behind the same [`Rig`] trait the executor drives on the
//! simulated rig.
//!
//! [`GcsNanoStage`] maps stage axes x, y[, z] to the rig file's controller
//! axes, speaks metres, and makes every move a straight line: each axis gets
//! the share of the speed that its part of the displacement asks for (GCS
//! `VEL` is per axis, so one common velocity would bend a diagonal move). A
//! two-axis stage does not drive z: its z range is the single point 0.
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
use super::gcs::{self, GcsError, GcsStage, RigFile, RigFileError, SafetyViolation, SentLog};
use super::stage::{AxisRange, CoarseStage, NanoStage, StageXyz, check_in_range};
use crate::calib::affine::{AffineCalibration, CalibError};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A GCS stage as the executor's nanostage.
pub struct GcsNanoStage {
    stage: GcsStage,
    endpoint: String,
    range: [AxisRange; 3],
    servo_on: bool,
    interrupt: Arc<AtomicBool>,
    /// Last velocity set per axis, controller units per second.
    velocity_units: Vec<Option<f64>>,
}

impl GcsNanoStage {
    /// Wraps a stage of two (x, y) or three (x, y, z) axes. The range is the
    /// rig file's soft limits narrowed to the controller's travel (`TMN?`/`TMX?`).
    /// `interrupt` is the stage's Ctrl-C flag: while it is up, moves are
    /// refused before anything (not even `VEL`) is sent.
    pub fn new(mut stage: GcsStage, interrupt: Arc<AtomicBool>) -> Result<Self, GcsError> {
        let settings = stage.settings().clone();
        let n = settings.axes.len();
        if !(2..=3).contains(&n) {
            return Err(GcsError::InvalidArgument(format!(
                "a nanostage needs 2 (x, y) or 3 (x, y, z) axes, the rig file names {n}"
            )));
        }
        let axes: Vec<&str> = settings.axes.iter().map(String::as_str).collect();
        let tmn = stage.controller().travel_min(&axes)?;
        let tmx = stage.controller().travel_max(&axes)?;
        let mut range = [AxisRange {
            min_m: 0.0,
            max_m: 0.0,
        }; 3];
        for i in 0..n {
            let soft = settings.limits.soft_limits[i];
            range[i] = AxisRange {
                min_m: soft.min_m.max(tmn[i] * settings.unit_m),
                max_m: soft.max_m.min(tmx[i] * settings.unit_m),
            };
            if range[i].min_m > range[i].max_m {
                return Err(GcsError::InvalidArgument(format!(
                    "axis {}: soft limits {:.3}..{:.3} um lie outside the controller's travel {:.3}..{:.3} um",
                    settings.axes[i],
                    soft.min_m * 1e6,
                    soft.max_m * 1e6,
                    tmn[i] * settings.unit_m * 1e6,
                    tmx[i] * settings.unit_m * 1e6
                )));
            }
        }
        Ok(Self {
            endpoint: stage.controller().endpoint(),
            stage,
            range,
            servo_on: false,
            interrupt,
            velocity_units: vec![None; n],
        })
    }

    /// The GCS stage underneath (for queries the trait does not cover).
    pub fn gcs(&mut self) -> &mut GcsStage {
        &mut self.stage
    }

    fn axes(&self) -> usize {
        self.velocity_units.len()
    }

    /// Per-axis velocities (controller units) that make the move from
    /// `from` to `to` a straight line at `speed_m_per_s`; axes that do not
    /// move keep their velocity (`VEL 0` is refused by controllers).
    fn set_line_velocities(
        &mut self,
        from: &[f64],
        to: &[f64],
        speed_m_per_s: f64,
    ) -> Result<(), GcsError> {
        let length: f64 = from
            .iter()
            .zip(to)
            .map(|(a, b)| (b - a).powi(2))
            .sum::<f64>()
            .sqrt();
        if length == 0.0 {
            return Ok(());
        }
        let unit_m = self.stage.settings().unit_m;
        let axes = self.stage.settings().axes.clone();
        let mut pairs = Vec::new();
        for (i, axis) in axes.iter().enumerate() {
            let share = (to[i] - from[i]).abs() / length;
            if share < 1e-9 {
                continue;
            }
            // Rounded like positions, so that equal speeds are not re-sent.
            let units = (speed_m_per_s * share / unit_m * 1e9).round() / 1e9;
            if units > 0.0 && self.velocity_units[i] != Some(units) {
                pairs.push((axis.as_str(), units, i));
            }
        }
        if pairs.is_empty() {
            return Ok(());
        }
        let wire: Vec<(&str, f64)> = pairs.iter().map(|&(a, u, _)| (a, u)).collect();
        self.stage.controller().set_velocity(&wire)?;
        for (_, units, i) in pairs {
            self.velocity_units[i] = Some(units);
        }
        Ok(())
    }

    fn move_checked(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), GcsError> {
        let n = self.axes();
        if self.interrupt.load(Ordering::SeqCst) {
            // The stage halted when the flag was seen; make sure, then refuse.
            let _ = self.stage.halt();
            return Err(GcsError::Interrupted);
        }
        self.stage
            .settings()
            .limits
            .check_speed(speed_m_per_s)
            .map_err(GcsError::Safety)?;
        if !self.servo_on {
            self.stage.enable_servo()?;
            self.servo_on = true;
        }
        let from = self.stage.position_m()?;
        // Limits and step are checked again by the stage before MOV; checking
        // here first keeps a refused move from touching VEL.
        let limits = &self.stage.settings().limits;
        limits.check_target(&self.stage.settings().axes, &target[..n])?;
        limits.check_step(&from, &target[..n])?;
        self.set_line_velocities(&from, &target[..n], speed_m_per_s)?;
        self.stage.move_to_m(&target[..n])
    }

    /// Maps a driver error to the executor's error, naming axes x, y, z.
    fn rig_error(&self, e: GcsError) -> RigError {
        let axis_name = |id: &str| {
            self.stage
                .settings()
                .axes
                .iter()
                .position(|a| a == id)
                .map_or('?', |i| ['x', 'y', 'z'][i])
        };
        match e {
            GcsError::Safety(SafetyViolation::OutsideSoftLimits {
                axis,
                target_m,
                min_m,
                max_m,
            }) => RigError::OutOfRange {
                axis: axis_name(&axis),
                target_um: target_m * 1e6,
                min_um: min_m * 1e6,
                max_um: max_m * 1e6,
            },
            GcsError::Safety(SafetyViolation::StepTooLarge { step_m, max_step_m }) => {
                RigError::StepTooLarge {
                    step_um: step_m * 1e6,
                    max_um: max_step_m * 1e6,
                }
            }
            GcsError::Safety(SafetyViolation::SpeedNotAllowed {
                speed_m_per_s,
                max_speed_m_per_s,
            }) => RigError::BadSpeed {
                speed_um_s: speed_m_per_s * 1e6,
                max_um_s: max_speed_m_per_s * 1e6,
            },
            GcsError::Timeout {
                command, timeout, ..
            } => RigError::Timeout {
                device: format!("stage {} (`{command}`)", self.endpoint),
                timeout_ms: timeout.as_millis() as u64,
            },
            other => RigError::StageFault(other.to_string()),
        }
    }
}

impl NanoStage for GcsNanoStage {
    fn range(&self) -> [AxisRange; 3] {
        self.range
    }

    fn position(&mut self) -> Result<StageXyz, RigError> {
        let p = self.stage.position_m().map_err(|e| self.rig_error(e))?;
        Ok([p[0], p[1], p.get(2).copied().unwrap_or(0.0)])
    }

    fn move_to(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), RigError> {
        check_in_range(target, &self.range)?;
        self.move_checked(target, speed_m_per_s)
            .map_err(|e| self.rig_error(e))
    }

    fn halt(&mut self) -> Result<(), RigError> {
        self.stage.halt().map_err(|e| self.rig_error(e))
    }
}

/// How [`HardwareRig::open`] opens a rig.
#[derive(Default)]
pub struct HardwareRigOptions {
    /// Open no stage link: log every byte that would be sent (see
    /// [`HardwareRig::sent_log`]) while an in-process simulator answers.
    /// The camera is still opened (reading frames moves nothing).
    pub dry_run: bool,
    /// The explicit CLI flag that waives the confirmation before the first
    /// move on a rig file with `real_hardware = true`.
    pub waive_confirmation: bool,
    /// The Ctrl-C flag; `None` installs the process's Ctrl-C handler
    /// ([`gcs::interrupt::ctrlc_flag`]). Raising it halts the stage.
    pub interrupt: Option<Arc<AtomicBool>>,
    /// A camera to use instead of the rig file's (required for `kind = "simulated"`).
    pub camera: Option<BoxedCamera>,
    /// A coarse stage; without one, coarse moves fail with [`RigError::NoCoarseStage`].
    pub coarse: Option<Box<dyn CoarseStage + Send>>,
}

/// Why a hardware rig could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum HardwareRigError {
    /// The rig file is missing or invalid.
    #[error(transparent)]
    RigFile(#[from] RigFileError),
    /// The calibration the rig file names could not be loaded.
    #[error("calibration {path} named by the rig file: {source}")]
    Calibration {
        /// The calibration file.
        path: PathBuf,
        /// What was wrong.
        source: CalibError,
    },
    /// The stage could not be reached or set up.
    #[error("stage: {0}")]
    Stage(#[from] GcsError),
    /// The camera could not be opened.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// The Ctrl-C handler could not be installed.
    #[error("cannot install the Ctrl-C handler: {0}")]
    Interrupt(#[from] ctrlc::Error),
}

/// A rig of real (or simulated-controller) hardware, driven through [`Rig`].
pub struct HardwareRig {
    stage: GcsNanoStage,
    coarse: Option<Box<dyn CoarseStage + Send>>,
    camera: BoxedCamera,
    calibration: AffineCalibration,
    clock: WallClock,
    rig_file: RigFile,
    sent_log: Option<SentLog>,
    interrupt: Arc<AtomicBool>,
    /// Rig time when the stage last came to rest (a move or halt returned).
    settled_at_s: f64,
    stale_frames: usize,
}

/// Longest a grab keeps discarding frames exposed before the stage settled.
const STALE_FRAME_PATIENCE: std::time::Duration = std::time::Duration::from_secs(5);

impl HardwareRig {
    /// Opens everything a rig file names: the calibration, the stage (behind
    /// the safety checks, in dry run if asked), and the camera (unless one is
    /// given in `opts`). Rig time starts now.
    pub fn open(rig_file: &Path, opts: HardwareRigOptions) -> Result<Self, HardwareRigError> {
        let rig = RigFile::load(rig_file)?;
        let calibration = AffineCalibration::load(&rig.calibration).map_err(|source| {
            HardwareRigError::Calibration {
                path: rig.calibration.clone(),
                source,
            }
        })?;
        let clock = WallClock::start();
        let camera = match opts.camera {
            Some(camera) => camera,
            None => open_camera(&rig.camera, clock)?,
        };
        let interrupt = match opts.interrupt {
            Some(flag) => flag,
            None => gcs::interrupt::ctrlc_flag()?,
        };
        let (stage, sent_log) = gcs::open_stage(
            &rig,
            opts.dry_run,
            opts.waive_confirmation,
            Arc::clone(&interrupt),
        )?;
        Ok(Self {
            stage: GcsNanoStage::new(stage, Arc::clone(&interrupt))?,
            coarse: opts.coarse,
            camera,
            calibration,
            clock,
            rig_file: rig,
            sent_log,
            interrupt,
            settled_at_s: f64::NEG_INFINITY,
            stale_frames: 0,
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

    /// The nanostage (for GCS queries beyond the trait).
    pub fn nanostage(&mut self) -> &mut GcsNanoStage {
        &mut self.stage
    }

    /// The Ctrl-C flag the stage watches.
    pub fn interrupt_flag(&self) -> &Arc<AtomicBool> {
        &self.interrupt
    }
}

impl Rig for HardwareRig {
    /// Wall time since the rig was opened.
    fn now_s(&self) -> f64 {
        self.clock.now_s()
    }
    fn calibration(&self) -> &AffineCalibration {
        &self.calibration
    }
}

impl NanoStage for HardwareRig {
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
    fn halt(&mut self) -> Result<(), RigError> {
        let halted = self.stage.halt();
        self.settled();
        halted
    }
}

impl CoarseStage for HardwareRig {
    fn coarse_position(&mut self) -> Result<[f64; 2], RigError> {
        match &mut self.coarse {
            Some(c) => c.coarse_position(),
            None => Err(RigError::NoCoarseStage),
        }
    }
    fn move_coarse(&mut self, target: [f64; 2]) -> Result<(), RigError> {
        match &mut self.coarse {
            Some(c) => c.move_coarse(target),
            None => Err(RigError::NoCoarseStage),
        }
    }
}

impl Camera for HardwareRig {
    /// The next frame exposed after the stage last came to rest: a frame
    /// from before (a camera program's backlog, or one exposed while the
    /// stage was still moving) shows particles where they no longer are and
    /// is discarded. After [`STALE_FRAME_PATIENCE`] of stale frames, `Ok(None)`.
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        let started = std::time::Instant::now();
        loop {
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
