//! A recording's frames, read one at a time and checked as they come: each
//! the size of the first, and as many as the stage log has entries. What
//! can be checked before the first frame is ([`super::recording::open_recording`]:
//! a folder's sizes, a count that is exact); a video's container only
//! estimates its length, so its count is checked here, as it ends.

use super::recording::{Recording, RecordingError};
use crate::vision::frame::not_one_size;
use crate::vision::frame_stream::{FrameStream, NamedFrame};

/// The frames of a [`Recording`], in order ([`Recording::frames`]).
pub struct RecordingFrames<'r> {
    recording: &'r Recording,
    stream: FrameStream,
    first: Option<(String, (usize, usize))>,
    read: usize,
    done: bool,
}

impl<'r> RecordingFrames<'r> {
    pub(super) fn new(recording: &'r Recording, stream: FrameStream) -> Self {
        Self {
            recording,
            stream,
            first: None,
            read: 0,
            done: false,
        }
    }

    /// How many frames the recording holds, when its source says exactly
    /// (a folder, a stack; not a video's container).
    pub fn exact_len(&self) -> Option<usize> {
        self.stream.exact_len()
    }

    fn mismatch(&self, message: String) -> RecordingError {
        RecordingError::Mismatch {
            path: self.recording.frames_path.clone(),
            message,
        }
    }

    /// The next frame, or why the recording cannot go on; `None` after its
    /// last frame.
    fn checked_next(&mut self) -> Option<Result<NamedFrame, RecordingError>> {
        let entries = self.recording.stage_log.as_ref().map(Vec::len);
        let named = match self.stream.next() {
            None if self.read == 0 => {
                return Some(Err(self.mismatch("it holds no frames".into())));
            }
            None => {
                return entries
                    .filter(|&n| n != self.read)
                    .map(|n| Err(self.mismatch(entries_for_frames(n, &self.read.to_string()))));
            }
            Some(Err(e)) => {
                return Some(Err(RecordingError::Format {
                    path: self.recording.frames_path.clone(),
                    message: e.to_string(),
                }));
            }
            Some(Ok(named)) => named,
        };
        if let Some(n) = entries.filter(|&n| self.read >= n) {
            return Some(Err(
                self.mismatch(entries_for_frames(n, &format!("more than {n}")))
            ));
        }
        let size = (named.frame.width(), named.frame.height());
        match &self.first {
            None => self.first = Some((named.name.clone(), size)),
            Some((first_name, first_size)) if *first_size != size => {
                return Some(Err(self.mismatch(not_one_size(
                    &named.name,
                    size,
                    first_name,
                    *first_size,
                ))));
            }
            Some(_) => {}
        }
        self.read += 1;
        Some(Ok(named))
    }
}

/// What a stage log of `entries` lines said of `frames` frames.
pub(super) fn entries_for_frames(entries: usize, frames: &str) -> String {
    let noun = if frames == "1" { "frame" } else { "frames" };
    format!("{entries} stage-log entries for {frames} {noun}")
}

