//! A camera that reads the TIFF/PNG frames another program (the camera's own
//! acquisition software) writes into a folder.
//!
//! New files are taken in name or modification-time order. A file is read
//! only once its size and modification time have stayed the same for
//! `stable_for`, and only kept if it decodes; a file that does not decode is
//! retried after twice the previous wait (a writer that pauses mid-file gets
//! time to finish; any change to the file starts the count again) and
//! skipped (with a warning, and listed in [`FolderCamera::skipped`]) after
//! `max_decode_attempts` reads of the same unchanged content: with the
//! defaults, 50 + 100 + 200 ms. A grab
//! waits at most `timeout` (or until Ctrl-C's flag is raised:
//! [`Camera::stop_waiting_on`]) and then returns `Ok(None)` ("no frame"), so a
//! writer that stops or a file that stays half-written never hangs the caller.
//! Polling (not inotify) keeps it portable and works on network shares.

use super::camera::{Camera, TimedFrame};
use super::camera_clock::WallClock;
use super::camera_error::CameraError;
use super::camera_source::{CameraSource, FrameOrder, FramePick, ms};
use super::error::RigError;
use crate::natural_order::natural_cmp;
use crate::vision::frame_input::{Channel, decode_image};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime};

/// File extensions taken as frames (compared case-insensitively).
pub const FRAME_EXTENSIONS: [&str; 3] = ["png", "tif", "tiff"];

/// How a watched folder is read.
#[derive(Debug, Clone, PartialEq)]
pub struct FolderCameraSettings {
    /// The folder.
    pub dir: PathBuf,
    /// Order new files are taken in.
    pub order: FrameOrder,
    /// Every frame, or only the newest.
    pub pick: FramePick,
    /// Ignore files present when the camera opens.
    pub skip_existing: bool,
    /// How long size and mtime must stay unchanged before a file is read.
    pub stable_for: Duration,
    /// Longest wait in one grab; then `Ok(None)`.
    pub timeout: Duration,
    /// Pause between folder scans.
    pub poll_interval: Duration,
    /// Failed decodes of the same unchanged file before it is skipped.
    pub max_decode_attempts: u32,
    /// Which colour channel makes the grey frame.
    pub channel: Channel,
}

impl FolderCameraSettings {
    /// Defaults: name order, every frame, existing files skipped, 50 ms
    /// stable, 5 s timeout, 10 ms polls, 3 decode attempts, luminance.
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: dir.into(),
            order: FrameOrder::Name,
            pick: FramePick::Every,
            skip_existing: true,
            stable_for: Duration::from_millis(50),
            timeout: Duration::from_secs(5),
            poll_interval: Duration::from_millis(10),
            max_decode_attempts: 3,
            channel: Channel::Luminance,
        }
    }

    /// The settings a rig file's `kind = "folder"` section asks for; `None`
    /// for other kinds.
    pub fn from_source(source: &CameraSource) -> Option<Self> {
        match source {
            CameraSource::Folder {
                path,
                order,
                pick,
                skip_existing,
                stable_ms,
                timeout_ms,
                channel,
            } => Some(Self {
                order: *order,
                pick: *pick,
                skip_existing: *skip_existing,
                stable_for: ms(*stable_ms),
                timeout: ms(*timeout_ms),
                channel: *channel,
                ..Self::new(path)
            }),
            _ => None,
        }
    }
}

/// A file that was given up on, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedFile {
    /// The file.
    pub path: PathBuf,
    /// The last decode error.
    pub reason: String,
}

/// What was last seen of a file not yet taken.
struct Watch {
    size: u64,
    modified: Option<SystemTime>,
    unchanged_since: Instant,
    /// How long the file must stay unchanged before the next read: the
    /// stable time, doubled after every failed decode.
    wait: Duration,
    failures: u32,
}

struct Candidate {
    path: PathBuf,
    size: u64,
    modified: Option<SystemTime>,
}

/// The watched-folder camera.
pub struct FolderCamera {
    settings: FolderCameraSettings,
    clock: WallClock,
    taken: HashSet<PathBuf>,
    watching: HashMap<PathBuf, Watch>,
    skipped: Vec<SkippedFile>,
    /// Ctrl-C's flag, once given ([`Camera::stop_waiting_on`]).
    stop: Option<Arc<AtomicBool>>,
}

