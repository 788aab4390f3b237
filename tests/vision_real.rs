//! Real frames (fixtures/real, see PROVENANCE.md): bright-field rings against an
//! independent ring fit; dark spots against trackpy's `locate`, both with
//! nanopush's Crocker-Grier mode (the reference calls' own parameters) and
//! with nanopush's own detector.

use std::path::{Path, PathBuf};

use nanopush::vision::crocker_grier::{LocateParams, locate};
use nanopush::vision::detect::{DetectSettings, detect_particles};
use nanopush::vision::frame_input::{Channel, load_frame, load_frames};
use nanopush::vision::matching::match_points;
use nanopush::vision::ring_edge::CentreEstimate;

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/real")
        .join(rel)
}

/// Rows of a reference CSV (comment and header lines skipped), as numbers.
fn read_csv_rows(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('x'))
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

fn read_csv_xy(path: &Path) -> Vec<[f64; 2]> {
    read_csv_rows(path).iter().map(|f| [f[0], f[1]]).collect()
}

#[test]
fn brightfield_exactly_five_particles_in_every_frame() {
    for name in ["bf_0000", "bf_0025", "bf_0049"] {
        let frame = load_frame(
            &fixture(&format!("brightfield/{name}.png")),
            Channel::Luminance,
        )
        .unwrap();
        let found = detect_particles(&frame, &DetectSettings::default()).unwrap();
        let reference = read_csv_xy(&fixture(&format!("reference/{name}.ringfit.csv")));
        let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
        assert_eq!(found.len(), 5, "{name}");
        assert_eq!(match_points(&reference, &pts, 1.0).pairs.len(), 5, "{name}");
    }
}

/// Worst distance from the independent ring-minimum fit (scripts/peers/
/// brightfield_ring_reference.py) over the five particles of each frame,
/// with the given centre estimate; asserts exactly five found and matched.
fn brightfield_worst_offsets(centre: CentreEstimate) -> Vec<(String, f64)> {
    ["bf_0000", "bf_0025", "bf_0049"]
        .iter()
        .map(|name| {
            let frame = load_frame(
                &fixture(&format!("brightfield/{name}.png")),
                Channel::Luminance,
            )
            .unwrap();
            let found = detect_particles(
                &frame,
                &DetectSettings {
                    diameter_px: 17.0,
                    centre,
                    ..DetectSettings::default()
                },
            )
            .unwrap();
            let reference = read_csv_xy(&fixture(&format!("reference/{name}.ringfit.csv")));
            let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
            let m = match_points(&reference, &pts, 3.0);
            let worst = m.pairs.iter().map(|p| p.2.hypot(p.3)).fold(0.0, f64::max);
            println!(
                "{name} ({centre:?}): {} found, {} matched, worst offset {worst:.3} px",
                found.len(),
                m.pairs.len()
            );
            assert_eq!(found.len(), 5, "{name}");
            assert_eq!(m.pairs.len(), 5, "{name}");
            (name.to_string(), worst)
        })
        .collect()
}

/// The brightfield particles are asymmetric (core ~1 px left of the dark
/// ring): the ring-edge centre sits within 0.5 px of the independent
/// ring-minimum fit, where the profile centre is up to 0.63 px off
/// (docs/vision-history.md, ninth pass).
#[test]
fn brightfield_exactly_five_particles_within_half_a_pixel_of_the_ring_fit() {
    for (name, worst) in brightfield_worst_offsets(CentreEstimate::RingEdge) {
        assert!(worst <= 0.5, "{name}: worst offset {worst} px");
    }
}

/// The profile centre alone (the default) does not meet the 0.5 px target on
/// these asymmetric particles: kept to show the figures (worst 0.633 px on
/// bf_0049); run with --ignored.
#[test]
#[ignore = "profile centre: worst 0.579, 0.449, 0.620 px from the ring-minimum fit on bf_0000, bf_0025, bf_0049 (asymmetric particles); met by CentreEstimate::RingEdge"]
fn brightfield_profile_centre_within_half_a_pixel_of_the_ring_fit() {
    for (name, worst) in brightfield_worst_offsets(CentreEstimate::Profile) {
        assert!(worst <= 0.5, "{name}: worst offset {worst} px");
    }
}

