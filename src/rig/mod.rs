//! Rig interface (stage, camera, probe readout) and its implementations:
//! the simulated rig ([`sim`]) and PI GCS 2.0 controllers ([`gcs`]).

pub mod camera;
pub mod error;
pub mod gcs;
pub mod sim;
pub mod stage;

pub use error::RigError;
