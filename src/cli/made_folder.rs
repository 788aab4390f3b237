//! An output folder a command makes, and taking it back when the command
//! ends having done nothing worth keeping (refused before any move, or a
//! first move on real hardware not confirmed). Why: such runs had left
//! empty folders behind (`rig calibrate`) and a journal that blocked the
//! same `--out` from being used again (`assemble --rig`), though nothing
//! had moved. What was there before stays, and with [`MadeFolder::keeping`]
//! the files the command writes are put back as they were (a declined
//! `--resume` had appended to its journal and rewritten the run's report).
//! Only those are kept: keeping every file had read a run's videos, which
//! can be hundreds of MB, on every resume.

use anyhow::Context;
use std::collections::HashSet;
use std::ffi::OsString;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// A folder made (or found) for a command's output, with what it held then.
pub struct MadeFolder {
    dir: PathBuf,
    /// The outermost folder this made (`dir` or an ancestor); `None` when
    /// `dir` existed.
    outermost_made: Option<PathBuf>,
    /// Names in `dir` before the command wrote anything.
    before: HashSet<OsString>,
    /// Files in `dir` the command may change, as they were
    /// ([`MadeFolder::keeping`]).
    kept: Vec<Kept>,
}

/// A file as it was before the command, enough to put it back.
enum Kept {
    /// A file the command rewrites: its bytes.
    Whole { path: PathBuf, bytes: Vec<u8> },
    /// A file the command only appends to, after cutting off a last line
    /// torn by a crash (a journal: `JournalWriter::resume`): its length and
    /// the bytes after its last newline.
    Appended {
        path: PathBuf,
        len: u64,
        torn: Vec<u8>,
    },
}

impl MadeFolder {
    /// Makes `dir` and its missing ancestors, noting which were missing and
    /// what `dir` already held.
    pub fn create(dir: &Path) -> anyhow::Result<Self> {
        let noted = Self::before_making(dir)?;
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(noted)
    }

    /// Notes what `dir` and its ancestors hold, for a folder that something
    /// else makes later, if it comes to it (a `--record` folder, made only
    /// once the first frame is in).
    pub fn before_making(dir: &Path) -> anyhow::Result<Self> {
        let outermost_made = dir
            .ancestors()
            .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
            .last()
            .map(Path::to_path_buf);
        let before = match outermost_made {
            Some(_) => HashSet::new(),
            None => std::fs::read_dir(dir)
                .with_context(|| format!("reading {}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.file_name()))
                .collect(),
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            outermost_made,
            before,
            kept: Vec::new(),
        })
    }

    /// Also keeps, of the files directly in the folder, those named in
    /// `rewritten` (their bytes) and in `appended` (their length and torn
    /// last line, [`Kept::Appended`]), which [`MadeFolder::undo`] puts back
    /// where they changed. Files the command makes are removed by `undo`
    /// anyway; the rest are neither read nor touched.
    pub fn keeping(mut self, rewritten: &[&str], appended: &[&str]) -> anyhow::Result<Self> {
        for name in rewritten {
            let path = self.dir.join(name);
            if path.is_file() {
                let bytes =
                    std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
                self.kept.push(Kept::Whole { path, bytes });
            }
        }
        for name in appended {
            let path = self.dir.join(name);
            if path.is_file() {
                let (len, torn) =
                    torn_tail(&path).with_context(|| format!("reading {}", path.display()))?;
                self.kept.push(Kept::Appended { path, len, torn });
            }
        }
        Ok(self)
    }

    /// Removes what appeared in the folder since [`MadeFolder::create`],
    /// then the folders it made, as far as they are empty (one another
    /// process wrote into is left). Returns whether the folder is left as
    /// it was found.
    pub fn undo(&self) -> anyhow::Result<bool> {
        if !self.dir.exists() {
            return Ok(true);
        }
        for kept in &self.kept {
            kept.put_back()?;
        }
        for entry in std::fs::read_dir(&self.dir)
            .with_context(|| format!("reading {}", self.dir.display()))?
        {
            let entry = entry?;
            if self.before.contains(&entry.file_name()) {
                continue;
            }
            let path = entry.path();
            let removed = if entry.file_type()?.is_dir() {
                std::fs::remove_dir_all(&path)
            } else {
                std::fs::remove_file(&path)
            };
            removed.with_context(|| format!("removing {}", path.display()))?;
        }
        let Some(outermost) = &self.outermost_made else {
            return Ok(true);
        };
        for made in self.dir.ancestors() {
            if std::fs::remove_dir(made).is_err() {
                return Ok(false);
            }
            if made == outermost {
                break;
            }
        }
        Ok(true)
    }

    /// [`MadeFolder::undo`], said as the end of "FOLDER ...": whether it is
    /// as it was, or why not.
    pub fn undo_said(&self) -> String {
        match self.undo() {
            Ok(true) => "is as it was before".to_string(),
            Ok(false) => "is left: something else wrote into it".to_string(),
            Err(e) => format!("is left: {e:#}"),
        }
    }
}

impl Kept {
    /// Writes the file back as it was, where it changed.
    fn put_back(&self) -> anyhow::Result<()> {
        match self {
            Kept::Whole { path, bytes } => {
                if std::fs::read(path).ok().as_ref() != Some(bytes) {
                    std::fs::write(path, bytes)
                        .with_context(|| format!("putting back {}", path.display()))?;
                }
                Ok(())
            }
            Kept::Appended { path, len, torn } => {
                let put_back = || -> std::io::Result<()> {
                    let mut file = std::fs::OpenOptions::new().write(true).open(path)?;
                    let lines = len - torn.len() as u64;
                    if file.metadata()?.len() < lines {
                        return Err(std::io::Error::other(format!(
                            "it is shorter than the {lines} bytes it was appended to"
                        )));
                    }
                    file.set_len(lines)?;
                    file.seek(SeekFrom::Start(lines))?;
                    file.write_all(torn)
                };
                put_back().with_context(|| format!("putting back {}", path.display()))
            }
        }
    }

