//! Runs the closed loop in-process on the simulated rig and reads back what
//! it did: how the run ended, the ground truth at every site, and the
//! journal's events.
// Each test binary that includes this module uses only part of it.
#![allow(dead_code)]

use nanopush::exec::assemble::{Assembly, AssemblyInputs, RunEnd};
use nanopush::exec::events::RunEvent;
use nanopush::exec::journal::{JournalWriter, read_journal};
use nanopush::exec::sim_run::{SimRunRequest, inputs_for, prepare_sim_run};
use nanopush::rig::Rig;

/// What a run left.
pub struct Outcome {
    pub end: RunEnd,
    /// Ground-truth distance from each site to the nearest particle.
    pub site_errors_m: Vec<f64>,
    /// The journal's events, in order.
    pub events: Vec<RunEvent>,
    /// Rig time at the end.
    pub t_end_s: f64,
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

/// Runs `request` to its end, the loop's inputs changed by `adjust`.
pub fn run_sim(request: &SimRunRequest, adjust: impl FnOnce(&mut AssemblyInputs)) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let mut run = prepare_sim_run(request).unwrap();
    let journal_path = dir.path().join("journal.jsonl");
    let journal = JournalWriter::create(&journal_path).unwrap();
    let mut inputs = inputs_for(
        &run.scene,
        run.sites.clone(),
        &run.rig,
        run.layout.field_m,
        false,
    );
    adjust(&mut inputs);
    let end = Assembly::start(&mut run.rig, inputs, journal, run.spec)
        .unwrap()
        .run()
        .unwrap();
    let world = &run.rig.stage.world.particles;
    let site_errors_m = run
        .sites
        .iter()
        .map(|s| {
            world
                .iter()
                .map(|p| (p.x_m - s.centre_m.x).hypot(p.y_m - s.centre_m.y))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let events = read_journal::<RunEvent>(&journal_path)
        .unwrap()
        .entries
        .into_iter()
        .map(|e| e.event)
        .collect();
    Outcome {
        end,
        site_errors_m,
        events,
        t_end_s: run.rig.now_s(),
    }
}