/// The parameters of one trackpy `locate` call, as the fixture's header states.
struct TrackpyCall {
    /// trackpy's `diameter` (odd, px).
    diameter_px: f64,
    /// trackpy's `minmass`.
    minmass: f64,
    /// Dark features (`invert=True`, or the frame inverted before the call).
    invert: bool,
}

impl TrackpyCall {
    /// The same call for nanopush's Crocker-Grier mode (other parameters at
    /// trackpy's defaults, as in the reference call).
    fn locate_params(&self) -> LocateParams {
        LocateParams {
            minmass: self.minmass,
            invert: self.invert,
            ..LocateParams::new(self.diameter_px as u32)
        }
    }
}

/// Compares nanopush (7 px size hint, dark spots) with a trackpy reference
/// under trackpy's own separation and edge margin (a fair comparison: these
/// are rules of the reference call, not of the particles); the mass rule
/// stays nanopush's (mass significance >= `threshold_sigma` noise units).
fn profile_fit_versus_trackpy(
    frame_rel: &str,
    reference: &str,
    channel: Channel,
    call: TrackpyCall,
) {
    let frame = load_frame(&fixture(frame_rel), channel).unwrap();
    // trackpy's separation (`diameter + 1`) and edge margin, as the
    // Crocker-Grier mode defines them for the same call.
    let params = call.locate_params();
    let settings = DetectSettings {
        diameter_px: 7.0,
        polarity: Some(nanopush::vision::detect::Polarity::Dark),
        min_separation_px: Some(params.separation()),
        ..DetectSettings::default()
    };
    let margin = params.margin_px() as f64;
    let (w, h) = (frame.width() as f64, frame.height() as f64);
    let found: Vec<_> = detect_particles(&frame, &settings)
        .unwrap()
        .into_iter()
        .filter(|d| {
            d.x_px >= margin
                && d.y_px >= margin
                && d.x_px <= w - 1.0 - margin
                && d.y_px <= h - 1.0 - margin
        })
        .collect();
    let tp = read_csv_xy(&fixture(reference));
    let pts: Vec<[f64; 2]> = found.iter().map(|d| [d.x_px, d.y_px]).collect();
    let m = match_points(&tp, &pts, 1.5);
    let extra = (found.len() - m.pairs.len()) as f64 / tp.len() as f64;
    println!(
        "{frame_rel}: trackpy {}, nanopush {}, matched {:.1} %, extra {:.1} %",
        tp.len(),
        found.len(),
        100.0 * m.recall(),
        100.0 * extra
    );
    assert!(m.recall() >= 0.95, "{frame_rel}: matched {}", m.recall());
    assert!(extra <= 0.05, "{frame_rel}: extra {extra}");
}

/// nanopush's own detector against trackpy (docs/vision-history.md, sixth pass): with
/// trackpy's separation (12 px) and edge margin (5 px), 60.7 % of trackpy's
/// detections on bulk_water_000 matched within 1.5 px and 5.8 % extra
/// (68.2 % and 6.5 % on bulk_water_100); the significance rules differ:
/// trackpy's `minmass=20` takes spots that nanopush's threshold, since
/// 2026-11-29 in units of the background's own correlated noise
/// (`vision::band_noise`), leaves as background texture (86.7 % and 36.4 %
/// on bulk_water_000 before). The Crocker-Grier mode meets the target
/// (`crocker_grier_matches_trackpy_on_bulk_water`).
#[test]
#[ignore = "profile-fit detector: 60.7 % matched, 5.8 % extra on bulk_water_000 (target >= 95 %, <= 5 %); met by the crocker_grier mode"]
fn profile_fit_bulk_water_matches_trackpy() {
    let call = || TrackpyCall {
        diameter_px: 11.0,
        minmass: 20.0,
        invert: true,
    };
    profile_fit_versus_trackpy(
        "bulk_water/bulk_water_000.png",
        "reference/bulk_water_000.trackpy.csv",
        Channel::Green,
        call(),
    );
    profile_fit_versus_trackpy(
        "bulk_water/bulk_water_100.png",
        "reference/bulk_water_100.trackpy.csv",
        Channel::Green,
        call(),
    );
}

