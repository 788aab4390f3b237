//! A calibration a few per cent off in scale or rotation, caught during a
//! run (`exec::calibration_fit`): the apex's offset from where the stage
//! was sent grows with the stage's position, where drift grows with time.
//! The loop is told a calibration scaled or turned about where the stage
//! starts (the camera still renders with the true one), as a user's
//! calibration made on a slightly other lens or with the stage's unit off
//! would be. Judged on how the run ends.

use nalgebra::{Matrix2, Vector2};
use nanopush::calib::camera_map::CameraCalibration;
use nanopush::exec::assemble::RunEnd;
use nanopush::exec::calibration_fit::{MapFit, MapFitSettings, fit_map};
use nanopush::exec::events::RunEvent;
use nanopush::exec::sim_run::SimRunRequest;
use nanopush::plan::pattern_request::PatternRequest;
use nanopush::rig::Rig;
use nanopush::rig::sim::rig::SimRig;
use nanopush::rig::stage::NanoStage;
use std::path::Path;

mod sim_loop;
use sim_loop::{Outcome, run_sim_told};

/// The executor's placement tolerance.
const PLACED_M: f64 = 0.2e-6;

/// The paper scene drifting `drift_nm_s` along `direction_deg`, written into `dir`.
fn drifting_scene(dir: &Path, drift_nm_s: f64, direction_deg: f64) -> std::path::PathBuf {
    let paper = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml");
    let scene = dir.join("scene.toml");
    let text = std::fs::read_to_string(paper).unwrap();
    let environment =
        format!("[environment]\ndrift_nm_s = {drift_nm_s}\ndrift_direction_deg = {direction_deg}");
    std::fs::write(&scene, format!("{text}\n{environment}\n")).unwrap();
    scene
}

/// CMU (50 particles, layout `seed`) drifting `drift.0` nm/s along
/// `drift.1` deg, the loop told the camera's calibration scaled by
/// `scale` and turned `turn_deg` about the centre of the stage's travel,
/// its map checked with `settings`.
fn run(
    seed: u64,
    drift: (f64, f64),
    scale: f64,
    turn_deg: f64,
    settings: MapFitSettings,
) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let request = SimRunRequest {
        target: Some(PatternRequest::text("CMU")),
        scene: drifting_scene(dir.path(), drift.0, drift.1),
        seed,
        particles: 50,
        ..SimRunRequest::default()
    };
    let told = |rig: &mut SimRig| {
        let (sin, cos) = turn_deg.to_radians().sin_cos();
        let m = Matrix2::new(cos, -sin, sin, cos) * scale;
        let range = rig.range();
        let c = Vector2::from_fn(|i, _| (range[i].min_m + range[i].max_m) / 2.0);
        let truth = rig.calibration();
        // stage' = M (stage - c) + c for every pixel.
        CameraCalibration::affine(m * truth.linear, m * (truth.offset_m - c) + c)
    };
    run_sim_told(&request, told, |inputs| inputs.settings.map_fit = settings)
}

/// How near the loop's fit came to stopping the run at any frame of `o`
/// (it fits the sightings so far at every frame): the largest of the
/// smaller of gradient / `max_gradient` and change / (`min_change_m` + drift
/// allowance), over 1 at a stop; with the sightings it had at the first
/// frame the default thresholds would stop at.
fn nearest_stop(o: &Outcome) -> (f64, Option<usize>) {
    let defaults = MapFitSettings::default();
    let (mut nearest, mut trips) = (0.0f64, None);
    for k in 1..=o.map_sightings.len() {
        if let MapFit::Fitted(g) = fit_map(&o.map_sightings[..k], &defaults) {
            let allowed = defaults.min_change_m + defaults.drift_allowance_m_per_s * g.span_s;
            nearest = nearest.max((g.size() / defaults.max_gradient).min(g.change_m() / allowed));
            if trips.is_none() && g.doubt(&defaults).is_some() {
                trips = Some(k);
            }
        }
    }
    (nearest, trips)
}

