//! Angle newtypes: degrees at the file/CLI boundary, radians inside the model.
//! Keeping them apart in the type system stops the classic deg/rad slip
//! (spec section 5, case 9).

use serde::{Deserialize, Serialize};

/// An angle in degrees, as written in scene files and CLI flags.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
pub struct Degrees(pub f64);

/// An angle in radians, as used by every formula of the model.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
pub struct Radians(pub f64);

impl Degrees {
    /// Converts to radians (the only way into the model's formulas).
    pub fn to_radians(self) -> Radians {
        Radians(self.0.to_radians())
    }
}

impl Radians {
    /// Converts to degrees for reports and files.
    pub fn to_degrees(self) -> Degrees {
        Degrees(self.0.to_degrees())
    }
}

impl From<Degrees> for Radians {
    fn from(d: Degrees) -> Self {
        d.to_radians()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degrees_round_trip_through_radians() {
        let d = Degrees(45.0);
        let r = d.to_radians();
        assert!((r.0 - std::f64::consts::FRAC_PI_4).abs() < 1e-15);
        assert!((r.to_degrees().0 - 45.0).abs() < 1e-12);
    }
}
