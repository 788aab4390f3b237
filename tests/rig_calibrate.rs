//! `nanopush rig calibrate` end to end, with no hardware: the GCS controller
//! simulator over loopback TCP moves the probe, and the simulated microscope
//! draws it through a known, turned camera map into a watched folder. The
//! map the command fits must be that map; its recording must fit the same
//! map again through `nanopush calibrate`; a second run must not replace
//! it unasked.

use nanopush::calib::camera_map::CameraCalibration;
use nanopush::calib::lens::RadialLens;
use nanopush::model::Scene;
use nanopush::rig::gcs::{RigFile, SimConfig, SimServer};
use nanopush::rig::microscope_feeder::{MicroscopeFeeder, layout_in_travel};
use nanopush::vision::frame_input::{Channel, load_frame};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

const UM: f64 = 1e-6;

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The camera map of the simulated microscope: 0.3 um a pixel, turned 5
/// degrees and mirrored in y against the stage (as a camera looking down
/// through an objective may be), pixel (0, 0) near stage (-8, 115) um.
fn truth() -> CameraCalibration {
    let (s, c) = 5f64.to_radians().sin_cos();
    let k = 0.3 * UM;
    CameraCalibration::affine(
        nalgebra::Matrix2::new(k * c, k * s, k * s, -k * c),
        nalgebra::Vector2::new(-8.0 * UM, 115.0 * UM),
    )
}

/// The simulator and the microscope, and a rig file for the command that
/// names a calibration not made yet.
struct Bench {
    // Field order is drop order: the feeder stops before the server.
    _feeder: MicroscopeFeeder,
    _server: SimServer,
    dir: tempfile::TempDir,
    rig: PathBuf,
}

fn bench() -> Bench {
    bench_through(&truth())
}

/// The bench with the microscope drawing through `camera`.
fn bench_through(camera: &CameraCalibration) -> Bench {
    let mut server = SimServer::new(SimConfig::default());
    server.handle().with(|c, now| c.set_time_scale(50.0, now));
    let addr = server.serve_tcp("127.0.0.1:0").unwrap().to_string();
    let dir = tempfile::tempdir().unwrap();
    let truth_path = dir.path().join("truth.toml");
    std::fs::write(&truth_path, camera.to_toml(None)).unwrap();
    let frames = dir.path().join("frames");
    let text = std::fs::read_to_string(manifest().join("calib/rig-gcs-sim-folder.toml"))
        .unwrap()
        .replace("127.0.0.1:50000", &addr)
        .replace(
            "\"../out/rig-gcs-sim-folder/frames\"",
            &format!("{:?}", frames.display().to_string()),
        );
    let truth_rig = dir.path().join("truth-rig.toml");
    std::fs::write(
        &truth_rig,
        text.replace("\"camera-stage-sim-folder.toml\"", "\"truth.toml\""),
    )
    .unwrap();
    let rig = dir.path().join("rig.toml");
    std::fs::write(
        &rig,
        text.replace("\"camera-stage-sim-folder.toml\"", "\"camera.toml\""),
    )
    .unwrap();
    let scene = Scene::load(&manifest().join("calib/paper-ps-ito.toml")).unwrap();
    let layout = layout_in_travel(&scene, 12, [100.0 * UM, 100.0 * UM], 10.0 * UM, 5).unwrap();
    let feeder = MicroscopeFeeder::for_rig_file(
        server.handle(),
        None,
        &RigFile::load(&truth_rig).unwrap(),
        &scene,
        &layout,
        5,
        Duration::from_millis(20),
    )
    .unwrap();
    Bench {
        _feeder: feeder,
        _server: server,
        dir,
        rig,
    }
}

