//! Everything that can go wrong talking to a GCS controller, as one typed enum.

use super::controller_error::ControllerError;
use super::safety::SafetyViolation;
use std::time::Duration;

/// An error from the GCS driver, its transport, or the safety layer.
#[derive(Debug, thiserror::Error)]
pub enum GcsError {
    /// The controller answered `ERR?` with a non-zero code after `command`.
    #[error("`{command}` was refused: {error}")]
    Controller {
        /// The command (without line feed) that the error followed.
        command: String,
        /// The typed controller error.
        error: ControllerError,
    },
    /// No complete reply line arrived within the timeout.
    #[error(
        "no reply to `{command}` within {timeout:?} (the rig file's timeout_ms; received so far: {partial:?}); is the controller on and connected?"
    )]
    Timeout {
        /// The command that went unanswered.
        command: String,
        /// The read timeout in force.
        timeout: Duration,
        /// Bytes of an incomplete line received before the timeout.
        partial: String,
    },
    /// The controller answered, but the axes were not on target within the
    /// settle timeout (it had read as a controller that did not answer).
    #[error(
        "the axes were not on target within {timeout:?} (the rig file's settle_timeout_ms): the controller answers, but the move did not settle in that time"
    )]
    NotSettled {
        /// The settle timeout in force.
        timeout: Duration,
    },
    /// A reply arrived but could not be understood.
    #[error("malformed reply to `{command}`: {reason} (reply: {reply:?})")]
    MalformedReply {
        /// The command that was answered.
        command: String,
        /// What was wrong with the reply.
        reason: String,
        /// The reply as received (lossily decoded).
        reply: String,
    },
    /// The connection failed or was closed by the other side.
    #[error("connection to {endpoint} failed")]
    Io {
        /// Where we were talking to (address or tty path).
        endpoint: String,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The command was refused locally before any byte was sent.
    #[error("refused before sending: {0}")]
    Safety(#[from] SafetyViolation),
    /// An argument given to the driver cannot be put on the wire.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// Ctrl-C, SIGTERM or SIGHUP arrived ([`crate::rig::interrupt`]): the
    /// stage was halted and the operation abandoned.
    #[error(
        "interrupted ({}); the stage was sent HLT",
        crate::rig::interrupt::CAUSE
    )]
    Interrupted,
}

impl GcsError {
    /// True when the error means the link itself is unusable (reconnect may help).
    pub fn is_link_failure(&self) -> bool {
        matches!(
            self,
            Self::Timeout { .. }
                | Self::NotSettled { .. }
                | Self::Io { .. }
                | Self::MalformedReply { .. }
        )
    }

    /// The controller error code carried, if this is a controller error.
    pub fn controller_error(&self) -> Option<ControllerError> {
        match self {
            Self::Controller { error, .. } => Some(*error),
            _ => None,
        }
    }
}
