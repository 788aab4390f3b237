//! `nanopush rig sim-gcs` and `nanopush rig probe` from the outside: the
//! probe reads a running simulator through a rig file, and dry-runs.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

fn nanopush() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nanopush"))
}

/// Kills the simulator child (by its own id) when the test ends, even on panic.
struct Sim(Child);

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn rig_text(port: u16) -> String {
    std::fs::read_to_string("calib/rig-gcs-sim.toml")
        .unwrap()
        .replace("127.0.0.1:50000", &format!("127.0.0.1:{port}"))
}

/// calib/rig-gcs-sim-folder.toml with the camera calibration and the
/// frames folder of a test's own, both as absolute paths.
fn folder_rig_text(calibration: &std::path::Path, frames: &std::path::Path) -> String {
    std::fs::read_to_string("calib/rig-gcs-sim-folder.toml")
        .unwrap()
        .replace(
            "\"camera-stage-sim-folder.toml\"",
            &format!("{:?}", calibration.display().to_string()),
        )
        .replace(
            "\"../out/rig-gcs-sim-folder/frames\"",
            &format!("{:?}", frames.display().to_string()),
        )
}

/// `nanopush rig probe --rig RIG`'s output, which must succeed.
fn probe(rig: &std::path::Path) -> String {
    let out = nanopush()
        .args(["rig", "probe", "--rig"])
        .arg(rig)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// `nanopush rig sim-gcs ARGS` started, and the port of each of its
/// first `listening` lines, which must name `what` in turn. The simulator
/// is killed when the returned `Sim` is dropped; keep the reader (the
/// pipe) open while it runs.
fn sim_gcs(args: &[&str], what: &[&str]) -> (Sim, BufReader<std::process::ChildStdout>, Vec<u16>) {
    let mut child = nanopush()
        .args(["rig", "sim-gcs"])
        .args(args)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let sim = Sim(child);
    let mut reader = BufReader::new(stdout);
    let ports = what
        .iter()
        .map(|what| {
            let mut line = String::new();
            reader.read_line(&mut line).unwrap();
            assert!(line.contains(what), "{line}");
            line.trim().rsplit(':').next().unwrap().parse().unwrap()
        })
        .collect();
    (sim, reader, ports)
}

#[test]
fn probe_reads_a_running_simulator() {
    let (sim, reader, ports) = sim_gcs(&["--port", "0"], &["GCS simulator"]);
    let port = ports[0];

    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("rig.toml");
    std::fs::write(&rig, rig_text(port)).unwrap();
    let text = probe(&rig);
    assert!(text.contains("GCS syntax:     2"), "{text}");
    assert!(text.contains("axes:           1 2 3"), "{text}");
    assert!(text.contains("pending error:  none"), "{text}");
    drop(sim);
    drop(reader);
}

#[test]
fn probe_dry_run_lists_the_bytes_and_a_dead_address_fails() {
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("rig.toml");
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    std::fs::write(&rig, rig_text(port)).unwrap();
    let out = probe_dry_run(&rig);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("\"*IDN?\\n\""), "{text}");
    assert!(!text.contains("MOV "), "probe must not move: {text}");
    // The bytes in the order sent: the report's queries, then the rig
    // file's checks' (which had been left out, the list printed before
    // them), listed after the report.
    let listed = text
        .split_once("dry run: bytes that would have been sent to the stage, in order")
        .map(|(report, list)| (report.contains("pending error:"), list))
        .unwrap_or((false, ""));
    let sent: Vec<&str> = listed.1.lines().skip(1).map(str::trim).collect();
    let error_query = sent.iter().position(|b| *b == "\"ERR?\\n\"");
    assert!(
        listed.0
            && sent.first() == Some(&"\"*IDN?\\n\"")
            && error_query.is_some_and(|at| sent[at..].contains(&"\"SAI?\\n\"")),
        "{text}"
    );

    let out = nanopush()
        .args(["rig", "probe", "--rig"])
        .arg(&rig)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("connecting"));
}

