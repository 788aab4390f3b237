//! TIFF pages that neither the `image` crate nor OpenCV decode: unsigned
//! 32-bit and half-float samples, and 32/64-bit float or integer grey that
//! `image` refuses (OpenCV has no unsigned 32-bit type and no half-float
//! TIFFs). Read with the `tiff` crate, which takes every sample format;
//! samples other than 8/16-bit counts are mapped by
//! [`frame_from_wide`](super::wide_samples::frame_from_wide).

use std::io::Cursor;

use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult};

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
