//! Particle detection: candidates where the band-passed frame holds more
//! energy than its measured noise allows, then sub-pixel location by the
//! chosen locator (pixel peak, centroid, radial symmetry, or profile fit).
//!
//! The energy (local mean of the squared band-pass) responds to rings and spots
//! of either contrast alike; its threshold is in units of the frame's own noise,
//! so it does not depend on bit depth, gain or exposure.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::band_noise;
use super::filter::{
    bin_frame, box_mean_in_place, box_mean_into, local_extrema_both, local_maxima,
};
use super::frame::Frame;
use super::frame_pool::{self, WorkBuffer};
use super::noise::{MIN_NOISE_COUNTS, estimate_noise_sigma};
use super::poor_fits::drop_poor_overlapping_fits;
use super::profile_fit::{ProfileModel, fit_particle, fit_particle_among};
use super::radial_symmetry::radial_symmetry_centre;
use super::ring_edge::{CentreEstimate, recentre_on_ring_edges};
use super::roi::RoiMask;

/// How a candidate's sub-pixel centre is found (the study compares them).
///
/// Spelt as `detect --locator` takes it (`pixel-peak`) in tables and JSON
/// alike: the study's table said `PixelPeak` and its JSON `pixel_peak`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Locator {
    /// Integer position of the energy peak (what a Hough/peak finder gives).
    PixelPeak,
    /// Centroid of the absolute band-passed intensity (trackpy-like).
    Centroid,
    /// Radial-symmetry centre (Parthasarathy 2012).
    RadialSymmetry,
    /// Least-squares profile fit started from the radial-symmetry centre.
    ProfileFit,
}

impl std::fmt::Display for Locator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Locator::PixelPeak => "pixel-peak",
            Locator::Centroid => "centroid",
            Locator::RadialSymmetry => "radial-symmetry",
            Locator::ProfileFit => "profile-fit",
        })
    }
}

impl Locator {
    /// Every locator shipped, coarsest first.
    pub const ALL: [Locator; 4] = [
        Locator::PixelPeak,
        Locator::Centroid,
        Locator::RadialSymmetry,
        Locator::ProfileFit,
    ];
}

/// Detection parameters; physical meaning, documented defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectSettings {
    /// Apparent particle diameter in pixels (the size hint), ring included.
    pub diameter_px: f64,
    /// Intensity model; `None` picks ring for diameters >= 10 px, else spot.
    pub model: Option<ProfileModel>,
    /// Candidate threshold: energy excess in standard deviations of the noise energy.
    pub threshold_sigma: f64,
    /// Minimum fitted contrast-to-noise ratio to report a particle.
    pub min_snr: f64,
    /// Sub-pixel locator.
    pub locator: Locator,
    /// Optional region of interest.
    pub roi: Option<RoiMask>,
    /// Keep only particles whose centre is darker (`Dark`) or brighter
    /// (`Bright`) than the background; `None` keeps both.
    pub polarity: Option<Polarity>,
    /// Minimum centre-to-centre distance between reported particles, pixels:
    /// of two closer ones only the more significant is kept (trackpy's
    /// `separation`, by default its `diameter + 1`). `None` keeps the
    /// locator's own merge distance; set it to compare against a tool that
    /// was run with a given separation.
    pub min_separation_px: Option<f64>,
    /// Centre reported for ring-model particles: the profile centre, or the
    /// centre of the outline where an asymmetric particle's differs
    /// (`ring_edge`). Default: profile.
    pub centre: CentreEstimate,
}

/// Contrast of a particle's centre against the background.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Polarity {
    /// Centre darker than the background (dark spots, inverted rings).
    Dark,
    /// Centre brighter than the background (fluorescence, bright-core rings).
    Bright,
}

impl Default for DetectSettings {
    fn default() -> Self {
        Self {
            diameter_px: 17.0,
            model: None,
            threshold_sigma: 6.0,
            min_snr: 3.0,
            locator: Locator::ProfileFit,
            roi: None,
            polarity: None,
            min_separation_px: None,
            centre: CentreEstimate::Profile,
        }
    }
}

