//! A HardwareRig made of the GCS controller simulator (over loopback TCP) and
//! a watched-folder camera fed with frames of the simulated microscope: moves
//! through the `Rig` trait reach the simulator, diagonal moves are straight
//! lines, Ctrl-C and halt stop the stage, a missing coarse stage is a typed
//! error, and dry runs send nothing.

use nanopush::render::microscope::{RenderSettings, SceneView, TipView, render_frame};
use nanopush::rig::camera::Camera;
use nanopush::rig::camera_error::CameraError;
use nanopush::rig::gcs::{SimConfig, SimServer};
use nanopush::rig::hardware::{HardwareRig, HardwareRigError, HardwareRigOptions};
use nanopush::rig::stage::{CoarseStage, NanoStage};
use nanopush::rig::{Rig, RigError};
use nanopush::vision::frame_input::save_png;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

const UM: f64 = 1e-6;

struct Bench {
    sim: SimServer,
    _dir: tempfile::TempDir,
    rig_path: PathBuf,
    frames: PathBuf,
    interrupt: Arc<AtomicBool>,
}

/// The shipped XYZ simulator rig file, pointed at a fresh simulator and a
/// temporary frame folder.
fn bench(camera_toml: Option<&str>) -> Bench {
    let mut sim = SimServer::new(SimConfig::default());
    let addr = sim.serve_tcp("127.0.0.1:0").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    let calib = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/camera-stage-sim.toml");
    let mut text = std::fs::read_to_string("calib/rig-gcs-sim-xyz.toml")
        .unwrap()
        .replace("127.0.0.1:50000", &addr.to_string())
        .replace(
            "\"camera-stage-sim.toml\"",
            &format!("{:?}", calib.display().to_string()),
        )
        .replace(
            "\"../out/rig-gcs-sim/frames\"",
            &format!("{:?}", frames.display().to_string()),
        )
        .replace("timeout_ms = 5000", "timeout_ms = 2000");
    if let Some(camera) = camera_toml {
        let start = text.find("[camera]").unwrap();
        text.truncate(start);
        text.push_str(camera);
    }
    let rig_path = dir.path().join("rig.toml");
    std::fs::write(&rig_path, text).unwrap();
    Bench {
        sim,
        _dir: dir,
        rig_path,
        frames,
        interrupt: Arc::new(AtomicBool::new(false)),
    }
}

fn open(b: &Bench) -> HardwareRig {
    HardwareRig::open(
        &b.rig_path,
        HardwareRigOptions {
            interrupt: Some(Arc::clone(&b.interrupt)),
            ..Default::default()
        },
    )
    .unwrap()
}

/// Simulator axis positions, micrometres.
fn sim_um(sim: &SimServer) -> [f64; 3] {
    sim.inspect(|c, now| [0, 1, 2].map(|i| c.position(i, now).unwrap()))
}

#[test]
fn moves_through_the_rig_trait_reach_the_simulator() {
    let b = bench(None);
    let mut rig = open(&b);
    let range = rig.range();
    assert!((range[0].min_m - 2.0 * UM).abs() < 1e-12, "soft limit wins");
    assert!(
        (range[2].max_m - 15.0 * UM).abs() < 1e-12,
        "controller travel"
    );

    NanoStage::move_to(&mut rig, [40.0 * UM, 60.0 * UM, 12.0 * UM], 150.0 * UM).unwrap();
    let at = sim_um(&b.sim);
    assert!(
        (at[0] - 40.0).abs() < 1e-9 && (at[1] - 60.0).abs() < 1e-9 && (at[2] - 12.0).abs() < 1e-9,
        "{at:?}"
    );
    let p = NanoStage::position(&mut rig).unwrap();
    assert!((p[0] - 40.0 * UM).abs() < 1e-12 && (p[2] - 12.0 * UM).abs() < 1e-12);
    assert!(!b.sim.inspect(|c, now| c.any_moving(now)));

    // A diagonal move is a straight line: axis velocities share the speed
    // in proportion to each axis's displacement (30 and 40 um of a 50 um move).
    NanoStage::move_to(
        &mut rig,
        [70.0 * UM, 100.0 * UM - 80.0 * UM, 12.0 * UM],
        100.0 * UM,
    )
    .unwrap();
    let vel = rig
        .nanostage()
        .gcs()
        .controller()
        .velocity(&["1", "2"])
        .unwrap();
    assert!(
        (vel[0] - 60.0).abs() < 1e-6 && (vel[1] - 80.0).abs() < 1e-6,
        "{vel:?}"
    );
}

