//! Frames read one at a time, in order, from a folder of images, a video, a
//! TIFF stack or a single image: a long recording is replayed holding one
//! frame, not all of them (1,500 frames of 1024x1024 px read whole had
//! taken 6.26 GB, and the first result came only once the last frame was
//! read).

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use opencv::core::{Mat, MatTraitConst, Vector};
use opencv::prelude::{VideoCaptureTrait, VideoCaptureTraitConst};
use opencv::videoio::VideoCapture;

use super::frame::Frame;
use super::frame_input::{
    Channel, FrameInputError, decode_error, file_name_text, image_files, is_tiff, is_video,
    load_frame, mat_to_frame,
};
use super::opencv_quiet::{open_video, quietly};
use super::tiff_fallback;
use super::tiff_stated_interval::stated_interval_s;
use super::tiff_stated_pages;

/// TIFF pages decoded per read: OpenCV walks a stack from its first page on
/// every read, so one page a read costs the square of the pages.
const TIFF_PAGES_PER_READ: usize = 16;

/// One frame and what it is called where it came from, for a user to find
/// it: a folder's file name, else the file's name with the frame's (or
/// page's) number when the file holds several.
#[derive(Debug, Clone)]
pub struct NamedFrame {
    pub frame: Frame,
    pub name: String,
}

/// The frames of a path, read as they are asked for.
pub struct FrameStream {
    path: PathBuf,
    name: String,
    channel: Channel,
    source: Source,
    read: usize,
    /// Seconds between a TIFF stack's frames, as its description states.
    tiff_interval_s: Option<f64>,
}

/// Seconds between frames as the frames themselves state them, and what
/// states it (for a user to see where the frames' times come from).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatedInterval {
    /// Seconds from one frame to the next.
    pub seconds: f64,
    /// What said so: "the video's frame rate", "the stack's ImageJ description".
    pub from: &'static str,
}

enum Source {
    /// A folder's images, in [`image_files`]' order.
    Files(Vec<PathBuf>),
    /// A video file; `said` is the frame count its container states.
    Video {
        capture: VideoCapture,
        said: Option<usize>,
        ended: bool,
    },
    /// A TIFF stack OpenCV reads, `pages` long, a few pages at a time.
    TiffPages {
        pages: usize,
        decoded: VecDeque<Frame>,
    },
    /// Frames decoded at once: a single image, or a stack of a sample type
    /// only the `tiff` crate reads (it decodes a file whole).
    Held {
        frames: VecDeque<Frame>,
        count: usize,
    },
}

impl FrameStream {
    /// Opens `path`: lists a folder, opens a video, counts a stack's pages,
    /// or reads a single image. No frame of a folder, video or stack is
    /// decoded yet.
    pub fn open(path: &Path, channel: Channel) -> Result<Self, FrameInputError> {
        let source = if path.is_dir() {
            Source::Files(image_files(path)?)
        } else if !path.is_file() {
            return Err(FrameInputError::Io {
                path: path.to_owned(),
                source: std::io::Error::from(std::io::ErrorKind::NotFound),
            });
        } else if is_video(path) {
            let capture = open_video(path).map_err(|e| decode_error(path, e.to_string()))?;
            let said = quietly(|| capture.get(opencv::videoio::CAP_PROP_FRAME_COUNT))
                .ok()
                .filter(|n| n.is_finite() && *n >= 1.0)
                .map(|n| n.round() as usize);
            Source::Video {
                capture,
                said,
                ended: false,
            }
        } else if is_tiff(path) {
            tiff_stack(path, channel)?
        } else {
            Source::Held {
                frames: VecDeque::from([load_frame(path, channel)?]),
                count: 1,
            }
        };
        Ok(Self {
            path: path.to_owned(),
            name: file_name_text(path),
            channel,
            source,
            read: 0,
            tiff_interval_s: is_tiff(path).then(|| tiff_interval_s(path)).flatten(),
        })
    }

    /// How many frames the source holds, when it says: exact for a folder,
    /// a stack or an image; a video's container may only estimate it (and a
    /// video cut short holds fewer).
    pub fn stated_len(&self) -> Option<usize> {
        match &self.source {
            Source::Files(files) => Some(files.len()),
            Source::Video { said, .. } => *said,
            Source::TiffPages { pages, .. } => Some(*pages),
            Source::Held { count, .. } => Some(*count),
        }
    }

    /// [`Self::stated_len`] when it is a count, not a container's estimate.
    pub fn exact_len(&self) -> Option<usize> {
        self.len_is_exact().then(|| self.stated_len()).flatten()
    }

    /// True when [`Self::stated_len`] is a count, not a container's estimate.
    pub fn len_is_exact(&self) -> bool {
        !matches!(self.source, Source::Video { .. })
    }

