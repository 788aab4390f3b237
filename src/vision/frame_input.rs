//! Reading frames from files: single images (PNG, TIFF, BMP, JPEG; 8/16-bit,
//! grey or colour; TIFFs also 32-bit float or integer and signed 16-bit),
//! multi-page TIFF stacks, image-sequence folders and video.
//!
//! Single images go through the pure-Rust `image` crate (clear errors on
//! truncated files); multi-page TIFF stacks and video go through OpenCV
//! (imgcodecs `imreadmulti`, videoio `VideoCapture`); TIFF sample types
//! neither decodes (32-bit float or integer grey for `image`, unsigned
//! 32-bit and half floats for OpenCV) go through the `tiff` crate
//! (`tiff_fallback`). Samples other than 8/16-bit counts are mapped onto
//! 16-bit counts (`wide_samples`).

use std::path::{Path, PathBuf};

use image::{DynamicImage, ImageReader};
use opencv::core::{Mat, MatTraitConst, MatTraitConstManual};
use thiserror::Error;

use super::camera_bits::at_camera_bits;
use super::frame::{Frame, FrameError};
use super::frame_stream::FrameStream;
use super::tiff_fallback;
use super::wide_samples::frame_from_wide;

/// Which part of a colour frame becomes the grey frame (in files, by its
/// name: `"luminance"`, `"red"`, `"green"`, `"blue"`, or the short names
/// the command line takes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum Channel {
    /// Rec. 601 luminance (0.299 R + 0.587 G + 0.114 B).
    #[default]
    Luminance,
    /// Red channel only.
    Red,
    /// Green channel only (often the sharpest on a Bayer camera).
    Green,
    /// Blue channel only.
    Blue,
}

impl std::str::FromStr for Channel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "luminance" | "lum" | "grey" | "gray" => Ok(Self::Luminance),
            "red" | "r" => Ok(Self::Red),
            "green" | "g" => Ok(Self::Green),
            "blue" | "b" => Ok(Self::Blue),
            other => Err(format!(
                "unknown channel {other:?}; use luminance, red, green or blue"
            )),
        }
    }
}

impl TryFrom<String> for Channel {
    type Error = String;
    fn try_from(name: String) -> Result<Self, Self::Error> {
        name.parse()
    }
}

impl From<Channel> for String {
    fn from(channel: Channel) -> Self {
        channel.to_string()
    }
}

impl std::fmt::Display for Channel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Luminance => "luminance",
            Self::Red => "red",
            Self::Green => "green",
            Self::Blue => "blue",
        })
    }
}

/// Ways reading a frame can fail.
#[derive(Debug, Error)]
pub enum FrameInputError {
    /// The file could not be opened or read.
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The file is not an image nanopush reads, or it is corrupt/truncated.
    #[error("cannot decode {path}: {reason}")]
    Decode { path: PathBuf, reason: String },
    /// The decoded image is not a valid frame (e.g. zero size).
    #[error("{path}: {source}")]
    Invalid { path: PathBuf, source: FrameError },
    /// A stack, sequence or video held no frames.
    #[error("{path} holds no frames{}", why_empty(path))]
    Empty { path: PathBuf },
}

const VIDEO_EXTENSIONS: [&str; 5] = ["avi", "mp4", "mov", "mkv", "m4v"];
const IMAGE_EXTENSIONS: [&str; 7] = ["png", "tif", "tiff", "bmp", "jpg", "jpeg", "pgm"];

/// What an empty video may be: a cut-short MP4 lacks the index at its end
/// and reads as nothing at all.
fn why_empty(path: &Path) -> &'static str {
    if is_video(path) {
        " (a video cut short, or still being written, may read as none)"
    } else {
        ""
    }
}

/// True for a file name ending as a video does (`.avi`, `.mp4`, ...).
pub(super) fn is_video(path: &Path) -> bool {
    VIDEO_EXTENSIONS.contains(&extension(path).as_str())
}

/// The last part of `path` as text ("" when it has none): what a frame
/// from that file is called.
pub fn file_name_text(path: &Path) -> String {
    path.file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
}

