//! Whether the calibration's scale or rotation is a few per cent off, as the
//! apex's offsets across the field tell.
//!
//! Why: a calibration that reads every stage point p as M (p - c) + c puts
//! the apex (M - I)(stage - c) off where the stage was sent: an offset that
//! grows with where the stage is, where drift grows with time. A scale 5 %
//! off put the apex at most 2.4 um off, under
//! [`CALIBRATION_DOUBT_M`](crate::exec::assemble::CALIBRATION_DOUBT_M); the
//! drift filter took it for drift and the run stopped on the planner after
//! three lost contacts on one particle, naming no calibration. Such a run
//! gives few frames whose apex is clear of particles (the first two, parked
//! at either end of the travel, on the simulated rig), so no fit of drift
//! beside position would be trusted in time. Instead the offsets of the
//! latest minute are fitted, by least squares, to I - M for M a scale and
//! a turn (two unknowns: one stretch of travel in any direction tells
//! both), and refitted without the sightings far off the first fit (an
//! apex pulled 0.1-0.3 um by a particle, in a fifth of the frames). Drift
//! in that minute is allowed for, at a rate beyond any the loop follows.
//! Written by hand: closed-form, two unknowns; no crate fits a similarity
//! to residual vectors with the degenerate cases (one place) said.

use crate::exec::assemble::CALIBRATION_UNFIT;
use crate::median::upper_median;

/// A sighting dropped from the refit lies this many times the median
/// sighting's distance off the first fit.
const OUTLIER_FACTOR: f64 = 3.0;

/// One frame's apex, clear of particles, against where the stage was sent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSighting {
    /// Rig time of the frame, seconds.
    pub t_s: f64,
    /// Where the nanostage was sent (x, y), metres.
    pub stage_m: [f64; 2],
    /// The apex less where the stage was sent (x, y), metres.
    pub offset_m: [f64; 2],
}

/// Which sightings are fitted, and what gradient is the calibration's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapFitSettings {
    /// Only sightings this recent (before the latest) are fitted, seconds
    /// (default 60 s): drift has little time to pass for position.
    pub window_s: f64,
    /// Fewest sightings for a verdict (default 2: the run above stopped
    /// with two).
    pub min_sightings: usize,
    /// Shortest travel between two fitted sightings for a verdict, metres
    /// (default 20 um): across less, the apex's noise makes per cents.
    pub min_travel_m: f64,
    /// Gradient (metres of offset a metre of travel) above which the
    /// calibration is doubted (default 0.015: 1.5 % in scale, 0.9 deg).
    pub max_gradient: f64,
    /// Smallest change of the offset across the travel for a doubt,
    /// metres (default 0.5 um: 2.5 times the placed tolerance, beyond a
    /// pulled apex), to which `drift_allowance_m_per_s` over the fitted
    /// sightings' time span is added.
    pub min_change_m: f64,
    /// The fastest drift allowed for, metres a second (default 10 nm/s,
    /// twice the 5 nm/s of a probe just mounted).
    pub drift_allowance_m_per_s: f64,
}

impl Default for MapFitSettings {
    fn default() -> Self {
        Self {
            window_s: 60.0,
            min_sightings: 2,
            min_travel_m: 20e-6,
            max_gradient: 0.015,
            min_change_m: 0.5e-6,
            drift_allowance_m_per_s: 10e-9,
        }
    }
}

/// What the sightings say of the calibration's map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MapFit {
    /// Fewer finite sightings in the window than `min_sightings` (or left
    /// after the refit).
    TooFew,
    /// The stage travelled less than `min_travel_m` between them.
    Narrow,
    /// The fit.
    Fitted(MapGradient),
}

/// How the apex's offset changes across the field: by (s R - I) times the
/// travel, for a scale s and a turn R.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapGradient {
    /// s cos(turn) - 1.
    pub stretch: f64,
    /// s sin(turn).
    pub turn: f64,
    /// Sightings the refit kept.
    pub kept: usize,
    /// Longest travel between two of them, metres.
    pub travel_m: f64,
    /// Time between the first and the last of them, seconds.
    pub span_s: f64,
}

