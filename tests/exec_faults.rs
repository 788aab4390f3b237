//! Faults on the simulated rig: dropped frames, missed detections, a stage
//! error mid-push, and the process killed mid-run then resumed. Each run must
//! complete with every site filled (ground truth), disturb no particle that
//! already sat on its site, and keep every journal entry.
//!
//! "Disturbed" is judged on the simulated world's ground truth: a particle
//! within 0.1 um of a site (half the placement tolerance, so the camera also
//! sees it placed and the planner leaves it alone) that moves more than
//! 50 nm during any later stage move.

use nanopush::calib::camera_map::CameraCalibration;
use nanopush::exec::assemble::RunEnd;
use nanopush::exec::events::RunEvent;
use nanopush::exec::journal::read_journal;
use nanopush::exec::sim_run::{SimFaults, SimRunRequest};
use nanopush::plan::pattern_request::PatternRequest;
use nanopush::rig::sim::rig::SimRig;
use nanopush::rig::sim::state::SimState;
use nanopush::rig::stage::{NanoStage, StageXyz};
use nanopush::rig::{Rig, RigError};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

mod sim_loop;
use sim_loop::run_sim_moved;

/// A layout and pattern the planner completes without faults (7 sites, 20 particles).
const RUN: [&str; 6] = ["--text", "L", "--seed", "4", "--particles", "20"];
/// Ground-truth distance to a site under which a particle counts as placed.
const ON_SITE_M: f64 = 0.1e-6;
/// Movement of a placed particle that counts as disturbing it.
const DISTURBED_M: f64 = 50e-9;
/// The executor's placement tolerance.
const PLACED_M: f64 = 0.2e-6;

/// The same run as RUN, with faults.
fn request(faults: SimFaults) -> SimRunRequest {
    SimRunRequest {
        target: Some(PatternRequest::text("L")),
        scene: Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml"),
        seed: 4,
        particles: 20,
        faults,
        ..SimRunRequest::default()
    }
}

/// Particles (id, x, y) within ON_SITE_M of a site.
fn on_site(particles: &[(usize, f64, f64)], sites: &[[f64; 2]]) -> Vec<(usize, f64, f64)> {
    particles
        .iter()
        .copied()
        .filter(|(_, x, y)| {
            sites
                .iter()
                .any(|s| (x - s[0]).hypot(y - s[1]) <= ON_SITE_M)
        })
        .collect()
}

/// Ground truth: every particle's (id, x, y).
fn truth(rig: &SimRig) -> Vec<(usize, f64, f64)> {
    rig.stage
        .world
        .particles
        .iter()
        .map(|p| (p.id, p.x_m, p.y_m))
        .collect()
}

/// What a watched in-process run gives the tests.
struct Outcome {
    end: RunEnd,
    events: Vec<RunEvent>,
    disturbed: Vec<String>,
    site_errors_m: Vec<f64>,
}

fn watched_run(faults: SimFaults) -> Outcome {
    watched_run_told(faults, |_, _| None, None)
}

/// [`watched_run`], the loop told the calibration `told` makes of the
/// camera's own and the stage's start (`None`: the camera's own), Ctrl-C pressed at the first
/// move `interrupt_at` picks.
fn watched_run_told(
    faults: SimFaults,
    told: impl FnOnce(&CameraCalibration, StageXyz) -> Option<CameraCalibration>,
    interrupt_at: Option<fn(&[StageXyz], StageXyz) -> bool>,
) -> Outcome {
    let mut disturbed = Vec::new();
    let told = |rig: &mut SimRig| {
        let start = rig.position().unwrap();
        told(rig.calibration(), start).unwrap_or(*rig.calibration())
    };
    // Every move is checked for placed particles it disturbed.
    let log = &mut disturbed;
    let watch = move |sites: &[[f64; 2]]| {
        let sites = sites.to_vec();
        let mut interrupt_at = interrupt_at;
        let mut moves: Vec<StageXyz> = Vec::new();
        move |rig: &mut SimRig, target: StageXyz, speed: f64| {
            if interrupt_at.is_some_and(|at| at(&moves, target)) {
                interrupt_at = None;
                return Err(RigError::Interrupted);
            }
            moves.push(target);
            let before = on_site(&truth(rig), &sites);
            let result = rig.move_to(target, speed);
            let after = truth(rig);
            for (id, x, y) in before {
                let (_, x2, y2) = after.iter().copied().find(|p| p.0 == id).unwrap();
                let moved = (x2 - x).hypot(y2 - y);
                if moved > DISTURBED_M {
                    log.push(format!(
                        "particle {id} moved {:.0} nm at t {:.1} s",
                        moved * 1e9,
                        rig.now_s()
                    ));
                }
            }
            result
        }
    };
    let run = run_sim_moved(&request(faults), told, |_| {}, watch);
    Outcome {
        end: run.end,
        events: run.events,
        disturbed,
        site_errors_m: run.site_errors_m,
    }
}

