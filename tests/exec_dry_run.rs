//! `nanopush dry-run`: the recordings in fixtures/recordings replay frame by
//! frame; on a fresh recording the dry-run commands exactly what the loop
//! did; bad input is refused with a clear error and nothing is lost.

use nanopush::exec::dry_run::{DryCommand, DryRunReport};
use nanopush::exec::events::RunEvent;
use nanopush::exec::journal::read_journal;
use nanopush::plan::synth_layout::{LayoutKind, synth_layout};
use nanopush::vision::frame::Frame;
use nanopush::vision::frame_input::{Channel, load_frame, load_frames, save_png};
use nanopush::vision::line_defects::LineAxis;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

mod interrupted;
use interrupted::interrupt_after;
mod sim_loop;
use sim_loop::field_120x100;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn nanopush(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .current_dir(root())
        .args(args)
        .output()
        .unwrap()
}

fn dry_run(recording: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "dry-run",
        "--json",
        "--recording",
        recording.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    nanopush(&args)
}

fn ok_report(o: &Output, out: &Path) -> DryRunReport {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let printed: DryRunReport = serde_json::from_slice(&o.stdout).unwrap();
    let written: DryRunReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("dry-run.json")).unwrap()).unwrap();
    assert_eq!(printed, written);
    printed
}

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(snapshot(&p));
        } else {
            out.insert(p.clone(), std::fs::read(&p).unwrap());
        }
    }
    out
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let target = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &target);
        } else {
            std::fs::copy(&p, &target).unwrap();
        }
    }
}

#[test]
fn the_simulated_recording_replays_with_the_models_pushes() {
    let dir = tempfile::tempdir().unwrap();
    let rec = root().join("fixtures/recordings/sim-L-seed6");
    let before = snapshot(&rec);
    let r = ok_report(&dry_run(&rec, dir.path(), &[]), dir.path());
    assert_eq!(r.frames.len(), 4);
    assert_eq!(r.sites_um.len(), 7);
    assert!(r.frames[0].tip_um.is_some());
    assert_eq!(r.frames[0].particles.len(), 20);
    for f in &r.frames {
        let DryCommand::Push {
            to_um,
            contact_angle_deg,
            duration_s,
            ..
        } = &f.command
        else {
            panic!("frame {}: {:?}", f.frame, f.command);
        };
        assert!(
            r.sites_um
                .iter()
                .any(|s| (s[0] - to_um[0]).hypot(s[1] - to_um[1]) < 1e-9)
        );
        assert!(contact_angle_deg.is_some() && duration_s.is_some_and(|d| d > 0.0));
    }
    // The pushes made between frames show: sites fill up.
    assert!(r.frames[3].filled > r.frames[0].filled);
    // Each frame names its file, for a user to find it.
    let sources: Vec<&str> = r.frames.iter().map(|f| f.source.as_str()).collect();
    assert_eq!(
        sources,
        [
            "frame_00000.png",
            "frame_00001.png",
            "frame_00002.png",
            "frame_00003.png"
        ]
    );
    let video = load_frames(&dir.path().join("dry-run.mp4"), Channel::Luminance).unwrap();
    assert_eq!(video.len(), 4);
    assert_eq!(snapshot(&rec), before, "the recording was changed");
}

/// A pattern asked for on the command line replaces the recording's
/// target: the dry-run plans it where, at the pitch and turn asked.
#[test]
fn a_pattern_asked_for_is_tried_on_the_recording_instead_of_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let rec = root().join("fixtures/recordings/sim-L-seed6");
    let asked = [
        "--text",
        "L",
        "--at",
        "60,50",
        "--pitch-um",
        "11",
        "--rotation-deg",
        "90",
    ];
    let r = ok_report(&dry_run(&rec, dir.path(), &asked), dir.path());
    let (lo, hi) = r
        .sites_um
        .iter()
        .fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), s| {
            (
                [lo[0].min(s[0]), lo[1].min(s[1])],
                [hi[0].max(s[0]), hi[1].max(s[1])],
            )
        });
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    assert!(
        (centre[0] - 60.0).abs() < 1e-6 && (centre[1] - 50.0).abs() < 1e-6,
        "{centre:?}"
    );
    // L stands 4 pitches tall and 2 wide; a quarter turn lays it down.
    let size = [hi[0] - lo[0], hi[1] - lo[1]];
    assert!(
        (size[0] - 44.0).abs() < 1e-6 && (size[1] - 22.0).abs() < 1e-6,
        "{size:?}"
    );
    let DryCommand::Push { to_um, .. } = &r.frames[0].command else {
        panic!("{:?}", r.frames[0].command);
    };
    assert!(
        r.sites_um
            .iter()
            .any(|s| (s[0] - to_um[0]).hypot(s[1] - to_um[1]) < 1e-9)
    );
    // A placement without a pattern to place is refused.
    let o = dry_run(&rec, &dir.path().join("at-only"), &["--at", "60,50"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("give --text or --pattern too"),
        "{err}"
    );
}

#[test]
fn the_real_recording_replays_with_five_particles_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let rec = root().join("fixtures/recordings/real-brightfield");
    let r = ok_report(&dry_run(&rec, dir.path(), &[]), dir.path());
    assert_eq!(r.frames.len(), 3);
    assert_eq!(r.sites_um.len(), 3);
    for f in &r.frames {
        assert_eq!(f.particles.len(), 5, "frame {}", f.frame);
        assert!(f.tip_um.is_none());
        assert!(
            matches!(f.command, DryCommand::Push { .. }),
            "frame {}: {:?}",
            f.frame,
            f.command
        );
    }
}

/// The sim-L recording copied under `dir` with every frame passed through
/// `camera` (a defect the recording's camera did not have), and the
/// fixture itself.
fn recording_through(dir: &Path, camera: impl Fn(&Frame) -> Vec<f32>) -> (PathBuf, PathBuf) {
    let fixture = root().join("fixtures/recordings/sim-L-seed6");
    let rec = dir.join("rec");
    copy_dir(&fixture, &rec);
    for e in std::fs::read_dir(rec.join("frames")).unwrap() {
        let path = e.unwrap().path();
        let frame = load_frame(&path, Channel::Luminance).unwrap();
        let seen = Frame::new(
            frame.width(),
            frame.height(),
            camera(&frame),
            frame.bit_depth(),
        );
        save_png(&seen.unwrap(), &path).unwrap();
    }
    (rec, fixture)
}