/// Ways detection refuses to run.
#[derive(Debug, Error, PartialEq)]
pub enum DetectError {
    /// The size hint is not a finite diameter of at least 2 px.
    #[error("particle diameter hint {0} px must be finite and >= 2")]
    Diameter(f64),
    /// The frame is smaller than one particle.
    #[error("frame {width}x{height} is smaller than a particle of {diameter:.1} px")]
    FrameTooSmall {
        width: usize,
        height: usize,
        diameter: f64,
    },
}

/// One detected particle, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Centre x in pixels.
    pub x_px: f64,
    /// Centre y in pixels.
    pub y_px: f64,
    /// Radius in pixels (ring radius, or 1/e^2 radius for spots).
    pub r_px: f64,
    /// 1-sigma centre uncertainty per axis in pixels.
    pub sigma_px: f64,
    /// Detection SNR (fitted contrast over residual noise, or energy SNR).
    pub quality: f64,
    /// True when the particle is cut by the frame edge.
    pub edge_clipped: bool,
    /// True when `r_px` and `sigma_px` were measured (a fit, or trackpy's
    /// moments); false when `r_px` is the size hint and `sigma_px` a nominal
    /// value: the pixel-peak, centroid and radial-symmetry locators, and a
    /// dim spot whose fit failed, kept at its centroid as trackpy keeps it.
    pub fitted: bool,
}

/// Smallest size hint, px across, fitted with the ring model when none is
/// chosen; smaller particles are fitted as spots.
pub const RING_MODEL_MIN_DIAMETER_PX: f64 = 10.0;

/// The model a size hint implies when none is chosen.
pub fn model_for(settings: &DetectSettings) -> ProfileModel {
    settings
        .model
        .unwrap_or(if settings.diameter_px >= RING_MODEL_MIN_DIAMETER_PX {
            ProfileModel::Ring
        } else {
            ProfileModel::Spot
        })
}

/// A candidate: integer peak of the energy map and its energy SNR.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Peak x (integer pixel).
    pub x: usize,
    /// Peak y (integer pixel).
    pub y: usize,
    /// Energy excess over the noise energy, in its standard deviations.
    pub snr: f64,
}

/// The band-passed frame and its noise, shared by the locators.
struct Bandpass {
    values: WorkBuffer,
    /// Width and height of the frame filtered (the binned one, when searched binned).
    size: (usize, usize),
    noise_var: f64,
    /// Per-pixel noise of the raw frame, counts.
    noise_sigma: f64,
    /// The white estimate is at the quantisation floor: the frame has no
    /// pixel noise (a lossy codec smoothed it away, or a clean render).
    white_at_floor: bool,
    /// A frame-sized work buffer the energy map reuses.
    work: WorkBuffer,
}

/// `noise_floor`: a band-pass noise variance measured on the frame's
/// background ([`band_noise`]), which the white estimate's cannot go under.
fn bandpass(frame: &Frame, diameter: f64, noise_floor: Option<f64>) -> Bandpass {
    let (w, h) = (frame.width(), frame.height());
    // Two full-frame buffers in all, from the pool (see `frame_pool`).
    let mut values = frame_pool::take(w * h);
    let mut bg = frame_pool::take(w * h);
    box_mean_into(frame.pixels(), &mut values, w, h, 1);
    let bg_r = diameter.ceil() as usize;
    box_mean_into(frame.pixels(), &mut bg, w, h, bg_r);
    for (v, b) in values.iter_mut().zip(bg.iter()) {
        *v -= b;
    }
    let big = ((2 * bg_r + 1) as f64).powi(2);
    // White noise through (3x3 mean - big mean): sum of squared kernel weights.
    let gain = 1.0 / 9.0 - 1.0 / big;
    let white_sigma = estimate_noise_sigma(frame);
    let white_var = white_sigma.powi(2) * gain;
    let noise_var = white_var.max(noise_floor.unwrap_or(0.0));
    Bandpass {
        values,
        size: (w, h),
        noise_var,
        // The white noise per pixel that would pass the filter as this does.
        noise_sigma: (noise_var / gain).sqrt(),
        white_at_floor: white_sigma <= MIN_NOISE_COUNTS,
        work: bg,
    }
}

/// Candidates: local maxima of the band-pass energy above the noise
/// threshold, in full-frame pixels (searched on the 2x2-binned frame when
/// [`searches_binned`] holds, as detection does).
pub fn find_candidates(
    frame: &Frame,
    settings: &DetectSettings,
) -> Result<Vec<Candidate>, DetectError> {
    check(frame, settings)?;
    let mut search = CandidateSearch::run(frame, settings, None);
    search.cands.truncate(search.n_energy);
    Ok(search.cands)
}