impl MapGradient {
    /// Metres of offset a metre of travel, in any direction.
    pub fn size(&self) -> f64 {
        self.stretch.hypot(self.turn)
    }

    /// The scale the calibration reads positions at, less one.
    pub fn scale_fraction(&self) -> f64 {
        (1.0 + self.stretch).hypot(self.turn) - 1.0
    }

    /// How far the calibration turns positions, radians (from +x towards +y).
    pub fn rotation_rad(&self) -> f64 {
        self.turn.atan2(1.0 + self.stretch)
    }

    /// How much the gradient changes the offset across the travel, metres.
    pub fn change_m(&self) -> f64 {
        self.size() * self.travel_m
    }

    /// Why the calibration does not fit, when the gradient passes
    /// `max_gradient` and its change across the travel passes
    /// `min_change_m` and what drift could make in the time.
    pub fn doubt(&self, settings: &MapFitSettings) -> Option<String> {
        let drift_m = settings.drift_allowance_m_per_s * self.span_s;
        let changed = self.change_m() > settings.min_change_m + drift_m;
        (self.size() > settings.max_gradient && changed).then(|| {
            format!(
                "the probe's apex is off the stage by an amount that grows with the stage's position \
                 ({:.2} um across {:.0} um of travel in {:.0} s, {} sightings clear of particles): \
                 about {:+.1} % in scale and {:+.1} deg turned; drift grows with time, not place: \
                 {CALIBRATION_UNFIT}; make it again (nanopush rig calibrate) before pushing",
                self.change_m() * 1e6,
                self.travel_m * 1e6,
                self.span_s,
                self.kept,
                self.scale_fraction() * 100.0,
                self.rotation_rad().to_degrees()
            )
        })
    }
}

/// Fits the sightings of the latest `window_s` (non-finite ones left
/// out), then again without those beyond three times the
/// median distance off the first fit.
pub fn fit_map(sightings: &[MapSighting], settings: &MapFitSettings) -> MapFit {
    let finite: Vec<MapSighting> = sightings
        .iter()
        .filter(|s| {
            [
                s.t_s,
                s.stage_m[0],
                s.stage_m[1],
                s.offset_m[0],
                s.offset_m[1],
            ]
            .iter()
            .all(|v| v.is_finite())
        })
        .copied()
        .collect();
    let latest = finite
        .iter()
        .map(|s| s.t_s)
        .fold(f64::NEG_INFINITY, f64::max);
    let recent: Vec<MapSighting> = finite
        .into_iter()
        .filter(|s| latest - s.t_s <= settings.window_s)
        .collect();
    let first = match Solved::of(&recent, settings) {
        Ok(s) => s,
        Err(why) => return why,
    };
    let distances: Vec<f64> = recent.iter().map(|s| first.off_m(s)).collect();
    let limit = OUTLIER_FACTOR * upper_median(&mut distances.clone()).unwrap_or(0.0);
    let kept: Vec<MapSighting> = recent
        .iter()
        .zip(&distances)
        .filter(|(_, d)| **d <= limit)
        .map(|(s, _)| *s)
        .collect();
    match Solved::of(&kept, settings) {
        Ok(s) => MapFit::Fitted(s.gradient),
        Err(why) => why,
    }
}

/// A least-squares fit: the mean offset at the mean position, and the gradient.
struct Solved {
    mean_stage: [f64; 2],
    mean_offset: [f64; 2],
    gradient: MapGradient,
}

