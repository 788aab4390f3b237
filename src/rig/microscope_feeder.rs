//! The simulated microscope playing a camera's acquisition program: a thread
//! that watches the GCS controller simulator, lets its tip push the particles
//! of a [`GcsSimWorld`], and writes what the camera would see into a folder,
//! where a watched-folder camera ([`FolderCamera`](super::camera_folder::FolderCamera))
//! picks the frames up. With it, a rig file naming the controller simulator
//! and that folder rehearses a whole session with no hardware.
//!
//! Like a camera, it exposes frames only with the stage at rest (while the
//! stage moves it just follows the motions). Each frame is written under a
//! hidden temporary name, stamped with its exposure time as modification
//! time (the folder camera's frame time, so a frame exposed before a move
//! ended is recognisably older than the move), and renamed into place; only
//! the newest `keep_frames` are kept on disk.
//!
//! With a second simulated controller as the coarse stage, the sample (the
//! world) moves under the probe and the camera by the coarse offset, as on
//! the simulated rig: frames show the world shifted by it, and are exposed
//! only with both controllers at rest.

use super::camera_source::CameraSource;
use super::gcs::{CoarseAxes, GcsSimWorld, RigFile, SimHandle, TipAxes};
use super::sim::build::{centring_offset, world_for};
use super::sim::model_physics::ModelPhysics;
use super::sim::rig::SimCameraConfig;
use crate::calib::camera_map::CameraCalibration;
use crate::model::Scene;
use crate::plan::Layout;
use crate::render::microscope::{RenderSettings, render_frame};
use crate::vision::frame_input::{hidden_sibling, save_png};
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

/// What the simulated microscope writes, and where.
#[derive(Debug, Clone)]
pub struct FeederSettings {
    /// The watched folder (must exist).
    pub folder: PathBuf,
    /// Frame size, pixel -> stage calibration, optics and noise.
    pub camera: SimCameraConfig,
    /// Shortest time between two frames (the camera's frame period).
    pub interval: Duration,
    /// Frames kept on disk; older ones are deleted.
    pub keep_frames: usize,
    /// Seed of the camera noise. Frames of the same stage state (the same
    /// number of motions applied) get the same noise, so that which frame a
    /// reader happens to grab does not change what it sees: a rehearsal on
    /// the simulated microscope repeats.
    pub seed: u64,
}

/// Why the simulated microscope stopped.
#[derive(Debug, thiserror::Error)]
pub enum FeederError {
    /// The world could not be drawn (a calibration that cannot be inverted, a bad setting).
    #[error("simulated microscope: cannot draw the frame: {0}")]
    Render(String),
    /// A frame could not be written.
    #[error("simulated microscope: writing {path}: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The rig file or the controller does not suit the simulated microscope.
    #[error("simulated microscope: {0}")]
    Setup(String),
    /// The thread panicked.
    #[error("simulated microscope: the feeder thread panicked")]
    Panicked,
}

/// How often the feeder looks at the controller while the stage moves.
const POLL: Duration = Duration::from_millis(2);

/// The running simulated microscope; dropping it stops the thread.
pub struct MicroscopeFeeder {
    stop: Arc<AtomicBool>,
    world: Arc<Mutex<GcsSimWorld>>,
    frames: Arc<AtomicUsize>,
    thread: Option<JoinHandle<Result<(), FeederError>>>,
}