/// `nanopush rig sim-gcs --port 0 --coarse-port 0` with `extra` flags, its
/// stdout (kept open while it runs) and the nanostage's and coarse stage's
/// ports it chose.
fn sim_with_coarse(extra: &[&str]) -> (Sim, BufReader<std::process::ChildStdout>, u16, u16) {
    let args = [&["--port", "0", "--coarse-port", "0"], extra].concat();
    let (sim, reader, ports) = sim_gcs(&args, &["GCS simulator", "coarse-stage simulator"]);
    (sim, reader, ports[0], ports[1])
}

/// calib/rig-gcs-sim-coarse-folder.toml on the simulators' ports, its
/// calibration named by its absolute path and its camera watching `frames`.
fn coarse_rig_text(nano: u16, coarse: u16, frames: &std::path::Path) -> String {
    std::fs::read_to_string("calib/rig-gcs-sim-coarse-folder.toml")
        .unwrap()
        .replace("127.0.0.1:50000", &format!("127.0.0.1:{nano}"))
        .replace("127.0.0.1:50001", &format!("127.0.0.1:{coarse}"))
        .replace(
            "\"camera-stage-sim-coarse.toml\"",
            &format!(
                "{:?}",
                std::fs::canonicalize("calib/camera-stage-sim-coarse.toml")
                    .unwrap()
                    .display()
                    .to_string()
            ),
        )
        .replace(
            "\"../out/rig-gcs-sim-coarse-folder/frames\"",
            &format!("{:?}", frames.display().to_string()),
        )
}

#[test]
fn probe_shows_the_coarse_stage_of_a_rig_file_with_one() {
    let (sim, reader, nano, coarse) = sim_with_coarse(&[]);
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("rig.toml");
    std::fs::write(
        &rig,
        coarse_rig_text(nano, coarse, &dir.path().join("frames")),
    )
    .unwrap();
    let text = probe(&rig);
    let (stage, coarse_part) = text.split_once("coarse stage:").expect("a coarse section");
    assert!(stage.contains("axes:           1 2 3"), "{text}");
    assert!(coarse_part.contains("C-884"), "{text}");
    assert!(coarse_part.contains("axes:           1 2\n"), "{text}");
    // In um to 3 decimals, in columns: the coarse stage's 12.5 mm, the
    // nanostage's 50 um (both had been printed as the controllers said
    // them, in their units, in columns that did not line up).
    assert!(
        coarse_part.contains("1000 um (the rig file's unit_um)"),
        "{text}"
    );
    for (part, row) in [
        (
            stage,
            "1          0.000 ..    100.000        50.000       50.000",
        ),
        (
            coarse_part,
            "1          0.000 ..  25000.000     12500.000    12500.000",
        ),
    ] {
        assert!(part.contains(row), "{row:?} in:\n{text}");
        let table: Vec<&str> = part
            .lines()
            .skip_while(|l| !l.starts_with("axis "))
            .take_while(|l| !l.starts_with("pending error"))
            .collect();
        assert!(table.len() > 2, "{text}");
        assert!(
            table.iter().all(|l| l.len() == table[0].len()),
            "columns not aligned:\n{}",
            table.join("\n")
        );
    }
    drop(sim);
    drop(reader);
}