#[test]
fn refused_moves_leave_the_simulator_where_it_was() {
    let b = bench(None);
    let mut rig = open(&b);
    let before = sim_um(&b.sim);
    let err =
        NanoStage::move_to(&mut rig, [99.0 * UM, 50.0 * UM, 7.5 * UM], 50.0 * UM).unwrap_err();
    assert!(
        matches!(err, RigError::OutOfRange { axis: 'x', .. }),
        "{err}"
    );
    let err = NanoStage::move_to(&mut rig, [50.0 * UM, 50.0 * UM, 7.5 * UM], 1.0).unwrap_err();
    assert!(matches!(err, RigError::BadSpeed { .. }), "{err}");
    let err = NanoStage::move_to(&mut rig, [f64::NAN, 50.0 * UM, 7.5 * UM], 50.0 * UM).unwrap_err();
    assert!(matches!(err, RigError::OutOfRange { .. }), "{err}");
    assert_eq!(sim_um(&b.sim), before);
}

#[test]
fn ctrl_c_during_a_move_halts_the_simulator() {
    let b = bench(None);
    let mut rig = open(&b);
    NanoStage::move_to(&mut rig, [10.0 * UM, 50.0 * UM, 7.5 * UM], 200.0 * UM).unwrap();
    let flag = Arc::clone(&b.interrupt);
    let raiser = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(150));
        flag.store(true, Ordering::SeqCst);
    });
    // 80 um at 20 um/s: 4 s, interrupted after about 0.15 s.
    let err =
        NanoStage::move_to(&mut rig, [90.0 * UM, 50.0 * UM, 7.5 * UM], 20.0 * UM).unwrap_err();
    raiser.join().unwrap();
    assert!(matches!(err, RigError::Interrupted), "{err}");
    assert!(err.to_string().contains("interrupted"), "{err}");
    assert!(!b.sim.inspect(|c, now| c.any_moving(now)), "still moving");
    let x = sim_um(&b.sim)[0];
    assert!(x > 10.0 && x < 90.0, "halted mid-way, at {x} um");
    // Moves stay refused while the flag is up.
    assert!(NanoStage::move_to(&mut rig, [50.0 * UM, 50.0 * UM, 7.5 * UM], 20.0 * UM).is_err());
}

#[test]
fn halt_works_and_a_missing_coarse_stage_is_a_typed_error() {
    let b = bench(None);
    let mut rig = open(&b);
    rig.halt().unwrap();
    assert!(matches!(
        CoarseStage::move_coarse(&mut rig, [1e-3, 0.0]),
        Err(RigError::NoCoarseStage)
    ));
    assert!(matches!(
        CoarseStage::coarse_position(&mut rig),
        Err(RigError::NoCoarseStage)
    ));
}

#[test]
fn the_camera_sees_the_frames_the_simulated_microscope_writes() {
    let b = bench(None);
    let mut rig = open(&b);
    NanoStage::move_to(&mut rig, [30.0 * UM, 70.0 * UM, 7.5 * UM], 200.0 * UM).unwrap();
    // A writer playing the camera software: draws the tip where the
    // simulator's stage is, through the rig's calibration, into the folder.
    let p = NanoStage::position(&mut rig).unwrap();
    let [ax, ay] = rig.calibration().stage_to_pixel(p[0], p[1]).unwrap();
    assert!(
        (ax - 80.0).abs() < 1e-6 && (ay - 160.0).abs() < 1e-6,
        "{ax} {ay}"
    );
    let scene = SceneView {
        width_px: 240,
        height_px: 240,
        particles: vec![],
        tip: Some(TipView {
            apex_x_px: ax,
            apex_y_px: ay,
            angle_rad: 1.0,
        }),
    };
    let frame = render_frame(&scene, &RenderSettings::with_snr(30.0, 12), 7).unwrap();
    // A file's time comes from the kernel's coarse clock, up to a tick
    // behind the precise one: a frame written within a tick of the stage
    // settling can carry an earlier time, and the rig rightly discards it
    // as exposed before the stage came to rest (this test once failed so
    // in CI). A camera program writes later frames; this one writes one.
    std::thread::sleep(Duration::from_millis(30));
    let before = rig.now_s();
    save_png(&frame, &b.frames.join("frame_000001.png")).unwrap();
    let timed = rig.grab().unwrap().expect("the written frame");
    assert_eq!(timed.frame.width(), 240);
    let same = timed
        .frame
        .pixels()
        .iter()
        .zip(frame.pixels())
        .all(|(a, b)| (a - b.round().clamp(0.0, 65535.0)).abs() < 1e-3);
    assert!(same, "the grabbed frame is not the written one");
    assert!(timed.t_s >= before - 0.05 && timed.t_s <= rig.now_s());
}

