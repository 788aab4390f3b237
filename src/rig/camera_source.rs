//! The `[camera]` section of a rig file: which kind of camera, and its fields,
//! in lab units (milliseconds). One enum variant per way frames reach nanopush.

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::vision::frame_input::Channel;

/// Where camera frames come from (`[camera] kind = "..."` in a rig file).
/// Read key by key ([`super::camera_table`]), so that an error points at
/// its key; a field left out takes the default its doc comment gives.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum CameraSource {
    /// A folder the camera's own acquisition software writes TIFF/PNG frames into.
    Folder {
        /// The watched folder (relative to the rig file).
        path: PathBuf,
        /// In which order new files are taken (default by name).
        order: FrameOrder,
        /// Every new frame in turn (the default), or only the newest (older
        /// ones are skipped).
        pick: FramePick,
        /// Ignore the files already in the folder when the camera opens
        /// (default true).
        skip_existing: bool,
        /// A file counts as complete once its size has not changed for this
        /// long (default 50).
        stable_ms: u64,
        /// Longest wait for the next frame before `grab` returns "no frame"
        /// (default 5000).
        timeout_ms: u64,
        /// Which part of colour frames is looked at (default luminance).
        channel: Channel,
    },
    /// A video file read through OpenCV VideoCapture (one frame per grab).
    Video {
        /// The file (relative to the rig file).
        path: PathBuf,
        /// Which part of colour frames is looked at (default luminance).
        channel: Channel,
    },
    /// A video device (V4L2 `/dev/videoN`, ...) through OpenCV VideoCapture.
    Device {
        /// Device index (`0` for `/dev/video0`).
        index: i32,
        /// Which part of colour frames is looked at (default luminance).
        channel: Channel,
    },
    /// A GStreamer pipeline through OpenCV VideoCapture (ends in `appsink`).
    Gstreamer {
        /// The pipeline string.
        pipeline: String,
        /// Which part of colour frames is looked at (default luminance).
        channel: Channel,
    },
    /// A GenICam camera (GigE Vision / USB3 Vision) through Aravis; needs the
    /// `aravis` cargo feature.
    Aravis {
        /// Aravis device id (empty, the default: the first camera found).
        device: String,
        /// Longest wait for a frame buffer, milliseconds (default 5000).
        timeout_ms: u64,
    },
    /// The simulated microscope (the simulated rig's camera).
    Simulated,
}

/// In which order a watched folder's new files become frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrameOrder {
    /// By file name (zero-padded frame numbers sort right).
    #[default]
    Name,
    /// By modification time (name breaks ties).
    Mtime,
}

/// Which of the waiting frames a grab returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FramePick {
    /// Every frame in turn: nothing is skipped.
    #[default]
    Every,
    /// Only the newest complete frame; older waiting ones are skipped (for a
    /// camera that streams faster than the executor looks).
    Latest,
}

pub(super) fn default_true() -> bool {
    true
}
pub(super) fn default_stable_ms() -> u64 {
    50
}
pub(super) fn default_frame_timeout_ms() -> u64 {
    5000
}

impl CameraSource {
    /// Resolves relative file paths against `base` (the rig file's folder).
    pub fn resolve_paths(&mut self, base: &Path) {
        match self {
            Self::Folder { path, .. } | Self::Video { path, .. } => *path = base.join(&*path),
            _ => {}
        }
    }

    /// Checks the values (positive times, non-empty pipeline); the reason on failure.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            Self::Folder {
                stable_ms,
                timeout_ms,
                ..
            } if *timeout_ms == 0 || *stable_ms > *timeout_ms => Err(format!(
                "camera.timeout_ms ({timeout_ms}) must be positive and at least camera.stable_ms ({stable_ms})"
            )),
            Self::Aravis { timeout_ms: 0, .. } => Err("camera.timeout_ms must be positive".into()),
            Self::Device { index, .. } if *index < 0 => {
                Err(format!("camera.index must be >= 0, got {index}"))
            }
            Self::Gstreamer { pipeline, .. } if pipeline.trim().is_empty() => {
                Err("camera.pipeline is empty".into())
            }
            _ => Ok(()),
        }
    }

    /// Which part of colour frames the camera gives (luminance for the
    /// kinds that give grey frames only: Aravis's mono formats, the
    /// simulated microscope).
    pub fn channel(&self) -> Channel {
        match self {
            Self::Folder { channel, .. }
            | Self::Video { channel, .. }
            | Self::Device { channel, .. }
            | Self::Gstreamer { channel, .. } => *channel,
            Self::Aravis { .. } | Self::Simulated => Channel::Luminance,
        }
    }

    /// Where frames come from, for a person: "folder /lab/frames, channel green".
    pub fn describe(&self) -> String {
        let place = match self {
            Self::Folder { path, .. } => format!("folder {}", path.display()),
            Self::Video { path, .. } => format!("video {}", path.display()),
            Self::Device { index, .. } => format!("device /dev/video{index}"),
            Self::Gstreamer { pipeline, .. } => format!("gstreamer pipeline {pipeline:?}"),
            Self::Aravis { device, .. } if device.is_empty() => {
                return "aravis, the first camera".into();
            }
            Self::Aravis { device, .. } => return format!("aravis {device}"),
            Self::Simulated => return "the simulated microscope".into(),
        };
        format!("{place}, channel {}", self.channel())
    }

    /// What to check when no frame comes (the folder's writer, or the
    /// device), for an error message.
    pub fn when_no_frame(&self) -> &'static str {
        match self {
            Self::Folder {
                skip_existing: true,
                ..
            } => {
                "is the camera's software writing new frames into the folder? (skip_existing = true: the files already there are not taken)"
            }
            Self::Folder { .. } => "the folder holds no frame, and none was written into it",
            Self::Video { .. } => "the video file has no frame left",
            _ => "is the camera on, and streaming?",
        }
    }

    /// The kind as written in the rig file.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Folder { .. } => "folder",
            Self::Video { .. } => "video",
            Self::Device { .. } => "device",
            Self::Gstreamer { .. } => "gstreamer",
            Self::Aravis { .. } => "aravis",
            Self::Simulated => "simulated",
        }
    }
}

