//! `nanopush detect`: particles and the probe tip in one frame.

use std::path::PathBuf;

use super::distinct_outputs::{flagged, given, prepare_outputs};

use anyhow::Context;
use clap::ValueEnum;

use crate::calib::camera_map::CameraCalibration;
use crate::vision::analyse::{
    FrameAnalysis, PreparedFrame, analyse_frame, prepare_frame, report_camera_state,
};
use crate::vision::crocker_grier::{LocateParams, locate};
use crate::vision::detect::{DetectSettings, Locator, Polarity};
use crate::vision::detections_file::DetectionsFile;
use crate::vision::frame_input::{Channel, first_of_several, load_frame};
use crate::vision::overlay::draw_overlay;
use crate::vision::ring_edge::CentreEstimate;
use crate::vision::size_check::hint_doubt;
use crate::vision::tip::{TipSettings, detect_tip};

/// Arguments of `nanopush detect`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Frame: PNG, TIFF, BMP, JPEG, a video (first frame) or a folder (first image).
    pub frame: PathBuf,
    /// Pixel-to-stage calibration TOML: adds where each particle and the
    /// tip lie on the stage (x_um, y_um in --json; "at (x, y) um" in text).
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// Apparent particle diameter in pixels, ring included (default 17).
    #[arg(long, conflicts_with = "radius_um")]
    pub diameter_px: Option<f64>,
    /// Particle radius in micrometres (needs --calib).
    #[arg(long, requires = "calib")]
    pub radius_um: Option<f64>,
    /// Print the detections as JSON ("nanopush.detections/1").
    #[arg(long)]
    pub json: bool,
    /// Write an overlay PNG of what was found.
    #[arg(long)]
    pub overlay: Option<PathBuf>,
    /// Colour frames: luminance, red, green or blue.
    #[arg(long, default_value = "luminance")]
    pub channel: Channel,
    /// Sub-pixel locator. `profile-fit` is the detector (each candidate
    /// fitted, a ring kept only when the fit is a particle, a spot of enough
    /// mass kept at its centroid when its fit fails: "not fitted"); `crocker-grier`
    /// gives trackpy-comparable results (trackpy's `locate`: --diameter-px
    /// is its odd `diameter`, --polarity dark its `invert`; quality is its
    /// `mass`, r_px its radius of gyration). `pixel-peak`, `centroid` and
    /// `radial-symmetry` are for `study vision`: they only place every
    /// candidate above the threshold, noise included, skip particles within
    /// half a diameter of the frame's edge, and take neither --polarity nor
    /// --centre ring-edge.
    #[arg(long, value_enum, default_value = "profile-fit")]
    pub locator: LocatorArg,
    /// crocker-grier: minimum band-passed mass in frame counts (trackpy's
    /// `minmass`; default 0).
    #[arg(long)]
    pub minmass: Option<f64>,
    /// crocker-grier: minimum feature separation in px (default diameter + 1).
    #[arg(long)]
    pub separation_px: Option<f64>,
    /// Keep only dark-centred or bright-centred particles.
    #[arg(long, value_parser = ["dark", "bright"])]
    pub polarity: Option<String>,
    /// Do not look for the probe tip.
    #[arg(long)]
    pub no_tip: bool,
    /// Centre of ring-shaped (bright-field) particles: `profile` (the profile
    /// fit's, most precise on symmetric particles) or `ring-edge` (the centre
    /// of the dark ring, the particle's outline, where it differs
    /// significantly: asymmetric particles under oblique light).
    #[arg(long, value_enum, default_value = "profile")]
    pub centre: CentreArg,
}

/// CLI spelling of the centre estimates.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum CentreArg {
    Profile,
    RingEdge,
}

impl From<CentreArg> for CentreEstimate {
    fn from(arg: CentreArg) -> Self {
        match arg {
            CentreArg::Profile => CentreEstimate::Profile,
            CentreArg::RingEdge => CentreEstimate::RingEdge,
        }
    }
}

/// CLI spelling of the locators.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum LocatorArg {
    PixelPeak,
    Centroid,
    RadialSymmetry,
    ProfileFit,
    CrockerGrier,
}

impl LocatorArg {
    /// The detector's locator; `None` for crocker-grier, which is its own
    /// detector (vision::crocker_grier).
    fn detector_locator(self) -> Option<Locator> {
        match self {
            LocatorArg::PixelPeak => Some(Locator::PixelPeak),
            LocatorArg::Centroid => Some(Locator::Centroid),
            LocatorArg::RadialSymmetry => Some(Locator::RadialSymmetry),
            LocatorArg::ProfileFit => Some(Locator::ProfileFit),
            LocatorArg::CrockerGrier => None,
        }
    }
}