/// The dry-run of `rec` as printed for people (no `--json`).
fn dry_run_for_people(rec: &Path, out: &Path) -> Output {
    nanopush(&[
        "dry-run",
        "--recording",
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
}

/// The dry-run of `rec` as printed for people: stdout and stderr.
fn printed_dry_run(rec: &Path, out: &Path) -> (String, String) {
    let o = dry_run_for_people(rec, out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// A camera with a dead column: the dry-run names the repaired line in every
/// frame, in dry-run.json and in the printed frame lines, and sees and
/// commands what it does on the undamaged recording.
#[test]
fn a_dead_camera_column_is_named_in_every_frame_and_changes_nothing_seen() {
    const DEAD_COLUMN: usize = 280;
    let dir = tempfile::tempdir().unwrap();
    let (rec, fixture) = recording_through(dir.path(), |frame| {
        let mut px = frame.pixels().to_vec();
        for y in 0..frame.height() {
            px[y * frame.width() + DEAD_COLUMN] = 0.0;
        }
        px
    });
    let clean_out = dir.path().join("clean");
    let clean = ok_report(&dry_run(&fixture, &clean_out, &[]), &clean_out);
    let broken_out = dir.path().join("broken");
    let broken = ok_report(&dry_run(&rec, &broken_out, &[]), &broken_out);
    assert_eq!(broken.frames.len(), clean.frames.len());
    for (c, b) in clean.frames.iter().zip(&broken.frames) {
        assert!(c.repaired_lines.is_empty(), "{:?}", c.repaired_lines);
        let lines: Vec<_> = b.repaired_lines.iter().map(|l| (l.axis, l.index)).collect();
        assert_eq!(
            lines,
            [(LineAxis::Column, DEAD_COLUMN)],
            "frame {}",
            b.frame
        );
        assert_eq!(b.particles.len(), c.particles.len(), "frame {}", b.frame);
        for (pc, pb) in c.particles.iter().zip(&b.particles) {
            assert_eq!(pb.id, pc.id);
            let moved_um = (pb.x_um - pc.x_um).hypot(pb.y_um - pc.y_um);
            assert!(
                moved_um < 0.15,
                "frame {} particle {}: {moved_um} um",
                b.frame,
                pb.id
            );
        }
        match (&c.command, &b.command) {
            (
                DryCommand::Push {
                    particle: pc,
                    to_um: tc,
                    ..
                },
                DryCommand::Push {
                    particle: pb,
                    to_um: tb,
                    ..
                },
            ) => {
                assert_eq!((pb, tb), (pc, tc), "frame {}", b.frame);
            }
            (clean_command, broken_command) => {
                assert_eq!(broken_command, clean_command, "frame {}", b.frame)
            }
        }
    }
    let (stdout, _) = printed_dry_run(&rec, &dir.path().join("text"));
    let named = format!("camera lines repaired: column {DEAD_COLUMN}");
    assert_eq!(
        stdout.matches(&named).count(),
        clean.frames.len(),
        "{stdout}"
    );
}

/// An over-exposed recording (every frame's counts scaled so that its
/// median reaches the full count): every frame says so, in dry-run.json
/// and in its printed line; the undamaged recording's frames do not.
#[test]
fn an_over_exposed_recording_is_named_in_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let (rec, fixture) = recording_through(dir.path(), |frame| {
        let mut sorted = frame.pixels().to_vec();
        sorted.sort_by(f32::total_cmp);
        let gain = frame.max_count() / sorted[sorted.len() / 2];
        let full = frame.max_count();
        frame
            .pixels()
            .iter()
            .map(|p| (p * gain).min(full))
            .collect()
    });
    let clean_out = dir.path().join("clean");
    let clean = ok_report(&dry_run(&fixture, &clean_out, &[]), &clean_out);
    assert!(clean.frames.iter().all(|f| f.clipped.is_none()));
    let over_out = dir.path().join("over");
    let over = ok_report(&dry_run(&rec, &over_out, &[]), &over_out);
    for f in &over.frames {
        let e = f.clipped.expect("a clipped frame");
        assert!(e.saturated_fraction >= 0.5, "frame {}: {e:?}", f.frame);
    }
    let (stdout, stderr) = printed_dry_run(&rec, &dir.path().join("text"));
    assert_eq!(
        stdout.matches("(camera clipped: ").count(),
        over.frames.len(),
        "{stdout}"
    );
    assert_eq!(
        stderr.matches("over-exposed").count(),
        1,
        "warned once: {stderr}"
    );
}

/// A run on the simulated rig of `text` (`seed`, `particles`) in `dir`,
/// recorded: its --out and its recording.
fn recorded_run(dir: &Path, text: &str, seed: &str, particles: &str) -> (PathBuf, PathBuf) {
    let (out, rec) = (dir.join("out"), dir.join("rec"));
    let o = nanopush(&[
        "assemble",
        "--text",
        text,
        "--seed",
        seed,
        "--particles",
        particles,
        "--out",
        out.to_str().unwrap(),
        "--record",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (out, rec)
}

#[test]
fn on_a_fresh_recording_the_dry_run_commands_what_the_loop_did() {
    let dir = tempfile::tempdir().unwrap();
    let (out, rec) = recorded_run(dir.path(), "L", "6", "20");
    let first = read_journal::<RunEvent>(&out.join("journal.jsonl"))
        .unwrap()
        .entries
        .into_iter()
        .find_map(|e| match e.event {
            RunEvent::Decision {
                particle,
                from_um,
                to_um,
                contact_angle_deg,
                duration_s,
                ..
            } => Some((particle, from_um, to_um, contact_angle_deg, duration_s)),
            _ => None,
        })
        .unwrap();
    let r = ok_report(
        &dry_run(&rec, &dir.path().join("dry"), &[]),
        &dir.path().join("dry"),
    );
    let DryCommand::Push {
        particle,
        from_um,
        to_um,
        contact_angle_deg,
        duration_s,
        ..
        // Frame 0 is the loop's first look; it plans from frame 1, taken with
        // the probe parked clear of the particles.
    } = r.frames[1].command.clone()
    else {
        panic!("{:?}", r.frames[1].command);
    };
    assert_eq!(particle, first.0);
    for i in 0..2 {
        assert!((from_um[i] - first.1[i]).abs() < 1e-9 && (to_um[i] - first.2[i]).abs() < 1e-9);
    }
    assert_eq!(contact_angle_deg, Some(first.3));
    assert!((duration_s.unwrap() - first.4).abs() < 1e-9 * first.4);
    assert_eq!(r.frames.last().unwrap().command, DryCommand::Done);
}

fn assert_refused(o: &Output, needle: &str) {
    assert!(
        !o.status.success(),
        "expected a refusal mentioning {needle}"
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(needle),
        "stderr does not mention {needle}: {err}"
    );
}

#[test]
fn bad_recordings_are_refused_clearly_and_nothing_is_lost() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // Missing.
    assert_refused(
        &dry_run(&dir.path().join("nope"), &out, &[]),
        "recording.toml",
    );
    // Corrupt description, corrupt frame, stage log that does not match the frames.
    let fixture = root().join("fixtures/recordings/sim-L-seed6");
    type Damage<'a> = &'a dyn Fn(&Path);
    let cases: [(&str, Damage, &str); 4] = [
        (
            // Named as a file of the recording, not answered with what a
            // recording is.
            "calibration",
            &|r| std::fs::remove_file(r.join("calibration.toml")).unwrap(),
            "calibration.toml: not found (named in the recording's recording.toml)",
        ),
        (
            "description",
            &|r| std::fs::write(r.join("recording.toml"), "schema = [").unwrap(),
            "recording.toml",
        ),
        (
            "frame",
            &|r| std::fs::write(r.join("frames/frame_00002.png"), b"\x89PNG broken").unwrap(),
            "frames",
        ),
        (
            "stage log",
            &|r| {
                let log = r.join("stage.jsonl");
                let text = std::fs::read_to_string(&log).unwrap();
                let cut: Vec<&str> = text.lines().take(3).collect();
                std::fs::write(&log, cut.join("\n") + "\n").unwrap();
            },
            "2 stage-log entries for 4 frames",
        ),
    ];
    for (name, damage, needle) in cases {
        let rec = dir.path().join(name);
        copy_dir(&fixture, &rec);
        damage(&rec);
        let before = snapshot(&rec);
        assert_refused(&dry_run(&rec, &out, &[]), needle);
        assert_eq!(snapshot(&rec), before, "{name}: the recording was changed");
        assert!(!out.join("dry-run.json").exists(), "{name}");
    }
    // Pattern that the recording's particles cannot fill, scene of other particles.
    let rec = dir.path().join("pattern");
    copy_dir(&root().join("fixtures/recordings/real-brightfield"), &rec);
    let spec = std::fs::read_to_string(rec.join("recording.toml")).unwrap();
    std::fs::write(
        rec.join("recording.toml"),
        spec.replace("pattern = \"pattern.toml\"", "pattern_text = \"CMU\""),
    )
    .unwrap();
    // Nor the folders it made for a nested --out.
    let nested = dir.path().join("nested");
    assert_refused(
        &dry_run(&rec, &nested.join("a/b"), &[]),
        "but the first frame shows 5 particles",
    );
    assert!(
        !nested.exists(),
        "a refused dry-run left its --out folder behind"
    );
    // A glyph the font has not: the file and its key are named.
    std::fs::write(
        rec.join("recording.toml"),
        spec.replace("pattern = \"pattern.toml\"", "pattern_text = \"L!\""),
    )
    .unwrap();
    assert_refused(
        &dry_run(&rec, &out, &[]),
        "recording.toml `pattern_text`: unknown glyph",
    );
    let small = dir.path().join("small.toml");
    let paper = std::fs::read_to_string(root().join("calib/paper-ps-ito.toml")).unwrap();
    std::fs::write(
        &small,
        paper.replace("radius_um = 5.0 ", "radius_um = 0.5 "),
    )
    .unwrap();
    assert_refused(
        &dry_run(
            &root().join("fixtures/recordings/real-brightfield"),
            &out,
            &["--scene", small.to_str().unwrap()],
        ),
        &format!(
            "the scene {} (--scene) has particles of radius 0.50 um",
            small.display()
        ),
    );
    // An earlier dry-run is not overwritten.
    let first = dir.path().join("first");
    ok_report(&dry_run(&fixture, &first, &[]), &first);
    let kept = std::fs::read(first.join("dry-run.json")).unwrap();
    assert_refused(&dry_run(&fixture, &first, &[]), "exists");
    assert_eq!(std::fs::read(first.join("dry-run.json")).unwrap(), kept);
    // Nor an animation left alone in the folder.
    let partial = dir.path().join("partial");
    std::fs::create_dir_all(&partial).unwrap();
    std::fs::write(partial.join("dry-run.mp4"), b"precious").unwrap();
    assert_refused(&dry_run(&fixture, &partial, &[]), "dry-run.mp4 exists");
    assert_eq!(
        std::fs::read(partial.join("dry-run.mp4")).unwrap(),
        b"precious"
    );
    // The recording is only read: an --out in it, or in its frames, or
    // reached through `..`, is refused.
    let rec = dir.path().join("kept");
    copy_dir(&fixture, &rec);
    let before = snapshot(&rec);
    for out in [
        rec.clone(),
        rec.join("frames"),
        rec.join("new/deeper"),
        dir.path().join("partial/../kept/x"),
    ] {
        assert_refused(&dry_run(&rec, &out, &[]), "is inside the recording");
    }
    assert_eq!(snapshot(&rec), before, "the recording was changed");
    // Nor in its frames' folder when that lies outside the recording: the
    // animation was written among the frames.
    let apart = dir.path().join("apart");
    copy_dir(&fixture, &apart);
    let frames = dir.path().join("frames-elsewhere");
    std::fs::rename(apart.join("frames"), &frames).unwrap();
    set_line(
        &apart,
        "recording.toml",
        "frames =",
        &format!("frames = {:?}", frames.display().to_string()),
    );
    let frames_before = snapshot(&frames);
    assert_refused(
        &dry_run(&apart, &frames, &[]),
        "is inside its frames' folder",
    );
    assert_eq!(snapshot(&frames), frames_before, "the frames were changed");
    ok_report(
        &dry_run(&apart, &dir.path().join("beside"), &[]),
        &dir.path().join("beside"),
    );
}

mod deadline;

/// `file` in `rec` with `line_start`'s line replaced by `line`.
fn set_line(rec: &Path, file: &str, line_start: &str, line: &str) {
    let p = rec.join(file);
    let text = std::fs::read_to_string(&p).unwrap();
    let out: Vec<&str> = text
        .lines()
        .map(|l| if l.starts_with(line_start) { line } else { l })
        .collect();
    std::fs::write(&p, out.join("\n") + "\n").unwrap();
}

/// A recording whose numbers cannot be right is refused when read, naming
/// the file and the field, with a non-zero exit and nothing written: a
/// field of no size or sites on top of each other used to give "nothing:
/// planner: ..." on every frame and exit 0, a site 1e9 um away never
/// ended, one 5 mm off the field was planned a push to, a coarse offset of
/// 1e308 um drew ghost particles, and frames of two sizes failed only in
/// the animation, after every frame.
#[test]
fn recordings_with_impossible_numbers_are_refused_on_read() {
    let dir = tempfile::tempdir().unwrap();
    let fixture = root().join("fixtures/recordings/sim-L-seed6");
    let spec = |line: &'static str| {
        let key = line.split(' ').next().unwrap();
        move |r: &Path| set_line(r, "recording.toml", key, line)
    };
    type Damage = Box<dyn Fn(&Path)>;
    let cases: Vec<(&str, Damage, &str)> = vec![
        (
            "far site",
            Box::new(spec("sites_um = [[1e9, 0.0], [5.0, 5.0]]")),
            "recording.toml: sites_um: site 0 at (1.000e9, 0.000) um is not a finite position",
        ),
        (
            "site off the field",
            Box::new(spec("sites_um = [[-5000, 80]]")),
            "recording.toml: sites_um: site 0 at (-5000.000, 80.000) um lies outside the 120.0 x 100.0 um field",
        ),
        (
            "nan site",
            Box::new(spec("sites_um = [[nan, 0.0], [5.0, 5.0]]")),
            "sites_um: site 0 at (NaN, 0.000) um",
        ),
        (
            "same site twice",
            Box::new(spec("sites_um = [[50.0, 50.0], [50.0, 50.0]]")),
            "sites_um: sites 0 and 1 overlap",
        ),
        (
            "negative field",
            Box::new(spec("field_um = [-120.0, 100.0]")),
            "recording.toml: field_um is [-120.000, 100.000]",
        ),
        (
            "nan field",
            Box::new(spec("field_um = [nan, 100.0]")),
            "field_um is [NaN, 100.000]",
        ),
        (
            "no site",
            Box::new(spec("sites_um = []")),
            "recording.toml: sites_um is empty",
        ),
        (
            "empty field",
            Box::new(spec("field_um = [0.0, 100.0]")),
            "field_um is [0.000, 100.000]",
        ),
        (
            "sheared calibration",
            Box::new(|r: &Path| {
                set_line(
                    r,
                    "calibration.toml",
                    "pixel_to_stage_um",
                    "pixel_to_stage_um = [[0.25, 0.5, -20.0], [0.0, -0.25, 120.0]]",
                )
            }),
            "calibration.toml: pixel_to_stage_um has pixel axes 0.2500 and 0.5590 um long, 63.4 deg off perpendicular",
        ),
        (
            "absurd offset",
            Box::new(|r: &Path| {
                let log = r.join("stage.jsonl");
                let text = std::fs::read_to_string(&log).unwrap();
                let line = text.lines().nth(2).unwrap();
                let at = line.find("\"coarse_offset_um\"").unwrap();
                let end = at + line[at..].find(']').unwrap() + 1;
                let bad = format!(
                    "{}\"coarse_offset_um\":[1e308,-1e308]{}",
                    &line[..at],
                    &line[end..]
                );
                std::fs::write(&log, text.replace(line, &bad)).unwrap();
            }),
            "stage.jsonl: line 3: coarse_offset_um is [1.000e308, -1.000e308]",
        ),
        (
            "frames of two sizes",
            Box::new(|r: &Path| {
                let small =
                    nanopush::vision::frame::Frame::new(200, 150, vec![100.0; 200 * 150], 8)
                        .unwrap();
                nanopush::vision::frame_input::save_png(&small, &r.join("frames/frame_00002.png"))
                    .unwrap();
            }),
            "frames: frame_00002.png is 200x150 px but frame_00000.png is 560x560 px",
        ),
    ];
    for (name, damage, needle) in cases {
        let rec = dir.path().join(name.replace(' ', "-"));
        let out = dir.path().join(format!("out-{}", name.replace(' ', "-")));
        copy_dir(&fixture, &rec);
        damage(&rec);
        let args = [
            "dry-run",
            "--recording",
            rec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        let ran = deadline::nanopush_within(dir.path(), &args, 30);
        assert!(!ran.ok, "{name}: accepted:\n{}", ran.stdout);
        assert!(ran.stderr.contains(needle), "{name}: {}", ran.stderr);
        assert!(!out.exists(), "{name}: {} was written", out.display());
    }
}

/// A copy at `at` of the real bright-field recording, its particles said
/// to be `radius_um` (5 um as recorded).
fn real_brightfield_with_radius(at: &Path, radius_um: f64) -> PathBuf {
    copy_dir(&root().join("fixtures/recordings/real-brightfield"), at);
    let line = format!("particle_radius_um = {radius_um:?}");
    set_line(at, "recording.toml", "particle_radius_um", &line);
    at.to_path_buf()
}

/// A recording whose particle radius is far too small (1 um for the real
/// bright-field frames' 4.8 um) finds each particle several times over and
/// commands pushes of ring pieces: the dry-run warns on its first frame.
#[test]
fn a_particle_radius_that_finds_pieces_of_particles_is_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    let rec = real_brightfield_with_radius(&dir.path().join("small"), 1.0);
    let out = dry_run(&rec, &dir.path().join("out"), &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("first frame: 49 particles found near the size hint")
            && stderr.contains("several times over"),
        "{stderr}"
    );
}

/// A recording whose particle radius is a fifth off what its frames show
/// is warned of with the measured size: with 4 um declared for 5 um
/// particles, those measured over 5.2 um had been left out of every plan
/// without a word (and a plan pushed another through one). The right
/// radius says nothing.
#[test]
fn a_particle_radius_the_frames_do_not_measure_is_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    let warning = "the particles found measure";
    let rec = real_brightfield_with_radius(&dir.path().join("as-recorded"), 5.0);
    let as_recorded = dry_run(&rec, &dir.path().join("as-recorded-out"), &[]);
    let stderr = String::from_utf8_lossy(&as_recorded.stderr);
    assert!(
        as_recorded.status.success() && !stderr.contains(warning),
        "{stderr}"
    );
    let rec = real_brightfield_with_radius(&dir.path().join("small"), 4.0);
    let small = dry_run(&rec, &dir.path().join("small-out"), &[]);
    let stderr = String::from_utf8_lossy(&small.stderr);
    assert!(
        stderr.contains(&format!(
            "{warning} 4.76 um in radius (median of 5), 19 % larger than the scene's 4.00 um"
        )),
        "{stderr}"
    );
}

/// A recording whose last frame was cut short (a recorder that crashed
/// mid-write) replays the frames before it and says where it ended, exit
/// 0, as a video cut short does: the whole dry-run, its output folder
/// with it, had been thrown away for the last file. A frame cut short
/// mid-recording keeps the frames before it too, with a non-zero exit.
#[test]
fn a_frame_cut_short_ends_the_replay_and_keeps_the_frames_before() {
    let dir = tempfile::tempdir().unwrap();
    let rec = real_brightfield_with_radius(&dir.path().join("rec"), 5.0);
    let last = rec.join("frames/bf_0049.png");
    let bytes = std::fs::read(&last).unwrap();
    std::fs::write(&last, &bytes[..bytes.len() / 2]).unwrap();
    let out = dir.path().join("out");
    let o = dry_run(&rec, &out, &[]);
    let r = ok_report(&o, &out);
    assert_eq!(r.frames.len(), 2);
    let why = r.ended_early.as_deref().unwrap_or_default();
    assert!(
        why.contains("bf_0049.png") && why.contains("the replay ends there, after 2 frames"),
        "{why}"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("dry-run ended early"), "{stderr}");
    assert!(out.join("dry-run.mp4").is_file());
    // Cut mid-recording, frames after it go unread: kept, but a failure.
    let middle = rec.join("frames/bf_0025.png");
    let bytes = std::fs::read(&middle).unwrap();
    std::fs::write(&middle, &bytes[..bytes.len() / 2]).unwrap();
    let out = dir.path().join("out-middle");
    let o = dry_run(&rec, &out, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && stderr.contains("after 1 frame; 1 frame after it not analysed"),
        "{stderr}"
    );
    let written: DryRunReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("dry-run.json")).unwrap()).unwrap();
    assert_eq!((written.frames.len(), written.unread_after), (1, 1));
}