/// `rig probe` checks the rig file against the controllers and the apex
/// as `assemble --rig` does when it opens the rig, and reports every
/// problem: an axis the controller lacks, a coarse stage in mm written as
/// um, a calibration 18 um off the apex (probe had passed all three, which
/// `assemble` then refused). The rig file as it should be passes.
#[test]
fn probe_reports_every_way_the_rig_file_does_not_fit_its_rig() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let microscope = dir.path().join("microscope.toml");
    std::fs::write(&microscope, coarse_rig_text(50000, 50001, &frames)).unwrap();
    let microscope = microscope.to_str().unwrap();
    let (sim, reader, nano, coarse) = sim_with_coarse(&[
        "--time-scale",
        "100",
        "--microscope",
        microscope,
        "--seed",
        "2",
        "--particles",
        "20",
    ]);
    let good = coarse_rig_text(nano, coarse, &frames);
    let off = dir.path().join("off.toml");
    std::fs::write(
        &off,
        std::fs::read_to_string("calib/camera-stage-sim-coarse.toml")
            .unwrap()
            .replace("-20.0], [0.0, -0.25, 120.0", "-5.0], [0.0, -0.25, 130.0"),
    )
    .unwrap();
    let calibration = std::fs::canonicalize("calib/camera-stage-sim-coarse.toml").unwrap();
    let off_calibration = good.replace(
        &format!("{:?}", calibration.display().to_string()),
        &format!("{:?}", off.display().to_string()),
    );
    let mismatched = good
        .replace(r#"axes = ["1", "2", "3"]"#, r#"axes = ["1", "2", "4"]"#)
        .replace("unit_um = 1000.0 ", "unit_um = 1.0 ");
    assert!(off_calibration != good && mismatched.matches("unit_um = 1.0").count() == 2);
    let run = |name: &str, text: &str| {
        let rig = dir.path().join(name);
        std::fs::write(&rig, text).unwrap();
        let out = nanopush()
            .args(["rig", "probe", "--camera", "--rig"])
            .arg(&rig)
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stderr).into_owned();
        (out.status.success(), said)
    };
    let (ok, said) = run("good.toml", &good);
    assert!(ok, "{said}");
    let (ok, said) = run("mismatched.toml", &mismatched);
    assert!(
        !ok && said.contains("2 parts of the rig")
            && said.contains("axis 4 is not on the controller")
            && said.contains("coarse stage: invalid argument: axis 1: soft limits")
            && said.contains("axis 2: soft limits")
            && said.contains("with unit_um = 1000, not 1"),
        "{said}"
    );
    let (ok, said) = run("off-rig.toml", &off_calibration);
    assert!(
        !ok && said.contains("the calibration does not fit this camera and stage")
            && said.contains("off.toml"),
        "{said}"
    );
    drop(sim);
    drop(reader);
}

#[test]
fn sim_gcs_asks_for_the_coarse_port_a_coarse_rig_file_needs() {
    let out = nanopush()
        .args(["rig", "sim-gcs", "--port", "0", "--microscope"])
        .arg("calib/rig-gcs-sim-coarse-folder.toml")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--coarse-port"), "{stderr}");
}

/// The microscope's own flags without --microscope were taken and
/// ignored: the server started with no camera and no word.
#[test]
fn sim_gcs_refuses_microscope_flags_without_a_microscope() {
    for flag in ["--particles", "--seed", "--frame-interval-ms"] {
        let out = nanopush()
            .args(["rig", "sim-gcs", "--port", "0", flag, "5"])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{flag}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("--microscope"), "{flag}: {stderr}");
    }
}

/// `nanopush rig probe --dry-run --rig RIG`.
fn probe_dry_run(rig: &std::path::Path) -> std::process::Output {
    nanopush()
        .args(["rig", "probe", "--dry-run", "--rig"])
        .arg(rig)
        .output()
        .unwrap()
}

/// `nanopush assemble --text L --dry-run --rig RIG --out OUT`.
fn assemble_dry_run(rig: &std::path::Path, out: &std::path::Path) -> std::process::Output {
    assemble_on(rig, out, &["--text", "L", "--dry-run"])
}

/// `nanopush assemble --rig RIG --out OUT ARGS`.
fn assemble_on(
    rig: &std::path::Path,
    out: &std::path::Path,
    args: &[&str],
) -> std::process::Output {
    nanopush()
        .args(["assemble", "--rig"])
        .arg(rig)
        .arg("--out")
        .arg(out)
        .args(args)
        .output()
        .unwrap()
}