/// nanopush's own detector against trackpy (docs/vision-history.md, sixth pass): with
/// trackpy's separation (10 px) and edge margin (4 px), 94.5 % matched, 63.7 %
/// extra (89.2 % extra before 2026-11-29, `vision::band_noise`). The
/// Crocker-Grier mode meets the target (`crocker_grier_matches_trackpy_on_t76`).
#[test]
#[ignore = "profile-fit detector: 94.5 % matched, 63.7 % extra on T76S3F00001 (target >= 95 %, <= 5 %); met by the crocker_grier mode"]
fn profile_fit_trackpy_test_frame_matches_trackpy() {
    profile_fit_versus_trackpy(
        "trackpy_tests/T76S3F00001.png",
        "reference/T76S3F00001.trackpy.csv",
        Channel::Luminance,
        TrackpyCall {
            diameter_px: 9.0,
            minmass: 140.0,
            invert: true,
        },
    );
}

/// Runs nanopush's Crocker-Grier mode with the reference call's own
/// parameters and checks the acceptance (>= 95 % of trackpy's features
/// matched within 1.5 px, <= 5 % extra) and that matched positions agree to
/// 1e-3 px; prints how close positions and masses are.
fn crocker_grier_versus_trackpy(
    frame_rel: &str,
    reference: &str,
    channel: Channel,
    call: TrackpyCall,
) {
    let frame = load_frame(&fixture(frame_rel), channel).unwrap();
    let found = locate(&frame, &call.locate_params()).unwrap();
    let rows = read_csv_rows(&fixture(reference));
    let tp: Vec<[f64; 2]> = rows.iter().map(|r| [r[0], r[1]]).collect();
    let pts: Vec<[f64; 2]> = found.iter().map(|f| [f.x_px, f.y_px]).collect();
    let m = match_points(&tp, &pts, 1.5);
    let extra = (found.len() - m.pairs.len()) as f64 / tp.len() as f64;
    let mut offsets: Vec<f64> = m.pairs.iter().map(|p| p.2.hypot(p.3)).collect();
    offsets.sort_by(f64::total_cmp);
    let mut mass_rel: Vec<f64> = m
        .pairs
        .iter()
        .map(|&(i, j, _, _)| (found[j].mass / rows[i][2] - 1.0).abs())
        .collect();
    mass_rel.sort_by(f64::total_cmp);
    let median = |v: &[f64]| v.get(v.len() / 2).copied().unwrap_or(0.0);
    let worst = |v: &[f64]| v.last().copied().unwrap_or(0.0);
    println!(
        "{frame_rel} crocker_grier: trackpy {}, nanopush {}, matched {:.1} %, extra {:.1} %, \
         offset median {:.2e} px worst {:.2e} px, mass rel. difference median {:.2e} worst {:.2e}",
        tp.len(),
        found.len(),
        100.0 * m.recall(),
        100.0 * extra,
        median(&offsets),
        worst(&offsets),
        median(&mass_rel),
        worst(&mass_rel),
    );
    assert!(m.recall() >= 0.95, "{frame_rel}: matched {}", m.recall());
    assert!(extra <= 0.05, "{frame_rel}: extra {extra}");
    // Same algorithm, same rounding rules: positions agree to the reference
    // file's precision (4 decimals), far inside the 1.5 px acceptance.
    assert!(
        worst(&offsets) <= 1e-3,
        "{frame_rel}: worst offset {} px",
        worst(&offsets)
    );
}

