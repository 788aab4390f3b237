//! Runs the closed loop in-process on the simulated rig and reads back what
//! it did: how the run ended, the ground truth at every site, and the
//! journal's events.
// Each test binary that includes this module uses only part of it.
#![allow(dead_code)]

use nanopush::calib::camera_map::CameraCalibration;
use nanopush::exec::assemble::{Assembly, AssemblyInputs, RunEnd};
use nanopush::exec::calibration_fit::MapSighting;
use nanopush::exec::events::RunEvent;
use nanopush::exec::journal::{JournalWriter, read_journal};
use nanopush::exec::sim_run::{SimRunRequest, inputs_for, prepare_sim_run};
use nanopush::plan::pattern_request::PatternRequest;
use nanopush::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
use nanopush::rig::camera::{Camera, TimedFrame};
use nanopush::rig::sim::rig::SimRig;
use nanopush::rig::sim::stage::TimedLanding;
use nanopush::rig::stage::{AxisRange, CoarseStage, NanoStage, StageXyz};
use nanopush::rig::{Rig, RigError};
use std::path::Path;

/// What a run left.
pub struct Outcome {
    pub end: RunEnd,
    /// Ground-truth distance from each site to the nearest particle.
    pub site_errors_m: Vec<f64>,
    /// The journal's events, in order.
    pub events: Vec<RunEvent>,
    /// Rig time at the end.
    pub t_end_s: f64,
    /// The apex offsets the loop fitted the calibration's map to.
    pub map_sightings: Vec<MapSighting>,
    /// Every move that lowered the tip onto a particle (ground truth).
    pub landings: Vec<TimedLanding>,
}

impl Outcome {
    /// Root-mean-square of the site errors, nanometres.
    pub fn rms_nm(&self) -> f64 {
        let n = self.site_errors_m.len() as f64;
        (self.site_errors_m.iter().map(|e| e * e).sum::<f64>() / n).sqrt() * 1e9
    }

    /// Sites with a particle within `tolerance_m`.
    pub fn filled(&self, tolerance_m: f64) -> usize {
        self.site_errors_m
            .iter()
            .filter(|e| **e <= tolerance_m)
            .count()
    }
}

/// The simulated rig, telling the loop a calibration of its own instead
/// of the camera's (which still renders the frames), each nanostage move
/// made by `mover` (a test watches or fails moves there).
struct Told<'r, M> {
    rig: &'r mut SimRig,
    calibration: CameraCalibration,
    mover: M,
}

impl<M: FnMut(&mut SimRig, StageXyz, f64) -> Result<(), RigError>> NanoStage for Told<'_, M> {
    fn range(&self) -> [AxisRange; 3] {
        self.rig.range()
    }
    fn position(&mut self) -> Result<StageXyz, RigError> {
        self.rig.position()
    }
    fn move_to(&mut self, target: StageXyz, speed: f64) -> Result<(), RigError> {
        (self.mover)(self.rig, target, speed)
    }
    fn halt(&mut self) -> Result<(), RigError> {
        self.rig.halt()
    }
}

impl<M> CoarseStage for Told<'_, M> {
    fn coarse_position(&mut self) -> Result<[f64; 2], RigError> {
        self.rig.coarse_position()
    }
    fn move_coarse(&mut self, target: [f64; 2]) -> Result<(), RigError> {
        self.rig.move_coarse(target)
    }
}

impl<M> Camera for Told<'_, M> {
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        self.rig.grab()
    }
}

impl<M: FnMut(&mut SimRig, StageXyz, f64) -> Result<(), RigError>> Rig for Told<'_, M> {
    fn now_s(&self) -> f64 {
        self.rig.now_s()
    }
    fn calibration(&self) -> &CameraCalibration {
        &self.calibration
    }
}

/// Runs `request` to its end, the loop's inputs changed by `adjust`.
pub fn run_sim(request: &SimRunRequest, adjust: impl FnOnce(&mut AssemblyInputs)) -> Outcome {
    run_sim_told(request, |rig| *rig.calibration(), adjust)
}

