//! Writing an animation as a video file with OpenCV's VideoWriter (already a
//! dependency for reading videos; the `image` crate here is built without its
//! GIF encoder). The codec follows the extension: `.mp4` is MPEG-4 part 2
//! (`mp4v`), `.avi` is Motion-JPEG. Files written here read back with
//! [`crate::vision::frame_input::load_frames`].

use crate::vision::opencv_quiet::quietly;
use image::RgbImage;
use opencv::core::{Mat, Scalar, Size};
use opencv::prelude::*;
use opencv::videoio;
use std::path::{Path, PathBuf};

/// Why a video could not be written.
#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    /// The extension names no codec this writer knows.
    #[error("video {path}: unknown extension (use .mp4 or .avi)")]
    Extension { path: PathBuf },
    /// OpenCV could not open the file for writing with the codec.
    #[error("video {path}: OpenCV could not open it for writing ({reason})")]
    Open { path: PathBuf, reason: String },
    /// A frame of another size than the first.
    #[error("video {path}: frame {frame} is {got:?} px, the video is {want:?} px")]
    Size {
        path: PathBuf,
        frame: usize,
        got: (u32, u32),
        want: (u32, u32),
    },
    /// OpenCV failed while writing.
    #[error("video {path}: {reason}")]
    Write { path: PathBuf, reason: String },
}

/// An open video file taking RGB frames of one size.
pub struct VideoWriter {
    inner: videoio::VideoWriter,
    path: PathBuf,
    size: (u32, u32),
    frames: usize,
}

impl VideoWriter {
    /// Opens `path` for frames of `size` (width, height) at `fps` frames per second.
    pub fn create(path: &Path, fps: f64, size: (u32, u32)) -> Result<Self, VideoError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let code = match ext.as_deref() {
            Some("mp4") => ['m', 'p', '4', 'v'],
            Some("avi") => ['M', 'J', 'P', 'G'],
            _ => {
                return Err(VideoError::Extension {
                    path: path.to_owned(),
                });
            }
        };
        let open = |reason: String| VideoError::Open {
            path: path.to_owned(),
            reason,
        };
        let fourcc = videoio::VideoWriter::fourcc(code[0], code[1], code[2], code[3])
            .map_err(|e| open(e.to_string()))?;
        // OpenCV's and FFmpeg's own lines kept off standard error: the
        // error says which file could not be written.
        let inner = quietly(|| {
            videoio::VideoWriter::new(
                &path.to_string_lossy(),
                fourcc,
                fps.clamp(0.1, 120.0),
                Size::new(size.0 as i32, size.1 as i32),
                true,
            )
        })
        .map_err(|e| open(e.to_string()))?;
        if !inner.is_opened().map_err(|e| open(e.to_string()))? {
            return Err(open("no backend accepted the codec".to_owned()));
        }
        Ok(Self {
            inner,
            path: path.to_owned(),
            size,
            frames: 0,
        })
    }

    /// Appends one frame (must have the video's size).
    pub fn write(&mut self, img: &RgbImage) -> Result<(), VideoError> {
        if img.dimensions() != self.size {
            return Err(VideoError::Size {
                path: self.path.clone(),
                frame: self.frames,
                got: img.dimensions(),
                want: self.size,
            });
        }
        let err = |e: opencv::Error| VideoError::Write {
            path: self.path.clone(),
            reason: e.to_string(),
        };
        let mut mat = Mat::new_rows_cols_with_default(
            self.size.1 as i32,
            self.size.0 as i32,
            opencv::core::CV_8UC3,
            Scalar::all(0.0),
        )
        .map_err(err)?;
        let bytes = mat.data_bytes_mut().map_err(err)?;
        for (dst, src) in bytes.chunks_exact_mut(3).zip(img.pixels()) {
            dst.copy_from_slice(&[src.0[2], src.0[1], src.0[0]]);
        }
        quietly(|| self.inner.write(&mat)).map_err(err)?;
        self.frames += 1;
        Ok(())
    }

    /// Closes the file; returns the number of frames written.
    pub fn finish(mut self) -> Result<usize, VideoError> {
        quietly(|| self.inner.release()).map_err(|e| VideoError::Write {
            path: self.path.clone(),
            reason: e.to_string(),
        })?;
        Ok(self.frames)
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// A video of flat grey frames of `size`, one a level, for tests of what
/// reads videos.
#[cfg(test)]
pub(crate) fn flat_grey_video(path: &Path, fps: f64, size: (u32, u32), levels: &[u8]) {
    let mut video = VideoWriter::create(path, fps, size).unwrap();
    for &level in levels {
        video
            .write(&RgbImage::from_pixel(
                size.0,
                size.1,
                image::Rgb([level; 3]),
            ))
            .unwrap();
    }
    assert_eq!(video.finish().unwrap(), levels.len());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::frame_input::{Channel, load_frames};

    #[test]
    fn a_written_video_reads_back_with_its_frame_count_and_size() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["a.mp4", "a.avi"] {
            let path = dir.path().join(name);
            let mut w = VideoWriter::create(&path, 5.0, (64, 48)).unwrap();
            for k in 0..3u8 {
                let img = RgbImage::from_fn(64, 48, |x, _| image::Rgb([k * 60, (x * 3) as u8, 0]));
                w.write(&img).unwrap();
            }
            assert!(matches!(
                w.write(&RgbImage::new(10, 10)),
                Err(VideoError::Size { frame: 3, .. })
            ));
            assert_eq!(w.finish().unwrap(), 3);
            let back = load_frames(&path, Channel::Luminance).unwrap();
            assert_eq!(back.len(), 3, "{name}");
            assert_eq!((back[0].width(), back[0].height()), (64, 48));
        }
    }

    #[test]
    fn an_unknown_extension_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        assert!(matches!(
            VideoWriter::create(&dir.path().join("a.gif"), 5.0, (8, 8)),
            Err(VideoError::Extension { .. })
        ));
    }
}
