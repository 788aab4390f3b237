//! Straight-line moves on the axes of one GCS controller, in metres: what
//! the nanostage ([`GcsNanoStage`](super::hardware::GcsNanoStage)) and the
//! coarse stage ([`GcsCoarseStage`](super::gcs_coarse_stage::GcsCoarseStage))
//! both are, so that neither copies the other.
//!
//! Every move is a straight line: each axis gets the share of the speed that
//! its part of the displacement asks for (GCS `VEL` is per axis, so one
//! common velocity would bend a diagonal move). Safety is the GCS stage's
//! (soft limits, largest step, top speed checked before any byte is sent;
//! confirmation before the first move on real hardware; Ctrl-C sends `HLT`;
//! a failure or drop while moving halts).

use super::error::RigError;
use super::gcs::safety::step_length;
use super::gcs::{GcsError, GcsStage, SafetyViolation};
use super::stage::AxisRange;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// How far outside its range a target may be and still be taken, metres,
/// snapped onto the range's edge: the rounding of the executor's
/// sample-to-stage arithmetic (a target computed as `p - (p - min)` need not
/// be `min` in floating point). Far below any stage's resolution.
pub const RANGE_ROUNDING_M: f64 = 1e-12;

/// `target` snapped onto `range` when it lies within [`RANGE_ROUNDING_M`]
/// outside it; anything else (NaN included) is returned unchanged.
pub fn snap_into_range(target: f64, range: &AxisRange) -> f64 {
    if target < range.min_m && target >= range.min_m - RANGE_ROUNDING_M {
        range.min_m
    } else if target > range.max_m && target <= range.max_m + RANGE_ROUNDING_M {
        range.max_m
    } else {
        target
    }
}

/// The ends of equal pieces of the line from `from` to `to`, each at most
/// `max_step_m` long (at most 99 % of it, so that where the stage settles,
/// a few nanometres off a piece's end, never makes the next one longer),
/// the last `to` itself; just `to` for a short move or a
/// malformed one (the stage's own checks then refuse it).
pub fn pieces(from: &[f64], to: &[f64], max_step_m: f64) -> Vec<Vec<f64>> {
    let length = step_length(from, to);
    let n = (length / (max_step_m * PIECE_SHARE)).ceil();
    if from.len() != to.len() || !(n > 1.0 && n <= MAX_PIECES as f64) {
        return vec![to.to_vec()];
    }
    let n = n as usize;
    (1..=n)
        .map(|k| {
            if k == n {
                return to.to_vec();
            }
            let t = k as f64 / n as f64;
            from.iter().zip(to).map(|(a, b)| a + (b - a) * t).collect()
        })
        .collect()
}

/// A piece's most length, as a share of the largest step.
const PIECE_SHARE: f64 = 0.99;

/// Most pieces a move is cut into; a longer one is left whole for the
/// stage to refuse as too long a step (a largest step of nanometres, a
/// unit slip, would otherwise send thousands of moves).
const MAX_PIECES: usize = 1000;

/// What to say of soft limits outside an axis's travel that would lie
/// within it in another unit (a controller in mm with `unit_um = 1`, the
/// C-884's 0..25 mm read as 0..25 um): the unit to write instead.
fn unit_hint(min_m: f64, max_m: f64, travel_m: [f64; 2], unit_m: f64) -> String {
    [1000.0, 1e-3]
        .into_iter()
        .find(|k| min_m >= travel_m[0] * k && max_m <= travel_m[1] * k)
        .map_or(String::new(), |k| {
            let um = |m: f64| (m * 1e12).round() / 1e6;
            format!(
                " (they lie within it with unit_um = {}, not {}: is unit_um the controller's unit?)",
                um(unit_m * k),
                um(unit_m)
            )
        })
}

/// The axes of one GCS controller moving in straight lines, in metres.
pub struct GcsLineStage {
    stage: GcsStage,
    endpoint: String,
    names: Vec<char>,
    range: Vec<AxisRange>,
    servo_on: bool,
    interrupt: Arc<AtomicBool>,
    /// Last velocity set per axis, controller units per second.
    velocity_units: Vec<Option<f64>>,
}

