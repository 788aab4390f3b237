//! The tip's drift against the sample (`exec::drift`). On the simulated rig a
//! scene's `environment.drift_nm_s` moves the tip against the sample by that
//! much every second, in x; the loop sees the apex where the stage was not
//! told to put it, follows the difference and takes it out of its moves.
//! Judged on the simulated world's ground truth.

use nanopush::exec::assemble::{Assembly, RunEnd};
use nanopush::exec::drift::DriftEstimate;
use nanopush::exec::events::RunEvent;
use nanopush::exec::journal::{JournalWriter, read_journal};
use nanopush::exec::sim_run::{SimRunRequest, inputs_for, prepare_sim_run};
use nanopush::plan::pattern_request::PatternRequest;
use nanopush::rig::Rig;
use std::path::Path;

/// The executor's placement tolerance.
const PLACED_M: f64 = 0.2e-6;

/// What a run left.
struct Outcome {
    end: RunEnd,
    /// Ground-truth distance from each site to the nearest particle.
    site_errors_m: Vec<f64>,
    /// The last drift estimate the journal holds.
    estimate: Option<DriftEstimate>,
    /// Rig time at the end.
    t_end_s: f64,
}

impl Outcome {
    fn rms_nm(&self) -> f64 {
        let n = self.site_errors_m.len() as f64;
        (self.site_errors_m.iter().map(|e| e * e).sum::<f64>() / n).sqrt() * 1e9
    }

    fn filled(&self) -> usize {
        self.site_errors_m
            .iter()
            .filter(|e| **e <= PLACED_M)
            .count()
    }
}

/// CMU on the paper scene drifting `drift_nm_s`, on the random layout of
/// `seed`, the drift followed or not.
fn run(drift_nm_s: f64, seed: u64, follow: bool) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let paper = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml");
    let scene = dir.path().join("scene.toml");
    let text = std::fs::read_to_string(paper).unwrap();
    std::fs::write(
        &scene,
        format!("{text}\n[environment]\ndrift_nm_s = {drift_nm_s}\n"),
    )
    .unwrap();
    let mut run = prepare_sim_run(&SimRunRequest {
        target: Some(PatternRequest::text("CMU")),
        scene,
        seed,
        particles: 50,
        ..SimRunRequest::default()
    })
    .unwrap();
    let journal_path = dir.path().join("journal.jsonl");
    let journal = JournalWriter::create(&journal_path).unwrap();
    let mut inputs = inputs_for(&run.scene, run.sites.clone(), &run.rig, run.layout.field_m);
    if !follow {
        inputs.settings.drift = None;
    }
    let end = Assembly::start(&mut run.rig, inputs, journal, run.spec)
        .unwrap()
        .run()
        .unwrap();
    let truth: Vec<[f64; 2]> = run
        .rig
        .stage
        .world
        .particles
        .iter()
        .map(|p| [p.x_m, p.y_m])
        .collect();
    let site_errors_m = run
        .sites
        .iter()
        .map(|s| {
            truth
                .iter()
                .map(|p| (p[0] - s.centre_m.x).hypot(p[1] - s.centre_m.y))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let entries = read_journal::<RunEvent>(&journal_path).unwrap().entries;
    let estimate = entries.iter().rev().find_map(|e| match e.event {
        RunEvent::Observation { drift, .. } => drift,
        _ => None,
    });
    Outcome {
        end,
        site_errors_m,
        estimate,
        t_end_s: run.rig.now_s(),
    }
}

#[test]
fn a_drifting_tip_is_followed_and_every_site_filled() {
    // 2 nm/s, a probe not long on its stage: 0.6 um by the end of the run.
    let followed = run(2.0, 4, true);
    let ignored = run(2.0, 4, false);
    eprintln!(
        "followed: {:?} {}/31 rms {:.0} nm, {:?}; ignored: {:?} {}/31 rms {:.0} nm",
        followed.end,
        followed.filled(),
        followed.rms_nm(),
        followed.estimate,
        ignored.end,
        ignored.filled(),
        ignored.rms_nm()
    );
    assert_eq!(followed.end, RunEnd::Done);
    assert_eq!(followed.filled(), followed.site_errors_m.len());
    // The estimate: the scene's 2 nm/s in x (measured 2.10), the drift by
    // the end of the run. In y, where nothing drifts, -0.33 nm/s: the
    // apex's fit is off by a few tens of nanometres differently across the
    // field, and the work moves across it (-0.27 in the run without drift).
    let e = followed.estimate.expect("an estimate");
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
    assert!(ignored.filled() < followed.filled());
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
        followed.estimate
    );
    assert_eq!(followed.end, RunEnd::Done);
    assert_eq!(ignored.end, RunEnd::Done);
    // Measured 18.0 against 17.9 nm; taking the estimate out unshrunk: 23.0.
    assert!(followed.rms_nm() <= ignored.rms_nm() + 2.0);
    let e = followed.estimate.expect("an estimate");
    assert!(e.offset_um[0].hypot(e.offset_um[1]) < 0.05, "{e:?}");
}