/// calib/rig-gcs-sim-xyz.toml's text, its calibration named by its full
/// path and its camera watching `frames`.
fn xyz_rig_text(frames: &std::path::Path) -> String {
    let calibration = std::fs::canonicalize("calib/camera-stage-sim.toml").unwrap();
    std::fs::read_to_string("calib/rig-gcs-sim-xyz.toml")
        .unwrap()
        .replace(
            r#""camera-stage-sim.toml""#,
            &format!("{:?}", calibration.display().to_string()),
        )
        .replace(
            r#""../out/rig-gcs-sim/frames""#,
            &format!("{:?}", frames.display().to_string()),
        )
}

#[test]
fn a_rig_file_naming_one_axis_twice_is_refused_by_probe_and_assemble() {
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("dup-axes.toml");
    let text = std::fs::read_to_string("calib/rig-gcs-sim-xyz.toml").unwrap();
    let bad = text.replace(r#"axes = ["1", "2", "3"]"#, r#"axes = ["1", "1", "3"]"#);
    assert_ne!(bad, text, "the replacement did not apply");
    std::fs::write(&rig, bad).unwrap();
    let probe = probe_dry_run(&rig);
    let assemble = assemble_dry_run(&rig, &dir.path().join("out"));
    for (what, run) in [("probe", probe), ("assemble", assemble)] {
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{what} accepted it: {stderr}");
        for needle in ["dup-axes.toml", "stage.axes", "\"1\" twice"] {
            assert!(
                stderr.contains(needle),
                "{what}: no {needle:?} in: {stderr}"
            );
        }
        assert!(
            !String::from_utf8_lossy(&run.stdout).contains("MOV "),
            "{what} moved"
        );
    }
}

/// A stage without z cannot lift the tip: `assemble` refuses it (every
/// travel would drag the tip across the sample; it had run, parking with
/// the tip down), and `rig calibrate` only with the tip lifted by hand (it
/// had swept the grid at the tip's height and moved particles 6 um).
#[test]
fn a_stage_without_z_is_refused_where_the_tip_would_sweep_the_sample() {
    let dir = tempfile::tempdir().unwrap();
    let rig = std::path::Path::new("calib/rig-gcs-sim.toml");
    let run = assemble_dry_run(rig, &dir.path().join("out"));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && stderr.contains("no z axis"),
        "{stderr}"
    );
    assert!(!String::from_utf8_lossy(&run.stdout).contains("MOV "));
    let run = nanopush()
        .args(["rig", "calibrate", "--rig"])
        .arg(rig)
        .arg("--out")
        .arg(dir.path().join("c.toml"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && stderr.contains("--tip-lifted-by-hand"),
        "{stderr}"
    );
    assert!(!dir.path().join("c.toml").exists());
}

/// A z convention that leaves the tip no room above the particles is
/// refused before anything moves: with the substrate at the top of z's
/// travel (or 10 um below it, or in nm), the tip had travelled sideways at
/// 0 or 5 um among 10 um particles before a push was refused as out of
/// range; with it 5 um up, the lift was capped level with their tops and
/// the run lost contact five times without a word.
#[test]
fn a_z_travel_that_cannot_lift_the_tip_clear_is_refused_before_any_move() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    let text = xyz_rig_text(&frames);
    for (surface_um, rises_um) in [("15", "0.000"), ("10", "5.000"), ("5", "10.000")] {
        let rig = dir.path().join(format!("z{surface_um}.toml"));
        let z =
            format!("real_hardware = false\nz_surface_um = {surface_um}\nz_lifts = \"increasing\"");
        let bad = text.replace("real_hardware = false", &z);
        assert_ne!(bad, text, "the replacement did not apply");
        std::fs::write(&rig, bad).unwrap();
        let run = assemble_dry_run(&rig, &dir.path().join(format!("out{surface_um}")));
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(
            !run.status.success()
                && stderr.contains(&format!(
                    "the tip can rise only {rises_um} um above the substrate (stage.z_surface_um {surface_um} um"
                ))
                && stderr.contains("travels 12.000 um above it"),
            "z_surface_um {surface_um}: {stderr}"
        );
        assert!(!String::from_utf8_lossy(&run.stdout).contains("MOV "));
    }
}

