//! A command's output files must not be its input files, nor each other:
//! `detect FRAME --overlay FRAME` replaced the microscope frame with the
//! drawing, and `plan --layout L --out L` the layout with the plan, both
//! with exit 0. And their folders are made before any work, as the
//! commands that write a folder do: `rig calibrate --out new/camera.toml`
//! drove the stage through its 19 stops, then failed on the folder.

use std::path::{Path, PathBuf};

/// Where `path` is on disk, whether or not it exists yet: the file's name
/// under its folder's canonical path (so `./a.json`, `a.json` and a link
/// to the folder are one file). `None` when the folder does not exist
/// (the write will fail on its own, naming it).
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(real) = std::fs::canonicalize(path) {
        return Some(real);
    }
    let name = path.file_name()?;
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(std::fs::canonicalize(folder).ok()?.join(name))
}

/// The (flag, path) of an optional path argument.
pub fn flagged<'a>(
    flag: &'static str,
    path: &'a Option<PathBuf>,
) -> Option<(&'static str, &'a Path)> {
    path.as_deref().map(|p| (flag, p))
}

/// The (flag, path) pairs of the arguments given, in order.
pub fn given<'a, const N: usize>(
    pairs: [Option<(&'static str, &'a Path)>; N],
) -> Vec<(&'static str, &'a Path)> {
    pairs.into_iter().flatten().collect()
}

/// Makes the folder of each output (flag, path) that is not there yet,
/// then refuses an output that is one of `inputs` (flag, path) or another
/// output, naming both flags.
pub fn prepare_outputs(inputs: &[(&str, &Path)], outputs: &[(&str, &Path)]) -> anyhow::Result<()> {
    for &(flag, path) in outputs {
        let Some(folder) = path.parent().filter(|p| !p.as_os_str().is_empty()) else {
            continue;
        };
        if folder.exists() && !folder.is_dir() {
            anyhow::bail!(
                "{flag} {}: {} is a file, not a folder",
                path.display(),
                folder.display()
            );
        }
        std::fs::create_dir_all(folder).map_err(|e| {
            anyhow::anyhow!("{flag} {}: cannot make its folder: {e}", path.display())
        })?;
    }
    check_distinct_outputs(inputs, outputs)
}

/// Refuses an output (flag, path) that is one of `inputs` (flag, path) or
/// another output, naming both flags.
fn check_distinct_outputs(
    inputs: &[(&str, &Path)],
    outputs: &[(&str, &Path)],
) -> anyhow::Result<()> {
    let inputs: Vec<_> = inputs.iter().map(|(f, p)| (*f, resolved(p))).collect();
    let mut earlier: Vec<(&str, Option<PathBuf>)> = Vec::new();
    for &(flag, path) in outputs {
        let here = resolved(path);
        if here.is_some() {
            let clash = |other: &&(&str, Option<PathBuf>)| other.1 == here;
            if let Some((input, _)) = inputs.iter().find(clash) {
                anyhow::bail!(
                    "{flag} {} is the input {input}: writing it would replace what was read; choose another file",
                    path.display()
                );
            }
            if let Some((other, _)) = earlier.iter().find(clash) {
                anyhow::bail!(
                    "{flag} {} is also {other}: one would overwrite the other; choose another file",
                    path.display()
                );
            }
        }
        earlier.push((flag, here));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_is_an_input_or_another_output_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let layout = dir.path().join("layout.json");
        std::fs::write(&layout, "{}").unwrap();
        let plan = dir.path().join("plan.json");
        // The same file spelt another way.
        let again = dir.path().join(".").join("layout.json");
        let fine = check_distinct_outputs(&[("--layout", &layout)], &[("--out", &plan)]);
        assert!(fine.is_ok());
        let e = check_distinct_outputs(&[("--layout", &layout)], &[("--out", &again)])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--out") && e.contains("the input --layout"),
            "{e}"
        );
        let e = check_distinct_outputs(&[], &[("--out", &plan), ("--overlay", &plan)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--overlay") && e.contains("also --out"), "{e}");
        // A folder that does not exist is left to the write to report.
        let nowhere = dir.path().join("no/such/plan.json");
        assert!(check_distinct_outputs(&[("--layout", &layout)], &[("--out", &nowhere)]).is_ok());
    }

    /// Outputs in folders not there yet get them before any work, and two
    /// outputs that are one file in such a folder are still refused.
    #[test]
    fn the_folders_of_outputs_are_made_first() {
        let dir = tempfile::tempdir().unwrap();
        let plan = dir.path().join("new/deeper/plan.json");
        let svg = dir.path().join("other/plan.svg");
        prepare_outputs(&[], &[("--out", &plan), ("--overlay", &svg)]).unwrap();
        assert!(plan.parent().unwrap().is_dir() && svg.parent().unwrap().is_dir());
        assert!(!plan.exists(), "only the folder is made");
        let twice = dir.path().join("third/a.json");
        let e = prepare_outputs(&[], &[("--out", &twice), ("--overlay", &twice)]).unwrap_err();
        assert!(e.to_string().contains("also --out"), "{e}");
        // A folder that is a file is named.
        let blocked = dir.path().join("new/deeper/plan.json/x.json");
        std::fs::write(&plan, "{}").unwrap();
        let e = prepare_outputs(&[], &[("--out", &blocked)]).unwrap_err();
        assert!(e.to_string().contains("is a file, not a folder"), "{e}");
    }
}
