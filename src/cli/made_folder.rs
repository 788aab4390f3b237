//! An output folder a command makes, and taking it back when the command
//! ends having done nothing worth keeping (refused before any move, or a
//! first move on real hardware not confirmed). Why: such runs had left
//! empty folders behind (`rig calibrate`) and a journal that blocked the
//! same `--out` from being used again (`assemble --rig`), though nothing
//! had moved. What was there before stays, and with
//! [`MadeFolder::keeping_contents`] the files there are put back as they
//! were (a declined `--resume` had appended to its journal and rewritten
//! the run's report).

use anyhow::Context;
use std::collections::HashSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// A folder made (or found) for a command's output, with what it held then.
pub struct MadeFolder {
    dir: PathBuf,
    /// The outermost folder this made (`dir` or an ancestor); `None` when
    /// `dir` existed.
    outermost_made: Option<PathBuf>,
    /// Names in `dir` before the command wrote anything.
    before: HashSet<OsString>,
    /// The files directly in `dir` and their bytes, when kept
    /// ([`MadeFolder::keeping_contents`]).
    contents: Vec<(PathBuf, Vec<u8>)>,
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
            contents: Vec::new(),
        })
    }

    /// Also keeps the bytes of every file directly in the folder, which
    /// [`MadeFolder::undo`] writes back where they changed.
    pub fn keeping_contents(mut self) -> anyhow::Result<Self> {
        if !self.dir.is_dir() {
            return Ok(self);
        }
        for entry in std::fs::read_dir(&self.dir)
            .with_context(|| format!("reading {}", self.dir.display()))?
        {
            let path = entry?.path();
            if path.is_file() {
                let bytes =
                    std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
                self.contents.push((path, bytes));
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
        for (path, bytes) in &self.contents {
            if std::fs::read(path).ok().as_ref() != Some(bytes) {
                std::fs::write(path, bytes)
                    .with_context(|| format!("putting back {}", path.display()))?;
            }
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
            .keeping_contents()
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
}
