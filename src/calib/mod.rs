//! Pixel-to-stage calibration.

pub mod affine;