/// Smallest size hint, pixels, whose candidates are searched on the 2x2-binned
/// frame. The candidates only start the fits (sub-pixel work is on the full
/// frame), and a particle 14 px across is still 7 binned pixels across, where
/// the band-pass, energy and extremum windows (0.3 diameter: 2 binned pixels)
/// keep touching particles apart; binning averages 4 pixels, so the per-pixel
/// noise halves with the signal unchanged. The search reads and writes a
/// quarter of the pixels: it was ~45 % of a 1024x1024 frame's time.
pub const BINNED_SEARCH_MIN_DIAMETER_PX: f64 = 14.0;

/// True when detection searches candidates on the 2x2-binned frame: ring
/// profile fits of particles at least [`BINNED_SEARCH_MIN_DIAMETER_PX`] across.
/// The pixel-peak and centroid locators and the spot model read the
/// band-pass itself at full resolution, so they search the full frame.
pub fn searches_binned(settings: &DetectSettings) -> bool {
    fits_rings(settings) && settings.diameter_px >= BINNED_SEARCH_MIN_DIAMETER_PX
}

/// True when each candidate is fitted with the ring model: only then are
/// ring cores candidates, and touching rings refitted.
fn fits_rings(settings: &DetectSettings) -> bool {
    settings.locator == Locator::ProfileFit && model_for(settings) == ProfileModel::Ring
}

/// The candidate search: energy candidates first (`n_energy` of them), then
/// ring cores (ring model, profile fit), in full-frame pixels, and the band-pass of the
/// frame searched (the binned one when `binned`).
struct CandidateSearch {
    cands: Vec<Candidate>,
    n_energy: usize,
    bp: Bandpass,
    binned: bool,
}

impl CandidateSearch {
    fn run(frame: &Frame, settings: &DetectSettings, noise_floor: Option<f64>) -> Self {
        if !searches_binned(settings) {
            let mut bp = bandpass(frame, settings.diameter_px, noise_floor);
            let mut cands = candidates_from(frame, settings, &mut bp);
            let n_energy = cands.len();
            // Cores only where a fit follows: most are arcs of a ring (485
            // of 656 on the bench frame), which a fit merges or rejects but
            // the pixel peak, centroid and radial-symmetry locators would
            // report as particles (precision 0.20-0.30 at SNR 4).
            if fits_rings(settings) {
                let taken = 0.25 * settings.diameter_px;
                add_core_candidates(
                    &mut cands,
                    &bp,
                    (frame.width(), frame.height()),
                    settings,
                    taken,
                );
            }
            return Self {
                cands,
                n_energy,
                bp,
                binned: false,
            };
        }
        let (w, h) = (frame.width(), frame.height());
        let small = &bin_frame(frame);
        let (bw, bh) = (small.width(), small.height());
        // What the search reads of the settings, at half the size.
        let half = DetectSettings {
            diameter_px: 0.5 * settings.diameter_px,
            threshold_sigma: settings.threshold_sigma,
            polarity: settings.polarity,
            model: Some(ProfileModel::Ring),
            ..DetectSettings::default()
        };
        let mut bp = bandpass(small, half.diameter_px, noise_floor);
        let mut cands = candidates_from(small, &half, &mut bp);
        let n_energy = cands.len();
        // No core is dropped for lying near an energy candidate: on the
        // 2-px grid the quarter-diameter test of the full search flips at
        // its edge (a touching sphere's core 11 px from the energy maximum
        // between two spheres, 40 px spheres, was dropped at 4.5 binned px).
        // Cores of particles already found are still skipped before any
        // fit (`explained` in the caller).
        add_core_candidates(&mut cands, &bp, (bw, bh), &half, 0.0);
        // A binned pixel covers full pixels 2x and 2x + 1: its centre is
        // 2x + 0.5, taken as 2x + 1 (the radial-symmetry start and the fit
        // move half a pixel at once).
        for c in &mut cands {
            c.x = (2 * c.x + 1).min(w - 1);
            c.y = (2 * c.y + 1).min(h - 1);
        }
        Self {
            cands,
            n_energy,
            bp,
            binned: true,
        }
    }
}