/// Ctrl-C during a long dry-run keeps what was analysed (dry-run.json and
/// a playable animation of those frames) and says so, exit non-zero: it
/// had left a hidden, unplayable .dry-run.mp4 and nothing else.
#[test]
fn ctrl_c_ends_a_dry_run_keeping_the_frames_analysed() {
    let dir = tempfile::tempdir().unwrap();
    let rec = real_brightfield_with_radius(&dir.path().join("rec"), 5.0);
    let frames = rec.join("frames");
    let first = std::fs::read(frames.join("bf_0000.png")).unwrap();
    for k in 1..400 {
        std::fs::write(frames.join(format!("bf_1{k:04}.png")), &first).unwrap();
    }
    let out = dir.path().join("out");
    let command = dry_run_command(&rec, &out);
    // Pressed once the first frame is printed (the first line says where
    // the frames' times come from).
    let pressed = interrupt_after(command, &["replay: ", "frame"], Duration::ZERO);
    let stderr =
        pressed.stopped_at_once("stopping the dry-run (Ctrl-C or a termination signal) now");
    let rest = pressed.after;
    assert!(
        stderr.contains("dry-run interrupted (Ctrl-C or a termination signal) after")
            && stderr.contains(&format!(
                "{} and {}",
                out.join("dry-run.json").display(),
                out.join("dry-run.mp4").display()
            )),
        "{stderr}"
    );
    let written: DryRunReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("dry-run.json")).unwrap()).unwrap();
    let n = written.frames.len();
    assert!((1..402).contains(&n), "{n} frames of 402");
    assert_eq!(
        rest.iter().filter(|l| l.starts_with("frame")).count() + 1,
        n,
        "every frame printed is in the file"
    );
    assert!(out.join("dry-run.mp4").is_file());
    assert!(!out.join(".dry-run.mp4").exists());
}