#[test]
fn dry_run_logs_moves_and_needs_no_controller() {
    let b = bench(None);
    let text = std::fs::read_to_string(&b.rig_path)
        .unwrap()
        .replace(&b.sim.tcp_addr().unwrap().to_string(), "192.0.2.1:50000")
        .replace(
            "real_hardware = false",
            "real_hardware = true\nz_surface_um = 0.0\nz_lifts = \"increasing\"",
        );
    std::fs::write(&b.rig_path, text).unwrap();
    let mut rig = HardwareRig::open(
        &b.rig_path,
        HardwareRigOptions {
            dry_run: true,
            interrupt: Some(Arc::clone(&b.interrupt)),
            ..Default::default()
        },
    )
    .unwrap();
    NanoStage::move_to(&mut rig, [52.0 * UM, 50.0 * UM, 7.5 * UM], 100.0 * UM).unwrap();
    let sent: Vec<String> = rig
        .sent_log()
        .unwrap()
        .lock()
        .unwrap()
        .iter()
        .map(|b| String::from_utf8_lossy(b).into_owned())
        .collect();
    assert!(
        sent.contains(&"MOV 1 52 2 50 3 7.5\n".to_string()),
        "{sent:?}"
    );
    assert!(sent.contains(&"VEL 1 100\n".to_string()), "{sent:?}");
}

#[test]
fn open_names_what_is_wrong() {
    // A camera kind that needs a world, without a camera given.
    let b = bench(Some("[camera]\nkind = \"simulated\"\n"));
    let err = HardwareRig::open(
        &b.rig_path,
        HardwareRigOptions {
            interrupt: Some(Arc::clone(&b.interrupt)),
            ..Default::default()
        },
    )
    .err()
    .unwrap();
    assert!(
        matches!(
            err,
            HardwareRigError::Camera(CameraError::SimulatedNeedsWorld)
        ),
        "{err}"
    );
    // A missing calibration file.
    let text = std::fs::read_to_string(&b.rig_path)
        .unwrap()
        .replace("camera-stage-sim.toml", "no-such-calibration.toml");
    std::fs::write(&b.rig_path, text).unwrap();
    let err = HardwareRig::open(&b.rig_path, HardwareRigOptions::default())
        .err()
        .unwrap();
    assert!(matches!(err, HardwareRigError::Calibration { .. }), "{err}");
    // The simulated microscope needs a world no rig file has: the message
    // speaks of the rig file, not of the library's API.
    let b = bench(Some("[camera]\nkind = \"simulated\"\n"));
    let err = HardwareRig::open(&b.rig_path, HardwareRigOptions::default())
        .err()
        .unwrap();
    let said = err.to_string();
    assert!(
        said.contains("kind = \"folder\"") && !said.contains("HardwareRig::open"),
        "{said}"
    );
    // A watched folder that does not exist.
    let b = bench(Some(
        "[camera]\nkind = \"folder\"\npath = \"/nonexistent/frames\"\n",
    ));
    let err = HardwareRig::open(&b.rig_path, HardwareRigOptions::default())
        .err()
        .unwrap();
    assert!(
        matches!(err, HardwareRigError::Camera(CameraError::Folder { .. })),
        "{err}"
    );
}

/// The XYZ bench plus a coarse-stage controller simulator (25 mm axes in
/// mm, at 12.5 mm) in the rig file's `[coarse]` section; x carries the
/// sample (sign -1), y the nanostage (sign +1).
fn coarse_bench() -> (Bench, SimServer) {
    let b = bench(None);
    let mut coarse = SimServer::new(SimConfig::coarse());
    let addr = coarse.serve_tcp("127.0.0.1:0").unwrap();
    let mut text = std::fs::read_to_string(&b.rig_path).unwrap();
    text.push_str(&format!(
        "\n[coarse]\nsign = [-1, 1]\n\n[coarse.stage]\ndriver = \"gcs\"\nlink = \"tcp\"\n\
         address = \"{addr}\"\naxes = [\"1\", \"2\"]\nunit_um = 1000.0\nreal_hardware = false\n\n\
         [coarse.safety]\nsoft_min_um = [1000.0, 1000.0]\nsoft_max_um = [24000.0, 24000.0]\n\
         max_step_um = 1000.0\ntop_speed_um_s = 2000.0\n"
    ));
    std::fs::write(&b.rig_path, text).unwrap();
    (b, coarse)
}