    /// Bytes held in memory for this file.
    #[cfg(test)]
    fn bytes_held(&self) -> usize {
        match self {
            Kept::Whole { bytes, .. } => bytes.len(),
            Kept::Appended { torn, .. } => torn.len(),
        }
    }
}

/// The length of the file at `path` and the bytes after its last newline
/// (all of it without one), read backwards from its end in 64 KiB pieces:
/// a journal's torn last line, without reading the journal.
fn torn_tail(path: &Path) -> std::io::Result<(u64, Vec<u8>)> {
    const PIECE: u64 = 64 * 1024;
    let mut file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    let mut torn = Vec::new();
    let mut end = len;
    while end > 0 {
        let start = end.saturating_sub(PIECE);
        let mut piece = vec![0; (end - start) as usize];
        file.seek(SeekFrom::Start(start))?;
        file.read_exact(&mut piece)?;
        let newline = piece.iter().rposition(|b| *b == b'\n');
        if let Some(at) = newline {
            piece.drain(..=at);
        }
        piece.extend_from_slice(&torn);
        torn = piece;
        if newline.is_some() {
            break;
        }
        end = start;
    }
    Ok((len, torn))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undo_removes_what_was_made_and_keeps_what_was_there() {
        let root = tempfile::tempdir().unwrap();
        // Made from scratch, two levels deep: nothing left.
        let deep = root.path().join("a/b/run");
        let made = MadeFolder::create(&deep).unwrap();
        std::fs::write(deep.join("journal.jsonl"), "{}").unwrap();
        std::fs::create_dir(deep.join("frames")).unwrap();
        assert!(made.undo().unwrap());
        assert!(!root.path().join("a").exists());
        // Found with a file in it: the file and the folder stay.
        let kept = root.path().join("kept");
        std::fs::create_dir(&kept).unwrap();
        std::fs::write(kept.join("notes.txt"), "mine").unwrap();
        let made = MadeFolder::create(&kept).unwrap();
        std::fs::write(kept.join("report.json"), "{}").unwrap();
        assert!(made.undo().unwrap());
        let names: Vec<_> = std::fs::read_dir(&kept)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![OsString::from("notes.txt")]);
    }