fn nanopush(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .current_dir(manifest())
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: &Output) -> String {
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// The map `nanopush calibrate` fits to `recording` (with `extra` flags),
/// written to `out`.
fn refit(recording: &Path, out: &Path, extra: &[&str]) -> CameraCalibration {
    let (recording, out_arg) = (recording.to_str().unwrap(), out.to_str().unwrap());
    let args = [
        &["calibrate", "--recording", recording, "--out", out_arg][..],
        extra,
    ]
    .concat();
    ok(&nanopush(&args));
    CameraCalibration::load(out).unwrap()
}

/// Largest distance between where two maps put a pixel of a 400 x 400 px
/// view, micrometres.
fn worst_um(a: &CameraCalibration, b: &CameraCalibration) -> f64 {
    a.largest_difference_m(b, 401, 401) / UM
}

#[test]
fn calibrating_on_the_simulated_rig_finds_the_cameras_map_and_keeps_its_recording() {
    let b = bench();
    let rig = b.rig.to_str().unwrap();
    let text = ok(&nanopush(&["rig", "calibrate", "--rig", rig]));
    assert!(
        text.contains("the rig file names this calibration"),
        "{text}"
    );
    let written = b.dir.path().join("camera.toml");
    let fitted = CameraCalibration::load(&written).unwrap();
    let err = worst_um(&fitted, &truth());
    println!("fitted map against the camera's: worst {err:.4} um over the view\n{text}");
    // A third of a pixel (0.1 um) anywhere in the view; a map fitted
    // without the turn would be 0.3 um/px x 400 px x sin 5 deg = 10 um off.
    assert!(err < 0.1, "{err} um");

    // The recording fits the same map again.
    let recording = b.dir.path().join("camera-recording");
    let csv = std::fs::read_to_string(recording.join("stage.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3 + 16, "{csv}");
    let again = refit(&recording, &b.dir.path().join("again.toml"), &[]);
    assert!(worst_um(&again, &fitted) < 1e-6);

    // A second run keeps the calibration and moves nothing.
    let before = std::fs::read_to_string(&written).unwrap();
    let out = nanopush(&["rig", "calibrate", "--rig", rig]);
    assert!(!out.status.success());
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(message.contains("--force"), "{message}");
    assert_eq!(std::fs::read_to_string(&written).unwrap(), before);
    // Neither does a run into the same recording with another output.
    let out = nanopush(&[
        "rig",
        "calibrate",
        "--rig",
        rig,
        "--out",
        b.dir.path().join("other.toml").to_str().unwrap(),
        "--recording",
        recording.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(message.contains("holds a recording already"), "{message}");

    // A map fitted into the recording itself, and a note of the user's.
    let in_recording = recording.join("calibration.toml");
    refit(&recording, &in_recording, &[]);
    std::fs::write(recording.join("notes.txt"), "objective 20x").unwrap();

    // With --force it measures again (on a smaller grid) and says how far
    // the old map was. The earlier recording goes with it: 7 of its frames
    // and the map fitted from it had stayed beside the new stage.csv.
    let text = ok(&nanopush(&[
        "rig",
        "calibrate",
        "--rig",
        rig,
        "--force",
        "--grid",
        "3",
    ]));
    let csv = std::fs::read_to_string(recording.join("stage.csv")).unwrap();
    let pngs = std::fs::read_dir(&recording)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "png")
        })
        .count();
    assert_eq!(pngs, csv.lines().count() - 1, "{csv}");
    assert!(pngs < 19, "{csv}");
    assert!(!in_recording.exists());
    assert!(recording.join("notes.txt").exists());
    let moved: f64 = text
        .split("put the view up to ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{text}"));
    let new = CameraCalibration::load(&written).unwrap();
    println!("measured again: the two maps differ by up to {moved:.4} um over the view");
    // Over the frames' own view (the command's), to its 3 decimals.
    let frame = load_frame(&recording.join("frame_000.png"), Channel::Luminance).unwrap();
    let (w, h) = (frame.width(), frame.height());
    assert!(
        (moved - new.largest_difference_m(&fitted, w, h) / UM).abs() < 1e-3,
        "{moved}\n{text}"
    );
    assert!(worst_um(&new, &truth()) < 0.1);
}

#[test]
fn an_objective_that_bends_the_view_is_measured_with_the_map() {
    // Barrel distortion of 0.8 % at the corner of the view (about 2.3 px),
    // centred on the frame of about 355 x 466 px the travel makes: what
    // an affine map cannot follow.
    let lens = RadialLens::centred_on(355, 466, -0.008);
    let camera = truth().with_lens(Some(lens));
    let b = bench_through(&camera);
    let text = ok(&nanopush(&[
        "rig",
        "calibrate",
        "--rig",
        b.rig.to_str().unwrap(),
    ]));
    assert!(text.contains("lens k1"), "{text}");
    let fitted = CameraCalibration::load(&b.dir.path().join("camera.toml")).unwrap();
    let recording = b.dir.path().join("camera-recording");
    let first = recording.join("frame_000.png");
    let frame = nanopush::vision::frame_input::load_frame(
        &first,
        nanopush::vision::frame_input::Channel::Luminance,
    )
    .unwrap();
    let (w, h) = (frame.width(), frame.height());
    let err = fitted.largest_difference_m(&camera, w, h) / UM;
    // The same recording fitted without the lens.
    let affine = refit(
        &recording,
        &b.dir.path().join("affine.toml"),
        &["--lens", "none"],
    );
    let affine_err = affine.largest_difference_m(&camera, w, h) / UM;
    println!(
        "{w} x {h} px view: with the lens worst {err:.4} um (k1 {:+.5}, true {:+.5}); affine alone worst {affine_err:.4} um\n{text}",
        fitted.lens.map_or(0.0, |l| l.k1),
        lens.k1
    );
    assert!(err < 0.1, "{err} um");
    assert!(affine_err > 2.0 * err, "{affine_err} um");
}

/// A rig file in `dir` naming a calibration not made yet (camera.toml),
/// with nobody listening at its stage's address.
fn unreachable_rig(dir: &Path) -> PathBuf {
    let rig = dir.join("rig.toml");
    std::fs::write(
        &rig,
        std::fs::read_to_string(manifest().join("calib/rig-gcs-sim-folder.toml"))
            .unwrap()
            .replace("\"camera-stage-sim-folder.toml\"", "\"camera.toml\""),
    )
    .unwrap();
    rig
}

#[test]
fn bad_calibration_flags_are_refused_before_the_rig_is_opened() {
    // Nobody listens at the rig file's address: a flag error must come first.
    let dir = tempfile::tempdir().unwrap();
    let rig = unreachable_rig(dir.path());
    let rig = rig.to_str().unwrap();
    for (flags, says) in [
        (&["--grid", "1"][..], "2 to 20 points a side, got 1"),
        (&["--grid", "1000"][..], "2 to 20 points a side, got 1000"),
        (&["--step-um=-5"][..], "positive length"),
        (&["--threshold-px", "0"][..], "--threshold-px"),
    ] {
        let mut args = vec!["rig", "calibrate", "--rig", rig];
        args.extend_from_slice(flags);
        let out = nanopush(&args);
        assert!(!out.status.success());
        let message = String::from_utf8_lossy(&out.stderr);
        assert!(message.contains(says), "{flags:?}: {message}");
        assert!(!message.contains("connecting"), "{message}");
    }
}

/// A file given as --recording is refused before the rig is opened,
/// named by its kind (it had failed after the rig was opened, "reading
/// .../stage.csv: Not a directory").
#[test]
fn a_file_given_as_the_recording_folder_is_refused_by_what_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let rig = unreachable_rig(dir.path());
    let scene = manifest().join("calib/paper-ps-ito.toml");
    let notes = dir.path().join("notes.txt");
    std::fs::write(&notes, "objective 20x").unwrap();
    for (file, says) in [
        (
            &scene,
            "this is a scene file (nanopush.scene/1), not a recording folder",
        ),
        (&notes, "give a recording folder (frames and stage.csv"),
    ] {
        let out = nanopush(&[
            "rig",
            "calibrate",
            "--rig",
            rig.to_str().unwrap(),
            "--recording",
            file.to_str().unwrap(),
        ]);
        assert!(!out.status.success());
        let message = String::from_utf8_lossy(&out.stderr);
        assert!(
            message.contains(&format!("--recording {} is a file: {says}", file.display())),
            "{message}"
        );
        assert!(!message.contains("connecting"), "{message}");
    }
}