#[test]
fn crocker_grier_matches_trackpy_on_bulk_water() {
    for name in ["bulk_water_000", "bulk_water_100"] {
        crocker_grier_versus_trackpy(
            &format!("bulk_water/{name}.png"),
            &format!("reference/{name}.trackpy.csv"),
            Channel::Green,
            TrackpyCall {
                diameter_px: 11.0,
                minmass: 20.0,
                invert: true,
            },
        );
    }
}

#[test]
fn crocker_grier_matches_trackpy_on_t76() {
    crocker_grier_versus_trackpy(
        "trackpy_tests/T76S3F00001.png",
        "reference/T76S3F00001.trackpy.csv",
        Channel::Luminance,
        TrackpyCall {
            diameter_px: 9.0,
            minmass: 140.0,
            invert: true,
        },
    );
}

/// A 16-bit frame (the band-pass is rescaled to 65535 levels, not 255).
#[test]
fn crocker_grier_matches_trackpy_on_16bit_stuck_crop() {
    crocker_grier_versus_trackpy(
        "trackpy_tests/stuck_crop_be16.tif",
        "reference/stuck_crop.trackpy.csv",
        Channel::Luminance,
        TrackpyCall {
            diameter_px: 7.0,
            minmass: 100.0,
            invert: false,
        },
    );
}

#[test]
fn big_endian_16bit_tiff_stack_reads_every_page() {
    let frames = load_frames(
        &fixture("trackpy_tests/stuck_crop_be16.tif"),
        Channel::Luminance,
    )
    .unwrap();
    assert_eq!(frames.len(), 2);
    assert_eq!((frames[0].width(), frames[0].height()), (128, 128));
    assert_eq!(frames[0].bit_depth(), 16);
    // The first page alone through the pure-Rust reader agrees with OpenCV's.
    let first = load_frame(
        &fixture("trackpy_tests/stuck_crop_be16.tif"),
        Channel::Luminance,
    )
    .unwrap();
    assert_eq!(first.pixels(), frames[0].pixels());
    assert!(frames[0].pixels().iter().any(|&v| v > 255.0));
}

/// `nanopush detect ARGS FRAME` (with --no-tip --json).
fn detect_cli(frame: &std::path::Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .arg("detect")
        .args(args)
        .args(["--no-tip", "--json"])
        .arg(frame)
        .output()
        .unwrap()
}

/// The particle centres (px) of a successful `detect_cli` run.
fn detected_centres(out: &std::process::Output) -> Vec<[f64; 2]> {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc = nanopush::vision::detections_file::DetectionsFile::from_json(
        &String::from_utf8(out.stdout.clone()).unwrap(),
    )
    .unwrap();
    doc.particles.iter().map(|p| [p.x_px, p.y_px]).collect()
}

/// `nanopush detect --locator crocker-grier` runs the same call from the
/// command line: trackpy's 344 features on T76 in the JSON it writes; an
/// even diameter is refused with a non-zero exit.
#[test]
fn detect_cli_crocker_grier_mode_reproduces_the_t76_call() {
    let frame = fixture("trackpy_tests/T76S3F00001.png");
    let run = |diameter: &str| {
        detect_cli(
            &frame,
            &[
                "--locator",
                "crocker-grier",
                "--diameter-px",
                diameter,
                "--minmass",
                "140",
                "--polarity",
                "dark",
            ],
        )
    };
    let pts = detected_centres(&run("9"));
    let tp = read_csv_xy(&fixture("reference/T76S3F00001.trackpy.csv"));
    assert_eq!(pts.len(), tp.len());
    assert_eq!(match_points(&tp, &pts, 1e-3).pairs.len(), tp.len());
    let refused = run("8");
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("odd"));
}