impl GcsLineStage {
    /// Wraps a stage whose axes are called `names` in messages (`x`, `y`,
    /// `z`); the range is the rig file's soft limits narrowed to the
    /// controller's travel (`TMN?`/`TMX?`). `interrupt` is the stage's
    /// Ctrl-C flag: while it is up, moves are refused before anything (not
    /// even `VEL`) is sent.
    pub fn new(
        mut stage: GcsStage,
        interrupt: Arc<AtomicBool>,
        names: &[char],
    ) -> Result<Self, GcsError> {
        let settings = stage.settings().clone();
        let n = settings.axes.len();
        if n != names.len() {
            return Err(GcsError::InvalidArgument(format!(
                "{} ({}) expected, the rig file names {n}",
                crate::wording::counted(names.len(), "axis"),
                names.iter().collect::<String>()
            )));
        }
        let axes: Vec<&str> = settings.axes.iter().map(String::as_str).collect();
        let tmn = stage.controller().travel_min(&axes)?;
        let tmx = stage.controller().travel_max(&axes)?;
        let mut range = Vec::with_capacity(n);
        let mut outside = Vec::new();
        for i in 0..n {
            let soft = settings.limits.soft_limits[i];
            let travel = [tmn[i] * settings.unit_m, tmx[i] * settings.unit_m];
            let r = AxisRange {
                min_m: soft.min_m.max(travel[0]),
                max_m: soft.max_m.min(travel[1]),
            };
            if r.min_m > r.max_m {
                outside.push(format!(
                    "axis {}: soft limits {:.3}..{:.3} um lie outside the controller's travel {:.3}..{:.3} um{}",
                    settings.axes[i],
                    soft.min_m * 1e6,
                    soft.max_m * 1e6,
                    travel[0] * 1e6,
                    travel[1] * 1e6,
                    unit_hint(soft.min_m, soft.max_m, travel, settings.unit_m)
                ));
            }
            range.push(r);
        }
        // Every axis at once: `rig probe` reports them all.
        if !outside.is_empty() {
            return Err(GcsError::InvalidArgument(outside.join("; ")));
        }
        Ok(Self {
            endpoint: stage.controller().endpoint(),
            stage,
            names: names.to_vec(),
            range,
            servo_on: false,
            interrupt,
            velocity_units: vec![None; n],
        })
    }

    /// The GCS stage underneath (for queries this type does not cover).
    pub fn gcs(&mut self) -> &mut GcsStage {
        &mut self.stage
    }

