//! Rig interface (stage, camera, probe readout) and its implementations.
pub mod gcs;