fn candidates_from(frame: &Frame, settings: &DetectSettings, bp: &mut Bandpass) -> Vec<Candidate> {
    let (w, h) = (frame.width(), frame.height());
    // A window of 0.3 diameter keeps crowded neighbours separate maxima; a ring
    // may give several (core and ring), which fit to one centre and are merged.
    // A locator without a fit has only these maxima and no ring cores: it
    // needs the whole ring in the window (0.5 diameter) for its maximum to
    // sit at the centre (at 0.3 the pixel peak's centre RMS was 2.6 px
    // against 0.3 px, its maxima on the ring).
    let no_fit = settings.locator != Locator::ProfileFit;
    let frac = if no_fit && model_for(settings) == ProfileModel::Ring {
        0.5
    } else {
        0.3
    };
    let r = (frac * settings.diameter_px).round().max(1.0) as usize;
    // Without a fit, a maximum whose window leaves the frame is not taken:
    // the band-pass's edges made maxima in the frame's corners (8 of 88
    // pixel-peak detections at SNR 32), which a fit rejects and nothing else
    // does, and a particle the edge cuts has no centre these locators find.
    let inside = |i: usize| {
        let (x, y) = (i % w, i / w);
        !no_fit || (x >= r && y >= r && x + r < w && y + r < h)
    };
    // Energy: local mean of the squared band-pass (in a reused work frame).
    let energy = &mut bp.work;
    for (e, v) in energy.iter_mut().zip(bp.values.iter()) {
        *e = v * v;
    }
    box_mean_in_place(energy, w, h, r);
    let n_eff = (((2 * r + 1) * (2 * r + 1)) as f64 / 9.0).max(1.0);
    let noise_e = bp.noise_var.max(1e-12);
    let e_sd = noise_e * (2.0 / n_eff).sqrt();
    let threshold = (noise_e + settings.threshold_sigma * e_sd) as f32;
    let sat = frame.max_count();
    local_maxima(energy, w, h, r, threshold)
        .into_iter()
        .filter(|&i| !(frame.pixels()[i] >= sat && bp.values[i] == 0.0) && inside(i))
        .map(|i| Candidate {
            x: i % w,
            y: i / w,
            snr: (energy[i] as f64 - noise_e) / e_sd,
        })
        .collect()
}

/// Ring cores as candidates too: in a cluster of touching rings the energy's
/// maxima sit between particles, but each core stays a local extremum of the
/// band-passed frame (bright or dark by polarity). Cores within `taken_px`
/// of an energy candidate add nothing and are skipped.
fn add_core_candidates(
    out: &mut Vec<Candidate>,
    bp: &Bandpass,
    (w, h): (usize, usize),
    settings: &DetectSettings,
    taken_px: f64,
) {
    let r = (0.3 * settings.diameter_px).round().max(1.0) as usize;
    let sd = bp.noise_var.max(1e-12).sqrt();
    let threshold = (settings.threshold_sigma * sd) as f32;
    let [maxima, minima] = local_extrema_both(&bp.values, w, h, r, threshold);
    let by_sign = match settings.polarity {
        Some(Polarity::Bright) => vec![(1.0f32, maxima)],
        Some(Polarity::Dark) => vec![(-1.0, minima)],
        None => vec![(1.0, maxima), (-1.0, minima)],
    };
    let edge = r.min(w / 2).min(h / 2);
    let inside = |x: usize, y: usize| x >= edge && y >= edge && x + edge < w && y + edge < h;
    let near2 = taken_px.powi(2);
    for (sign, extrema) in by_sign {
        for i in extrema {
            let (x, y) = (i % w, i / w);
            let taken = out
                .iter()
                .any(|c| (c.x as f64 - x as f64).powi(2) + (c.y as f64 - y as f64).powi(2) < near2);
            if inside(x, y) && !taken {
                out.push(Candidate {
                    x,
                    y,
                    snr: (sign * bp.values[i]) as f64 / sd,
                });
            }
        }
    }
}

