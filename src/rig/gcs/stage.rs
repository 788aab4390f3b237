//! The safe, SI-unit face of a GCS stage: every move is checked against the
//! soft limits and the largest step before a byte is sent; the first move on
//! real hardware needs confirmation; Ctrl-C, a lost link or an abandoned wait
//! halt the stage; dropping a stage that may still move halts it too.

use super::confirmation::FirstMoveConfirmation;
use super::controller::GcsController;
use super::error::GcsError;
use super::safety::{SafetyLimits, SafetyViolation};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How a stage maps to its controller and what it may do.
#[derive(Debug, Clone, PartialEq)]
pub struct StageSettings {
    /// Controller axis identifiers, in stage-coordinate order (x, y[, z]).
    pub axes: Vec<String>,
    /// Metres per controller unit (1e-6 when the controller speaks micrometres).
    pub unit_m: f64,
    /// Host-side limits.
    pub limits: SafetyLimits,
    /// Longest wait for a move to settle before the stage is halted.
    pub settle_timeout: Duration,
    /// Pause between on-target polls.
    pub poll_interval: Duration,
}

/// A GCS controller behind the host-side safety checks, speaking metres.
pub struct GcsStage {
    controller: GcsController,
    settings: StageSettings,
    confirmation: FirstMoveConfirmation,
    interrupt: Arc<AtomicBool>,
    may_be_moving: bool,
    /// True once a move was handed to the controller.
    move_sent: bool,
}

impl GcsStage {
    /// Wraps a controller; checks the settings and that every axis exists.
    pub fn new(
        mut controller: GcsController,
        settings: StageSettings,
        confirmation: FirstMoveConfirmation,
        interrupt: Arc<AtomicBool>,
    ) -> Result<Self, GcsError> {
        settings
            .limits
            .validate()
            .map_err(GcsError::InvalidArgument)?;
        if !(settings.unit_m.is_finite() && settings.unit_m > 0.0) {
            return Err(GcsError::InvalidArgument(format!(
                "unit must be positive, got {} m",
                settings.unit_m
            )));
        }
        if settings.axes.len() != settings.limits.soft_limits.len() {
            return Err(GcsError::InvalidArgument(format!(
                "{} but {}",
                crate::wording::counted(settings.axes.len(), "axis"),
                crate::wording::counted(settings.limits.soft_limits.len(), "soft limit")
            )));
        }
        if let Some(axis) = super::protocol::repeated_axis(&settings.axes) {
            return Err(GcsError::InvalidArgument(format!(
                "axis {axis} is named twice in {:?}",
                settings.axes
            )));
        }
        let present = controller.axes()?;
        // Every missing axis at once: `rig probe` reports them all.
        let missing: Vec<&String> = settings
            .axes
            .iter()
            .filter(|a| !present.contains(a))
            .collect();
        match missing.as_slice() {
            [] => {}
            [one] => {
                return Err(GcsError::InvalidArgument(format!(
                    "axis {one} is not on the controller (it has {present:?})"
                )));
            }
            many => {
                return Err(GcsError::InvalidArgument(format!(
                    "axes {many:?} are not on the controller (it has {present:?})"
                )));
            }
        }
        Ok(Self {
            controller,
            settings,
            confirmation,
            interrupt,
            may_be_moving: false,
            move_sent: false,
        })
    }

    /// The underlying controller, for queries the stage does not wrap.
    pub fn controller(&mut self) -> &mut GcsController {
        &mut self.controller
    }

    /// The settings in force.
    pub fn settings(&self) -> &StageSettings {
        &self.settings
    }

    fn check_interrupt(&mut self) -> Result<(), GcsError> {
        if self.interrupt.load(Ordering::SeqCst) {
            self.controller.halt_after_failure();
            self.may_be_moving = false;
            return Err(GcsError::Interrupted);
        }
        Ok(())
    }

    /// Runs `f`; if it fails while the stage may be moving, halts first.
    fn guarded<T>(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<T, GcsError>,
    ) -> Result<T, GcsError> {
        let result = f(self);
        if result.is_err() && self.may_be_moving {
            if self.controller.halt_after_failure() {
                self.may_be_moving = false;
            } else {
                tracing::error!(
                    "could not halt the stage at {}: check it by hand",
                    self.controller.endpoint()
                );
            }
        }
        result
    }

    /// Metres to controller units, rounded to 1e-9 unit (far below any
    /// stage's resolution) so that 60e-6 m goes on the wire as `60`, not
    /// `59.99999999999999`.
    fn to_units(&self, value_m: f64) -> f64 {
        (value_m / self.settings.unit_m * 1e9).round() / 1e9
    }

    /// Current position, metres, per axis.
    pub fn position_m(&mut self) -> Result<Vec<f64>, GcsError> {
        let axes: Vec<String> = self.settings.axes.clone();
        let refs: Vec<&str> = axes.iter().map(String::as_str).collect();
        let unit = self.settings.unit_m;
        let pos = self.guarded(|s| s.controller.positions(&refs))?;
        Ok(pos.into_iter().map(|p| p * unit).collect())
    }

