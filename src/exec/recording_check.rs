//! Checks of a recording's numbers on read, by the planner's rules: a
//! field, site, calibration, offset or frame size that cannot be right is
//! refused naming its file and field, before any frame is analysed.
//! Unchecked, such a recording made every frame's plan fail (and the
//! dry-run exit 0), planned pushes off the field, or never ended.

use super::recording::{RecordingError, RecordingSpec, StageLogEntry};
use crate::plan::layout::{UM_PER_M, um_text};
use crate::plan::{
    Layout, MAX_COORDINATE_UM, Pattern, PlanConfig, PlanError, Site, coordinate_in_range,
};
use crate::vision::frame::check_one_size;
use crate::vision::frame_input::{Channel, file_name_text, load_frame};
use nalgebra::Vector2;
use std::path::{Path, PathBuf};

/// `keep_clear_um`, `field_um` and `sites_um`: finite, within a metre, sites apart by a
/// particle diameter and (with a field) in the field as a layout's particles.
pub(super) fn check_spec(spec: &RecordingSpec) -> Result<(), String> {
    if let Some(um) = spec.keep_clear_um {
        let asked = PlanConfig {
            keep_clear_m: um / UM_PER_M,
            ..PlanConfig::default()
        };
        asked.validate().map_err(|e| match e {
            PlanError::Config(why) => why,
            other => other.to_string(),
        })?;
    }
    let field = match spec.field_um {
        Some([w, h]) => {
            let ok = |v: f64| v > 0.0 && coordinate_in_range(v);
            if !(ok(w) && ok(h)) {
                return Err(format!(
                    "field_um is [{}, {}] (each must be finite, > 0 and at most {} um)",
                    um_text(w, 3),
                    um_text(h, 3),
                    um_text(MAX_COORDINATE_UM, 0)
                ));
            }
            Some([w / UM_PER_M, h / UM_PER_M])
        }
        None => None,
    };
    let Some(sites_um) = &spec.sites_um else {
        return Ok(());
    };
    if sites_um.is_empty() {
        // A dry-run of no site said "every site is filled" and exited 0.
        return Err(
            "sites_um is empty: name at least one site, or give pattern_text or pattern".into(),
        );
    }
    let radius_m = spec.particle_radius_um / UM_PER_M;
    let sites = sites_of(sites_um)?;
    if let Some(field_m) = field {
        check_sites_in_field(&sites, field_m, radius_m)?;
    }
    let pattern = Pattern {
        offsets_m: sites.iter().map(|s| s.centre_m).collect(),
    };
    pattern
        .check_no_overlap(2.0 * radius_m)
        .map_err(|e| format!("sites_um: {e}"))
}

/// The sites of `sites_um`, ids from 0, each finite and within a metre.
pub(crate) fn sites_of(sites_um: &[[f64; 2]]) -> Result<Vec<Site>, String> {
    sites_um
        .iter()
        .enumerate()
        .map(|(id, &[x, y])| {
            if !(coordinate_in_range(x) && coordinate_in_range(y)) {
                return Err(format!(
                    "sites_um: site {id} at ({}, {}) um is not a finite position within {} um (a metre) of the origin",
                    um_text(x, 3),
                    um_text(y, 3),
                    um_text(MAX_COORDINATE_UM, 0)
                ));
            }
            Ok(Site {
                id: id as u32,
                centre_m: Vector2::new(x, y) / UM_PER_M,
            })
        })
        .collect()
}

/// Every site lies in the field as a layout's particle must.
pub(crate) fn check_sites_in_field(
    sites: &[Site],
    field_m: [f64; 2],
    radius_m: f64,
) -> Result<(), String> {
    let layout = Layout {
        field_m,
        particles: Vec::new(),
    };
    sites
        .iter()
        .try_for_each(|s| layout.check_site_in_field(s, radius_m))
        .map_err(|e| format!("sites_um: {e}"))
}

/// A stage-log line's positions are finite and within a metre.
pub(super) fn check_stage_entry(e: &StageLogEntry) -> Result<(), String> {
    let far = |v: &[f64]| !v.iter().all(|&c| coordinate_in_range(c));
    let text = |v: &[f64]| {
        let parts: Vec<String> = v.iter().map(|&c| um_text(c, 3)).collect();
        format!("[{}]", parts.join(", "))
    };
    let bad = if far(&e.coarse_offset_um) {
        Some(("coarse_offset_um", text(&e.coarse_offset_um)))
    } else {
        e.stage_um
            .filter(|p| far(p))
            .map(|p| ("stage_um", text(&p)))
    };
    match bad {
        Some((what, value)) => Err(format!(
            "{what} is {value}: not a finite position within {} um (a metre) of the origin",
            um_text(MAX_COORDINATE_UM, 0)
        )),
        None => Ok(()),
    }
}

/// Every image of a frames folder is the size of the first (the animation
/// and the view are one size), read from the files' headers before any
/// frame is analysed; a file whose header the `image` crate cannot read is
/// decoded whole (a TIFF of wide samples), so one that cannot be a frame is
/// refused here, named. Videos and stacks are checked as they are read.
pub(super) fn check_frame_sizes(
    files: &[PathBuf],
    frames_path: &Path,
    channel: Channel,
) -> Result<(), RecordingError> {
    let sizes = files
        .iter()
        .map(|file| match image::image_dimensions(file) {
            Ok((w, h)) => Ok((w as usize, h as usize)),
            Err(_) => load_frame(file, channel).map(|f| (f.width(), f.height())),
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| RecordingError::Format {
            path: frames_path.to_owned(),
            message: e.to_string(),
        })?;
    check_one_size(&sizes, |k| file_name_text(&files[k])).map_err(|message| {
        RecordingError::Mismatch {
            path: frames_path.to_owned(),
            message,
        }
    })
}