/// Candidates between `near` and `far` pixels from `c`: other particles whose
/// pixels reach into its fit window. (A particle can give several candidates,
/// on its core and on its ring, so `near` is a trade-off; see the caller.)
fn neighbour_candidates(
    cands: &[Candidate],
    c: &Candidate,
    near: f64,
    far: f64,
) -> Vec<(f64, f64)> {
    cands
        .iter()
        .map(|o| (o.x as f64, o.y as f64))
        .filter(|&(x, y)| {
            // Squared: libm's hypot for every pair was 1.6 % of a frame.
            let d2 = (x - c.x as f64).powi(2) + (y - c.y as f64).powi(2);
            d2 >= near * near && d2 <= far * far
        })
        .collect()
}

fn check(frame: &Frame, settings: &DetectSettings) -> Result<(), DetectError> {
    let d = settings.diameter_px;
    if !d.is_finite() || d < 2.0 {
        return Err(DetectError::Diameter(d));
    }
    if (frame.width() as f64) < d || (frame.height() as f64) < d {
        return Err(DetectError::FrameTooSmall {
            width: frame.width(),
            height: frame.height(),
            diameter: d,
        });
    }
    Ok(())
}

fn centroid(bp: &Bandpass, w: usize, h: usize, c: &Candidate, r: usize) -> (f64, f64) {
    let (mut sx, mut sy, mut s) = (0.0, 0.0, 0.0);
    let (x0, x1) = (c.x.saturating_sub(r), (c.x + r).min(w - 1));
    let (y0, y1) = (c.y.saturating_sub(r), (c.y + r).min(h - 1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            let v = bp.values[y * w + x].abs() as f64;
            sx += v * x as f64;
            sy += v * y as f64;
            s += v;
        }
    }
    if s > 0.0 {
        (sx / s, sy / s)
    } else {
        (c.x as f64, c.y as f64)
    }
}

/// Integrated band-passed intensity over the disc of radius `radius_px`
/// around (cx, cy) (trackpy's "mass"), and the number of pixels summed.
fn disc_mass(bp: &Bandpass, w: usize, h: usize, cx: f64, cy: f64, radius_px: f64) -> (f64, usize) {
    let x0 = (cx - radius_px).floor().max(0.0) as usize;
    let y0 = (cy - radius_px).floor().max(0.0) as usize;
    let x1 = ((cx + radius_px).ceil() as usize).min(w - 1);
    let y1 = ((cy + radius_px).ceil() as usize).min(h - 1);
    let (mut sum, mut n) = (0.0, 0usize);
    for y in y0..=y1 {
        for x in x0..=x1 {
            if (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) <= radius_px * radius_px {
                sum += bp.values[y * w + x] as f64;
                n += 1;
            }
        }
    }
    (sum, n)
}

/// Mass significance of a spot: its integrated contrast (signed for the
/// wanted polarity, either sign when none is wanted) over the noise of a sum
/// of `n` pixels, so the acceptance rule is in units of the frame's noise.
fn mass_snr(bp: &Bandpass, mass: f64, n: usize, polarity: Option<Polarity>) -> f64 {
    let signed = match polarity {
        Some(Polarity::Dark) => -mass,
        Some(Polarity::Bright) => mass,
        None => mass.abs(),
    };
    signed / (bp.noise_sigma * (n.max(1) as f64).sqrt())
}

fn polarity_ok(centre_contrast: f64, polarity: Option<Polarity>) -> bool {
    match polarity {
        Some(Polarity::Dark) => centre_contrast < 0.0,
        Some(Polarity::Bright) => centre_contrast > 0.0,
        None => true,
    }
}

/// Detects particles with the chosen locator. An empty frame gives no detections.
pub fn detect_particles(
    frame: &Frame,
    settings: &DetectSettings,
) -> Result<Vec<Detection>, DetectError> {
    detect_particles_excluding(frame, settings, &|_, _| false)
}

/// As [`detect_particles`], skipping candidates where `exclude(x, y)` holds
/// before any sub-pixel work (e.g. on the probe silhouette's edges).
pub fn detect_particles_excluding(
    frame: &Frame,
    settings: &DetectSettings,
    exclude: &dyn Fn(f64, f64) -> bool,
) -> Result<Vec<Detection>, DetectError> {
    check(frame, settings)?;
    let (found, bp) = detect_at_noise(frame, settings, exclude, None);
    Ok(
        match correlated_noise_var(frame, &found, &bp, settings, exclude) {
            Some(floor) => detect_at_noise(frame, settings, exclude, Some(floor)).0,
            None => found,
        },
    )
}

