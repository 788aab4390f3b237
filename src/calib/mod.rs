//! Pixel-to-stage calibration.

pub mod calibration_run;
pub mod camera_fit;
pub mod camera_map;
pub mod fit_quality;
pub mod lens;
