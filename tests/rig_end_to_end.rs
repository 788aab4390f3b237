//! `nanopush assemble --rig` end to end, with no hardware: the stage is the
//! GCS controller simulator over loopback TCP, the camera is a watched
//! folder that the simulated microscope fills with frames of a simulated
//! world, which the controller's probe pushes with the pushing model. The run
//! must finish as the simulated-rig run on the same layout does: L on a rig
//! without a coarse stage, and CMU (wider than the nanostage's reach) on a
//! rig whose coarse stage is a second GCS controller simulator moving the
//! world; a dry run must move nothing; Ctrl-C and a controller that starts
//! talking garbage must leave the stage still.

use nalgebra::Vector2;
use nanopush::calib::camera_map::CameraCalibration;
use nanopush::calib::lens::RadialLens;
use nanopush::exec::observe::Perception;
use nanopush::exec::sim_run::layout_for;
use nanopush::model::Scene;
use nanopush::plan::stray_gap::seen_stray_gap_m;
use nanopush::plan::{Layout, Particle};
use nanopush::render::microscope::{RenderSettings, SceneView, render_frame};
use nanopush::rig::gcs::{RigFile, SimConfig, SimFault, SimServer};
use nanopush::rig::microscope_feeder::{MicroscopeFeeder, layout_in_travel};
use nanopush::rig::sim::world::World;
use nanopush::vision::detect::detect_particles;
use nanopush::vision::frame_input::{Channel, load_frame, save_png};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant};

mod interrupted;
use interrupted::{press_ctrl_c, wait_until_caught};

const UM: f64 = 1e-6;
/// The pattern on the rig without a coarse stage: its 94 um of travel holds
/// L, not CMU; L on the layout of seed 4 completes (see docs/rig.md).
const TEXT: &str = "L";
const SEED: u64 = 4;
const PARTICLES: usize = 20;
/// Longest a run may take before the test calls it hung.
const RUN_LIMIT: Duration = Duration::from_secs(240);

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn nanopush() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_nanopush"));
    c.current_dir(manifest());
    c
}

fn scene() -> Scene {
    Scene::load(&manifest().join("calib/paper-ps-ito.toml")).unwrap()
}

fn layout() -> Layout {
    layout_in_travel(
        &scene(),
        PARTICLES,
        [100.0 * UM, 100.0 * UM],
        10.0 * UM,
        SEED,
    )
    .unwrap()
}

/// The controller simulator(s), the simulated microscope, and a copy of
/// a calib/ rig file pointing at them.
struct Bench {
    // Field order is drop order: the feeder stops before the servers.
    feeder: MicroscopeFeeder,
    server: SimServer,
    coarse: Option<SimServer>,
    dir: tempfile::TempDir,
    rig_path: PathBuf,
    frames: PathBuf,
    text: &'static str,
}

/// A served simulator at `time_scale`.
fn serve(config: SimConfig, time_scale: f64) -> (SimServer, String) {
    let mut server = SimServer::new(config);
    server
        .handle()
        .with(|c, now| c.set_time_scale(time_scale, now));
    let addr = server.serve_tcp("127.0.0.1:0").unwrap();
    (server, addr.to_string())
}

/// The rig of calib/rig-gcs-sim-folder.toml (no coarse stage), world of
/// [`layout`], assembling [`TEXT`].
fn bench(time_scale: f64) -> Bench {
    bench_seeing(time_scale, None, &layout())
}

/// [`bench`]; with `camera`, the microscope draws through that map and
/// the rig file names a calibration not made yet (camera.toml in the
/// bench's folder), for `rig calibrate` to measure.
fn bench_seeing(time_scale: f64, camera: Option<&CameraCalibration>, world: &Layout) -> Bench {
    let (server, addr) = serve(SimConfig::default(), time_scale);
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let calibration = "camera-stage-sim-folder.toml";
    let text =
        rig_text("rig-gcs-sim-folder.toml", calibration, &frames).replace("127.0.0.1:50000", &addr);
    let rig_path = dir.path().join("rig.toml");
    let quoted = |path: &Path| format!("{:?}", path.display().to_string());
    let named = quoted(&manifest().join("calib").join(calibration));
    let rig = match camera {
        None => {
            std::fs::write(&rig_path, text).unwrap();
            RigFile::load(&rig_path).unwrap()
        }
        Some(camera) => {
            let truth = dir.path().join("truth.toml");
            std::fs::write(&truth, camera.to_toml(None)).unwrap();
            let made_later = dir.path().join("camera.toml");
            std::fs::write(&rig_path, text.replace(&named, &quoted(&made_later))).unwrap();
            let feeder_rig = dir.path().join("truth-rig.toml");
            std::fs::write(&feeder_rig, text.replace(&named, &quoted(&truth))).unwrap();
            RigFile::load(&feeder_rig).unwrap()
        }
    };
    let feeder = MicroscopeFeeder::for_rig_file(
        server.handle(),
        None,
        &rig,
        &scene(),
        world,
        SEED,
        Duration::from_millis(40),
    )
    .unwrap();
    Bench {
        feeder,
        server,
        coarse: None,
        dir,
        rig_path,
        frames,
        text: TEXT,
    }
}

/// A calib/ rig file with its calibration and frame folder made absolute.
fn rig_text(rig: &str, calibration: &str, frames: &Path) -> String {
    let folder = rig.trim_end_matches(".toml");
    std::fs::read_to_string(manifest().join("calib").join(rig))
        .unwrap()
        .replace(
            &format!("\"{calibration}\""),
            &format!(
                "{:?}",
                manifest()
                    .join("calib")
                    .join(calibration)
                    .display()
                    .to_string()
            ),
        )
        .replace(
            &format!("\"../out/{folder}/frames\""),
            &format!("{:?}", frames.display().to_string()),
        )
}

/// The pattern, layout seed and particle count of the coarse-stage run: what
/// `nanopush assemble --text CMU --seed 2` does on the simulated rig.
const COARSE_TEXT: &str = "CMU";
const COARSE_SEED: u64 = 2;
const COARSE_PARTICLES: usize = 50;

/// The rig of calib/rig-gcs-sim-coarse-folder.toml: nanostage and coarse
/// stage simulators, the world of the simulated rig's layout for
/// [`COARSE_SEED`] (120 x 100 um, the nanostage's range centred on it).
fn coarse_bench(time_scale: f64) -> Bench {
    let (server, addr) = serve(SimConfig::default(), time_scale);
    let (coarse, coarse_addr) = serve(SimConfig::coarse(), time_scale);
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let text = rig_text(
        "rig-gcs-sim-coarse-folder.toml",
        "camera-stage-sim-coarse.toml",
        &frames,
    )
    .replace("127.0.0.1:50000", &addr)
    .replace("127.0.0.1:50001", &coarse_addr);
    let rig_path = dir.path().join("rig.toml");
    std::fs::write(&rig_path, text).unwrap();
    let rig = RigFile::load(&rig_path).unwrap();
    let scene = scene();
    let layout = layout_for(None, &scene, COARSE_SEED, COARSE_PARTICLES).unwrap();
    let feeder = MicroscopeFeeder::for_rig_file(
        server.handle(),
        Some(coarse.handle()),
        &rig,
        &scene,
        &layout,
        COARSE_SEED,
        Duration::from_millis(40),
    )
    .unwrap();
    Bench {
        feeder,
        server,
        coarse: Some(coarse),
        dir,
        rig_path,
        frames,
        text: COARSE_TEXT,
    }
}

impl Bench {
    /// The run's JSON report, after checking that it finished every site as
    /// the simulated rig's `reference` run did, with the camera as the error
    /// source, the microscope still running and no stage moving.
    fn completed_like(&self, out: &Output, reference: &serde_json::Value) -> serde_json::Value {
        let report = json(out);
        assert_eq!(report["outcome"], "done", "{report}");
        assert_eq!(report["filled"], report["sites"], "{report}");
        assert_eq!(report["sites"], reference["sites"]);
        assert_eq!(report["error_source"], "camera");
        assert!(self.feeder.is_running(), "the simulated microscope failed");
        assert!(!self.moving(), "a stage was left moving");
        report
    }

    /// Per site of the run in `run_dir`, the distance from the particle
    /// nearest to it in the simulated world, nm: the sites as the camera saw
    /// them at the end (pixels) mapped onto the sample as the simulated
    /// microscope has it (camera map plus the coarse controller's offset).
    fn coarse_truth_errors_nm(&self, run_dir: &Path) -> Vec<f64> {
        let sites = self.coarse_sites_on_sample(run_dir);
        nearest_particle_nm(&self.feeder.world().world, &sites)
    }

    /// The sites of the run in `run_dir` on the sample, metres: as the
    /// camera saw them at the end (pixels), through the camera map plus
    /// the coarse controller's offset, as the simulated microscope has it.
    fn coarse_sites_on_sample(&self, run_dir: &Path) -> Vec<[f64; 2]> {
        let calibration =
            CameraCalibration::load(&manifest().join("calib/camera-stage-sim-coarse.toml"))
                .unwrap();
        let offset = self.feeder.world().coarse_offset_m(&self.coarse_units());
        sites_px(run_dir)
            .iter()
            .map(|px| {
                let [x, y] = calibration.pixel_to_stage_m(px[0], px[1]);
                [x + offset[0], y + offset[1]]
            })
            .collect()
    }

