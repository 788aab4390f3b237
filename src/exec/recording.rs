//! Recordings: what a run saw, kept so that detection, tracking and planning
//! can be replayed without a rig (`nanopush dry-run`).
//!
//! A recording is a folder:
//!
//! * `recording.toml` (schema `nanopush.recording/1`): where the frames are, the
//!   calibration file, the particle radius, the target (absolute `sites_um`, or a
//!   pattern to place: `pattern_text` or a site-list file `pattern`), and
//!   optionally a stage log, a scene for the model's advice, the field and
//!   the frame interval;
//! * the frames: a folder of images (sorted by name) or a video file;
//! * the calibration: a `nanopush.calibration/1` TOML file (`/2` with a lens);
//! * optionally the stage log, JSON Lines: a header `{"schema":
//!   "nanopush.stage-log/1"}`, then one line per frame with its time, the
//!   coarse stage offset and the commanded nanostage position.
//!
//! [`RecordingWriter`] writes one as a run goes (a [`FrameSink`]);
//! [`open_recording`] reads and checks one.

use super::assemble::{FrameSink, FrameView};
use super::recording_check::{check_frame_sizes, check_spec, check_stage_entry};
pub use super::recording_frames::RecordingFrames;
use super::recording_frames::entries_for_frames;
use super::recording_times::frame_times;
use crate::calib::camera_map::CameraCalibration;
use crate::vision::frame::Frame;
use crate::vision::frame_input::{Channel, FrameInputError, save_png};
use crate::vision::frame_stream::FrameStream;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

/// Schema of `recording.toml`.
pub const RECORDING_SCHEMA: &str = "nanopush.recording/1";
/// Schema of the stage log's header line.
pub const STAGE_LOG_SCHEMA: &str = "nanopush.stage-log/1";
/// Name of the description file inside a recording folder.
pub const RECORDING_FILE: &str = "recording.toml";

/// The description file of a recording (lab units). An unknown key is
/// refused: a misspelt `stage_log` or `detect_tip` would otherwise drop
/// what it says and the dry-run go on with other numbers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordingSpec {
    /// Always [`RECORDING_SCHEMA`].
    pub schema: String,
    /// Where the frames came from (provenance, free text).
    pub source: String,
    /// Folder of images or video file, relative to the recording.
    pub frames: String,
    /// Calibration TOML, relative to the recording.
    pub calibration: String,
    /// Radius of the particles, micrometres.
    pub particle_radius_um: f64,
    /// Seconds between frames when there is no stage log (default: the
    /// interval the frames state, a video's frame rate or a TIFF stack's
    /// ImageJ `finterval`, else 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_interval_s: Option<f64>,
    /// Stage log (JSON Lines), relative to the recording.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage_log: Option<String>,
    /// Target sites on the sample, micrometres (as the run used them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sites_um: Option<Vec<[f64; 2]>>,
    /// Text in the built-in font, placed on the first frame's particles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pattern_text: Option<String>,
    /// Site-list file, relative to the recording, placed like `pattern_text`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pattern: Option<String>,
    /// Field the particles lie in, micrometres from the origin (default: what the first frame shows).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field_um: Option<[f64; 2]>,
    /// Scene TOML for the model's advice, relative to the recording.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<String>,
    /// Look for the probe tip (default true; false for frames without a probe).
    #[serde(default = "yes")]
    pub detect_tip: bool,
    /// Which part of colour frames is looked at (default luminance; a
    /// recording this program writes holds grey frames).
    #[serde(default, skip_serializing_if = "is_luminance")]
    pub channel: Channel,
    /// Free space the run's plans kept round the pattern, micrometres
    /// (`assemble --keep-clear-um`), which the dry run's plans keep too
    /// (default: half the particle radius, as `assemble`'s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keep_clear_um: Option<f64>,
}

fn is_luminance(channel: &Channel) -> bool {
    *channel == Channel::Luminance
}

fn yes() -> bool {
    true
}