/// Particles by the Crocker-Grier mode, and the tip by nanopush's tip fit.
fn crocker_grier_analysis(
    frame: &crate::vision::frame::Frame,
    args: &Args,
    diameter_px: f64,
    tip_settings: Option<&TipSettings>,
) -> anyhow::Result<FrameAnalysis> {
    if !(diameter_px.fract() == 0.0 && diameter_px >= 3.0 && diameter_px % 2.0 == 1.0) {
        anyhow::bail!(
            "--locator crocker-grier needs --diameter-px as an odd whole number of pixels, \
             at least 3 (got {diameter_px}); when in doubt, round up"
        );
    }
    let params = LocateParams {
        minmass: args.minmass.unwrap_or(0.0),
        separation_px: args.separation_px,
        invert: args.polarity.as_deref() == Some("dark"),
        ..LocateParams::new(diameter_px as u32)
    };
    let PreparedFrame {
        frame,
        repaired_lines,
        exposure,
    } = prepare_frame(frame);
    let particles = locate(&frame, &params)
        .context("locating particles (crocker-grier)")?
        .into_iter()
        .map(Into::into)
        .collect();
    let tip = tip_settings.and_then(|t| detect_tip(&frame, t));
    Ok(FrameAnalysis {
        particles,
        tip,
        repaired_lines,
        exposure,
    })
}

/// The diameter hint in pixels for `--radius-um` at the calibration's
/// scale; an error names both when they give less than 2 px (a wrong
/// calibration or radius, not a diameter the user typed).
fn diameter_from_radius(radius_um: f64, m_per_px: f64) -> anyhow::Result<f64> {
    let diameter_px = 2.0 * radius_um * 1e-6 / m_per_px;
    anyhow::ensure!(
        radius_um.is_finite() && radius_um > 0.0 && diameter_px.is_finite() && diameter_px >= 2.0,
        "--radius-um {radius_um} at the calibration's {:.4e} um/px is a particle {diameter_px:.3} px across; \
         the detector needs at least 2 px: check --radius-um and the calibration",
        m_per_px * 1e6
    );
    Ok(diameter_px)
}

