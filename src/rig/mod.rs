//! Rig interface (stage, camera, probe readout) and its implementations.

pub mod error;
pub mod stage;

pub use error::RigError;
pub mod camera;
pub mod sim;