/// One stage-log line: the state of the stages when a frame was taken.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StageLogEntry {
    /// Frame number, from 0, in the order of the frames.
    pub frame: usize,
    /// Rig time of the exposure, seconds.
    pub t_s: f64,
    /// Coarse stage offset of the nanostage origin on the sample, micrometres.
    pub coarse_offset_um: [f64; 2],
    /// Commanded nanostage position, micrometres, when known.
    pub stage_um: Option<[f64; 3]>,
}

#[derive(Serialize, Deserialize)]
struct Header {
    schema: String,
}

/// Why a recording could not be written or read. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The folder or a file it names does not exist.
    #[error("recording {path}: not found ({})", missing_hint(.path))]
    Missing { path: PathBuf },
    /// Reading or writing failed.
    #[error("recording {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file does not parse or breaks the format.
    #[error("recording {path}: {message}")]
    Format { path: PathBuf, message: String },
    /// The file given as the recording, or its recording.toml, is another
    /// nanopush kind (a rig file, a calibration).
    #[error("recording {path}: {kind}")]
    AnotherKind {
        path: PathBuf,
        kind: crate::file_schema::AnotherKind,
    },
    /// The parts do not fit together (frame count vs stage log, no target).
    #[error("recording {path}: {message}")]
    Mismatch { path: PathBuf, message: String },
}

/// What to say of a missing `path`: the description itself, or a file it
/// names (a missing calibration had been answered with what a recording is).
fn missing_hint(path: &Path) -> String {
    if path.file_name().is_some_and(|n| n == RECORDING_FILE) {
        format!("a recording is a folder with {RECORDING_FILE}; see docs/exec.md")
    } else {
        format!("named in the recording's {RECORDING_FILE}")
    }
}

/// A recording read back and checked.
#[derive(Debug, Clone)]
pub struct Recording {
    /// The folder.
    pub dir: PathBuf,
    /// Its description.
    pub spec: RecordingSpec,
    /// Pixel -> nanostage map.
    pub calibration: CameraCalibration,
    /// Where the frames are: a folder of images, a video or a TIFF stack,
    /// read one at a time by [`Recording::frames`].
    pub frames_path: PathBuf,
    /// Seconds between frames without a stage log: `frame_interval_s`, else
    /// the video's own frame rate (a 25 fps video had read as 1 s a frame,
    /// and the model's advice was asked for the session's time 25 times
    /// too late) or a TIFF stack's ImageJ interval, else 1
    /// ([`frame_times`]).
    pub frame_interval_s: f64,
    /// Where the frames' times come from, as the dry-run says it ("frame
    /// interval 0.5 s, from the stack's ImageJ description").
    pub frame_times: String,
    /// One entry per frame, when the recording has a stage log.
    pub stage_log: Option<Vec<StageLogEntry>>,
}

impl Recording {
    /// Time of frame `i`: the stage log's, else `i` frame intervals, to
    /// the nanosecond (3 x 0.2 s had read 0.6000000000000001 s).
    pub fn time_s(&self, i: usize) -> f64 {
        match &self.stage_log {
            Some(log) => log[i].t_s,
            None => (i as f64 * self.frame_interval_s * 1e9).round() / 1e9,
        }
    }

    /// Coarse offset of frame `i`, metres (zero without a stage log).
    pub fn coarse_offset_m(&self, i: usize) -> [f64; 2] {
        self.stage_log.as_ref().map_or([0.0, 0.0], |log| {
            [
                log[i].coarse_offset_um[0] * 1e-6,
                log[i].coarse_offset_um[1] * 1e-6,
            ]
        })
    }

    /// The frames, in order, read as they are asked for and checked as they
    /// come ([`RecordingFrames`]).
    pub fn frames(&self) -> Result<RecordingFrames<'_>, RecordingError> {
        let stream = FrameStream::open(&self.frames_path, self.spec.channel).map_err(|e| {
            RecordingError::Format {
                path: self.frames_path.clone(),
                message: e.to_string(),
            }
        })?;
        Ok(RecordingFrames::new(self, stream))
    }

    /// A path inside the recording.
    pub fn file(&self, relative: &str) -> PathBuf {
        self.dir.join(relative)
    }
}

