//! Typed failures of the pushing model. Every way a computation can refuse is
//! named here, so callers never receive NaN or a silent garbage number.

use thiserror::Error;

/// Why a contact computation could not give a contact state.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ContactError {
    /// The load pulls harder than the contact can hold: the surfaces separate.
    #[error("load {load_n:.3e} N is below the pull-off force {pull_off_n:.3e} N: contact detached")]
    Detached {
        /// Applied load (negative = tensile).
        load_n: f64,
        /// Pull-off force of the interface (negative).
        pull_off_n: f64,
    },
    /// An input was NaN or infinite.
    #[error("non-finite contact input `{what}` = {value}")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Its value.
        value: f64,
    },
}

/// Why the pushing model could not produce a result.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    /// A scene field was missing or invalid; `field` is its dotted path.
    #[error("scene field `{field}`: {problem}")]
    Scene {
        /// Dotted path of the field, e.g. `particle.radius_um`.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A scene file could not be read ("cannot read: ...") or parsed
    /// ("line 3: ..."); callers name the file.
    #[error("{0}")]
    SceneText(String),
    /// The file given as a scene is another nanopush kind (a calibration, a
    /// rig file); callers name the file.
    #[error(transparent)]
    NotAScene(#[from] crate::file_schema::AnotherKind),
    /// A push parameter was invalid.
    #[error("push parameter `{field}`: {problem}")]
    Push {
        /// Parameter name with unit, e.g. `speed_um_s`.
        field: &'static str,
        /// What is wrong with it.
        problem: String,
    },
    /// A contact computation failed where no physical fallback exists.
    #[error(transparent)]
    Contact(#[from] ContactError),
    /// A bracketed root search could not bracket or converge.
    #[error("root search for {what} failed: {why}")]
    RootNotFound {
        /// Which quantity was being solved for.
        what: &'static str,
        /// Why it failed.
        why: String,
    },
    /// No contact angle in the scene's allowed range gives a safe push.
    #[error("no safe contact angle in {min_deg:.1}..{max_deg:.1} deg: {why}")]
    NoSafeAngle {
        /// Lower end of the allowed range.
        min_deg: f64,
        /// Upper end of the allowed range.
        max_deg: f64,
        /// Why every angle was rejected.
        why: String,
    },
}

impl ModelError {
    /// Shorthand for a scene-field error.
    pub fn scene(field: impl Into<String>, problem: impl Into<String>) -> Self {
        ModelError::Scene {
            field: field.into(),
            problem: problem.into(),
        }
    }
}
