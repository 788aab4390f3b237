//! GCS controller error codes (the number `ERR?` answers) as a typed enum.
//!
//! The numbers and texts follow PI's GCS 2.0 error table (the same table
//! PIPython ships); only the codes nanopush provokes or must react to get their
//! own variant, every other number is kept as [`ControllerError::Other`].

/// An error the controller reported through `ERR?` (never code 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ControllerError {
    /// 1: a parameter of the command could not be parsed.
    #[error("controller error 1: parameter syntax error")]
    ParamSyntax,
    /// 2: the controller does not know the command.
    #[error("controller error 2: unknown command")]
    UnknownCommand,
    /// 5: move refused because the axis is unreferenced or its servo is off.
    #[error("controller error 5: move attempted with servo off or on an unreferenced axis")]
    ServoOff,
    /// 7: the target lies outside the axis travel range (`TMN?`..`TMX?`).
    #[error("controller error 7: position out of limits")]
    PositionOutOfLimits,
    /// 8: the requested velocity is outside what the axis allows.
    #[error("controller error 8: velocity out of limits")]
    VelocityOutOfLimits,
    /// 10: motion was stopped by `STP`, `HLT` or `#24`.
    #[error("controller error 10: controller was stopped by command")]
    StoppedByCommand,
    /// 15: an axis identifier the controller does not have.
    #[error("controller error 15: invalid axis identifier")]
    InvalidAxis,
    /// 17: a parameter is out of its allowed range.
    #[error("controller error 17: parameter out of range")]
    ParamOutOfRange,
    /// Any other non-zero code; look it up in the controller manual.
    #[error("controller error {0} (see the controller manual)")]
    Other(i32),
}

impl ControllerError {
    /// Maps an `ERR?` number to a typed error; `None` for 0 (no error).
    pub fn from_code(code: i32) -> Option<Self> {
        Some(match code {
            0 => return None,
            1 => Self::ParamSyntax,
            2 => Self::UnknownCommand,
            5 => Self::ServoOff,
            7 => Self::PositionOutOfLimits,
            8 => Self::VelocityOutOfLimits,
            10 => Self::StoppedByCommand,
            15 => Self::InvalidAxis,
            17 => Self::ParamOutOfRange,
            other => Self::Other(other),
        })
    }

    /// The number the controller uses for this error (what `ERR?` answers).
    pub fn code(self) -> i32 {
        match self {
            Self::ParamSyntax => 1,
            Self::UnknownCommand => 2,
            Self::ServoOff => 5,
            Self::PositionOutOfLimits => 7,
            Self::VelocityOutOfLimits => 8,
            Self::StoppedByCommand => 10,
            Self::InvalidAxis => 15,
            Self::ParamOutOfRange => 17,
            Self::Other(code) => code,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_named_code_round_trips() {
        for code in [1, 2, 5, 7, 8, 10, 15, 17, 3, -1, 555] {
            let err = ControllerError::from_code(code).expect("non-zero code is an error");
            assert_eq!(err.code(), code);
        }
        assert_eq!(ControllerError::from_code(0), None);
        assert_eq!(
            ControllerError::from_code(5),
            Some(ControllerError::ServoOff)
        );
        assert_eq!(
            ControllerError::from_code(3),
            Some(ControllerError::Other(3))
        );
    }
}
