//! Limits checked on the host before any motion byte leaves it: soft travel
//! limits, the largest single step, and the top speed, all in SI units.

/// The straight-line length of a move from `from` to `to` over all axes
/// (what the largest step limits).
pub fn step_length(from: &[f64], to: &[f64]) -> f64 {
    from.iter()
        .zip(to)
        .map(|(a, b)| (b - a).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Relative rounding of a limit read in micrometres and held in metres.
const UNIT_ROUNDING: f64 = 1e-12;

/// Per-axis soft travel window, metres, in stage coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftLimit {
    /// Lowest allowed position, metres.
    pub min_m: f64,
    /// Highest allowed position, metres.
    pub max_m: f64,
}

/// Everything the host enforces before it commands motion.
#[derive(Debug, Clone, PartialEq)]
pub struct SafetyLimits {
    /// Soft travel window per axis (same order as the stage's axes).
    pub soft_limits: Vec<SoftLimit>,
    /// Largest distance a single move may cover (Euclidean over all axes), metres.
    pub max_step_m: f64,
    /// Largest closed-loop velocity that may be set, metres per second.
    pub max_speed_m_per_s: f64,
}

/// A move or setting refused by the host; nothing was sent.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SafetyViolation {
    /// The target lies outside an axis's soft limits.
    #[error(
        "axis {axis}: target {target_m:.9} m is outside the soft limits [{min_m:.9}, {max_m:.9}] m"
    )]
    OutsideSoftLimits {
        /// Axis identifier.
        axis: String,
        /// Requested target, metres.
        target_m: f64,
        /// Soft lower limit, metres.
        min_m: f64,
        /// Soft upper limit, metres.
        max_m: f64,
    },
    /// The move is longer than the largest single step.
    #[error("step of {step_m:.9} m exceeds the largest single step {max_step_m:.9} m")]
    StepTooLarge {
        /// Requested step length, metres.
        step_m: f64,
        /// Allowed largest step, metres.
        max_step_m: f64,
    },
    /// A velocity above the top speed (or not positive) was asked for.
    #[error("speed {speed_m_per_s} m/s is not in (0, {max_speed_m_per_s}] m/s")]
    SpeedNotAllowed {
        /// Requested speed, m/s.
        speed_m_per_s: f64,
        /// Top speed, m/s.
        max_speed_m_per_s: f64,
    },
    /// A coordinate was NaN or infinite, or the axis count was wrong.
    #[error("bad target: {0}")]
    BadTarget(String),
    /// The operator did not confirm the first move on real hardware.
    #[error("the first move on real hardware was not confirmed")]
    NotConfirmed,
}

impl SafetyLimits {
    /// Checks the limits themselves (finite, ordered, positive); messages in
    /// um, the rig file's unit.
    pub fn validate(&self) -> Result<(), String> {
        for (i, l) in self.soft_limits.iter().enumerate() {
            if !(l.min_m.is_finite() && l.max_m.is_finite() && l.min_m < l.max_m) {
                return Err(format!(
                    "soft limit {i}: need finite min < max, got [{:.3}, {:.3}] um",
                    l.min_m * 1e6,
                    l.max_m * 1e6
                ));
            }
        }
        if !(self.max_step_m.is_finite() && self.max_step_m > 0.0) {
            return Err(format!(
                "largest step must be positive, got {:.3} um",
                self.max_step_m * 1e6
            ));
        }
        if !(self.max_speed_m_per_s.is_finite() && self.max_speed_m_per_s > 0.0) {
            return Err(format!(
                "top speed must be positive, got {:.3} um/s",
                self.max_speed_m_per_s * 1e6
            ));
        }
        Ok(())
    }

    /// Checks a target against the soft limits (one coordinate per axis,
    /// named by `axes`); needs no I/O, so it runs before anything is sent.
    pub fn check_target(&self, axes: &[String], to_m: &[f64]) -> Result<(), SafetyViolation> {
        let n = self.soft_limits.len();
        if axes.len() != n || to_m.len() != n {
            return Err(SafetyViolation::BadTarget(format!(
                "expected {n} coordinates, got {}",
                to_m.len()
            )));
        }
        if let Some(bad) = to_m.iter().find(|v| !v.is_finite()) {
            return Err(SafetyViolation::BadTarget(format!(
                "coordinate {bad} is not finite"
            )));
        }
        for ((axis, limit), &target_m) in axes.iter().zip(&self.soft_limits).zip(to_m) {
            if !(limit.min_m..=limit.max_m).contains(&target_m) {
                return Err(SafetyViolation::OutsideSoftLimits {
                    axis: axis.clone(),
                    target_m,
                    min_m: limit.min_m,
                    max_m: limit.max_m,
                });
            }
        }
        Ok(())
    }

