//! The simulated rig: the simulated nanostage and coarse stage moving the tip
//! through the world, and a camera that draws the world with the synthetic
//! microscope. The camera is fixed to the nanostage's frame (the sample moves
//! under both when the coarse stage moves), so one calibration maps its pixels
//! to nanostage coordinates.
//!
//! Faults for tests are injected here: dropped frames and particles the
//! detector will miss in a given frame (drawn out of the frame).

use super::stage::SimStage;
use super::state::SimState;
use super::world::SimParticle;
use crate::calib::camera_map::CameraCalibration;
use crate::render::microscope::{ParticleView, RenderSettings, SceneView, TipView, render_frame};
use crate::rig::RigError;
use crate::rig::camera::{Camera, TimedFrame};
use crate::rig::stage::{AxisRange, CoarseStage, NanoStage, StageXyz};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// How the simulated camera sees the nanostage's range.
#[derive(Debug, Clone)]
pub struct SimCameraConfig {
    /// Frame width, pixels.
    pub width_px: usize,
    /// Frame height, pixels.
    pub height_px: usize,
    /// Pixel -> nanostage map.
    pub calibration: CameraCalibration,
    /// Microscope and camera rendering.
    pub render: RenderSettings,
    /// Direction from the cantilever body to the apex in the image, radians.
    pub tip_angle_rad: f64,
    /// Exposure plus read-out time per frame, seconds of rig time.
    pub frame_time_s: f64,
}

impl SimCameraConfig {
    /// A camera at `um_per_px` whose frame covers a nanostage range of
    /// `range_um` with `margin_um` on every side. Like a microscope camera
    /// seen on a screen, image y runs down while stage y runs up, so patterns
    /// read the right way up in the frames.
    pub fn covering(range_um: [f64; 2], margin_um: f64, um_per_px: f64) -> Self {
        let width_px = ((range_um[0] + 2.0 * margin_um) / um_per_px).ceil() as usize;
        let height_px = ((range_um[1] + 2.0 * margin_um) / um_per_px).ceil() as usize;
        let m_per_px = um_per_px * 1e-6;
        Self {
            width_px,
            height_px,
            calibration: CameraCalibration::affine(
                nalgebra::Matrix2::new(m_per_px, 0.0, 0.0, -m_per_px),
                nalgebra::Vector2::new(-margin_um * 1e-6, (range_um[1] + margin_um) * 1e-6),
            ),
            render: RenderSettings::with_snr(30.0, 16),
            tip_angle_rad: 60f64.to_radians(),
            frame_time_s: 0.05,
        }
    }
}

/// The whole simulated rig.
pub struct SimRig {
    /// The nanostage and the world (ground truth lives here).
    pub stage: SimStage,
    camera: SimCameraConfig,
    seed: u64,
    frames: usize,
    drop_frames: Vec<usize>,
    hidden: Vec<(usize, usize)>,
    persist_to: Option<PathBuf>,
    interrupt: Option<Arc<AtomicBool>>,
}

impl SimRig {
    /// A rig of this stage and camera; `seed` makes the camera noise repeatable.
    pub fn new(stage: SimStage, camera: SimCameraConfig, seed: u64) -> Self {
        Self {
            stage,
            camera,
            seed,
            frames: 0,
            drop_frames: Vec::new(),
            hidden: Vec::new(),
            persist_to: None,
            interrupt: None,
        }
    }

    /// Refuses every frame and move once `flag` is raised (Ctrl-C,
    /// [`crate::rig::interrupt`]), as a hardware stage does: the run then
    /// stops, journalled and resumable. It had ended without a word.
    pub fn stop_on(&mut self, flag: Arc<AtomicBool>) {
        self.interrupt = Some(flag);
    }

    fn check_interrupt(&self) -> Result<(), RigError> {
        match &self.interrupt {
            Some(flag) if flag.load(Ordering::SeqCst) => Err(RigError::Interrupted),
            _ => Ok(()),
        }
    }

    /// Saves the physical state to `path` after every move and frame, so a
    /// killed run can be resumed on the same world ([`SimRig::restore_from`]).
    pub fn persist_to(&mut self, path: PathBuf) -> Result<(), RigError> {
        self.persist_to = Some(path);
        self.persist()
    }

    /// Puts the world back as a saved state file left it.
    pub fn restore_from(&mut self, path: &Path) -> Result<(), RigError> {
        let state = SimState::load(path).map_err(|e| RigError::Io(e.to_string()))?;
        self.stage.restore(&state);
        self.frames = state.frames;
        Ok(())
    }

