//! The run journal: JSON Lines, one entry per command, observation or decision,
//! flushed to the OS as each is written so a killed process loses nothing it
//! had journalled. The first line is a header carrying the schema.
//!
//! Reading tolerates exactly one kind of damage, the one a crash causes: a last
//! line cut off mid-write. It is reported (not silently dropped) and ignored;
//! damage anywhere else is an error, because it means the file was edited or
//! corrupted and a resume from it could disturb placed particles.

use serde::{Deserialize, Serialize, de::DeserializeOwned};
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

/// The schema written in the header line.
pub const JOURNAL_SCHEMA: &str = "nanopush.journal/1";

/// Why a journal could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    /// The file could not be created, opened, written or flushed.
    #[error("journal {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A line other than a crash-truncated last line does not parse.
    #[error("journal {path}, line {line}: {message}")]
    Corrupt {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// The header is missing or names another schema.
    #[error("journal {path}: expected a header with schema {JOURNAL_SCHEMA}, found {found}")]
    Schema { path: PathBuf, found: String },
}

#[derive(Serialize, Deserialize)]
struct Header {
    schema: String,
}

/// One journal line: a sequence number, the run time it happened at, and the event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Entry<E> {
    /// Position in the journal, from 0, without gaps.
    pub seq: u64,
    /// Seconds of run time (rig clock) when the event happened.
    pub t_s: f64,
    /// What happened.
    pub event: E,
}

/// An open journal that appends entries and flushes each one.
pub struct JournalWriter {
    path: PathBuf,
    file: File,
    next_seq: u64,
}

impl JournalWriter {
    /// Creates a new journal (fails if the file exists, so nothing is overwritten).
    pub fn create(path: &Path) -> Result<Self, JournalError> {
        let io = |source| JournalError::Io {
            path: path.to_owned(),
            source,
        };
        let mut file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .map_err(io)?;
        let header = serde_json::to_string(&Header {
            schema: JOURNAL_SCHEMA.to_owned(),
        })
        .expect("header serialises");
        writeln!(file, "{header}").map_err(io)?;
        file.flush().map_err(io)?;
        Ok(Self {
            path: path.to_owned(),
            file,
            next_seq: 0,
        })
    }

    /// Reopens a journal for appending after `read` has checked it; new entries
    /// continue the sequence. A crash-truncated last line is cut off first so
    /// the file stays valid JSON Lines.
    pub fn resume<E: DeserializeOwned>(
        path: &Path,
    ) -> Result<(Self, JournalContents<E>), JournalError> {
        let contents = read_journal::<E>(path)?;
        if contents.truncated_tail {
            tracing::warn!(
                "{}: its last line was cut off (a crash while it was written); it is dropped, and the run goes on from the line before",
                path.display()
            );
        }
        let io = |source| JournalError::Io {
            path: path.to_owned(),
            source,
        };
        let file = OpenOptions::new().write(true).open(path).map_err(io)?;
        file.set_len(contents.valid_bytes).map_err(io)?;
        let mut file = OpenOptions::new().append(true).open(path).map_err(io)?;
        file.flush().map_err(io)?;
        let next_seq = contents.entries.last().map_or(0, |e| e.seq + 1);
        Ok((
            Self {
                path: path.to_owned(),
                file,
                next_seq,
            },
            contents,
        ))
    }

    /// Appends one event and flushes it to the OS before returning.
    pub fn append<E: Serialize>(&mut self, t_s: f64, event: &E) -> Result<u64, JournalError> {
        let seq = self.next_seq;
        let line = serde_json::to_string(&Entry { seq, t_s, event }).map_err(|e| {
            JournalError::Corrupt {
                path: self.path.clone(),
                line: seq as usize + 2,
                message: format!("event does not serialise: {e}"),
            }
        })?;
        let io = |source| JournalError::Io {
            path: self.path.clone(),
            source,
        };
        self.file
            .write_all(format!("{line}\n").as_bytes())
            .map_err(io)?;
        self.file.flush().map_err(io)?;
        self.next_seq += 1;
        Ok(seq)
    }