    /// Checks the length of a step from `from_m` to `to_m` (Euclidean).
    pub fn check_step(&self, from_m: &[f64], to_m: &[f64]) -> Result<(), SafetyViolation> {
        if from_m.len() != to_m.len() || from_m.iter().any(|v| !v.is_finite()) {
            return Err(SafetyViolation::BadTarget(format!(
                "current position {from_m:?} does not match target {to_m:?}"
            )));
        }
        let step_m = step_length(from_m, to_m);
        if step_m > self.max_step_m {
            return Err(SafetyViolation::StepTooLarge {
                step_m,
                max_step_m: self.max_step_m,
            });
        }
        Ok(())
    }

    /// Checks a whole move: soft limits of the target, then the step length.
    pub fn check_move(
        &self,
        axes: &[String],
        from_m: &[f64],
        to_m: &[f64],
    ) -> Result<(), SafetyViolation> {
        self.check_target(axes, to_m)?;
        self.check_step(from_m, to_m)
    }

    /// Checks a velocity before it is set. The top speed is read in um/s
    /// and converted, so a speed equal to it in um/s may exceed it by a
    /// rounding: 50 um/s was refused against a top speed of 50 um/s
    /// ("not in (0, 49.99999999999999]").
    pub fn check_speed(&self, speed_m_per_s: f64) -> Result<(), SafetyViolation> {
        if speed_m_per_s.is_finite()
            && speed_m_per_s > 0.0
            && speed_m_per_s <= self.max_speed_m_per_s * (1.0 + UNIT_ROUNDING)
        {
            Ok(())
        } else {
            Err(SafetyViolation::SpeedNotAllowed {
                speed_m_per_s,
                max_speed_m_per_s: self.max_speed_m_per_s,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> SafetyLimits {
        SafetyLimits {
            soft_limits: vec![
                SoftLimit {
                    min_m: 0.0,
                    max_m: 100e-6
                };
                2
            ],
            max_step_m: 5e-6,
            max_speed_m_per_s: 20e-6,
        }
    }

    #[test]
    fn moves_inside_limits_pass_and_others_are_named() {
        let axes = vec!["1".to_string(), "2".to_string()];
        let l = limits();
        assert!(l.validate().is_ok());
        assert!(
            l.check_move(&axes, &[50e-6, 50e-6], &[53e-6, 54e-6])
                .is_ok()
        );
        assert!(matches!(
            l.check_move(&axes, &[99e-6, 50e-6], &[101e-6, 50e-6]),
            Err(SafetyViolation::OutsideSoftLimits { ref axis, .. }) if axis == "1"
        ));
        assert!(matches!(
            l.check_move(&axes, &[50e-6, 50e-6], &[54e-6, 54e-6]),
            Err(SafetyViolation::StepTooLarge { .. })
        ));
        assert!(matches!(
            l.check_move(&axes, &[50e-6, 50e-6], &[f64::NAN, 50e-6]),
            Err(SafetyViolation::BadTarget(_))
        ));
        assert!(l.check_move(&axes, &[50e-6], &[50e-6]).is_err());
        assert!(l.check_speed(20e-6).is_ok());
        assert!(l.check_speed(21e-6).is_err());
        assert!(l.check_speed(0.0).is_err());
        // A top speed of 50 um/s held in metres is 4.9999999999999996e-5.
        let fifty = SafetyLimits {
            max_speed_m_per_s: 50.0 * 1e-6,
            ..limits()
        };
        assert!(fifty.check_speed(50e-6).is_ok());
        assert!(fifty.check_speed(50.001e-6).is_err());
    }

    #[test]
    fn bad_limits_are_reported() {
        let mut l = limits();
        l.soft_limits[1] = SoftLimit {
            min_m: 99e-6,
            max_m: 98e-6,
        };
        // In um, as the rig file gives them (not [0.000099, 0.000098]).
        assert_eq!(
            l.validate().unwrap_err(),
            "soft limit 1: need finite min < max, got [99.000, 98.000] um"
        );
        let mut l = limits();
        l.max_step_m = -5e-6;
        assert_eq!(
            l.validate().unwrap_err(),
            "largest step must be positive, got -5.000 um"
        );
    }
}