/// What one look at a candidate file found.
enum Look {
    Frame(TimedFrame),
    NotYet,
    GaveUp,
}

impl FolderCamera {
    /// Opens the folder (it must exist); with `skip_existing`, the files
    /// already there are never taken. Frame times are on `clock`.
    pub fn open(settings: FolderCameraSettings, clock: WallClock) -> Result<Self, CameraError> {
        let mut camera = Self {
            settings,
            clock,
            taken: HashSet::new(),
            watching: HashMap::new(),
            skipped: Vec::new(),
            stop: None,
        };
        let existing = camera.list().map_err(|source| CameraError::Folder {
            path: camera.settings.dir.clone(),
            source,
        })?;
        if camera.settings.skip_existing {
            camera.taken.extend(existing.into_iter().map(|c| c.path));
        }
        Ok(camera)
    }

    /// The settings in force.
    pub fn settings(&self) -> &FolderCameraSettings {
        &self.settings
    }

    /// Files given up on so far (did not decode after every attempt).
    pub fn skipped(&self) -> &[SkippedFile] {
        &self.skipped
    }

    /// Frame files not yet taken, in taking order.
    fn list(&self) -> std::io::Result<Vec<Candidate>> {
        let mut out = Vec::new();
        for entry in std::fs::read_dir(&self.settings.dir)? {
            let Ok(entry) = entry else { continue };
            let path = entry.path();
            if self.taken.contains(&path) || !is_frame_file(&path) {
                continue;
            }
            // A file deleted between listing and stat is simply not there.
            let Ok(meta) = entry.metadata() else { continue };
            if meta.is_file() {
                out.push(Candidate {
                    path,
                    size: meta.len(),
                    modified: meta.modified().ok(),
                });
            }
        }
        match self.settings.order {
            FrameOrder::Name => out.sort_by(|a, b| natural_cmp(&a.path, &b.path)),
            FrameOrder::Mtime => out.sort_by(|a, b| {
                a.modified
                    .cmp(&b.modified)
                    .then_with(|| natural_cmp(&a.path, &b.path))
            }),
        }
        Ok(out)
    }

    /// Looks at one candidate: still changing, complete and decoded, or given up.
    fn look(&mut self, c: &Candidate, now: Instant) -> Look {
        let stable_for = self.settings.stable_for;
        let watch = self.watching.entry(c.path.clone()).or_insert(Watch {
            size: c.size,
            modified: c.modified,
            unchanged_since: now,
            wait: stable_for,
            failures: 0,
        });
        if watch.size != c.size || watch.modified != c.modified {
            // Still being written: earlier failed reads do not count.
            watch.size = c.size;
            watch.modified = c.modified;
            watch.unchanged_since = now;
            watch.wait = stable_for;
            watch.failures = 0;
            return Look::NotYet;
        }
        if c.size == 0 || now.duration_since(watch.unchanged_since) < watch.wait {
            return Look::NotYet;
        }
        let decoded = std::fs::read(&c.path)
            .map_err(|e| e.to_string())
            .and_then(|bytes| {
                decode_image(&bytes, &c.path, self.settings.channel).map_err(|e| e.to_string())
            });
        match decoded {
            Ok(frame) => {
                self.watching.remove(&c.path);
                self.taken.insert(c.path.clone());
                let t_s = c
                    .modified
                    .map_or_else(|| self.clock.now_s(), |m| self.clock.system_time_s(m));
                Look::Frame(TimedFrame { t_s, frame })
            }
            Err(reason) => {
                watch.failures += 1;
                watch.unchanged_since = now;
                watch.wait *= 2;
                if watch.failures >= self.settings.max_decode_attempts {
                    tracing::warn!(
                        "camera folder: skipping {} after {} failed reads: {reason}",
                        c.path.display(),
                        watch.failures
                    );
                    self.watching.remove(&c.path);
                    self.taken.insert(c.path.clone());
                    self.skipped.push(SkippedFile {
                        path: c.path.clone(),
                        reason,
                    });
                    Look::GaveUp
                } else {
                    tracing::warn!(
                        "camera folder: {} is not readable yet ({reason}); will retry",
                        c.path.display()
                    );
                    Look::NotYet
                }
            }
        }
    }