/// Milliseconds from a file to a [`Duration`].
pub(crate) fn ms(value: u64) -> Duration {
    Duration::from_millis(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Section {
        camera: CameraSource,
    }

    fn every_kind() -> Vec<CameraSource> {
        vec![
            CameraSource::Folder {
                path: "frames".into(),
                order: FrameOrder::Mtime,
                pick: FramePick::Latest,
                skip_existing: false,
                stable_ms: 80,
                timeout_ms: 2000,
                channel: Channel::Green,
            },
            CameraSource::Video {
                path: "run.avi".into(),
                channel: Channel::Red,
            },
            CameraSource::Device {
                index: 2,
                channel: Channel::Blue,
            },
            CameraSource::Gstreamer {
                pipeline: "videotestsrc ! videoconvert ! appsink".into(),
                channel: Channel::Luminance,
            },
            CameraSource::Aravis {
                device: "Aravis-Fake-GV01".into(),
                timeout_ms: 300,
            },
            CameraSource::Simulated,
        ]
    }

    #[test]
    fn every_kind_round_trips_through_toml() {
        for camera in every_kind() {
            let text = toml::to_string(&Section {
                camera: camera.clone(),
            })
            .unwrap();
            assert!(
                text.contains(&format!("kind = \"{}\"", camera.kind())),
                "{text}"
            );
            let back: Section = toml::from_str(&text).unwrap();
            assert_eq!(back.camera, camera);
            assert_eq!(camera.validate(), Ok(()));
        }
    }

    #[test]
    fn folder_defaults_and_bad_values() {
        let s: Section = toml::from_str("[camera]\nkind = \"folder\"\npath = \"f\"\n").unwrap();
        assert_eq!(
            s.camera,
            CameraSource::Folder {
                path: "f".into(),
                order: FrameOrder::Name,
                pick: FramePick::Every,
                skip_existing: true,
                stable_ms: 50,
                timeout_ms: 5000,
                channel: Channel::Luminance,
            }
        );
        let bad: Section = toml::from_str(
            "[camera]\nkind = \"folder\"\npath = \"f\"\nstable_ms = 900\ntimeout_ms = 100\n",
        )
        .unwrap();
        assert!(bad.camera.validate().unwrap_err().contains("stable_ms"));
        assert!(
            toml::from_str::<Section>("[camera]\nkind = \"webcam\"\n").is_err(),
            "unknown kinds are refused"
        );
        assert!(
            toml::from_str::<Section>("[camera]\nkind = \"device\"\nindex = 0\npath = \"x\"\n")
                .is_err(),
            "unknown fields are refused"
        );
        // Aravis reads monochrome formats only: a channel there is a mistake.
        assert!(
            toml::from_str::<Section>("[camera]\nkind = \"aravis\"\nchannel = \"green\"\n")
                .is_err()
        );
        let err = toml::from_str::<Section>(
            "[camera]\nkind = \"device\"\nindex = 0\nchannel = \"purple\"\n",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("use luminance, red, green or blue"), "{err}");
    }

    #[test]
    fn relative_paths_resolve_against_the_rig_folder() {
        let mut cam = CameraSource::Video {
            path: "run.avi".into(),
            channel: Channel::Green,
        };
        cam.resolve_paths(Path::new("/lab/calib"));
        assert_eq!(
            cam,
            CameraSource::Video {
                path: "/lab/calib/run.avi".into(),
                channel: Channel::Green,
            }
        );
    }
}