/// Ctrl-C in the middle of a long frame (the first of 600 particles, where
/// a four-letter pattern is placed by full plans: over a minute on a
/// loaded machine) is answered at once on stderr and stops the dry-run
/// within seconds, with what was analysed (here nothing) written and
/// readable: the frame had been finished first, 8-120 s without a word.
#[test]
fn ctrl_c_in_a_long_frame_is_answered_and_stops_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let frames = rec.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for name in ["bulk_water_000.png", "bulk_water_100.png"] {
        std::fs::copy(
            root().join("fixtures/real/bulk_water").join(name),
            frames.join(name),
        )
        .unwrap();
    }
    // 1 um spheres at 2.85 px/um (fixtures/real/PROVENANCE.md).
    std::fs::write(
        rec.join("calibration.toml"),
        "schema = \"nanopush.calibration/1\"\npixel_to_stage_um = [[0.350877, 0.0, 0.0], [0.0, -0.350877, 148.77]]\n",
    )
    .unwrap();
    std::fs::write(
        rec.join("recording.toml"),
        "schema = \"nanopush.recording/1\"\nsource = \"bulk_water\"\nframes = \"frames\"\n\
         calibration = \"calibration.toml\"\nparticle_radius_um = 0.5\nframe_interval_s = 1.0\n\
         channel = \"green\"\ndetect_tip = false\nfield_um = [224.5, 148.7]\npattern_text = \"NANO\"\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let command = dry_run_command(&rec, &out);
    let pressed = interrupt_after(command, &["replay: "], Duration::from_secs(1));
    let stderr =
        pressed.stopped_at_once("stopping the dry-run (Ctrl-C or a termination signal) now");
    let rest = pressed.after;
    assert!(
        stderr.contains("dry-run interrupted (Ctrl-C or a termination signal) after 0 frames"),
        "{stderr}"
    );
    let written: DryRunReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("dry-run.json")).unwrap()).unwrap();
    assert_eq!(
        written.frames.len(),
        rest.iter().filter(|l| l.starts_with("frame")).count(),
        "every frame printed is in the file, and no other"
    );
    assert!(
        written
            .ended_early
            .is_some_and(|why| why.contains("interrupted"))
    );
}