/// A recording, said for a person given another file for one.
const RECORDING_WANTED: &str = "a recording (a folder with recording.toml, nanopush.recording/1, its frames and calibration; see docs/exec.md)";

/// The error for `text` when it is another nanopush kind than a
/// recording.toml.
fn another_kind(text: &str) -> Option<crate::file_schema::AnotherKind> {
    crate::file_schema::other_toml_kind(text, RECORDING_SCHEMA, RECORDING_WANTED)
}

/// Reads a recording folder and checks that its parts fit together.
pub fn open_recording(dir: &Path) -> Result<Recording, RecordingError> {
    // The recording.toml itself names its folder (it had been looked for
    // inside itself: ".../recording.toml/recording.toml: not found").
    let dir = match dir.file_name() {
        Some(name) if name == RECORDING_FILE && dir.is_file() => {
            dir.parent().unwrap_or(Path::new("."))
        }
        _ => dir,
    };
    // Another file given for the folder is named by what it is (a rig
    // file's path had been looked into: ".../rig.toml/recording.toml").
    if dir.is_file() {
        let text = std::fs::read_to_string(dir).unwrap_or_default();
        if let Some(kind) = another_kind(&text) {
            return Err(RecordingError::AnotherKind {
                path: dir.to_path_buf(),
                kind,
            });
        }
    }
    let spec_path = dir.join(RECORDING_FILE);
    if !spec_path.is_file() {
        return Err(RecordingError::Missing { path: spec_path });
    }
    let text = std::fs::read_to_string(&spec_path).map_err(|source| RecordingError::Io {
        path: spec_path.clone(),
        source,
    })?;
    let format = |message: String| RecordingError::Format {
        path: spec_path.clone(),
        message,
    };
    if let Some(kind) = another_kind(&text) {
        return Err(RecordingError::AnotherKind {
            path: spec_path,
            kind,
        });
    }
    let spec: RecordingSpec = toml::from_str(&text).map_err(|e| format(e.to_string()))?;
    if spec.schema != RECORDING_SCHEMA {
        return Err(format(format!(
            "schema is {:?}, expected {RECORDING_SCHEMA:?}",
            spec.schema
        )));
    }
    if !(spec.particle_radius_um.is_finite() && spec.particle_radius_um > 0.0) {
        return Err(format(format!(
            "particle_radius_um must be positive, got {}",
            spec.particle_radius_um
        )));
    }
    if let Some(dt) = spec.frame_interval_s
        && !(dt.is_finite() && dt > 0.0)
    {
        return Err(format(format!(
            "frame_interval_s must be positive, got {dt}"
        )));
    }
    check_spec(&spec).map_err(format)?;
    let targets = [
        spec.sites_um.is_some(),
        spec.pattern_text.is_some(),
        spec.pattern.is_some(),
    ];
    if targets.iter().filter(|t| **t).count() != 1 {
        return Err(RecordingError::Mismatch {
            path: spec_path.clone(),
            message: "give exactly one of sites_um, pattern_text, pattern".to_owned(),
        });
    }
    let cal_path = dir.join(&spec.calibration);
    if !cal_path.is_file() {
        return Err(RecordingError::Missing { path: cal_path });
    }
    let calibration = CameraCalibration::load(&cal_path).map_err(|e| RecordingError::Format {
        path: cal_path.clone(),
        message: e.to_string(),
    })?;
    let frames_path = dir.join(&spec.frames);
    if !frames_path.exists() {
        return Err(RecordingError::Missing { path: frames_path });
    }
    let frames_error = |e: FrameInputError| RecordingError::Format {
        path: frames_path.clone(),
        message: e.to_string(),
    };
    let mut stream = FrameStream::open(&frames_path, spec.channel).map_err(frames_error)?;
    let exact_frames = stream.exact_len();
    check_frame_sizes(stream.files(), &frames_path, spec.channel)?;
    // The first frame is read now: a video or stack that cannot be decoded
    // is refused before anything is written.
    match stream.next() {
        Some(Ok(_)) => {}
        Some(Err(e)) => return Err(frames_error(e)),
        None => {
            return Err(frames_error(FrameInputError::Empty {
                path: frames_path.clone(),
            }));
        }
    }
    let stage_log = match &spec.stage_log {
        None => None,
        Some(rel) => {
            let path = dir.join(rel);
            let log = read_stage_log(&path)?;
            if let Some(n) = exact_frames.filter(|&n| n != log.len()) {
                let mut message = entries_for_frames(log.len(), &n.to_string());
                if let Some(gap) = numbering_gap(stream.files()) {
                    message = format!("{message}: {gap}");
                }
                return Err(RecordingError::Mismatch { path, message });
            }
            Some(log)
        }
    };
    let times = frame_times(
        stage_log.is_some(),
        spec.frame_interval_s,
        stream.stated_interval(),
    );
    if let Some(note) = &times.warning {
        tracing::warn!("recording {}: {note}", spec_path.display());
    }
    Ok(Recording {
        dir: dir.to_owned(),
        spec,
        calibration,
        frames_path,
        frame_interval_s: times.interval_s,
        frame_times: times.origin,
        stage_log,
    })
}

