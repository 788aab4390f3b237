//! The stages a rig moves: the piezo nanostage that carries the probe and the
//! coarse stage that brings the work area into its reach. Positions are stage
//! metres; z is the probe height above the substrate.

use super::error::RigError;

/// A point in stage coordinates, metres (x, y in the image plane, z up).
pub type StageXyz = [f64; 3];

/// Travel range of one axis in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisRange {
    /// Lowest reachable position.
    pub min_m: f64,
    /// Highest reachable position.
    pub max_m: f64,
}

/// The piezo XYZ stage that carries the probe.
pub trait NanoStage {
    /// Travel range of x, y and z.
    fn range(&self) -> [AxisRange; 3];
    /// Where the stage is now, as measured by the stage.
    fn position(&mut self) -> Result<StageXyz, RigError>;
    /// Moves in a straight line at `speed_m_per_s` and returns once on target.
    fn move_to(&mut self, target: StageXyz, speed_m_per_s: f64) -> Result<(), RigError>;
    /// Stops any motion at once.
    fn halt(&mut self) -> Result<(), RigError>;
}

/// The coarse XY stage that moves the sample under the nanostage's reach.
pub trait CoarseStage {
    /// Where the coarse stage has put the nanostage's origin on the sample, metres.
    fn coarse_position(&mut self) -> Result<[f64; 2], RigError>;
    /// Moves the coarse stage and returns once it has settled.
    fn move_coarse(&mut self, target: [f64; 2]) -> Result<(), RigError>;
    /// Stops any coarse motion at once (stages that only move inside
    /// `move_coarse`, such as the simulated one, have nothing to stop).
    fn halt_coarse(&mut self) -> Result<(), RigError> {
        Ok(())
    }
    /// Where [`CoarseStage::coarse_position`]'s zero lies in the stage's own
    /// fixed coordinates, metres: a stage whose readings start at zero
    /// wherever it was opened (a GCS coarse stage) says where that was, so
    /// that a position kept across processes (a resumed run's) keeps its
    /// meaning. Zero for a stage that reads absolute positions.
    fn coarse_zero_m(&self) -> [f64; 2] {
        [0.0, 0.0]
    }
}

/// Checks a target against a range before anything moves.
pub fn check_in_range(target: StageXyz, range: &[AxisRange; 3]) -> Result<(), RigError> {
    for (i, (t, r)) in target.iter().zip(range).enumerate() {
        if !(t.is_finite() && *t >= r.min_m && *t <= r.max_m) {
            return Err(RigError::OutOfRange {
                axis: ['x', 'y', 'z'][i],
                target_um: t * 1e6,
                min_um: r.min_m * 1e6,
                max_um: r.max_m * 1e6,
            });
        }
    }
    Ok(())
}
