//! Synthetic microscope frames, overlays, plots and animations.
