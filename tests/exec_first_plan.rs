//! The pattern is placed on what the loop's first plan sees: the particles
//! as its first looks show them, the probe parked out of the way, with the
//! sizes the loop plans with, and the tip where it waits. On crowded
//! adversarial fields of 10 um spheres (44 in 120 x 100 um, 1 um gaps) a
//! place planned on anything else had no order at the loop's first plan,
//! and the run stopped before its first push.

use nanopush::exec::assemble::RunEnd;
use nanopush::plan::synth_layout::LayoutKind;

mod sim_loop;
use sim_loop::{field_120x100, paper_request_on, run_sim};

/// The end of a run of `text` on the adversarial field of `seed`, stopped
/// after its first push.
fn first_push(text: &str, seed: u64) -> RunEnd {
    let dir = tempfile::tempdir().unwrap();
    let params = field_120x100(44, 5.0, LayoutKind::Adversarial, false, seed);
    run_sim(&paper_request_on(dir.path(), text, &params), |inputs| {
        inputs.settings.max_pushes = 1;
    })
    .end
}

/// Seed 1: where the run starts, the probe's body hides a particle (at
/// 9.2, 7.5 um). Placed on that first frame, 'HI' went where the loop,
/// which parks the probe and then sees the particle, found no order.
#[test]
fn a_particle_under_the_probe_at_the_start_counts_in_the_placement() {
    let end = first_push("HI", 1);
    assert_eq!(end, RunEnd::PushesSpent(1));
}

/// Seed 2: placed on the parked frame alone, 'CMU' went where the loop's
/// first plan, on the particles' sizes from both its looks (nanometres
/// apart), found no order.
#[test]
fn a_crowded_place_is_planned_on_the_sizes_of_both_first_looks() {
    let end = first_push("CMU", 2);
    assert_eq!(end, RunEnd::PushesSpent(1));
}
