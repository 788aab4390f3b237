//! The tip's drift against the sample (`exec::drift`). On the simulated rig a
//! scene's `environment.drift_nm_s` moves the tip against the sample by that
//! much every second, along `drift_direction_deg` (default x); the loop sees the apex where the stage was not
//! told to put it, follows the difference and takes it out of its moves.
//! Judged on the simulated world's ground truth.

use nalgebra::Vector2;
use nanopush::exec::assemble::{AssemblySettings, RunEnd};
use nanopush::exec::drift::{DriftEstimate, DriftSettings};
use nanopush::exec::events::RunEvent;
use nanopush::exec::journal::{Entry, read_journal};
use nanopush::exec::sim_run::SimRunRequest;
use nanopush::plan::layout::{Layout, Particle};
use nanopush::plan::pattern_request::{PatternRequest, PatternSource};
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

/// The paper scene drifting `drift_nm_s` along `direction_deg`, written
/// into `dir`.
fn drifting_scene(dir: &Path, drift_nm_s: f64, direction_deg: f64) -> std::path::PathBuf {
    let paper = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml");
    let scene = dir.join("scene.toml");
    let text = std::fs::read_to_string(paper).unwrap();
    std::fs::write(
        &scene,
        format!(
            "{text}\n[environment]\ndrift_nm_s = {drift_nm_s}\ndrift_direction_deg = {direction_deg}\n"
        ),
    )
    .unwrap();
    scene
}

/// As [`run`], drifting along `direction_deg` (from +x towards +y).
fn run_along(drift_nm_s: f64, direction_deg: f64, seed: u64, follow: bool) -> Outcome {
    run_with(drift_nm_s, direction_deg, seed, |settings| {
        if !follow {
            settings.drift = None;
        }
    })
}

/// CMU on a scene drifting `drift_nm_s` along `direction_deg`, the
/// layout of `seed`, the loop's settings changed by `change`.
fn run_with(
    drift_nm_s: f64,
    direction_deg: f64,
    seed: u64,
    change: impl Fn(&mut AssemblySettings),
) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let scene = drifting_scene(dir.path(), drift_nm_s, direction_deg);
    let request = SimRunRequest {
        target: Some(PatternRequest::text("CMU")),
        scene,
        seed,
        particles: 50,
        // The situations these tests name (a particle boxed in a hair from
        // its site on seed 6, ...) were found on plans keeping no gap round
        // the pattern; plans keeping one push other particles.
        keep_clear_m: Some(0.0),
        ..SimRunRequest::default()
    };
    run_sim(&request, |inputs| change(&mut inputs.settings))
}

/// The loop's settings as they were when the named cases below were
/// found (until 2026-12-01): no rate of drift before 8 sightings span 60
/// s, and a push that moved nothing not leading the next. Both make those
/// cases rarer (none of 90 runs at 5 nm/s along x, y and 225 deg left a
/// site short or gave a particle up), so the tests that need one run as
/// then.
fn as_found(settings: &mut AssemblySettings) {
    settings.max_lead_m = 0.0;
    rate_over_60_s(settings);
}

/// The drift's rate from 8 sightings over 60 s, as until 2026-12-01.
fn rate_over_60_s(settings: &mut AssemblySettings) {
    settings.drift = Some(DriftSettings {
        min_span_s: 60.0,
        ..DriftSettings::default()
    });
}

/// The binary under test.
fn nanopush() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
}