    /// Seconds between frames as the source states them: a video's
    /// container's frame rate, a TIFF stack's ImageJ description; `None`
    /// for other sources or a time that is not positive.
    pub fn stated_interval(&self) -> Option<StatedInterval> {
        if let Some(seconds) = self.tiff_interval_s {
            return Some(StatedInterval {
                seconds,
                from: "the stack's ImageJ description",
            });
        }
        let Source::Video { capture, .. } = &self.source else {
            return None;
        };
        let fps = quietly(|| capture.get(opencv::videoio::CAP_PROP_FPS)).ok()?;
        (fps.is_finite() && fps > 0.0).then_some(StatedInterval {
            seconds: 1.0 / fps,
            from: "the video's frame rate",
        })
    }

    /// The files of a folder source, in the order they are read (empty for
    /// other sources).
    pub fn files(&self) -> &[PathBuf] {
        match &self.source {
            Source::Files(files) => files,
            _ => &[],
        }
    }

    fn next_frame(&mut self) -> Option<Result<(Frame, String), FrameInputError>> {
        let i = self.read;
        let several = format!("{} #{i}", self.name);
        match &mut self.source {
            Source::Files(files) => {
                let file = files.get(i)?;
                Some(load_frame(file, self.channel).map(|f| (f, file_name_text(file))))
            }
            // A video is always named with its frame's number: a one-frame
            // video is still one frame of a video.
            Source::Video {
                capture,
                said,
                ended,
            } => {
                if *ended {
                    return None;
                }
                match next_video_frame(capture, &self.path, self.channel) {
                    Ok(Some(frame)) => Some(Ok((frame, several))),
                    Ok(None) => {
                        *ended = true;
                        // A frame that cannot be decoded also reads as the
                        // end: the next read tells a damaged video from one
                        // cut short.
                        let more = said.is_some_and(|n| i + 1 < n)
                            && matches!(
                                next_video_frame(capture, &self.path, self.channel),
                                Ok(Some(_))
                            );
                        if more {
                            return Some(Err(decode_error(
                                &self.path,
                                format!(
                                    "frame {i} cannot be decoded, but the frames after it can: \
                                     the video is damaged there"
                                ),
                            )));
                        }
                        warn_if_cut_short(&self.path, *said, i);
                        None
                    }
                    Err(e) => Some(Err(e)),
                }
            }
            Source::TiffPages { pages, decoded } => {
                if i >= *pages {
                    return None;
                }
                if decoded.is_empty()
                    && let Err(e) = read_pages(&self.path, i, *pages, self.channel, decoded)
                {
                    return Some(Err(e));
                }
                let name = if *pages > 1 {
                    several
                } else {
                    self.name.clone()
                };
                decoded.pop_front().map(|f| Ok((f, name)))
            }
            Source::Held { frames, count } => {
                let name = if *count > 1 {
                    several
                } else {
                    self.name.clone()
                };
                frames.pop_front().map(|f| Ok((f, name)))
            }
        }
    }
}

impl Iterator for FrameStream {
    type Item = Result<NamedFrame, FrameInputError>;

    fn next(&mut self) -> Option<Self::Item> {
        let (frame, name) = match self.next_frame()? {
            Ok(named) => named,
            Err(e) => return Some(Err(e)),
        };
        self.read += 1;
        Some(Ok(NamedFrame { frame, name }))
    }
}

const ANY_DEPTH_OR_COLOUR: i32 =
    opencv::imgcodecs::IMREAD_ANYDEPTH | opencv::imgcodecs::IMREAD_ANYCOLOR;

/// A stack OpenCV reads is counted here and read as it goes; one of a
/// sample type it has not (unsigned 32-bit, half floats) is decoded whole.
fn tiff_stack(path: &Path, channel: Channel) -> Result<Source, FrameInputError> {
    let pages = if tiff_fallback::opencv_lacks_format(path) {
        0
    } else {
        quietly(|| opencv::imgcodecs::imcount(&path.to_string_lossy(), ANY_DEPTH_OR_COLOUR))
            .unwrap_or(0)
    };
    if pages > 0 {
        warn_if_stack_cut_short(path, pages);
        return Ok(Source::TiffPages {
            pages,
            decoded: VecDeque::new(),
        });
    }
    let bytes = std::fs::read(path).map_err(|source| FrameInputError::Io {
        path: path.to_owned(),
        source,
    })?;
    let frames = tiff_fallback::decode_pages(&bytes, channel, false)
        .map_err(|reason| decode_error(path, format!("cannot read the TIFF stack: {reason}")))?;
    warn_if_stack_cut_short(path, frames.len());
    Ok(Source::Held {
        count: frames.len(),
        frames: frames.into(),
    })
}