#[test]
fn a_rig_camera_folder_that_does_not_exist_leaves_out_without_a_journal() {
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("rig.toml");
    std::fs::write(&rig, xyz_rig_text(&dir.path().join("no-frames-here"))).unwrap();
    let out = dir.path().join("out");
    for attempt in 0..2 {
        let run = assemble_dry_run(&rig, &out);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "attempt {attempt}: {stderr}");
        assert!(
            stderr.contains("camera folder"),
            "attempt {attempt}: {stderr}"
        );
        assert!(!out.join("journal.jsonl").exists(), "attempt {attempt}");
    }
    // A pattern that cannot be is refused before the rig is opened.
    let run = assemble_on(&rig, &out, &["--text", "C?", "--dry-run"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{stderr}");
    assert!(
        stderr.contains("unknown glyph '?'") && !stderr.contains("camera folder"),
        "{stderr}"
    );
}

/// The scene `assemble --rig` and `rig probe --camera` size particles by.
const SCENE: &str = "calib/paper-ps-ito.toml";

/// `rig probe --camera` grabs a frame from the rig file's camera folder and
/// says what the loop sees in it: every particle of the layout drawn there,
/// the probe's apex where it was drawn and where the calibration maps it,
/// particles not the scene's size; a folder nothing is written into is an
/// error saying what to check.
#[test]
fn probe_camera_says_what_the_loop_sees_in_a_frame() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let run = |args: &[&str]| nanopush().args(args).output().unwrap();
    let layout = at("layout.json");
    let synth = [
        "synth",
        "layout",
        "--n",
        "12",
        "--field-um",
        "100x100",
        "--seed",
        "3",
        "--out",
    ];
    assert!(run(&[&synth[..], &[&layout]].concat()).status.success());
    // Folders of one frame each: the layout alone, the layout and the probe
    // (apex at (100, 80) px, its body up to the frame's edge), nothing.
    let probe = [
        "--tip-x-px",
        "100",
        "--tip-y-px",
        "80",
        "--tip-angle-deg",
        "270",
    ];
    for (folder, probe) in [("plain", &[][..]), ("tipped", &probe[..])] {
        std::fs::create_dir(at(folder)).unwrap();
        let frame = format!("{}/f0001.png", at(folder));
        // (A temporary folder's path has no spaces.)
        let draw = format!("synth frame --layout {layout} --um-per-px 0.5 --out {frame}");
        let draw: Vec<&str> = draw.split(' ').collect();
        assert!(
            run(&[&draw[..], probe].concat()).status.success(),
            "{folder}"
        );
    }
    std::fs::create_dir(at("empty")).unwrap();
    let calibration = std::fs::canonicalize("calib/camera-stage-sim.toml").unwrap();
    let probe_camera = |folder: &str, scene: &str| {
        let text = folder_rig_text(&calibration, std::path::Path::new(&at(folder)))
            .replace("skip_existing = true", "skip_existing = false")
            .replace("timeout_ms = 5000", "timeout_ms = 300");
        let rig = at(&format!("{folder}.toml"));
        std::fs::write(&rig, text).unwrap();
        let out = run(&[
            "rig",
            "probe",
            "--dry-run",
            "--camera",
            "--scene",
            scene,
            "--rig",
            &rig,
        ]);
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        (
            out.status.success(),
            text,
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let line = |text: &str, head: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(head))
            .unwrap_or_else(|| panic!("no {head:?} line in:\n{text}"))
            .trim()
            .to_string()
    };
    let numbers = |s: &str| -> Vec<f64> {
        s.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
            .filter_map(|w| w.parse().ok())
            .collect()
    };

    let (ok, text, err) = probe_camera("plain", SCENE);
    assert!(ok, "{text}{err}");
    assert!(line(&text, "source:").starts_with("folder "), "{text}");
    assert_eq!(line(&text, "frame:"), "200 x 200 px, 16-bit", "{text}");
    let particles = numbers(&line(&text, "particles:"));
    assert_eq!(particles[0] + particles[1], 12.0, "{text}");
    assert!(!text.contains("\nsize:"), "nothing to doubt: {text}");
    assert_eq!(line(&text, "tip:"), "not seen", "{text}");

    let (ok, text, err) = probe_camera("tipped", SCENE);
    assert!(ok, "{text}{err}");
    let tipped_text = text.clone();
    // apex at (x, y) px = (u, v) um: the calibration maps pixel p to 0.5 p - 10 um.
    let apex = numbers(&line(&text, "tip:"));
    assert!(
        (apex[0] - 100.0).abs() < 0.5 && (apex[1] - 80.0).abs() < 0.5,
        "{text}"
    );
    assert!((apex[2] - (0.5 * apex[0] - 10.0)).abs() < 0.01, "{text}");
    assert!((apex[3] - (0.5 * apex[1] - 10.0)).abs() < 0.01, "{text}");

    assert!(
        !text.contains("\nlens:"),
        "no lens in the calibration: {text}"
    );

    // The frame with the probe, its rig file naming another calibration.
    let probe_calibrated_by = |rig_name: &str, calibration_file: &str| {
        let tipped = std::fs::read_to_string(at("tipped.toml")).unwrap();
        let rig = at(rig_name);
        std::fs::write(
            &rig,
            tipped.replace(
                &format!("{:?}", calibration.display().to_string()),
                &format!("{calibration_file:?}"),
            ),
        )
        .unwrap();
        run(&["rig", "probe", "--dry-run", "--camera", "--rig", &rig])
    };

    // A calibration with a lens: the look says so, and pixels go through it.
    let lensed_calibration = at("lensed.toml");
    let lens = nanopush::calib::lens::RadialLens::centred_on(200, 200, -0.05);
    let map = nanopush::calib::camera_map::CameraCalibration::load(&calibration).unwrap();
    std::fs::write(&lensed_calibration, map.with_lens(Some(lens)).to_toml(None)).unwrap();
    let out = probe_calibrated_by("lensed-rig.toml", &lensed_calibration);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{text}");
    let shift = lens.largest_shift_px(200, 200);
    assert_eq!(
        line(&text, "lens:"),
        format!("k1 -0.05000: the calibration moves this frame's corners up to {shift:.2} px"),
        "{text}"
    );
    let seen = numbers(&line(&text, "tip:"));
    let [u, v] = map.with_lens(Some(lens)).pixel_to_stage_m(seen[0], seen[1]);
    assert!(
        (seen[2] - u * 1e6).abs() < 0.01 && (seen[3] - v * 1e6).abs() < 0.01,
        "{text}"
    );
    // Near the middle the lens hardly moves the apex; at the edges of the
    // view it does.
    assert_ne!(line(&text, "view:"), line(&tipped_text, "view:"));

    // No calibration made yet: the frame and the tip in pixels are shown
    // (what `rig calibrate` needs), and the command fails naming the
    // missing calibration and how to make it.
    let out = probe_calibrated_by("uncalibrated.toml", &at("not-made-yet.toml"));
    let (text, err) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(!out.status.success(), "{text}");
    assert_eq!(line(&text, "frame:"), "200 x 200 px, 16-bit", "{text}");
    let apex_px = numbers(&line(&text, "tip:"));
    assert!(
        (apex_px[0] - 100.0).abs() < 0.5 && (apex_px[1] - 80.0).abs() < 0.5,
        "{text}"
    );
    assert!(!text.contains("particles:"), "{text}");
    assert!(
        err.contains("not-made-yet.toml") && err.contains("nanopush rig calibrate --rig"),
        "{err}"
    );

    // Scenes whose particles are not the frame's (radius 5 um): none taken,
    // and the look says what it found instead. At 3.5 um the 12 are found
    // and left out for their size (the loop warns too); at 2.5 um the
    // detector, tuned to half the size, finds nothing, and the look tries
    // other hints.
    let scene = std::fs::read_to_string(SCENE).unwrap();
    assert!(scene.contains("\nradius_um = 5.0"));
    let wrong = [
        (
            "3.5",
            "12 found whole at another size (median radius 5.00 um)",
        ),
        (
            "2.5",
            "no particle found near the size hint; with a hint of radius 5.00 um, 12 found whole (median radius 5.00 um)",
        ),
    ];
    for (radius, told) in wrong {
        let path = at(&format!("scene-{radius}.toml"));
        let text = scene.replace("\nradius_um = 5.0", &format!("\nradius_um = {radius}"));
        std::fs::write(&path, text).unwrap();
        let (ok, text, err) = probe_camera("plain", &path);
        assert!(ok, "{text}{err}");
        assert!(
            line(&text, "particles:").starts_with("0 whole, 0 cut"),
            "{text}"
        );
        assert!(line(&text, "size:").starts_with(told), "{text}");
        let warned = err.contains("12 particles of radius 5.00 um (median) left out");
        assert_eq!(warned, radius == "3.5", "{err}");
        // A run with the scene stops at its first frame, saying the same.
        let out = at(&format!("run-{radius}"));
        let assemble = ["assemble", "--text", "L", "--dry-run", "--scene", &path];
        let run = nanopush()
            .args(assemble)
            .args(["--rig", &at("plain.toml"), "--out", &out])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{err}");
        let why = format!("no particles of radius {radius}0 um in the first frame; {told}");
        assert!(
            err.contains(&why) && err.contains("rig probe --rig"),
            "{err}"
        );
    }
    let (ok, text, err) = probe_camera("empty", SCENE);
    assert!(!ok, "{text}");
    assert!(
        err.contains("no frame from the camera") && err.contains("none was written"),
        "{err}"
    );

    // The controller off (nobody listens at the stage's address): the
    // camera is still looked at, and the command fails naming the stage;
    // with no frame either, naming both.
    let free_port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    for folder in ["plain", "empty"] {
        let text = std::fs::read_to_string(at(&format!("{folder}.toml"))).unwrap();
        assert!(text.contains("\"127.0.0.1:50000\""));
        let rig = at(&format!("{folder}-off.toml"));
        std::fs::write(
            &rig,
            text.replace("127.0.0.1:50000", &free_port.to_string()),
        )
        .unwrap();
        let out = run(&["rig", "probe", "--camera", "--scene", SCENE, "--rig", &rig]);
        let (text, err) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert!(!out.status.success(), "{text}");
        assert!(err.contains("connecting to the stage of"), "{err}");
        assert!(!text.contains("stage:"), "{text}");
        if folder == "plain" {
            let particles = numbers(&line(&text, "particles:"));
            assert_eq!(particles[0] + particles[1], 12.0, "{text}");
        } else {
            assert!(
                err.contains("2 parts of the rig could not be seen")
                    && err.contains("no frame from the camera"),
                "{err}"
            );
        }
    }
}