    /// One scan of the folder; a frame if one is ready.
    fn poll_once(&mut self) -> Result<Option<TimedFrame>, RigError> {
        let candidates = self.list().map_err(|e| {
            RigError::Io(format!(
                "camera folder {}: {e}",
                self.settings.dir.display()
            ))
        })?;
        let now = Instant::now();
        match self.settings.pick {
            FramePick::Every => {
                // Strict order: wait for the first file unless it is given up.
                for c in &candidates {
                    match self.look(c, now) {
                        Look::Frame(f) => return Ok(Some(f)),
                        Look::NotYet => return Ok(None),
                        Look::GaveUp => continue,
                    }
                }
            }
            FramePick::Latest => {
                for (i, c) in candidates.iter().enumerate().rev() {
                    if let Look::Frame(f) = self.look(c, now) {
                        for older in &candidates[..i] {
                            self.watching.remove(&older.path);
                            self.taken.insert(older.path.clone());
                        }
                        return Ok(Some(f));
                    }
                }
            }
        }
        Ok(None)
    }
}

fn is_frame_file(path: &Path) -> bool {
    let hidden = path
        .file_name()
        .and_then(|n| n.to_str())
        .is_none_or(|n| n.starts_with('.'));
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    !hidden && FRAME_EXTENSIONS.contains(&ext.as_str())
}

impl Camera for FolderCamera {
    /// The next complete frame; `Ok(None)` when none arrived within the
    /// timeout (ask again); an error only when the folder cannot be read.
    fn grab(&mut self) -> Result<Option<TimedFrame>, RigError> {
        let deadline = Instant::now() + self.settings.timeout;
        loop {
            if let Some(frame) = self.poll_once()? {
                return Ok(Some(frame));
            }
            let now = Instant::now();
            if self.stop.as_ref().is_some_and(|f| f.load(Ordering::SeqCst)) {
                return Ok(None);
            }
            if now >= deadline {
                tracing::debug!(
                    "camera folder {}: no new frame within {:?}",
                    self.settings.dir.display(),
                    self.settings.timeout
                );
                return Ok(None);
            }
            std::thread::sleep(self.settings.poll_interval.min(deadline - now));
        }
    }

    fn stop_waiting_on(&mut self, flag: Arc<AtomicBool>) {
        self.stop = Some(flag);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_visible_png_and_tiff_files_are_frames() {
        assert!(is_frame_file(Path::new("/f/img_001.PNG")));
        assert!(is_frame_file(Path::new("/f/a.tiff")));
        assert!(!is_frame_file(Path::new("/f/.img_001.png")));
        assert!(!is_frame_file(Path::new("/f/img_001.png.part")));
        assert!(!is_frame_file(Path::new("/f/notes.txt")));
    }

    #[test]
    fn a_missing_folder_is_a_typed_error() {
        let err = FolderCamera::open(
            FolderCameraSettings::new("/nonexistent/frames"),
            WallClock::start(),
        )
        .err()
        .unwrap();
        assert!(matches!(err, CameraError::Folder { .. }), "{err}");
    }

    /// A grab waiting on a folder no frame comes to gives up once Ctrl-C's
    /// flag is raised, not at its timeout.
    #[test]
    fn a_waiting_grab_gives_up_once_ctrl_c_is_pressed() {
        let dir = tempfile::tempdir().unwrap();
        let settings = FolderCameraSettings {
            timeout: Duration::from_secs(30),
            ..FolderCameraSettings::new(dir.path())
        };
        let mut camera = FolderCamera::open(settings, WallClock::start()).unwrap();
        let flag = Arc::new(AtomicBool::new(false));
        camera.stop_waiting_on(Arc::clone(&flag));
        let raiser = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            flag.store(true, Ordering::SeqCst);
        });
        let asked = Instant::now();
        assert!(camera.grab().unwrap().is_none());
        let waited = asked.elapsed();
        raiser.join().unwrap();
        assert!(waited < Duration::from_secs(10), "waited {waited:?}");
    }
}