/// The interval `path`'s description states; one it states that is not a
/// time is warned of and not used.
fn tiff_interval_s(path: &Path) -> Option<f64> {
    stated_interval_s(path)
        .inspect_err(|said| {
            tracing::warn!(
                "{}: the stack's ImageJ description states {said}: not used",
                path.display()
            );
        })
        .ok()
        .flatten()
}

/// Says so when the stack's own description counts more frames than it
/// holds ([`tiff_stated_pages::cut_short`]): cut short, it had read as its
/// first page alone, without a word.
fn warn_if_stack_cut_short(path: &Path, read: usize) {
    if let Some(said) = tiff_stated_pages::cut_short(path, read) {
        tracing::warn!("{said}");
    }
}

/// Decodes pages `start..` (up to [`TIFF_PAGES_PER_READ`] of the `pages`) into `decoded`.
fn read_pages(
    path: &Path,
    start: usize,
    pages: usize,
    channel: Channel,
    decoded: &mut VecDeque<Frame>,
) -> Result<(), FrameInputError> {
    let count = TIFF_PAGES_PER_READ.min(pages - start);
    let mut mats = Vector::<Mat>::new();
    let read = quietly(|| {
        opencv::imgcodecs::imreadmulti_range(
            &path.to_string_lossy(),
            &mut mats,
            start as i32,
            count as i32,
            ANY_DEPTH_OR_COLOUR,
        )
    })
    .is_ok_and(|ok| ok);
    if !read || mats.is_empty() {
        return Err(decode_error(
            path,
            format!("cannot read page {start} of the TIFF stack's {pages}"),
        ));
    }
    for mat in mats.iter() {
        decoded.push_back(mat_to_frame(&mat, path, channel)?);
    }
    Ok(())
}

/// The next frame of a video, `None` at its end.
fn next_video_frame(
    capture: &mut VideoCapture,
    path: &Path,
    channel: Channel,
) -> Result<Option<Frame>, FrameInputError> {
    let mut mat = Mat::default();
    let read = quietly(|| capture.read(&mut mat)).map_err(|e| decode_error(path, e.to_string()))?;
    if !read || mat.empty() {
        return Ok(None);
    }
    mat_to_frame(&mat, path, channel).map(Some)
}

