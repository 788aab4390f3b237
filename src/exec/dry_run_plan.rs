//! The dry-run's plan in hand, kept as the loop keeps its own
//! ([`super::assemble`]): the push commanded last leaves it when the next
//! frame shows it placed (or unmoved); a push that lost contact is made
//! again from where its particle lies; one the recording does not show made
//! drops the plan; the rest is kept while, moved onto
//! the particles seen, it still verifies (or, with no fresh plan found,
//! while it fails only after its next push). Planned afresh every frame, the
//! dry-run had commanded other orders than the loop whenever the planner
//! chose differently from the particles' new places.

use super::assemble::AssemblySettings;
use super::push_check::check_push;
use super::tracker::{Moved, Tracker};
use crate::plan::rebase::{rebase_plan, without_first_push};
use crate::plan::{Layout, Plan};

/// The plan in hand after the frame `tracker` has just seen, moved onto
/// the particles of `layout`: `None` when there was none or it cannot be
/// moved onto them. The caller verifies it.
pub(super) fn kept_plan(
    in_hand: Option<Plan>,
    commanded: Option<Moved>,
    tracker: &Tracker,
    layout: &Layout,
) -> Option<Plan> {
    let plan = in_hand?;
    let settings = AssemblySettings::default();
    let tolerances = settings.check_tolerances();
    let mut repushed = None;
    let plan = match commanded {
        None => plan,
        Some(m) => {
            if not_made(m, tracker) {
                // The recorded run did not make this push (the frame 0
                // plan, made before the loop's first, or another order):
                // plan from what it did.
                return None;
            }
            match seen_now(m.id, tracker).map(|at| check_push(m.from, m.to, at, &tolerances)) {
                Some(check) if check.completes_step() => without_first_push(&plan),
                Some(check) => {
                    if check.lost_contact() {
                        repushed = Some(m.id as u32);
                    }
                    plan
                }
                None => plan,
            }
        }
    };
    rebase_plan(&plan, layout, settings.keep_plan_shift_m, repushed).ok()
}

/// True when the frame `tracker` has just seen shows the particle of the
/// push `m` still where the push started, though the push was longer than
/// the placement tolerance: the recorded run did not make it (the loop
/// parks the probe before its first push, so frame 0's command is never
/// made; or it chose another order).
pub(super) fn not_made(m: Moved, tracker: &Tracker) -> bool {
    let placed_m = AssemblySettings::default().check_tolerances().placed_m;
    let distance = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
    distance(m.from, m.to) > placed_m
        && seen_now(m.id, tracker).is_some_and(|at| distance(at, m.from) <= placed_m)
}

/// Where the frame just seen shows track `id`, if it shows it.
fn seen_now(id: usize, tracker: &Tracker) -> Option<[f64; 2]> {
    tracker
        .track(id)
        .filter(|t| t.missed_frames == 0)
        .map(|t| [t.last.x_m, t.last.y_m])
}