/// A typo in a rig file's `[camera]` table is reported at its key's line,
/// not at the table's header (line 26), where every camera error had been.
#[test]
fn a_typo_in_the_camera_table_is_reported_at_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string("calib/rig-gcs-sim.toml").unwrap();
    let header = text.lines().position(|l| l == "[camera]").unwrap() + 1;
    let line = text.lines().position(|l| l == "stable_ms = 50").unwrap() + 1;
    assert_ne!(line, header);
    for (typo, says) in [
        ("stabel_ms = 50", "unknown field `stabel_ms`"),
        ("stable_ms = \"fast\"", "expected u64"),
        ("index = 0", "kind = \"folder\" takes only path, order"),
    ] {
        let rig = dir.path().join("typo.toml");
        std::fs::write(&rig, text.replace("stable_ms = 50", typo)).unwrap();
        let run = probe_dry_run(&rig);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{typo}: {stderr}");
        assert!(
            stderr.contains(&format!("at line {line},")) && stderr.contains(says),
            "{typo}: {stderr}"
        );
    }
    // A key of another kind above `kind` is reported at its own line, not
    // at the kind's (where it had been).
    let rig = dir.path().join("above.toml");
    std::fs::write(&rig, text.replace("[camera]\n", "[camera]\nindex = 0\n")).unwrap();
    let run = probe_dry_run(&rig);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains(&format!("at line {},", header + 1))
            && stderr.contains("unknown field `index`: a camera of kind = \"folder\""),
        "{stderr}"
    );
}