/// The band-pass noise variance on the background between `found`, when
/// it stands above the white estimate's by [`band_noise::CORRELATED_NOISE_RATIO`]
/// (in the search's own pixels: the binned frame's when it searched binned).
fn correlated_noise_var(
    frame: &Frame,
    found: &[Detection],
    bp: &Bandpass,
    settings: &DetectSettings,
    exclude: &dyn Fn(f64, f64) -> bool,
) -> Option<f64> {
    let scale = if searches_binned(settings) { 0.5 } else { 1.0 };
    let half_diameter = 0.5 * settings.diameter_px;
    // Half a diameter beyond each particle's ring: its halo stays out.
    let discs: Vec<band_noise::Disc> = found
        .iter()
        .map(|d| {
            let r = d.r_px.max(half_diameter) + half_diameter;
            (d.x_px * scale, d.y_px * scale, r * scale + 1.0)
        })
        .collect();
    let lag = (settings.diameter_px * scale).round().max(3.0) as usize;
    // The probe and clipped pixels are left out too: their edges are the
    // frame's largest steps, which the differences' tail (`Reading::Tail`)
    // would take for noise.
    let (w, h) = (frame.width(), frame.height());
    let sat = frame.max_count();
    let clipped = |x: f64, y: f64| {
        let (i, j) = (x.max(0.0) as usize, y.max(0.0) as usize);
        i < w && j < h && frame.at(i, j) >= sat
    };
    let excluded = |x: f64, y: f64| {
        let (x, y) = (x / scale, y / scale);
        exclude(x, y) || clipped(x, y)
    };
    let reading = if bp.white_at_floor {
        band_noise::Reading::Tail
    } else {
        band_noise::Reading::Median
    };
    let var =
        band_noise::background_band_var(&bp.values, bp.size, &discs, &excluded, lag, reading)?;
    (var > band_noise::CORRELATED_NOISE_RATIO.powi(2) * bp.noise_var).then_some(var)
}

