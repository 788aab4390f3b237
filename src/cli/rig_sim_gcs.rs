//! `nanopush rig sim-gcs`: a simulated PI GCS 2.0 controller (3 axes,
//! 100 x 100 x 15 um) on a TCP port and optionally a pseudo-terminal, for
//! rehearsing without hardware and for checking clients such as PIPython.
//! With `--microscope RIG_FILE` it also plays the microscope camera: a
//! simulated world of particles that the controller's probe pushes, drawn
//! into the rig file's watched folder (see `rig::microscope_feeder`).
//! With `--coarse-port P` a second simulated controller plays a coarse XY
//! stage (2 axes, 25 x 25 mm, in millimetres) on port P; the simulated
//! microscope then moves its world with it as the rig file's `[coarse]`
//! section says.

use crate::exec::sim_run::layout_for;
use crate::model::Scene;
use crate::plan::Layout;
use crate::rig::gcs::{RigFile, SimAxisConfig, SimConfig, SimServer};
use crate::rig::interrupt;
use crate::rig::microscope_feeder::{MicroscopeFeeder, layout_in_travel};
use anyhow::Context;
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// Arguments of `nanopush rig sim-gcs`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// TCP port to listen on (PI controllers use 50000; 0 picks a free one).
    #[arg(long, default_value_t = 50000)]
    pub port: u16,
    /// Address to bind; keep the loopback default unless you mean to expose it.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Also serve on a pseudo-terminal (stands in for a serial port) and print its path.
    #[arg(long)]
    pub pty: bool,
    /// Also simulate a coarse XY stage controller (2 axes, 25 x 25 mm, in
    /// mm, at the same time scale) on this TCP port (0 picks a free one).
    #[arg(long)]
    pub coarse_port: Option<u16>,
    /// Closed-loop velocity of every axis at start-up, micrometres per second.
    #[arg(long, default_value_t = 100.0)]
    pub velocity_um_s: f64,
    /// Simulated seconds per wall-clock second (e.g. 20 to rehearse slow pushes quickly).
    #[arg(long, default_value_t = 1.0)]
    pub time_scale: f64,
    /// Also play the microscope camera of this rig file: frames of a
    /// simulated world, pushed by this controller's probe, written into the
    /// rig file's watched folder.
    #[arg(long, value_name = "RIG_FILE")]
    pub microscope: Option<PathBuf>,
    /// With --microscope: scene (particle size, pushing physics).
    #[arg(
        long,
        default_value = "calib/paper-ps-ito.toml",
        requires = "microscope"
    )]
    pub scene: PathBuf,
    /// With --microscope: layout of the world (default: random, from --seed:
    /// in the nanostage's travel, or with --coarse-port the simulated rig's
    /// 120 x 100 um field).
    #[arg(long, requires = "microscope")]
    pub layout: Option<PathBuf>,
    /// With --microscope: seed of the random layout and of the camera noise.
    #[arg(long, default_value_t = 1, requires = "microscope")]
    pub seed: u64,
    /// With --microscope: particles in the random layout (not with --layout).
    #[arg(
        long,
        default_value_t = 30,
        requires = "microscope",
        conflicts_with = "layout"
    )]
    pub particles: usize,
    /// With --microscope: shortest time between frames, milliseconds.
    #[arg(long, default_value_t = 50, requires = "microscope")]
    pub frame_interval_ms: u64,
}

/// Clearance of random layouts from the edges of the travel, micrometres.
const LAYOUT_MARGIN_UM: f64 = 10.0;

/// Serves the simulator until Ctrl-C.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.velocity_um_s.is_finite() && args.velocity_um_s > 0.0,
        "--velocity-um-s must be positive, got {}",
        args.velocity_um_s
    );
    anyhow::ensure!(
        args.time_scale.is_finite() && args.time_scale > 0.0,
        "--time-scale must be positive, got {}",
        args.time_scale
    );
    let mut config = SimConfig::default();
    config
        .axes
        .iter_mut()
        .for_each(|a: &mut SimAxisConfig| a.velocity = args.velocity_um_s);
    let stop = interrupt::ctrlc_flag().context("installing the Ctrl-C handler")?;
    // The servers are kept (bound) until the loop below ends.
    let Serving {
        said,
        _server,
        _coarse,
        feeder,
    } = serve(&args, &config).context("the GCS simulator did not start (nothing is served)")?;
    let mut out = std::io::stdout();
    for line in &said {
        writeln!(out, "{line}")?;
    }
    eprintln!("press Ctrl-C to stop");
    out.flush()?;
    while !stop.load(Ordering::SeqCst) && feeder.as_ref().is_none_or(|f| f.is_running()) {
        std::thread::sleep(Duration::from_millis(20));
    }
    stop.store(false, Ordering::SeqCst);
    if let Some(feeder) = feeder {
        // Ground truth a hardware rig cannot give: read before the feeder
        // (which holds the world) stops.
        let truth = ground_truth_line(&feeder.world());
        let frames = feeder.stop()?;
        eprintln!(
            "simulated microscope: {} written; {truth}",
            crate::wording::counted(frames, "frame")
        );
    }
    Ok(())
}