/// Reads a stage log; entries must be numbered 0, 1, 2, ... with times that do not go back.
pub fn read_stage_log(path: &Path) -> Result<Vec<StageLogEntry>, RecordingError> {
    if !path.is_file() {
        return Err(RecordingError::Missing {
            path: path.to_owned(),
        });
    }
    let file = std::fs::File::open(path).map_err(|source| RecordingError::Io {
        path: path.to_owned(),
        source,
    })?;
    let format = |line: usize, message: String| RecordingError::Format {
        path: path.to_owned(),
        message: format!("line {line}: {message}"),
    };
    let mut out: Vec<StageLogEntry> = Vec::new();
    for (i, line) in std::io::BufReader::new(file).lines().enumerate() {
        let line = line.map_err(|source| RecordingError::Io {
            path: path.to_owned(),
            source,
        })?;
        if i == 0 {
            let ok =
                serde_json::from_str::<Header>(&line).is_ok_and(|h| h.schema == STAGE_LOG_SCHEMA);
            if !ok {
                return Err(format(
                    1,
                    format!("expected a header with schema {STAGE_LOG_SCHEMA}"),
                ));
            }
            continue;
        }
        // A blank line (an editor's trailing one) is no entry; it had been
        // refused as "EOF while parsing a value".
        if line.trim().is_empty() {
            continue;
        }
        let e: StageLogEntry =
            serde_json::from_str(&line).map_err(|err| format(i + 1, err.to_string()))?;
        check_stage_entry(&e).map_err(|m| format(i + 1, m))?;
        if e.frame != out.len() {
            return Err(format(
                i + 1,
                format!("frame {} where {} was expected", e.frame, out.len()),
            ));
        }
        if out.last().is_some_and(|p| e.t_s < p.t_s) || !e.t_s.is_finite() {
            return Err(format(i + 1, format!("time {} goes back", e.t_s)));
        }
        out.push(e);
    }
    Ok(out)
}

/// The names a [`RecordingWriter`] gives what it writes in its folder.
const CALIBRATION_FILE: &str = "calibration.toml";
const SCENE_FILE: &str = "scene.toml";
const STAGE_LOG_FILE: &str = "stage.jsonl";
const FRAMES_DIR: &str = "frames";

/// Writes a recording as a run goes: every analysed frame as a PNG plus its
/// stage-log line. A [`FrameSink`] cannot fail, so the first error is kept
/// and returned by [`RecordingWriter::finish`].
pub struct RecordingWriter {
    dir: PathBuf,
    log: std::fs::File,
    frames: usize,
    error: Option<RecordingError>,
    /// The stage log says where the stage was (false: `stage_um` null).
    stage_positions: bool,
}