    /// Starts a run into `out`, stops it with Ctrl-C once its journal
    /// holds `n` push decisions, and returns the journal then (the run
    /// must not have finished).
    fn stopped_after_decisions(&self, out: &str, n: usize, extra: &[&str]) -> String {
        let journal = self.dir.path().join(out).join("journal.jsonl");
        let child = self.assemble(out, extra);
        let decisions = || {
            std::fs::read_to_string(&journal)
                .map(|t| t.matches("\"kind\":\"decision\"").count())
                .unwrap_or(0)
        };
        let started = Instant::now();
        while decisions() < n {
            assert!(
                started.elapsed() < RUN_LIMIT,
                "the run never pushed {n} times"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        let out = interrupted(child, Duration::from_secs(30));
        assert!(!out.status.success());
        let before = std::fs::read_to_string(&journal).unwrap();
        assert!(
            !before.contains("\"kind\":\"done\""),
            "the run finished before the stop"
        );
        before
    }

    /// `assemble --rig --resume JOURNAL --json`, which must succeed, after
    /// which every site must be filled (the camera's count) and no stage
    /// moving; its report.
    fn resumed(&self, journal: &Path) -> serde_json::Value {
        let out = finish(self.resuming(journal), RUN_LIMIT);
        assert!(out.status.success(), "{}", failed(out.status, &out));
        let report = json(&out);
        assert_eq!(report["outcome"], "done", "{report}");
        assert_eq!(report["filled"], report["sites"], "{report}");
        assert!(!self.moving(), "a stage was left moving");
        // Rig time goes on from the stopped part: the journal's times keep
        // rising, and the report's time takes in both parts.
        let lines: Vec<serde_json::Value> = std::fs::read_to_string(journal)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        let resumed_at = lines
            .iter()
            .rposition(|l| l["event"]["kind"] == "resume")
            .expect("a resume entry");
        let time = |l: &serde_json::Value| l["t_s"].as_f64().unwrap();
        let stopped_s = lines[..resumed_at].iter().map(time).fold(0.0, f64::max);
        let after: Vec<f64> = lines[resumed_at..].iter().map(time).collect();
        eprintln!(
            "stopped part up to {stopped_s:.2} s; resumed part {:.2}-{:.2} s",
            after[0],
            after.last().unwrap()
        );
        assert!(
            after.iter().all(|&t| t >= stopped_s),
            "resumed times before the stop's {stopped_s} s: {after:?}"
        );
        assert!(report["time_s"].as_f64().unwrap() >= stopped_s, "{report}");
        report
    }

    /// `assemble --rig --resume JOURNAL --json`, started.
    fn resuming(&self, journal: &Path) -> Child {
        nanopush()
            .args(["assemble", "--json", "--rig"])
            .arg(&self.rig_path)
            .arg("--resume")
            .arg(journal)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    }

    /// Runs every controller's simulated time `scale` times the wall clock
    /// from now on.
    fn set_time_scale(&self, scale: f64) {
        let controllers = std::iter::once(&self.server).chain(&self.coarse);
        for server in controllers {
            server.handle().with(|c, now| c.set_time_scale(scale, now));
        }
    }

    /// Makes the bench's rig file say `real_hardware = true` (with the z
    /// convention that asks for); returns the text it had.
    fn as_real_hardware(&self) -> String {
        let text = std::fs::read_to_string(&self.rig_path).unwrap();
        let real = text.replace(
            "real_hardware = false",
            "real_hardware = true\nz_surface_um = 0.0\nz_lifts = \"increasing\"",
        );
        assert_ne!(real, text, "the replacement did not apply");
        std::fs::write(&self.rig_path, real).unwrap();
        text
    }

    /// `assemble --rig` with `args`, standard input at its end: the first
    /// move on real hardware is not confirmed. Its stderr, after checking
    /// that it failed saying nothing was moved.
    fn unconfirmed(&self, args: &[&std::ffi::OsStr]) -> String {
        let child = nanopush()
            .args(["assemble", "--rig"])
            .arg(&self.rig_path)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let run = finish(child, Duration::from_secs(60));
        let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
        assert!(!run.status.success(), "{}", failed(run.status, &run));
        assert!(
            stderr.contains("not confirmed: nothing was moved"),
            "{stderr}"
        );
        stderr
    }

    /// Waits (up to 20 s) until no stage moves.
    fn wait_still(&self) {
        let started = Instant::now();
        while self.moving() {
            assert!(started.elapsed() < Duration::from_secs(20), "never settled");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Waits until the run into `out` has begun its loop (its journal is
    /// there) and moves the stage: the loop's move, not the set-up's
    /// parking of the probe (a press then starts nothing:
    /// `ctrl_c_during_the_set_up_is_answered_at_once_and_starts_nothing`).
    fn wait_for_the_loops_move(&self, out: &str) {
        let journal = self.dir.path().join(out).join("journal.jsonl");
        let started = Instant::now();
        while !(journal.exists() && self.moving()) {
            assert!(started.elapsed() < Duration::from_secs(60), "never moved");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn moving(&self) -> bool {
        self.server.inspect(|c, now| c.any_moving(now))
            || self
                .coarse
                .as_ref()
                .is_some_and(|k| k.inspect(|c, now| c.any_moving(now)))
    }

    /// The coarse controller's axis positions, controller units (mm).
    fn coarse_units(&self) -> Vec<f64> {
        let k = self.coarse.as_ref().expect("a coarse bench");
        k.inspect(|c, now| (0..2).map(|i| c.position(i, now).unwrap()).collect())
    }

    fn positions_um(&self) -> [f64; 3] {
        self.server
            .inspect(|c, now| [0, 1, 2].map(|i| c.position(i, now).unwrap()))
    }

    fn assemble(&self, out: &str, extra: &[&str]) -> Child {
        nanopush()
            .args(["assemble", "--rig"])
            .arg(&self.rig_path)
            .args(["--text", self.text, "--out"])
            .arg(self.dir.path().join(out))
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    }
}

/// Where `server`'s `axes` ("1 2 3") were last sent (`MOV?`), controller units.
fn targets(server: &SimServer, axes: &str) -> Vec<f64> {
    let reply = (server.handle()).with(|c, now| c.handle_line(&format!("MOV? {axes}"), now));
    reply
        .iter()
        .map(|l| l.split_once('=').unwrap().1.parse().unwrap())
        .collect()
}

/// Sends the child Ctrl-C's signal (SIGINT) and waits for it as [`finish`] does.
fn interrupted(child: Child, limit: Duration) -> Output {
    press_ctrl_c(&child);
    finish(child, limit)
}

/// Waits for the child, killing it (by its own id) if it outlives `limit`.
fn finish(mut child: Child, limit: Duration) -> Output {
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "the run hung for {limit:?}; stderr: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn json(out: &Output) -> serde_json::Value {
    let text = String::from_utf8_lossy(&out.stdout);
    let start = text
        .find('{')
        .unwrap_or_else(|| panic!("no JSON in {text}"));
    serde_json::from_str(&text[start..]).unwrap()
}

fn failed(status: ExitStatus, out: &Output) -> String {
    format!(
        "{status}\nstdout: {}\nstderr: {}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The first third of a 480 x 480 16-bit PNG frame.
fn truncated_png(scratch: &Path) -> Vec<u8> {
    let view = SceneView {
        width_px: 480,
        height_px: 480,
        particles: vec![],
        tip: None,
    };
    let frame = render_frame(&view, &RenderSettings::with_snr(30.0, 16), 5).unwrap();
    let path = scratch.join("whole.png");
    save_png(&frame, &path).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.truncate(bytes.len() / 3);
    bytes
}

/// Site centres of a run as the camera saw them at the end, pixels.
fn sites_px(out_dir: &Path) -> Vec<[f64; 2]> {
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("sites.json")).unwrap())
            .unwrap();
    doc["sites"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| [s["x_px"].as_f64().unwrap(), s["y_px"].as_f64().unwrap()])
        .collect()
}

/// The events of a run's journal, in order (the schema line left out).
fn journal_events(out_dir: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out_dir.join("journal.jsonl"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["event"].clone())
        .collect()
}

/// Points of a journal event, um: `[x, y]` pairs or `{x_um, y_um}` objects.
fn points_um(v: &serde_json::Value) -> Vec<[f64; 2]> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| match p {
            serde_json::Value::Array(xy) => [xy[0].as_f64().unwrap(), xy[1].as_f64().unwrap()],
            p => [p["x_um"].as_f64().unwrap(), p["y_um"].as_f64().unwrap()],
        })
        .collect()
}

/// The middle and the size of the points' bounding box along axis `k`.
fn span(points: &[[f64; 2]], k: usize) -> (f64, f64) {
    let (lo, hi) = points
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p[k]), b.max(p[k])));
    ((lo + hi) / 2.0, hi - lo)
}

/// The simulated rig's run of `args` (the reference), as its JSON report.
fn reference_run(dir: &Path, args: &[&str]) -> serde_json::Value {
    let reference = nanopush()
        .args(["assemble", "--json"])
        .args(args)
        .arg("--out")
        .arg(dir.join("run"))
        .output()
        .unwrap();
    assert!(
        reference.status.success(),
        "{}",
        failed(reference.status, &reference)
    );
    let reference = json(&reference);
    assert_eq!(reference["outcome"], "done");
    reference
}

/// Per site, the distance to the nearest particle of the simulated world, nm.
fn nearest_particle_nm(world: &World, sites: &[[f64; 2]]) -> Vec<f64> {
    sites
        .iter()
        .map(|s| {
            world
                .particles
                .iter()
                .map(|p| (p.x_m - s[0]).hypot(p.y_m - s[1]) * 1e9)
                .fold(f64::INFINITY, f64::min)
        })
        .collect()
}

/// Root mean square and largest of `errors`.
fn rms_max(errors: &[f64]) -> (f64, f64) {
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    (rms, errors.iter().copied().fold(0.0, f64::max))
}

/// Site centres of a run, metres.
fn sites_m(out_dir: &Path) -> Vec<[f64; 2]> {
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("sites.json")).unwrap())
            .unwrap();
    doc["sites"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            [
                s["x_um"].as_f64().unwrap() * UM,
                s["y_um"].as_f64().unwrap() * UM,
            ]
        })
        .collect()
}