/// The JSON tells a script what the text marks: a particle the frame's
/// edge cuts, and one placed but not fitted (a hint of 3 px on bright-field
/// rings 17 px across finds dim spots whose fits fail: kept at their
/// centroids with the hint's radius and a nominal sigma, which had read as
/// measurements). Every particle at the right hint is fitted.
#[test]
fn detect_json_says_which_particles_are_cut_or_not_fitted() {
    use nanopush::vision::detections_file::DetectionsFile;
    let doc = |frame: &str, args: &[&str]| {
        let out = detect_cli(&fixture(frame), args);
        assert!(out.status.success());
        DetectionsFile::from_json(&String::from_utf8(out.stdout).unwrap()).unwrap()
    };
    let right = doc("brightfield/bf_0000.png", &[]);
    assert_eq!(right.particles.len(), 5);
    assert!(right.particles.iter().all(|p| p.fitted && !p.edge_clipped));
    let small = doc("brightfield/bf_0000.png", &["--diameter-px", "3"]);
    let unfitted: Vec<_> = small.particles.iter().filter(|p| !p.fitted).collect();
    assert!(!unfitted.is_empty(), "{} particles", small.particles.len());
    assert!(
        unfitted.iter().all(|p| p.r_px == 1.5 && p.sigma_px == 0.5),
        "{unfitted:?}"
    );
    assert!(
        small
            .particles
            .iter()
            .filter(|p| p.fitted)
            .all(|p| p.r_px != 1.5 || p.sigma_px != 0.5)
    );
    // T76's spots at 7 px: those within a radius and a pixel of an edge are cut.
    let t76 = doc("trackpy_tests/T76S3F00001.png", &["--diameter-px", "7"]);
    let (w, h) = (640.0, 424.0);
    let near_edge = |p: &&nanopush::vision::detections_file::ParticleRecord| {
        let edge = p.r_px.max(3.5) + 1.0;
        p.x_px < edge || p.y_px < edge || p.x_px > w - 1.0 - edge || p.y_px > h - 1.0 - edge
    };
    let cut = t76.particles.iter().filter(|p| p.edge_clipped).count();
    assert!(cut > 0);
    assert_eq!(cut, t76.particles.iter().filter(near_edge).count());
    assert!(
        t76.particles
            .iter()
            .filter(|p| p.edge_clipped)
            .all(|p| near_edge(&p))
    );
}