impl Solved {
    /// The fit of `s`, or why there is none. With d a sighting's position
    /// less the mean and o its offset less the mean, (s R - I) d = stretch
    /// d + turn J d, J d = (-d_y, d_x) being square to d and as long:
    /// stretch = sum o.d / sum |d|^2, turn = sum o.J d / sum |d|^2.
    fn of(s: &[MapSighting], settings: &MapFitSettings) -> Result<Self, MapFit> {
        if s.len() < settings.min_sightings.max(2) {
            return Err(MapFit::TooFew);
        }
        let travel_m = s
            .iter()
            .enumerate()
            .flat_map(|(i, a)| {
                s[i + 1..]
                    .iter()
                    .map(move |b| distance(a.stage_m, b.stage_m))
            })
            .fold(0.0, f64::max);
        if !(travel_m >= settings.min_travel_m && travel_m > 0.0) {
            return Err(MapFit::Narrow);
        }
        let n = s.len() as f64;
        let mean = |f: fn(&MapSighting) -> [f64; 2]| {
            [0, 1].map(|k| s.iter().map(|p| f(p)[k]).sum::<f64>() / n)
        };
        let (mean_stage, mean_offset) = (mean(|p| p.stage_m), mean(|p| p.offset_m));
        let (mut along, mut across, mut squares) = (0.0, 0.0, 0.0);
        for p in s {
            let d = [0, 1].map(|k| p.stage_m[k] - mean_stage[k]);
            let o = [0, 1].map(|k| p.offset_m[k] - mean_offset[k]);
            along += o[0] * d[0] + o[1] * d[1];
            across += -o[0] * d[1] + o[1] * d[0];
            squares += d[0] * d[0] + d[1] * d[1];
        }
        let (first, last) = s
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.t_s), hi.max(p.t_s))
            });
        Ok(Self {
            mean_stage,
            mean_offset,
            gradient: MapGradient {
                stretch: along / squares,
                turn: across / squares,
                kept: s.len(),
                travel_m,
                span_s: last - first,
            },
        })
    }

    /// How far `p`'s offset lies from the fit's, metres.
    fn off_m(&self, p: &MapSighting) -> f64 {
        let (a, b) = (self.gradient.stretch, self.gradient.turn);
        let d = [0, 1].map(|k| p.stage_m[k] - self.mean_stage[k]);
        let fitted = [a * d[0] - b * d[1], b * d[0] + a * d[1]];
        let r = [0, 1].map(|k| p.offset_m[k] - self.mean_offset[k] - fitted[k]);
        r[0].hypot(r[1])
    }
}

