//! The rig's camera: timestamped frames, or nothing when a frame was dropped.

use super::error::RigError;
use crate::vision::frame::Frame;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// A frame and the rig time it was exposed at.
#[derive(Debug, Clone, PartialEq)]
pub struct TimedFrame {
    /// Rig time of the exposure, seconds.
    pub t_s: f64,
    /// The image.
    pub frame: Frame,
}

/// A source of frames.
pub trait Camera {
    /// The next frame; `Ok(None)` when the camera dropped it (the caller may ask again).
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError>;

    /// Has a grab that is waiting for a frame give up (`Ok(None)`) once
    /// `flag` (Ctrl-C's) is raised, for a camera that may wait seconds for
    /// one: a press had gone unseen until its timeout. Others ignore it.
    fn stop_waiting_on(&mut self, _flag: Arc<AtomicBool>) {}
}