/// One detection with the band-pass noise at least `noise_floor`, and the
/// band-pass searched.
fn detect_at_noise(
    frame: &Frame,
    settings: &DetectSettings,
    exclude: &dyn Fn(f64, f64) -> bool,
    noise_floor: Option<f64>,
) -> (Vec<Detection>, Bandpass) {
    let (w, h) = (frame.width(), frame.height());
    let CandidateSearch {
        cands,
        n_energy,
        bp,
        binned,
    } = CandidateSearch::run(frame, settings, noise_floor);
    let radius = 0.5 * settings.diameter_px;
    let r_int = radius.round().max(1.0) as usize;
    let model = model_for(settings);
    // Spots accepted on mass are hard spheres: two closer than one diameter
    // are one particle seen twice (its halo, a noise peak). Fitted rings
    // likewise: two closer than 0.6 diameter overlap by 40 %, which spheres on
    // a substrate cannot (0.6, not 1.0, leaves room for a loose size hint).
    let merge_px = match (settings.locator, model) {
        (Locator::ProfileFit, ProfileModel::Spot) => settings.diameter_px,
        (Locator::ProfileFit, ProfileModel::Ring) => 0.6 * settings.diameter_px,
        _ => 0.5 * radius,
    };
    let explained = |out: &[Detection], x: f64, y: f64| {
        out.iter()
            .any(|o| (o.x_px - x).powi(2) + (o.y_px - y).powi(2) < merge_px.powi(2))
    };
    let mut out: Vec<Detection> = Vec::with_capacity(cands.len());
    for (k, c) in cands.iter().enumerate() {
        let coarse = (c.x as f64, c.y as f64);
        // A core candidate inside a particle already found is its ring's
        // dark (or bright) arc: it could only be merged into that particle,
        // and never replaces it, so it is not fitted (most core candidates
        // are such arcs: 485 of 656 candidates on the 100-sphere bench frame).
        if k >= n_energy && explained(&out, coarse.0, coarse.1) {
            continue;
        }
        if exclude(coarse.0, coarse.1)
            || settings
                .roi
                .as_ref()
                .is_some_and(|r| !r.contains(coarse.0, coarse.1))
        {
            continue;
        }
        let rs = || radial_symmetry_centre(frame, coarse.0, coarse.1, r_int + 2).unwrap_or(coarse);
        let (x, y, r, sigma, quality, fitted) = match settings.locator {
            Locator::PixelPeak => (coarse.0, coarse.1, radius, 0.5, c.snr, false),
            Locator::Centroid => {
                debug_assert!(!binned, "the centroid reads the full-frame band-pass");
                let (x, y) = centroid(&bp, w, h, c, r_int);
                (x, y, radius, 0.5, c.snr, false)
            }
            Locator::RadialSymmetry => {
                let (x, y) = rs();
                (x, y, radius, 0.25, c.snr, false)
            }
            Locator::ProfileFit if model == ProfileModel::Spot => {
                // Spots (a few pixels across) are accepted on their mass
                // significance, as trackpy does, not on the fit: the fit only
                // places them, and a dim spot whose fit fails keeps its centroid.
                debug_assert!(!binned, "spot masses read the full-frame band-pass");
                let (xc, yc) = centroid(&bp, w, h, c, r_int);
                let (mass, n) = disc_mass(&bp, w, h, xc, yc, radius);
                let snr = mass_snr(&bp, mass, n, settings.polarity);
                if snr < settings.threshold_sigma {
                    continue;
                }
                match fit_particle(frame, xc, yc, radius, model) {
                    Ok(f) if polarity_ok(f.centre_contrast, settings.polarity) => {
                        (f.x_px, f.y_px, f.r_px, f.sigma_px, snr, true)
                    }
                    _ => (xc, yc, radius, 0.5, snr, false),
                }
            }
            Locator::ProfileFit => {
                let (x0, y0) = rs();
                let d = settings.diameter_px;
                // Touching particles pull their candidates towards each other:
                // when the fit fails, cut the window at the bisectors of nearby
                // candidates (`refine_touching` redoes it with the found centres).
                let fitted = fit_particle(frame, x0, y0, radius, model).or_else(|_| {
                    fit_particle_among(
                        frame,
                        c.x as f64,
                        c.y as f64,
                        radius,
                        model,
                        &neighbour_candidates(&cands, c, 0.45 * d, 1.6 * d),
                    )
                });
                match fitted {
                    Ok(f)
                        if f.snr >= settings.min_snr
                            && polarity_ok(f.centre_contrast, settings.polarity) =>
                    {
                        (f.x_px, f.y_px, f.r_px, f.sigma_px, f.snr, true)
                    }
                    _ => continue,
                }
            }
        };
        if !(x.is_finite() && y.is_finite() && r.is_finite() && sigma.is_finite()) {
            continue;
        }
        if x < -0.5 || y < -0.5 || x > w as f64 - 0.5 || y > h as f64 - 0.5 {
            continue;
        }
        if let Some(roi) = &settings.roi
            && !roi.contains(x, y)
        {
            continue;
        }
        let edge = r.max(radius) + 1.0;
        let edge_clipped =
            x < edge || y < edge || x > w as f64 - 1.0 - edge || y > h as f64 - 1.0 - edge;
        let d = Detection {
            x_px: x,
            y_px: y,
            r_px: r,
            sigma_px: sigma,
            quality,
            edge_clipped,
            fitted,
        };
        // Two candidates that converged on one particle: keep the better.
        if let Some(prev) = out
            .iter_mut()
            .find(|o| (o.x_px - x).powi(2) + (o.y_px - y).powi(2) < merge_px.powi(2))
        {
            // A core candidate only fills in where the energy candidates found nothing.
            if d.quality > prev.quality && k < n_energy {
                *prev = d;
            }
            continue;
        }
        out.push(d);
    }
    if let Some(sep) = settings.min_separation_px {
        keep_separated(&mut out, sep);
    }
    if fits_rings(settings) {
        refine_touching(frame, &mut out, radius, settings);
        // Neighbours of a dropped phantom had their windows cut by it.
        if drop_poor_overlapping_fits(&mut out) > 0 {
            refine_touching(frame, &mut out, radius, settings);
        }
    }
    if settings.centre == CentreEstimate::RingEdge && model == ProfileModel::Ring {
        recentre_on_ring_edges(frame, &mut out, bp.noise_sigma);
    }
    (out, bp)
}

