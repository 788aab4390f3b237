//! What a user asks to assemble: a text or a pattern file, at a pitch,
//! turned and placed. `nanopush plan` and `nanopush assemble` (simulated rig
//! and hardware) read it the same way, so a pattern planned on paper is the
//! pattern the rig builds.

use super::DEFAULT_SITE_GAP_M;
use super::PlanConfig;
use super::layout::Layout;
use super::pattern::site_list::{is_site_list, read_pattern};
use super::pattern::transform::{Reachable, place_at, rotate};
use super::pattern::{Pattern, PatternError, Site};
use super::placement::{PlacementGoal, place_and_plan_until};
use nalgebra::Vector2;
use std::path::PathBuf;

/// Particles a site that a spread batch's default pitch leaves room for
/// ([`PatternRequest::pattern_for_batch`]): the planner keeps a choice, and
/// a particle measured a little wider than it is still fits.
pub const FITTING_PER_SITE: f64 = 1.25;

/// Least widening of the default pitch's radius for a spread batch: a batch
/// of one size measured with 10 nm of noise keeps its nominal pitch.
pub const WIDEN_ABOVE_M: f64 = 0.05e-6;

/// Where the pattern's sites come from.
#[derive(Debug, Clone, PartialEq)]
pub enum PatternSource {
    /// Text in the built-in font.
    Text(String),
    /// A site list (TOML/JSON, um), bitmap or SVG drawing.
    File(PathBuf),
}

/// A pattern as asked for: its source, pitch, rotation and placement.
#[derive(Debug, Clone, PartialEq)]
pub struct PatternRequest {
    /// The sites' source.
    pub source: PatternSource,
    /// Site pitch of text, bitmaps and drawings (a site list's positions are
    /// its own); `None`: a particle diameter plus [`DEFAULT_SITE_GAP_M`].
    pub pitch_m: Option<f64>,
    /// Counter-clockwise turn about the pattern's centre.
    pub rotation_rad: f64,
    /// The pattern's centre on the stage; `None`: where planning finds it
    /// best ([`place_and_plan_until`]).
    pub at_m: Option<Vector2<f64>>,
}

/// The source at the default pitch, unturned, placed by planning.
impl From<PatternSource> for PatternRequest {
    fn from(source: PatternSource) -> Self {
        Self {
            source,
            pitch_m: None,
            rotation_rad: 0.0,
            at_m: None,
        }
    }
}

impl PatternRequest {
    /// `text` at the default pitch, unturned, placed by planning.
    pub fn text(text: &str) -> Self {
        PatternSource::Text(text.to_string()).into()
    }

    /// The pattern for particles of `radius_m`: built at the pitch, turned,
    /// and refused when two sites are closer than a particle diameter.
    pub fn pattern(&self, radius_m: f64) -> Result<Pattern, PatternError> {
        // The text, bitmap and drawing readers each refuse a pitch that is
        // not a length.
        let pitch_m = self.pitch_m.unwrap_or(2.0 * radius_m + DEFAULT_SITE_GAP_M);
        // A pitch asked for and silently ignored would build another pattern.
        if let (Some(_), PatternSource::File(path)) = (self.pitch_m, &self.source)
            && is_site_list(path)
        {
            return Err(PatternError::File {
                path: path.display().to_string(),
                message: "a site list's positions are its own, in um: no pitch applies to it"
                    .into(),
            });
        }
        let pattern = match &self.source {
            PatternSource::Text(text) => Pattern::from_text(text, pitch_m)?,
            PatternSource::File(path) => read_pattern(path, pitch_m)?,
        };
        let pattern = rotate(&pattern, self.rotation_rad)?;
        pattern.check_no_overlap(2.0 * radius_m)?;
        Ok(pattern)
    }

