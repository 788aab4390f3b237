//! The motorised coarse XY stage on its own GCS controller (a C-884 driving
//! two linear stages, say), as the executor's [`CoarseStage`]: the same
//! straight-line, checked-before-sending moves as the nanostage
//! ([`GcsLineStage`]), at the rig file's top speed.
//!
//! The executor speaks of the coarse stage as the place where it has put the
//! nanostage's origin on the sample (the coarse offset). The controller
//! speaks of its axes' positions. The two are related by the rig file's
//! `sign` (is the sample or the nanostage carried?) and by where the sample
//! frame's origin is: here, the offset is zero where the coarse stage stood
//! when it was opened, so that the sample frame starts as the nanostage's.

use super::error::RigError;
use super::gcs::{self, CoarseSection, GcsController, GcsError, GcsStage, StageOpening};
use super::gcs_line_stage::GcsLineStage;
use super::stage::CoarseStage;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// A GCS controller's two axes as the coarse stage.
pub struct GcsCoarseStage {
    line: GcsLineStage,
    sign: [f64; 2],
    /// Signed axis positions, metres, at which the coarse offset is zero.
    zero_m: [f64; 2],
    speed_m_per_s: f64,
}

impl GcsCoarseStage {
    /// The rig file's coarse stage on a connected `controller`, behind every
    /// check `assemble --rig` opens it with ([`gcs::stage_on`]; its
    /// soft limits within the controller's travel in its `unit_um`: a
    /// C-884 in mm taken for um is caught there), as `rig probe` checks it.
    pub fn on_controller(
        controller: GcsController,
        section: &CoarseSection,
        opening: &StageOpening,
    ) -> Result<Self, GcsError> {
        let stage = gcs::stage_on(
            controller,
            &section.stage,
            section.stage_settings(),
            opening,
        )?;
        Self::new(
            stage,
            Arc::clone(&opening.interrupt),
            section.sign_factors(),
        )
    }

    /// Wraps a stage of exactly two axes (x, y, parallel to the
    /// nanostage's); `sign` is the rig file's (+1: a positive move carries
    /// the nanostage's origin positive across the sample; -1: it moves the
    /// sample positive). Coarse moves run at the stage's top speed. The
    /// offset is zero where the stage is now.
    pub fn new(
        stage: GcsStage,
        interrupt: Arc<AtomicBool>,
        sign: [f64; 2],
    ) -> Result<Self, GcsError> {
        if sign.iter().any(|s| s.abs() != 1.0) {
            return Err(GcsError::InvalidArgument(format!(
                "coarse sign must be +1 or -1 per axis, got {sign:?}"
            )));
        }
        let speed_m_per_s = stage.settings().limits.max_speed_m_per_s;
        let mut line = GcsLineStage::new(stage, interrupt, &['x', 'y'])?;
        let here = line.gcs().position_m()?;
        Ok(Self {
            line,
            sign,
            zero_m: [sign[0] * here[0], sign[1] * here[1]],
            speed_m_per_s,
        })
    }

    /// The GCS stage underneath (for queries the trait does not cover).
    pub fn gcs(&mut self) -> &mut GcsStage {
        self.line.gcs()
    }

    /// The coarse offset at axis positions `axes_m` (metres).
    pub fn offset_at(&self, axes_m: [f64; 2]) -> [f64; 2] {
        [0, 1].map(|i| self.sign[i] * axes_m[i] - self.zero_m[i])
    }

    /// The axis positions (metres) that put the nanostage's origin at `offset`.
    pub fn axes_for(&self, offset: [f64; 2]) -> [f64; 2] {
        // sign is +-1: its own inverse.
        [0, 1].map(|i| self.sign[i] * (offset[i] + self.zero_m[i]))
    }
}

impl CoarseStage for GcsCoarseStage {
    fn coarse_position(&mut self) -> Result<[f64; 2], RigError> {
        let p = self.line.position_m()?;
        Ok(self.offset_at([p[0], p[1]]))
    }

    /// Moves in a straight line at the top speed; a target outside the soft
    /// limits, too long a step or a Ctrl-C is refused before any byte.
    fn move_coarse(&mut self, target: [f64; 2]) -> Result<(), RigError> {
        if !(target[0].is_finite() && target[1].is_finite()) {
            return Err(RigError::StageFault(format!(
                "coarse target {target:?} is not finite"
            )));
        }
        let axes = self.axes_for(target);
        self.line.move_to_m(&axes, self.speed_m_per_s)
    }

    fn halt_coarse(&mut self) -> Result<(), RigError> {
        self.line.halt()
    }

    /// The controller's position (sign applied) when the stage was opened.
    fn coarse_zero_m(&self) -> [f64; 2] {
        self.zero_m
    }
}
