//! TIFF pages that neither the `image` crate nor OpenCV decode: unsigned
//! 32-bit and half-float samples, and 32/64-bit float or integer grey that
//! `image` refuses (OpenCV has no unsigned 32-bit type and no half-float
//! TIFFs). Read with the `tiff` crate, which takes every sample format;
//! samples other than 8/16-bit counts are mapped by
//! [`frame_from_wide`](super::wide_samples::frame_from_wide).

use std::io::{BufReader, Cursor};
use std::path::Path;

use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::{SampleFormat, Tag};

use super::frame::Frame;
use super::frame_input::{Channel, Interleaved, grey_frame};

/// The pages of the TIFF file `bytes` as frames (only the first when
/// `first_only`). Errors are the `tiff` crate's, or name the colour type.
pub fn decode_pages(
    bytes: &[u8],
    channel: Channel,
    first_only: bool,
) -> Result<Vec<Frame>, String> {
    let mut decoder = Decoder::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let mut frames = Vec::new();
    loop {
        frames.push(decode_page(&mut decoder, channel)?);
        if first_only || !decoder.more_images() {
            return Ok(frames);
        }
        decoder.next_image().map_err(|e| e.to_string())?;
    }
}

/// True when the TIFF at `path` holds samples OpenCV's reader refuses
/// (unsigned 32-bit, half floats), read from its first page's header: its
/// refusal prints a libtiff error to standard error that no log level
/// silences, so such files go to [`decode_pages`] without asking it. Any
/// file this cannot read is left to OpenCV and its errors.
pub fn opencv_lacks_format(path: &Path) -> bool {
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let Ok(mut decoder) = Decoder::new(BufReader::new(file)) else {
        return false;
    };
    let bits = match decoder.colortype() {
        Ok(ColorType::Gray(b) | ColorType::GrayA(b) | ColorType::RGB(b) | ColorType::RGBA(b)) => b,
        _ => return false,
    };
    let format = decoder
        .find_tag_unsigned_vec::<u16>(Tag::SampleFormat)
        .ok()
        .flatten()
        .and_then(|v| v.first().copied())
        .map_or(SampleFormat::Uint, SampleFormat::from_u16_exhaustive);
    matches!(
        (format, bits),
        (SampleFormat::Uint, 32) | (SampleFormat::IEEEFP, 16)
    )
}

/// The decoder's current page as a frame.
fn decode_page(decoder: &mut Decoder<Cursor<&[u8]>>, channel: Channel) -> Result<Frame, String> {
    let (w, h) = decoder.dimensions().map_err(|e| e.to_string())?;
    let colour = decoder.colortype().map_err(|e| e.to_string())?;
    let (channels, bits) = match colour {
        ColorType::Gray(b) => (1, b),
        ColorType::GrayA(b) => (2, b),
        ColorType::RGB(b) => (3, b),
        ColorType::RGBA(b) => (4, b),
        other => {
            return Err(format!(
                "TIFF colour type {other:?} is not a grey or RGB image"
            ));
        }
    };
    let decoded = decoder.read_image().map_err(|e| e.to_string())?;
    let counts = matches!(decoded, DecodingResult::U8(_) | DecodingResult::U16(_));
    let layout = Interleaved {
        channels,
        bgr: false,
    };
    let bits = counts.then_some(bits.min(16));
    grey_frame(
        w as usize,
        h as usize,
        samples_as_f32(decoded),
        layout,
        channel,
        bits,
    )
    .map_err(|e| e.to_string())
}

/// Every sample as f32 (64-bit values round to the nearest f32: a frame's
/// counts do not need more).
fn samples_as_f32(decoded: DecodingResult) -> Vec<f32> {
    fn all<T: Copy>(v: Vec<T>, f: impl Fn(T) -> f32) -> Vec<f32> {
        v.into_iter().map(f).collect()
    }
    match decoded {
        DecodingResult::U8(v) => all(v, f32::from),
        DecodingResult::U16(v) => all(v, f32::from),
        DecodingResult::U32(v) => all(v, |x| x as f32),
        DecodingResult::U64(v) => all(v, |x| x as f32),
        DecodingResult::F16(v) => all(v, |x| x.to_f32()),
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => all(v, |x| x as f32),
        DecodingResult::I8(v) => all(v, f32::from),
        DecodingResult::I16(v) => all(v, f32::from),
        DecodingResult::I32(v) => all(v, |x| x as f32),
        DecodingResult::I64(v) => all(v, |x| x as f32),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiff::encoder::{TiffEncoder, colortype};

    #[test]
    fn unsigned_32_bit_files_skip_opencv_and_the_rest_do_not() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, write: &dyn Fn(&mut TiffEncoder<std::fs::File>)| {
            let path = dir.path().join(name);
            let mut encoder = TiffEncoder::new(std::fs::File::create(&path).unwrap()).unwrap();
            write(&mut encoder);
            path
        };
        let u32_grey = write("u32.tif", &|e| {
            e.write_image::<colortype::Gray32>(2, 1, &[1, 2]).unwrap();
        });
        let u32_rgb = write("rgb32.tif", &|e| {
            e.write_image::<colortype::RGB32>(1, 1, &[1, 2, 3]).unwrap();
        });
        let u16_grey = write("u16.tif", &|e| {
            e.write_image::<colortype::Gray16>(2, 1, &[1, 2]).unwrap();
        });
        let f32_grey = write("f32.tif", &|e| {
            e.write_image::<colortype::Gray32Float>(2, 1, &[1.0, 2.0])
                .unwrap();
        });
        let i32_grey = write("i32.tif", &|e| {
            e.write_image::<colortype::GrayI32>(2, 1, &[-1, 2]).unwrap();
        });
        assert!(opencv_lacks_format(&u32_grey));
        assert!(opencv_lacks_format(&u32_rgb));
        for path in [u16_grey, f32_grey, i32_grey, dir.path().join("missing.tif")] {
            assert!(!opencv_lacks_format(&path), "{}", path.display());
        }
    }
}
