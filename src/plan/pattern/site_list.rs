//! Site lists: TOML or JSON files of site positions in micrometres,
//! `{ sites = [ { x_um = 0.0, y_um = 0.0 }, ... ] }` (TOML) or the same in JSON.

use super::{Pattern, PatternError};
use crate::plan::{MAX_COORDINATE_UM, coordinate_in_range};
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// One site of a site-list file, micrometres. Read only from a table of
/// exactly `x_um` and `y_um`: an array `[x, y, z]` or a third key (`z_um`)
/// had been read as x and y with the rest dropped, silently.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(try_from = "BTreeMap<String, f64>")]
pub struct SiteEntry {
    /// x, micrometres.
    pub x_um: f64,
    /// y, micrometres.
    pub y_um: f64,
}

impl TryFrom<BTreeMap<String, f64>> for SiteEntry {
    type Error = String;

    fn try_from(mut keys: BTreeMap<String, f64>) -> Result<Self, String> {
        let mut take = |name: &str| {
            keys.remove(name)
                .ok_or_else(|| format!("a site needs `{name}` (micrometres)"))
        };
        let (x_um, y_um) = (take("x_um")?, take("y_um")?);
        if let Some(other) = keys.keys().next() {
            return Err(format!(
                "a site has `{other}`: a site is `x_um` and `y_um` only"
            ));
        }
        Ok(SiteEntry { x_um, y_um })
    }
}

/// A site-list file.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SiteList {
    /// The sites, relative positions in micrometres (the pattern is recentred).
    pub sites: Vec<SiteEntry>,
}

impl SiteList {
    /// Parses TOML (`.toml`) or JSON (anything else) text.
    pub fn parse(text: &str, is_toml: bool, origin: &str) -> Result<Self, PatternError> {
        let err = |message: String| PatternError::File {
            path: origin.into(),
            message,
        };
        let text = crate::byte_order_mark::without_bom(text);
        if is_toml {
            toml::from_str(text).map_err(|e| err(e.to_string()))
        } else if text.trim_start().starts_with('[') {
            // serde reads a struct from an array too, and then says "invalid
            // type: map, expected a sequence" of the first site.
            Err(err(
                "a site list is an object, {\"sites\": [...]}, not a bare array: wrap the array"
                    .into(),
            ))
        } else {
            serde_json::from_str(text).map_err(|e| err(e.to_string()))
        }
    }

    /// The pattern these sites describe; a site beyond [`MAX_COORDINATE_UM`]
    /// is refused by index (most likely metres or nanometres written as um).
    pub fn to_pattern(&self, origin: &str) -> Result<Pattern, PatternError> {
        for (i, s) in self.sites.iter().enumerate() {
            for (name, v) in [("x_um", s.x_um), ("y_um", s.y_um)] {
                if !coordinate_in_range(v) {
                    // NaN had been told it was not within a metre.
                    let why = if v.is_finite() {
                        format!(
                            "is not within {MAX_COORDINATE_UM:e} um (a metre) of the origin: site lists are in micrometres"
                        )
                    } else {
                        "is not a number: give each site's x_um and y_um in micrometres".to_owned()
                    };
                    return Err(PatternError::File {
                        path: origin.into(),
                        message: format!("site {i}: {name} = {v:e} {why}"),
                    });
                }
            }
        }
        let offsets = self
            .sites
            .iter()
            .map(|s| Vector2::new(s.x_um * 1e-6, s.y_um * 1e-6))
            .collect();
        Pattern::from_offsets(offsets, &format!("{origin} lists no site"))
    }
}

/// Whether `path` names a site list (`.toml` / `.json`): positions in um,
/// which no pitch scales.
pub fn is_site_list(path: &Path) -> bool {
    has_extension(path, "toml") || has_extension(path, "json")
}