/// [`run_sim`], the loop told the calibration `told` makes of the rig
/// (its camera's own calibration, its stage's range).
pub fn run_sim_told(
    request: &SimRunRequest,
    told: impl FnOnce(&mut SimRig) -> CameraCalibration,
    adjust: impl FnOnce(&mut AssemblyInputs),
) -> Outcome {
    run_sim_moved(request, told, adjust, |_| {
        |rig: &mut SimRig, target, speed| rig.move_to(target, speed)
    })
}

/// [`run_sim_told`], each nanostage move made by the mover that `mover`
/// makes for the run's sites (x, y in metres).
pub fn run_sim_moved<M: FnMut(&mut SimRig, StageXyz, f64) -> Result<(), RigError>>(
    request: &SimRunRequest,
    told: impl FnOnce(&mut SimRig) -> CameraCalibration,
    adjust: impl FnOnce(&mut AssemblyInputs),
    mover: impl FnOnce(&[[f64; 2]]) -> M,
) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let mut run = prepare_sim_run(request, None).unwrap();
    let calibration = told(&mut run.rig);
    let journal_path = dir.path().join("journal.jsonl");
    let journal = JournalWriter::create(&journal_path).unwrap();
    let mut inputs = inputs_for(
        &run.scene,
        run.sites.clone(),
        &run.rig,
        run.layout.field_m,
        false,
        run.spec.keep_clear_um * 1e-6,
    );
    adjust(&mut inputs);
    let sites: Vec<[f64; 2]> = run
        .sites
        .iter()
        .map(|s| [s.centre_m.x, s.centre_m.y])
        .collect();
    let mut rig = Told {
        rig: &mut run.rig,
        calibration,
        mover: mover(&sites),
    };
    let mut assembly = Assembly::start(&mut rig, inputs, journal, run.spec).unwrap();
    let end = assembly.run().unwrap();
    let map_sightings = assembly.map_sightings().to_vec();
    drop(assembly);
    drop(rig);
    let world = &run.rig.stage.world.particles;
    let site_errors_m = sites
        .iter()
        .map(|s| {
            world
                .iter()
                .map(|p| (p.x_m - s[0]).hypot(p.y_m - s[1]))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    // Every entry reads back, numbered without gaps (read_journal checks the sequence).
    let contents = read_journal::<RunEvent>(&journal_path).unwrap();
    assert!(!contents.truncated_tail);
    let events = contents.entries.into_iter().map(|e| e.event).collect();
    Outcome {
        end,
        site_errors_m,
        events,
        t_end_s: run.rig.now_s(),
        map_sightings,
        landings: run.rig.stage.landings().to_vec(),
    }
}

/// `synth layout --n N --field-um 120x100 --radius-um R --min-gap-um 1
/// --kind K [--polydisperse] --seed S`: the acceptance scenes' field.
pub fn field_120x100(
    n: usize,
    radius_um: f64,
    kind: LayoutKind,
    polydisperse: bool,
    seed: u64,
) -> SynthParams {
    SynthParams {
        n,
        field_m: [120e-6, 100e-6],
        radius_m: radius_um * 1e-6,
        min_gap_m: 1e-6,
        polydisperse,
        kind,
        seed,
    }
}

/// A request to assemble `text` in the paper scene on the layout `params`
/// make (written in `dir`), the simulated rig seeded as the layout.
pub fn paper_request_on(dir: &Path, text: &str, params: &SynthParams) -> SimRunRequest {
    let layout_path = dir.join("layout.json");
    synth_layout(params).unwrap().write(&layout_path).unwrap();
    SimRunRequest {
        target: Some(PatternRequest::text(text)),
        scene: Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml"),
        layout: Some(layout_path),
        seed: params.seed,
        ..SimRunRequest::default()
    }
}