fn count(events: &[RunEvent], f: impl Fn(&RunEvent) -> bool) -> usize {
    events.iter().filter(|e| f(e)).count()
}

fn observations(events: &[RunEvent]) -> usize {
    count(events, |e| matches!(e, RunEvent::Observation { .. }))
}

fn clean() -> &'static Outcome {
    static CLEAN: OnceLock<Outcome> = OnceLock::new();
    CLEAN.get_or_init(|| watched_run(SimFaults::default()))
}

fn assert_completed_undisturbed(o: &Outcome) {
    assert_eq!(o.end, RunEnd::Done);
    assert!(
        o.site_errors_m.iter().all(|e| *e <= PLACED_M),
        "ground-truth site errors {:?} um",
        o.site_errors_m.iter().map(|e| e * 1e6).collect::<Vec<_>>()
    );
    assert!(o.disturbed.is_empty(), "{:?}", o.disturbed);
}

#[test]
fn the_fault_free_run_completes_undisturbed() {
    assert_completed_undisturbed(clean());
}

#[test]
fn dropped_frames_are_journalled_and_the_run_completes() {
    let o = watched_run(SimFaults {
        drop_frames: vec![1, 2, 6],
        ..SimFaults::default()
    });
    assert_completed_undisturbed(&o);
    assert_eq!(count(&o.events, |e| *e == RunEvent::FrameDropped), 3);
}

#[test]
fn missed_detections_are_looked_at_again_and_the_run_completes() {
    // Frame 1 (the first push's result) shows no particle at all; frame 4 misses a few.
    let mut hide: Vec<(usize, usize)> = (0..20).map(|id| (id, 1)).collect();
    hide.extend((0..20).step_by(4).map(|id| (id, 4)));
    let o = watched_run(SimFaults {
        hide,
        ..SimFaults::default()
    });
    assert_completed_undisturbed(&o);
    // The faulty frames were taken, and the tracker kept every identity
    // through them: no track was started for a particle it already knew.
    assert!(observations(&o.events) >= 5);
    for e in &o.events {
        if let RunEvent::Observation { particles, .. } = e {
            assert!(particles.iter().all(|p| p.id < 20), "a new track appeared");
        }
    }
}

#[test]
fn a_stage_error_mid_push_halts_lifts_and_the_run_completes() {
    // Move 2 is the first push's stroke; move 7 falls in a later push.
    for n in [2, 7] {
        let o = watched_run(SimFaults {
            fail_at_move: Some(n),
            ..SimFaults::default()
        });
        assert_completed_undisturbed(&o);
        assert_eq!(
            count(&o.events, |e| matches!(e, RunEvent::MoveFailed { .. })),
            1,
            "fault at move {n}"
        );
    }
}

