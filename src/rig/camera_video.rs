//! A camera read through OpenCV's videoio `VideoCapture`: a video device
//! (V4L2 on Linux), a video file, or a GStreamer pipeline ending in `appsink`.
//! Frames are timed when they are read (OpenCV gives no reliable exposure time).

use super::camera::{Camera, TimedFrame};
use super::camera_clock::WallClock;
use super::camera_error::CameraError;
use super::camera_source::CameraSource;
use super::error::RigError;
use crate::vision::frame_input::{Channel, mat_to_frame};
use crate::vision::opencv_quiet::{open_video, quietly};
use opencv::core::{Mat, MatTraitConst};
use opencv::prelude::{VideoCaptureTrait, VideoCaptureTraitConst};
use opencv::videoio::{CAP_ANY, CAP_GSTREAMER, VideoCapture};
use std::path::PathBuf;

/// What a [`VideoCamera`] opens.
#[derive(Debug, Clone, PartialEq)]
pub enum VideoInput {
    /// A device index (`0` is `/dev/video0`).
    Device(i32),
    /// A video file.
    File(PathBuf),
    /// A GStreamer pipeline string.
    Gstreamer(String),
}

impl VideoInput {
    /// The input a rig file's `video`, `device` or `gstreamer` section names.
    pub fn from_source(source: &CameraSource) -> Option<Self> {
        match source {
            CameraSource::Video { path, .. } => Some(Self::File(path.clone())),
            CameraSource::Device { index, .. } => Some(Self::Device(*index)),
            CameraSource::Gstreamer { pipeline, .. } => Some(Self::Gstreamer(pipeline.clone())),
            _ => None,
        }
    }

    fn kind(&self) -> &'static str {
        match self {
            Self::Device(_) => "device",
            Self::File(_) => "video",
            Self::Gstreamer(_) => "gstreamer",
        }
    }

    fn describe(&self) -> String {
        match self {
            Self::Device(i) => format!("/dev/video{i}"),
            Self::File(p) => p.display().to_string(),
            Self::Gstreamer(s) => s.clone(),
        }
    }
}

/// An OpenCV VideoCapture as a rig camera.
pub struct VideoCamera {
    input: VideoInput,
    capture: VideoCapture,
    clock: WallClock,
    channel: Channel,
    ended: bool,
    frames: usize,
}

impl VideoCamera {
    /// Opens the input; fails with [`CameraError::Open`] if OpenCV cannot.
    pub fn open(input: VideoInput, clock: WallClock) -> Result<Self, CameraError> {
        let open_error = |reason: String| CameraError::Open {
            kind: input.kind(),
            what: input.describe(),
            reason,
        };
        if let VideoInput::File(path) = &input
            && !path.is_file()
        {
            return Err(open_error("no such file".into()));
        }
        let capture = match &input {
            VideoInput::Device(index) => VideoCapture::new(*index, CAP_ANY),
            // A recording: OpenCV's and FFmpeg's own errors kept quiet, the
            // error below names the file.
            VideoInput::File(path) => open_video(path),
            VideoInput::Gstreamer(pipeline) => VideoCapture::from_file(pipeline, CAP_GSTREAMER),
        }
        .map_err(|e| open_error(e.to_string()))?;
        if !capture.is_opened().map_err(|e| open_error(e.to_string()))? {
            return Err(open_error(
                "OpenCV could not open it (no such device, unsupported codec, or OpenCV built without this backend)"
                    .into(),
            ));
        }
        Ok(Self {
            input,
            capture,
            clock,
            channel: Channel::Luminance,
            ended: false,
            frames: 0,
        })
    }

    /// Takes this channel of colour frames instead of luminance.
    pub fn with_channel(mut self, channel: Channel) -> Self {
        self.channel = channel;
        self
    }

    /// True once a video file has run out of frames (grab then returns `Ok(None)`).
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// Frames read so far.
    pub fn frames(&self) -> usize {
        self.frames
    }
}

impl Camera for VideoCamera {
    /// The next frame; `Ok(None)` when the source gave none (a device that
    /// dropped one, or the end of a file: see [`VideoCamera::ended`]).
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        if self.ended {
            return Ok(None);
        }
        let mut mat = Mat::default();
        // A file's damaged frame is said by the end it makes; a device's or
        // a pipeline's own warnings (timeouts) are left for the user to see.
        let capture = &mut self.capture;
        let got = if matches!(self.input, VideoInput::File(_)) {
            quietly(|| capture.read(&mut mat))
        } else {
            capture.read(&mut mat)
        }
        .map_err(|e| RigError::Io(format!("camera {}: {e}", self.input.describe())))?;
        if !got || mat.empty() {
            if matches!(self.input, VideoInput::File(_)) {
                self.ended = true;
            }
            return Ok(None);
        }
        let t_s = self.clock.now_s();
        let source = PathBuf::from(self.input.describe());
        let frame = mat_to_frame(&mat, &source, self.channel)
            .map_err(|e| RigError::Io(format!("camera: {e}")))?;
        self.frames += 1;
        Ok(Some(TimedFrame { t_s, frame }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_file_and_a_bad_pipeline_are_typed_errors() {
        let clock = WallClock::start();
        let err = VideoCamera::open(VideoInput::File("/nonexistent/run.avi".into()), clock)
            .err()
            .unwrap();
        assert!(
            matches!(err, CameraError::Open { kind: "video", .. }),
            "{err}"
        );
        let err = VideoCamera::open(
            VideoInput::Gstreamer("no-such-element ! appsink".into()),
            clock,
        )
        .err()
        .unwrap();
        assert!(
            matches!(
                err,
                CameraError::Open {
                    kind: "gstreamer",
                    ..
                }
            ),
            "{err}"
        );
    }
}
