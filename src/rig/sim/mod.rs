//! The simulated rig: the pushing model moves particles, the synthetic
//! microscope draws them. Its ground truth is for tests and reports only.

pub mod build;
pub mod model_physics;
pub mod rig;
pub mod stage;
pub mod state;
pub mod world;