impl RecordingWriter {
    /// Creates the folder (which must not hold a recording yet) and writes the
    /// description, the calibration and, if given, the scene next to it. The
    /// spec's `frames`, `calibration` and `stage_log` are set here.
    pub fn create(
        dir: &Path,
        mut spec: RecordingSpec,
        calibration: &CameraCalibration,
        scene_toml: Option<&str>,
    ) -> Result<Self, RecordingError> {
        let io = |path: PathBuf| move |source| RecordingError::Io { path, source };
        // Any file it would write, not only a recording's description: a
        // calibration `calibrate` had written there was replaced.
        let written = [RECORDING_FILE, CALIBRATION_FILE, SCENE_FILE, STAGE_LOG_FILE];
        let frames_dir = dir.join(FRAMES_DIR);
        let frames_held = std::fs::read_dir(&frames_dir).is_ok_and(|mut d| d.next().is_some());
        if let Some(held) = written
            .iter()
            .find(|name| dir.join(name).exists())
            .map(|name| name.to_string())
            .or(frames_held.then(|| format!("{FRAMES_DIR}/")))
        {
            return Err(RecordingError::Mismatch {
                path: dir.to_owned(),
                message: format!(
                    "already holds {held}, which a recording would replace: choose another folder"
                ),
            });
        }
        std::fs::create_dir_all(&frames_dir).map_err(io(frames_dir.clone()))?;
        spec.schema = RECORDING_SCHEMA.to_owned();
        spec.frames = FRAMES_DIR.to_owned();
        spec.calibration = CALIBRATION_FILE.to_owned();
        spec.stage_log = Some(STAGE_LOG_FILE.to_owned());
        // The frames it writes are the grey ones the loop analysed.
        spec.channel = Channel::Luminance;
        let cal = dir.join(CALIBRATION_FILE);
        std::fs::write(&cal, calibration.to_toml(None)).map_err(io(cal.clone()))?;
        if let Some(text) = scene_toml {
            spec.scene = Some(SCENE_FILE.to_owned());
            let p = dir.join(SCENE_FILE);
            std::fs::write(&p, text).map_err(io(p.clone()))?;
        }
        let text = toml::to_string(&spec).map_err(|e| RecordingError::Format {
            path: dir.join(RECORDING_FILE),
            message: e.to_string(),
        })?;
        let spec_path = dir.join(RECORDING_FILE);
        std::fs::write(&spec_path, text).map_err(io(spec_path.clone()))?;
        let log_path = dir.join(STAGE_LOG_FILE);
        let mut log = std::fs::File::create(&log_path).map_err(io(log_path.clone()))?;
        let header = serde_json::to_string(&Header {
            schema: STAGE_LOG_SCHEMA.to_owned(),
        })
        .expect("header serialises");
        writeln!(log, "{header}").map_err(io(log_path.clone()))?;
        Ok(Self {
            dir: dir.to_owned(),
            log,
            frames: 0,
            error: None,
            stage_positions: true,
        })
    }

    /// The writer logging no stage position (`stage_um` null), for a dry
    /// run on a rig: its stage is an in-process simulator's, starting
    /// wherever the real stage is not, and its positions read as the real
    /// stage's made every frame of `nanopush dry-run` say the loop stops
    /// for the calibration. The replay then does not check it, as the dry
    /// run could not.
    pub fn without_stage_positions(self) -> Self {
        Self {
            stage_positions: false,
            ..self
        }
    }

    /// Adds one frame with the stages' state.
    pub fn add(&mut self, frame: &Frame, entry: StageLogEntry) -> Result<(), RecordingError> {
        let png = self
            .dir
            .join(FRAMES_DIR)
            .join(format!("frame_{:05}.png", self.frames));
        save_png(frame, &png).map_err(|e| RecordingError::Format {
            path: png.clone(),
            message: e.to_string(),
        })?;
        let line = serde_json::to_string(&StageLogEntry {
            frame: self.frames,
            ..entry
        })
        .expect("stage log entry serialises");
        let log_path = self.dir.join(STAGE_LOG_FILE);
        writeln!(self.log, "{line}")
            .and_then(|()| self.log.flush())
            .map_err(|source| RecordingError::Io {
                path: log_path,
                source,
            })?;
        self.frames += 1;
        Ok(())
    }

    /// The number of frames written, or the first error met.
    pub fn finish(self) -> Result<usize, RecordingError> {
        match self.error {
            Some(e) => Err(e),
            None => Ok(self.frames),
        }
    }
}