#[test]
fn assembling_on_the_gcs_simulator_and_a_watched_folder_completes_like_the_simulated_rig() {
    // The simulated rig on the same layout: the reference.
    let reference_dir = tempfile::tempdir().unwrap();
    let layout_path = reference_dir.path().join("layout.json");
    layout().write(&layout_path).unwrap();
    let layout_arg = layout_path.display().to_string();
    let reference = reference_run(
        reference_dir.path(),
        &["--text", TEXT, "--seed", "1", "--layout", &layout_arg],
    );

    // A time scale of 50: a 10 um push at 1 um/s takes 0.2 s.
    let b = bench(50.0);
    let child = b.assemble("run", &["--json"]);
    // A camera program that crashed mid-write: a truncated frame that sorts
    // after every other, so the `latest` pick meets it first.
    // Written once the run moves, so that the camera is open and takes it as new.
    let started = Instant::now();
    while !b.moving() {
        assert!(started.elapsed() < Duration::from_secs(60), "never moved");
        std::thread::sleep(Duration::from_millis(5));
    }
    let png = truncated_png(b.dir.path());
    std::fs::write(b.frames.join("frame_99999999.png"), png).unwrap();
    let out = finish(child, RUN_LIMIT);
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let report = b.completed_like(&out, &reference);

    // Ground truth: the particles of the simulated world, against the sites.
    let run_dir = b.dir.path().join("run");
    let sites = sites_m(&run_dir);
    let world = b.feeder.world();
    let errors_nm = nearest_particle_nm(&world.world, &sites);
    let (rms, max) = rms_max(&errors_nm);
    eprintln!(
        "GCS rig: {} sites, truth rms {rms:.0} nm, max {max:.0} nm, {} pushes, {:.1} s wall; \
         simulated rig: rms {:.0} nm, max {:.0} nm, {} pushes",
        sites.len(),
        report["pushes"],
        report["time_s"].as_f64().unwrap(),
        reference["rms_error_nm"].as_f64().unwrap(),
        reference["max_error_nm"].as_f64().unwrap(),
        reference["pushes"],
    );
    // Every site holds a particle, as on the simulated rig (whose report
    // counts a site filled within the executor's 0.2 um tolerance).
    assert!(
        errors_nm.iter().all(|e| *e <= 200.0),
        "true placement errors {errors_nm:?} nm"
    );
    assert!(
        world.contacts().iter().any(|c| c.moved_m > 1.0 * UM),
        "the probe pushed nothing"
    );
    // Through the controller as on the simulated rig, the tip never comes
    // down on a particle.
    assert!(
        world.landings().is_empty(),
        "the tip was lowered onto particles: {:?}",
        world.landings()
    );
    // The camera's nearest stray is the world's, within what the detector
    // sizes particles to (15 nm a radius, tracker.rs ISOLATED_GAP_M).
    let centres: Vec<_> = sites
        .iter()
        .map(|s| nalgebra::Vector2::new(s[0], s[1]))
        .collect();
    let discs: Vec<_> = (world.world.particles.iter())
        .map(|p| (nalgebra::Vector2::new(p.x_m, p.y_m), p.radius_m))
        .collect();
    let truth_um = seen_stray_gap_m(&centres, &discs).expect("a stray in the world") * 1e6;
    let seen_um = report["nearest_stray_gap_um"]
        .as_f64()
        .expect("a stray gap");
    assert!(
        (seen_um - truth_um).abs() < 0.1,
        "the camera saw the nearest stray {seen_um} um off, the world has it {truth_um} um"
    );
    drop(world);
    // The half-written frame was skipped with a warning, not read.
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("frame_99999999.png"),
        "no warning about the truncated frame: {stderr}"
    );
}

/// Where an L is built off the middle of the view, towards a corner (where
/// the objective's distortion is largest), within what the nanostage
/// reaches with the particles it needs.
const OFF_MIDDLE: [&str; 2] = ["--at", "24,64"];

/// True placement errors, nm, of a run of [`TEXT`] at [`OFF_MIDDLE`] on a
/// rig whose microscope sees through `camera` and whose calibration is
/// measured by `rig calibrate` with `lens`.
fn errors_through(camera: &CameraCalibration, lens: &str) -> Vec<f64> {
    let b = bench_seeing(50.0, Some(camera), &layout());
    let calibrated = nanopush()
        .args(["rig", "calibrate", "--rig"])
        .arg(&b.rig_path)
        .args(["--lens", lens])
        .output()
        .unwrap();
    assert!(
        calibrated.status.success(),
        "{}",
        failed(calibrated.status, &calibrated)
    );
    let out = finish(
        b.assemble("run", &[&["--json"][..], &OFF_MIDDLE].concat()),
        RUN_LIMIT,
    );
    assert!(out.status.success(), "{}", failed(out.status, &out));
    assert_eq!(json(&out)["outcome"], "done");
    let sites = sites_m(&b.dir.path().join("run"));
    nearest_particle_nm(&b.feeder.world().world, &sites)
}

#[test]
fn an_objective_that_bends_the_view_is_calibrated_out_of_the_pattern() {
    // Barrel distortion moving the 480 x 480 px view's corners 0.8 % inward
    // (2.7 px, 0.7 um).
    let affine =
        CameraCalibration::load(&manifest().join("calib/camera-stage-sim-folder.toml")).unwrap();
    let camera = affine.with_lens(Some(RadialLens::centred_on(480, 480, -0.008)));
    let with_lens = errors_through(&camera, "radial");
    let without = errors_through(&camera, "none");
    let ((rms, max), (affine_rms, affine_max)) = (rms_max(&with_lens), rms_max(&without));
    eprintln!(
        "L at {:?} through a lens: calibrated with it truth rms {rms:.0} nm, max {max:.0} nm; affine rms {affine_rms:.0} nm, max {affine_max:.0} nm",
        OFF_MIDDLE[1]
    );
    // Measured: 6-8 nm rms, 12-13 nm max with the lens; 45 nm rms, 66-67
    // nm max with the affine map of the same kind of recording.
    assert!(max <= 50.0, "{with_lens:?} nm");
    assert!(
        rms < 0.5 * affine_rms,
        "{with_lens:?} against {without:?} nm"
    );
}

#[test]
fn a_dry_run_sends_nothing_and_logs_the_bytes_of_one_push() {
    let b = bench(50.0);
    let before = b.positions_um();
    let out = finish(b.assemble("dry", &["--dry-run"]), RUN_LIMIT);
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let log = std::fs::read_to_string(b.dir.path().join("dry/sent-bytes.log")).unwrap();
    assert!(log.lines().any(|l| l.starts_with("MOV 1 ")), "{log}");
    assert!(log.lines().any(|l| l == "ERR?\\n"), "{log}");
    assert_eq!(
        b.positions_um(),
        before,
        "the simulator moved during a dry run"
    );
    let pushes = std::fs::read_to_string(b.dir.path().join("dry/journal.jsonl"))
        .unwrap()
        .lines()
        .filter(|l| l.contains("\"kind\":\"decision\""))
        .count();
    assert_eq!(pushes, 1);
    // The camera saw the sample unmoved: no placement error, contact or
    // drift figure reads as if a push had been made.
    let printed = String::from_utf8_lossy(&out.stdout);
    assert!(
        printed.contains("1 on paper: the stage did not move"),
        "{printed}"
    );
    for figure in [
        "placement error  rms",
        "lost contacts)",
        "tip drift:",
        "nearest stray:",
    ] {
        assert!(!printed.contains(figure), "{figure}: {printed}");
    }
    // The bench's 150 um step does not bound the pushes: no note of it.
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("max_step_um"), "{stderr}");
    // It does not park the probe, and says a real run would.
    assert!(
        stderr.contains("a real run parks the probe first"),
        "{stderr}"
    );
}

/// A dry run reads no position from the controller: its in-process stage
/// starts at the centre of the travel wherever the real one is. With the
/// real stage 20 um off, it had stopped blaming the calibration; it warns
/// that it cannot check it, and makes its push on paper. Its recording
/// logs no stage position, so `nanopush dry-run` replays it without
/// blaming the calibration either (every frame had said "the loop stops
/// on its first look: ... the calibration does not fit ... make it again").
#[test]
fn a_dry_run_with_the_real_stage_elsewhere_warns_and_pushes_on_paper() {
    let b = bench(50.0);
    let start = b.positions_um();
    let elsewhere = format!("MOV 1 {} 2 {}", start[0] + 20.0, start[1] + 10.0);
    for line in ["SVO 1 1 2 1 3 1", &elsewhere] {
        b.server.handle().with(|c, now| c.handle_line(line, now));
    }
    b.wait_still();
    let before = b.positions_um();
    assert!((before[0] - start[0] - 20.0).abs() < 0.1, "{before:?}");
    let rec = b.dir.path().join("rec");
    let out = finish(
        b.assemble("dry", &["--dry-run", "--record", rec.to_str().unwrap()]),
        RUN_LIMIT,
    );
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("the dry run cannot check the calibration")
            && stderr.contains("22.4 um from where"),
        "{stderr}"
    );
    assert_eq!(b.positions_um(), before, "the simulator moved");
    let o = nanopush()
        .args(["dry-run", "--recording"])
        .arg(&rec)
        .arg("--out")
        .arg(b.dir.path().join("replay"))
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!said.contains("calibration does not fit"), "{said}");
    assert!(said.contains("-> push particle"), "{said}");
}