    fn persist(&self) -> Result<(), RigError> {
        let Some(path) = &self.persist_to else {
            return Ok(());
        };
        let mut state = self.stage.snapshot();
        state.frames = self.frames;
        state.save(path).map_err(|e| RigError::Io(e.to_string()))
    }

    /// Frames grabbed so far (dropped ones included).
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Fault: the camera drops frame number `n` (counted from 0).
    pub fn drop_frame(&mut self, n: usize) {
        self.drop_frames.push(n);
    }

    /// Fault: particle `id` is missing from frame number `n` (a missed detection).
    pub fn hide_particle_in_frame(&mut self, id: usize, n: usize) {
        self.hidden.push((id, n));
    }

    /// What the camera sees now, in pixels (ground truth for tests).
    pub fn scene_view(&self, frame: usize) -> Result<SceneView, RigError> {
        let visible = self
            .stage
            .world
            .particles
            .iter()
            .filter(|p| !self.hidden.contains(&(p.id, frame)));
        self.camera.view(
            visible,
            self.stage.actual_on_sample(),
            self.stage.coarse_offset(),
        )
    }
}

impl SimCameraConfig {
    /// What this camera sees of `particles` with the tip at `tip_on_sample`
    /// and the coarse stage at `coarse_offset` (all on the sample, metres),
    /// in pixels, ready for [`render_frame`].
    pub fn view<'p>(
        &self,
        particles: impl IntoIterator<Item = &'p SimParticle>,
        tip_on_sample: StageXyz,
        coarse_offset: [f64; 2],
    ) -> Result<SceneView, RigError> {
        let cal = &self.calibration;
        let to_px = |x: f64, y: f64| {
            cal.stage_to_pixel(x - coarse_offset[0], y - coarse_offset[1])
                .map_err(|e| RigError::Io(format!("camera calibration: {e}")))
        };
        let mut views = Vec::new();
        for p in particles {
            let [x_px, y_px] = to_px(p.x_m, p.y_m)?;
            views.push(ParticleView {
                x_px,
                y_px,
                radius_px: p.radius_m / cal.m_per_px(),
            });
        }
        let [apex_x_px, apex_y_px] = to_px(tip_on_sample[0], tip_on_sample[1])?;
        Ok(SceneView {
            width_px: self.width_px,
            height_px: self.height_px,
            particles: views,
            tip: Some(TipView {
                apex_x_px,
                apex_y_px,
                angle_rad: self.tip_angle_rad,
            }),
        })
    }
}

impl crate::rig::Rig for SimRig {
    fn now_s(&self) -> f64 {
        self.stage.clock_s()
    }
    /// The camera's pixel -> nanostage calibration (what a lab would have measured).
    fn calibration(&self) -> &CameraCalibration {
        &self.camera.calibration
    }
}

impl Camera for SimRig {
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        self.check_interrupt()?;
        let n = self.frames;
        self.frames += 1;
        self.stage.wait(self.camera.frame_time_s);
        if self.drop_frames.contains(&n) {
            return Ok(None);
        }
        let view = self.scene_view(n)?;
        let seed = self.seed ^ (n as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let frame = render_frame(&view, &self.camera.render, seed)
            .map_err(|e| RigError::Io(format!("simulated camera: {e}")))?;
        self.persist()?;
        Ok(Some(TimedFrame {
            t_s: self.stage.clock_s(),
            frame,
        }))
    }
}

impl NanoStage for SimRig {
    fn range(&self) -> [AxisRange; 3] {
        self.stage.range()
    }
    fn position(&mut self) -> Result<StageXyz, RigError> {
        self.stage.position()
    }
    fn move_to(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), RigError> {
        self.check_interrupt()?;
        let moved = self.stage.move_to(target, speed_m_per_s);
        self.persist()?;
        moved
    }
    fn halt(&mut self) -> Result<(), RigError> {
        self.stage.halt()
    }
}

impl CoarseStage for SimRig {
    fn coarse_position(&mut self) -> Result<[f64; 2], RigError> {
        Ok(self.stage.coarse_offset())
    }
    fn move_coarse(&mut self, target: [f64; 2]) -> Result<(), RigError> {
        self.check_interrupt()?;
        self.stage.move_coarse(target)?;
        self.persist()
    }
}