impl FrameSink for RecordingWriter {
    fn frame(&mut self, view: &FrameView<'_>) {
        if self.error.is_some() {
            return;
        }
        let s = view.sighting;
        let entry = StageLogEntry {
            frame: self.frames,
            t_s: s.t_s,
            coarse_offset_um: [s.coarse_offset_m[0] * 1e6, s.coarse_offset_m[1] * 1e6],
            stage_um: s
                .stage_m
                .filter(|_| self.stage_positions)
                .map(|p| [p[0] * 1e6, p[1] * 1e6, p[2] * 1e6]),
        };
        if let Err(e) = self.add(&s.frame, entry) {
            self.error = Some(e);
        }
    }
}

/// Where the numbers in a folder's frame names break their run (a frame
/// deleted or copied in), so that a count that does not match the stage
/// log names the file ("9 stage-log entries for 8 frames" had named none).
fn numbering_gap(files: &[std::path::PathBuf]) -> Option<String> {
    let number = |p: &std::path::PathBuf| -> Option<u64> {
        let stem = p.file_stem()?.to_str()?;
        let digits: String = stem
            .chars()
            .rev()
            .take_while(char::is_ascii_digit)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        digits.parse().ok()
    };
    let name = |p: &std::path::PathBuf| {
        p.file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
    };
    files.windows(2).find_map(|pair| {
        let (a, b) = (number(&pair[0])?, number(&pair[1])?);
        (b != a + 1).then(|| {
            if b > a + 1 {
                format!(
                    "the frames' numbers jump from {} to {} (a frame missing?)",
                    name(&pair[0]),
                    name(&pair[1])
                )
            } else {
                format!(
                    "{} follows {} (a frame added or renamed?)",
                    name(&pair[1]),
                    name(&pair[0])
                )
            }
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_break_in_the_frames_numbers_is_named() {
        let files = |names: &[&str]| -> Vec<std::path::PathBuf> {
            names
                .iter()
                .map(|n| std::path::PathBuf::from(format!("frames/{n}")))
                .collect()
        };
        let gap = numbering_gap(&files(&["frame_00003.png", "frame_00005.png"])).unwrap();
        assert!(
            gap.contains("jump from frame_00003.png to frame_00005.png"),
            "{gap}"
        );
        let copied = numbering_gap(&files(&["f_1.png", "f_2.png", "f_2 copy.png", "f_3.png"]));
        assert!(
            copied.is_none(),
            "a name without a trailing number says nothing: {copied:?}"
        );
        let again = numbering_gap(&files(&["f_1.png", "f_2.png", "f_2.tif"])).unwrap();
        assert!(again.contains("f_2.tif follows f_2.png"), "{again}");
        assert_eq!(
            numbering_gap(&files(&["a_7.png", "a_8.png", "a_9.png"])),
            None
        );
    }

    fn spec() -> RecordingSpec {
        RecordingSpec {
            schema: String::new(),
            source: "unit test".to_owned(),
            frames: String::new(),
            calibration: String::new(),
            particle_radius_um: 5.0,
            frame_interval_s: None,
            stage_log: None,
            sites_um: Some(vec![[10.0, 20.0], [20.5, 20.0]]),
            pattern_text: None,
            pattern: None,
            field_um: Some([100.0, 80.0]),
            scene: None,
            detect_tip: true,
            channel: Channel::Luminance,
            keep_clear_um: None,
        }
    }

    fn frame(v: f32) -> Frame {
        Frame::new(16, 12, vec![v; 16 * 12], 8).unwrap()
    }

    fn all_frames(r: &Recording) -> Vec<Frame> {
        r.frames().unwrap().map(|f| f.unwrap().frame).collect()
    }

    #[test]
    fn a_written_recording_reads_back_with_its_frames_log_and_calibration() {
        let dir = tempfile::tempdir().unwrap();
        let rec_dir = dir.path().join("rec");
        // With the objective's distortion: it travels with the recording.
        let lens = crate::calib::lens::RadialLens::centred_on(16, 12, -0.01);
        let cal = CameraCalibration::from_scale_rotation(0.25e-6, 0.0, [-20e-6, 120e-6])
            .with_lens(Some(lens));
        let kept = RecordingSpec {
            keep_clear_um: Some(1.5),
            ..spec()
        };
        let mut w = RecordingWriter::create(&rec_dir, kept, &cal, Some("name = \"x\"\n")).unwrap();
        for k in 0..3 {
            let entry = StageLogEntry {
                frame: 99,
                t_s: k as f64 * 0.5,
                coarse_offset_um: [10.0, 0.0],
                stage_um: Some([1.0, 2.0, 3.0]),
            };
            w.add(&frame(10.0 * k as f32), entry).unwrap();
        }
        assert_eq!(w.finish().unwrap(), 3);
        let r = open_recording(&rec_dir).unwrap();
        let frames = all_frames(&r);
        assert_eq!(frames.len(), 3);
        assert_eq!(frames[2].at(3, 3), 20.0);
        let log = r.stage_log.as_ref().unwrap();
        assert_eq!(
            log.iter().map(|e| e.frame).collect::<Vec<_>>(),
            vec![0, 1, 2]
        );
        assert_eq!(r.time_s(2), 1.0);
        let off = r.coarse_offset_m(1);
        assert!((off[0] - 10e-6).abs() < 1e-18 && off[1] == 0.0);
        assert!((r.calibration.m_per_px() - 0.25e-6).abs() < 1e-15);
        assert_eq!(r.calibration.lens, Some(lens));
        assert_eq!(r.spec.sites_um, spec().sites_um);
        assert_eq!(r.spec.scene.as_deref(), Some("scene.toml"));
        assert_eq!(r.spec.keep_clear_um, Some(1.5));
        assert!(matches!(
            RecordingWriter::create(&rec_dir, spec(), &cal, None),
            Err(RecordingError::Mismatch { .. })
        ));
    }

    /// A folder holding any file a recording writes is refused, naming it,
    /// and the file kept: `assemble --record DIR` replaced the calibration
    /// `calibrate --recording DIR` had written there.
    #[test]
    fn a_folder_holding_a_file_a_recording_writes_is_refused() {
        let cal = CameraCalibration::from_scale_rotation(0.25e-6, 0.0, [0.0, 0.0]);
        for held in ["calibration.toml", "stage.jsonl", "frames/frame_00000.png"] {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join(held);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, "kept").unwrap();
            let e = match RecordingWriter::create(dir.path(), spec(), &cal, None) {
                Err(e) => e.to_string(),
                Ok(_) => panic!("{held}: a recording was begun over it"),
            };
            let name = held.split('/').next().unwrap();
            assert!(e.contains(name), "{held}: {e}");
            assert_eq!(std::fs::read_to_string(&path).unwrap(), "kept");
        }
        let empty = tempfile::tempdir().unwrap();
        std::fs::create_dir(empty.path().join("frames")).unwrap();
        assert!(RecordingWriter::create(empty.path(), spec(), &cal, None).is_ok());
    }

    /// Frames from a colour camera are read in the channel the description
    /// names; what this program writes is grey and says nothing of it.
    #[test]
    fn a_colour_recording_is_read_in_its_channel() {
        let dir = tempfile::tempdir().unwrap();
        let rec_dir = dir.path().join("rec");
        let cal = CameraCalibration::from_scale_rotation(0.25e-6, 0.0, [0.0, 0.0]);
        let asked = RecordingSpec {
            channel: Channel::Red,
            ..spec()
        };
        let mut w = RecordingWriter::create(&rec_dir, asked, &cal, None).unwrap();
        let entry = StageLogEntry {
            frame: 0,
            t_s: 0.0,
            coarse_offset_um: [0.0, 0.0],
            stage_um: None,
        };
        w.add(&frame(1.0), entry).unwrap();
        w.finish().unwrap();
        let toml_path = rec_dir.join(RECORDING_FILE);
        let written = std::fs::read_to_string(&toml_path).unwrap();
        assert!(!written.contains("channel"), "{written}");
        assert_eq!(
            open_recording(&rec_dir).unwrap().spec.channel,
            Channel::Luminance
        );
        // The frame replaced by a colour one, and the channel named.
        let colour = image::RgbImage::from_pixel(16, 12, image::Rgb([10, 200, 30]));
        colour.save(rec_dir.join("frames/frame_00000.png")).unwrap();
        for (name, channel, count) in [("green", Channel::Green, 200.0), ("b", Channel::Blue, 30.0)]
        {
            std::fs::write(&toml_path, format!("{written}channel = \"{name}\"\n")).unwrap();
            let r = open_recording(&rec_dir).unwrap();
            assert_eq!(r.spec.channel, channel);
            assert_eq!(all_frames(&r)[0].at(5, 5), count);
            let again: RecordingSpec = toml::from_str(&toml::to_string(&r.spec).unwrap()).unwrap();
            assert_eq!(again, r.spec);
        }
        std::fs::write(&toml_path, format!("{written}channel = \"infrared\"\n")).unwrap();
        let e = open_recording(&rec_dir).unwrap_err().to_string();
        assert!(e.contains("use luminance, red, green or blue"), "{e}");
    }

    #[test]
    fn broken_recordings_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let rec_dir = dir.path().join("rec");
        assert!(matches!(
            open_recording(&rec_dir),
            Err(RecordingError::Missing { .. })
        ));
        let cal = CameraCalibration::from_scale_rotation(0.25e-6, 0.0, [0.0, 0.0]);
        let mut w = RecordingWriter::create(&rec_dir, spec(), &cal, None).unwrap();
        w.add(
            &frame(1.0),
            StageLogEntry {
                frame: 0,
                t_s: 0.0,
                coarse_offset_um: [0.0, 0.0],
                stage_um: None,
            },
        )
        .unwrap();
        w.finish().unwrap();
        // A stage log with an extra line no longer matches the frames.
        let log = rec_dir.join("stage.jsonl");
        let text = std::fs::read_to_string(&log).unwrap();
        std::fs::write(&log, format!("{text}{{\"frame\":1,\"t_s\":1.0,\"coarse_offset_um\":[0.0,0.0],\"stage_um\":null}}\n")).unwrap();
        assert!(matches!(
            open_recording(&rec_dir),
            Err(RecordingError::Mismatch { .. })
        ));
        std::fs::write(&log, text.replace("\"frame\":0", "\"frame\":4")).unwrap();
        let e = open_recording(&rec_dir).unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        std::fs::write(&log, text).unwrap();
        assert!(open_recording(&rec_dir).is_ok());
        // A corrupt frame is named.
        std::fs::write(rec_dir.join("frames/frame_00000.png"), b"not a png").unwrap();
        let e = open_recording(&rec_dir).unwrap_err();
        assert!(
            matches!(e, RecordingError::Format { .. }) && e.to_string().contains("frames"),
            "{e}"
        );
        // A misspelt key is refused, named with the file.
        let description = std::fs::read_to_string(rec_dir.join(RECORDING_FILE)).unwrap();
        assert!(description.contains("\nframes = "), "{description}");
        std::fs::write(
            rec_dir.join(RECORDING_FILE),
            format!("{description}stage_logs = \"stage.jsonl\"\n"),
        )
        .unwrap();
        let e = open_recording(&rec_dir).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(RECORDING_FILE) && text.contains("stage_logs"),
            "{e}"
        );
        // A gap round the pattern no plan may keep is refused by name.
        std::fs::write(
            rec_dir.join(RECORDING_FILE),
            format!("{description}keep_clear_um = -2.0\n"),
        )
        .unwrap();
        let e = open_recording(&rec_dir).unwrap_err().to_string();
        assert!(
            e.contains(RECORDING_FILE) && e.contains("keep_clear_um is -2.000 (must be finite"),
            "{e}"
        );
        // A corrupt description is named.
        std::fs::write(rec_dir.join(RECORDING_FILE), "schema = 3").unwrap();
        let e = open_recording(&rec_dir).unwrap_err();
        assert!(e.to_string().contains(RECORDING_FILE), "{e}");
    }
}