/// `assemble --rig` refused in its set-up, after the rig was opened and
/// before anything moved (here: a z travel that cannot lift the tip clear),
/// leaves no `--out` it made behind, and one that was there as it was; it
/// had left an empty folder.
#[test]
fn a_set_up_refusal_leaves_no_out_folder_behind() {
    let (sim, reader, ports) = sim_gcs(&["--port", "0"], &["GCS simulator"]);
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    let text = xyz_rig_text(&frames)
        .replace("127.0.0.1:50000", &format!("127.0.0.1:{}", ports[0]))
        .replace(
            "real_hardware = false",
            "real_hardware = false\nz_surface_um = 15\nz_lifts = \"increasing\"",
        );
    let rig = dir.path().join("rig.toml");
    std::fs::write(&rig, text).unwrap();
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), "mine").unwrap();
    for out in [dir.path().join("new/run"), mine.clone()] {
        let run = assemble_on(&rig, &out, &["--text", "L"]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(
            !run.status.success() && stderr.contains("the tip can rise only"),
            "{stderr}"
        );
        assert!(
            stderr.contains(&format!("{} is as it was before", out.display())),
            "{stderr}"
        );
    }
    assert!(!dir.path().join("new").exists());
    let left: Vec<_> = std::fs::read_dir(&mine)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, ["notes.txt"]);
    drop(sim);
    drop(reader);
}

