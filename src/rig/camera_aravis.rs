//! A GenICam camera (GigE Vision / USB3 Vision) through Aravis, behind the
//! `aravis` cargo feature (it links libaravis-0.8, Debian: libaravis-dev).
//!
//! Kept minimal: one single-frame acquisition per grab
//! (`arv_camera_acquisition`), monochrome pixel formats only (Mono8, and the
//! unpacked Mono10/12/16 in 16-bit words). Frame time is when the buffer
//! arrived. Checked against Aravis's own simulated camera (`arv-fake-gv-camera-0.8`,
//! Debian: aravis-tools) only, see docs/rig.md.

use super::camera::{Camera, TimedFrame};
use super::camera_clock::WallClock;
use super::camera_error::CameraError;
use super::error::RigError;
use crate::vision::frame::Frame;
use aravis::prelude::*;
use aravis::{BufferStatus, PixelFormat};
use std::time::Duration;

/// A GenICam camera through Aravis.
pub struct AravisCamera {
    camera: aravis::Camera,
    device: String,
    timeout: Duration,
    clock: WallClock,
}

impl AravisCamera {
    /// Opens `device` (an Aravis device id; empty: the first camera found).
    pub fn open(device: &str, timeout: Duration, clock: WallClock) -> Result<Self, CameraError> {
        // The token only guards against double initialisation; losing it is harmless.
        let _ = aravis::Aravis::initialize();
        let name = (!device.is_empty()).then_some(device);
        let camera = aravis::Camera::new(name).map_err(|e| CameraError::Open {
            kind: "aravis",
            what: device.to_string(),
            reason: e.to_string(),
        })?;
        Ok(Self {
            camera,
            device: device.to_string(),
            timeout,
            clock,
        })
    }
}

/// Bits per pixel of the monochrome formats read, `None` for the others.
fn mono_bits(format: PixelFormat) -> Option<u8> {
    [
        (PixelFormat::MONO_8, 8),
        (PixelFormat::MONO_10, 10),
        (PixelFormat::MONO_12, 12),
        (PixelFormat::MONO_16, 16),
    ]
    .into_iter()
    .find(|(f, _)| *f == format)
    .map(|(_, b)| b)
}

/// Grey frame from a buffer's bytes; rows may carry padding at their end.
fn frame_from_bytes(data: &[u8], width: usize, height: usize, bits: u8) -> Result<Frame, String> {
    let bytes_per_px = if bits > 8 { 2 } else { 1 };
    if width == 0 || height == 0 || data.len() < width * height * bytes_per_px {
        return Err(format!(
            "buffer of {} bytes is too small for {width}x{height} at {bits} bits",
            data.len()
        ));
    }
    let stride = data.len() / height;
    let mut pixels = Vec::with_capacity(width * height);
    for row in data.chunks(stride).take(height) {
        let row = &row[..width * bytes_per_px];
        if bytes_per_px == 1 {
            pixels.extend(row.iter().map(|&b| f32::from(b)));
        } else {
            pixels.extend(
                row.chunks_exact(2)
                    .map(|c| f32::from(u16::from_le_bytes([c[0], c[1]]))),
            );
        }
    }
    Frame::new(width, height, pixels, bits).map_err(|e| e.to_string())
}

impl Camera for AravisCamera {
    /// One acquired frame; `Ok(None)` when the camera delivered no complete
    /// buffer within the timeout.
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        let io = |what: String| RigError::Io(format!("aravis camera {:?}: {what}", self.device));
        let buffer = match self.camera.acquisition(self.timeout.as_micros() as u64) {
            Ok(buffer) => buffer,
            Err(e) => {
                tracing::warn!("aravis camera {:?}: no frame: {e}", self.device);
                return Ok(None);
            }
        };
        if buffer.status() != BufferStatus::Success {
            tracing::warn!(
                "aravis camera {:?}: dropped buffer ({:?})",
                self.device,
                buffer.status()
            );
            return Ok(None);
        }
        let format = buffer.image_pixel_format();
        let bits = mono_bits(format).ok_or_else(|| {
            io(format!(
                "pixel format 0x{:08x} is not monochrome 8/10/12/16 bit; set PixelFormat to Mono8 or Mono16",
                format.raw()
            ))
        })?;
        let width = buffer.image_width().max(0) as usize;
        let height = buffer.image_height().max(0) as usize;
        let frame = frame_from_bytes(&buffer.image_data(), width, height, bits).map_err(io)?;
        Ok(Some(TimedFrame {
            t_s: self.clock.now_s(),
            frame,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn padded_sixteen_bit_rows_become_a_frame() {
        // 2x2 Mono16, each row padded by 2 bytes.
        let data = [1, 0, 2, 0, 9, 9, 3, 0, 0, 1, 9, 9];
        let f = frame_from_bytes(&data, 2, 2, 16).unwrap();
        assert_eq!(f.pixels(), &[1.0, 2.0, 3.0, 256.0]);
        assert!(frame_from_bytes(&data[..5], 2, 2, 16).is_err());
    }
}
