//! Dense layouts in the closed loop: where the particles as measured put a
//! later step of the plan in hand into a particle and no fresh order is
//! found at the pattern's fixed sites, the loop makes the plan's next push
//! when that replays clean, and plans again after it. Judged on the
//! simulated world's ground truth.

use nanopush::exec::assemble::RunEnd;
use nanopush::plan::synth_layout::LayoutKind;

mod sim_loop;
use sim_loop::{field_120x100, paper_request_on, run_sim};

/// The executor's placement tolerance.
const PLACED_M: f64 = 0.2e-6;

/// 'HI' on `synth layout --n 50 --field-um 120x100 --radius-um 5
/// --min-gap-um 1 --kind adversarial --seed 5` (a dense core at 1 um gaps
/// under the letters). After its fifth push the plan in hand put the tip
/// 0.17 um into a particle at its 79th step, no new order was found, and
/// the run stopped at 0 of 20 sites; pushing on with the plan in hand
/// fills all 20.
#[test]
fn a_dense_core_is_assembled_by_pushing_on_with_the_plan_in_hand() {
    let dir = tempfile::tempdir().unwrap();
    let params = field_120x100(50, 5.0, LayoutKind::Adversarial, false, 5);
    let request = paper_request_on(dir.path(), "HI", &params);
    let o = run_sim(&request, |_| {});
    eprintln!(
        "adversarial seed 5, HI: {:?}, rms {:.0} nm",
        o.end,
        o.rms_nm()
    );
    assert_eq!(o.end, RunEnd::Done);
    assert_eq!(o.filled(PLACED_M), o.site_errors_m.len());
}
