//! The `nanopush.plan/1` JSON file (micrometres, degrees), written and read back.

use super::layout::um_in_file;
use super::pattern::Site;
use super::value_sign::Sign;
use super::{Plan, PlanConfig, PlanSummary, Step};
use nalgebra::Vector2;
use rustc_hash::FxHashSet;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Schema tag of plan files.
pub const PLAN_SCHEMA: &str = "nanopush.plan/1";

/// Errors reading or writing a plan file.
#[derive(Debug, thiserror::Error)]
pub enum PlanFileError {
    /// I/O failure.
    #[error("plan file {path}: {source}")]
    Io {
        /// Path.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// Not valid plan JSON.
    #[error("plan file {path}: not a valid nanopush.plan/1 document: {source}")]
    Parse {
        /// Path.
        path: String,
        /// Cause.
        source: serde_json::Error,
    },
    /// What is wrong with a file's plan, named by the file.
    #[error("plan file {path}: {}", .inner.to_string().trim_start_matches("plan file: "))]
    InFile {
        /// Path of the file.
        path: String,
        /// What is wrong.
        inner: Box<PlanFileError>,
    },
    /// Wrong schema tag.
    #[error("plan schema is {0:?}, expected \"nanopush.plan/1\"")]
    Schema(String),
    /// A value is not finite.
    #[error("plan file: {0} is not finite")]
    NotFinite(String),
    /// A value is finite but outside its range.
    #[error("plan file: {0}")]
    OutOfRange(String),
    /// The sites and the assignment do not agree (a site id twice, a pair
    /// naming no site, a site or a particle assigned twice).
    #[error("plan file: {0}")]
    Inconsistent(String),
}

#[derive(Debug, Serialize, Deserialize)]
struct SiteJ {
    id: u32,
    x_um: f64,
    y_um: f64,
}

#[derive(Debug, Serialize, Deserialize)]
struct PairJ {
    particle: u32,
    site: u32,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum StepJ {
    Push {
        particle: u32,
        from_um: [f64; 2],
        to_um: [f64; 2],
        approach_um: [f64; 2],
        contact_angle_deg: f64,
    },
    TipTravel {
        from_um: [f64; 2],
        to_um: [f64; 2],
    },
    CoarseMove {
        centre_um: [f64; 2],
    },
}

/// Geometry the replay needs to rebuild corridors.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct PlanGeometry {
    /// Tip disc radius, um.
    pub tip_radius_um: f64,
    /// Landing distance behind contact, um.
    pub standoff_um: f64,
    /// Nanostage range, um.
    pub nanostage_range_um: f64,
}

/// What `nanopush plan` plans with by default: a plan file of another tool
/// may leave its geometry out (the plan fields do not name it).
impl Default for PlanGeometry {
    fn default() -> Self {
        Self::of_config(&PlanConfig::default())
    }
}

impl PlanGeometry {
    /// `nanopush plan`'s geometry for particles of `radius_m` (the tip
    /// scaled to them, [`PlanConfig::with_tip_scaled_to`]): what a plan
    /// that gives none is replayed with.
    pub fn for_particle_radius(radius_m: f64) -> Self {
        Self::of_config(&PlanConfig::default().with_tip_scaled_to(radius_m))
    }

