//! The run animation: every analysed frame with what the loop knew then
//! (sites, tracked particles, the plan, the tip, the push being checked),
//! written as a video ([`crate::render::video`]). A recorded real-time view
//! of the loop, for the report and for dry-runs.

use super::assemble::{FrameSink, FrameView};
use crate::render::run_overlay::{RunOverlay, draw_run_frame};
use crate::render::video::{VideoError, VideoWriter};
use crate::vision::frame_input::hidden_sibling;
use std::path::{Path, PathBuf};

/// Frames per second of the animation (one analysed frame per step of the loop).
pub const ANIMATION_FPS: f64 = 2.0;

/// Why the animation could not be written.
#[derive(Debug, thiserror::Error)]
pub enum AnimationError {
    /// The video writer failed.
    #[error(transparent)]
    Video(#[from] VideoError),
    /// Drawing a frame failed.
    #[error("animation frame {frame}: {message}")]
    Draw { frame: usize, message: String },
}

/// A [`FrameSink`] that draws and writes each frame; the video is opened at
/// the first frame (its size is the frame's, times `scale`).
pub struct AnimationWriter {
    path: PathBuf,
    scale: f64,
    video: Option<VideoWriter>,
    frames: usize,
    error: Option<AnimationError>,
}

impl AnimationWriter {
    /// An animation to be written to `path` (`.mp4` or `.avi`), frames scaled by `scale`.
    pub fn new(path: &Path, scale: f64) -> Self {
        Self {
            path: path.to_owned(),
            scale,
            video: None,
            frames: 0,
            error: None,
        }
    }

    /// Draws one frame and appends it.
    pub fn add(&mut self, view: &FrameView<'_>) -> Result<(), AnimationError> {
        let overlay = overlay_for(view);
        let img =
            draw_run_frame(&view.sighting.frame, &overlay, self.scale).map_err(|message| {
                AnimationError::Draw {
                    frame: self.frames,
                    message,
                }
            })?;
        if self.video.is_none() {
            self.video = Some(VideoWriter::create(
                &hidden_sibling(&self.path),
                ANIMATION_FPS,
                img.dimensions(),
            )?);
        }
        if let Some(v) = self.video.as_mut() {
            v.write(&img)?;
        }
        self.frames += 1;
        Ok(())
    }

    /// Drops the animation of a run that did not end: the part written
    /// under its hidden name is removed.
    pub fn discard(self) {
        if let Some(v) = self.video {
            let _ = v.finish();
            let _ = std::fs::remove_file(hidden_sibling(&self.path));
        }
    }

    /// Closes the video: its path and frame count, `None` when no frame came, or the first error.
    /// The video is written under a hidden name and takes its own only
    /// here: a run killed part way leaves no `run.mp4` that cannot be
    /// played (a 44-byte file without its index had been linked from the
    /// resumed run's report).
    pub fn finish(self) -> Result<Option<(PathBuf, usize)>, AnimationError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        match self.video {
            None => Ok(None),
            Some(v) => {
                let frames = v.finish()?;
                let written = hidden_sibling(&self.path);
                std::fs::rename(&written, &self.path).map_err(|e| {
                    AnimationError::Video(VideoError::Write {
                        path: self.path.clone(),
                        reason: e.to_string(),
                    })
                })?;
                Ok(Some((self.path, frames)))
            }
        }
    }
}

impl FrameSink for AnimationWriter {
    fn frame(&mut self, view: &FrameView<'_>) {
        if self.error.is_none()
            && let Err(e) = self.add(view)
        {
            self.error = Some(e);
        }
    }
}

/// What the loop knew at this frame, in its pixels.
pub fn overlay_for(view: &FrameView<'_>) -> RunOverlay {
    let off = view.sighting.coarse_offset_m;
    let cal = view.calibration;
    let px = |p: [f64; 2]| cal.stage_to_pixel(p[0] - off[0], p[1] - off[1]).ok();
    let m_per_px = cal.m_per_px();
    let seen: Vec<[f64; 3]> = view
        .tracks
        .iter()
        .filter_map(|t| {
            px([t.x_um * 1e-6, t.y_um * 1e-6]).map(|p| [p[0], p[1], t.r_um * 1e-6 / m_per_px])
        })
        .collect();
    let radius_px = seen.first().map_or(10.0, |p| p[2]);
    let filled = view
        .sites
        .iter()
        .filter(|s| {
            view.tracks.iter().any(|t| {
                (t.x_um * 1e-6 - s.centre_m.x).hypot(t.y_um * 1e-6 - s.centre_m.y) <= 0.2e-6
            })
        })
        .count();
    let pair = |a: [f64; 2], b: [f64; 2]| Some([px(a)?, px(b)?]);
    let mut caption = format!(
        "t {:.1} s   particles {}   sites filled {}/{}",
        view.sighting.t_s,
        view.tracks.len(),
        filled,
        view.sites.len()
    );
    if let Some(p) = view.push {
        caption.push_str(&format!("   checking push of particle {}", p.particle));
    }
    RunOverlay {
        sites_px: view
            .sites
            .iter()
            .filter_map(|s| px([s.centre_m.x, s.centre_m.y]))
            .collect(),
        site_radius_px: radius_px,
        particles_px: seen,
        plan_px: view
            .plan
            .iter()
            .filter_map(|p| pair(p.from, p.to))
            .collect(),
        push_px: view.push.and_then(|p| pair(p.from, p.to)),
        tip_px: view.sighting.tip_m.and_then(px),
        caption,
    }
}
