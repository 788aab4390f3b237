//! Over- and under-exposure: how much of a frame sits at the camera's full
//! count or at zero. The fit takes saturated pixels as censored (a
//! particle's clipped core keeps its centre), but where the background
//! itself clips, rings are cut off: at a tenth of the frame clipped
//! particles start to go missing and centres to drift (docs/vision.md). A camera set that way should be told, once, not
//! silently measured worse. Zero counts are the other end: a black level
//! set too low clips the dark probe and dim backgrounds to 0.

use serde::{Deserialize, Serialize};

use super::frame::Frame;
use super::log_on_change::changed;

/// A frame with more of its pixels than this at either end is reported as
/// clipped there (1 %: the synthetic over-exposed frames whose particles
/// all keep their centres clip 0.85 %, the real frames in the fixtures at
/// most 0.04 %, bright-field cores at 255).
pub const CLIPPED_WARN_FRACTION: f64 = 0.01;

/// The fractions of a frame's pixels at its ends.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Exposure {
    /// At the camera's full count (saturated).
    pub saturated_fraction: f64,
    /// At zero counts (the black level clips).
    pub dark_fraction: f64,
}

impl Exposure {
    /// Counts both ends in one pass.
    pub fn of(frame: &Frame) -> Self {
        let full = frame.max_count();
        let px = frame.pixels();
        let (mut saturated, mut dark) = (0usize, 0usize);
        // Lanes of per-chunk counts that the compiler keeps in vector
        // registers; a u32 lane cannot overflow within one chunk.
        for chunk in px.chunks(1 << 16) {
            let (s, d) = chunk.iter().fold((0u32, 0u32), |(s, d), &p| {
                (s + u32::from(p >= full), d + u32::from(p <= 0.0))
            });
            saturated += s as usize;
            dark += d as usize;
        }
        let n = px.len().max(1) as f64;
        Exposure {
            saturated_fraction: saturated as f64 / n,
            dark_fraction: dark as f64 / n,
        }
    }

    /// Itself when either end holds more than [`CLIPPED_WARN_FRACTION`]
    /// (what the journal and the dry-run record), else None.
    pub fn clipped(self) -> Option<Self> {
        (self.saturated_fraction.max(self.dark_fraction) > CLIPPED_WARN_FRACTION).then_some(self)
    }

    /// What a user should hear about this frame's exposure, by the end
    /// that clips ("saturated" or "dark").
    pub fn warnings(&self, full_count: f32) -> Vec<(&'static str, String)> {
        let mut said = Vec::new();
        if self.saturated_fraction > CLIPPED_WARN_FRACTION {
            said.push((
                "saturated",
                format!(
                    "{:.1} % of the pixels at the camera's full count ({full_count:.0}): \
                     over-exposed; particles and the probe where the background clips are \
                     located less well or missed (lower the exposure, gain or illumination)",
                    100.0 * self.saturated_fraction
                ),
            ));
        }
        if self.dark_fraction > CLIPPED_WARN_FRACTION {
            said.push((
                "dark",
                format!(
                    "{:.1} % of the pixels at 0 counts: the camera's black level clips \
                     (raise its offset or the illumination)",
                    100.0 * self.dark_fraction
                ),
            ));
        }
        said
    }
}

impl std::fmt::Display for Exposure {
    /// "61.0 % saturated, 0.0 % at 0 counts".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.1} % saturated, {:.1} % at 0 counts",
            100.0 * self.saturated_fraction,
            100.0 * self.dark_fraction
        )
    }
}

/// Warns of `source`'s clipped frames, each end once (a camera set badly
/// stays so frame after frame).
pub fn report(source: &str, exposure: &Exposure, full_count: f32) {
    for (end, warning) in exposure.warnings(full_count) {
        if changed(format!("{end} exposure of {source}"), "clipped".to_owned()) {
            tracing::warn!("{source}: {warning}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(pixels: Vec<f32>, bits: u8) -> Frame {
        Frame::new(pixels.len(), 1, pixels, bits).unwrap()
    }

    #[test]
    fn ends_are_counted_at_the_frames_own_full_count() {
        let mut px = vec![100.0; 1000];
        px[..30].fill(255.0);
        px[30..35].fill(0.0);
        let eight = Exposure::of(&frame(px.clone(), 8));
        assert_eq!(
            eight,
            Exposure {
                saturated_fraction: 0.03,
                dark_fraction: 0.005
            }
        );
        let warned = eight.warnings(255.0);
        assert_eq!(warned.len(), 1, "{warned:?}");
        assert_eq!(warned[0].0, "saturated");
        assert!(
            warned[0]
                .1
                .starts_with("3.0 % of the pixels at the camera's full count (255)")
        );
        // 255 is no end for a 16-bit camera.
        let sixteen = Exposure::of(&frame(px, 16));
        assert_eq!(sixteen.saturated_fraction, 0.0);
        assert!(sixteen.warnings(65535.0).is_empty());
    }

    #[test]
    fn a_clipped_black_level_is_its_own_warning() {
        let mut px = vec![100.0; 200];
        px[..20].fill(0.0);
        let warned = Exposure::of(&frame(px, 8)).warnings(255.0);
        assert_eq!(warned.len(), 1);
        assert_eq!(warned[0].0, "dark");
        assert!(
            warned[0].1.starts_with("10.0 % of the pixels at 0 counts"),
            "{warned:?}"
        );
    }

    #[test]
    fn counts_span_many_chunks() {
        let mut px = vec![7.0; 3 << 16];
        for p in px.iter_mut().step_by(10) {
            *p = 65535.0;
        }
        let e = Exposure::of(&frame(px, 16));
        assert!((e.saturated_fraction - 0.1).abs() < 1e-5, "{e:?}");
    }
}