    fn of_config(c: &PlanConfig) -> Self {
        PlanGeometry {
            tip_radius_um: c.tip_radius_m * 1e6,
            standoff_um: c.standoff_m * 1e6,
            nanostage_range_um: c.nanostage_range_m * 1e6,
        }
    }
}

impl PlanGeometry {
    /// The values by their file names, for checks and messages.
    pub fn named(&self) -> [(&'static str, f64); 3] {
        [
            ("tip_radius_um", self.tip_radius_um),
            ("standoff_um", self.standoff_um),
            ("nanostage_range_um", self.nanostage_range_um),
        ]
    }

    /// Refuses a tip of no size (it touches nothing), a stage of no range
    /// (it reaches nothing) and a metre or more of either (`plan` refuses
    /// them too); the tip may land at its contact point. Names the value.
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in self.named() {
            let sign = if name == "standoff_um" {
                Sign::NonNegative
            } else {
                Sign::Positive
            };
            if !v.is_finite() {
                return Err(format!("{name} is {v} (must be finite)"));
            }
            if !sign.holds(v) {
                return Err(format!("{name} is {v} (must be {})", sign.bound()));
            }
            if !super::coordinate_in_range(v) {
                return Err(format!(
                    "{name} is {v} (a metre or more: no probe or stage is)"
                ));
            }
        }
        Ok(())
    }
}

/// The planner's figures: written for the reader, not replayed, so
/// another tool may leave out any of them (or write null for a figure it
/// has not got: serde_json writes a non-finite number so).
#[derive(Debug, Serialize, Deserialize, Default)]
#[serde(default)]
struct SummaryJ {
    #[serde(deserialize_with = "zero_if_null")]
    pushes: usize,
    #[serde(deserialize_with = "zero_if_null")]
    buffer_pushes: usize,
    #[serde(deserialize_with = "nan_if_null")]
    push_distance_um: f64,
    #[serde(deserialize_with = "nan_if_null")]
    tip_travel_um: f64,
    #[serde(deserialize_with = "nan_if_null")]
    lb_push_um: f64,
    #[serde(deserialize_with = "nan_if_null")]
    lb_tip_um: f64,
    #[serde(deserialize_with = "nan_if_null")]
    push_ratio: f64,
    #[serde(deserialize_with = "nan_if_null")]
    total_ratio: f64,
    #[serde(deserialize_with = "zero_if_null")]
    coarse_moves: usize,
    #[serde(deserialize_with = "nan_if_null")]
    predicted_time_s: f64,
    #[serde(deserialize_with = "nan_if_null")]
    planning_time_s: f64,
}

fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

fn zero_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    Ok(Option::<usize>::deserialize(d)?.unwrap_or(0))
}

#[derive(Debug, Serialize, Deserialize)]
struct PlanJ {
    schema: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    geometry: Option<PlanGeometry>,
    sites: Vec<SiteJ>,
    assignment: Vec<PairJ>,
    steps: Vec<StepJ>,
    #[serde(default, deserialize_with = "default_if_null")]
    summary: SummaryJ,
}

/// `"summary": null` reads as no summary, as a missing one does.
fn default_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<SummaryJ, D::Error> {
    Ok(Option::<SummaryJ>::deserialize(d)?.unwrap_or_default())
}

fn um(v: Vector2<f64>) -> [f64; 2] {
    [um_in_file(v.x), um_in_file(v.y)]
}
fn m(v: [f64; 2], what: &str) -> Result<Vector2<f64>, PlanFileError> {
    if !v[0].is_finite() || !v[1].is_finite() {
        return Err(PlanFileError::NotFinite(what.into()));
    }
    if !v.iter().all(|&c| super::coordinate_in_range(c)) {
        return Err(PlanFileError::OutOfRange(format!(
            "{what} is ({:e}, {:e}) um, not within {:e} um (a metre) of the origin",
            v[0],
            v[1],
            super::MAX_COORDINATE_UM
        )));
    }
    Ok(Vector2::new(v[0] * 1e-6, v[1] * 1e-6))
}

/// Ratio a / b, 1 when both are zero, infinite-free (0 when only b is zero).
pub fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 {
        a / b
    } else if a == 0.0 {
        1.0
    } else {
        0.0
    }
}

/// Summary as the JSON object the CLI prints with `--json`.
pub fn summary_json(s: &PlanSummary) -> serde_json::Value {
    serde_json::to_value(summary_j(s)).expect("summary serialises")
}

fn summary_j(s: &PlanSummary) -> SummaryJ {
    SummaryJ {
        pushes: s.pushes,
        buffer_pushes: s.buffer_pushes,
        push_distance_um: s.push_distance_m * 1e6,
        tip_travel_um: s.tip_travel_m * 1e6,
        lb_push_um: s.lb_push_m * 1e6,
        lb_tip_um: s.lb_tip_m * 1e6,
        push_ratio: ratio(s.push_distance_m, s.lb_push_m),
        total_ratio: ratio(s.push_distance_m + s.tip_travel_m, s.lb_push_m + s.lb_tip_m),
        coarse_moves: s.coarse_moves,
        predicted_time_s: s.predicted_time_s,
        planning_time_s: s.planning_time_s,
    }
}