/// `nanopush dry-run` of `rec` into `out`, run from the project's root.
fn dry_run_command(rec: &Path, out: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_nanopush"));
    command
        .current_dir(root())
        .args(["dry-run", "--recording"])
        .arg(rec)
        .arg("--out")
        .arg(out);
    command
}

/// The fixture's frames as an MJPG video at 25 fps, its stage log left out:
/// frames are the video's frame rate apart (they had been 1 s, so the
/// model's advice was asked for a session 25 times older), and a copy of
/// the video cut short says how many frames it read of how many.
#[test]
fn a_video_recording_keeps_its_frame_rate_and_says_when_it_is_cut_short() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    copy_dir(&root().join("fixtures/recordings/sim-L-seed6"), &rec);
    let frames = load_frames(&rec.join("frames"), Channel::Luminance).unwrap();
    let (w, h) = (frames[0].width() as u32, frames[0].height() as u32);
    let mut video =
        nanopush::render::video::VideoWriter::create(&rec.join("frames.avi"), 25.0, (w, h))
            .unwrap();
    for f in &frames {
        let grey = image::GrayImage::from_fn(w, h, |x, y| {
            image::Luma([(f.at(x as usize, y as usize) * 255.0 / f.max_count()).round() as u8])
        });
        video
            .write(&image::DynamicImage::ImageLuma8(grey).to_rgb8())
            .unwrap();
    }
    assert_eq!(video.finish().unwrap(), 4);
    set_line(
        &rec,
        "recording.toml",
        "frames =",
        "frames = \"frames.avi\"",
    );
    set_line(&rec, "recording.toml", "stage_log", "# no stage log");
    let out = dir.path().join("out");
    let r = ok_report(&dry_run(&rec, &out, &[]), &out);
    let times: Vec<f64> = r.frames.iter().map(|f| f.t_s).collect();
    assert_eq!(times.len(), 4);
    for (i, t) in times.iter().enumerate() {
        assert!((t - 0.04 * i as f64).abs() < 1e-9, "{times:?}");
    }
    // The description's own interval stands over the video's, and times
    // read as a person writes them (3 x 0.2 s had read 0.6000000000000001).
    set_line(
        &rec,
        "recording.toml",
        "# no stage log",
        "frame_interval_s = 0.2",
    );
    let out2 = dir.path().join("out2");
    let r = ok_report(&dry_run(&rec, &out2, &[]), &out2);
    assert_eq!(r.frames[3].t_s, 0.6);
    // Cut to its first half: fewer frames, and a warning that says so.
    let bytes = std::fs::read(rec.join("frames.avi")).unwrap();
    std::fs::write(rec.join("frames.avi"), &bytes[..bytes.len() / 2]).unwrap();
    let out3 = dir.path().join("out3");
    let o = dry_run(&rec, &out3, &[]);
    let r = ok_report(&o, &out3);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(r.frames.len() < 4, "{} frames", r.frames.len());
    assert!(
        stderr.contains(&format!(
            "the video says it has 4 frames, but only the first {} could be read",
            r.frames.len()
        )),
        "{stderr}"
    );
    // With the fixture's stage log of 4 entries (copied with it), the cut
    // video is refused when it ends: the frames before it were printed, and
    // no --out is left behind.
    set_line(
        &rec,
        "recording.toml",
        "frame_interval_s",
        "stage_log = \"stage.jsonl\"",
    );
    let out4 = dir.path().join("out4");
    let o = dry_run_for_people(&rec, &out4);
    assert_refused(
        &o,
        &format!("4 stage-log entries for {} frames", r.frames.len()),
    );
    let printed = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        printed.lines().filter(|l| l.starts_with("frame ")).count(),
        r.frames.len(),
        "{printed}"
    );
    assert!(!out4.exists(), "a refused dry-run left its --out behind");
}

