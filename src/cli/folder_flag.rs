//! A flag naming the folder a command writes into, checked before the
//! command works: a file there had been found only when the folder was
//! made, after the work (`simulate --out keep.json` printed its whole
//! summary, then failed), and in the system's words ("File exists (os
//! error 17)"); a file of another nanopush kind is named by what it is
//! (`rig calibrate --recording scene.toml` had said "reading
//! .../stage.csv: Not a directory").

use anyhow::bail;
use std::path::Path;

/// Refuses `path`, given as `flag`, when it is a file: the folder it names
/// (`folder`, "a folder") cannot be made there.
pub fn check_folder_flag(flag: &str, path: &Path, folder: &'static str) -> anyhow::Result<()> {
    if !path.exists() || path.is_dir() {
        return Ok(());
    }
    // No schema is expected: any nanopush kind is named.
    let said = std::fs::read_to_string(path)
        .ok()
        .and_then(|text| crate::file_schema::other_toml_kind(&text, "", folder))
        .map_or_else(|| format!("give {folder}"), |kind| kind.to_string());
    bail!("{flag} {} is a file: {said}", path.display());
}