/// Geometry block of `plan`, made with `config`.
pub fn geometry_of(plan: &Plan, config: &PlanConfig) -> PlanGeometry {
    PlanGeometry {
        tip_radius_um: config.tip_radius_m * 1e6,
        standoff_um: plan.standoff_m * 1e6,
        nanostage_range_um: config.nanostage_range_m * 1e6,
    }
}

/// Serialises a plan to `nanopush.plan/1` JSON.
pub fn to_json(plan: &Plan, config: &PlanConfig) -> String {
    let file = PlanJ {
        schema: PLAN_SCHEMA.into(),
        geometry: Some(geometry_of(plan, config)),
        sites: plan
            .sites
            .iter()
            .map(|s| SiteJ {
                id: s.id,
                x_um: um_in_file(s.centre_m.x),
                y_um: um_in_file(s.centre_m.y),
            })
            .collect(),
        assignment: plan
            .assignment
            .iter()
            .map(|&(p, s)| PairJ {
                particle: p,
                site: s,
            })
            .collect(),
        steps: plan
            .steps
            .iter()
            .map(|s| match *s {
                Step::Push {
                    particle,
                    from_m,
                    to_m,
                    approach_m,
                    contact_angle_rad,
                } => StepJ::Push {
                    particle,
                    from_um: um(from_m),
                    to_um: um(to_m),
                    approach_um: um(approach_m),
                    contact_angle_deg: contact_angle_rad.to_degrees(),
                },
                Step::TipTravel { from_m, to_m } => StepJ::TipTravel {
                    from_um: um(from_m),
                    to_um: um(to_m),
                },
                Step::CoarseMove { centre_m } => StepJ::CoarseMove {
                    centre_um: um(centre_m),
                },
            })
            .collect(),
        summary: summary_j(&plan.summary),
    };
    serde_json::to_string_pretty(&file).expect("plan serialises")
}

/// Parses `nanopush.plan/1` JSON; returns the plan and its geometry, `None`
/// when the file gives none (the replay then takes [`PlanGeometry::default`]).
pub fn from_json(text: &str, origin: &str) -> Result<(Plan, Option<PlanGeometry>), PlanFileError> {
    let text = crate::byte_order_mark::without_bom(text);
    let f: PlanJ = serde_json::from_str(text).map_err(|source| {
        // Another file's schema first: a layout given as the plan had been
        // "missing field `sites`".
        match crate::file_schema::other_json_schema(text, PLAN_SCHEMA) {
            Some(s) => PlanFileError::Schema(s),
            None => PlanFileError::Parse {
                path: origin.into(),
                source,
            },
        }
    })?;
    if f.schema != PLAN_SCHEMA {
        return Err(PlanFileError::Schema(f.schema));
    }
    if let Some(g) = &f.geometry {
        g.check().map_err(PlanFileError::OutOfRange)?;
    }
    let mut sites = Vec::new();
    for s in &f.sites {
        sites.push(Site {
            id: s.id,
            centre_m: m([s.x_um, s.y_um], &format!("site {}", s.id))?,
        });
    }
    let mut steps = Vec::new();
    for (i, s) in f.steps.iter().enumerate() {
        let w = format!("step {i}");
        steps.push(match *s {
            StepJ::Push {
                particle,
                from_um,
                to_um,
                approach_um,
                contact_angle_deg,
            } => {
                if !super::contact_angle_in_range(contact_angle_deg) {
                    return Err(PlanFileError::OutOfRange(format!(
                        "{w} contact_angle_deg is {contact_angle_deg} (must be in 0..90)"
                    )));
                }
                Step::Push {
                    particle,
                    from_m: m(from_um, &w)?,
                    to_m: m(to_um, &w)?,
                    approach_m: m(approach_um, &w)?,
                    contact_angle_rad: contact_angle_deg.to_radians(),
                }
            }
            StepJ::TipTravel { from_um, to_um } => Step::TipTravel {
                from_m: m(from_um, &w)?,
                to_m: m(to_um, &w)?,
            },
            StepJ::CoarseMove { centre_um } => Step::CoarseMove {
                centre_m: m(centre_um, &w)?,
            },
        });
    }
    let s = &f.summary;
    let summary = PlanSummary {
        pushes: s.pushes,
        buffer_pushes: s.buffer_pushes,
        push_distance_m: s.push_distance_um * 1e-6,
        tip_travel_m: s.tip_travel_um * 1e-6,
        lb_push_m: s.lb_push_um * 1e-6,
        lb_tip_m: s.lb_tip_um * 1e-6,
        coarse_moves: s.coarse_moves,
        predicted_time_s: s.predicted_time_s,
        planning_time_s: s.planning_time_s,
    };
    let assignment = assignment_of(&f.sites, &f.assignment)?;
    Ok((
        Plan {
            sites,
            assignment,
            steps,
            summary,
            standoff_m: f.geometry.unwrap_or_default().standoff_um * 1e-6,
        },
        f.geometry,
    ))
}