/// The distance between two points, metres.
fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// `n` sightings, a frame every 6 s at random places over 60 um
    /// square, of a map scaled `scale` and turned `turn_deg` about (50,
    /// 50) um and a drift `rate` (m/s), with 40 nm of noise and a fifth of
    /// the apexes pulled 0.1-0.3 um.
    fn sightings(scale: f64, turn_deg: f64, rate: [f64; 2], n: usize) -> Vec<MapSighting> {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let noise = Normal::new(0.0, 40e-9).unwrap();
        let (sin, cos) = turn_deg.to_radians().sin_cos();
        let g = [
            [scale * cos - 1.0, -scale * sin],
            [scale * sin, scale * cos - 1.0],
        ];
        (0..n)
            .map(|i| {
                let t_s = 6.0 * i as f64;
                let stage_m = [0, 1].map(|_| rng.random_range(20e-6..80e-6));
                let pull = if rng.random_range(0..5) == 0 {
                    rng.random_range(0.1e-6..0.3e-6)
                } else {
                    0.0
                };
                let d = [stage_m[0] - 50e-6, stage_m[1] - 50e-6];
                let offset_m = [0, 1].map(|k| {
                    g[k][0] * d[0] + g[k][1] * d[1] + rate[k] * t_s + noise.sample(&mut rng) + pull
                });
                MapSighting {
                    t_s,
                    stage_m,
                    offset_m,
                }
            })
            .collect()
    }

    fn fitted(s: &[MapSighting]) -> MapGradient {
        match fit_map(s, &MapFitSettings::default()) {
            MapFit::Fitted(g) => g,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_known_scale_and_turn_are_recovered_past_noise_pulled_apexes_and_drift() {
        // 11 sightings in the 60 s window.
        let g = fitted(&sightings(1.03, 2.0, [3e-9, -1e-9], 30));
        assert!((g.scale_fraction() - 0.03).abs() < 0.002, "{g:?}");
        assert!((g.rotation_rad().to_degrees() - 2.0).abs() < 0.15, "{g:?}");
        assert!(g.kept <= 11 && g.kept >= 7 && g.span_s <= 60.0, "{g:?}");
        let why = g.doubt(&MapFitSettings::default()).unwrap();
        let said = format!(
            "{:+.1} % in scale and {:+.1} deg turned",
            g.scale_fraction() * 100.0,
            g.rotation_rad().to_degrees()
        );
        assert!(why.contains(&said) && why.contains("11 sightings"), "{why}");
        assert!(
            why.contains("make it again (nanopush rig calibrate)"),
            "{why}"
        );
        // Said as every stop for the calibration says it (the stop is
        // typed where the loop makes it: Assembly::observe).
        assert!(why.contains(CALIBRATION_UNFIT), "{why}");
        // Two sightings, far apart, tell a scale 5 % short.
        let two = sightings(0.95, 0.0, [0.0, 0.0], 30);
        let far = [
            two[0],
            *two.iter()
                .find(|s| distance(s.stage_m, two[0].stage_m) > 40e-6)
                .unwrap(),
        ];
        let g = fitted(&far);
        assert!((g.scale_fraction() + 0.05).abs() < 0.01, "{g:?} {far:?}");
        assert!(g.doubt(&MapFitSettings::default()).is_some(), "{g:?}");
    }

    #[test]
    fn a_right_calibration_under_drift_is_not_doubted() {
        for rate in [[5e-9, 2e-9], [0.0, -5e-9]] {
            let g = fitted(&sightings(1.0, 0.0, rate, 30));
            assert_eq!(g.doubt(&MapFitSettings::default()), None, "{g:?}");
        }
        // Nor a scale error too small to matter across the travel.
        let small = fitted(&sightings(1.005, 0.0, [0.0, 0.0], 30));
        assert_eq!(small.doubt(&MapFitSettings::default()), None, "{small:?}");
    }

    #[test]
    fn degenerate_sightings_give_no_verdict() {
        let settings = MapFitSettings::default();
        let fit = |s: &[MapSighting]| fit_map(s, &settings);
        let scaled = sightings(1.05, 0.0, [0.0, 0.0], 30);
        assert_eq!(fit(&[]), MapFit::TooFew);
        assert_eq!(fit(&scaled[..1]), MapFit::TooFew);
        // All at one place, or all but within a few um.
        let at = |s: &MapSighting, stage_m| MapSighting { stage_m, ..*s };
        let one_place: Vec<_> = scaled.iter().map(|s| at(s, [50e-6, 50e-6])).collect();
        assert_eq!(fit(&one_place), MapFit::Narrow);
        let near: Vec<_> = scaled
            .iter()
            .map(|s| at(s, [s.stage_m[0] / 4.0, 5e-6]))
            .collect();
        assert_eq!(fit(&near), MapFit::Narrow);
        // Only the latest minute: an old sighting far away is not fitted.
        let mut old = one_place.clone();
        old[0].stage_m = [0.0, 0.0];
        assert_eq!(fit(&old), MapFit::Narrow);
        // Numbers that are not finite are left out, not fitted.
        let mut spoilt = scaled.clone();
        let last = spoilt.len() - 1;
        spoilt[last].offset_m[0] = f64::NAN;
        spoilt[last - 1].t_s = f64::INFINITY;
        spoilt[last - 2].stage_m[1] = f64::NAN;
        let g = fitted(&spoilt);
        assert!((g.scale_fraction() - 0.05).abs() < 0.003, "{g:?}");
        assert!(g.size().is_finite() && g.change_m().is_finite());
    }
}