    /// [`Self::pattern`] for a batch of particles of `radii_m` whose
    /// nominal radius is `nominal_m`. At the default pitch of text,
    /// bitmaps and drawings, a batch whose radii spread is given a pitch
    /// at least [`FITTING_PER_SITE`] particles a site fit: sites a pitch
    /// apart take particles up to about 0.1 um wider than the radius the
    /// pitch is built for ([`super::site_radius_m`]), and at the nominal
    /// pitch a 5 % spread left too few (CMU's 31 sites among 50 particles
    /// of 4.3-5.7 um: 27-30 fitted on 4 of 13 layouts, and the run was
    /// refused). The pattern is built for the radius of the particle that
    /// many are no wider than, when that is more than [`WIDEN_ABOVE_M`]
    /// over the nominal; when the pattern would then leave `area`, for
    /// the widest radius it still fits at (CMU at the 11.02 um pitch of a
    /// 5.26 um radius is 121.3 um wide).
    pub fn pattern_for_batch(
        &self,
        nominal_m: f64,
        radii_m: &[f64],
        area: &Reachable,
    ) -> Result<Pattern, PatternError> {
        let pattern = self.pattern(nominal_m)?;
        let listed = matches!(&self.source, PatternSource::File(path) if is_site_list(path));
        if self.pitch_m.is_some() || listed {
            return Ok(pattern);
        }
        let mut sorted: Vec<f64> = radii_m.iter().copied().filter(|r| r.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        let need = (FITTING_PER_SITE * pattern.offsets_m.len() as f64).ceil() as usize;
        let wanted = match sorted.get(need.clamp(1, sorted.len().max(1)) - 1) {
            Some(&r) if r > nominal_m + WIDEN_ABOVE_M => r,
            _ => return Ok(pattern),
        };
        let room = area.hi_m - area.lo_m;
        let inside = |r: f64| {
            let p = self.pattern(r).ok()?;
            let e = p.extent_m();
            (e.x <= room.x && e.y <= room.y).then_some(p)
        };
        if let Some(wide) = inside(wanted) {
            return Ok(wide);
        }
        // The widest that fits, to a nanometre.
        let (mut fits, mut leaves) = (nominal_m, wanted);
        while leaves - fits > 1e-9 {
            let mid = 0.5 * (fits + leaves);
            match inside(mid) {
                Some(_) => fits = mid,
                None => leaves = mid,
            }
        }
        Ok(inside(fits).unwrap_or(pattern))
    }

    /// The sites: at the asked centre (refused when a site leaves `area`),
    /// else where a full plan on `layout` is best by `goal` (until
    /// `interrupt` is raised).
    pub fn sites(
        &self,
        pattern: &Pattern,
        area: &Reachable,
        layout: &Layout,
        config: &PlanConfig,
        goal: PlacementGoal,
        interrupt: Option<&std::sync::atomic::AtomicBool>,
    ) -> Result<Vec<Site>, PatternError> {
        match self.at_m {
            Some(centre_m) => place_at(pattern, centre_m, area, layout.max_radius_m()),
            None => place_and_plan_until(pattern, area, layout, config, goal, interrupt)
                .map(|placed| placed.sites),
        }
    }

    /// The text, or the file's path: how reports and journals name the pattern.
    pub fn label(&self) -> String {
        match &self.source {
            PatternSource::Text(text) => text.clone(),
            PatternSource::File(path) => path.display().to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 5e-6;

    #[test]
    fn pitch_and_rotation_shape_the_pattern() {
        let plain = PatternRequest::text("I").pattern(R).unwrap();
        // "I" is a 3x5 glyph: its tallest column is 4 default pitches long.
        let default_pitch = 2.0 * R + DEFAULT_SITE_GAP_M;
        assert!((plain.extent_m().y - 4.0 * default_pitch).abs() < 1e-12);
        let wide = PatternRequest {
            pitch_m: Some(12e-6),
            ..PatternRequest::text("I")
        };
        assert!((wide.pattern(R).unwrap().extent_m().y - 48e-6).abs() < 1e-12);
        let turned = PatternRequest {
            rotation_rad: std::f64::consts::FRAC_PI_2,
            ..wide
        };
        let extent = turned.pattern(R).unwrap().extent_m();
        assert!((extent.x - 48e-6).abs() < 1e-9, "{extent:?}");
    }

    /// "I" has 11 sites: 14 particles must fit its pitch.
    #[test]
    fn a_spread_batch_widens_the_default_pitch_until_enough_fit() {
        let pitch = |p: &Pattern| p.extent_m().y / 4.0;
        let one_size: Vec<f64> = (0..20).map(|i| R + (i % 5) as f64 * 4e-9).collect();
        let plain = PatternRequest::text("I")
            .pattern_for_batch(R, &one_size, &room())
            .unwrap();
        assert!((pitch(&plain) - (2.0 * R + DEFAULT_SITE_GAP_M)).abs() < 1e-12);
        // 10 of 5 um, 10 of 5.3 um: the 14th narrowest is 5.3 um.
        let spread: Vec<f64> = (0..20).map(|i| if i < 10 { R } else { 5.3e-6 }).collect();
        let wide = PatternRequest::text("I")
            .pattern_for_batch(R, &spread, &room())
            .unwrap();
        assert!((pitch(&wide) - (2.0 * 5.3e-6 + DEFAULT_SITE_GAP_M)).abs() < 1e-12);
        // An asked pitch stays.
        let asked = PatternRequest {
            pitch_m: Some(12e-6),
            ..PatternRequest::text("I")
        };
        assert!(
            (pitch(&asked.pattern_for_batch(R, &spread, &room()).unwrap()) - 12e-6).abs() < 1e-12
        );
        // Where 5.3 um's pitch would leave the area, the widest that fits.
        let tight = Reachable {
            lo_m: Vector2::zeros(),
            hi_m: Vector2::new(100e-6, 43e-6),
        };
        let fitted = PatternRequest::text("I")
            .pattern_for_batch(R, &spread, &tight)
            .unwrap();
        assert!((fitted.extent_m().y - 43e-6).abs() < 1e-8, "{fitted:?}");
    }

    /// Room enough for any pattern here.
    fn room() -> Reachable {
        Reachable {
            lo_m: Vector2::zeros(),
            hi_m: Vector2::new(1e-3, 1e-3),
        }
    }

    #[test]
    fn a_site_list_takes_no_pitch() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("two.toml");
        let sites = "sites = [ { x_um = 0.0, y_um = 0.0 }, { x_um = 12.0, y_um = 0.0 } ]\n";
        std::fs::write(&path, sites).unwrap();
        let listed = PatternRequest::from(PatternSource::File(path));
        assert!((listed.pattern(R).unwrap().extent_m().x - 12e-6).abs() < 1e-12);
        // Nor a batch's: its sites stay where the list has them.
        let spread = [R, 5.9e-6, 5.9e-6];
        let kept = listed.pattern_for_batch(R, &spread, &room()).unwrap();
        assert!((kept.extent_m().x - 12e-6).abs() < 1e-12);
        let pitched = PatternRequest {
            pitch_m: Some(20e-6),
            ..listed
        };
        let err = pitched.pattern(R).unwrap_err().to_string();
        assert!(err.contains("no pitch applies"), "{err}");
    }

    #[test]
    fn a_pitch_under_a_diameter_or_not_positive_is_refused() {
        for pitch in [8e-6, 0.0, -1e-5, f64::NAN] {
            let request = PatternRequest {
                pitch_m: Some(pitch),
                ..PatternRequest::text("I")
            };
            let err = request.pattern(R).unwrap_err().to_string();
            let expected = if pitch > 0.0 { "overlap" } else { "pitch_um" };
            assert!(err.contains(expected), "{pitch}: {err}");
        }
    }

    #[test]
    fn sites_go_where_asked_or_are_refused_outside_the_area() {
        let layout = Layout {
            field_m: [120e-6, 100e-6],
            particles: (0..20)
                .map(|i| crate::plan::layout::Particle {
                    id: i,
                    centre_m: Vector2::new(
                        10e-6 + 11e-6 * (i % 10) as f64,
                        if i < 10 { 10e-6 } else { 90e-6 },
                    ),
                    radius_m: R,
                })
                .collect(),
        };
        let area = Reachable::for_field(layout.field_m, R);
        let request = PatternRequest {
            at_m: Some(Vector2::new(60e-6, 50e-6)),
            ..PatternRequest::text("L")
        };
        let pattern = request.pattern(R).unwrap();
        let config = PlanConfig::default();
        let placed = |r: &PatternRequest| {
            r.sites(
                &pattern,
                &area,
                &layout,
                &config,
                PlacementGoal::LeastPush,
                None,
            )
        };
        let sites = placed(&request).unwrap();
        let n = sites.len() as f64;
        let centre = sites.iter().map(|s| s.centre_m).sum::<Vector2<f64>>() / n;
        let (lo, hi) =
            crate::plan::pattern::bbox(&sites.iter().map(|s| s.centre_m).collect::<Vec<_>>());
        assert!(((lo + hi) / 2.0 - Vector2::new(60e-6, 50e-6)).norm() < 1e-12);
        assert!(centre.x < 60e-6, "an L leans left: {centre:?}");
        let off = PatternRequest {
            at_m: Some(Vector2::new(5e-6, 50e-6)),
            ..request
        };
        let err = placed(&off).unwrap_err();
        assert!(
            matches!(err, PatternError::OutsideAtPlacement { .. }),
            "{err}"
        );
    }
}