    /// Travel of each axis: soft limits within the controller's travel.
    pub fn range(&self) -> &[AxisRange] {
        &self.range
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
        let length = step_length(from, to);
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

    /// Where the axes are, metres.
    pub fn position_m(&mut self) -> Result<Vec<f64>, RigError> {
        self.stage.position_m().map_err(|e| self.rig_error(e))
    }

    /// Moves every axis in a straight line to `target_m` at `speed_m_per_s`
    /// and returns once on target; refused before any byte when outside the
    /// range, too long a step, too fast, or after Ctrl-C.
    /// Targets within [`RANGE_ROUNDING_M`] outside the range are snapped onto it.
    pub fn move_to_m(&mut self, target_m: &[f64], speed_m_per_s: f64) -> Result<(), RigError> {
        let target = self.snapped_in_range(target_m)?;
        self.move_checked(&target, speed_m_per_s)
            .map_err(|e| self.rig_error(e))
    }

    /// `target_m` snapped onto the range within its rounding, or why it is out of it.
    fn snapped_in_range(&self, target_m: &[f64]) -> Result<Vec<f64>, RigError> {
        let target: Vec<f64> = target_m
            .iter()
            .zip(self.range.iter().chain(std::iter::repeat(&self.range[0])))
            .map(|(t, r)| snap_into_range(*t, r))
            .collect();
        self.check_in_range(&target)?;
        Ok(target)
    }

    /// [`Self::move_to_m`], a move longer than the rig file's largest step
    /// made in equal pieces along the same line, each no longer and each
    /// waited on (as `rig calibrate` moves): the nanostage's, whose range
    /// bounds every move (the E-727 templates' 10 um had stopped
    /// `assemble` at its first lifted travel). Not the coarse stage's: a
    /// coarse move beyond its largest step is a wild target, refused.
    pub fn move_to_m_in_pieces(
        &mut self,
        target_m: &[f64],
        speed_m_per_s: f64,
    ) -> Result<(), RigError> {
        // The whole move is checked first: no piece goes when its end is out of range.
        let target = self.snapped_in_range(target_m)?;
        let from = self.position_m()?;
        let max_step_m = self.stage.settings().limits.max_step_m;
        for piece in pieces(&from, &target, max_step_m) {
            self.move_to_m(&piece, speed_m_per_s)?;
        }
        Ok(())
    }

    /// Halts every axis now.
    pub fn halt(&mut self) -> Result<(), RigError> {
        self.stage.halt().map_err(|e| self.rig_error(e))
    }

    fn check_in_range(&self, target_m: &[f64]) -> Result<(), RigError> {
        if target_m.len() != self.range.len() {
            return Err(RigError::StageFault(format!(
                "{} for {}",
                crate::wording::counted(target_m.len(), "coordinate"),
                crate::wording::counted(self.range.len(), "axis")
            )));
        }
        for ((t, r), name) in target_m.iter().zip(&self.range).zip(&self.names) {
            if !(t.is_finite() && *t >= r.min_m && *t <= r.max_m) {
                return Err(RigError::OutOfRange {
                    axis: *name,
                    target_um: t * 1e6,
                    min_um: r.min_m * 1e6,
                    max_um: r.max_m * 1e6,
                });
            }
        }
        Ok(())
    }

    fn move_checked(&mut self, target: &[f64], speed_m_per_s: f64) -> Result<(), GcsError> {
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
        let from = self.stage.position_m()?;
        // Limits and step are checked again by the stage before MOV; checking
        // here first keeps a refused move from touching SVO or VEL.
        let limits = &self.stage.settings().limits;
        limits.check_target(&self.stage.settings().axes, target)?;
        limits.check_step(&from, target)?;
        // Asked before servo on and VEL: a refusal leaves the axes as found.
        self.stage.confirm_first_move(&from, target)?;
        if !self.servo_on {
            self.stage.enable_servo()?;
            self.servo_on = true;
        }
        self.set_line_velocities(&from, target, speed_m_per_s)?;
        self.stage.move_to_m(target)
    }

    /// Maps a driver error to the executor's error, naming axes as given to [`GcsLineStage::new`].
    pub fn rig_error(&self, e: GcsError) -> RigError {
        let axis_name = |id: &str| {
            self.stage
                .settings()
                .axes
                .iter()
                .position(|a| a == id)
                .and_then(|i| self.names.get(i).copied())
                .unwrap_or('?')
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
            GcsError::NotSettled { timeout } => RigError::NotSettled {
                device: format!("stage {}", self.endpoint),
                timeout_ms: timeout.as_millis() as u64,
            },
            GcsError::Interrupted => RigError::Interrupted,
            GcsError::Safety(SafetyViolation::NotConfirmed) => RigError::NotConfirmed,
            // With its causes: "connection to ... failed" alone had not
            // said the connection was refused.
            other => {
                let mut said = other.to_string();
                let mut cause = std::error::Error::source(&other);
                while let Some(c) = cause {
                    said = format!("{said}: {c}");
                    cause = c.source();
                }
                RigError::StageFault(said)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_move_is_cut_into_equal_pieces_along_its_line() {
        let (from, to) = ([0.0, 0.0, 15e-6], [30e-6, 40e-6, 15e-6]);
        let cut = pieces(&from, &to, 10e-6);
        assert_eq!(cut.len(), 6, "50 um in pieces of at most 9.9 um");
        assert_eq!(cut.last().unwrap(), &to.to_vec());
        let mut at = from.to_vec();
        for p in &cut {
            let step = step_length(&at, p);
            assert!((step - 50e-6 / 6.0).abs() < 1e-15, "{step}");
            // On the line: x and y keep their 3:4 ratio, z its height.
            assert!(
                (p[0] * 4.0 - p[1] * 3.0).abs() < 1e-18 && p[2] == 15e-6,
                "{p:?}"
            );
            at = p.clone();
        }
        assert_eq!(pieces(&from, &to, 60e-6), vec![to.to_vec()], "short enough");
        assert_eq!(
            pieces(&from, &to, 1e-9),
            vec![to.to_vec()],
            "too many: left whole"
        );
    }
}
