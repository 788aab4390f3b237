//! Rig interface (stage, camera, probe readout) and its implementations:
//! the simulated rig ([`sim`]) and PI GCS 2.0 controllers ([`gcs`]).

pub mod camera;
#[cfg(feature = "aravis")]
pub mod camera_aravis;
pub mod camera_clock;
pub mod camera_error;
pub mod camera_folder;
pub mod camera_open;
pub mod camera_source;
pub mod camera_table;
pub mod camera_video;
pub mod error;
pub mod gcs;
pub mod gcs_coarse_stage;
pub mod gcs_line_stage;
pub mod hardware;
pub mod interrupt;
pub mod microscope_feeder;
pub mod sim;
pub mod stage;

pub use error::RigError;

use crate::calib::camera_map::CameraCalibration;

/// Everything the executor drives: the nanostage, the coarse stage, the camera.
/// A rig without a coarse stage refuses coarse moves with a [`RigError`].
pub trait Rig: stage::NanoStage + stage::CoarseStage + camera::Camera {
    /// Rig time in seconds: the simulated clock, or wall time since start on hardware.
    fn now_s(&self) -> f64;
    /// The camera's pixel -> nanostage calibration.
    fn calibration(&self) -> &CameraCalibration;
    /// Seconds of [`Rig::now_s`] spent waiting for the operator since the
    /// last call (the confirmation before real hardware's first move): no
    /// work of the rig's. None on a simulated rig.
    fn take_operator_wait_s(&mut self) -> f64 {
        0.0
    }
}