impl Iterator for RecordingFrames<'_> {
    type Item = Result<NamedFrame, RecordingError>;

    /// Stops after the first error: a frame that cannot be read or checked
    /// ends the recording.
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let item = self.checked_next();
        self.done = !matches!(item, Some(Ok(_)));
        item
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::camera_map::CameraCalibration;
    use crate::exec::recording::{STAGE_LOG_SCHEMA, open_recording};
    use crate::vision::frame::Frame;
    use crate::vision::frame_input::save_png;
    use std::path::Path;

    /// A recording in `dir` of `frames` (a path in it), with a stage log of
    /// `entries` lines when given.
    fn describe(dir: &Path, frames: &str, entries: Option<usize>) {
        let cal = CameraCalibration::from_scale_rotation(0.25e-6, 0.0, [0.0, 0.0]);
        std::fs::write(dir.join("calibration.toml"), cal.to_toml(None)).unwrap();
        let mut toml = format!(
            "schema = \"nanopush.recording/1\"\nsource = \"unit test\"\nframes = \"{frames}\"\n\
             calibration = \"calibration.toml\"\nparticle_radius_um = 1.0\nsites_um = [[1.0, 1.0]]\n"
        );
        if let Some(n) = entries {
            toml.push_str("stage_log = \"stage.jsonl\"\n");
            let mut log = format!("{{\"schema\":\"{STAGE_LOG_SCHEMA}\"}}\n");
            for i in 0..n {
                log.push_str(&format!(
                    "{{\"frame\":{i},\"t_s\":{i}.0,\"coarse_offset_um\":[0.0,0.0],\"stage_um\":null}}\n"
                ));
            }
            std::fs::write(dir.join("stage.jsonl"), log).unwrap();
        }
        std::fs::write(dir.join("recording.toml"), toml).unwrap();
    }

    fn grey(w: usize, h: usize, v: f32) -> Frame {
        Frame::new(w, h, vec![v; w * h], 8).unwrap()
    }

    /// The frames read before the first error, and the error's text.
    fn replay(dir: &Path) -> (usize, Option<String>) {
        let recording = open_recording(dir).unwrap();
        let mut read = 0;
        for frame in recording.frames().unwrap() {
            match frame {
                Ok(_) => read += 1,
                Err(e) => return (read, Some(e.to_string())),
            }
        }
        (read, None)
    }

    /// A video's container may only estimate its length, so the stage log
    /// is held against the frames as they come: one frame too many stops
    /// the replay at it, a video that ends early stops it at its end.
    #[test]
    fn a_videos_length_is_checked_against_the_stage_log_as_it_goes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.avi");
        crate::render::video::flat_grey_video(&path, 10.0, (16, 12), &[0, 60, 120]);
        for (entries, want) in [
            (3, (3, None)),
            (2, (2, Some("2 stage-log entries for more than 2 frames"))),
            (4, (3, Some("4 stage-log entries for 3 frames"))),
        ] {
            describe(dir.path(), "v.avi", Some(entries));
            let (read, error) = replay(dir.path());
            assert_eq!(read, want.0, "{entries} entries");
            match (error, want.1) {
                (None, None) => {}
                (Some(e), Some(needle)) => assert!(e.contains(needle), "{e}"),
                (e, needle) => panic!("{entries} entries: {e:?}, expected {needle:?}"),
            }
        }
    }

    /// A folder's frame of another size is refused on opening, from the
    /// files' headers; a stack's, when its page is read.
    #[test]
    fn a_frame_of_another_size_is_named() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("frames")).unwrap();
        save_png(&grey(16, 12, 10.0), &dir.path().join("frames/f_0.png")).unwrap();
        save_png(&grey(16, 10, 10.0), &dir.path().join("frames/f_1.png")).unwrap();
        describe(dir.path(), "frames", None);
        let e = open_recording(dir.path()).unwrap_err();
        assert!(
            matches!(e, RecordingError::Mismatch { .. })
                && e.to_string()
                    .contains("f_1.png is 16x10 px but f_0.png is 16x12 px"),
            "{e}"
        );
        let stack = dir.path().join("s.tif");
        let mut encoder =
            tiff::encoder::TiffEncoder::new(std::fs::File::create(&stack).unwrap()).unwrap();
        for h in [12u32, 12, 10] {
            let page = vec![10u8; 16 * h as usize];
            encoder
                .write_image::<tiff::encoder::colortype::Gray8>(16, h, &page)
                .unwrap();
        }
        drop(encoder);
        describe(dir.path(), "s.tif", Some(3));
        let (read, error) = replay(dir.path());
        assert_eq!(read, 2);
        let e = error.unwrap();
        assert!(
            e.contains("s.tif #2 is 16x10 px but s.tif #0 is 16x12 px"),
            "{e}"
        );
    }
}
