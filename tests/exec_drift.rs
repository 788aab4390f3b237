//! The tip's drift against the sample (`exec::drift`). On the simulated rig a
//! scene's `environment.drift_nm_s` moves the tip against the sample by that
//! much every second, along `drift_direction_deg` (default x); the loop sees the apex where the stage was not
//! told to put it, follows the difference and takes it out of its moves.
//! Judged on the simulated world's ground truth.

use nanopush::exec::assemble::RunEnd;
use nanopush::exec::drift::DriftEstimate;
use nanopush::exec::events::RunEvent;
use nanopush::exec::sim_run::SimRunRequest;
use nanopush::plan::pattern_request::PatternRequest;
use std::path::Path;

mod sim_loop;
use sim_loop::{Outcome, run_sim};

/// The executor's placement tolerance.
const PLACED_M: f64 = 0.2e-6;

/// CMU on the paper scene drifting `drift_nm_s` along x, on the random
/// layout of `seed`, the drift followed or not.
fn run(drift_nm_s: f64, seed: u64, follow: bool) -> Outcome {
    run_along(drift_nm_s, 0.0, seed, follow)
}

/// As [`run`], drifting along `direction_deg` (from +x towards +y).
fn run_along(drift_nm_s: f64, direction_deg: f64, seed: u64, follow: bool) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let paper = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml");
    let scene = dir.path().join("scene.toml");
    let text = std::fs::read_to_string(paper).unwrap();
    std::fs::write(
        &scene,
        format!(
            "{text}\n[environment]\ndrift_nm_s = {drift_nm_s}\ndrift_direction_deg = {direction_deg}\n"
        ),
    )
    .unwrap();
    let request = SimRunRequest {
        target: Some(PatternRequest::text("CMU")),
        scene,
        seed,
        particles: 50,
        ..SimRunRequest::default()
    };
    run_sim(&request, |inputs| {
        if !follow {
            inputs.settings.drift = None;
        }
    })
}

/// The last drift estimate the journal holds.
fn estimate(o: &Outcome) -> Option<DriftEstimate> {
    o.events.iter().rev().find_map(|e| match e {
        RunEvent::Observation { drift, .. } => *drift,
        _ => None,
    })
}

#[test]
fn a_drifting_tip_is_followed_and_every_site_filled() {
    // 2 nm/s, a probe not long on its stage: 0.6 um by the end of the run.
    let followed = run(2.0, 4, true);
    let ignored = run(2.0, 4, false);
    eprintln!(
        "followed: {:?} {}/31 rms {:.0} nm, {:?}; ignored: {:?} {}/31 rms {:.0} nm",
        followed.end,
        followed.filled(PLACED_M),
        followed.rms_nm(),
        estimate(&followed),
        ignored.end,
        ignored.filled(PLACED_M),
        ignored.rms_nm()
    );
    assert_eq!(followed.end, RunEnd::Done);
    assert_eq!(followed.filled(PLACED_M), followed.site_errors_m.len());
    // The estimate: the scene's 2 nm/s in x (measured 2.06), the drift by
    // the end of the run; in y, where nothing drifts, 0 (a rate of 0.3 nm/s
    // from the apex's error across the field is not significant).
    let e = estimate(&followed).expect("an estimate");
    assert!(
        (e.rate_nm_s[0] - 2.0).abs() < 0.3 && e.rate_nm_s[1].abs() < 0.5,
        "{e:?}"
    );
    let drifted_um = 2e-3 * followed.t_end_s;
    assert!(
        (e.offset_um[0] - drifted_um).abs() < 0.06,
        "{e:?}, {drifted_um} um"
    );
    // Not followed, the same run fails: the positive control.
    assert_ne!(ignored.end, RunEnd::Done);
    assert!(ignored.filled(PLACED_M) < followed.filled(PLACED_M));
}

/// 5 nm/s, a probe just mounted: after each push the tip waits where its
/// apex is clear of every particle (farther back along the probe's line
/// when the nearest point is among the letters), so most frames are
/// sightings. Waiting at the nearest point, seed 1 had 5 sightings in 16
/// frames, never a rate, and stopped at 8 of 31: a particle 0.2 um short
/// of its site, re-pushed three times in vain, given up on its own site.
#[test]
fn a_fast_drift_is_followed_from_frames_the_loop_keeps_clear() {
    let o = run(5.0, 1, true);
    let e = estimate(&o).expect("an estimate");
    let frames = o
        .events
        .iter()
        .filter(|e| matches!(e, RunEvent::Observation { .. }))
        .count();
    eprintln!(
        "5 nm/s: {:?} {}/31 rms {:.0} nm, {} sightings in {frames} frames, {e:?}",
        o.end,
        o.filled(PLACED_M),
        o.rms_nm(),
        e.sightings
    );
    assert_eq!(o.end, RunEnd::Done);
    assert_eq!(o.filled(PLACED_M), o.site_errors_m.len());
    assert!(2 * e.sightings >= frames, "{} of {frames}", e.sightings);
    assert!((e.rate_nm_s[0] - 5.0).abs() < 0.5, "{e:?}");
}

#[test]
fn without_drift_following_it_changes_little() {
    // No drift: the estimate is the apex's error, and the shrinking keeps
    // it out of the moves.
    let followed = run(0.0, 4, true);
    let ignored = run(0.0, 4, false);
    eprintln!(
        "no drift: followed rms {:.1} nm, ignored rms {:.1} nm, {:?}",
        followed.rms_nm(),
        ignored.rms_nm(),
        estimate(&followed)
    );
    assert_eq!(followed.end, RunEnd::Done);
    assert_eq!(ignored.end, RunEnd::Done);
    // Measured 15.0 against 15.0 nm (before the loop took the batch's
    // measured radius, 18.0 against 17.9 nm, and 23.0 with the estimate
    // taken out unshrunk).
    assert!(followed.rms_nm() <= ignored.rms_nm() + 2.0);
    let e = estimate(&followed).expect("an estimate");
    assert!(e.offset_um[0].hypot(e.offset_um[1]) < 0.05, "{e:?}");
}

/// The simulated tip drifts along any direction of the stage, and the
/// estimate is the same on both axes: 2 nm/s along y (CMU seed 4, as the
/// x test) is followed to every site, its rate seen in y.
#[test]
fn a_drift_along_y_is_followed_as_one_along_x() {
    let o = run_along(2.0, 90.0, 4, true);
    let e = estimate(&o).expect("an estimate");
    eprintln!(
        "2 nm/s along y: {:?} {}/31 rms {:.0} nm, {e:?}",
        o.end,
        o.filled(PLACED_M),
        o.rms_nm()
    );
    assert_eq!(o.end, RunEnd::Done);
    assert_eq!(o.filled(PLACED_M), o.site_errors_m.len());
    assert!(
        e.rate_nm_s[0].abs() < 0.5 && (e.rate_nm_s[1] - 2.0).abs() < 0.3,
        "{e:?}"
    );
    let drifted_um = 2e-3 * o.t_end_s;
    assert!(
        (e.offset_um[1] - drifted_um).abs() < 0.06 && e.offset_um[0].abs() < 0.06,
        "{e:?}, {drifted_um} um"
    );
}