/// On a stage without z, --z-um is refused before the rig is opened as a
/// flag that does not apply: its refusal had ended "run the same command
/// again", which stops the same way.
#[test]
fn z_um_on_a_stage_without_z_is_said_not_to_apply() {
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("rig.toml");
    let text = std::fs::read_to_string(manifest().join("calib/rig-gcs-sim.toml")).unwrap();
    assert!(text.contains("axes = [\"1\", \"2\"]"), "{text}");
    std::fs::write(
        &rig,
        text.replace("\"camera-stage-sim.toml\"", "\"camera.toml\""),
    )
    .unwrap();
    for (by_hand, then) in [
        (&["--tip-lifted-by-hand"][..], "Leave --z-um out"),
        (
            &[][..],
            "Leave --z-um out, lift the tip clear by hand and pass --tip-lifted-by-hand",
        ),
    ] {
        let args = [
            "rig",
            "calibrate",
            "--rig",
            rig.to_str().unwrap(),
            "--z-um",
            "50",
        ];
        let out = nanopush(&[&args[..], by_hand].concat());
        assert!(!out.status.success());
        let message = String::from_utf8_lossy(&out.stderr);
        assert!(
            message.contains("the stage has no z axis")
                && message.contains("--z-um 50 does not apply")
                && message.trim_end().ends_with(then)
                && !message.contains("run the same command again"),
            "{by_hand:?}: {message}"
        );
    }
}