/// True for a file name ending in `.tif` or `.tiff` (a stack, maybe).
pub(super) fn is_tiff(path: &Path) -> bool {
    matches!(extension(path).as_str(), "tif" | "tiff")
}

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Which of several frames [`load_frame`] reads from `path`, when it holds
/// several (a folder, a video, a TIFF stack), for a command to say so (a
/// stack's first page had been taken without a word).
pub fn first_of_several(path: &Path) -> Option<String> {
    if path.is_dir() {
        let files = image_files(path).ok()?;
        let name = files.first()?.file_name()?.to_string_lossy().into_owned();
        Some(format!("its first image of {}, {name}", files.len()))
    } else if is_video(path) {
        Some("its first frame (a video)".into())
    } else if is_tiff(path) {
        let pages = FrameStream::open(path, Channel::Luminance)
            .ok()?
            .stated_len()?;
        (pages > 1).then(|| format!("its first page of {pages} (a TIFF stack)"))
    } else {
        None
    }
}

/// Reads one frame: the only (or first) image of the file.
pub fn load_frame(path: &Path, channel: Channel) -> Result<Frame, FrameInputError> {
    if !(path.is_dir() || is_video(path)) {
        let bytes = std::fs::read(path).map_err(|source| FrameInputError::Io {
            path: path.to_owned(),
            source,
        })?;
        return decode_image(&bytes, path, channel);
    }
    // Only the first is read: a long video or a big folder read whole
    // took the memory of every frame for one.
    let first = FrameStream::open(path, channel)?.next().transpose()?;
    first
        .map(|named| named.frame)
        .ok_or_else(|| FrameInputError::Empty {
            path: path.to_owned(),
        })
}

/// The images of a folder, sorted by name, numbers by value (`img_2`
/// before `img_10`, [`crate::natural_order`]): the frames [`load_frames`]
/// reads from it, in its order (so an error can name a frame's file).
/// Hidden files are not frames: a frame being written (this program writes
/// one under a dot name first), or the `._` files macOS leaves on a copy.
pub fn image_files(dir: &Path) -> Result<Vec<PathBuf>, FrameInputError> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| FrameInputError::Io {
            path: dir.to_owned(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| IMAGE_EXTENSIONS.contains(&extension(p).as_str()))
        .filter(|p| {
            !p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'))
        })
        .collect();
    files.sort_by(|a, b| crate::natural_order::natural_cmp(a, b));
    Ok(files)
}

/// Reads every frame: all pages of a TIFF stack, all images of a folder (sorted
/// by name), all frames of a video, or the single image of any other file.
/// A long recording is better read a frame at a time ([`FrameStream`]).
pub fn load_frames(path: &Path, channel: Channel) -> Result<Vec<Frame>, FrameInputError> {
    let frames = FrameStream::open(path, channel)?
        .map(|named| named.map(|n| n.frame))
        .collect::<Result<Vec<_>, _>>()?;
    if frames.is_empty() {
        return Err(FrameInputError::Empty {
            path: path.to_owned(),
        });
    }
    Ok(frames)
}

pub(super) fn decode_error(path: &Path, reason: String) -> FrameInputError {
    FrameInputError::Decode {
        path: path.to_owned(),
        reason,
    }
}

/// Decodes an in-memory image file (format guessed from its content).
pub fn decode_image(bytes: &[u8], path: &Path, channel: Channel) -> Result<Frame, FrameInputError> {
    let reader = ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| decode_error(path, e.to_string()))?;
    if reader.format().is_none() {
        return Err(decode_error(
            path,
            "unsupported or unknown image format".into(),
        ));
    }
    let format = reader.format();
    let img = match reader.decode() {
        Ok(img) => img,
        Err(image::ImageError::Unsupported(_)) if format == Some(image::ImageFormat::Tiff) => {
            return first_page_of_wide_tiff(bytes, path, channel);
        }
        Err(e) => return Err(decode_error(path, e.to_string())),
    };
    image_to_frame(&img, channel).map_err(|source| FrameInputError::Invalid {
        path: path.to_owned(),
        source,
    })
}

