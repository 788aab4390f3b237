//! Particles off the scene's nominal size: the loop plans, strokes and
//! decides with the particles' measured sizes, so a batch 2 % smaller or
//! larger than the scene says, or one whose radii spread by 5 %, is
//! assembled as well as one of the nominal size. Scenes of micron-sized
//! particles are assembled too, and ones too small for the simulated
//! camera refused. Judged on the simulated world's ground truth.

use nanopush::exec::assemble::RunEnd;
use nanopush::exec::events::RunEvent;
use nanopush::exec::sim_run::{SimRunError, SimRunRequest, prepare_sim_run};
use nanopush::plan::pattern_request::PatternRequest;
use nanopush::plan::synth_layout::{LayoutKind, SynthParams};
use std::path::Path;

mod sim_loop;
use sim_loop::{Outcome, field_120x100, paper_request_on, run_sim};
mod paper_scene;
use paper_scene::scene_file;

/// The executor's placement tolerance.
const PLACED_M: f64 = 0.2e-6;

/// CMU in the paper scene (5 um particles) on a random layout of particles
/// of `radius_um` (with a 5 % spread when `polydisperse`).
fn run(radius_um: f64, polydisperse: bool, seed: u64) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let params = field_120x100(50, radius_um, LayoutKind::Uniform, polydisperse, seed);
    run_sim(&paper_request_on(dir.path(), "CMU", &params), |_| {})
}

#[test]
fn a_batch_two_percent_off_the_scenes_size_is_assembled() {
    for radius_um in [4.9, 5.1] {
        let o = run(radius_um, false, 3);
        let radii = decided_radii(&o);
        eprintln!(
            "{radius_um} um: {:?}, rms {:.0} nm, radii {radii:?}",
            o.end,
            o.rms_nm()
        );
        // With the scene's 5 um every push fell 0.35 um short (4.9 um) or
        // overshot 0.3 um (5.1 um) and CMU stopped at 0 of 31.
        assert_every_site_filled(&o, &format!("{radius_um} um"));
        assert!(!radii.is_empty());
        assert!(
            radii.iter().all(|r| (r - radius_um).abs() < 0.01),
            "{radius_um} um: decided with {radii:?}"
        );
    }
}

/// A batch whose radii spread by 5 % (4.4-5.4 um): each particle is
/// planned and pushed with its own measured size, and the widest are kept
/// off the sites. With the batch's median for all it stopped after 0-2
/// sites (the outliers' pushes fell 0.4 um short, re-push after re-push).
#[test]
fn a_batch_with_a_five_percent_spread_of_radii_is_assembled() {
    let o = run(5.0, true, 2);
    let radii = decided_radii(&o);
    let spread = radii.iter().cloned().fold(f64::MIN, f64::max)
        - radii.iter().cloned().fold(f64::MAX, f64::min);
    eprintln!(
        "spread batch: {:?}, rms {:.0} nm, decided radii spread {spread:.3} um",
        o.end,
        o.rms_nm()
    );
    assert_every_site_filled(&o, "seed 2");
    assert!(spread > 0.3, "pushed with radii spread by only {spread} um");
}

/// The run finished and every site holds its particle within the
/// executor's tolerance, by ground truth.
fn assert_every_site_filled(o: &Outcome, what: &str) {
    assert_eq!(o.end, RunEnd::Done, "{what}");
    assert_eq!(o.filled(PLACED_M), o.site_errors_m.len(), "{what}");
}

/// The radii the loop's push decisions were made with, um.
fn decided_radii(o: &Outcome) -> Vec<f64> {
    o.events
        .iter()
        .filter_map(|e| match e {
            RunEvent::Decision { radius_um, .. } => *radius_um,
            _ => None,
        })
        .collect()
}

/// The simulated rig places the pattern on the particles its first frame
/// shows, with the sizes the loop will plan them with, as the hardware rig
/// does. Placed on the world's true radii, CMU on this spread batch (seed
/// 10) went to a centre where the loop's first plan, on measured radii,
/// found no order: stopped at 0 of 31 ("particle 5 ... blocked by
/// particle 10, an unassigned particle with no free buffer spot").
#[test]
fn a_spread_batch_is_placed_where_the_loops_own_plan_finds_an_order() {
    let o = run(5.0, true, 10);
    eprintln!("spread batch seed 10: rms {:.0} nm", o.rms_nm());
    assert_every_site_filled(&o, "seed 10");
}