fn has_extension(path: &Path, ext: &str) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// Reads a pattern file: `.toml` / `.json` site lists, `.svg` drawings
/// whose paths are sampled at `pitch_m` (1 user unit = 1 um), or an image
/// (`.png`, `.bmp`, ...) where every dark pixel is a site at `pitch_m`.
pub fn read_pattern(path: &Path, pitch_m: f64) -> Result<Pattern, PatternError> {
    let origin = path.display().to_string();
    if is_site_list(path) {
        let text = std::fs::read_to_string(path).map_err(|e| PatternError::File {
            path: origin.clone(),
            message: e.to_string(),
        })?;
        SiteList::parse(&text, has_extension(path, "toml"), &origin)?.to_pattern(&origin)
    } else if has_extension(path, "svg") {
        super::svg_path::read_svg(path, pitch_m)
    } else if path.is_dir() || image::ImageFormat::from_path(path).is_err() {
        // Named by what a pattern may be: a folder had read "The image
        // format could not be determined", a .csv "`.\"csv\"` was not
        // recognized as an image format".
        let what = if path.is_dir() {
            "a folder"
        } else {
            "no pattern file"
        };
        Err(PatternError::File {
            path: origin,
            message: format!(
                "{what}: give a site list (.toml or .json, um), an SVG drawing (.svg) or an image (.png, .bmp, .tif, ...)"
            ),
        })
    } else {
        super::bitmap::read_bitmap(path, pitch_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder or a file of no pattern kind is named as such, with the
    /// kinds a pattern may be.
    #[test]
    fn a_file_of_no_pattern_kind_names_the_kinds() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("sites.csv");
        std::fs::write(&csv, "x,y\n1,2\n").unwrap();
        for (path, what) in [
            (dir.path().to_path_buf(), "a folder"),
            (csv, "no pattern file"),
        ] {
            let e = read_pattern(&path, 10e-6).unwrap_err().to_string();
            assert!(
                e.contains(what) && e.contains(".toml or .json") && e.contains(".svg"),
                "{e}"
            );
        }
    }

    /// A site a metre or more out is refused by index, in short figures.
    #[test]
    fn a_site_beyond_a_metre_is_refused_by_index() {
        let list = SiteList::parse(
            "sites = [{ x_um = 0.0, y_um = 0.0 }, { x_um = 5.0, y_um = 1e300 }]",
            true,
            "far.toml",
        )
        .unwrap();
        let message = list.to_pattern("far.toml").unwrap_err().to_string();
        assert!(
            message.contains("site 1: y_um = 1e300 is not within 1e6 um"),
            "{message}"
        );
        assert!(message.len() < 200, "{message}");
        let nan = SiteList::parse("sites = [{ x_um = nan, y_um = 0.0 }]", true, "nan.toml")
            .unwrap()
            .to_pattern("nan.toml")
            .unwrap_err()
            .to_string();
        assert!(nan.contains("site 0: x_um = NaN is not a number"), "{nan}");
        let near = SiteList::parse(
            "sites = [{ x_um = 0.0, y_um = 0.0 }, { x_um = 5.0, y_um = 1e6 }]",
            true,
            "near.toml",
        )
        .unwrap();
        let nan =
            SiteList::parse("sites = [{ x_um = nan, y_um = 0.0 }]", true, "nan.toml").unwrap();
        let message = nan.to_pattern("nan.toml").unwrap_err().to_string();
        assert!(message.contains("site 0: x_um = NaN"), "{message}");
        assert_eq!(near.to_pattern("near.toml").unwrap().offsets_m.len(), 2);
    }

    /// Three numbers, a third key or a missing one: refused, saying what a
    /// site is (each was read as x and y, the rest dropped, before).
    #[test]
    fn a_site_is_x_um_and_y_um_and_nothing_else() {
        let refused = |text: &str, is_toml: bool| {
            SiteList::parse(text, is_toml, "s").unwrap_err().to_string()
        };
        let arrays = refused("sites = [[0.0, 0.0, 9.0]]", true);
        assert!(arrays.contains("expected a map"), "{arrays}");
        let json_arrays = refused(r#"{"sites": [[0, 0, 5]]}"#, false);
        assert!(json_arrays.contains("expected a map"), "{json_arrays}");
        let third = refused(r#"{"sites": [{"x_um": 0, "y_um": 0, "z_um": 4}]}"#, false);
        assert!(third.contains("`z_um`"), "{third}");
        // A byte-order mark (a Windows editor's) is not the text.
        let one = r#"{"sites": [{"x_um": 1, "y_um": 2}]}"#;
        assert_eq!(
            SiteList::parse(&format!("\u{feff}{one}"), false, "s").unwrap(),
            SiteList::parse(one, false, "s").unwrap()
        );
        let missing = refused("sites = [{ x_um = 1.0 }]", true);
        assert!(missing.contains("needs `y_um`"), "{missing}");
        let bare = refused(r#" [{"x_um": 0, "y_um": 0}]"#, false);
        assert!(bare.contains("not a bare array"), "{bare}");
        let ok = SiteList::parse(r#"{"sites": [{"x_um": 1, "y_um": 2.5}]}"#, false, "s").unwrap();
        assert_eq!(
            ok.sites[0],
            SiteEntry {
                x_um: 1.0,
                y_um: 2.5
            }
        );
    }

    #[test]
    fn toml_and_json_round_trip() {
        let list = SiteList {
            sites: vec![
                SiteEntry {
                    x_um: 0.0,
                    y_um: 1.5,
                },
                SiteEntry {
                    x_um: 11.0,
                    y_um: 1.5,
                },
            ],
        };
        let t = toml::to_string(&list).unwrap();
        assert_eq!(SiteList::parse(&t, true, "t").unwrap(), list);
        let j = serde_json::to_string(&list).unwrap();
        assert_eq!(SiteList::parse(&j, false, "j").unwrap(), list);
        let p = list.to_pattern("t").unwrap();
        assert!((p.offsets_m[1].x - p.offsets_m[0].x - 11e-6).abs() < 1e-15);
        assert!(matches!(
            SiteList { sites: vec![] }.to_pattern("e"),
            Err(PatternError::Empty(_))
        ));
    }
}