#[test]
fn a_missing_calibration_is_named_with_how_to_make_it() {
    let dir = tempfile::tempdir().unwrap();
    let rig = unreachable_rig(dir.path());
    let rig = rig.to_str().unwrap();
    let out_dir = dir.path().join("run");
    for args in [
        vec!["rig", "probe", "--rig", rig, "--camera"],
        vec![
            "assemble",
            "--rig",
            rig,
            "--text",
            "L",
            "--out",
            out_dir.to_str().unwrap(),
        ],
    ] {
        let out = nanopush(&args);
        assert!(!out.status.success());
        let message = String::from_utf8_lossy(&out.stderr);
        assert!(
            message.contains("camera.toml") && message.contains("nanopush rig calibrate --rig"),
            "{args:?}: {message}"
        );
    }
}

/// `nanopush rig calibrate --rig RIG --out OUT`'s arguments.
fn calibrate_into<'a>(rig: &'a str, out: &'a str) -> [&'a str; 6] {
    ["rig", "calibrate", "--rig", rig, "--out", out]
}

/// The names in `dir`, sorted.
fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_refused_run_leaves_no_folder_it_made_and_advises_only_what_is_accepted() {
    let b = bench();
    let good = std::fs::read_to_string(&b.rig).unwrap();
    // The simulator's stage starts at x = 50 um: outside 52..98.
    let off = good.replace(
        "soft_min_um = [2.0, 2.0, 0.0]",
        "soft_min_um = [52.0, 2.0, 0.0]",
    );
    assert_ne!(off, good, "the replacement did not apply");
    std::fs::write(&b.rig, &off).unwrap();
    let rig = b.rig.to_str().unwrap();
    let made = b.dir.path().join("new");
    let out = made.join("cal/camera.toml");
    let mine = b.dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), "objective 20x").unwrap();
    let args = calibrate_into(rig, out.to_str().unwrap());
    for extra in [&[][..], &["--recording", mine.to_str().unwrap()]] {
        let refused = nanopush(&[&args[..], extra].concat());
        assert!(!refused.status.success());
        let message = String::from_utf8_lossy(&refused.stderr);
        assert!(
            message.contains("outside the rig file's limits"),
            "{message}"
        );
        // Refused before any move: said so, not "stopped at ...".
        assert!(
            message.contains("nothing moved: the stage is where it was, at (50.00, 50.00) um")
                && !message.contains("not put back"),
            "{message}"
        );
        // No frame: nothing to fit, so no fit is advised.
        assert!(!message.contains("nanopush calibrate"), "{message}");
        assert!(message.contains("run the same command again"), "{message}");
        assert!(!made.exists(), "{message}");
        assert_eq!(names_in(&mine), ["notes.txt"], "{message}");
    }
    // Put right, the same command is accepted.
    std::fs::write(&b.rig, &good).unwrap();
    ok(&nanopush(&args));
    assert!(out.exists());
}

/// Stopped with Ctrl-C after one frame (short of a fit) or after seven
/// (enough), the command advised is accepted; a fit is advised with the
/// run's own output (it had said `--out FILE`).
#[test]
fn a_run_stopped_early_advises_a_command_that_is_accepted() {
    for frames_before_stop in [1, 7] {
        stopped_after(frames_before_stop);
    }
}

