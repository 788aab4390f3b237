//! The height the tip travels at, above the substrate, when it must not
//! touch the particles: their tops plus [`LIFT_ABOVE_PARTICLES_M`]. One
//! rule for every command that moves the tip sideways over a sample
//! (`assemble --rig` between pushes, `rig calibrate` over its grid), so
//! that neither accepts a height the other refuses (`rig calibrate --z-um
//! 2` had swept the tip among 10 um particles that `assemble` would not).

use crate::rig::gcs::StageSection;

/// How far above the particles' tops the tip travels between pushes.
pub const LIFT_ABOVE_PARTICLES_M: f64 = 2e-6;

/// The lowest height above the substrate at which the tip clears particles
/// of `radius_m`: their tops plus [`LIFT_ABOVE_PARTICLES_M`].
pub fn clear_height_m(radius_m: f64) -> f64 {
    2.0 * radius_m + LIFT_ABOVE_PARTICLES_M
}

/// Why a travel height was refused, before anything moved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TravelHeightError {
    /// The stage's z cannot rise clear of the particles at all: the rig
    /// file's z convention (or its soft limits) leave too little room.
    #[error(
        "the tip can rise only {top_um:.3} um above the substrate (stage.z_surface_um {z_surface}, z_lifts {z_lifts}, within z's \
         soft limits and travel), but travels {clear_um:.3} um above it, clear of the scene's {diameter_um:.2} um particles: \
         is z_surface_um the controller's z where the tip touches the substrate, in um?"
    )]
    StageTooLow {
        /// The top of z travel as a height above the substrate, um.
        top_um: f64,
        /// The height the tip must travel at, um.
        clear_um: f64,
        /// The particles' diameter, um.
        diameter_um: f64,
        /// The rig file's `z_surface_um`, as said to the user.
        z_surface: String,
        /// The rig file's `z_lifts`, as said to the user.
        z_lifts: String,
    },
    /// A travel height asked for below the particles' tops plus the lift.
    #[error(
        "a travel height of {height_um:.3} um is below {clear_um:.3} um, the tops of the scene's {diameter_um:.2} um particles \
         plus {lift_um:.1} um: the tip would sweep them aside"
    )]
    AmongParticles {
        /// The height asked for, um.
        height_um: f64,
        /// The lowest height that clears the particles, um.
        clear_um: f64,
        /// The particles' diameter, um.
        diameter_um: f64,
        /// The lift above their tops, um.
        lift_um: f64,
    },
}

impl TravelHeightError {
    /// The heights that would be accepted, um (lowest, highest), when
    /// there are any: the fix for a height the user gave.
    pub fn accepted_um(&self, top_um: f64) -> Option<(f64, f64)> {
        match self {
            Self::AmongParticles { clear_um, .. } if *clear_um <= top_um => {
                Some((*clear_um, top_um))
            }
            _ => None,
        }
    }
}

/// Refuses a tip that cannot travel clear of particles of `radius_m`:
/// a stage whose z reaches no higher than `top_m` above the substrate
/// (`stage` names the rig file's z convention that put it there) below
/// [`clear_height_m`], or a `height_m` asked for below it.
pub fn check_travel_height(
    height_m: Option<f64>,
    top_m: f64,
    radius_m: f64,
    stage: &StageSection,
) -> Result<(), TravelHeightError> {
    let clear_m = clear_height_m(radius_m);
    let diameter_um = 2.0 * radius_m * 1e6;
    if top_m < clear_m {
        return Err(TravelHeightError::StageTooLow {
            top_um: top_m * 1e6,
            clear_um: clear_m * 1e6,
            diameter_um,
            z_surface: stage
                .z_surface_um
                .map_or("not given".to_owned(), |z| format!("{z} um")),
            z_lifts: stage
                .z_lifts
                .map_or("not given".to_owned(), |l| format!("{l:?}").to_lowercase()),
        });
    }
    match height_m {
        Some(h) if h.is_nan() || h < clear_m => Err(TravelHeightError::AmongParticles {
            height_um: h * 1e6,
            clear_um: clear_m * 1e6,
            diameter_um,
            lift_um: LIFT_ABOVE_PARTICLES_M * 1e6,
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::gcs::RigFile;

    fn stage() -> StageSection {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/calib/rig-gcs-sim-folder.toml");
        RigFile::load(std::path::Path::new(path)).unwrap().stage
    }

    #[test]
    fn a_height_among_the_particles_is_refused_and_the_accepted_ones_named() {
        let (top, r) = (15e-6, 5e-6);
        assert_eq!(check_travel_height(None, top, r, &stage()), Ok(()));
        assert_eq!(check_travel_height(Some(12e-6), top, r, &stage()), Ok(()));
        let err = check_travel_height(Some(2e-6), top, r, &stage()).unwrap_err();
        assert!(err.to_string().contains("below 12.000 um"), "{err}");
        assert_eq!(err.accepted_um(15.0), Some((12.0, 15.0)));
        let err = check_travel_height(Some(13e-6), 10e-6, r, &stage()).unwrap_err();
        assert!(
            matches!(err, TravelHeightError::StageTooLow { .. }),
            "{err}"
        );
        assert_eq!(err.accepted_um(10.0), None);
    }
}