/// The first page of a TIFF the `image` crate does not take (32-bit float or
/// integer grey, signed or half-float samples), read by [`tiff_fallback`].
fn first_page_of_wide_tiff(
    bytes: &[u8],
    path: &Path,
    channel: Channel,
) -> Result<Frame, FrameInputError> {
    tiff_fallback::decode_pages(bytes, channel, true)
        .map_err(|reason| decode_error(path, reason))?
        .into_iter()
        .next()
        .ok_or_else(|| FrameInputError::Empty {
            path: path.to_owned(),
        })
}

/// One grey value of an RGB sample, as `channel` says.
fn pick(channel: Channel, r: f32, g: f32, b: f32) -> f32 {
    match channel {
        Channel::Luminance => 0.299 * r + 0.587 * g + 0.114 * b,
        Channel::Red => r,
        Channel::Green => g,
        Channel::Blue => b,
    }
}

/// Converts a decoded image to a grey frame, keeping 16-bit depth when
/// present; float colour images are mapped onto 16-bit counts
/// ([`frame_from_wide`]).
pub fn image_to_frame(img: &DynamicImage, channel: Channel) -> Result<Frame, FrameError> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    if matches!(
        img,
        DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_)
    ) {
        let rgb = Interleaved {
            channels: 3,
            bgr: false,
        };
        return grey_frame(w, h, img.to_rgb32f().into_raw(), rgb, channel, None);
    }
    let sixteen = matches!(
        img,
        DynamicImage::ImageLuma16(_)
            | DynamicImage::ImageLumaA16(_)
            | DynamicImage::ImageRgb16(_)
            | DynamicImage::ImageRgba16(_)
    );
    let grey_source = matches!(
        img,
        DynamicImage::ImageLuma8(_)
            | DynamicImage::ImageLumaA8(_)
            | DynamicImage::ImageLuma16(_)
            | DynamicImage::ImageLumaA16(_)
    );
    let pixels: Vec<f32> = if sixteen {
        if grey_source {
            img.to_luma16()
                .into_raw()
                .into_iter()
                .map(f32::from)
                .collect()
        } else {
            img.to_rgb16()
                .pixels()
                .map(|p| pick(channel, p[0] as f32, p[1] as f32, p[2] as f32))
                .collect()
        }
    } else if grey_source {
        img.to_luma8()
            .into_raw()
            .into_iter()
            .map(f32::from)
            .collect()
    } else {
        img.to_rgb8()
            .pixels()
            .map(|p| pick(channel, p[0] as f32, p[1] as f32, p[2] as f32))
            .collect()
    };
    Frame::new(w, h, pixels, if sixteen { 16 } else { 8 }).map(at_camera_bits)
}

/// Converts an OpenCV matrix (1/3/4 channels, BGR order) to a frame: 8U and
/// 16U as counts, signed 8/16-bit, 32-bit integer and float 32/64 mapped
/// onto 16-bit counts.
pub fn mat_to_frame(mat: &Mat, path: &Path, channel: Channel) -> Result<Frame, FrameInputError> {
    let (w, h) = (mat.cols().max(0) as usize, mat.rows().max(0) as usize);
    let nch = mat.channels().max(1) as usize;
    let mat = if mat.is_continuous() {
        mat.clone()
    } else {
        mat.try_clone()
            .map_err(|e| decode_error(path, e.to_string()))?
    };
    let bytes = mat
        .data_bytes()
        .map_err(|e| decode_error(path, e.to_string()))?;
    let depth = mat.depth();
    let wide = WIDE_DEPTHS.contains(&depth);
    let samples: Vec<f32> = if depth == opencv::core::CV_8U {
        bytes.iter().map(|&b| b as f32).collect()
    } else if depth == opencv::core::CV_16U {
        bytes
            .chunks_exact(2)
            .map(|c| u16::from_ne_bytes([c[0], c[1]]) as f32)
            .collect()
    } else if wide {
        let mut floats = Mat::default();
        mat.convert_to(&mut floats, opencv::core::CV_32F, 1.0, 0.0)
            .map_err(|e| decode_error(path, e.to_string()))?;
        floats
            .data_bytes()
            .map_err(|e| decode_error(path, e.to_string()))?
            .chunks_exact(4)
            .map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    } else {
        return Err(decode_error(
            path,
            format!("unsupported pixel depth code {depth}"),
        ));
    };
    let bits = match (wide, depth == opencv::core::CV_16U) {
        (true, _) => None,
        (false, true) => Some(16),
        (false, false) => Some(8),
    };
    let layout = Interleaved {
        channels: nch,
        bgr: true,
    };
    grey_frame(w, h, samples, layout, channel, bits).map_err(|source| FrameInputError::Invalid {
        path: path.to_owned(),
        source,
    })
}