impl MicroscopeFeeder {
    /// Starts recording the controllers' motions (the nanostage's, and the
    /// coarse stage's if there is one) and writing frames.
    pub fn start(
        controller: SimHandle,
        coarse: Option<SimHandle>,
        world: GcsSimWorld,
        settings: FeederSettings,
    ) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let world = Arc::new(Mutex::new(world));
        let frames = Arc::new(AtomicUsize::new(0));
        with_both(&controller, coarse.as_ref(), |c, k, now| {
            c.record_motions(now);
            if let Some(k) = k {
                k.record_motions(now);
            }
        });
        let thread = {
            let (stop, world, frames) =
                (Arc::clone(&stop), Arc::clone(&world), Arc::clone(&frames));
            std::thread::spawn(move || {
                feed(
                    &controller,
                    coarse.as_ref(),
                    &world,
                    &settings,
                    &stop,
                    &frames,
                )
            })
        };
        Self {
            stop,
            world,
            frames,
            thread: Some(thread),
        }
    }

    /// The simulated microscope a rig file asks for: frames into its watched
    /// folder (created if missing), drawn through its calibration, of a
    /// frame size that shows the controller's whole x-y travel; the world of
    /// `layout` with the physics of `scene`, pushed by the controller's axes
    /// the rig file names (x, y, z: all three are needed).
    ///
    /// With `coarse` (the controller playing the rig file's `[coarse]`
    /// stage), the coarse stage moves the world as the rig file's `sign`
    /// says, and the world starts where the simulated rig puts it: the
    /// nanostage's range centred on the layout's field
    /// ([`centring_offset`]).
    pub fn for_rig_file(
        controller: SimHandle,
        coarse: Option<SimHandle>,
        rig: &RigFile,
        scene: &Scene,
        layout: &Layout,
        seed: u64,
        interval: Duration,
    ) -> Result<Self, FeederError> {
        let CameraSource::Folder { path: folder, .. } = &rig.camera else {
            return Err(FeederError::Setup(
                "the rig file's camera is not a watched folder (kind = \"folder\")".to_owned(),
            ));
        };
        std::fs::create_dir_all(folder).map_err(|e| FeederError::Write {
            path: folder.clone(),
            message: e.to_string(),
        })?;
        let calibration = CameraCalibration::load(&rig.calibration).map_err(|e| {
            FeederError::Setup(format!("calibration {}: {e}", rig.calibration.display()))
        })?;
        let config = controller.with(|c, _| c.config().clone());
        let index = |name: &str| {
            config
                .axes
                .iter()
                .position(|a| a.name == name)
                .ok_or_else(|| FeederError::Setup(format!("the controller has no axis {name:?}")))
        };
        let [x, y, z] = match rig.stage.axes.as_slice() {
            [x, y, z] => [index(x)?, index(y)?, index(z)?],
            other => {
                return Err(FeederError::Setup(format!(
                    "the simulated world needs the probe height: the rig file names {}, not 3 (x, y, z)",
                    crate::wording::counted(other.len(), "axis")
                )));
            }
        };
        let unit_m = rig.stage.unit_um * 1e-6;
        let (width_px, height_px) =
            frame_covering(&calibration, &config.axes[x], &config.axes[y], unit_m)?;
        let camera = SimCameraConfig {
            width_px,
            height_px,
            calibration,
            render: RenderSettings::with_snr(30.0, 16),
            tip_angle_rad: 60f64.to_radians(),
            frame_time_s: interval.as_secs_f64(),
        };
        let mut world = GcsSimWorld::new(
            world_for(scene, layout),
            Box::new(ModelPhysics::new(scene.clone())),
            TipAxes {
                xyz: [x, y, z],
                unit_m,
            },
            Instant::now(),
        );
        if let Some(handle) = &coarse {
            let travel = |a: &super::gcs::SimAxisConfig| (a.max - a.min) * unit_m;
            let range_m = [travel(&config.axes[x]), travel(&config.axes[y])];
            world = world.with_coarse(coarse_axes(
                handle,
                rig,
                centring_offset(layout.field_m, range_m),
            )?);
        }
        Ok(Self::start(
            controller,
            coarse,
            world,
            FeederSettings {
                folder: folder.clone(),
                camera,
                interval,
                keep_frames: 8,
                seed,
            },
        ))
    }

    /// The world as it is now (ground truth for tests and reports).
    pub fn world(&self) -> MutexGuard<'_, GcsSimWorld> {
        self.world.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Frames written so far.
    pub fn frames_written(&self) -> usize {
        self.frames.load(Ordering::SeqCst)
    }

    /// True while the thread runs (it ends on the first error).
    pub fn is_running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// Stops the thread and says why it had stopped, if it had failed.
    pub fn stop(mut self) -> Result<usize, FeederError> {
        self.join()?;
        Ok(self.frames_written())
    }

    fn join(&mut self) -> Result<(), FeederError> {
        self.stop.store(true, Ordering::SeqCst);
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| FeederError::Panicked)?,
            None => Ok(()),
        }
    }
}

