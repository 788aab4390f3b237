//! Where a stopped run picks up (`nanopush assemble --resume JOURNAL`, on
//! the simulated rig or a hardware one): its journal reopened for
//! appending, the run spec it started with, the pushes it made, where the
//! tip last went, whether it follows the tip's drift, and how often it was
//! resumed before. A run that finished, or stopped for its calibration, is
//! refused before its journal is touched.

use super::assemble::AssemblySettings;
use super::events::{RunEvent, RunSpec};
use super::journal::{Entry, JournalError, JournalWriter, read_journal};
use super::report::count_journal;
use super::stop_cause::{StopCause, instead_of_resuming_for_calibration};
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
    /// The run does not follow the tip's drift ([`drift_off`]).
    pub drift_off: bool,
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
    /// The run stopped because its calibration does not fit: its sites
    /// were placed through it (the journal is left as it is).
    #[error("{path}: the run stopped at {t_s:.1} s for its calibration: {reason}; {instead}")]
    CalibrationUnfit {
        /// The journal.
        path: String,
        /// When it stopped, rig seconds.
        t_s: f64,
        /// The stop's reason, as journalled.
        reason: String,
        /// What to do instead ([`instead_of_resuming_for_calibration`]).
        instead: String,
    },
}

impl ResumePoint {
    /// Reads the journal at `path` and reopens it, unless its run finished
    /// or last stopped for its calibration (then the file is not touched).
    pub fn read(path: &Path) -> Result<Self, ResumeError> {
        let entries = read_journal::<RunEvent>(path)?.entries;
        if let Some(done) = entries.iter().find(|e| e.event == RunEvent::Done) {
            return Err(ResumeError::Finished {
                path: path.display().to_string(),
                t_s: done.t_s,
            });
        }
        if let Some(refused) = stopped_for_calibration(path, &entries) {
            return Err(refused);
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
        let drift_off = drift_off(&contents.entries);
        Ok(Self {
            journal,
            spec,
            pushes_done,
            last_tip_m,
            left_short_sites,
            resumes,
            last_t_s,
            drift_off,
        })
    }

    /// Whether a resume of it told `drift_follow` (`--resume
    /// --drift-follow`) leaves the drift unfollowed: as the run has it
    /// ([`drift_off`]), unless told.
    pub fn drift_off_unless(&self, drift_follow: bool) -> bool {
        self.drift_off && !drift_follow
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

/// Whether the run whose journal holds `entries` does not follow the tip's
/// drift: its run spec's `drift_off` (`--no-drift-follow`), unless a resume
/// since followed it (`--resume --drift-follow`, journalled in its resume
/// entry), after which every resume does. What a resume runs with and what
/// a stop advises, on the simulated rig and a hardware one alike (a later
/// resume without the flag had gone back to not following it).
pub fn drift_off(entries: &[Entry<RunEvent>]) -> bool {
    let started_off = matches!(
        entries.first().map(|e| &e.event),
        Some(RunEvent::Start(spec)) if spec.drift_off
    );
    let followed_since = entries
        .iter()
        .any(|e| matches!(e.event, RunEvent::Resume { drift_follow: true }));
    started_off && !followed_since
}

/// [`ResumeError::CalibrationUnfit`] when the run's last stop was for its
/// calibration (by the journalled cause, or an older journal's wording):
/// its sites were placed through a calibration the run found wrong.
fn stopped_for_calibration(path: &Path, entries: &[Entry<RunEvent>]) -> Option<ResumeError> {
    let (t_s, reason, cause) = entries.iter().rev().find_map(|e| match &e.event {
        RunEvent::Stopped { reason, cause } => Some((e.t_s, reason, *cause)),
        _ => None,
    })?;
    let rig = match entries.first().map(|e| &e.event) {
        Some(RunEvent::Start(RunSpec {
            rig: Some(frame), ..
        })) => {
            format!(" --rig {}", frame.rig_file)
        }
        _ => String::new(),
    };
    (StopCause::journalled(cause, reason) == StopCause::CalibrationUnfit).then(|| {
        ResumeError::CalibrationUnfit {
            path: path.display().to_string(),
            t_s,
            reason: reason.clone(),
            instead: instead_of_resuming_for_calibration(&rig),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::events::RigFrame;
    use std::io::Write;
    use std::path::PathBuf;

    /// A journal in `dir` holding a run spec (on the rig `rig.toml`,
    /// `drift_off` as given) and then `events`.
    fn journal(dir: &tempfile::TempDir, drift_off: bool, events: &[RunEvent]) -> PathBuf {
        let path = dir.path().join("journal.jsonl");
        let mut w = JournalWriter::create(&path).unwrap();
        let spec = RunSpec {
            pattern: "I".into(),
            scene: "scene.toml".into(),
            layout: None,
            seed: None,
            sites_um: vec![[10.0, 20.0]],
            radius_um: 5.0,
            rig: Some(RigFrame {
                rig_file: "rig.toml".into(),
                field_um: [100.0, 100.0],
                coarse_shift_um: None,
                first_view_coarse_um: None,
            }),
            drift_off,
            keep_clear_um: 0.0,
            command: None,
            scene_crc32: None,
        };
        w.append(0.0, &RunEvent::Start(spec)).unwrap();
        for (i, e) in events.iter().enumerate() {
            w.append(1.0 + i as f64, e).unwrap();
        }
        path
    }

    fn stopped(reason: &str, cause: Option<StopCause>) -> RunEvent {
        RunEvent::Stopped {
            reason: reason.into(),
            cause,
        }
    }

    /// A run started with --no-drift-follow and resumed with
    /// --drift-follow goes on following the drift at its next resume,
    /// told nothing: the resume entry keeps the choice. A plain resume (as
    /// older journals hold) keeps the run's own.
    #[test]
    fn a_resume_that_follows_the_drift_is_kept_by_the_next() {
        let dir = tempfile::tempdir().unwrap();
        let path = journal(&dir, true, &[stopped("lost contact", None)]);
        let point = ResumePoint::read(&path).unwrap();
        assert!(point.drift_off);
        assert!(point.drift_off_unless(false));
        assert!(!point.drift_off_unless(true));
        // What Assembly::resume journals when told --drift-follow.
        let mut w = point.journal;
        w.append(9.0, &RunEvent::Resume { drift_follow: true })
            .unwrap();
        w.append(10.0, &stopped("interrupted", Some(StopCause::Other)))
            .unwrap();
        let again = ResumePoint::read(&path).unwrap();
        assert!(
            !again.drift_off,
            "the next resume went back to not following"
        );
        assert!(!again.drift_off_unless(false));
        let plain = tempfile::tempdir().unwrap();
        let path = journal(
            &plain,
            true,
            &[
                stopped("x", None),
                RunEvent::Resume {
                    drift_follow: false,
                },
                stopped("y", None),
            ],
        );
        assert!(ResumePoint::read(&path).unwrap().drift_off);
        let followed = tempfile::tempdir().unwrap();
        let path = journal(&followed, false, &[stopped("x", None)]);
        assert!(!ResumePoint::read(&path).unwrap().drift_off);
    }

    /// A run whose last stop was for its calibration is refused, naming the
    /// stop and what to do instead, its journal byte for byte as it was
    /// (a torn last line not cut off); an older journal's stop is known by
    /// its wording, a journalled cause by the cause alone.
    #[test]
    fn a_run_stopped_for_its_calibration_is_refused_untouched() {
        let why = "the camera sees the probe's apex at (1.00, 2.00) um, 20.0 um from where the stage has it \
                   (21.00, 2.00) um: the calibration does not fit this camera and stage (another rig's)";
        for cause in [Some(StopCause::CalibrationUnfit), None] {
            let dir = tempfile::tempdir().unwrap();
            let path = journal(&dir, false, &[stopped(why, cause)]);
            let mut f = std::fs::OpenOptions::new()
                .append(true)
                .open(&path)
                .unwrap();
            write!(f, "{{\"seq\":2,\"t_s\":3.0,\"ev").unwrap();
            drop(f);
            let before = std::fs::read(&path).unwrap();
            let Err(e) = ResumePoint::read(&path) else {
                panic!("{cause:?}: resumed");
            };
            let said = e.to_string();
            assert!(matches!(e, ResumeError::CalibrationUnfit { .. }), "{said}");
            assert!(
                said.contains("the run stopped at 1.0 s for its calibration: the camera sees"),
                "{said}"
            );
            assert!(
                said.ends_with(
                    "not to be resumed: make the calibration again (nanopush rig calibrate --rig rig.toml), \
                     then start a new run in another --out"
                ),
                "{said}"
            );
            assert_eq!(std::fs::read(&path).unwrap(), before, "{cause:?}");
        }
        // The cause journalled says another stop: resumed, whatever the words.
        let dir = tempfile::tempdir().unwrap();
        let path = journal(&dir, false, &[stopped(why, Some(StopCause::Other))]);
        assert!(ResumePoint::read(&path).is_ok());
        // Resumed since, and stopped for something else: the last stop stands.
        let dir = tempfile::tempdir().unwrap();
        let path = journal(
            &dir,
            false,
            &[
                stopped("3 stage faults in a row", Some(StopCause::Other)),
                RunEvent::Resume {
                    drift_follow: false,
                },
                stopped("reworded", Some(StopCause::CalibrationUnfit)),
            ],
        );
        assert!(matches!(
            ResumePoint::read(&path),
            Err(ResumeError::CalibrationUnfit { .. })
        ));
    }
}