/// How a decoder interleaves a pixel's samples: 1 grey, 2 grey and alpha,
/// 3 or 4 colour (and alpha), blue first when `bgr` (OpenCV's order).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Interleaved {
    pub channels: usize,
    pub bgr: bool,
}

/// The grey frame of row-major interleaved `samples` (`channel` of a colour
/// one): 8/16-bit counts as they are (`bits`), other samples (`bits` None)
/// mapped by [`frame_from_wide`]. Shared by every decoder.
pub(crate) fn grey_frame(
    w: usize,
    h: usize,
    samples: Vec<f32>,
    layout: Interleaved,
    channel: Channel,
    bits: Option<u8>,
) -> Result<Frame, FrameError> {
    let pixels: Vec<f32> = match layout.channels {
        0 | 1 => samples,
        2 => samples.chunks_exact(2).map(|p| p[0]).collect(),
        n => samples
            .chunks_exact(n)
            .map(|p| {
                if layout.bgr {
                    pick(channel, p[2], p[1], p[0])
                } else {
                    pick(channel, p[0], p[1], p[2])
                }
            })
            .collect(),
    };
    match bits {
        Some(bits) => Frame::new(w, h, pixels, bits).map(at_camera_bits),
        None => frame_from_wide(w, h, &pixels),
    }
}

/// OpenCV depths read as wide samples (mapped onto 16-bit counts by
/// [`frame_from_wide`]): signed 8- and 16-bit, 32-bit integer, 32- and
/// 64-bit float.
const WIDE_DEPTHS: [i32; 5] = [
    opencv::core::CV_8S,
    opencv::core::CV_16S,
    opencv::core::CV_32S,
    opencv::core::CV_32F,
    opencv::core::CV_64F,
];

/// `path` with a dot before its file name: where a frame (or a file written
/// with it) goes before it is renamed into place, so a reader of the folder
/// never sees half a file (same folder, so the rename is atomic; same
/// extension, so the image encoder is chosen by it).
pub(crate) fn hidden_sibling(path: &Path) -> PathBuf {
    let name = path.file_name().map_or_else(
        || "frame.png".to_owned(),
        |n| n.to_string_lossy().into_owned(),
    );
    path.with_file_name(format!(".{name}"))
}