/// Coarse simulator axis positions, mm.
fn coarse_mm(sim: &SimServer) -> [f64; 2] {
    sim.inspect(|c, now| [0, 1].map(|i| c.position(i, now).unwrap()))
}

#[test]
fn the_coarse_stage_moves_by_its_sign_and_unit_only_with_the_tip_retracted() {
    let (b, coarse) = coarse_bench();
    let mut rig = open(&b);
    assert!(rig.has_coarse());
    assert_eq!(CoarseStage::coarse_position(&mut rig).unwrap(), [0.0, 0.0]);

    // The tip starts mid-travel (z = 7.5 um): a coarse move would drag it.
    let err = CoarseStage::move_coarse(&mut rig, [10.0 * UM, -20.0 * UM]).unwrap_err();
    assert!(err.to_string().contains("not retracted"), "{err}");
    assert_eq!(coarse_mm(&coarse), [12.5, 12.5]);

    NanoStage::move_to(&mut rig, [50.0 * UM, 50.0 * UM, 15.0 * UM], 200.0 * UM).unwrap();
    CoarseStage::move_coarse(&mut rig, [10.0 * UM, -20.0 * UM]).unwrap();
    // x carries the sample: the nanostage's origin +10 um on it is the
    // axis at -10 um; y carries the nanostage: -20 um is -20 um.
    let at = coarse_mm(&coarse);
    assert!(
        (at[0] - 12.49).abs() < 1e-9 && (at[1] - 12.48).abs() < 1e-9,
        "{at:?}"
    );
    let offset = CoarseStage::coarse_position(&mut rig).unwrap();
    assert!(
        (offset[0] - 10.0 * UM).abs() < 1e-12 && (offset[1] + 20.0 * UM).abs() < 1e-12,
        "{offset:?}"
    );

    // A new sample frame moves no axis; later moves are in it.
    rig.reframe_sample([0.0, 0.0]).unwrap();
    assert_eq!(coarse_mm(&coarse), at);
    let offset = CoarseStage::coarse_position(&mut rig).unwrap();
    assert!(offset.iter().all(|o| o.abs() < 1e-12), "{offset:?}");
    CoarseStage::move_coarse(&mut rig, [5.0 * UM, 0.0]).unwrap();
    assert!((coarse_mm(&coarse)[0] - 12.485).abs() < 1e-9);

    // Too long a step and a target beyond the soft limits are refused
    // before anything moves.
    let before = coarse_mm(&coarse);
    let err = CoarseStage::move_coarse(&mut rig, [0.0, 2000.0 * UM]).unwrap_err();
    assert!(matches!(err, RigError::StepTooLarge { .. }), "{err}");
    let err = CoarseStage::move_coarse(&mut rig, [12_000.0 * UM, 0.0]).unwrap_err();
    assert!(
        matches!(err, RigError::OutOfRange { axis: 'x', .. }),
        "{err}"
    );
    assert_eq!(coarse_mm(&coarse), before);
    rig.halt().unwrap();
}

#[test]
fn ctrl_c_during_a_coarse_move_halts_the_coarse_simulator() {
    let (b, coarse) = coarse_bench();
    let mut rig = open(&b);
    NanoStage::move_to(&mut rig, [50.0 * UM, 50.0 * UM, 15.0 * UM], 200.0 * UM).unwrap();
    let flag = Arc::clone(&b.interrupt);
    let raiser = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(150));
        flag.store(true, Ordering::SeqCst);
    });
    // 900 um at the 2 mm/s top speed: 0.45 s, interrupted after about 0.15 s.
    let err = CoarseStage::move_coarse(&mut rig, [0.0, 900.0 * UM]).unwrap_err();
    raiser.join().unwrap();
    assert!(err.to_string().contains("interrupted"), "{err}");
    assert!(!coarse.inspect(|c, now| c.any_moving(now)), "still moving");
    let y = coarse_mm(&coarse)[1];
    assert!(y > 12.5 && y < 13.4, "halted mid-way, at {y} mm");
}
