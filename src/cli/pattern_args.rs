//! The pattern flags `nanopush plan` and `nanopush assemble` share: what to
//! assemble (`--text` or `--pattern`), at which pitch, turned how far, and
//! where (`--at`).

use crate::plan::pattern_request::{PatternRequest, PatternSource};
use anyhow::bail;
use nalgebra::Vector2;
use std::path::PathBuf;

/// What to assemble and where.
#[derive(clap::Args, Debug, Clone)]
pub struct PatternArgs {
    /// Text to write with the built-in 3x5 font (A-Z, 0-9, space; lower case
    /// is written upper case), e.g. CMU.
    #[arg(long, conflicts_with = "pattern")]
    pub text: Option<String>,
    /// Pattern file: site list (.toml/.json, um), SVG drawing (.svg: its
    /// paths sampled at the pitch, 1 user unit = 1 um) or bitmap image
    /// (dark pixel = site).
    #[arg(long)]
    pub pattern: Option<PathBuf>,
    /// Site pitch in um for text, bitmaps and drawings (default: particle
    /// diameter + 0.5 um; a site list's positions are its own).
    #[arg(long)]
    pub pitch_um: Option<f64>,
    /// Pattern rotation about its centre, degrees counter-clockwise.
    #[arg(long, default_value_t = 0.0)]
    pub rotation_deg: f64,
    /// Pattern centre "X,Y" in um from the field's lower-left corner; on a
    /// hardware rig (`assemble --rig`), in the calibration's stage um, as
    /// `rig probe --camera` prints the view (default: chosen by planning full plans at the best candidate
    /// centres: `plan` keeps the least pushing, `assemble` the shortest
    /// run; when the best are refused, the first of up to 24 others that
    /// plans, nearest the particles first, then of the 4 least crowded).
    #[arg(long, value_parser = parse_xy, allow_hyphen_values = true)]
    pub at: Option<(f64, f64)>,
}

impl PatternArgs {
    /// The request these flags make; an error when neither `--text` nor
    /// `--pattern` is given, or the pitch is not a length.
    pub fn request(&self) -> anyhow::Result<PatternRequest> {
        let source = match (&self.text, &self.pattern) {
            (Some(text), _) => PatternSource::Text(text.clone()),
            (None, Some(path)) => PatternSource::File(path.clone()),
            (None, None) => bail!("give --text or --pattern"),
        };
        if let Some(p) = self.pitch_um
            && !(p.is_finite() && p > 0.0)
        {
            bail!("--pitch-um must be finite and > 0, got {p}");
        }
        // A turn at most: 1e300 degrees had been planned as whatever its
        // sine came to.
        if self.rotation_deg.is_nan() || self.rotation_deg.abs() > 360.0 {
            bail!(
                "--rotation-deg must be within -360 and 360, got {}",
                self.rotation_deg
            );
        }
        Ok(PatternRequest {
            source,
            pitch_m: self.pitch_um.map(|p| p * 1e-6),
            rotation_rad: self.rotation_deg.to_radians(),
            at_m: self.at.map(|(x, y)| Vector2::new(x * 1e-6, y * 1e-6)),
        })
    }
}

fn parse_xy(s: &str) -> Result<(f64, f64), String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("expected X,Y in um, got {s:?}"))?;
    let x: f64 = x.trim().parse().map_err(|e| format!("bad X {x:?}: {e}"))?;
    let y: f64 = y.trim().parse().map_err(|e| format!("bad Y {y:?}: {e}"))?;
    if !x.is_finite() || !y.is_finite() {
        return Err(format!("X,Y must be finite, got {s:?}"));
    }
    Ok((x, y))
}
