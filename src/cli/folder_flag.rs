//! A flag naming the folder a command writes into, checked before the
//! command works: a file there had been found only when the folder was
//! made, after the work (`simulate --out keep.json` printed its whole
//! summary, then failed), and in the system's words ("File exists (os
//! error 17)").

use anyhow::bail;
use std::path::Path;

/// Refuses `path`, given as `flag`, when it is a file: the folder it names
/// cannot be made there.
pub fn check_folder_flag(flag: &str, path: &Path) -> anyhow::Result<()> {
    if path.exists() && !path.is_dir() {
        bail!("{flag} {} is a file: give a folder", path.display());
    }
    Ok(())
}