/// SIGHUP (a closed terminal) with the output's reader gone stops the run
/// as Ctrl-C does: the handler's own line to the closed pipe had killed
/// the process (SIGPIPE) mid-run, before the stop was journalled.
#[test]
fn a_hang_up_with_the_output_gone_stops_the_run_as_ctrl_c_does() {
    let dir = tempfile::tempdir().unwrap();
    let out: PathBuf = dir.path().join("run");
    let journal = out.join("journal.jsonl");
    let mut child = spawn_run(&out);
    drop(child.stderr.take());
    wait_for_lines(&journal, 30);
    let sent = Command::new("kill")
        .args(["-HUP", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    child.wait().unwrap();
    let entries = read_journal::<RunEvent>(&journal).unwrap().entries;
    assert!(
        matches!(&entries.last().unwrap().event, RunEvent::Stopped { reason, .. } if reason.contains("interrupted")),
        "{:?}",
        entries.last()
    );
}

/// Ctrl-C mid-push leaves the tip down beside a particle, and the stop
/// says so, with what to do (a user who moves x or y by hand drags it
/// across the sample; it had said only "the stage was halted"); Ctrl-C
/// with the tip lifted says nothing of it.
#[test]
fn a_stop_with_the_tip_down_says_so() {
    // The particles are 10 um tall; the stroke's push runs below them.
    const DOWN_M: f64 = 10e-6;
    let mid_push: fn(&[StageXyz], StageXyz) -> bool =
        |before, to| to[2] < DOWN_M && before.last().is_some_and(|p| p[2] < DOWN_M);
    let lifted_after_a_push: fn(&[StageXyz], StageXyz) -> bool = |before, to| {
        let pushed = before.iter().any(|p| p[2] < DOWN_M);
        pushed && to[2] > DOWN_M && before.last().is_some_and(|p| p[2] > DOWN_M)
    };
    let reason = |at| match watched_run_told(SimFaults::default(), |_, _| None, Some(at)).end {
        RunEnd::Stopped(reason) => reason,
        other => panic!("{other:?}"),
    };
    let down = reason(mid_push);
    assert!(
        down.starts_with("interrupted (Ctrl-C or a termination signal)")
            && down.contains("the tip may be down on the sample")
            && down.contains(
                "below the particles' tops at 10.00 um: lift z before moving x or y by hand"
            ),
        "{down}"
    );
    let up = reason(lifted_after_a_push);
    assert!(
        up.starts_with("interrupted (Ctrl-C or a termination signal)")
            && !up.contains("tip may be down"),
        "{up}"
    );
}

/// A calibration with x and y swapped about where the stage starts (a rig
/// file naming the controller's axes the wrong way round) fits the first
/// frame, so the start's check passes; the next frame, the tip parked
/// away, shows the apex far from where the stage has it, and the run
/// stops there, naming the calibration and the axes, before any push (it
/// had pushed at mirrored places, taking the difference for drift).
#[test]
fn a_calibration_with_x_and_y_swapped_stops_the_run_at_its_first_move() {
    let o = watched_run_told(
        SimFaults::default(),
        |truth, start| {
            let swap = nalgebra::Matrix2::new(0.0, 1.0, 1.0, 0.0);
            let c = nalgebra::Vector2::new(start[0], start[1]);
            // stage' = S (stage - c) + c for every pixel.
            Some(CameraCalibration::affine(
                swap * truth.linear,
                swap * (truth.offset_m - c) + c,
            ))
        },
        None,
    );
    let RunEnd::CalibrationUnfit(why) = &o.end else {
        panic!("ran to {:?}", o.end);
    };
    assert!(
        why.contains("calibration does not fit") && why.contains("stage axes or unit_um"),
        "{why}"
    );
    assert!(observations(&o.events) >= 2, "stopped on its first frame");
    assert_eq!(
        count(&o.events, |e| matches!(e, RunEvent::Decision { .. })),
        0
    );
}

/// `nanopush assemble` of [`RUN`] into `out`, started: stdout dropped, stderr piped.
fn spawn_run(out: &Path) -> std::process::Child {
    binary()
        .args(["assemble", "--out", out.to_str().unwrap()])
        .args(RUN)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// A run into `out`, sent `signal` (`kill`'s flag) `times` once its
/// journal shows it well under way; what it said when it ended.
fn signalled_run(out: &Path, signal: &str, times: usize) -> std::process::Output {
    let child = spawn_run(out);
    wait_for_lines(&out.join("journal.jsonl"), 30);
    for _ in 0..times {
        let sent = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
    }
    child.wait_with_output().unwrap()
}

/// Waits (at most 120 s) until `journal` holds `n` complete lines: a run
/// well under way.
fn wait_for_lines(journal: &Path, n: usize) {
    let started = Instant::now();
    while complete_lines(journal).len() < n {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the journal never reached {n} lines"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn binary() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_nanopush"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn complete_lines(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut lines: Vec<String> = text.split_inclusive('\n').map(str::to_owned).collect();
    if lines.last().is_some_and(|l| !l.ends_with('\n')) {
        lines.pop();
    }
    lines
}

fn particles(state: &SimState) -> Vec<(usize, f64, f64)> {
    state
        .particles
        .iter()
        .map(|p| (p.id, p.x_m, p.y_m))
        .collect()
}

/// Ctrl-C (SIGINT, twice) part way: the run stops as a run stops, its journal
/// ending "stopped", its report and animation written, the error saying
/// how to go on; resumed so, it fills every site. It had ended without a
/// word, leaving neither.
#[test]
fn a_run_stopped_with_ctrl_c_is_reported_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let out: PathBuf = dir.path().join("run");
    let journal = out.join("journal.jsonl");
    // Pressed twice in a panic: the second press had ended the program at
    // once, with no report (and on a rig before the stage was halted).
    let o = signalled_run(&out, "-INT", 2);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    let go_on = format!(
        "go on with it: nanopush assemble --resume {}",
        journal.display()
    );
    assert!(
        stderr.contains("interrupted (Ctrl-C or a termination signal)"),
        "{stderr}"
    );
    assert!(stderr.contains(&go_on), "{stderr}");
    let entries = read_journal::<RunEvent>(&journal).unwrap().entries;
    assert!(
        matches!(&entries.last().unwrap().event, RunEvent::Stopped { reason, .. } if reason.contains("Ctrl-C")),
        "{:?}",
        entries.last()
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert!(
        report["outcome"].as_str().unwrap().contains("Ctrl-C"),
        "{report}"
    );
    assert!(out.join("run.mp4").is_file());
    // The stopped run's report says how to go on, and what it was asked.
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains(&format!(
            "To go on with it: `nanopush assemble --resume {}`",
            journal.display()
        )),
        "{md}"
    );
    assert!(
        report["asked"]["command"]
            .as_str()
            .is_some_and(|c| c.contains("nanopush assemble --out")),
        "{report}"
    );
    let resumed = binary()
        .args(["assemble", "--json", "--resume", journal.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&resumed.stderr);
    assert!(resumed.status.success(), "resume failed: {stderr}");
    let entries = read_journal::<RunEvent>(&journal).unwrap().entries;
    assert_eq!(entries.last().unwrap().event, RunEvent::Done);
}

/// SIGTERM (a `kill`, a service stop) stops a run as Ctrl-C does, and the
/// stop does not blame a Ctrl-C nobody pressed: it had said "interrupted
/// by the user (Ctrl-C)".
#[test]
fn a_run_stopped_by_sigterm_says_what_may_have_stopped_it() {
    let dir = tempfile::tempdir().unwrap();
    let out: PathBuf = dir.path().join("run");
    let o = signalled_run(&out, "-TERM", 1);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let outcome = report["outcome"].as_str().unwrap();
    for told in [stderr.as_ref(), outcome] {
        assert!(
            told.contains("interrupted (Ctrl-C or a termination signal)")
                && !told.contains("by the user"),
            "{told}"
        );
    }
}

/// Kills `assemble` once its journal has `kill_after` lines, then resumes it.
fn kill_and_resume(kill_after: usize) {
    let dir = tempfile::tempdir().unwrap();
    let out: PathBuf = dir.path().join("run");
    let journal = out.join("journal.jsonl");
    // The scene named relative to where the run starts; resumed from
    // another folder (the journal keeps its absolute path).
    let paper = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml");
    std::fs::copy(paper, dir.path().join("my scene.toml")).unwrap();
    let mut child = binary()
        .current_dir(dir.path())
        .args(["assemble", "--scene", "my scene.toml"])
        .args(["--out", out.to_str().unwrap()])
        .args(RUN)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while complete_lines(&journal).len() < kill_after {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the journal never reached {kill_after} lines"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before the kill"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    // The killed run's video was never finished: no run.mp4 to link.
    assert!(!out.join("run.mp4").exists());
    let before = complete_lines(&journal);
    let contents = read_journal::<RunEvent>(&journal).unwrap();
    let RunEvent::Start(spec) = &contents.entries[0].event else {
        panic!("the journal does not start with the run spec");
    };
    assert!(
        !contents.entries.iter().any(|e| e.event == RunEvent::Done),
        "killed after the run was done: kill earlier"
    );
    let sites_m: Vec<[f64; 2]> = spec
        .sites_um
        .iter()
        .map(|s| [s[0] * 1e-6, s[1] * 1e-6])
        .collect();
    let at_kill = SimState::load(&out.join("sim-state.json")).unwrap();
    let placed = on_site(&particles(&at_kill), &sites_m);

    // A crash mid-write leaves half a line: the resume says so, and cuts it off.
    let mut file = std::fs::OpenOptions::new()
        .append(true)
        .open(&journal)
        .unwrap();
    std::io::Write::write_all(&mut file, b"{\"seq\": 99999, \"t_s\"").unwrap();
    drop(file);
    let resumed = binary()
        .current_dir(&out)
        .args(["assemble", "--json", "--resume", journal.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&resumed.stderr);
    assert!(resumed.status.success(), "resume failed: {stderr}");
    assert!(stderr.contains("its last line was cut off"), "{stderr}");
    // No entry lost: the old lines are still there, byte for byte, and the
    // whole journal reads back with a gap-free sequence.
    let after = complete_lines(&journal);
    assert_eq!(&after[..before.len()], &before[..]);
    let all = read_journal::<RunEvent>(&journal).unwrap();
    assert!(!all.truncated_tail);
    assert_eq!(
        all.entries[before.len() - 1].event,
        RunEvent::Resume {
            drift_follow: false
        }
    );
    assert_eq!(all.entries.last().unwrap().event, RunEvent::Done);
    // The resumed part's video is there and playable; the report links it
    // and nothing of the killed part.
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(out.join("run-resume-1.mp4").is_file());
    assert!(
        report.contains("run-resume-1.mp4") && !report.contains("(run.mp4)"),
        "{report}"
    );
    // Ground truth: every site filled, and nothing that sat on a site at the kill moved.
    let end = SimState::load(&out.join("sim-state.json")).unwrap();
    let end_particles = particles(&end);
    for (id, x, y) in &placed {
        let (_, x2, y2) = end_particles.iter().find(|p| p.0 == *id).unwrap();
        let moved = (x2 - x).hypot(y2 - y);
        assert!(
            moved <= DISTURBED_M,
            "particle {id}, placed at the kill, moved {:.0} nm",
            moved * 1e9
        );
    }
    for s in &sites_m {
        let e = end_particles
            .iter()
            .map(|p| (p.1 - s[0]).hypot(p.2 - s[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(
            e <= PLACED_M,
            "site ({:.2}, {:.2}) um off by {:.0} nm",
            s[0] * 1e6,
            s[1] * 1e6,
            e * 1e9
        );
    }
    let report: serde_json::Value = serde_json::from_slice(&resumed.stdout).unwrap();
    assert_eq!(report["filled"], report["sites"]);
    // The report covers the whole run and says it was resumed; a push
    // decided and cut off before the tip went down is not counted twice.
    assert_eq!(report["resumes"], 1);
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("Resumed 1 time after a stop"), "{md}");
    let decisions = (all.entries.iter())
        .filter(|e| matches!(e.event, RunEvent::Decision { .. }))
        .count() as u64;
    let checked = (all.entries.iter())
        .filter(|e| matches!(&e.event, RunEvent::Check { result, .. } if !result.starts_with("refused")))
        .count() as u64;
    let made = report["pushes"].as_u64().unwrap();
    let not_made = report["pushes_not_made"].as_u64().unwrap();
    assert_eq!(made + not_made, decisions, "{report}");
    // At most the push the kill cut off after the tip went down is made unchecked.
    assert!(made == checked || made == checked + 1, "{report}");
}

/// Killed at six points of the run (during a push, before a check, after
/// placements) and resumed: every run completes without loss. The run
/// writes 67 journal lines (its placement since the seventeenth pass).
#[test]
fn killed_anywhere_and_resumed_the_run_completes() {
    for kill_after in [10, 20, 30, 40, 50, 60] {
        kill_and_resume(kill_after);
    }
}

#[test]
fn an_unreadable_journal_is_refused_and_left_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let journal = dir.path().join("journal.jsonl");
    let text = "{\"schema\":\"nanopush.journal/1\"}\n{\"seq\":0,\"t_s\":0.0,\"event\":{\"kind\":\"resume\"}}\nnot json\n{\"seq\":2,\"t_s\":0.0,\"event\":{\"kind\":\"resume\"}}\n";
    std::fs::write(&journal, text).unwrap();
    let out = binary()
        .args(["assemble", "--resume", journal.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 3"), "{err}");
    assert_eq!(std::fs::read_to_string(&journal).unwrap(), text);
    let missing = binary()
        .args([
            "assemble",
            "--resume",
            dir.path().join("nope.jsonl").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("nope.jsonl"));
}

/// Another camera's calibration (0.30 for 0.25 um/px, turned 90 deg) puts
/// the apex far from where the stage has it: the run stops on its first
/// frame, naming the calibration, before any move (it had pushed three
/// times, lost contact three times and stopped on "no collision-free
/// order").
#[test]
fn a_calibration_of_another_camera_stops_the_run_before_any_push() {
    let o = watched_run_told(
        SimFaults::default(),
        |truth, _| {
            // Turned and scaled about pixel (100, 100), which still maps where it should.
            let turned = |offset_m: [f64; 2]| {
                CameraCalibration::from_scale_rotation(
                    truth.m_per_px() * 1.2,
                    std::f64::consts::FRAC_PI_2,
                    offset_m,
                )
            };
            let (want, got) = (
                truth.pixel_to_stage_m(100.0, 100.0),
                turned([0.0, 0.0]).pixel_to_stage_m(100.0, 100.0),
            );
            Some(turned([want[0] - got[0], want[1] - got[1]]))
        },
        None,
    );
    let RunEnd::CalibrationUnfit(why) = &o.end else {
        panic!("ran to {:?}", o.end);
    };
    assert!(why.contains("calibration does not fit"), "{why}");
    assert_eq!(
        count(&o.events, |e| matches!(e, RunEvent::Decision { .. })),
        0
    );
}
