//! Synthetic microscope frames, overlays, plots and animations.

pub mod key;
pub mod microscope;
pub mod microscope_truth;
pub mod noise;
pub mod plan_on_frame;
pub mod plan_overlay;
pub mod plot;
pub mod probe;
pub mod run_overlay;
pub mod sphere;
pub mod video;
