//! What can go wrong talking to a rig, as the executor sees it.

/// A rig failure. The executor stops safely on any of these.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// A target outside the stage's travel or soft limits; nothing was moved.
    #[error("axis {axis} target {target_um:.3} um is outside {min_um:.3}..{max_um:.3} um")]
    OutOfRange {
        axis: char,
        target_um: f64,
        min_um: f64,
        max_um: f64,
    },
    /// A single move longer than the rig allows; nothing was moved.
    #[error("a move of {step_um:.3} um is longer than the largest allowed step {max_um:.3} um")]
    StepTooLarge { step_um: f64, max_um: f64 },
    /// A speed the stage cannot do, or not a finite positive number.
    #[error(
        "speed {speed_um_s:.3} um/s is not in (0, {max_um_s:.3}] um/s (the rig file's top_speed_um_s)"
    )]
    BadSpeed { speed_um_s: f64, max_um_s: f64 },
    /// The stage reported a fault during a move; it has been halted.
    #[error("stage fault: {0}")]
    StageFault(String),
    /// The controller or camera did not answer in time.
    #[error("{device} did not answer within {timeout_ms} ms")]
    Timeout { device: String, timeout_ms: u64 },
    /// The stage answered, but its axes were not on target within the rig
    /// file's settle timeout.
    #[error(
        "{device} was not on target within {timeout_ms} ms (the rig file's settle_timeout_ms): it answers, but the move did not settle in that time"
    )]
    NotSettled { device: String, timeout_ms: u64 },
    /// The rig has no coarse stage (a hardware rig whose rig file names none);
    /// nothing was moved.
    #[error("this rig has no coarse stage: move the sample by hand, or add one to the rig")]
    NoCoarseStage,
    /// Ctrl-C, SIGTERM or SIGHUP arrived ([`crate::rig::interrupt`]): the
    /// stage was halted and nothing more is moved. A run stops on it as on
    /// any stop: it is journalled and can be resumed (it had been a "stage
    /// fault", retried).
    #[error("interrupted ({}); the stage was halted", crate::rig::interrupt::CAUSE)]
    Interrupted,
    /// The operator answered the first-move question on real hardware with
    /// anything but `yes`: nothing was sent that moves or powers an axis,
    /// and nothing more will be (it had been a "stage fault", retried).
    #[error("the first move on real hardware was not confirmed: nothing was moved")]
    NotConfirmed,
    /// The camera or another input could not be read.
    #[error("{0}")]
    Io(String),
}