/// How many of the journal's events are `is`.
fn count_events(o: &Outcome, is: impl Fn(&RunEvent) -> bool) -> usize {
    o.events.iter().filter(|e| is(e)).count()
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
    // Not followed, the same run fails: the positive control. Its stop
    // names the drift and the flag (it had named a particle it could not
    // move, at 0.6 um of drift).
    let RunEnd::Stopped(why) = &ignored.end else {
        panic!("{:?}", ignored.end)
    };
    assert!(
        why.contains("the run does not follow drift (--no-drift-follow), and the apex has moved"),
        "{why}"
    );
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
    let frames = count_events(&o, |e| matches!(e, RunEvent::Observation { .. }));
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

/// The sites the journal says were left short, with the camera's error, nm.
fn left_short(o: &Outcome) -> Vec<(usize, f64)> {
    o.events
        .iter()
        .filter_map(|e| match e {
            RunEvent::LeftShort { site, error_nm, .. } => Some((*site, *error_nm)),
            _ => None,
        })
        .collect()
}

/// How far the camera's last frame showing the particle left short on
/// site `site` puts it from that site, nm.
fn left_short_last_seen_nm(o: &Outcome, site: usize) -> f64 {
    let particle = o
        .events
        .iter()
        .find_map(|e| match e {
            RunEvent::LeftShort {
                site: s, particle, ..
            } if *s == site => Some(*particle),
            _ => None,
        })
        .expect("the site left short");
    let sites = o
        .events
        .iter()
        .find_map(|e| match e {
            RunEvent::Start(spec) => Some(spec.sites_um.clone()),
            _ => None,
        })
        .expect("a start");
    let at = sites[site];
    let seen = o.events.iter().rev().find_map(|e| match e {
        RunEvent::Observation { particles, .. } => particles.iter().find(|p| p.id == particle),
        _ => None,
    });
    let p = seen.expect("the particle seen");
    (p.x_um - at[0]).hypot(p.y_um - at[1]) * 1e3
}

/// 5 nm/s along x, seed 32, with the loop as it was when the case was
/// found ([`as_found`]: since 2026-12-01 this run fills every site with
/// nothing left short; seed 9 until the simulated rig placed the pattern
/// on the loop's first looks, 2026-12-02, when seeds 16 and 32 of 1-40 left
/// one short; seed 45 until the tip crossed most of the gap to the particle
/// at the travel speed; along y, seed 6, until the tip waited on its way). A
/// particle 0.19-0.26 um short of its site is re-pushed three times in vain
/// and given up on; it covers its site and cannot be moved, and the run
/// had stopped (seed 6: at 9 of 31). Now a
/// particle given up on within 0.5 um of a site fills it: the run is done.
/// The loop judges the other sites by the camera, whose error against the
/// truth is tens of nm under this drift (on seed 9 one site read within 0.2
/// um was 0.208 um in truth): each within 0.25 um in truth. The particle
/// left short is held to the 0.5 um it is left within, by the camera and
/// in truth, and the camera's last frame to within 50 nm of the truth
/// (175.7 against 177.0 nm). The left-short entry keeps the reading of
/// the frame the particle was given up on, 235 nm here: with three
/// neighbours 0.4 um away its readings scatter from frame to frame
/// (172.7-235.2 nm over its last 23 frames, two of them about 57 nm
/// farther along x; the 56-58 nm on seeds 16 and 32 noted on 2026-12-02 is
/// that scatter, not a bias).
#[test]
fn a_particle_given_up_near_its_site_fills_it_and_the_run_goes_on() {
    let o = run_with(5.0, 0.0, 32, as_found);
    let short = left_short(&o);
    eprintln!(
        "5 nm/s along x, seed 32: {:?} {}/31 rms {:.0} nm, left short {short:?}",
        o.end,
        o.filled(PLACED_M),
        o.rms_nm()
    );
    assert_eq!(o.end, RunEnd::Done);
    assert!(!short.is_empty());
    for (i, e) in o.site_errors_m.iter().enumerate() {
        match short.iter().find(|(site, _)| *site == i) {
            // Within 0.5 um of its site by the camera and in truth.
            Some((_, seen_nm)) => {
                assert!(*seen_nm <= 500.0, "site {i}: {seen_nm} nm");
                assert!(*e <= 0.5e-6, "site {i}: {e} m, seen {seen_nm} nm");
                let last_nm = left_short_last_seen_nm(&o, i);
                assert!(
                    (last_nm - e * 1e9).abs() <= 50.0,
                    "site {i}: last seen {last_nm:.1} nm, truth {:.1} nm",
                    e * 1e9
                );
            }
            None => assert!(*e <= PLACED_M + 0.05e-6, "site {i}: {e} m"),
        }
    }
}

/// 5 nm/s along 225 deg, seed 20, the plans keeping their default gap
/// round the pattern, the rate of drift taken over 60 s as when the case
/// was found ([`rate_over_60_s`], the lead left on): with no rate yet, the tip
/// stood about 0.1 um behind where the loop put it, and a 0.12 um push of
/// a particle 0.7 um from a site moved it about 20 nm, three times; the
/// particle was given up, covering the site, and the run stopped at 31 s
/// ("no plan can fill it"). Now a push that moves its particle less than
/// half its length leads the particle's next push by the shortfall (at
/// most 0.25 um): done, every site within 0.25 um in truth.
#[test]
fn a_push_that_moved_nothing_leads_the_next_and_the_run_is_done() {
    let dir = tempfile::tempdir().unwrap();
    let request = SimRunRequest {
        target: Some(PatternRequest::text("CMU")),
        scene: drifting_scene(dir.path(), 5.0, 225.0),
        seed: 20,
        particles: 50,
        ..SimRunRequest::default()
    };
    let o = run_sim(&request, |inputs| rate_over_60_s(&mut inputs.settings));
    let led = count_events(&o, |e| {
        matches!(
            e,
            RunEvent::Decision {
                lead_nm: Some(_),
                ..
            }
        )
    });
    eprintln!(
        "5 nm/s along 225 deg, seed 20: {:?} {}/31 rms {:.0} nm, {led} pushes led, left short {:?}",
        o.end,
        o.filled(PLACED_M),
        o.rms_nm(),
        left_short(&o)
    );
    assert!(led > 0, "no push was led");
    assert_eq!(o.end, RunEnd::Done);
    for (i, e) in o.site_errors_m.iter().enumerate() {
        assert!(*e <= PLACED_M + 0.05e-6, "site {i}: {e} m");
    }
}

/// 5 nm/s along y, seed 1: a particle 0.21 um from its site with a filled
/// site's particle above it. Every fresh plan began with the same 0.12 um
/// first leg of a bent route; it never moved the particle, yet the check
/// called it placed (within 0.2 um of where it was meant to go), the rest
/// of the route no longer verified, and a fresh plan asked again: 127
/// pushes for 31 sites. A push now has to move its particle half its
/// length to count as placed.
#[test]
fn a_push_that_moves_nothing_is_not_taken_as_placed() {
    let o = run_along(5.0, 90.0, 1, true);
    let pushes = count_events(&o, |e| matches!(e, RunEvent::Decision { .. }));
    eprintln!(
        "5 nm/s along y, seed 1: {:?} {}/31 rms {:.0} nm, {pushes} pushes, left short {:?}",
        o.end,
        o.filled(PLACED_M),
        o.rms_nm(),
        left_short(&o)
    );
    assert_eq!(o.end, RunEnd::Done);
    // Measured 43 (127 before).
    assert!(pushes <= 60, "{pushes} pushes");
}

/// 5 nm/s along x, seed 32 (at 225 deg, seed 33, until the tip crossed
/// most of the gap to the particle at the travel speed, 2026-12-01; 2
/// nm/s, seed 6, until the tip waited on its way): a particle placed on
/// its site reads 0.21 um from it
/// later, between three filled sites where the tip cannot get behind it;
/// the plan in hand then leaves that site unfilled and every fresh plan was
/// refused ("walled in"): stopped at 21 of 31. Now, when the planner
/// refuses, a particle within 0.5 um of an unfilled site is left there,
/// filling it short, and the loop plans without it.
#[test]
fn a_particle_boxed_in_a_hair_from_its_site_fills_it() {
    let o = run(5.0, 32, true);
    let short = left_short(&o);
    let given_up: Vec<usize> = (o.events.iter())
        .filter_map(|e| match e {
            RunEvent::GiveUp { particle, .. } => Some(*particle),
            _ => None,
        })
        .collect();
    eprintln!(
        "5 nm/s along x, seed 32: {:?} {}/31 rms {:.0} nm, left short {short:?}, given up {given_up:?}",
        o.end,
        o.filled(PLACED_M),
        o.rms_nm()
    );
    assert_eq!(o.end, RunEnd::Done);
    assert!(
        o.events.iter().any(|e| matches!(e,
            RunEvent::LeftShort { particle, error_nm, .. }
                if *error_nm <= 500.0 && !given_up.contains(particle))),
        "no particle left short on a refusal: {short:?}"
    );
}

/// A particle boxed in a hair from its site: the middle of a 3 x 3 block
/// of particles on their sites at the default pitch (0.5 um gaps), 0.3 um
/// off its own and 0.2 um from its right-hand neighbour, so no gap round
/// it takes the 2 um tip. The planner refuses, the particle is left short,
/// every other site is filled, and the fresh plan has no push: the run is
/// done. It had stopped there with "the plan has no push left" (found on
/// CMU seed 33 at 5 nm/s along y, a run whose chaos lost the case when the
/// loop changed; this block makes it on purpose).
#[test]
fn a_run_whose_last_sites_are_left_short_is_done() {
    let dir = tempfile::tempdir().unwrap();
    let (pitch_um, off_um) = (10.5, 0.3);
    let mut particles = Vec::new();
    let mut sites = Vec::new();
    for j in -1..=1 {
        for i in -1..=1 {
            let (x, y) = (60.0 + pitch_um * i as f64, 50.0 + pitch_um * j as f64);
            sites.push(format!(r#"{{"x_um": {x}, "y_um": {y}}}"#));
            let dx = if (i, j) == (0, 0) { off_um } else { 0.0 };
            particles.push(Particle {
                id: particles.len() as u32,
                centre_m: Vector2::new((x + dx) * 1e-6, y * 1e-6),
                radius_m: 5e-6,
            });
        }
    }
    let layout = Layout {
        field_m: [120e-6, 100e-6],
        particles,
    };
    let layout_path = dir.path().join("layout.json");
    layout.write(&layout_path).unwrap();
    let sites_path = dir.path().join("sites.json");
    let site_list = format!(r#"{{"sites": [{}]}}"#, sites.join(", "));
    std::fs::write(&sites_path, site_list).unwrap();
    let target = PatternRequest {
        at_m: Some(Vector2::new(60e-6, 50e-6)),
        ..PatternRequest::from(PatternSource::File(sites_path))
    };
    let request = SimRunRequest {
        target: Some(target),
        scene: Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml"),
        layout: Some(layout_path),
        seed: 1,
        ..SimRunRequest::default()
    };
    let o = run_sim(&request, |_| {});
    let short = left_short(&o);
    let pushless_plan = (o.events.iter()).any(|e| matches!(e, RunEvent::Plan { pushes: 0, .. }));
    eprintln!(
        "boxed block: {:?} {}/9, left short {short:?}",
        o.end,
        o.filled(PLACED_M)
    );
    assert!(
        short.len() == 1 && short[0].0 == 4 && pushless_plan,
        "not the case named: left short {short:?}, a plan with no push: {pushless_plan}"
    );
    assert_eq!(o.end, RunEnd::Done);
    assert_eq!(o.filled(PLACED_M), 8);
}

/// `assemble --no-drift-follow` runs without the drift estimate, and says
/// so in its journal's run spec, where a resume reads it; by default the
/// same run follows the drift.
#[test]
fn the_drift_is_not_followed_when_the_user_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let scene = drifting_scene(dir.path(), 2.0, 0.0);
    let journal_of = |flag: Option<&str>| {
        let out = dir.path().join(format!("run{}", flag.is_some()));
        let ran = nanopush()
            .args(["assemble", "--text", "I", "--json", "--scene"])
            .arg(&scene)
            .arg("--out")
            .arg(&out)
            .args(flag)
            .output()
            .unwrap();
        assert!(
            ran.status.success(),
            "{}",
            String::from_utf8_lossy(&ran.stderr)
        );
        read_journal::<RunEvent>(&out.join("journal.jsonl"))
            .unwrap()
            .entries
    };
    let estimates = |entries: &[Entry<RunEvent>]| {
        (entries.iter())
            .filter(|e| matches!(e.event, RunEvent::Observation { drift: Some(_), .. }))
            .count()
    };
    let drift_off = |entries: &[Entry<RunEvent>]| match &entries[0].event {
        RunEvent::Start(spec) => spec.drift_off,
        other => panic!("first entry {other:?}"),
    };
    let off = journal_of(Some("--no-drift-follow"));
    assert!(drift_off(&off));
    assert_eq!(estimates(&off), 0);
    let followed = journal_of(None);
    assert!(!drift_off(&followed));
    assert!(estimates(&followed) > 0);
}

/// A resumed run leaves the sites its run left short as they were: the
/// particle nearest each (8 nm/s along y, seed 7: sites 6 and 7, 257 and
/// 258 nm off; at 5 nm/s seed 23 until the drift's rate came over 30 s
/// and a push that moved nothing led the next, 2026-12-01, and seed 6
/// until the tip waited on its way) is left there
/// again on the first look, before any push, not pushed three more times in
/// vain. The run is killed once its journal has the entry.
#[test]
fn a_resumed_run_leaves_short_what_its_run_left_short() {
    let dir = tempfile::tempdir().unwrap();
    let scene = drifting_scene(dir.path(), 8.0, 90.0);
    let out = dir.path().join("run");
    let journal = out.join("journal.jsonl");
    let mut child = nanopush()
        .args([
            "assemble",
            "--text",
            "CMU",
            "--seed",
            "7",
            "--keep-clear-um",
            "0",
        ])
        .arg("--scene")
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    while !std::fs::read_to_string(&journal)
        .unwrap_or_default()
        .contains(r#""kind":"left_short""#)
    {
        assert!(child.try_wait().unwrap().is_none(), "the run ended first");
        assert!(started.elapsed().as_secs() < 300, "no site left short");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let ran = nanopush()
        .args(["assemble", "--json", "--resume"])
        .arg(&journal)
        .output()
        .unwrap();
    let entries = read_journal::<RunEvent>(&journal).unwrap().entries;
    let events: Vec<&RunEvent> = entries.iter().map(|e| &e.event).collect();
    let resumed_at = events
        .iter()
        .position(|e| matches!(e, RunEvent::Resume { .. }))
        .expect("a resume entry");
    let (before, after) = events.split_at(resumed_at);
    let sites_of = |events: &[&RunEvent]| -> Vec<usize> {
        (events.iter())
            .filter_map(|e| match e {
                RunEvent::LeftShort { site, .. } => Some(*site),
                _ => None,
            })
            .collect()
    };
    let first_push = (after.iter())
        .position(|e| matches!(e, RunEvent::Decision { .. }))
        .unwrap_or(after.len());
    let left_before = sites_of(before);
    let left_again = sites_of(&after[..first_push]);
    eprintln!(
        "left short before the kill {left_before:?}, again on resuming {left_again:?}: {}",
        String::from_utf8_lossy(&ran.stdout)
    );
    assert!(!left_before.is_empty());
    for site in &left_before {
        assert!(
            left_again.contains(site),
            "site {site} not left short again"
        );
    }
}

/// A run started with `--no-drift-follow` that stops for the drift it does
/// not follow says the exact command that goes on following it
/// (`--resume JOURNAL --drift-follow`), and that command does: the resumed
/// part estimates the drift, and its resume entry journals the choice, so
/// that a later resume keeps following it (`resume_point::drift_off`;
/// a later `--resume` without the flag had gone back to not following).
/// The journal's `drift_off` had been kept by every resume, and the advice
/// "go on without --no-drift-follow" was a command `--resume` refuses.
#[test]
fn a_run_stopped_for_unfollowed_drift_resumes_following_it() {
    let dir = tempfile::tempdir().unwrap();
    // 5 nm/s: at 2, since 2026-12-01, the re-pushes led by the shortfall
    // of the push before finish the run.
    let scene = drifting_scene(dir.path(), 5.0, 0.0);
    let out = dir.path().join("run");
    let stopped = nanopush()
        .args([
            "assemble",
            "--text",
            "CMU",
            "--seed",
            "4",
            "--no-drift-follow",
        ])
        .arg("--scene")
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&stopped.stderr);
    assert!(!stopped.status.success(), "{stderr}");
    let advised = stderr
        .lines()
        .find_map(|l| {
            l.split_once("to follow it from here: nanopush ")
                .map(|(_, c)| c)
        })
        .unwrap_or_else(|| panic!("no command that follows the drift: {stderr}"));
    assert!(advised.ends_with(" --drift-follow"), "{advised}");
    let resumed = nanopush()
        .args(advised.split_whitespace())
        .arg("--json")
        .output()
        .unwrap();
    let entries = read_journal::<RunEvent>(&out.join("journal.jsonl"))
        .unwrap()
        .entries;
    let resumed_at = (entries.iter())
        .rposition(|e| matches!(e.event, RunEvent::Resume { .. }))
        .expect("a resume entry");
    assert_eq!(
        entries[resumed_at].event,
        RunEvent::Resume { drift_follow: true },
        "the resume's choice is not journalled"
    );
    let estimates = (entries[resumed_at..].iter())
        .filter(|e| matches!(e.event, RunEvent::Observation { drift: Some(_), .. }))
        .count();
    eprintln!(
        "advised: {advised}; {estimates} drift estimates after the resume; {}",
        String::from_utf8_lossy(&resumed.stdout)
    );
    assert!(
        estimates > 0,
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&resumed.stdout).unwrap();
    assert_eq!(report["outcome"], "done", "{report}");
}
