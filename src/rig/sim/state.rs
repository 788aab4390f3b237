//! The simulated rig's physical state as a file, so that a killed run can be
//! resumed on the same world: on a real rig the particles simply stay where
//! they are; on the simulated one this file is where they stay. Written
//! atomically (temporary file, then rename) so a kill never leaves half a state.

use serde::{Deserialize, Serialize};
use std::path::Path;

/// Schema of the state file.
pub const SIM_STATE_SCHEMA: &str = "nanopush.sim-state/1";

/// One particle of the saved world, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SavedParticle {
    /// World identity.
    pub id: usize,
    /// Centre x, metres.
    pub x_m: f64,
    /// Centre y, metres.
    pub y_m: f64,
    /// Radius, metres.
    pub radius_m: f64,
}

/// Everything that changes while the simulated rig runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimState {
    /// Always [`SIM_STATE_SCHEMA`].
    pub schema: String,
    /// The particles.
    pub particles: Vec<SavedParticle>,
    /// Commanded nanostage position, metres.
    pub commanded: [f64; 3],
    /// Real tip position on the sample, metres.
    pub actual: [f64; 3],
    /// Rig clock, seconds.
    pub clock_s: f64,
    /// Coarse-stage offset, metres.
    pub coarse_offset: [f64; 2],
    /// Moves made so far.
    pub moves: usize,
    /// Frames grabbed so far.
    pub frames: usize,
}

/// Why a state file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum SimStateError {
    /// Reading or writing failed.
    #[error("simulated rig state {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The file is not a state file of this schema.
    #[error("simulated rig state {path}: {message}")]
    Format { path: String, message: String },
}

impl SimState {
    /// Writes the state atomically.
    pub fn save(&self, path: &Path) -> Result<(), SimStateError> {
        let io = |source| SimStateError::Io {
            path: path.display().to_string(),
            source,
        };
        let tmp = path.with_extension("json.tmp");
        let text = serde_json::to_string(self).expect("state serialises");
        std::fs::write(&tmp, text).map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    }

    /// Reads a state written by [`SimState::save`].
    pub fn load(path: &Path) -> Result<Self, SimStateError> {
        let text = std::fs::read_to_string(path).map_err(|source| SimStateError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let state: SimState = serde_json::from_str(&text).map_err(|e| SimStateError::Format {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        if state.schema != SIM_STATE_SCHEMA {
            return Err(SimStateError::Format {
                path: path.display().to_string(),
                message: format!("schema {} is not {SIM_STATE_SCHEMA}", state.schema),
            });
        }
        Ok(state)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_saved_state_reads_back_identically_and_a_foreign_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("state.json");
        let state = SimState {
            schema: SIM_STATE_SCHEMA.to_owned(),
            particles: vec![SavedParticle {
                id: 3,
                x_m: 1.5e-5,
                y_m: 2.25e-5,
                radius_m: 5e-6,
            }],
            commanded: [1e-6, 2e-6, 3e-6],
            actual: [1.01e-6, 2e-6, 3e-6],
            clock_s: 12.5,
            coarse_offset: [1e-5, 0.0],
            moves: 7,
            frames: 4,
        };
        state.save(&path).unwrap();
        assert_eq!(SimState::load(&path).unwrap(), state);
        std::fs::write(&path, "{\"schema\":\"other/1\"}").unwrap();
        assert!(matches!(
            SimState::load(&path),
            Err(SimStateError::Format { .. })
        ));
    }
}