/// Writes a plan file.
pub fn write(plan: &Plan, config: &PlanConfig, path: &Path) -> Result<(), PlanFileError> {
    std::fs::write(path, to_json(plan, config)).map_err(|source| PlanFileError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// The (particle, site) pairs, each site among `sites` (ids unique) and
/// each site and particle at most once: a plan that assigns a site twice
/// would verify on whichever of its particles lands there.
fn assignment_of(sites: &[SiteJ], pairs: &[PairJ]) -> Result<Vec<(u32, u32)>, PlanFileError> {
    let mut site_ids = FxHashSet::default();
    if let Some(s) = sites.iter().find(|s| !site_ids.insert(s.id)) {
        return Err(PlanFileError::Inconsistent(format!(
            "site id {} appears twice",
            s.id
        )));
    }
    let (mut sites_taken, mut particles_taken) = (FxHashSet::default(), FxHashSet::default());
    for (k, a) in pairs.iter().enumerate() {
        let problem = if !site_ids.contains(&a.site) {
            "names no site of the plan"
        } else if !sites_taken.insert(a.site) {
            "assigns its site a second time"
        } else if !particles_taken.insert(a.particle) {
            "assigns its particle a second time"
        } else {
            continue;
        };
        return Err(PlanFileError::Inconsistent(format!(
            "assignment {k} (particle {}, site {}) {problem}",
            a.particle, a.site
        )));
    }
    Ok(pairs.iter().map(|a| (a.particle, a.site)).collect())
}

/// Reads a plan file (its geometry as [`from_json`]).
pub fn read(path: &Path) -> Result<(Plan, Option<PlanGeometry>), PlanFileError> {
    let text = std::fs::read_to_string(path).map_err(|source| PlanFileError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let origin = path.display().to_string();
    from_json(&text, &origin).map_err(|e| match e {
        PlanFileError::Io { .. } | PlanFileError::Parse { .. } => e,
        inner => PlanFileError::InFile {
            path: origin,
            inner: Box::new(inner),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::pattern::numbered_sites;
    use crate::plan::{Layout, plan_assembly};

    /// A one-push plan as written, parsed for editing, and its push's step.
    fn one_push_document() -> (serde_json::Value, usize) {
        let layout = Layout::of_test_centres_um(&[(50.0, 50.0)]);
        let sites = numbered_sites([Vector2::new(80e-6, 50e-6)]);
        let config = PlanConfig::default();
        let plan = plan_assembly(&layout, &sites, &config).unwrap();
        let doc: serde_json::Value = serde_json::from_str(&to_json(&plan, &config)).unwrap();
        let step = doc["steps"]
            .as_array()
            .unwrap()
            .iter()
            .position(|s| s["kind"] == "push")
            .unwrap();
        (doc, step)
    }

    /// Another tool's plan with a contact angle no tip can push at is
    /// refused by step; one inside 0..90 reads back as written.
    #[test]
    fn a_push_at_an_angle_no_tip_pushes_at_is_refused_by_step() {
        let (mut doc, step) = one_push_document();
        for (angle, ok) in [
            (45.0, true),
            (0.0, true),
            (90.0, false),
            (-5.0, false),
            (120.0, false),
        ] {
            doc["steps"][step]["contact_angle_deg"] = angle.into();
            match from_json(&doc.to_string(), "edited") {
                Ok((plan, _)) => {
                    assert!(ok, "{angle} deg was read");
                    let Step::Push {
                        contact_angle_rad, ..
                    } = plan.steps[step]
                    else {
                        panic!("step {step} is not a push")
                    };
                    assert!((contact_angle_rad.to_degrees() - angle).abs() < 1e-9);
                }
                Err(PlanFileError::OutOfRange(what)) => {
                    assert!(!ok, "{angle} deg was refused: {what}");
                    assert!(
                        what.contains(&format!("step {step} contact_angle_deg")),
                        "{what}"
                    );
                }
                Err(e) => panic!("{angle} deg: {e}"),
            }
        }
    }

    /// A plan saved with a byte-order mark (a Windows editor's) reads as
    /// without it: serde_json had refused it at "line 1 column 1".
    #[test]
    fn a_byte_order_mark_is_not_the_plan() {
        let (doc, _) = one_push_document();
        let text = doc.to_string();
        let plain = from_json(&text, "plain").unwrap();
        let marked = from_json(&format!("\u{feff}{text}"), "marked").unwrap();
        assert_eq!(marked.0, plain.0);
    }

    /// A point a metre or more out is refused by step (its distances would
    /// overflow to infinity in the replay).
    #[test]
    fn a_point_beyond_a_metre_is_refused_by_step() {
        let (mut doc, step) = one_push_document();
        doc["steps"][step]["to_um"] = serde_json::json!([1e300, 0.0]);
        match from_json(&doc.to_string(), "edited") {
            Err(PlanFileError::OutOfRange(what)) => {
                assert!(what.contains(&format!("step {step}")), "{what}");
                assert!(what.contains("1e300"), "{what}");
            }
            other => panic!("{other:?}"),
        }
    }

    /// A tip of no size or a negative one, or a stage of no range, is
    /// refused with its value (-1 had been called "not finite", 0 read and
    /// verified although `plan` refuses it).
    #[test]
    fn a_geometry_of_no_tip_or_no_range_is_refused_with_its_value() {
        let (doc, _) = one_push_document();
        for (key, value, want) in [
            ("tip_radius_um", -1.0, "tip_radius_um is -1 (must be > 0)"),
            ("tip_radius_um", 0.0, "tip_radius_um is 0 (must be > 0)"),
            (
                "nanostage_range_um",
                0.0,
                "nanostage_range_um is 0 (must be > 0)",
            ),
            ("standoff_um", -0.5, "standoff_um is -0.5 (must be >= 0)"),
            (
                "tip_radius_um",
                2e6,
                "tip_radius_um is 2000000 (a metre or more",
            ),
            (
                "nanostage_range_um",
                1e7,
                "nanostage_range_um is 10000000 (a metre",
            ),
        ] {
            let mut d = doc.clone();
            d["geometry"][key] = value.into();
            let e = from_json(&d.to_string(), "edited").unwrap_err().to_string();
            assert!(e.contains(want), "{key} {value}: {e}");
        }
        let mut d = doc.clone();
        d["geometry"]["standoff_um"] = 0.0.into();
        assert!(from_json(&d.to_string(), "edited").is_ok());
    }

    /// Sites and an assignment that disagree are refused, naming the pair;
    /// the plan as written reads back with its assignment.
    #[test]
    fn an_assignment_that_disagrees_with_the_sites_is_refused_by_pair() {
        let (doc, _) = one_push_document();
        let (plan, _) = from_json(&doc.to_string(), "as written").unwrap();
        assert_eq!(plan.assignment, vec![(0, 0)]);
        let edits: [(&str, serde_json::Value, &str); 4] = [
            (
                "assignment",
                serde_json::json!([{"particle": 0, "site": 7}]),
                "assignment 0 (particle 0, site 7) names no site",
            ),
            (
                "assignment",
                serde_json::json!([{"particle": 0, "site": 0}, {"particle": 9, "site": 0}]),
                "assignment 1 (particle 9, site 0) assigns its site a second time",
            ),
            (
                "sites",
                serde_json::json!([{"id": 0, "x_um": 80.0, "y_um": 50.0}, {"id": 1, "x_um": 95.0, "y_um": 50.0}]),
                "",
            ),
            (
                "sites",
                serde_json::json!([{"id": 0, "x_um": 80.0, "y_um": 50.0}, {"id": 0, "x_um": 95.0, "y_um": 50.0}]),
                "site id 0 appears twice",
            ),
        ];
        for (field, value, want) in edits {
            let mut d = doc.clone();
            d[field] = value;
            match from_json(&d.to_string(), "edited") {
                Ok(_) => assert!(want.is_empty(), "{field} edit read: want {want}"),
                Err(PlanFileError::Inconsistent(what)) => {
                    assert!(!want.is_empty() && what.contains(want), "{what}")
                }
                Err(e) => panic!("{e}"),
            }
        }
        let mut d = doc.clone();
        d["sites"] = serde_json::json!([{"id": 0, "x_um": 80.0, "y_um": 50.0}, {"id": 1, "x_um": 95.0, "y_um": 50.0}]);
        d["assignment"] =
            serde_json::json!([{"particle": 0, "site": 0}, {"particle": 0, "site": 1}]);
        match from_json(&d.to_string(), "edited") {
            Err(PlanFileError::Inconsistent(what)) => assert!(
                what.contains(
                    "assignment 1 (particle 0, site 1) assigns its particle a second time"
                ),
                "{what}"
            ),
            other => panic!("{other:?}"),
        }
    }

    /// A plan with only the fields the plan format names (schema, sites,
    /// assignment, steps), as another tool writes it, reads: it had been
    /// refused for a missing `geometry`, which the replay then takes from
    /// `nanopush plan`'s defaults. The summary is the planner's figures,
    /// not replayed: any part of it, and a null figure, reads.
    #[test]
    fn a_plan_with_only_the_named_fields_reads() {
        let (doc, step) = one_push_document();
        let bare = serde_json::json!({
            "schema": PLAN_SCHEMA,
            "sites": doc["sites"],
            "assignment": doc["assignment"],
            "steps": [doc["steps"][step]],
        });
        let (plan, geometry) = from_json(&bare.to_string(), "bare").unwrap();
        assert_eq!(geometry, None);
        assert_eq!(plan.steps.len(), 1);
        assert_eq!(plan.standoff_m, PlanConfig::default().standoff_m);
        let mut partial = bare.clone();
        partial["summary"] = serde_json::json!({"pushes": 1, "predicted_time_s": null});
        let (plan, _) = from_json(&partial.to_string(), "partial").unwrap();
        assert_eq!(plan.summary.pushes, 1);
        assert!(plan.summary.predicted_time_s.is_nan());
        for summary in [
            serde_json::json!({"pushes": null, "coarse_moves": null}),
            serde_json::Value::Null,
        ] {
            partial["summary"] = summary;
            let (plan, _) = from_json(&partial.to_string(), "null").unwrap();
            assert_eq!(plan.summary.pushes, 0);
        }
        // Written by nanopush, the geometry is there and reads back.
        let (_, written) = from_json(&doc.to_string(), "written").unwrap();
        assert_eq!(written, Some(PlanGeometry::default()));
    }

    /// A document of another schema is refused with the schema it has.
    #[test]
    fn another_schema_is_refused_by_name() {
        let (mut doc, _) = one_push_document();
        doc["schema"] = "nanopush.plan/2".into();
        match from_json(&doc.to_string(), "edited") {
            Err(PlanFileError::Schema(s)) => assert_eq!(s, "nanopush.plan/2"),
            other => panic!("{other:?}"),
        }
        // A layout given as the plan: its schema, not a missing field.
        let layout = crate::plan::layout::Layout::of_test_centres_um(&[(1.0, 2.0)]).to_json();
        match from_json(&layout, "layout.json") {
            Err(PlanFileError::Schema(s)) => assert_eq!(s, "nanopush.layout/1"),
            other => panic!("{other:?}"),
        }
    }
}
