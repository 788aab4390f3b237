//! What a number read from a layout, a pattern or a flag must be besides
//! finite: the layout and pattern checks share it, so each error says the
//! requirement the same way.

/// The sign a checked value must have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sign {
    /// Any finite value (coordinates, angles).
    Any,
    /// Zero or more (gaps).
    NonNegative,
    /// More than zero (sizes, pitches).
    Positive,
}

impl Sign {
    /// The requirement `value` breaks, as the text after "must be finite"
    /// ("" when only finiteness is asked), or `None` when it is fine.
    pub fn broken_by(self, value: f64) -> Option<&'static str> {
        let (bad_sign, needs) = match self {
            Sign::Any => (false, ""),
            Sign::NonNegative => (value < 0.0, " and >= 0"),
            Sign::Positive => (value <= 0.0, " and > 0"),
        };
        (!value.is_finite() || bad_sign).then_some(needs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_sign_refuses_what_it_must_and_nothing_else() {
        assert_eq!(Sign::Any.broken_by(-3.0), None);
        assert_eq!(Sign::Any.broken_by(f64::NAN), Some(""));
        assert_eq!(Sign::NonNegative.broken_by(0.0), None);
        assert_eq!(Sign::NonNegative.broken_by(-1e-9), Some(" and >= 0"));
        assert_eq!(Sign::Positive.broken_by(0.0), Some(" and > 0"));
        assert_eq!(Sign::Positive.broken_by(f64::INFINITY), Some(" and > 0"));
        assert_eq!(Sign::Positive.broken_by(1e-12), None);
    }
}