/// Writes a frame as a grey PNG of its own bit depth (counts clamped, rounded).
pub fn save_png(frame: &Frame, path: &Path) -> Result<(), image::ImageError> {
    let (w, h) = (frame.width() as u32, frame.height() as u32);
    if frame.bit_depth() > 8 {
        let data: Vec<u16> = frame
            .pixels()
            .iter()
            .map(|&p| p.round().clamp(0.0, 65535.0) as u16)
            .collect();
        let buf = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, data)
            .expect("buffer size matches frame size");
        buf.save(path)
    } else {
        let data: Vec<u8> = frame
            .pixels()
            .iter()
            .map(|&p| p.round().clamp(0.0, 255.0) as u8)
            .collect();
        let buf = image::GrayImage::from_raw(w, h, data).expect("buffer size matches frame size");
        buf.save(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use opencv::core::Vector;

    /// A camera's unpadded frame numbers come back in the order written.
    #[test]
    fn a_folders_images_are_listed_by_their_numbers_hidden_ones_left_out() {
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "img_10.png",
            "img_2.png",
            "img_1.png",
            "notes.txt",
            "img_9.png",
            "._img_9.png",
            ".img_11.png",
        ] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        let names: Vec<String> = image_files(dir.path())
            .unwrap()
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["img_1.png", "img_2.png", "img_9.png", "img_10.png"]);
    }

    /// One frame of a folder is its first image alone: the others are not
    /// read (a broken one after it does not matter, as a long recording's
    /// memory does not), while the whole folder's read names the broken one.
    #[test]
    fn a_folders_first_frame_is_read_alone() {
        let dir = tempfile::tempdir().unwrap();
        let first = Frame::new(4, 3, (0..12).map(|i| i as f32).collect(), 8).unwrap();
        save_png(&first, &dir.path().join("img_1.png")).unwrap();
        std::fs::write(dir.path().join("img_2.png"), b"not a png").unwrap();
        assert_eq!(load_frame(dir.path(), Channel::Luminance).unwrap(), first);
        let whole = load_frames(dir.path(), Channel::Luminance).unwrap_err();
        assert!(whole.to_string().contains("img_2.png"), "{whole}");
        let empty = tempfile::tempdir().unwrap();
        let err = load_frame(empty.path(), Channel::Luminance).unwrap_err();
        assert!(matches!(err, FrameInputError::Empty { .. }), "{err}");
    }

    #[test]
    fn png_round_trip_keeps_8_and_16_bit_counts() {
        let dir = tempfile::tempdir().unwrap();
        for (bits, max) in [(8u8, 255.0f32), (16, 65535.0)] {
            let px: Vec<f32> = (0..12 * 7).map(|i| ((i * 977) as f32) % max).collect();
            let f = Frame::new(12, 7, px, bits).unwrap();
            let p = dir.path().join(format!("f{bits}.png"));
            save_png(&f, &p).unwrap();
            assert_eq!(load_frame(&p, Channel::Luminance).unwrap(), f);
            // Same image as a one-frame sequence folder.
            assert_eq!(
                load_frames(dir.path(), Channel::Luminance).unwrap().len(),
                if bits == 8 { 1 } else { 2 }
            );
        }
    }

    #[test]
    fn colour_channels_are_selectable() {
        let img = image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(
            2,
            2,
            image::Rgb([10, 200, 30]),
        ));
        assert_eq!(
            image_to_frame(&img, Channel::Green).unwrap().at(0, 0),
            200.0
        );
        assert_eq!(image_to_frame(&img, Channel::Red).unwrap().at(1, 1), 10.0);
        let lum = image_to_frame(&img, Channel::Luminance).unwrap().at(0, 0);
        assert!((lum - (0.299 * 10.0 + 0.587 * 200.0 + 0.114 * 30.0)).abs() < 1e-3);
        assert_eq!("green".parse::<Channel>(), Ok(Channel::Green));
        assert!("purple".parse::<Channel>().is_err());
    }

    /// In a file a channel is its name; it reads back, takes the command
    /// line's short names, and an unknown one says which there are.
    #[test]
    fn a_channel_in_a_file_is_its_name_and_reads_back() {
        #[derive(serde::Serialize, serde::Deserialize)]
        struct Section {
            channel: Channel,
        }
        for channel in [
            Channel::Luminance,
            Channel::Red,
            Channel::Green,
            Channel::Blue,
        ] {
            let text = toml::to_string(&Section { channel }).unwrap();
            assert_eq!(text.trim(), format!("channel = \"{channel}\""));
            assert_eq!(toml::from_str::<Section>(&text).unwrap().channel, channel);
        }
        let short: Section = toml::from_str("channel = \"G\"").unwrap();
        assert_eq!(short.channel, Channel::Green);
        let err = toml::from_str::<Section>("channel = \"purple\"")
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("use luminance, red, green or blue"), "{err}");
    }

    use opencv::prelude::MatTrait;

    /// A one-channel OpenCV matrix of `depth` holding `samples` (row-major).
    fn mat_of(w: usize, h: usize, depth: i32, samples: &[f64]) -> Mat {
        let mut mat = Mat::new_rows_cols_with_default(
            h as i32,
            w as i32,
            opencv::core::CV_MAKETYPE(depth, 1),
            opencv::core::Scalar::all(0.0),
        )
        .unwrap();
        for (i, &v) in samples.iter().enumerate() {
            let (x, y) = ((i % w) as i32, (i / w) as i32);
            if depth == opencv::core::CV_32F {
                *mat.at_2d_mut::<f32>(y, x).unwrap() = v as f32;
            } else {
                *mat.at_2d_mut::<i16>(y, x).unwrap() = v as i16;
            }
        }
        mat
    }

    fn as_f32(samples: &[f64]) -> Vec<f32> {
        samples.iter().map(|&v| v as f32).collect()
    }

    #[test]
    fn float_and_signed_tiffs_read_as_their_samples_mapped_onto_counts() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (5, 3);
        let float: Vec<f64> = (0..w * h).map(|i| (i as f64 * 0.37).sin() * 0.01).collect();
        let signed: Vec<f64> = (0..w * h)
            .map(|i| (i as f64 * 997.0) % 600.0 - 300.0)
            .collect();
        for (depth, samples) in [
            (opencv::core::CV_32F, &float),
            (opencv::core::CV_16S, &signed),
        ] {
            let path = dir.path().join(format!("wide_{depth}.tif"));
            let params = Vector::<i32>::new();
            assert!(
                opencv::imgcodecs::imwrite(
                    &path.to_string_lossy(),
                    &mat_of(w, h, depth, samples),
                    &params
                )
                .unwrap()
            );
            let want = frame_from_wide(w, h, &as_f32(samples)).unwrap();
            assert_eq!(load_frame(&path, Channel::Luminance).unwrap(), want);
            assert_eq!(load_frames(&path, Channel::Luminance).unwrap(), vec![want]);
        }
    }

    #[test]
    fn a_float_tiff_stack_reads_page_by_page() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("stack.tif");
        let pages: Vec<Vec<f64>> = (0..3)
            .map(|k| {
                (0..12)
                    .map(|i| (i * (k + 2)) as f64 * 1e-3 - 0.004)
                    .collect()
            })
            .collect();
        let mats: Vector<Mat> = pages
            .iter()
            .map(|p| mat_of(4, 3, opencv::core::CV_32F, p))
            .collect();
        let params = Vector::<i32>::new();
        assert!(opencv::imgcodecs::imwritemulti(&path.to_string_lossy(), &mats, &params).unwrap());
        let want: Vec<Frame> = pages
            .iter()
            .map(|p| frame_from_wide(4, 3, &as_f32(p)).unwrap())
            .collect();
        assert_eq!(load_frames(&path, Channel::Luminance).unwrap(), want);
    }

    #[test]
    fn unsigned_32_bit_tiffs_opencv_cannot_read_come_through_the_tiff_crate() {
        let dir = tempfile::tempdir().unwrap();
        let pages: Vec<Vec<u32>> = (0..2u32)
            .map(|k| {
                (0..12u32)
                    .map(|i| 4_000_000_000 - i * 1_000 * (k + 1))
                    .collect()
            })
            .collect();
        let path = dir.path().join("u32.tif");
        let mut encoder =
            tiff::encoder::TiffEncoder::new(std::fs::File::create(&path).unwrap()).unwrap();
        for page in &pages {
            encoder
                .write_image::<tiff::encoder::colortype::Gray32>(4, 3, page)
                .unwrap();
        }
        drop(encoder);
        let want: Vec<Frame> = pages
            .iter()
            .map(|p| {
                let samples: Vec<f32> = p.iter().map(|&v| v as f32).collect();
                frame_from_wide(4, 3, &samples).unwrap()
            })
            .collect();
        assert_eq!(load_frames(&path, Channel::Luminance).unwrap(), want);
        assert_eq!(load_frame(&path, Channel::Luminance).unwrap(), want[0]);
    }

    #[test]
    fn a_float_colour_tiff_reads_the_chosen_channel_mapped_onto_counts() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("colour.tif");
        let img = image::Rgb32FImage::from_fn(3, 2, |x, y| {
            image::Rgb([x as f32, 0.5 * y as f32, -(x as f32) - y as f32])
        });
        image::DynamicImage::ImageRgb32F(img.clone())
            .save(&path)
            .unwrap();
        let green: Vec<f32> = img.pixels().map(|p| p[1]).collect();
        assert_eq!(
            load_frame(&path, Channel::Green).unwrap(),
            frame_from_wide(3, 2, &green).unwrap()
        );
    }
}