/// The fixture's frames as an ImageJ TIFF stack without a stage log,
/// its description stating `description` on the first page.
fn imagej_stack_recording(dir: &Path, description: &str) -> PathBuf {
    let rec = dir.join("rec");
    copy_dir(&root().join("fixtures/recordings/sim-L-seed6"), &rec);
    let frames = load_frames(&rec.join("frames"), Channel::Luminance).unwrap();
    let file = std::fs::File::create(rec.join("frames.tif")).unwrap();
    let mut tiff = tiff::encoder::TiffEncoder::new(file).unwrap();
    for (k, f) in frames.iter().enumerate() {
        let mut image = tiff
            .new_image::<tiff::encoder::colortype::Gray16>(f.width() as u32, f.height() as u32)
            .unwrap();
        if k == 0 {
            image
                .encoder()
                .write_tag(tiff::tags::Tag::ImageDescription, description)
                .unwrap();
        }
        let samples: Vec<u16> = f.pixels().iter().map(|&p| p as u16).collect();
        image.write_data(&samples).unwrap();
    }
    set_line(
        &rec,
        "recording.toml",
        "frames =",
        "frames = \"frames.tif\"",
    );
    set_line(&rec, "recording.toml", "stage_log", "# no stage log");
    rec
}

/// An ImageJ stack's stated frame interval (`finterval=0.5`) gives the
/// frames' times, and the dry-run says so; the recording's own
/// `frame_interval_s` overrides it, with a warning that they disagree; a
/// stated interval that is not a time is warned of and not used. The
/// stack's frames had been taken 1 s apart whatever it said.
#[test]
fn an_imagej_stacks_frame_interval_gives_the_frames_times() {
    let times = |r: &DryRunReport| r.frames.iter().map(|f| f.t_s).collect::<Vec<_>>();
    let dir = tempfile::tempdir().unwrap();
    let rec = imagej_stack_recording(
        dir.path(),
        "ImageJ=1.54f\nimages=4\nframes=4\nfinterval=0.5\nloop=false\n",
    );
    let out = dir.path().join("out");
    let o = dry_run(&rec, &out, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(times(&ok_report(&o, &out)), [0.0, 0.5, 1.0, 1.5]);
    assert!(!stderr.contains("1 s apart"), "{stderr}");
    let (printed, _) = printed_dry_run(&rec, &dir.path().join("printed"));
    assert!(
        printed.contains("replay: frame interval 0.5 s, from the stack's ImageJ description"),
        "{printed}"
    );
    // The user's value wins, and the disagreement is said.
    set_line(
        &rec,
        "recording.toml",
        "# no stage log",
        "frame_interval_s = 2.0",
    );
    let out2 = dir.path().join("out2");
    let o = dry_run(&rec, &out2, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(times(&ok_report(&o, &out2)), [0.0, 2.0, 4.0, 6.0]);
    assert!(
        stderr.contains(
            "frame_interval_s = 2 is used, but the stack's ImageJ description says 0.5 s"
        ),
        "{stderr}"
    );
    // A stated interval of 0 is refused, named, and the default taken.
    let dir0 = tempfile::tempdir().unwrap();
    let rec0 = imagej_stack_recording(dir0.path(), "ImageJ=1.54f\nimages=4\nfinterval=0\n");
    let out3 = dir0.path().join("out");
    let o = dry_run(&rec0, &out3, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(times(&ok_report(&o, &out3)), [0.0, 1.0, 2.0, 3.0]);
    assert!(
        stderr.contains("the stack's ImageJ description states finterval=0, which is not a positive time between frames: not used"),
        "{stderr}"
    );
    assert!(stderr.contains("frames are taken 1 s apart"), "{stderr}");
}

/// A camera that sees beyond the field (here the calibration puts the
/// frame's left 80 um at negative x): the particles there are obstacles
/// no plan pushes, with a warning, and the others are planned. Every frame's
/// plan had been refused whole: "particle 2 at (-43.473, 87.954) um lies
/// outside the 120.0 x 100.0 um field".
#[test]
fn particles_beyond_the_field_are_obstacles_of_the_plans_not_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    copy_dir(&root().join("fixtures/recordings/sim-L-seed6"), &rec);
    let cal = std::fs::read_to_string(rec.join("calibration.toml")).unwrap();
    assert!(cal.contains("-20.0]"), "{cal}");
    std::fs::write(
        rec.join("calibration.toml"),
        cal.replace("-20.0]", "-80.0]"),
    )
    .unwrap();
    // The shifted map puts the apex 60 um from the stage log, where the
    // loop stops for the calibration (tested on its own): the probe is not
    // looked for here.
    set_line(&rec, "recording.toml", "detect_tip", "detect_tip = false");
    let out = dir.path().join("out");
    let o = dry_run(&rec, &out, &[]);
    let r = ok_report(&o, &out);
    let beyond = |f: &nanopush::exec::dry_run::DryRunFrame| {
        f.particles
            .iter()
            .filter(|p| p.x_um < -2.0 * p.r_um)
            .count()
    };
    assert!(beyond(&r.frames[0]) >= 3, "{:?}", r.frames[0].particles);
    for f in &r.frames {
        assert!(
            matches!(f.command, DryCommand::Push { .. }),
            "frame {}: {:?}",
            f.frame,
            f.command
        );
        if let DryCommand::Push { from_um, .. } = f.command {
            assert!(from_um[0] > -10.0, "frame {}: pushes {from_um:?}", f.frame);
        }
    }
    let stderr = String::from_utf8_lossy(&o.stderr);
    let warned = format!(
        "{} particles lie beyond the 120.0 x 100.0 um field",
        beyond(&r.frames[0])
    );
    assert!(stderr.contains(&warned), "{stderr}");
    // A pattern the particles in the field cannot fill is refused on the
    // first frame, counting only those (it had been taken, and every
    // frame's plan refused "3 sites but only 1 particles").
    let bf = dir.path().join("bf");
    copy_dir(&root().join("fixtures/recordings/real-brightfield"), &bf);
    set_line(
        &bf,
        "calibration.toml",
        "pixel_to_stage_um",
        "pixel_to_stage_um = [[0.588235, 0.0, -200.0], [0.0, -0.588235, 294.1176]]",
    );
    assert_refused(
        &dry_run(&bf, &dir.path().join("bf-out"), &[]),
        "the pattern has 3 sites but the first frame shows 1 particle in the field (4 more beyond it)",
    );
}

/// The dry-run takes the push it commanded as made, as the loop takes its
/// own, and keeps its plan in hand as the loop does: on a recorded run it
/// commands every push the loop made, in its order (CMU, seed 3: 30 of 40
/// had matched, then 35 with the pushes taken as made). Matched as
/// unpushed, a particle pushed out from under the probe had got a new id,
/// and its old place, hidden by the probe, stayed as a ghost the planner
/// pushed: 51 particles in a world of 50, and pushes of 29 nm the loop
/// never made. Its plans keep the gap round the pattern the run kept (the
/// recording's `keep_clear_um`): planning with none, it commanded other
/// pushes from frame 32 on, and saw 51 particles there.
#[test]
fn on_a_recorded_run_the_dry_run_commands_every_push_the_loop_made() {
    let dir = tempfile::tempdir().unwrap();
    let (out, rec) = recorded_run(dir.path(), "CMU", "3", "50");
    let dry = dir.path().join("dry");
    let r = ok_report(&dry_run(&rec, &dry, &[]), &dry);
    assert!(r.frames.len() > 30, "{} frames", r.frames.len());
    for f in &r.frames {
        assert!(
            f.particles.len() <= 50,
            "frame {}: {} particles in a world of 50",
            f.frame,
            f.particles.len()
        );
    }
    // Each decision of the run against the dry-run's command on the frame
    // the run decided on (the last observed before it).
    let mut observed = 0;
    let mut decisions = Vec::new();
    for entry in read_journal::<RunEvent>(&out.join("journal.jsonl"))
        .unwrap()
        .entries
    {
        match entry.event {
            RunEvent::Observation { .. } => observed += 1,
            RunEvent::Decision { from_um, to_um, .. } => {
                decisions.push((observed - 1, from_um, to_um))
            }
            _ => {}
        }
    }
    assert!(decisions.len() > 30, "{} decisions", decisions.len());
    let near = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 0.1;
    let differing: Vec<usize> = decisions
        .iter()
        .filter(|(frame, from, to)| {
            !matches!(r.frames[*frame].command,
                DryCommand::Push { from_um, to_um, .. } if near(from_um, *from) && near(to_um, *to))
        })
        .map(|d| d.0)
        .collect();
    assert!(
        differing.is_empty(),
        "frames commanding another push: {differing:?}"
    );
}

/// A run started from any folder records the scene it ran with (the
/// default scene's path is the project's; from elsewhere the run used the
/// built-in copy and had recorded no scene, so the dry-run gave no angle
/// or duration); a resumed run cannot be recorded, and says so.
#[test]
fn a_recording_made_from_another_folder_keeps_its_scene() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_nanopush"))
            .current_dir(dir.path())
            .args(args)
            .output()
            .unwrap()
    };
    let o = run(&[
        "assemble",
        "--text",
        "L",
        "--seed",
        "6",
        "--particles",
        "20",
        "--out",
        "out",
        "--record",
        "rec",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let scene = std::fs::read_to_string(dir.path().join("rec/scene.toml")).unwrap();
    let paper = std::fs::read_to_string(root().join("calib/paper-ps-ito.toml")).unwrap();
    assert_eq!(scene, paper);
    let r = ok_report(
        &dry_run(&dir.path().join("rec"), &dir.path().join("dry"), &[]),
        &dir.path().join("dry"),
    );
    assert!(
        matches!(
            r.frames[1].command,
            DryCommand::Push {
                contact_angle_deg: Some(_),
                ..
            }
        ),
        "{:?}",
        r.frames[1].command
    );
    let o = run(&[
        "assemble",
        "--resume",
        "out/journal.jsonl",
        "--record",
        "rec2",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--record") && err.contains("--resume"),
        "{err}"
    );
    assert!(!dir.path().join("rec2").exists());
}

/// A recording replayed through a calibration that is not its camera's
/// (shifted 6.7 um at the apex): the loop would stop on its first look, and
/// the dry-run says so on every frame instead of commanding pushes (it had
/// commanded them through a mirrored calibration, exit 0).
#[test]
fn a_calibration_that_misplaces_the_apex_is_where_the_loop_would_stop() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    copy_dir(&root().join("fixtures/recordings/sim-L-seed6"), &rec);
    let out = dir.path().join("out");
    let report = ok_report(&dry_run(&rec, &out, &[]), &out);
    assert!(
        report
            .frames
            .iter()
            .any(|f| matches!(f.command, DryCommand::Push { .. })),
        "the recording's own calibration commands pushes"
    );
    set_line(
        &rec,
        "calibration.toml",
        "pixel_to_stage_um",
        "pixel_to_stage_um = [[0.25, 0.0, -23.0], [0.0, -0.25, 126.0]]",
    );
    let out = dir.path().join("out2");
    let report = ok_report(&dry_run(&rec, &out, &[]), &out);
    for f in &report.frames {
        match &f.command {
            DryCommand::Refused { reason } => {
                assert!(reason.contains("calibration does not fit"), "{reason}")
            }
            other => panic!("frame {}: {other:?}", f.frame),
        }
    }
}

/// A stage log an editor left a blank last line in, given as the
/// recording.toml file itself: both read (the first had been refused as
/// "EOF while parsing a value", the second looked for
/// "recording.toml/recording.toml").
#[test]
fn a_blank_stage_log_line_and_the_recording_file_itself_are_taken() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    copy_dir(&root().join("fixtures/recordings/sim-L-seed6"), &rec);
    let log = rec.join("stage.jsonl");
    let text = std::fs::read_to_string(&log).unwrap();
    std::fs::write(&log, format!("{text}\n")).unwrap();
    let out = dir.path().join("out");
    let report = ok_report(&dry_run(&rec.join("recording.toml"), &out, &[]), &out);
    assert_eq!(report.frames.len(), 4);
}

/// Where the recording shows that the push commanded on the frame before
/// was not made, the frame says so (the dry-run then plans from what it
/// shows, and its commands may part from the run's; that had gone
/// unsaid). The fixture's frame 2 is taken with the probe parked: frame
/// 1's 17.8 um push of particle 16 is not made there.
#[test]
fn a_frame_says_when_the_last_command_was_not_made() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let rec = root().join("fixtures/recordings/sim-L-seed6");
    let report = ok_report(&dry_run(&rec, &out, &[]), &out);
    let flags: Vec<bool> = report
        .frames
        .iter()
        .map(|f| f.last_command_not_made)
        .collect();
    assert_eq!(flags[..3], [false, false, true], "{flags:?}");
    let (printed, _) = printed_dry_run(&rec, &dir.path().join("p"));
    assert!(
        printed.contains("does not show the last command made"),
        "{printed}"
    );
}

