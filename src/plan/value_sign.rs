//! What a number read from a layout, a pattern, a plan file or a flag must
//! be besides finite: their checks share it, so each error says the
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
    /// True when `value` is finite and of this sign.
    pub fn holds(self, value: f64) -> bool {
        value.is_finite()
            && match self {
                Sign::Any => true,
                Sign::NonNegative => value >= 0.0,
                Sign::Positive => value > 0.0,
            }
    }

    /// The bound a finite value must keep: "> 0", ">= 0", or "" for any.
    pub fn bound(self) -> &'static str {
        match self {
            Sign::Any => "",
            Sign::NonNegative => ">= 0",
            Sign::Positive => "> 0",
        }
    }

    /// The requirement `value` breaks, as the text after "must be finite"
    /// ("" when only finiteness is asked), or `None` when it is fine.
    pub fn broken_by(self, value: f64) -> Option<&'static str> {
        let needs = match self {
            Sign::Any => "",
            Sign::NonNegative => " and >= 0",
            Sign::Positive => " and > 0",
        };
        (!self.holds(value)).then_some(needs)
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
        assert!(Sign::NonNegative.holds(0.0) && !Sign::Positive.holds(0.0));
        assert_eq!(Sign::NonNegative.bound(), ">= 0");
    }
}