/// A rig run's journal starts when the run does, before its first frame:
/// the start entry had been stamped after the first frame was looked at
/// and the pattern placed, later than the first observations journalled.
#[test]
fn a_rig_runs_journal_is_stamped_from_its_start() {
    let b = bench(50.0);
    let out = finish(b.assemble("stamped", &["--dry-run"]), RUN_LIMIT);
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let lines: Vec<serde_json::Value> =
        std::fs::read_to_string(b.dir.path().join("stamped/journal.jsonl"))
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
    assert_eq!(lines[0]["event"]["kind"], "start", "{}", lines[0]);
    let time = |l: &serde_json::Value| l["t_s"].as_f64().unwrap();
    let first_seen = lines
        .iter()
        .find(|l| l["event"]["kind"] == "observation")
        .expect("an observation");
    assert!(
        time(&lines[0]) <= time(first_seen),
        "start at {} s, first observation at {} s",
        time(&lines[0]),
        time(first_seen)
    );
    for l in &lines[1..] {
        assert!(time(l) >= time(&lines[0]), "{l} before the start");
    }
}

/// A particle under the probe's body where the stage starts is in the
/// placement: the run parks the probe and looks again before it places
/// the pattern, as the loop looks before its first plan. With two
/// particles, one of them hidden, and a pattern of two sites: placed on the
/// first frame alone (before 2026-12-03), the pattern had been placed for
/// the one particle it shows, and with the check on the particles in the
/// field it would be refused; now both count and the run fills both
/// sites. A pattern the particles cannot fill is refused.
#[test]
fn a_particle_under_the_probe_where_the_run_starts_is_in_the_placement() {
    let calibration =
        CameraCalibration::load(&manifest().join("calib/camera-stage-sim-folder.toml")).unwrap();
    // The feeder draws the probe pointing at 60 deg in the frame, its apex
    // where the stage starts (mid-range); its body lies behind the apex.
    let apex_px = calibration.stage_to_pixel(50.0 * UM, 50.0 * UM).unwrap();
    let (sin, cos) = 60f64.to_radians().sin_cos();
    let back_px = |d: f64| calibration.pixel_to_stage_m(apex_px[0] - d * cos, apex_px[1] - d * sin);
    let hidden = back_px(100.0);
    let particle = |id, at: [f64; 2]| Particle {
        id,
        centre_m: Vector2::from(at),
        radius_m: scene().particle_radius_m,
    };
    let world = Layout {
        field_m: [100.0 * UM, 100.0 * UM],
        particles: vec![particle(0, [75.0 * UM, 30.0 * UM]), particle(1, hidden)],
    };
    let b = bench_seeing(50.0, None, &world);
    let pair = b.dir.path().join("pair.toml");
    std::fs::write(
        &pair,
        "sites = [{ x_um = 0.0, y_um = 0.0 }, { x_um = 10.5, y_um = 0.0 }]\n",
    )
    .unwrap();
    let assemble = |pattern: &Path, out: &str| {
        nanopush()
            .args(["assemble", "--rig"])
            .arg(&b.rig_path)
            .arg("--pattern")
            .arg(pattern)
            .arg("--out")
            .arg(b.dir.path().join(out))
            .output()
            .unwrap()
    };
    let out = assemble(&pair, "run");
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let events = journal_events(&b.dir.path().join("run"));
    let first_look = events
        .iter()
        .find(|e| e["kind"] == "observation")
        .unwrap_or_else(|| panic!("no observation: {events:?}"));
    let seen = first_look["particles"].as_array().unwrap();
    assert_eq!(seen.len(), 2, "the loop's first look: {first_look}");
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(b.dir.path().join("run/report.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(report["filled"], 2, "{report}");
    let row = b.dir.path().join("row.toml");
    let sites = "sites = [{ x_um = 0.0, y_um = 0.0 }, { x_um = 10.5, y_um = 0.0 }, { x_um = 21.0, y_um = 0.0 }]\n";
    std::fs::write(&row, sites).unwrap();
    let refused = assemble(&row, "three");
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success()
            && stderr.contains("the pattern has 3 sites but")
            && stderr.contains("2 particles in the field"),
        "{stderr}"
    );
}

#[test]
fn a_rig_run_builds_the_pattern_where_asked() {
    let b = bench(50.0);
    let placed = ["--at", "50,45", "--pitch-um", "11", "--rotation-deg", "90"];
    let out = finish(
        b.assemble("at", &[&["--dry-run"][..], &placed].concat()),
        RUN_LIMIT,
    );
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let events = journal_events(&b.dir.path().join("at"));
    // A rig has no seed: neither the start entry nor the report gives one
    // (both had said seed 1, the simulated rig's default).
    assert!(events[0].get("seed").is_none(), "{}", events[0]);
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(b.dir.path().join("at/report.json")).unwrap(),
    )
    .unwrap();
    assert!(report["asked"]["seed"].is_null(), "{}", report["asked"]);
    let sites = points_um(&events[0]["sites_um"]);
    let ((cx, w), (cy, h)) = (span(&sites, 0), span(&sites, 1));
    assert!(
        (cx - 50.0).abs() < 1e-6 && (cy - 45.0).abs() < 1e-6,
        "centre ({cx}, {cy})"
    );
    // L stands 4 pitches tall and 2 wide; a quarter turn lays it down.
    assert!(
        (w - 44.0).abs() < 1e-6 && (h - 22.0).abs() < 1e-6,
        "{w} x {h} um"
    );
}

/// The E-727 templates' largest step (10 um) and a top speed below the
/// loop's 50 um/s travel: the run had stopped before its first lifted
/// travel ("speed 50 um/s is not in (0, 20]"; at the templates' own 50,
/// "not in (0, 49.99999999999999]", a rounding, `safety.rs`' units), then
/// "a move of 54.5 um is longer than the largest allowed step"). Long
/// moves go in pieces, the travel within the top speed; a scene pushing
/// faster than it is refused before anything moves.
#[test]
fn a_rig_with_the_templates_short_step_and_top_speed_assembles() {
    let b = bench(50.0);
    let text = std::fs::read_to_string(&b.rig_path).unwrap();
    let templated = text
        .replace("max_step_um = 150.0", "max_step_um = 10.0")
        .replace("top_speed_um_s = 200.0", "top_speed_um_s = 20.0");
    assert_ne!(templated, text, "the replacement did not apply");
    std::fs::write(&b.rig_path, &templated).unwrap();
    let out = finish(b.assemble("templated", &["--json"]), RUN_LIMIT);
    assert!(out.status.success(), "{}", failed(out.status, &out));
    // The step, not the range, bounds the pushes: said once.
    let stderr = String::from_utf8_lossy(&out.stderr);
    let note = "(max_step_um 10.0 um in the rig file): a larger step makes fewer pushes";
    assert_eq!(stderr.matches(note).count(), 1, "{stderr}");
    assert!(stderr.contains("note: pushes at most "), "{stderr}");
    let report = json(&out);
    assert_eq!(report["filled"], report["sites"], "{report}");
    assert_eq!(report["outcome"], "done", "{report}");
    // Pushes fit one 10 um move: cut into pieces by the stage, they had
    // stopped mid-push and ended short (L: 10 pushes, 2 re-pushes).
    eprintln!(
        "10 um step: {} pushes, {} re-pushes",
        report["pushes"], report["repushes"]
    );
    assert_eq!(report["repushes"], 0, "{report}");
    assert_eq!(report["lost_contacts_detected"], 0, "{report}");
    // Refused before anything moves, saying why.
    let refused_with = |name: &str, rig: String, why: &[&str]| {
        std::fs::write(&b.rig_path, rig).unwrap();
        let refused = finish(b.assemble(name, &[]), RUN_LIMIT);
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(
            !refused.status.success() && why.iter().all(|w| stderr.contains(w)),
            "{stderr}"
        );
        assert!(!b.moving());
    };
    refused_with(
        "slow",
        templated.replace("top_speed_um_s = 20.0", "top_speed_um_s = 0.5"),
        &["the scene pushes at 1.000 um/s, faster than the rig file's top_speed_um_s 0.500"],
    );
    // A step that holds no useful push, naming the step it needs.
    refused_with(
        "tiny",
        templated.replace("max_step_um = 10.0", "max_step_um = 1.5"),
        &[
            "a push must fit one stage move of at most 1.500 um",
            "raise max_step_um to at least",
        ],
    );
}

