//! Pixel-to-stage calibration.

pub mod affine;
pub mod calibration_run;
