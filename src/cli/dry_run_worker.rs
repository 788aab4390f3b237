//! The dry-run's replay on a worker thread, so that Ctrl-C stops it at
//! once: one frame's analysis (the first frame's placement of a pattern
//! over 600 particles, a fresh plan among them) can take a minute, and the
//! flag, looked at between frames, had left 8-20 s without a word. On the
//! flag ([`crate::rig::interrupt`], the one `assemble` stops on) the frame
//! in analysis is abandoned and the frames committed before it are kept:
//! each is printed, drawn into the animation and listed for `dry-run.json`
//! in one step under one lock, so the three always agree.

use crate::exec::animation::AnimationWriter;
use crate::exec::dry_run::{DRY_RUN_SCHEMA, DryRunError, DryRunFrame, DryRunReport, dry_run};
use crate::exec::recording::Recording;
use crate::model::Scene;
use crate::plan::pattern::sites_um;
use crate::plan::pattern_request::PatternRequest;
use crate::rig::interrupt::CAUSE;
use crate::wording::counted;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

/// How often the waiting thread looks at the flag and the worker.
const POLL: Duration = Duration::from_millis(20);

/// What the replay has committed so far.
struct Committed {
    frames: Vec<DryRunFrame>,
    sites_um: Vec<[f64; 2]>,
    animation: Option<AnimationWriter>,
    /// Set when the replay is abandoned: nothing more is committed.
    closed: bool,
}

/// How a replay ended.
pub struct Replayed {
    /// The report: the replay's own, or, when abandoned, the frames
    /// committed before Ctrl-C with `ended_early` saying so.
    pub report: Result<DryRunReport, DryRunError>,
    /// The animation of the frames in the report.
    pub animation: AnimationWriter,
}

/// Replays `recording` on a worker thread (`print` shows each frame as it
/// is committed) until it ends or `interrupt` is raised.
pub fn replay(
    recording: Recording,
    scene: Option<Scene>,
    asked: Option<PatternRequest>,
    animation: AnimationWriter,
    print: fn(&DryRunFrame, usize),
    interrupt: &AtomicBool,
) -> anyhow::Result<Replayed> {
    let committed = Arc::new(Mutex::new(Committed {
        frames: Vec::new(),
        sites_um: Vec::new(),
        animation: Some(animation),
        closed: false,
    }));
    let shared = Arc::clone(&committed);
    let dir = recording.dir.display().to_string();
    let worker = std::thread::spawn(move || {
        let mut commit = |view: &crate::exec::assemble::FrameView<'_>, frame: &DryRunFrame| {
            let mut c = lock(&shared);
            if c.closed {
                return;
            }
            if let Some(a) = c.animation.as_mut() {
                crate::exec::assemble::FrameSink::frame(a, view);
            }
            print(frame, view.sites.len());
            if c.frames.is_empty() {
                c.sites_um = sites_um(view.sites);
            }
            c.frames.push(frame.clone());
        };
        dry_run(&recording, scene.as_ref(), asked.as_ref(), &mut commit)
    });
    while !worker.is_finished() && !interrupt.load(Ordering::SeqCst) {
        std::thread::sleep(POLL);
    }
    let mut c = lock(&committed);
    c.closed = true;
    let animation = c.animation.take();
    let animation = animation.ok_or_else(|| anyhow::anyhow!("the animation was taken twice"))?;
    if worker.is_finished() {
        drop(c);
        let report = worker
            .join()
            .map_err(|_| anyhow::anyhow!("the dry-run's analysis failed unexpectedly"))?;
        return Ok(Replayed { report, animation });
    }
    // The worker is left to end with the process: what it finds now is
    // not committed.
    let frames = std::mem::take(&mut c.frames);
    let report = DryRunReport {
        schema: DRY_RUN_SCHEMA.to_owned(),
        recording: dir,
        sites_um: std::mem::take(&mut c.sites_um),
        ended_early: Some(format!(
            "interrupted ({CAUSE}) after {}",
            counted(frames.len(), "frame")
        )),
        frames,
        unread_after: 0,
    };
    Ok(Replayed {
        report: Ok(report),
        animation,
    })
}

/// The lock, also after a panic elsewhere: the frames it holds were
/// committed whole.
fn lock(m: &Mutex<Committed>) -> MutexGuard<'_, Committed> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}