#[test]
fn a_dry_run_that_ends_on_a_stage_error_exits_non_zero_and_still_reports() {
    let b = bench(50.0);
    // The dry run's in-process controller moves in real time: travel moves
    // settle in under 1.5 s, the push (5 um at about 1 um/s) takes over 5 s.
    let text = std::fs::read_to_string(&b.rig_path).unwrap();
    let short = text.replace("settle_timeout_ms = 20000", "settle_timeout_ms = 3000");
    assert_ne!(short, text, "the replacement did not apply");
    std::fs::write(&b.rig_path, short).unwrap();
    let out = finish(b.assemble("dry", &["--dry-run", "--json"]), RUN_LIMIT);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{}", failed(out.status, &out));
    // With --json, stdout is the report alone (the sent bytes' files had
    // been named there first, and a script could not read it).
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("{e}: {}", String::from_utf8_lossy(&out.stdout));
    });
    let outcome = report["outcome"].as_str().unwrap_or_default();
    assert!(outcome.contains("stopped: rig error"), "{report}");
    // The controller answered: the move did not settle in time (it had
    // read "did not answer within 3000 ms").
    assert!(
        stderr.contains("was not on target within 3000 ms (the rig file's settle_timeout_ms)"),
        "{stderr}"
    );
    assert!(
        stderr.contains("bytes that would have been sent: "),
        "{stderr}"
    );
    for file in ["journal.jsonl", "report.json", "sent-bytes.log"] {
        assert!(b.dir.path().join("dry").join(file).exists(), "no {file}");
    }
}

#[test]
fn ctrl_c_halts_the_stage_mid_move_and_garbage_replies_stop_the_run_with_it_still() {
    // Real time: the first travel (tens of um at 10 um/s) takes seconds.
    let b = bench(1.0);
    let child = b.assemble("interrupted", &[]);
    b.wait_for_the_loops_move("interrupted");
    let target = targets(&b.server, "1 2 3");
    let out = interrupted(child, Duration::from_secs(20));
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(!b.moving(), "the stage was left moving");
    // The run stops as a run stops: journalled, reported, and the error
    // says how to go on (it had been a "stage fault" with no report).
    assert!(
        stderr.contains("go on with it: nanopush assemble --rig"),
        "{stderr}"
    );
    let stopped = b.dir.path().join("interrupted");
    let report = std::fs::read_to_string(stopped.join("report.json")).unwrap();
    assert!(
        report.contains("interrupted (Ctrl-C or a termination signal)"),
        "{report}"
    );
    let journal = std::fs::read_to_string(stopped.join("journal.jsonl")).unwrap();
    let last = journal.lines().last().unwrap();
    assert!(last.contains("\"kind\":\"stopped\""), "{last}");
    let here = b.positions_um();
    assert!(
        (0..3).any(|i| (here[i] - target[i]).abs() > 0.5),
        "halted at {here:?}, which is the move's target {target:?}: not halted mid-way"
    );

    // A controller that answers garbage in the middle of a run.
    let child = b.assemble("garbage", &[]);
    b.wait_for_the_loops_move("garbage");
    b.server.set_fault(SimFault::Garbage);
    let out = finish(child, Duration::from_secs(60));
    b.server.set_fault(SimFault::None);
    assert!(!out.status.success(), "{}", failed(out.status, &out));
    std::thread::sleep(Duration::from_millis(100));
    assert!(!b.moving(), "the stage was left moving");
    // A controller gone wrong stops the run as a run stops too: it had
    // left no report, no end in the journal and no word of --resume.
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("go on with it: nanopush assemble --rig"),
        "{stderr}"
    );
    let stopped = b.dir.path().join("garbage");
    assert!(stopped.join("report.json").exists(), "no report");
    let journal = std::fs::read_to_string(stopped.join("journal.jsonl")).unwrap();
    let last = journal.lines().last().unwrap();
    assert!(last.contains("\"kind\":\"stopped\""), "{last}");

    // Real hardware whose first move nobody confirms (no terminal): refused
    // before servo on, the run stopped with the reason, and nothing moved.
    let text = b.as_real_hardware();
    let before = b.positions_um();
    let out = finish(b.assemble("unconfirmed", &[]), Duration::from_secs(60));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{}", failed(out.status, &out));
    assert!(
        stderr.contains("not confirmed: nothing was moved"),
        "{stderr}"
    );
    assert_eq!(b.positions_um(), before);
    std::fs::write(&b.rig_path, text).unwrap();
}

/// Ctrl-C as soon as `assemble --rig` can take it, before the rig is even
/// open: answered at once on stderr, and the set-up (opening the rig, the
/// first frame, placing the pattern: seconds) stops at its next step with
/// "interrupted ... nothing was moved", --out left unmade and the stage
/// still. The set-up had run on to the first stage command unaware of the
/// press, begun a journal and only then stopped, or (the handler installed
/// only with the stage) been ended by it without a word.
#[test]
fn ctrl_c_during_the_set_up_is_answered_at_once_and_starts_nothing() {
    // Real time, and the coarse rig: its set-up plans CMU on 50 particles.
    let b = coarse_bench(1.0);
    let before = b.positions_um();
    let child = b.assemble("early", &[]);
    wait_until_caught(&child);
    let pressed = Instant::now();
    // Generous: a noisy machine may be slow, but the run must not go on.
    let out = interrupted(child, Duration::from_secs(60));
    let stopped_in = pressed.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("stopped {stopped_in:?} after the press: {stderr}");
    assert!(!out.status.success(), "{}", failed(out.status, &out));
    assert!(
        stopped_in < Duration::from_secs(10),
        "stopped {stopped_in:?} after the press: {stderr}"
    );
    assert!(
        stderr.starts_with("stopping (Ctrl-C or a termination signal) now"),
        "the press was not answered first: {stderr}"
    );
    assert!(
        stderr.contains("error: interrupted (Ctrl-C or a termination signal)"),
        "{stderr}"
    );
    assert!(stderr.contains("nothing was moved"), "{stderr}");
    assert!(stderr.contains("nothing was started"), "{stderr}");
    assert!(
        !b.dir.path().join("early").exists(),
        "--out was made for a run that never began"
    );
    assert!(!b.moving(), "a stage was left moving");
    assert_eq!(b.positions_um(), before, "the nanostage moved");
}

/// A first move on real hardware that nobody confirms (here standard input
/// at its end, no terminal: what EOF or Ctrl-C at the question come to)
/// moves nothing, and leaves `--out` and `--record` as they were: a
/// journal left there had blocked the same command ("journal.jsonl exists:
/// use --resume"), and a recording left in the `--record` folder did too.
#[test]
fn an_unconfirmed_first_move_leaves_out_as_it_was() {
    let b = bench(50.0);
    b.as_real_hardware();
    let kept = b.dir.path().join("kept");
    std::fs::create_dir(&kept).unwrap();
    std::fs::write(kept.join("notes.txt"), "sample 3").unwrap();
    let record = b.dir.path().join("rec/run");
    let before = b.positions_um();
    // A folder made by the run and one that was there; each run twice.
    for out in [b.dir.path().join("new/run"), kept.clone()] {
        for attempt in 0..2 {
            let text = std::ffi::OsStr::new(b.text);
            let stderr = b.unconfirmed(&[
                "--text".as_ref(),
                text,
                "--out".as_ref(),
                out.as_os_str(),
                "--record".as_ref(),
                record.as_os_str(),
            ]);
            assert!(
                stderr.contains("is as it was") && !stderr.contains("--resume"),
                "attempt {attempt}: {stderr}"
            );
            // The flag that waives the question is named, and the move
            // reads in um without float noise (14.999999999999998 had shown).
            assert!(
                stderr.contains("run the command again with --yes-move-hardware"),
                "{stderr}"
            );
            let asked = stderr.lines().find(|l| l.starts_with("first move on "));
            assert!(
                asked.is_some_and(|l| l.contains(" um")
                    && !l.contains("9999")
                    && !l.contains("0000")),
                "{stderr}"
            );
            assert!(!b.dir.path().join("new").exists(), "{stderr}");
            assert!(!b.dir.path().join("rec").exists(), "{stderr}");
            let names: Vec<String> = std::fs::read_dir(&kept)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            assert_eq!(names, ["notes.txt"], "{stderr}");
        }
    }
    assert_eq!(b.positions_um(), before);
}