/// A calibration run stopped with Ctrl-C once `frames` frames are saved.
fn stopped_after(frames: usize) {
    let b = bench();
    let rig = b.rig.to_str().unwrap();
    let args = ["rig", "calibrate", "--rig", rig];
    let child = Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .current_dir(manifest())
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let csv = b.dir.path().join("camera-recording/stage.csv");
    let started = std::time::Instant::now();
    while std::fs::read_to_string(&csv).map_or(0, |t| t.lines().count()) < frames + 1 {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "no frame saved"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGINT,
    )
    .unwrap();
    let stopped = child.wait_with_output().unwrap();
    assert!(!stopped.status.success());
    let message = String::from_utf8_lossy(&stopped.stderr);
    let frames = std::fs::read_to_string(&csv).unwrap().lines().count() - 1;
    println!("stopped after {frames} frames: {message}");
    assert!(message.contains("interrupted"), "{message}");
    // It moved: where it stopped, and that it stays there.
    assert!(
        message.contains("the stage stopped at") && message.contains("it was not put back"),
        "{message}"
    );
    // Whatever it advises is accepted; the fit writes where the run was to write.
    let fit = format!(
        "`nanopush calibrate --recording {} --out {}`",
        csv.parent().unwrap().display(),
        b.dir.path().join("camera.toml").display()
    );
    if message.contains("fit them with") {
        assert!(message.contains(&fit), "{message}");
        refit(csv.parent().unwrap(), &b.dir.path().join("fit.toml"), &[]);
    } else {
        assert!(
            frames < 7 && message.contains("run the same command again with --force"),
            "{message}"
        );
        ok(&nanopush(&[&args[..], &["--force"]].concat()));
    }
}

/// A flag the run cannot work with is named with a value that works, and
/// that value is accepted: a first step longer than the room in the range
/// (the tip had only been lifted and lowered again, yet the run said "the
/// stage stopped at ...; it was not put back" and "run the same command
/// again"), a travel height above z's travel or among the particles
/// (`--z-um 2` had been accepted: `assemble --rig` refuses to travel
/// there).
#[test]
fn a_flag_the_run_cannot_work_with_is_named_with_one_it_can() {
    let b = bench();
    let rig = b.rig.to_str().unwrap();
    let out = b.dir.path().join("cal/camera.toml");
    let args = calibrate_into(rig, out.to_str().unwrap());
    let stopped = nanopush(&[&args[..], &["--step-um", "500"]].concat());
    assert!(!stopped.status.success());
    let message = String::from_utf8_lossy(&stopped.stderr);
    assert!(
        message.contains("only the tip's height changed (x and y never moved), and it was put back where it was, at (50.00, 50.00) um")
            && !message.contains("not put back"),
        "{message}"
    );
    assert!(
        message.contains("run it again with --force and --step-um 5 instead of 500")
            && !message.contains("the same command"),
        "{message}"
    );
    ok(&nanopush(
        &[&args[..], &["--force", "--step-um", "5", "--grid", "2"]].concat(),
    ));
    std::fs::remove_dir_all(out.parent().unwrap()).unwrap();
    for z in ["50", "2"] {
        let refused = nanopush(&[&args[..], &["--z-um", z]].concat());
        assert!(!refused.status.success());
        let message = String::from_utf8_lossy(&refused.stderr);
        assert!(
            message.contains("refused before anything moved")
                && message.contains(&format!("--z-um {z}: "))
                && message.contains("give --z-um from 12.0 to 15.0, or leave it out"),
            "--z-um {z}: {message}"
        );
        assert!(!out.parent().unwrap().exists(), "{message}");
    }
    ok(&nanopush(
        &[&args[..], &["--z-um", "12", "--grid", "2"]].concat(),
    ));
}

/// A camera that gives no frame stops the run before anything moves, in
/// two tries of its timeout, saying what to check (it had waited ten at
/// the first stop, 51 s with no word, then said only "no frame from the
/// camera in 10 tries").
#[test]
fn a_silent_camera_is_said_before_anything_moves() {
    let b = bench();
    let silent = b.dir.path().join("silent");
    std::fs::create_dir(&silent).unwrap();
    let text = std::fs::read_to_string(&b.rig)
        .unwrap()
        .replace(
            &format!("{:?}", b.dir.path().join("frames").display().to_string()),
            &format!("{:?}", silent.display().to_string()),
        )
        .replace("timeout_ms = 5000", "timeout_ms = 300");
    let rig = b.dir.path().join("silent.toml");
    std::fs::write(&rig, &text).unwrap();
    assert!(text.contains("silent") && text.contains("timeout_ms = 300"));
    let out = nanopush(&["rig", "calibrate", "--rig", rig.to_str().unwrap()]);
    assert!(!out.status.success());
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(
        message.contains("waiting for a frame from the camera (folder")
            && message.contains("refused before anything moved: no frame from the camera")
            && message.contains("in 2 tries of its timeout")
            && message.contains("is the camera's software writing new frames"),
        "{message}"
    );
    assert!(!b.dir.path().join("camera-recording").exists());
}