/// Keeps, most significant first, only particles at least `separation_px`
/// from every particle already kept (trackpy's `drop_close`, ranked by
/// quality instead of peak brightness). Order of the survivors is preserved.
fn keep_separated(found: &mut Vec<Detection>, separation_px: f64) {
    if !(separation_px.is_finite() && separation_px > 0.0) {
        return;
    }
    let mut order: Vec<usize> = (0..found.len()).collect();
    order.sort_by(|&a, &b| found[b].quality.total_cmp(&found[a].quality));
    let sep2 = separation_px * separation_px;
    let mut keep = vec![false; found.len()];
    let mut kept: Vec<(f64, f64)> = Vec::with_capacity(found.len());
    for i in order {
        let (x, y) = (found[i].x_px, found[i].y_px);
        if kept
            .iter()
            .all(|&(kx, ky)| (kx - x).powi(2) + (ky - y).powi(2) >= sep2)
        {
            keep[i] = true;
            kept.push((x, y));
        }
    }
    let mut k = keep.iter();
    found.retain(|_| *k.next().unwrap_or(&false));
}

/// The centres other than `centres[i]` closer than `reach` (px) to it.
pub(crate) fn neighbours_within(centres: &[(f64, f64)], i: usize, reach: f64) -> Vec<(f64, f64)> {
    let (x, y) = centres[i];
    centres
        .iter()
        .enumerate()
        .filter(|&(j, c)| j != i && (c.0 - x).powi(2) + (c.1 - y).powi(2) < reach * reach)
        .map(|(_, &c)| c)
        .collect()
}

/// Refits every ring with a neighbour closer than 1.25 diameters on a window cut
/// at the bisectors of the neighbours' found centres: a one-sphere model cannot
/// explain a neighbour's core and ring, and touching is what an assembled
/// pattern is made of. A refit that fails or jumps keeps the first fit.
fn refine_touching(frame: &Frame, found: &mut [Detection], radius: f64, settings: &DetectSettings) {
    let reach = 1.25 * settings.diameter_px;
    let centres: Vec<(f64, f64)> = found.iter().map(|d| (d.x_px, d.y_px)).collect();
    for (i, d) in found.iter_mut().enumerate() {
        let neighbours = neighbours_within(&centres, i, reach);
        if neighbours.is_empty() {
            continue;
        }
        if let Ok(f) = fit_particle_among(
            frame,
            d.x_px,
            d.y_px,
            radius,
            ProfileModel::Ring,
            &neighbours,
        ) && f.snr >= settings.min_snr
            && (f.x_px - d.x_px).hypot(f.y_px - d.y_px) < 0.5 * radius
        {
            d.x_px = f.x_px;
            d.y_px = f.y_px;
            d.sigma_px = f.sigma_px;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(x_px: f64, y_px: f64, quality: f64) -> Detection {
        Detection {
            x_px,
            y_px,
            r_px: 3.0,
            sigma_px: 0.1,
            quality,
            edge_clipped: false,
            fitted: true,
        }
    }

    #[test]
    fn keep_separated_keeps_the_more_significant_of_close_pairs_in_order() {
        // 0 and 1 are 10 px apart (1 wins), 2 is 10 px from 1 but 20 from 0,
        // 3 is far from all; survivors keep their input order.
        let mut found = vec![
            det(0.0, 0.0, 5.0),
            det(10.0, 0.0, 9.0),
            det(20.0, 0.0, 4.0),
            det(100.0, 0.0, 1.0),
        ];
        keep_separated(&mut found, 12.0);
        let xs: Vec<f64> = found.iter().map(|d| d.x_px).collect();
        assert_eq!(xs, vec![10.0, 100.0]);
    }

    #[test]
    fn keep_separated_keeps_pairs_at_exactly_the_separation_and_ignores_bad_values() {
        let mut found = vec![det(0.0, 0.0, 1.0), det(12.0, 0.0, 2.0)];
        keep_separated(&mut found, 12.0);
        assert_eq!(found.len(), 2);
        let mut close = vec![det(0.0, 0.0, 1.0), det(1.0, 0.0, 2.0)];
        keep_separated(&mut close, f64::NAN);
        keep_separated(&mut close, -1.0);
        assert_eq!(close.len(), 2);
    }
}