/// Measures the fit on correct calibrations under drift and on wrong
/// ones, the check off (thresholds out of reach): the figures the
/// defaults were chosen from (docs/exec.md).
/// `cargo test --release --test exec_calibration_fit -- --ignored --nocapture`
#[test]
#[ignore = "measurement: minutes of simulated runs"]
fn measure_the_map_gradient_of_right_and_wrong_calibrations() {
    let off = MapFitSettings {
        max_gradient: f64::INFINITY,
        ..MapFitSettings::default()
    };
    let cases = [
        (4, (0.0, 0.0), 1.0, 0.0),
        (1, (0.0, 0.0), 1.0, 0.0),
        (5, (0.0, 0.0), 1.0, 0.0),
        (4, (2.0, 0.0), 1.0, 0.0),
        (4, (2.0, 90.0), 1.0, 0.0),
        (1, (5.0, 0.0), 1.0, 0.0),
        (4, (5.0, 45.0), 1.0, 0.0),
        (4, (0.0, 0.0), 0.95, 0.0),
        (1, (0.0, 0.0), 0.95, 0.0),
        (4, (2.0, 0.0), 0.95, 0.0),
        (4, (0.0, 0.0), 1.05, 0.0),
        (4, (0.0, 0.0), 0.97, 0.0),
        (1, (0.0, 0.0), 0.97, 0.0),
        (4, (0.0, 0.0), 1.03, 0.0),
        (4, (0.0, 0.0), 1.0, 2.0),
        (1, (0.0, 0.0), 1.0, -2.0),
        (4, (2.0, 90.0), 1.0, 2.0),
    ];
    for (seed, drift, scale, turn) in cases {
        let o = run(seed, drift, scale, turn, off);
        let (nearest, trips) = nearest_stop(&o);
        let last = match fit_map(&o.map_sightings, &off) {
            MapFit::Fitted(g) => format!(
                "{:+.2} % {:+.2} deg over {:.0} um",
                g.scale_fraction() * 100.0,
                g.rotation_rad().to_degrees(),
                g.travel_m * 1e6
            ),
            other => format!("{other:?}"),
        };
        eprintln!(
            "seed {seed} drift {drift:?} scale {scale} turn {turn} deg: {:?} {}/31, {} sightings, \
             nearest to a stop {nearest:.2}, default stops at sighting {trips:?}; at the end {last}",
            o.end,
            o.filled(PLACED_M),
            o.map_sightings.len(),
        );
    }
}

/// How many of the journal's events are decisions to push.
fn pushes(o: &Outcome) -> usize {
    let decision = |e: &&RunEvent| matches!(e, RunEvent::Decision { .. });
    o.events.iter().filter(decision).count()
}

/// The figure before `unit` in `why` (" % in scale", " deg turned").
fn said(why: &str, unit: &str) -> f64 {
    let before = &why[..why.find(unit).unwrap_or_else(|| panic!("{unit}: {why}"))];
    before.rsplit(' ').next().unwrap().parse().unwrap()
}

/// A calibration 5 % short, 3 % short, or turned 2 deg, about the
/// stage's centre (the apex at most 2.4, 1.4 or 1.7 um off, under the
/// 5 um doubt): the run stops naming the calibration, its scale and its
/// turn, before any push. It had taken the offset for drift, pushed,
/// lost contact three times on one particle and stopped on the planner.
#[test]
fn a_calibration_a_few_per_cent_off_stops_the_run_naming_it() {
    for (seed, scale, turn_deg) in [(4, 0.95, 0.0), (1, 0.97, 0.0), (4, 1.0, 2.0)] {
        let o = run(seed, (0.0, 0.0), scale, turn_deg, MapFitSettings::default());
        let RunEnd::CalibrationUnfit(why) = &o.end else {
            panic!("scale {scale}, turn {turn_deg}: ran to {:?}", o.end);
        };
        eprintln!("scale {scale}, turn {turn_deg} deg, seed {seed}: {why}");
        assert!(!why.contains("planner"), "{why}");
        assert!(why.contains("grows with the stage's position"), "{why}");
        assert!(
            why.contains("the calibration does not fit this camera and stage; make it again (nanopush rig calibrate)"),
            "{why}"
        );
        assert!(
            (said(why, " % in scale") - (scale - 1.0) * 100.0).abs() < 0.3,
            "{why}"
        );
        assert!((said(why, " deg turned") - turn_deg).abs() < 0.2, "{why}");
        assert_eq!(pushes(&o), 0, "{why}");
    }
}

/// A right calibration under drift of 5 nm/s (a probe just mounted, the
/// fastest the loop follows) across x, and diagonally: the map is fitted
/// at the frames (the stage travels the field) and never doubted; the
/// run fills every site as before.
#[test]
fn a_right_calibration_under_drift_is_not_doubted() {
    for (seed, drift) in [(1, (5.0, 0.0)), (4, (5.0, 45.0))] {
        let o = run(seed, drift, 1.0, 0.0, MapFitSettings::default());
        assert_eq!(o.end, RunEnd::Done, "drift {drift:?}");
        assert_eq!(o.filled(PLACED_M), o.site_errors_m.len());
        let MapFit::Fitted(g) = fit_map(&o.map_sightings, &MapFitSettings::default()) else {
            panic!("no fit of {} sightings", o.map_sightings.len());
        };
        // Measured nearest to a stop: 0.30 and 0.24 of the way.
        let (nearest, trips) = nearest_stop(&o);
        assert!(nearest < 0.5 && trips.is_none(), "{nearest} {g:?}");
    }
}
