//! Pixel-to-stage calibration.