    /// Kept contents are written back; a folder never made is left alone.
    #[test]
    fn undo_puts_back_the_files_it_kept() {
        let root = tempfile::tempdir().unwrap();
        let run = root.path().join("run");
        std::fs::create_dir(&run).unwrap();
        std::fs::write(run.join("journal.jsonl"), "start\n").unwrap();
        let kept = MadeFolder::create(&run)
            .unwrap()
            .keeping(&["report.json"], &["journal.jsonl"])
            .unwrap();
        std::fs::write(run.join("journal.jsonl"), "start\nresume\nstopped\n").unwrap();
        std::fs::write(run.join("report.json"), "{}").unwrap();
        assert!(kept.undo().unwrap());
        assert_eq!(
            std::fs::read_to_string(run.join("journal.jsonl")).unwrap(),
            "start\n"
        );
        assert!(!run.join("report.json").exists());
        let later = root.path().join("rec/new");
        let noted = MadeFolder::before_making(&later).unwrap();
        assert!(noted.undo().unwrap());
        std::fs::create_dir_all(later.join("frames")).unwrap();
        assert!(noted.undo().unwrap());
        assert!(!root.path().join("rec").exists());
    }

    /// Only the files named are kept, so a video beside them is never read;
    /// the journal, appended to after its torn last line was cut off, and
    /// the report, rewritten, are put back byte for byte, and what the
    /// command made is removed.
    #[test]
    fn only_the_files_a_resume_writes_are_kept_and_put_back() {
        let root = tempfile::tempdir().unwrap();
        let run = root.path().join("run");
        std::fs::create_dir(&run).unwrap();
        // A torn last line longer than a piece of torn_tail's reading.
        let torn = format!("{{\"seq\":2,\"note\":\"{}", "x".repeat(70_000));
        let journal = format!("header\nentry 0\nentry 1\n{torn}");
        std::fs::write(run.join("journal.jsonl"), &journal).unwrap();
        std::fs::write(run.join("report.json"), "{\"pushes\":1}").unwrap();
        let video = vec![7u8; 4 << 20];
        std::fs::write(run.join("run.mp4"), &video).unwrap();
        let kept = MadeFolder::before_making(&run)
            .unwrap()
            .keeping(&["report.json", "sites.json"], &["journal.jsonl"])
            .unwrap();
        let held: usize = kept.kept.iter().map(Kept::bytes_held).sum();
        assert_eq!(held, "{\"pushes\":1}".len() + torn.len());
        // What a declined resume does: cut the torn line, append, rewrite.
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(run.join("journal.jsonl"))
            .unwrap();
        file.set_len((journal.len() - torn.len()) as u64).unwrap();
        drop(file);
        let mut file = std::fs::OpenOptions::new()
            .append(true)
            .open(run.join("journal.jsonl"))
            .unwrap();
        file.write_all(b"resume\nstopped\n").unwrap();
        drop(file);
        std::fs::write(run.join("report.json"), "{}").unwrap();
        std::fs::write(run.join("sites.json"), "{}").unwrap();
        std::fs::write(run.join("run-resume-1.mp4"), "new").unwrap();
        assert!(kept.undo().unwrap());
        assert_eq!(
            std::fs::read_to_string(run.join("journal.jsonl")).unwrap(),
            journal
        );
        assert_eq!(
            std::fs::read_to_string(run.join("report.json")).unwrap(),
            "{\"pushes\":1}"
        );
        assert!(!run.join("sites.json").exists());
        assert!(!run.join("run-resume-1.mp4").exists());
        assert_eq!(std::fs::read(run.join("run.mp4")).unwrap(), video);
        // A journal ending with its newline keeps nothing but its length.
        std::fs::write(run.join("journal.jsonl"), "header\nentry 0\n").unwrap();
        assert_eq!(
            torn_tail(&run.join("journal.jsonl")).unwrap(),
            (15, Vec::new())
        );
    }
}