impl Drop for MicroscopeFeeder {
    fn drop(&mut self) {
        if let Err(e) = self.join() {
            tracing::warn!("{e}");
        }
    }
}

/// The coarse controller's axes as the rig file's `[coarse]` section names
/// them, with the zero that puts the nanostage's origin at `offset_m` on the
/// sample where the coarse controller stands now.
fn coarse_axes(
    handle: &SimHandle,
    rig: &RigFile,
    offset_m: [f64; 2],
) -> Result<CoarseAxes, FeederError> {
    let Some(section) = &rig.coarse else {
        return Err(FeederError::Setup(
            "a coarse controller was given but the rig file has no [coarse] section".to_owned(),
        ));
    };
    let (config, positions) = handle.with(|c, now| {
        let n = c.config().axes.len();
        (
            c.config().clone(),
            (0..n)
                .filter_map(|i| c.position(i, now))
                .collect::<Vec<f64>>(),
        )
    });
    let index = |name: &String| {
        config
            .axes
            .iter()
            .position(|a| &a.name == name)
            .ok_or_else(|| {
                FeederError::Setup(format!("the coarse controller has no axis {name:?}"))
            })
    };
    let [x, y] = match section.stage.axes.as_slice() {
        [x, y] => [index(x)?, index(y)?],
        other => {
            return Err(FeederError::Setup(format!(
                "the coarse stage needs 2 axes, the rig file names {}",
                other.len()
            )));
        }
    };
    let axes = CoarseAxes {
        xy: [x, y],
        unit_m: section.stage.unit_um * 1e-6,
        sign: section.sign_factors(),
        zero_m: [0.0, 0.0],
    };
    Ok(axes.with_offset_at(&positions, offset_m))
}

/// Runs `f` on the nanostage controller and, if there is one, the coarse
/// controller, both held at once so that one instant holds for both.
fn with_both<R>(
    nano: &SimHandle,
    coarse: Option<&SimHandle>,
    f: impl FnOnce(&mut super::gcs::SimController, Option<&mut super::gcs::SimController>, Instant) -> R,
) -> R {
    nano.with(|c, now| match coarse {
        Some(k) => k.with(|k, _| f(c, Some(k), now)),
        None => f(c, None, now),
    })
}

/// Frame size, pixels, that shows the whole x-y travel of the controller
/// through `calibration`, with the margin that lies between pixel 0 and the
/// travel's nearest corner repeated on the far side.
fn frame_covering(
    calibration: &CameraCalibration,
    x: &super::gcs::SimAxisConfig,
    y: &super::gcs::SimAxisConfig,
    unit_m: f64,
) -> Result<(usize, usize), FeederError> {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for (xu, yu) in [
        (x.min, y.min),
        (x.min, y.max),
        (x.max, y.min),
        (x.max, y.max),
    ] {
        let px = calibration
            .stage_to_pixel(xu * unit_m, yu * unit_m)
            .map_err(|e| FeederError::Setup(format!("calibration: {e}")))?;
        for i in 0..2 {
            lo[i] = lo[i].min(px[i]);
            hi[i] = hi[i].max(px[i]);
        }
    }
    let size = |i: usize| (hi[i] + lo[i].max(0.0)).ceil();
    let (w, h) = (size(0), size(1));
    if !(w >= 16.0 && h >= 16.0 && w <= 16384.0 && h <= 16384.0) {
        return Err(FeederError::Setup(format!(
            "a frame showing the travel would be {w} x {h} px: check the calibration"
        )));
    }
    Ok((w as usize, h as usize))
}

fn lock(world: &Mutex<GcsSimWorld>) -> MutexGuard<'_, GcsSimWorld> {
    world.lock().unwrap_or_else(|p| p.into_inner())
}