/// A "T" on 20 particles of the paper scene made `radius_um` (the scene
/// written in `dir`).
fn t_of_radius(dir: &Path, radius_um: f64) -> SimRunRequest {
    SimRunRequest {
        target: Some(PatternRequest::text("T")),
        scene: scene_file(
            dir,
            &format!("scene-{radius_um}um.toml"),
            &[("radius_um = 5.0 ", &format!("radius_um = {radius_um} "))],
        ),
        particles: 20,
        seed: 2,
        ..SimRunRequest::default()
    }
}

/// Micron-sized particles are assembled: the simulated camera shows them
/// at least 10 px across, finer than its 0.25 um/px, which showed these 4.8
/// px across, where the detector fits pieces of their drawn rings as spots
/// (centres jumping between frames, phantom particles boxing real ones in)
/// and the run stopped.
#[test]
fn a_pattern_of_micron_sized_particles_is_assembled() {
    let dir = tempfile::tempdir().unwrap();
    let o = run_sim(&t_of_radius(dir.path(), 0.6), |_| {});
    eprintln!("0.6 um particles: {:?}, rms {:.0} nm", o.end, o.rms_nm());
    assert_every_site_filled(&o, "0.6 um particles");
}

/// Particles the simulated camera cannot show as rings even at its finest
/// resolution are refused before the run, naming the smallest it runs.
#[test]
fn particles_too_small_for_the_simulated_camera_are_refused_before_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let Err(e) = prepare_sim_run(&t_of_radius(dir.path(), 0.4), None) else {
        panic!("0.4 um particles were not refused");
    };
    assert!(matches!(e, SimRunError::TooSmallToSee { .. }), "{e}");
    let said = e.to_string();
    assert!(said.contains("8.0 px across"), "{said}");
    assert!(said.contains("radius 0.50 um and up"), "{said}");
}

/// 'HI' on `n` spheres of 1 um, 0.1 um apart at least, in a field of
/// `field_m`, in the paper scene made 0.5 um in radius (written in `dir`).
fn micron_field(
    dir: &Path,
    (n, field_m): (usize, [f64; 2]),
    kind: LayoutKind,
    seed: u64,
) -> SimRunRequest {
    let params = SynthParams {
        n,
        field_m,
        radius_m: 0.5e-6,
        min_gap_m: 0.1e-6,
        polydisperse: false,
        kind,
        seed,
    };
    let mut request = paper_request_on(dir, "HI", &params);
    request.scene = t_of_radius(dir, 0.5).scene;
    request
}

/// A dense field of 1 um spheres (300 in 30 x 25 um, 0.1 um gaps): every
/// push lowers the tip where its plan checked it may land. With the
/// settings' 0.5 um clearance behind the particle, where the plan checks
/// 0.2 um (its 0.1 um tip disc and standoff), the tip came down on a
/// neighbour 3 times in this run (1-3 times in 7 of 8 such fields).
#[test]
fn the_tip_is_never_lowered_onto_a_particle_in_a_dense_field_of_micron_spheres() {
    let dir = tempfile::tempdir().unwrap();
    let request = micron_field(dir.path(), (300, [30e-6, 25e-6]), LayoutKind::Uniform, 5);
    let o = run_sim(&request, |_| {});
    eprintln!(
        "1 um spheres, 300 in 30 x 25 um: {:?}, rms {:.0} nm, tip lowered onto {:?}",
        o.end,
        o.rms_nm(),
        o.landings
    );
    assert!(o.landings.is_empty(), "{:?}", o.landings);
    assert_every_site_filled(&o, "dense 1 um spheres");
}

/// A field of 1 um spheres too crowded round the pattern for any plan
/// (adversarial, 150 in 40 x 30 um, 0.1 um gaps, 'HI', seed 1): the run
/// stops with the planner's refusal of the field as it lies. The loop's
/// last resort, leaving the particles near a site there (short) and
/// planning again, fails too; its refusal alone had been the reason given,
/// and on seed 2 (which plans since the placement tries the least crowded
/// centres) it named a particle the loop had left short "immovable".
#[test]
fn a_crowded_field_stops_with_the_refusal_of_the_field_as_it_lies() {
    let dir = tempfile::tempdir().unwrap();
    let request = micron_field(
        dir.path(),
        (150, [40e-6, 30e-6]),
        LayoutKind::Adversarial,
        1,
    );
    let o = run_sim(&request, |_| {});
    let RunEnd::Stopped(reason) = &o.end else {
        panic!("not stopped: {:?}", o.end);
    };
    eprintln!("crowded 1 um field: {reason}");
    let (first, salvage) = reason
        .split_once(" (nor with ")
        .unwrap_or_else(|| panic!("no second try said: {reason}"));
    assert!(
        first.starts_with("planner: no collision-free order:") && !first.contains("immovable"),
        "{reason}"
    );
    assert!(
        salvage.contains("left short where they lie near a site"),
        "{reason}"
    );
}
