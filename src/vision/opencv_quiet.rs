//! Keeping OpenCV's own messages off standard error while it opens and
//! reads recordings and writes animations: on a file that is not a video,
//! or one cut short, OpenCV's backends printed their errors (`[ERROR:0@...]
//! global cap.cpp ...`, `Unexpected element. Expected: LIST`) and FFmpeg
//! its own (`[mov,mp4,...] moov atom not found`) before or instead of this
//! program's error, which names the file and what is wrong with it.
//!
//! Not reached by any setting OpenCV offers: the line `imreadmulti` writes
//! to standard error itself when a TIFF page cannot be decoded
//! ("imreadmulti_('...'): can't read data: ..."), and libtiff's own.

use opencv::core::{LogLevel, set_log_level};
use opencv::videoio::{CAP_ANY, CAP_FFMPEG, VideoCapture, VideoCaptureAPIs, has_backend};
use std::path::Path;

/// OpenCV's setting of FFmpeg's log level, read once, when its FFmpeg
/// backend is first used.
const FFMPEG_LOG_LEVEL: &str = "OPENCV_FFMPEG_LOGLEVEL";

/// OpenCV's switch for FFmpeg's verbose log (a user debugging asks for it).
const FFMPEG_DEBUG: &str = "OPENCV_FFMPEG_DEBUG";

/// FFmpeg's `AV_LOG_QUIET`.
const AV_LOG_QUIET: &str = "-8";

/// Runs `f` with OpenCV's log silenced, restored after.
pub fn quietly<T>(f: impl FnOnce() -> T) -> T {
    let before = set_log_level(LogLevel::LOG_LEVEL_SILENT);
    let out = f();
    if let Ok(level) = before {
        let _ = set_log_level(level);
    }
    out
}

/// Opens a video file quietly: through OpenCV's FFmpeg backend alone when
/// OpenCV has it, else through whichever backend takes it. On a file FFmpeg
/// refuses, the others had been tried in turn and printed their own errors
/// past any log level (the built-in AVI reader's "Unexpected element").
pub fn open_video(path: &Path) -> opencv::Result<VideoCapture> {
    quietly(|| {
        let backend = if has_backend(VideoCaptureAPIs::CAP_FFMPEG).unwrap_or(false) {
            CAP_FFMPEG
        } else {
            CAP_ANY
        };
        VideoCapture::from_file(&path.to_string_lossy(), backend)
    })
}

/// Asks OpenCV to keep FFmpeg's own log quiet for this process, unless the
/// user set the level or FFmpeg debugging: FFmpeg's lines are not OpenCV's
/// log, and this setting is OpenCV's only control of them. It changes the
/// environment, so it is for the start of `main`, before any thread.
pub fn quiet_ffmpeg_for_this_process() {
    if [FFMPEG_LOG_LEVEL, FFMPEG_DEBUG]
        .iter()
        .all(|v| std::env::var_os(v).is_none())
    {
        // SAFETY: called first in `main`, while the process has one thread,
        // so nothing reads the environment meanwhile.
        unsafe { std::env::set_var(FFMPEG_LOG_LEVEL, AV_LOG_QUIET) };
    }
}