fn feed(
    controller: &SimHandle,
    coarse: Option<&SimHandle>,
    world: &Mutex<GcsSimWorld>,
    settings: &FeederSettings,
    stop: &AtomicBool,
    frames: &AtomicUsize,
) -> Result<(), FeederError> {
    let mut on_disk: VecDeque<PathBuf> = VecDeque::new();
    let mut n: u64 = 0;
    while !stop.load(Ordering::SeqCst) {
        let started = Instant::now();
        let (nano, coarse_now, moving, exposed, now) =
            with_both(controller, coarse, |c, k, now| {
                let axes = c.config().axes.len();
                let positions: Vec<f64> = (0..axes).filter_map(|i| c.position(i, now)).collect();
                let coarse_now = k.map(|k| {
                    let axes = k.config().axes.len();
                    let positions: Vec<f64> =
                        (0..axes).filter_map(|i| k.position(i, now)).collect();
                    (k.take_motions(), positions, k.any_moving(now))
                });
                let moving = c.any_moving(now) || coarse_now.as_ref().is_some_and(|k| k.2);
                (
                    (c.take_motions(), positions),
                    coarse_now,
                    moving,
                    SystemTime::now(),
                    now,
                )
            });
        let (coarse_motions, coarse_positions) =
            coarse_now.map(|(m, p, _)| (m, p)).unwrap_or_default();
        let (view, state) = {
            let mut w = lock(world);
            w.advance_with_coarse(nano.0, coarse_motions, now);
            let state = w.motions_applied() as u64;
            let view = if moving {
                None
            } else {
                let tip = w.tip_on_sample_m(&nano.1, &coarse_positions);
                let offset = w.coarse_offset_m(&coarse_positions);
                Some(
                    settings
                        .camera
                        .view(&w.world.particles, tip, offset)
                        .map_err(|e| FeederError::Render(e.to_string()))?,
                )
            };
            (view, state)
        };
        let Some(view) = view else {
            std::thread::sleep(POLL);
            continue;
        };
        let seed = settings.seed ^ state.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let frame = render_frame(&view, &settings.camera.render, seed)
            .map_err(|e| FeederError::Render(e.to_string()))?;
        n += 1;
        let path = settings.folder.join(format!("frame_{n:08}.png"));
        write_atomically(&frame, &path, exposed)?;
        frames.store(n as usize, Ordering::SeqCst);
        on_disk.push_back(path);
        while on_disk.len() > settings.keep_frames.max(1) {
            if let Some(old) = on_disk.pop_front() {
                // A camera may be reading it; a frame left behind is harmless.
                let _ = std::fs::remove_file(old);
            }
        }
        while started.elapsed() < settings.interval && !stop.load(Ordering::SeqCst) {
            std::thread::sleep(POLL);
        }
    }
    Ok(())
}

/// Writes the frame under a hidden name, stamps its exposure time, renames it.
fn write_atomically(
    frame: &crate::vision::frame::Frame,
    path: &Path,
    exposed: SystemTime,
) -> Result<(), FeederError> {
    let tmp = hidden_sibling(path);
    let fail = |message: String| FeederError::Write {
        path: path.to_path_buf(),
        message,
    };
    save_png(frame, &tmp).map_err(|e| fail(e.to_string()))?;
    std::fs::File::options()
        .write(true)
        .open(&tmp)
        .and_then(|f| f.set_modified(exposed))
        .map_err(|e| fail(format!("stamping the exposure time: {e}")))?;
    std::fs::rename(&tmp, path).map_err(|e| fail(e.to_string()))
}

/// A random layout of `n` particles of the scene's radius for the simulated
/// microscope: uniform in the square `[margin, travel - margin]` of the
/// controller's travel (the planner's field on a rig without a coarse stage
/// starts at 0, so particles stay clear of the range's edges).
pub fn layout_in_travel(
    scene: &Scene,
    n: usize,
    travel_m: [f64; 2],
    margin_m: f64,
    seed: u64,
) -> Result<Layout, crate::plan::synth_layout::SynthError> {
    use crate::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
    let mut layout = synth_layout(&SynthParams {
        n,
        field_m: [travel_m[0] - 2.0 * margin_m, travel_m[1] - 2.0 * margin_m],
        radius_m: scene.particle_radius_m,
        min_gap_m: 1e-6,
        polydisperse: false,
        kind: LayoutKind::Uniform,
        seed,
    })?;
    for p in &mut layout.particles {
        p.centre_m += nalgebra::Vector2::new(margin_m, margin_m);
    }
    layout.field_m = travel_m;
    Ok(layout)
}
