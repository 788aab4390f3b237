//! Why a camera could not be opened. Once open, cameras report through
//! [`RigError`] like every other rig part.

use super::error::RigError;
use std::path::PathBuf;

/// A camera that could not be opened, naming the source and what to do.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// The watched folder is missing or unreadable.
    #[error("camera folder {path} cannot be read: {source} (create it, or fix [camera] path)")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// OpenCV could not open the video file, device or pipeline.
    #[error("cannot open {kind} camera {what:?}: {reason}")]
    Open {
        /// The `[camera] kind`.
        kind: &'static str,
        /// What was opened (path, index, pipeline or device id).
        what: String,
        /// What the library said.
        reason: String,
    },
    /// The camera kind needs a cargo feature this build lacks.
    #[error(
        "camera kind {kind:?} needs nanopush built with `--features {feature}` (see docs/rig.md)"
    )]
    FeatureMissing {
        /// The `[camera] kind`.
        kind: &'static str,
        /// The cargo feature.
        feature: &'static str,
    },
    /// The simulated microscope cannot be built from a rig file alone.
    #[error(
        "camera kind \"simulated\" draws a simulated world, which a rig file has not got: give the rig's camera, kind = \"folder\" (the frames a camera program, or `nanopush rig sim-gcs --microscope`, writes), \"video\", \"device\", \"gstreamer\" or \"aravis\" (docs/rig.md)"
    )]
    SimulatedNeedsWorld,
}

impl From<CameraError> for RigError {
    fn from(e: CameraError) -> Self {
        RigError::Io(e.to_string())
    }
}