/// A video cut short (a copy stopped midway, a recorder that crashed) reads
/// as its first frames and nothing else: say how many are missing.
fn warn_if_cut_short(path: &Path, said: Option<usize>, read: usize) {
    if let Some(said) = said
        && said > read
    {
        tracing::warn!(
            "{}: the video says it has {}, but only the first {read} could be read (is the file cut short?)",
            path.display(),
            crate::wording::counted(said, "frame"),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::video::flat_grey_video;
    use crate::vision::frame_input::save_png;

    fn frame(w: usize, h: usize, k: usize, bits: u8) -> Frame {
        let px = (0..w * h)
            .map(|i| ((i * 7 + k * 131) % 250) as f32)
            .collect();
        Frame::new(w, h, px, bits).unwrap()
    }

    fn read_all(path: &Path) -> Vec<NamedFrame> {
        FrameStream::open(path, Channel::Luminance)
            .unwrap()
            .collect::<Result<Vec<_>, _>>()
            .unwrap()
    }

    fn names(frames: &[NamedFrame]) -> Vec<String> {
        frames.iter().map(|n| n.name.clone()).collect()
    }

    /// Frames are named as a user finds them: a folder's files in their
    /// order (numbers by value), a stack's numbered pages, a one-page
    /// stack's or an image's own name.
    #[test]
    fn a_folders_and_a_stacks_frames_come_in_order_named() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().join("seq");
        std::fs::create_dir(&folder).unwrap();
        for (k, name) in ["b_10.png", "b_2.png"].iter().enumerate() {
            save_png(&frame(6, 4, k, 8), &folder.join(name)).unwrap();
        }
        std::fs::write(folder.join("notes.txt"), b"").unwrap();
        let stream = FrameStream::open(&folder, Channel::Luminance).unwrap();
        assert_eq!(
            (stream.stated_len(), stream.len_is_exact()),
            (Some(2), true)
        );
        assert_eq!(stream.stated_interval(), None);
        let read = read_all(&folder);
        assert_eq!(names(&read), ["b_2.png", "b_10.png"]);
        assert_eq!(read[0].frame, frame(6, 4, 1, 8));
        for (pages, want) in [(2, vec!["s2.tif #0", "s2.tif #1"]), (1, vec!["s1.tif"])] {
            let path = dir.path().join(format!("s{pages}.tif"));
            write_stack(
                &path,
                &(0..pages).map(|k| frame(6, 4, k, 16)).collect::<Vec<_>>(),
            );
            assert_eq!(names(&read_all(&path)), want);
        }
        let single = folder.join("b_2.png");
        assert_eq!(names(&read_all(&single)), ["b_2.png"]);
    }

    fn write_stack(path: &Path, frames: &[Frame]) {
        let mut encoder =
            tiff::encoder::TiffEncoder::new(std::fs::File::create(path).unwrap()).unwrap();
        for f in frames {
            let samples: Vec<u16> = f.pixels().iter().map(|&p| p as u16).collect();
            encoder
                .write_image::<tiff::encoder::colortype::Gray16>(
                    f.width() as u32,
                    f.height() as u32,
                    &samples,
                )
                .unwrap();
        }
    }

    /// A stack longer than one read comes whole and in order across the
    /// reads (pages 15/16 and 31/32 lie on their seams).
    #[test]
    fn a_long_stack_reads_every_page_in_order_a_few_at_a_time() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("long.tif");
        let pages: Vec<Frame> = (0..2 * TIFF_PAGES_PER_READ + 3)
            .map(|k| frame(5, 3, k, 16))
            .collect();
        write_stack(&path, &pages);
        let stream = FrameStream::open(&path, Channel::Luminance).unwrap();
        assert_eq!(stream.stated_len(), Some(pages.len()));
        let read: Vec<Frame> = read_all(&path).into_iter().map(|n| n.frame).collect();
        assert_eq!(read, pages);
    }

    /// A video's frames are numbered, even when there is one; its frame
    /// rate and the count its container states are given.
    #[test]
    fn a_videos_frames_are_numbered_with_its_rate_and_count() {
        let dir = tempfile::tempdir().unwrap();
        for n in [1, 3] {
            let path = dir.path().join(format!("v{n}.avi"));
            let levels: Vec<u8> = (0..n).map(|k| 40 * k as u8 + 20).collect();
            flat_grey_video(&path, 20.0, (32, 24), &levels);
            let stream = FrameStream::open(&path, Channel::Luminance).unwrap();
            assert_eq!(
                (stream.stated_len(), stream.len_is_exact()),
                (Some(n), false)
            );
            let dt = stream.stated_interval().unwrap();
            assert!((dt.seconds - 0.05).abs() < 1e-9, "{dt:?}");
            assert_eq!(dt.from, "the video's frame rate");
            let read = read_all(&path);
            let want: Vec<String> = (0..n).map(|i| format!("v{n}.avi #{i}")).collect();
            assert_eq!(names(&read), want);
            let grey: Vec<f32> = read.iter().map(|r| r.frame.at(16, 12)).collect();
            assert!(grey.windows(2).all(|p| p[1] > p[0] + 30.0), "{grey:?}");
        }
    }

    /// A video frame that cannot be decoded is an error naming it, not the
    /// video's end: the frames after it had been dropped with a warning that
    /// the file was cut short.
    #[test]
    fn a_damaged_video_frame_is_an_error_not_the_end() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.avi");
        flat_grey_video(&path, 10.0, (32, 24), &[20, 60, 100, 140, 180]);
        let mut bytes = std::fs::read(&path).unwrap();
        let jpegs: Vec<usize> = (0..bytes.len() - 3)
            .filter(|&i| bytes[i..i + 3] == [0xff, 0xd8, 0xff])
            .collect();
        assert_eq!(jpegs.len(), 5, "one JPEG a frame");
        bytes[jpegs[2]..jpegs[2] + 200].fill(0);
        std::fs::write(&path, bytes).unwrap();
        let mut stream = FrameStream::open(&path, Channel::Luminance).unwrap();
        for _ in 0..2 {
            assert!(stream.next().unwrap().is_ok());
        }
        let err = stream.next().unwrap().unwrap_err().to_string();
        assert!(err.contains("frame 2 cannot be decoded"), "{err}");
        assert!(stream.next().is_none());
    }

    /// A folder's broken frame stops the stream where it lies, named; the
    /// frames before it were given.
    #[test]
    fn a_broken_frame_is_an_error_where_it_lies() {
        let dir = tempfile::tempdir().unwrap();
        save_png(&frame(4, 4, 0, 8), &dir.path().join("f_1.png")).unwrap();
        std::fs::write(dir.path().join("f_2.png"), b"not a png").unwrap();
        let mut stream = FrameStream::open(dir.path(), Channel::Luminance).unwrap();
        assert!(stream.next().unwrap().is_ok());
        let err = stream.next().unwrap().unwrap_err();
        assert!(err.to_string().contains("f_2.png"), "{err}");
        let missing = FrameStream::open(&dir.path().join("none.avi"), Channel::Luminance);
        assert!(matches!(missing, Err(FrameInputError::Io { .. })));
    }
}