/// What the simulated world saw of the session: the probe's contacts with
/// particles, and the moves that lowered it onto one (0 on a sound run).
fn ground_truth_line(world: &crate::rig::gcs::GcsSimWorld) -> String {
    format!(
        "ground truth: the probe met particles {} and was lowered onto one {}",
        crate::wording::counted(world.contacts().len(), "time"),
        crate::wording::counted(world.landings().len(), "time")
    )
}

/// The simulator(s) and the microscope started, and what to say of them.
struct Serving {
    /// "listening on ..." lines, printed only once everything is up: one
    /// printed first had read as a running simulator when a bad layout or a
    /// port in use then stopped it.
    said: Vec<String>,
    /// The nanostage's controller, served while this lives.
    _server: SimServer,
    /// The coarse stage's, with --coarse-port.
    _coarse: Option<SimServer>,
    /// The simulated microscope, with --microscope.
    feeder: Option<MicroscopeFeeder>,
}

/// Starts everything the arguments ask for, or nothing.
fn serve(args: &Args, config: &SimConfig) -> anyhow::Result<Serving> {
    let mut said = Vec::new();
    let mut server = SimServer::new(config.clone());
    server
        .handle()
        .with(|c, now| c.set_time_scale(args.time_scale, now));
    let addr = server
        .serve_tcp(&format!("{}:{}", args.host, args.port))
        .map_err(|e| bind_error(e, &args.host, args.port, "--port"))?;
    said.push(format!("GCS simulator listening on tcp {addr}"));
    if args.pty {
        let path = server.serve_pty().context("opening a pseudo-terminal")?;
        said.push(format!("GCS simulator serving on pty {}", path.display()));
    }
    let coarse = match args.coarse_port {
        Some(port) => {
            let mut coarse = SimServer::new(SimConfig::coarse());
            coarse
                .handle()
                .with(|c, now| c.set_time_scale(args.time_scale, now));
            let addr = coarse
                .serve_tcp(&format!("{}:{port}", args.host))
                .map_err(|e| bind_error(e, &args.host, port, "--coarse-port"))
                .context("the coarse stage")?;
            said.push(format!(
                "GCS coarse-stage simulator listening on tcp {addr}"
            ));
            Some(coarse)
        }
        None => None,
    };
    let feeder = match &args.microscope {
        Some(rig_path) => {
            let feeder = microscope(args, &server, coarse.as_ref(), config, rig_path)?;
            said.push(format!(
                "simulated microscope writing frames for {}",
                rig_path.display()
            ));
            Some(feeder)
        }
        None => None,
    };
    Ok(Serving {
        said,
        _server: server,
        _coarse: coarse,
        feeder,
    })
}

/// Why `host:port` could not be listened on, with what to do when it is
/// taken (another simulator still running, most often).
fn bind_error(e: std::io::Error, host: &str, port: u16, flag: &str) -> anyhow::Error {
    if e.kind() == std::io::ErrorKind::AddrInUse {
        anyhow::anyhow!(
            "{host}:{port} is in use (another `nanopush rig sim-gcs` still running?): stop that, or give another {flag} (0 picks a free port)"
        )
    } else {
        anyhow::Error::new(e).context(format!("listening on {host}:{port}"))
    }
}

fn microscope(
    args: &Args,
    server: &SimServer,
    coarse: Option<&SimServer>,
    config: &SimConfig,
    rig_path: &std::path::Path,
) -> anyhow::Result<MicroscopeFeeder> {
    let rig = RigFile::load(rig_path)?;
    anyhow::ensure!(
        rig.coarse.is_none() || coarse.is_some(),
        "{} has a [coarse] section: give --coarse-port (its port) so that a simulated coarse stage moves the world",
        rig_path.display()
    );
    let scene =
        Scene::load(&args.scene).with_context(|| format!("scene {}", args.scene.display()))?;
    let layout = match &args.layout {
        Some(path) => Layout::read(path)?,
        None if coarse.is_some() => layout_for(None, &scene, args.seed, args.particles)?,
        None => {
            let travel =
                |i: usize| (config.axes[i].max - config.axes[i].min) * rig.stage.unit_um * 1e-6;
            layout_in_travel(
                &scene,
                args.particles,
                [travel(0), travel(1)],
                LAYOUT_MARGIN_UM * 1e-6,
                args.seed,
            )?
        }
    };
    Ok(MicroscopeFeeder::for_rig_file(
        server.handle(),
        coarse.map(SimServer::handle),
        &rig,
        &scene,
        &layout,
        args.seed,
        Duration::from_millis(args.frame_interval_ms),
    )?)
}
