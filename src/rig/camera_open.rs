//! Opens the camera a rig file's `[camera]` section names.

use super::camera::Camera;
use super::camera_clock::WallClock;
use super::camera_error::CameraError;
use super::camera_folder::{FolderCamera, FolderCameraSettings};
use super::camera_source::CameraSource;
use super::camera_video::{VideoCamera, VideoInput};

/// A camera of any kind, movable to another thread.
pub type BoxedCamera = Box<dyn Camera + Send>;

/// Opens `source` with frame times on `clock`. `simulated` cannot be opened
/// from a rig file (it needs a simulated world); `aravis` needs the `aravis`
/// cargo feature.
pub fn open_camera(source: &CameraSource, clock: WallClock) -> Result<BoxedCamera, CameraError> {
    if let Some(settings) = FolderCameraSettings::from_source(source) {
        return Ok(Box::new(FolderCamera::open(settings, clock)?));
    }
    if let Some(input) = VideoInput::from_source(source) {
        let camera = VideoCamera::open(input, clock)?.with_channel(source.channel());
        return Ok(Box::new(camera));
    }
    match source {
        CameraSource::Aravis { device, timeout_ms } => open_aravis(device, *timeout_ms, clock),
        _ => Err(CameraError::SimulatedNeedsWorld),
    }
}

#[cfg(feature = "aravis")]
fn open_aravis(
    device: &str,
    timeout_ms: u64,
    clock: WallClock,
) -> Result<BoxedCamera, CameraError> {
    let camera = super::camera_aravis::AravisCamera::open(
        device,
        super::camera_source::ms(timeout_ms),
        clock,
    )?;
    Ok(Box::new(camera))
}

#[cfg(not(feature = "aravis"))]
fn open_aravis(
    _device: &str,
    _timeout_ms: u64,
    _clock: WallClock,
) -> Result<BoxedCamera, CameraError> {
    Err(CameraError::FeatureMissing {
        kind: "aravis",
        feature: "aravis",
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_that_cannot_open_here_say_why() {
        let clock = WallClock::start();
        assert!(matches!(
            open_camera(&CameraSource::Simulated, clock),
            Err(CameraError::SimulatedNeedsWorld)
        ));
        #[cfg(not(feature = "aravis"))]
        assert!(matches!(
            open_camera(
                &CameraSource::Aravis {
                    device: String::new(),
                    timeout_ms: 100
                },
                clock
            ),
            Err(CameraError::FeatureMissing { .. })
        ));
    }
}
