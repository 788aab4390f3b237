//! Where a stopped run picks up (`nanopush assemble --resume JOURNAL`, on
//! the simulated rig or a hardware one): its journal reopened for
//! appending, the run spec it started with, the pushes it made, where the
//! tip last went, and how often it was resumed before.

use super::assemble::AssemblySettings;
use super::events::{RunEvent, RunSpec};
use super::journal::{JournalError, JournalWriter, read_journal};
use super::report::count_journal;
use crate::plan::Site;
use crate::plan::pattern::numbered_sites;
use std::path::Path;

/// A stopped run, ready to go on.
pub struct ResumePoint {
    /// The journal, reopened for appending (a torn last line cut off).
    pub journal: JournalWriter,
    /// The run spec of its first entry.
    pub spec: RunSpec,
    /// Pushes made before the stop.
    pub pushes_done: usize,
    /// Where the tip was last sent (nanostage x, y, metres), if anywhere.
    pub last_tip_m: Option<[f64; 2]>,
    /// Sites the run left short (indices into its sites): the particles
    /// near them are left there again (`Assembly::resume`).
    pub left_short_sites: Vec<usize>,
    /// Resumes before this one.
    pub resumes: usize,
    /// The latest rig time in the journal, seconds: where a hardware rig's
    /// clock goes on from.
    pub last_t_s: f64,
}

/// Why a journal cannot be resumed.
#[derive(Debug, thiserror::Error)]
pub enum ResumeError {
    /// The journal could not be read or reopened.
    #[error(transparent)]
    Journal(#[from] JournalError),
    /// The run finished: nothing to resume (the journal is left as it is).
    #[error("{path}: run already finished at {t_s:.1} s; nothing to resume")]
    Finished {
        /// The journal.
        path: String,
        /// When it finished, rig seconds.
        t_s: f64,
    },
    /// The first entry is not a run spec.
    #[error("{0} does not start with a run spec")]
    NoSpec(String),
}

impl ResumePoint {
    /// Reads the journal at `path` and reopens it, unless its run finished
    /// (then the file is not touched).
    pub fn read(path: &Path) -> Result<Self, ResumeError> {
        let finished = read_journal::<RunEvent>(path)?
            .entries
            .iter()
            .find(|e| e.event == RunEvent::Done)
            .map(|e| e.t_s);
        if let Some(t_s) = finished {
            return Err(ResumeError::Finished {
                path: path.display().to_string(),
                t_s,
            });
        }
        let (journal, contents) = JournalWriter::resume::<RunEvent>(path)?;
        let Some(RunEvent::Start(spec)) = contents.entries.first().map(|e| e.event.clone()) else {
            return Err(ResumeError::NoSpec(path.display().to_string()));
        };
        let tolerance_um = AssemblySettings::default().placed_tolerance_m * 1e6;
        let counts = count_journal(&contents.entries, &spec.sites_um, tolerance_um);
        let pushes_done = counts.pushes;
        let left_short_sites = counts.left_short.iter().map(|l| l.site).collect();
        let last_tip_m = contents.entries.iter().rev().find_map(|e| match &e.event {
            RunEvent::Move { target_um, .. } => Some([target_um[0] * 1e-6, target_um[1] * 1e-6]),
            _ => None,
        });
        let resumes = counts.resumes;
        let last_t_s = contents.entries.iter().map(|e| e.t_s).fold(0.0, f64::max);
        Ok(Self {
            journal,
            spec,
            pushes_done,
            last_tip_m,
            left_short_sites,
            resumes,
            last_t_s,
        })
    }

    /// The run's target sites, metres.
    pub fn sites(&self) -> Vec<Site> {
        numbered_sites(
            self.spec
                .sites_um
                .iter()
                .map(|s| nalgebra::Vector2::new(s[0], s[1]) * 1e-6),
        )
    }
}