    /// Switches closed-loop servo on for every stage axis; on real hardware
    /// only once the first move is confirmed ([`GcsStage::confirm_first_move`]):
    /// servo on powers the axes.
    pub fn enable_servo(&mut self) -> Result<(), GcsError> {
        if !matches!(self.confirmation, FirstMoveConfirmation::NotNeeded) {
            return Err(SafetyViolation::NotConfirmed.into());
        }
        self.check_interrupt()?;
        let axes = self.settings.axes.clone();
        let refs: Vec<(&str, bool)> = axes.iter().map(|a| (a.as_str(), true)).collect();
        self.controller.set_servo(&refs)
    }

    /// Sets the closed-loop speed of every axis (checked against the top speed).
    pub fn set_speed_m_per_s(&mut self, speed_m_per_s: f64) -> Result<(), GcsError> {
        self.settings.limits.check_speed(speed_m_per_s)?;
        self.check_interrupt()?;
        let value = self.to_units(speed_m_per_s);
        let axes = self.settings.axes.clone();
        let pairs: Vec<(&str, f64)> = axes.iter().map(|a| (a.as_str(), value)).collect();
        self.controller.set_velocity(&pairs)
    }

    /// Starts an absolute move to `target_m` (metres, one per axis) after the
    /// soft-limit and step checks; returns once the controller accepted it.
    pub fn start_move_m(&mut self, target_m: &[f64]) -> Result<(), GcsError> {
        self.settings
            .limits
            .check_target(&self.settings.axes, target_m)?;
        self.check_interrupt()?;
        let from_m = self.position_m()?;
        self.settings.limits.check_step(&from_m, target_m)?;
        self.confirm_first_move(&from_m, target_m)?;
        let axes = self.settings.axes.clone();
        let units: Vec<f64> = target_m.iter().map(|&t| self.to_units(t)).collect();
        let pairs: Vec<(&str, f64)> = axes.iter().map(String::as_str).zip(units).collect();
        self.may_be_moving = true;
        self.move_sent = true;
        self.guarded(|s| s.controller.move_to(&pairs))
    }

    /// True once a move was sent (accepted or not): before that the stage
    /// is where it was found.
    pub fn move_sent(&self) -> bool {
        self.move_sent
    }

    /// True once the operator declined the first move (no `yes`, the
    /// input's end, Ctrl-C at the question): nothing that powers or moves
    /// an axis was sent, nor will be.
    pub fn first_move_refused(&self) -> bool {
        matches!(self.confirmation, FirstMoveConfirmation::Refused)
    }

    /// Asks the operator once, on real hardware, before the first command
    /// that powers or moves an axis (servo on, velocities, the move); a
    /// refusal holds for the rest of the process, so a clean-up move after
    /// it is refused too instead of asking again.
    pub fn confirm_first_move(&mut self, from_m: &[f64], target_m: &[f64]) -> Result<(), GcsError> {
        let ask = match &mut self.confirmation {
            FirstMoveConfirmation::NotNeeded => return Ok(()),
            FirstMoveConfirmation::Refused => return Err(SafetyViolation::NotConfirmed.into()),
            FirstMoveConfirmation::Ask(ask) => ask,
        };
        let um = |m: &[f64]| {
            let each: Vec<String> = m.iter().map(|v| format!("{:.3}", v * 1e6)).collect();
            format!("({}) um", each.join(", "))
        };
        let travel = from_m
            .iter()
            .zip(target_m)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let to = if travel < 1e-9 {
            "staying there (servo on and velocities set first)".to_owned()
        } else {
            format!("to {}", um(target_m))
        };
        let text = format!(
            "first move on {}: axes {:?} from {} {to}",
            self.controller.endpoint(),
            self.settings.axes,
            um(from_m),
        );
        if ask(&text) {
            self.confirmation = FirstMoveConfirmation::NotNeeded;
            Ok(())
        } else {
            self.confirmation = FirstMoveConfirmation::Refused;
            Err(SafetyViolation::NotConfirmed.into())
        }
    }

    /// Waits until every axis is on target; halts the stage and fails on
    /// Ctrl-C, on a link failure, or after the settle timeout.
    pub fn wait_settled(&mut self) -> Result<(), GcsError> {
        let deadline = Instant::now() + self.settings.settle_timeout;
        let axes = self.settings.axes.clone();
        let refs: Vec<&str> = axes.iter().map(String::as_str).collect();
        loop {
            self.check_interrupt()?;
            let settled = self.guarded(|s| s.controller.on_target(&refs))?;
            if settled.iter().all(|&b| b) {
                self.may_be_moving = false;
                return Ok(());
            }
            if Instant::now() >= deadline {
                let timeout = self.settings.settle_timeout;
                return self.guarded(|_| Err(GcsError::NotSettled { timeout }));
            }
            std::thread::sleep(self.settings.poll_interval);
        }
    }

    /// Moves to `target_m` and waits until settled.
    pub fn move_to_m(&mut self, target_m: &[f64]) -> Result<(), GcsError> {
        self.start_move_m(target_m)?;
        self.wait_settled()
    }

    /// Halts every axis now.
    pub fn halt(&mut self) -> Result<(), GcsError> {
        self.controller.halt(&[])?;
        self.may_be_moving = false;
        Ok(())
    }
}

impl Drop for GcsStage {
    fn drop(&mut self) {
        if self.may_be_moving && !self.controller.halt_after_failure() {
            tracing::error!(
                "stage dropped while it may be moving and HLT failed: check {}",
                self.controller.endpoint()
            );
        }
    }
}