/// `rig sim-gcs` says it listens only once everything asked for runs: a
/// bad layout or a port in use had been preceded by "listening on ...",
/// which read as a simulator running. The failure says it did not start,
/// and a port in use what to do.
#[test]
fn sim_gcs_says_it_listens_only_once_it_does() {
    let bad = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(bad.path(), "{}").unwrap();
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let layout = bad.path().to_str().unwrap();
    let microscope = ["--microscope", "calib/rig-gcs-sim-folder.toml"];
    for (args, says) in [
        (
            vec![
                "--port",
                "0",
                microscope[0],
                microscope[1],
                "--layout",
                layout,
            ],
            "layout",
        ),
        (vec!["--port", &port], "is in use"),
        (
            vec!["--port", "0", "--coarse-port", &port],
            "give another --coarse-port",
        ),
    ] {
        let run = nanopush()
            .args(["rig", "sim-gcs"])
            .args(&args)
            .output()
            .unwrap();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&run.stdout),
            String::from_utf8_lossy(&run.stderr),
        );
        assert!(!run.status.success(), "{args:?}: {stdout}{stderr}");
        assert!(!stdout.contains("listening"), "{args:?}: {stdout}");
        assert!(
            stderr.contains("the GCS simulator did not start") && stderr.contains(says),
            "{args:?}: {stderr}"
        );
    }
}

/// Stopped with Ctrl-C, `rig sim-gcs --microscope` says what its world saw
/// (ground truth a hardware rig cannot give): here nothing moved the probe,
/// so it met no particle and was lowered onto none.
#[test]
fn sim_gcs_stopped_says_what_its_world_saw() {
    let dir = tempfile::tempdir().unwrap();
    let calibration = std::fs::canonicalize("calib/camera-stage-sim-folder.toml").unwrap();
    let rig = folder_rig_text(&calibration, &dir.path().join("frames"));
    assert!(!rig.contains("../out"), "{rig}");
    let microscope = dir.path().join("microscope.toml");
    std::fs::write(&microscope, rig).unwrap();
    let mut child = nanopush()
        .args(["rig", "sim-gcs", "--port", "0", "--microscope"])
        .arg(&microscope)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut reader = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    reader.read_line(&mut line).unwrap();
    assert!(line.contains("GCS simulator listening"), "{line}");
    let sent = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains(
            "ground truth: the probe met particles 0 times and was lowered onto one 0 times"
        ),
        "{stderr}"
    );
}