/// Where the loop pushes on with a plan in hand that fails only later (no
/// fresh order found in a dense core), the run finishes (it had stopped at
/// 0 of 20 sites after 5 pushes, a step 79 of its plan 0.17 um into a
/// particle) and the dry-run of its recording commands the same pushes (it
/// had said "planner: no collision-free order" on 17 frames the loop
/// pushed through).
#[test]
fn the_dry_run_pushes_on_with_a_plan_in_hand_as_the_loop_does() {
    let dir = tempfile::tempdir().unwrap();
    let layout = dir.path().join("layout.json");
    // `synth layout --n 50 --field-um 120x100 --radius-um 5 --min-gap-um 1
    // --kind adversarial --seed 5`: a dense core under the letters.
    synth_layout(&field_120x100(50, 5.0, LayoutKind::Adversarial, false, 5))
        .unwrap()
        .write(&layout)
        .unwrap();
    let (out, rec) = (dir.path().join("out"), dir.path().join("rec"));
    let run = nanopush(&[
        "assemble",
        "--text",
        "HI",
        "--layout",
        layout.to_str().unwrap(),
        "--seed",
        "5",
        "--out",
        out.to_str().unwrap(),
        "--record",
        rec.to_str().unwrap(),
    ]);
    let said = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{said}");
    assert!(said.contains("the plan in hand fails only later"), "{said}");
    let r = ok_report(
        &dry_run(&rec, &dir.path().join("dry"), &[]),
        &dir.path().join("dry"),
    );
    let refused: Vec<_> = (r.frames.iter())
        .filter(|f| matches!(f.command, DryCommand::Refused { .. }))
        .collect();
    assert!(refused.is_empty(), "{:?}", refused[0].command);
    assert_eq!(r.frames.last().unwrap().command, DryCommand::Done);
}