/// Detects and prints (text or JSON), optionally drawing an overlay.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(overlay) = &args.overlay {
        // Checked first: an unknown extension had failed to save only after
        // the whole detection, with nothing printed.
        if !image::ImageFormat::from_path(overlay).is_ok_and(|f| f.writing_enabled()) {
            anyhow::bail!(
                "--overlay {}: name a .png (or .tif, .bmp, .jpg) file to draw into",
                overlay.display()
            );
        }
        let inputs = given([
            Some(("FRAME", args.frame.as_path())),
            flagged("--calib", &args.calib),
        ]);
        prepare_outputs(&inputs, &[("--overlay", overlay)])?;
    }
    let frame = load_frame(&args.frame, args.channel)
        .with_context(|| format!("loading {}", args.frame.display()))?;
    if let Some(which) = first_of_several(&args.frame) {
        eprintln!("{}: detecting on {which}", args.frame.display());
    }
    let calib = match &args.calib {
        Some(p) => Some(
            CameraCalibration::load(p)
                .with_context(|| format!("loading calibration {}", p.display()))?,
        ),
        None => None,
    };
    let diameter_px = match (args.diameter_px, args.radius_um, &calib) {
        (Some(d), _, _) if !(d.is_finite() && d >= 2.0) => {
            anyhow::bail!("--diameter-px {d}: a particle's diameter hint must be at least 2 px")
        }
        (Some(d), _, _) => d,
        (None, Some(r), Some(c)) => diameter_from_radius(r, c.m_per_px())?,
        _ => {
            // Said, since a frame of particles 40 px across found 1 of 48
            // at the default without a word.
            let d = DetectSettings::default().diameter_px;
            eprintln!(
                "size hint: the default {d} px across (give --diameter-px, or --calib with --radius-um, for particles of another size)"
            );
            d
        }
    };
    let tip_settings = (!args.no_tip).then(TipSettings::default);
    let places_only = matches!(
        args.locator,
        LocatorArg::PixelPeak | LocatorArg::Centroid | LocatorArg::RadialSymmetry
    );
    let locator_name = args
        .locator
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_owned());
    // Named as given: "--polarity and --centre ring-edge" had answered
    // --centre ring-edge alone.
    let needs_fit: Vec<&str> = [
        ("--polarity", args.polarity.is_some()),
        (
            "--centre ring-edge",
            matches!(args.centre, CentreArg::RingEdge),
        ),
    ]
    .iter()
    .filter(|(_, given)| *given)
    .map(|(flag, _)| *flag)
    .collect();
    if places_only && !needs_fit.is_empty() {
        anyhow::bail!(
            "{} {} a fitted particle: --locator {locator_name} only places candidates (use --locator profile-fit)",
            needs_fit.join(" and "),
            if needs_fit.len() == 1 {
                "needs"
            } else {
                "need"
            }
        );
    }
    // Taken and ignored by the other locators before.
    if !matches!(args.locator, LocatorArg::CrockerGrier)
        && (args.minmass.is_some() || args.separation_px.is_some())
    {
        anyhow::bail!(
            "--minmass and --separation-px are crocker-grier's: --locator {locator_name} does not use them"
        );
    }
    let analysis = match args.locator.detector_locator() {
        Some(locator) => {
            let settings = DetectSettings {
                diameter_px,
                locator,
                polarity: match args.polarity.as_deref() {
                    Some("dark") => Some(Polarity::Dark),
                    Some("bright") => Some(Polarity::Bright),
                    _ => None,
                },
                centre: args.centre.into(),
                ..DetectSettings::default()
            };
            let analysis = analyse_frame(&frame, &settings, tip_settings.as_ref())
                .context("detecting particles")?;
            // Said, since a wrong hint fails quietly: twice the size found
            // "0 particles", a fifth of it 51 pieces of 5 rings.
            if locator == Locator::ProfileFit
                && let Some(doubt) =
                    hint_doubt(&prepare_frame(&frame).frame, &settings, &analysis.particles)
            {
                eprintln!("warning: {doubt}");
            }
            analysis
        }
        None if matches!(args.centre, CentreArg::RingEdge) => anyhow::bail!(
            "--centre ring-edge refines the detector's ring fits; --locator crocker-grier \
             reproduces trackpy and has no ring fit (use --locator profile-fit)"
        ),
        None => crocker_grier_analysis(&frame, &args, diameter_px, tip_settings.as_ref())?,
    };
    report_camera_state(
        &args.frame.display().to_string(),
        &analysis.repaired_lines,
        &analysis.exposure,
        frame.max_count(),
    );
    let FrameAnalysis { particles, tip, .. } = &analysis;
    if let Some(path) = &args.overlay {
        draw_overlay(&frame, particles, tip.as_ref())
            .save(path)
            .with_context(|| format!("writing overlay {}", path.display()))?;
    }
    let doc = DetectionsFile::new(&analysis, calib.as_ref());
    if args.json {
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!(
            "{}",
            crate::wording::counted(doc.particles.len(), "particle")
        );
        // With --calib, where each lies on the stage too.
        let on_stage = |x: Option<f64>, y: Option<f64>| match (x, y) {
            (Some(x), Some(y)) => format!("  at ({x:.3}, {y:.3}) um"),
            _ => String::new(),
        };
        for p in &doc.particles {
            println!(
                "  x {:9.3} px  y {:9.3} px  r {:6.2} px  sigma {:.3} px  quality {:7.1}{}{}{}",
                p.x_px,
                p.y_px,
                p.r_px,
                p.sigma_px,
                p.quality,
                on_stage(p.x_um, p.y_um),
                if p.edge_clipped {
                    "  (edge-clipped)"
                } else {
                    ""
                },
                if p.fitted { "" } else { "  (not fitted)" }
            );
        }
        // Said, since a failed spot fit's hint radius and nominal sigma
        // read as measurements.
        if doc.particles.iter().any(|p| !p.fitted) {
            let why = if places_only {
                format!("the {locator_name} locator only places particles")
            } else {
                "a spot whose fit failed, kept at its centroid".to_owned()
            };
            println!("not fitted: {why}; r is the size hint and sigma a nominal value");
        }
        match &doc.tip {
            Some(t) => println!(
                "tip: x {:.2} px  y {:.2} px  angle {:.2} deg  score {:.3}{}",
                t.x_px,
                t.y_px,
                t.angle_deg,
                t.score,
                on_stage(t.x_um, t.y_um)
            ),
            None => println!("tip: not found"),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The detector's locators are spelt one way: as `--locator` takes them,
    /// as tables print them and as JSON writes them.
    #[test]
    fn locators_are_spelt_as_the_flag_takes_them() {
        use clap::ValueEnum;
        for arg in LocatorArg::value_variants() {
            let Some(locator) = arg.detector_locator() else {
                continue;
            };
            let flag = arg.to_possible_value().unwrap().get_name().to_owned();
            assert_eq!(locator.to_string(), flag);
            assert_eq!(
                serde_json::to_string(&locator).unwrap(),
                format!("\"{flag}\"")
            );
        }
    }
}
