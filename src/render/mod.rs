//! Synthetic microscope frames, overlays, plots and animations.
pub mod plan_overlay;