/// Appends half a line to `journal`, as a crash while writing leaves one.
fn tear_last_line(journal: &Path) {
    let mut file = std::fs::OpenOptions::new()
        .append(true)
        .open(journal)
        .unwrap();
    std::io::Write::write_all(&mut file, br#"{"seq":999,"t_s":1.0,"ev"#).unwrap();
}

/// Every file directly in `dir`, by name, with its bytes.
fn files_in(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    files.sort();
    files
}

/// A `--resume` whose first move on real hardware nobody confirms moves
/// nothing and leaves the run's folder as it was, byte for byte: it had
/// appended `resume` and `stopped` lines to the journal and rewritten the
/// report. A torn last line of the journal, which the resume cuts off
/// before appending, is put back too, and a video beside it is left alone
/// (only what a resume writes is kept, `MadeFolder::keeping`).
#[test]
fn an_unconfirmed_resume_leaves_the_run_as_it_was() {
    let b = bench(50.0);
    let run_dir = b.dir.path().join("run");
    b.stopped_after_decisions("run", 1, &[]);
    tear_last_line(&run_dir.join("journal.jsonl"));
    std::fs::write(run_dir.join("run.mp4"), vec![7u8; 1 << 20]).unwrap();
    let before = files_in(&run_dir);
    b.as_real_hardware();
    let at = b.positions_um();
    let journal = run_dir.join("journal.jsonl");
    let stderr = b.unconfirmed(&["--resume".as_ref(), journal.as_os_str()]);
    assert!(
        stderr.contains("is as it was before: run the same command again to go on"),
        "{stderr}"
    );
    let names = |files: &[(String, Vec<u8>)]| -> Vec<String> {
        files.iter().map(|(n, _)| n.clone()).collect()
    };
    let after = files_in(&run_dir);
    assert_eq!(names(&after), names(&before), "{stderr}");
    assert!(after == before, "a file of the run changed: {stderr}");
    assert_eq!(b.positions_um(), at);
}

/// A rig file whose stage unit is 1000 times the controller's (`unit_um =
/// 1000` for a controller counting in um): the stage reads 1000 times where
/// the camera sees the probe. The run stops at its first frame naming the
/// factor and unit_um, and offers `--resume` (the calibration fits); it
/// had stopped blaming the calibration ("make it again").
#[test]
fn a_stage_unit_1000_times_off_is_named_not_the_calibration() {
    let b = bench(50.0);
    let text = std::fs::read_to_string(&b.rig_path).unwrap();
    assert!(text.contains("unit_um = 1.0\n"), "{text}");
    std::fs::write(
        &b.rig_path,
        text.replace("unit_um = 1.0\n", "unit_um = 1000.0\n"),
    )
    .unwrap();
    let run = finish(b.assemble("run", &[]), RUN_LIMIT);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{}", failed(run.status, &run));
    assert!(
        stderr.contains("the stage moved 1/1000 of what it was asked")
            && stderr.contains("stage unit_um")
            && stderr.contains("1000 times too large"),
        "{stderr}"
    );
    assert!(!stderr.contains("calibration does not fit"), "{stderr}");
    assert!(stderr.contains("--resume"), "{stderr}");
}

/// A rig file whose calibration is not the camera's (the camera's view
/// lies 20 um further along x than it says) stops the run at its first
/// frame for the calibration, and offers no `--resume`: the sites were
/// placed through that map, so the way on is a new calibration and a new
/// run (the `--resume` line had been printed all the same).
#[test]
fn a_run_stopped_for_its_calibration_is_not_offered_a_resume() {
    let named = manifest().join("calib/camera-stage-sim-folder.toml");
    let said = CameraCalibration::load(&named).unwrap();
    let camera = CameraCalibration::affine(
        said.linear,
        said.offset_m + nalgebra::Vector2::new(20.0 * UM, 0.0),
    );
    let b = bench_seeing(50.0, Some(&camera), &layout());
    std::fs::copy(&named, b.dir.path().join("camera.toml")).unwrap();
    let run = finish(b.assemble("run", &[]), RUN_LIMIT);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{}", failed(run.status, &run));
    assert!(
        stderr.contains("the calibration does not fit this camera and stage")
            && stderr.contains("make the calibration again (nanopush rig calibrate --rig")
            && stderr.contains("then start a new run in another --out"),
        "{stderr}"
    );
    assert!(!stderr.contains("--resume"), "{stderr}");
    // Resumed by hand all the same: refused, naming the stop and what to
    // do, before anything moved or was written.
    let run_dir = b.dir.path().join("run");
    let before = files_in(&run_dir);
    let at = b.positions_um();
    let resumed = finish(
        nanopush()
            .args(["assemble", "--rig"])
            .arg(&b.rig_path)
            .arg("--resume")
            .arg(run_dir.join("journal.jsonl"))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
        RUN_LIMIT,
    );
    let stderr = String::from_utf8_lossy(&resumed.stderr);
    assert!(
        !resumed.status.success(),
        "{}",
        failed(resumed.status, &resumed)
    );
    assert!(
        stderr.contains("for its calibration: ")
            && stderr.contains("the calibration does not fit this camera and stage")
            && stderr.contains("so it is not to be resumed: make the calibration again (nanopush rig calibrate --rig")
            && stderr.contains("then start a new run in another --out"),
        "{stderr}"
    );
    assert!(
        files_in(&run_dir) == before,
        "the run's folder changed: {stderr}"
    );
    assert_eq!(b.positions_um(), at);
}

#[test]
fn assembling_cmu_with_a_gcs_coarse_stage_completes_like_the_simulated_rig() {
    let seed = COARSE_SEED.to_string();
    let particles = COARSE_PARTICLES.to_string();
    let reference_dir = tempfile::tempdir().unwrap();
    let reference = reference_run(
        reference_dir.path(),
        &[
            "--text",
            COARSE_TEXT,
            "--seed",
            &seed,
            "--particles",
            &particles,
        ],
    );

    // A time scale of 100: a 10 um push at 1 um/s takes 0.1 s.
    let b = coarse_bench(100.0);
    let start_units = b.coarse_units();
    let started = Instant::now();
    let out = finish(b.assemble("run", &["--json"]), RUN_LIMIT);
    let wall_s = started.elapsed().as_secs_f64();
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let report = b.completed_like(&out, &reference);
    // The same --out again names the report a rig run writes (it had named
    // report.md, which only the simulated rig writes).
    let again = finish(b.assemble("run", &[]), RUN_LIMIT);
    let said = String::from_utf8_lossy(&again.stderr);
    assert!(!again.status.success());
    assert!(
        said.contains("holds a finished run (its report is report.json there)"),
        "{said}"
    );

    // The coarse stage was used: the journal holds coarse moves and the
    // coarse controller is no longer where it started.
    let run_dir = b.dir.path().join("run");
    let journal = std::fs::read_to_string(run_dir.join("journal.jsonl")).unwrap();
    let coarse_moves = journal
        .lines()
        .filter(|l| l.contains("\"kind\":\"coarse_move\""))
        .count();
    assert!(coarse_moves > 0, "no coarse move in the journal");
    let end_units = b.coarse_units();
    assert_ne!(end_units, start_units, "the coarse controller never moved");

    let errors_nm = b.coarse_truth_errors_nm(&run_dir);
    let (rms, max) = rms_max(&errors_nm);
    eprintln!(
        "GCS rig with coarse stage: {} sites, truth rms {rms:.0} nm, max {max:.0} nm, {} pushes, \
         {coarse_moves} coarse moves, {wall_s:.1} s wall; simulated rig: rms {:.0} nm, max {:.0} nm, {} pushes",
        errors_nm.len(),
        report["pushes"],
        reference["rms_error_nm"].as_f64().unwrap(),
        reference["max_error_nm"].as_f64().unwrap(),
        reference["pushes"],
    );
    // Every site holds a particle within the executor's 0.2 um tolerance,
    // as on the simulated rig.
    assert!(
        errors_nm.iter().all(|e| *e <= 200.0),
        "true placement errors {errors_nm:?} nm"
    );
    assert!(rms < 200.0, "rms {rms} nm");
    assert!(
        b.feeder
            .world()
            .contacts()
            .iter()
            .any(|c| c.moved_m > 1.0 * UM),
        "the probe pushed nothing"
    );
}

/// A run on a rig without a coarse stage, stopped part way by Ctrl-C,
/// goes on with `assemble --rig --resume` and fills every site (ground
/// truth), its stopped run's lines kept.
#[test]
fn a_stopped_rig_run_resumes_and_fills_every_site() {
    let b = bench(50.0);
    let run_dir = b.dir.path().join("run");
    let before = b.stopped_after_decisions("run", 3, &[]);
    let report = b.resumed(&run_dir.join("journal.jsonl"));
    let after = std::fs::read_to_string(run_dir.join("journal.jsonl")).unwrap();
    assert!(
        after.starts_with(&before),
        "the stopped run's lines changed"
    );
    let errors_nm = nearest_particle_nm(&b.feeder.world().world, &sites_m(&run_dir));
    eprintln!(
        "resumed after 3 push decisions: {} sites, {} pushes in all, truth errors up to {:.0} nm",
        errors_nm.len(),
        report["pushes"],
        errors_nm.iter().copied().fold(0.0, f64::max)
    );
    assert!(
        errors_nm.iter().all(|e| *e <= 200.0),
        "true placement errors {errors_nm:?} nm"
    );
}

/// A run on a rig with a coarse stage, stopped part way by Ctrl-C, goes on
/// with `assemble --rig --resume`: the run's sample frame is put back on
/// the coarse stage, the journal's lines are kept byte for byte, and every
/// site ends up holding a particle (ground truth).
#[test]
fn a_stopped_coarse_rig_run_resumes_and_fills_every_site() {
    let b = coarse_bench(100.0);
    let run_dir = b.dir.path().join("run");
    let journal = run_dir.join("journal.jsonl");
    // Plans keeping no gap round the pattern: those the 10 sites filled
    // by the 12th decision were counted on (keeping 2.5 um, some of the 12
    // push strays out first, and 7 are filled).
    let before = b.stopped_after_decisions("run", 12, &["--keep-clear-um", "0"]);
    let at_stop = b.feeder.world().world.clone();

    // Not on the simulated rig: the journal says which rig it was.
    let out = nanopush()
        .args(["assemble", "--resume"])
        .arg(&journal)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    // The hint names the rig file, not the journal, as --rig's value.
    let hint = format!("resume it with --rig {} --resume", b.rig_path.display());
    assert!(stderr.contains(&hint), "{stderr}");
    assert_eq!(std::fs::read_to_string(&journal).unwrap(), before);

    let report = b.resumed(&journal);
    let after = std::fs::read_to_string(&journal).unwrap();
    assert!(
        after.starts_with(&before),
        "the stopped run's lines changed"
    );
    assert!(after[before.len()..].contains("\"kind\":\"resume\""));
    let errors_nm = b.coarse_truth_errors_nm(&run_dir);
    let (rms, max) = rms_max(&errors_nm);
    // The pattern goes on where the stopped run put it: sites filled before
    // the stop are sites of the resumed run (10 here; with the frame not
    // put back the pattern is built elsewhere and none is).
    let sites = b.coarse_sites_on_sample(&run_dir);
    let kept = nearest_particle_nm(&at_stop, &sites)
        .iter()
        .filter(|e| **e <= 200.0)
        .count();
    eprintln!(
        "resumed after 12 push decisions: {} sites, {kept} filled at the stop, truth rms {rms:.0} nm, max {max:.0} nm, {} pushes in all",
        errors_nm.len(),
        report["pushes"]
    );
    assert!(
        kept >= 8,
        "{kept} sites of the resumed run were filled at the stop"
    );
    // The camera sees the particles where the stopped run last saw them:
    // the sample frame is the run's (the coarse stage's readings start at
    // zero in each process: without its fixed coordinates the frame was
    // 10.7 um off here, and 3 sites filled at the stop were kept).
    let events = journal_events(&run_dir);
    let resumed_at = events.iter().position(|e| e["kind"] == "resume").unwrap();
    let observations = |range: &[serde_json::Value]| -> Vec<Vec<[f64; 2]>> {
        range
            .iter()
            .filter(|e| e["kind"] == "observation")
            .map(|e| points_um(&e["particles"]))
            .collect()
    };
    let last_before = observations(&events[..resumed_at]).pop().unwrap();
    let first_after = observations(&events[resumed_at..]).swap_remove(0);
    // And it plans on every particle the run knew: it first looks from
    // where the run first looked (from where it stopped, one particle lay
    // out of view here, and the plan went through it: 39-41 pushes in all
    // against 36-37).
    let planned_at = resumed_at
        + events[resumed_at..]
            .iter()
            .position(|e| e["kind"] == "plan")
            .unwrap();
    let planned_on = observations(&events[resumed_at..planned_at]).pop().unwrap();
    assert_eq!(planned_on.len(), last_before.len());
    let mut moved_um: Vec<f64> = first_after
        .iter()
        .map(|p| {
            last_before
                .iter()
                .map(|q| (p[0] - q[0]).hypot(p[1] - q[1]))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    moved_um.sort_by(f64::total_cmp);
    let median = moved_um[moved_um.len() / 2];
    assert!(
        median < 0.2,
        "particles seen {median} um from where the run last saw them"
    );
    assert!(
        errors_nm.iter().all(|e| *e <= 200.0),
        "true placement errors {errors_nm:?} nm"
    );
    assert!(!b.moving(), "a stage was left moving");
}

/// Ctrl-C during a resume's set-up, before its loop began (here while the
/// coarse stage goes back to where the run first looked, the sample moved
/// by hand since the stop): the stage is halted mid-way and the command
/// exits non-zero saying so once, with the `--resume` line; the journal is
/// left byte for byte as it was (the resume entry is written as the loop
/// begins, `Assembly::resume`; a torn last line, cut as the journal was
/// read, is put back), and the same `--resume` then finishes the run. L
/// on the coarse rig: a few seconds where CMU takes 14.
#[test]
fn ctrl_c_in_a_resumes_set_up_halts_the_stage_and_leaves_the_journal_as_it_was() {
    let b = Bench {
        text: TEXT,
        ..coarse_bench(100.0)
    };
    let journal = b.dir.path().join("run/journal.jsonl");
    b.stopped_after_decisions("run", 1, &[]);
    let whole = std::fs::read(&journal).unwrap();
    // The resume cuts it off on reading the journal: put back too.
    tear_last_line(&journal);
    let before = std::fs::read(&journal).unwrap();
    let coarse = b.coarse.as_ref().unwrap();
    // The tip lifted, then the sample moved 0.2 mm along each axis.
    b.server
        .handle()
        .with(|c, now| c.handle_line("MOV 3 15", now));
    b.wait_still();
    let [x, y] = b.coarse_units()[..] else {
        unreachable!("two coarse axes")
    };
    let by_hand = format!("MOV 1 {} 2 {}", x + 0.2, y + 0.2);
    for line in ["SVO 1 1 2 1", &by_hand] {
        coarse.handle().with(|c, now| c.handle_line(line, now));
    }
    b.wait_still();
    // Slow enough (0.2 mm at 1 mm/s now takes 10 s) for the press to
    // come while the set-up moves the coarse stage back.
    b.set_time_scale(0.02);
    let mut child = b.resuming(&journal);
    let started = Instant::now();
    while !coarse.inspect(|c, now| c.any_moving(now)) {
        if child.try_wait().unwrap().is_some() || started.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "the resume never moved the coarse stage: {}",
                failed(out.status, &out)
            );
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let target = targets(coarse, "1 2");
    let out = interrupted(child, Duration::from_secs(30));
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stderr}");
    assert!(!out.status.success(), "{}", failed(out.status, &out));
    // The torn line's warning comes first, as the journal is read.
    let first = stderr
        .lines()
        .find(|l| !l.contains("its last line was cut off"));
    assert!(
        first.is_some_and(|l| l.starts_with("stopping (Ctrl-C or a termination signal) now")),
        "the press was not answered first: {stderr}"
    );
    assert!(
        stderr.contains("interrupted (Ctrl-C or a termination signal)"),
        "{stderr}"
    );
    let go_on = format!(
        "; the stage was halted; {} is as it was before; go on with it: nanopush assemble --rig {} --resume {}",
        b.dir.path().join("run").display(),
        b.rig_path.display(),
        journal.display()
    );
    assert!(stderr.contains(&go_on), "{stderr}");
    // Said once: the move's own stop says it too.
    assert_eq!(
        stderr.matches("the stage was halted").count(),
        1,
        "{stderr}"
    );
    assert!(!b.moving(), "a stage was left moving");
    let here = b.coarse_units();
    assert!(
        (0..2).any(|i| (here[i] - target[i]).abs() > 1e-3),
        "the coarse stage stopped at {here:?}, its target {target:?}: not halted mid-way"
    );
    assert!(
        std::fs::read(&journal).unwrap() == before,
        "the journal changed: {stderr}"
    );

    // Not stopped, the same resume finishes the run, its journal one
    // resume on.
    b.set_time_scale(100.0);
    b.resumed(&journal);
    let after = std::fs::read(&journal).unwrap();
    assert!(after.starts_with(&whole), "the stopped run's lines changed");
    let added = String::from_utf8_lossy(&after[whole.len()..]).into_owned();
    assert_eq!(added.matches("\"kind\":\"resume\"").count(), 1, "{added}");
}

/// With a coarse stage, `--at` is in the calibration's coordinates (those
/// `rig probe --camera` prints the view in), not the run's shifted field:
/// the pattern's centre lies where the calibration puts the asked point
/// among the particles the camera shows.
#[test]
fn a_coarse_rig_run_centres_the_pattern_at_calibrated_coordinates() {
    let b = coarse_bench(50.0);
    let calibration =
        CameraCalibration::load(&manifest().join("calib/camera-stage-sim-coarse.toml")).unwrap();
    // The view's middle, plus a few um so that no symmetry hides a slip.
    let [vx, vy] = calibration.pixel_to_stage_m(280.0, 220.0);
    let at = [vx * 1e6 + 3.0, vy * 1e6 - 2.0];
    let at_flag = format!("{},{}", at[0], at[1]);
    let out = finish(
        b.assemble("at", &["--dry-run", "--at", &at_flag]),
        RUN_LIMIT,
    );
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let events = journal_events(&b.dir.path().join("at"));
    let sites = points_um(&events[0]["sites_um"]);
    let first_seen = events
        .iter()
        .find(|e| e["kind"] == "observation")
        .map(|e| points_um(&e["particles"]))
        .unwrap();
    // The particles in the calibration's coordinates: a frame of the
    // folder (nothing moved in a dry run), detected here.
    let mut frames: Vec<_> = std::fs::read_dir(&b.frames)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    frames.sort();
    let frame = frames
        .iter()
        .rev()
        .find_map(|f| load_frame(f, Channel::Luminance).ok())
        .unwrap();
    let settings = Perception::for_particles(5e-6, calibration.m_per_px(), 1).detect;
    let calibrated: Vec<[f64; 2]> = detect_particles(&frame, &settings)
        .unwrap()
        .iter()
        .filter(|d| !d.edge_clipped)
        .map(|d| {
            calibration
                .pixel_to_stage_m(d.x_px, d.y_px)
                .map(|v| v * 1e6)
        })
        .collect();
    // The run's field is the calibration's coordinates shifted: the shift
    // that lays most detections onto the run's first sighting.
    let matches = |shift: [f64; 2]| {
        calibrated
            .iter()
            .filter(|c| {
                first_seen
                    .iter()
                    .any(|p| (p[0] - c[0] - shift[0]).hypot(p[1] - c[1] - shift[1]) < 0.3)
            })
            .count()
    };
    let shift = first_seen
        .iter()
        .flat_map(|p| calibrated.iter().map(move |c| [p[0] - c[0], p[1] - c[1]]))
        .max_by_key(|&s| matches(s))
        .unwrap();
    assert!(
        matches(shift) * 10 >= calibrated.len() * 8,
        "{} of {} detections matched",
        matches(shift),
        calibrated.len()
    );
    let centre = [span(&sites, 0).0 - shift[0], span(&sites, 1).0 - shift[1]];
    assert!(
        (centre[0] - at[0]).hypot(centre[1] - at[1]) < 0.3,
        "centre {centre:?} um in the calibration's coordinates, asked {at:?}"
    );
    // A point off the view is refused in the words it was asked in.
    let off = format!("{},{}", at[0] + 500.0, at[1]);
    let out = finish(b.assemble("off", &["--dry-run", "--at", &off]), RUN_LIMIT);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    let asked = format!("placed at ({:.1}, {:.1}) um", at[0] + 500.0, at[1]);
    assert!(stderr.contains(&asked), "{stderr}");
    // ... with the centres that fit, in the same coordinates: the point
    // that planned above lies among them.
    let range: Vec<f64> = stderr
        .split("may lie from")
        .nth(1)
        .unwrap_or_else(|| panic!("no range in: {stderr}"))
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .filter_map(|w| w.parse().ok())
        .take(4)
        .collect();
    assert!(
        range[0] <= at[0] && at[0] <= range[2] && range[1] <= at[1] && at[1] <= range[3],
        "{at:?} outside {range:?}: {stderr}"
    );
}

#[test]
fn a_dry_run_with_a_coarse_stage_moves_neither_stage_and_logs_both() {
    let b = coarse_bench(50.0);
    let (nano, coarse) = (b.positions_um(), b.coarse_units());
    let out = finish(b.assemble("dry", &["--dry-run"]), RUN_LIMIT);
    assert!(out.status.success(), "{}", failed(out.status, &out));
    assert_eq!(b.positions_um(), nano, "the nanostage moved in a dry run");
    assert_eq!(
        b.coarse_units(),
        coarse,
        "the coarse stage moved in a dry run"
    );
    let log = std::fs::read_to_string(b.dir.path().join("dry/coarse-sent-bytes.log")).unwrap();
    assert!(log.lines().any(|l| l == "POS? 1 2\\n"), "{log}");
    assert!(
        std::fs::read_to_string(b.dir.path().join("dry/sent-bytes.log"))
            .unwrap()
            .lines()
            .any(|l| l.starts_with("MOV 1 ")),
        "no nanostage move logged"
    );
}

/// `--record` on a rig writes a recording the dry-run replays: its first
/// plan is the run's first decision (the flag had been ignored on a rig
/// without a word).
#[test]
fn a_rig_run_is_recorded_and_its_recording_replays() {
    let b = bench(50.0);
    let rec = b.dir.path().join("rec");
    let out = finish(
        b.assemble(
            "recorded",
            &["--dry-run", "--record", rec.to_str().unwrap()],
        ),
        RUN_LIMIT,
    );
    assert!(out.status.success(), "{}", failed(out.status, &out));
    let events = journal_events(&b.dir.path().join("recorded"));
    let observations = events.iter().filter(|e| e["kind"] == "observation").count();
    let decision = events
        .iter()
        .find(|e| e["kind"] == "decision")
        .expect("a decision");
    assert!(rec.join("scene.toml").is_file(), "no scene recorded");
    let dry = b.dir.path().join("dry");
    let o = nanopush()
        .args(["dry-run", "--json", "--recording"])
        .arg(&rec)
        .arg("--out")
        .arg(&dry)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let frames = report["frames"].as_array().unwrap();
    assert_eq!(frames.len(), observations);
    let planned = frames
        .iter()
        .map(|f| &f["command"])
        .find(|c| c["kind"] == "push")
        .expect("a push commanded");
    assert_eq!(planned["particle"], decision["particle"]);
    let xy = |v: &serde_json::Value| [v[0].as_f64().unwrap(), v[1].as_f64().unwrap()];
    for key in ["from_um", "to_um"] {
        let (a, b) = (xy(&planned[key]), xy(&decision[key]));
        assert!(
            (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-6,
            "{key}: {a:?} vs {b:?}"
        );
    }
}

/// A run on a rig with a coarse stage whose link to both controllers is
/// lost mid-push (the program serving them killed) stops as on the rig
/// without one: the summary on stdout, and on stderr that the tip may be
/// down and the exact `--resume` line; report.json and sites.json written.
/// The coarse stage, asked where it stood for sites.json's pixels, had
/// ended the run on its own error ("stage fault: connection to tcp ...
/// failed", naming neither stage) before any of that, sites.json left out.
#[test]
fn a_coarse_rig_run_that_loses_its_link_mid_push_still_says_how_to_go_on() {
    let mut b = coarse_bench(100.0);
    let run_dir = b.dir.path().join("lost");
    let journal = run_dir.join("journal.jsonl");
    let child = b.assemble("lost", &[]);
    // The tip below the particles' tops, moving: mid-push.
    let tops_um = 2.0 * scene().particle_radius_m / UM;
    let started = Instant::now();
    let pushing = || {
        let pushed =
            std::fs::read_to_string(&journal).is_ok_and(|t| t.contains("\"kind\":\"decision\""));
        pushed && b.moving() && b.server.inspect(|c, now| c.position(2, now).unwrap()) < tops_um
    };
    while !pushing() {
        assert!(started.elapsed() < RUN_LIMIT, "the run never pushed");
        std::thread::sleep(Duration::from_millis(1));
    }
    let coarse_addr = b.coarse.as_ref().and_then(|k| k.tcp_addr()).unwrap();
    // Both controllers gone: their links closed, reconnecting refused (the
    // coarse one first, so that it is gone when the run stops).
    drop(b.coarse.take());
    drop(std::mem::replace(
        &mut b.server,
        SimServer::new(SimConfig::default()),
    ));
    let out = finish(child, Duration::from_secs(60));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{}", failed(out.status, &out));
    for said in ["assembly on", "sites filled", "report: "] {
        assert!(
            stdout.contains(said),
            "no {said:?} in {stdout}\nstderr: {stderr}"
        );
    }
    assert!(
        stderr.contains("the tip may be down on the sample")
            && stderr.contains("lift z before moving x or y by hand (--resume lifts it first)"),
        "{stderr}"
    );
    let resume = format!(
        "go on with it: nanopush assemble --rig {} --resume {}",
        b.rig_path.display(),
        journal.display()
    );
    let error = stderr.trim_end().lines().last().unwrap_or_default();
    assert!(error.ends_with(&resume), "{stderr}");
    // The stop is the nanostage's; the coarse stage's silence is a note.
    assert!(
        error.starts_with("error: assembly did not finish: stopped: rig")
            && !error.contains(&coarse_addr.to_string()),
        "{stderr}"
    );
    let report = std::fs::read_to_string(run_dir.join("report.json")).unwrap();
    let report: serde_json::Value = serde_json::from_str(&report).unwrap();
    let sites = sites_px(&run_dir);
    assert_eq!(
        Some(sites.len() as u64),
        report["sites"].as_u64(),
        "{report}"
    );
    let last = std::fs::read_to_string(&journal).unwrap();
    let last = last.lines().last().unwrap();
    assert!(last.contains("\"kind\":\"stopped\""), "{last}");
}

/// Real hardware's first move waits for the operator's `yes`, typed here
/// on a pseudo-terminal 2 s after the question: the wait is journalled,
/// said apart, and left out of the report's time, which had counted it as
/// the rig's work against the lower bound.
#[test]
fn the_wait_for_the_operators_yes_is_not_the_runs_time() {
    use std::io::{Read, Write};
    let b = bench(50.0);
    b.as_real_hardware();
    let terminal = nix::pty::openpty(None, None).unwrap();
    let mut child = nanopush()
        .args(["assemble", "--rig"])
        .arg(&b.rig_path)
        .args(["--text", b.text, "--out"])
        .arg(b.dir.path().join("run"))
        .stdin(Stdio::from(terminal.slave))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Stderr read as it comes: the question ends without a newline.
    let mut stderr = child.stderr.take().unwrap();
    let (asked, question) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        let mut all = Vec::new();
        let mut chunk = [0u8; 4096];
        while let Ok(n @ 1..) = stderr.read(&mut chunk) {
            all.extend_from_slice(&chunk[..n]);
            if String::from_utf8_lossy(&all).contains("Type `yes`") {
                let _ = asked.send(());
            }
        }
        String::from_utf8_lossy(&all).into_owned()
    });
    question
        .recv_timeout(RUN_LIMIT)
        .expect("the first move was not asked");
    let waited = Duration::from_secs(2);
    std::thread::sleep(waited);
    let mut operator = std::fs::File::from(terminal.master);
    operator.write_all(b"yes\n").unwrap();
    let journal = b.dir.path().join("run/journal.jsonl");
    let started = Instant::now();
    while !std::fs::read_to_string(&journal).is_ok_and(|t| t.contains("\"kind\":\"decision\"")) {
        assert!(started.elapsed() < RUN_LIMIT, "the run never pushed");
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = interrupted(child, Duration::from_secs(30));
    let stderr = reader.join().unwrap();
    assert!(!out.status.success(), "{stderr}");
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(b.dir.path().join("run/report.json")).unwrap(),
    )
    .unwrap();
    let text = std::fs::read_to_string(&journal).unwrap();
    let entries: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let journalled: f64 = entries
        .iter()
        .filter(|e| e["event"]["kind"] == "operator_wait")
        .map(|e| e["event"]["waited_s"].as_f64().unwrap())
        .sum();
    let last_t_s = entries.last().unwrap()["t_s"].as_f64().unwrap();
    let wait_s = report["operator_wait_s"].as_f64().unwrap();
    let time_s = report["time_s"].as_f64().unwrap();
    eprintln!("waited {wait_s:.2} s; run time {time_s:.2} s, last entry at {last_t_s:.2} s");
    assert_eq!(wait_s, journalled, "{report}");
    assert!(wait_s >= waited.as_secs_f64(), "{report}");
    assert!(wait_s < waited.as_secs_f64() + 2.0, "{report}");
    // The report is written after the last entry, at the end's rig time.
    assert!(time_s + wait_s >= last_t_s, "{report}");
    assert!(
        time_s < last_t_s - 1.0,
        "the wait is in the run's time: {report}"
    );
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        summary.contains(&format!(
            "operator: {wait_s:.1} s waiting for `yes`, not in the run's time"
        )),
        "{summary}"
    );
}