    /// The file this journal writes to.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// What a journal holds, and whether its last line had been cut off by a crash.
#[derive(Debug)]
pub struct JournalContents<E> {
    /// Every complete entry, in order.
    pub entries: Vec<Entry<E>>,
    /// True when an incomplete last line (a crash mid-write) was found and ignored.
    pub truncated_tail: bool,
    /// Length in bytes of the valid part of the file.
    pub valid_bytes: u64,
}

/// Reads a whole journal; see the module doc for what damage it tolerates.
pub fn read_journal<E: DeserializeOwned>(path: &Path) -> Result<JournalContents<E>, JournalError> {
    let io = |source| JournalError::Io {
        path: path.to_owned(),
        source,
    };
    let mut reader = BufReader::new(File::open(path).map_err(io)?);
    let mut lines: Vec<(String, bool)> = Vec::new();
    loop {
        let mut buf = String::new();
        let n = reader.read_line(&mut buf).map_err(io)?;
        if n == 0 {
            break;
        }
        let complete = buf.ends_with('\n');
        lines.push((buf, complete));
    }
    let header_ok = lines.first().is_some_and(|(l, complete)| {
        *complete && serde_json::from_str::<Header>(l).is_ok_and(|h| h.schema == JOURNAL_SCHEMA)
    });
    if !header_ok {
        return Err(JournalError::Schema {
            path: path.to_owned(),
            found: lines
                .first()
                .map_or("an empty file".to_owned(), |(l, _)| l.trim().to_owned()),
        });
    }
    let mut valid_bytes = lines[0].0.len() as u64;
    let mut entries = Vec::new();
    let mut truncated_tail = false;
    for (i, (line, complete)) in lines.iter().enumerate().skip(1) {
        // A blank line (an editor's, a shell's `echo >>`) holds nothing to lose.
        if *complete && line.trim().is_empty() {
            valid_bytes += line.len() as u64;
            continue;
        }
        match (serde_json::from_str::<Entry<E>>(line), complete) {
            (Ok(entry), true) => {
                valid_bytes += line.len() as u64;
                entries.push(entry);
            }
            // read_line returns a line without its newline only at the end of the
            // file: a last line cut off mid-write, even when what is there parses.
            (_, false) => truncated_tail = true,
            (Err(e), true) => {
                return Err(JournalError::Corrupt {
                    path: path.to_owned(),
                    line: i + 1,
                    message: e.to_string(),
                });
            }
        }
    }
    for (expected, entry) in entries.iter().enumerate() {
        if entry.seq != expected as u64 {
            return Err(JournalError::Corrupt {
                path: path.to_owned(),
                line: expected + 2,
                message: format!("sequence {} where {expected} was expected", entry.seq),
            });
        }
    }
    Ok(JournalContents {
        entries,
        truncated_tail,
        valid_bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::{Deserialize, Serialize};

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(tag = "kind", rename_all = "snake_case")]
    enum Ev {
        Move { x_um: f64 },
        Seen { n: u32 },
    }

    fn events() -> Vec<Ev> {
        vec![
            Ev::Move { x_um: 1.5 },
            Ev::Seen { n: 3 },
            Ev::Move { x_um: -2.0 },
        ]
    }

    /// A journal of `events()` at t = 0 in `dir`.
    fn written(dir: &tempfile::TempDir) -> PathBuf {
        let path = dir.path().join("j.jsonl");
        let mut w = JournalWriter::create(&path).unwrap();
        for e in events() {
            w.append(0.0, &e).unwrap();
        }
        path
    }

    #[test]
    fn written_entries_read_back_identically() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j.jsonl");
        let mut w = JournalWriter::create(&path).unwrap();
        for (i, e) in events().iter().enumerate() {
            assert_eq!(w.append(i as f64 * 0.5, e).unwrap(), i as u64);
        }
        let back = read_journal::<Ev>(&path).unwrap();
        assert!(!back.truncated_tail);
        let got: Vec<Ev> = back.entries.iter().map(|e| e.event.clone()).collect();
        assert_eq!(got, events());
        assert_eq!(back.entries[2].t_s, 1.0);
    }

    #[test]
    fn create_refuses_to_overwrite() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j.jsonl");
        JournalWriter::create(&path).unwrap();
        assert!(matches!(
            JournalWriter::create(&path),
            Err(JournalError::Io { .. })
        ));
    }

    #[test]
    fn crash_truncated_tail_is_reported_and_resume_continues_the_sequence() {
        let dir = tempfile::tempdir().unwrap();
        let path = written(&dir);
        // Simulate a kill mid-write: half a line at the end.
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        write!(f, "{{\"seq\":3,\"t_s\":0.0,\"ev").unwrap();
        drop(f);
        let (mut w, contents) = JournalWriter::resume::<Ev>(&path).unwrap();
        assert!(contents.truncated_tail);
        assert_eq!(contents.entries.len(), 3);
        assert_eq!(w.append(9.0, &Ev::Seen { n: 7 }).unwrap(), 3);
        let back = read_journal::<Ev>(&path).unwrap();
        assert!(!back.truncated_tail);
        assert_eq!(back.entries.len(), 4);
        assert_eq!(back.entries[3].event, Ev::Seen { n: 7 });
    }

    /// A blank line (an editor's newline at the end, `echo >>`) is no
    /// damage: the journal reads and resumes past it.
    #[test]
    fn blank_lines_are_skipped_and_the_journal_resumes() {
        let dir = tempfile::tempdir().unwrap();
        let path = written(&dir);
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        writeln!(f).unwrap();
        writeln!(f, "  ").unwrap();
        drop(f);
        let (mut w, contents) = JournalWriter::resume::<Ev>(&path).unwrap();
        assert!(!contents.truncated_tail);
        assert_eq!(contents.entries.len(), 3);
        assert_eq!(w.append(9.0, &Ev::Seen { n: 7 }).unwrap(), 3);
        let back = read_journal::<Ev>(&path).unwrap();
        assert_eq!(back.entries.len(), 4);
        assert_eq!(back.entries[3].event, Ev::Seen { n: 7 });
    }

    #[test]
    fn damage_before_the_last_line_is_an_error_naming_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = written(&dir);
        let text = std::fs::read_to_string(&path).unwrap();
        let damaged = text.replacen("\"seen\"", "\"seen", 1);
        std::fs::write(&path, damaged).unwrap();
        match read_journal::<Ev>(&path) {
            Err(JournalError::Corrupt { line, .. }) => assert_eq!(line, 3),
            other => panic!("expected Corrupt, got {other:?}"),
        }
    }

    #[test]
    fn a_file_without_the_header_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j.jsonl");
        std::fs::write(&path, "{\"schema\":\"other/1\"}\n").unwrap();
        assert!(matches!(
            read_journal::<Ev>(&path),
            Err(JournalError::Schema { .. })
        ));
        std::fs::write(&path, "").unwrap();
        assert!(matches!(
            read_journal::<Ev>(&path),
            Err(JournalError::Schema { .. })
        ));
    }
}