/// `detect` says when its size hint does not fit the frame's particles
/// (it printed "0 particles", or 51 pieces of 5 rings, without a word):
/// bright-field rings 17 px across, at the right hint nothing is said.
#[test]
fn detect_says_when_its_size_hint_does_not_fit() {
    let frame = fixture("brightfield/bf_0000.png");
    let warned = |hint: &str| {
        let out = detect_cli(&frame, &["--diameter-px", hint]);
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let right = warned("17");
    assert!(!right.contains("warning"), "{right}");
    let twice = warned("34");
    assert!(
        twice.contains("no whole particle found at the size hint of 34 px across")
            && twice.contains("finds 5"),
        "{twice}"
    );
    let fifth = warned("3");
    assert!(
        fifth.contains("each may be found several times over"),
        "{fifth}"
    );
    let wide = warned("30");
    assert!(wide.contains("the particles found measure 16."), "{wide}");
    let half = warned("8");
    assert!(
        half.contains("7 of the 7 whole particles found could not be fitted"),
        "{half}"
    );
    // Spots 5-7 px across at 5 px: a few larger "rings" are no evidence of
    // pieces (3 at 10 px had been offered as the fix).
    let spots = detect_cli(
        &fixture("bulk_water/bulk_water_000.png"),
        &["--channel", "green", "--diameter-px", "5"],
    );
    let said = String::from_utf8_lossy(&spots.stderr);
    assert!(!said.contains("warning"), "{said}");
}

/// A ring-model hint too large for frames of small spots (about 7 px)
/// found a handful of "rings" without a word (T76S3F00001: 12 at 10 px,
/// 1 at 15 px, where trackpy finds 344; bulk_water_000: 1 at 13 px):
/// `detect` now says that a smaller hint finds hundreds of spots, and
/// names their size. At the right hint it says nothing.
#[test]
fn a_hint_too_large_for_small_spots_is_said_with_the_spots_size() {
    let said = |frame: &str, args: &[&str]| {
        let out = detect_cli(&fixture(frame), args);
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let t76 = "trackpy_tests/T76S3F00001.png";
    for hint in ["10", "15"] {
        let text = said(t76, &["--diameter-px", hint]);
        assert!(
            text.contains(&format!(
                "at the size hint of {hint} px across, but a hint of"
            )) && text.contains("spots besides, 8.")
                && text.contains("is --diameter-px their size?"),
            "{hint}: {text}"
        );
    }
    let water = "bulk_water/bulk_water_000.png";
    let text = said(water, &["--channel", "green", "--diameter-px", "13"]);
    assert!(
        text.contains("1 particle found at the size hint of 13 px across"),
        "{text}"
    );
    let right = said(t76, &["--diameter-px", "7"]);
    assert!(!right.contains("warning"), "{right}");
}

/// `nanopush detect --centre ring-edge` on a brightfield frame: the five
/// particles within 0.5 px of the independent ring fit in the JSON it writes;
/// with --locator crocker-grier (no ring fit) the flag is refused.
#[test]
fn detect_cli_ring_edge_centres_on_brightfield() {
    let frame = fixture("brightfield/bf_0000.png");
    let run = |extra: &[&str]| detect_cli(&frame, &[&["--centre", "ring-edge"], extra].concat());
    let pts = detected_centres(&run(&[]));
    let reference = read_csv_xy(&fixture("reference/bf_0000.ringfit.csv"));
    assert_eq!(pts.len(), 5);
    assert_eq!(match_points(&reference, &pts, 0.5).pairs.len(), 5);
    let refused = run(&["--locator", "crocker-grier", "--diameter-px", "17"]);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("ring-edge"));
    // The study locators place candidates and fit none: refused too (they
    // took the flag and ignored it).
    for locator in ["pixel-peak", "centroid", "radial-symmetry"] {
        let refused = run(&["--locator", locator]);
        assert!(!refused.status.success(), "{locator}");
        let said = String::from_utf8_lossy(&refused.stderr);
        // Named as typed (it read `PixelPeak`), and only the flag given
        // (it had named --polarity too).
        assert!(
            said.contains("--centre ring-edge needs a fitted particle")
                && !said.contains("--polarity")
                && said.contains(&format!("--locator {locator} ")),
            "{locator}: {said}"
        );
    }
    // Crocker-Grier's own settings, given to another locator, were ignored.
    for flag in ["--minmass", "--separation-px"] {
        let refused = run(&[flag, "5"]);
        let said = String::from_utf8_lossy(&refused.stderr);
        assert!(
            !refused.status.success() && said.contains("are crocker-grier's"),
            "{flag}: {said}"
        );
    }
}

/// The camera line-defect repair (vision::line_defects) must leave real
/// frames alone: every frame of the fixtures, stacks included, has none.
#[test]
fn real_frames_have_no_line_defects() {
    use nanopush::vision::line_defects::repair_line_defects;
    let mut frames = 0;
    for dir in ["brightfield", "bulk_water", "trackpy_tests"] {
        let mut files: Vec<PathBuf> = std::fs::read_dir(fixture(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        for path in files {
            for (k, frame) in load_frames(&path, Channel::Luminance)
                .unwrap()
                .iter()
                .enumerate()
            {
                let defects = repair_line_defects(frame).1;
                assert!(
                    defects.is_empty(),
                    "{} frame {k}: {defects:?}",
                    path.display()
                );
                frames += 1;
            }
        }
    }
    assert!(frames >= 7, "{frames} frames");
}
