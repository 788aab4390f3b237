//! Particle layouts: where the particles are before planning.
//!
//! The file format `nanopush.layout/1` is JSON in micrometres; inside the
//! library everything is SI metres. Conversion happens once, here.

use super::Site;
use super::touching::{Overlap, TOUCHING_OVERLAP_FRACTION, settle_overlaps};
use super::value_sign::Sign;
use crate::wording::counted;
use nalgebra::Vector2;
use rustc_hash::FxHashMap;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Schema tag written into and required from every layout file.
pub const LAYOUT_SCHEMA: &str = "nanopush.layout/1";

/// Micrometres per metre, the lab unit of every file the planner reads or writes.
pub const UM_PER_M: f64 = 1e6;

/// Metres as the micrometres a file holds: rounded to 1e-9 um (a
/// femtometre, below any measurement), so that a 120 um field is written
/// 120, not 119.99999999999999 (a script comparing `field_um == [120,
/// 100]` had failed), and reads back within half a femtometre.
pub fn um_in_file(m: f64) -> f64 {
    (m * UM_PER_M * 1e9).round() / 1e9
}

/// One particle: an identifier the rest of the pipeline keeps, a centre and a radius (SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Particle {
    /// Stable identifier (from the layout file or from detection).
    pub id: u32,
    /// Centre in stage coordinates, metres.
    pub centre_m: Vector2<f64>,
    /// Radius in metres.
    pub radius_m: f64,
}

/// A field of particles: the planner's view of the world before planning.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Width and height of the work field in metres; the origin is its lower-left corner.
    pub field_m: [f64; 2],
    /// Every particle in the field.
    pub particles: Vec<Particle>,
}

/// A layout file's particles and the ids of those it marks `"immovable"`:
/// obstacles a plan must never push (a frame's edge cut them, so their
/// centres were never measured). Kept beside [`Layout`], not in it: only
/// planning and its replay heed the mark, the simulated world does not.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkedLayout {
    /// The particles and the field.
    pub layout: Layout,
    /// Ids of the particles a plan must leave where they are, in file order.
    pub immovable: Vec<u32>,
}

/// Everything that can be wrong with a layout, and where.
#[derive(Debug, thiserror::Error)]
pub enum LayoutError {
    /// The file could not be read or written.
    #[error("layout file {path}: {source}")]
    Io {
        /// Path of the file.
        path: String,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The JSON did not parse into the layout schema.
    #[error("layout file {path}: not a valid nanopush.layout/1 document: {source}")]
    Parse {
        /// Path of the file.
        path: String,
        /// Underlying JSON error.
        source: serde_json::Error,
    },
    /// A particle's `immovable` is not a boolean (serde would name neither
    /// the particle nor the key).
    #[error("layout file {path}: particle {id} immovable is {found} (must be true or false)")]
    ImmovableNotBoolean {
        /// Path of the file.
        path: String,
        /// Particle id.
        id: u32,
        /// The value found, as JSON text.
        found: String,
    },
    /// What is wrong with a file's layout, named by the file (a message
    /// like "layout: particles 1 and 3 overlap" had not said which file).
    #[error("layout file {path}: {}", .inner.to_string().trim_start_matches("layout: "))]
    InFile {
        /// Path of the file.
        path: String,
        /// What is wrong.
        inner: Box<LayoutError>,
    },
    /// The schema field names another kind or version.
    #[error("layout schema is {found:?}, expected {LAYOUT_SCHEMA:?}")]
    Schema {
        /// The schema found.
        found: String,
    },
    /// A value is NaN, infinite, negative or zero where it must be positive.
    #[error("layout: {what} is {} (must be finite{needs})", short_text(*value))]
    BadValue {
        /// Which value, e.g. "particle 3 radius_um".
        what: String,
        /// The offending value.
        value: f64,
        /// The requirement besides finite, e.g. " and > 0".
        needs: &'static str,
    },
    /// Two particles share an identifier.
    #[error("layout: particle id {0} appears twice")]
    DuplicateId(u32),
    /// Two particles overlap (their discs intersect by more than the tolerance).
    #[error(
        "layout: particles {a} and {b} overlap by {overlap_um:.3} um, more than the {allowed_um:.3} um read as touching"
    )]
    Overlap {
        /// First particle id.
        a: u32,
        /// Second particle id.
        b: u32,
        /// Overlap depth in micrometres.
        overlap_um: f64,
        /// The deepest overlap read as touching for this pair, micrometres.
        allowed_um: f64,
    },
    /// A particle far outside the field: coordinates in another unit or
    /// from another origin, most often.
    #[error(
        "layout: particle {} (positions are in um from the field's lower-left corner)",
        .0.where_off()
    )]
    OutsideField(OffField),
    /// A target site far outside the field: the planner would push a
    /// particle there in pieces the nanostage can reach, without bound.
    #[error(
        "site {} (sites are in um from the field's lower-left corner)",
        .0.where_off()
    )]
    SiteOutsideField(OffField),
    /// A field wider than any stage: a size in another unit, most often.
    #[error(
        "layout: field {what} is {} (must be at most {} um, a metre)",
        um_text(*.value, 1),
        um_text(crate::plan::MAX_COORDINATE_UM, 0)
    )]
    FieldTooLarge {
        /// "width_um" or "height_um".
        what: &'static str,
        /// The size, micrometres.
        value: f64,
    },
    /// A particle no probe pushes: a layout in nm read as um.
    #[error(
        "layout: particle {id} radius_um {} is over {} um, no particle a probe pushes: layout files are in um (is this one in nm?)",
        um_text(*.radius_um, 3),
        um_text(MAX_RADIUS_UM, 0)
    )]
    RadiusNotMicro {
        /// Particle id.
        id: u32,
        /// Radius, micrometres.
        radius_um: f64,
    },
    /// A particle wider than the field it lies in.
    #[error(
        "layout: particle {id} radius_um {} is too large for the {} x {} um field",
        um_text(*.radius_um, 3),
        um_text(*.width_um, 1),
        um_text(*.height_um, 1)
    )]
    LargerThanField {
        /// Particle id.
        id: u32,
        /// Radius, micrometres.
        radius_um: f64,
        /// Field width, micrometres.
        width_um: f64,
        /// Field height, micrometres.
        height_um: f64,
    },
}

/// The largest particle radius a layout holds, um: a millimetre across is
/// past what a probe under a microscope pushes, and a layout of 10 um
/// particles written in nm (radius 5,000) had planned 1,239 pushes over a
/// 12 cm field.
pub const MAX_RADIUS_UM: f64 = 500.0;

/// Wire format of a layout file (micrometres).
#[derive(Debug, Serialize, Deserialize)]
struct LayoutFile {
    schema: String,
    field_um: [f64; 2],
    particles: Vec<ParticleFile>,
}

#[derive(Debug, Serialize, Deserialize)]
struct ParticleFile {
    id: u32,
    x_um: f64,
    y_um: f64,
    radius_um: f64,
    /// Written only when true, so that files of tools without the mark
    /// read the same; read as any value (null too) so that a non-boolean is
    /// refused naming its particle.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "present"
    )]
    immovable: Option<serde_json::Value>,
}

/// A key's value, `Some` even when it is null (absent is `None`, by `default`).
fn present<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<serde_json::Value>, D::Error> {
    serde_json::Value::deserialize(d).map(Some)
}

/// Overlap (metres) tolerated between particles, to absorb rounding in files.
const OVERLAP_TOLERANCE_M: f64 = 1e-9;

/// How far outside the field a particle's centre may lie, in its radii. A
/// frame's edge may cut a particle (its centre then lies up to a radius
/// out, more with the locator's error); a centre further out than this has
/// no part within a radius of the field, which is a layout in the wrong
/// unit or origin rather than a particle of this field.
const OUTSIDE_FIELD_RADII: f64 = 2.0;

/// How far `c` lies outside the field `field_m` (from the origin), metres
/// (0 inside; NaN for a NaN coordinate, which `f64::max` would otherwise drop).
pub fn beyond_field_m(field_m: [f64; 2], c: Vector2<f64>) -> f64 {
    if c.x.is_nan() || c.y.is_nan() {
        return f64::NAN;
    }
    let out = |v: f64, size: f64| (-v).max(v - size).max(0.0);
    out(c.x, field_m[0]).hypot(out(c.y, field_m[1]))
}

/// True when a particle of `radius_m` centred at `c` may be in a layout of
/// the field `field_m` (at most two radii beyond an
/// edge): what a camera sees beyond that is out of the plan's reach.
pub fn may_lie_in_field(field_m: [f64; 2], c: Vector2<f64>, radius_m: f64) -> bool {
    beyond_field_m(field_m, c) <= OUTSIDE_FIELD_RADII * radius_m
}

/// `value` with `decimals` decimals, or in exponent form when a mistyped
/// input (a position, an --at or a --pitch-um of 1e300) makes it too long
/// to read: the planner's error messages print sizes with it.
pub(crate) fn um_text(value: f64, decimals: usize) -> String {
    if value.abs() < 1e9 || !value.is_finite() {
        format!("{value:.decimals$}")
    } else {
        format!("{value:.3e}")
    }
}

/// `value` as a person wrote it: six decimals at most, trailing zeros
/// dropped, exponent form when that would hide it ("-120", not the
/// "-119.99999999999999" a width in um took through metres and back).
fn short_text(value: f64) -> String {
    let tiny = value != 0.0 && value.abs() < 1e-6;
    if !value.is_finite() || tiny || value.abs() >= 1e9 {
        return format!("{value:e}");
    }
    let fixed = format!("{value:.6}");
    let trimmed = fixed.trim_end_matches('0').trim_end_matches('.');
    match trimmed {
        "-0" => "0".to_owned(),
        t => t.to_owned(),
    }
}

/// Where a particle or a site lies off its field, and the field's size.
#[derive(Debug, Clone, PartialEq)]
pub struct OffField {
    /// Particle or site id.
    pub id: u32,
    /// Centre, micrometres.
    pub x_um: f64,
    /// Centre, micrometres.
    pub y_um: f64,
    /// Field width, micrometres.
    pub width_um: f64,
    /// Field height, micrometres.
    pub height_um: f64,
}

impl OffField {
    /// "ID at (X, Y) um lies outside the W x H um field", for the errors of
    /// a particle and of a site.
    fn where_off(&self) -> String {
        format!(
            "{} at ({}, {}) um lies outside the {} x {} um field",
            self.id,
            um_text(self.x_um, 3),
            um_text(self.y_um, 3),
            um_text(self.width_um, 1),
            um_text(self.height_um, 1)
        )
    }
}

/// Refuses a value that is NaN, infinite or of the wrong `sign`, naming it.
pub(crate) fn check_finite(what: &str, value: f64, sign: Sign) -> Result<(), LayoutError> {
    match sign.broken_by(value) {
        Some(needs) => Err(LayoutError::BadValue {
            what: what.to_string(),
            value,
            needs,
        }),
        None => Ok(()),
    }
}

impl Layout {
    /// Checks every value is finite, radii positive, ids unique, no two
    /// particles overlap and each lies in the field (at most two radii
    /// beyond an edge).
    pub fn validate(&self) -> Result<(), LayoutError> {
        self.validate_holding(&[])
    }

    /// [`Layout::validate`], with the particles `held` (obstacles never
    /// pushed) allowed anywhere beyond the field: a camera sees past the
    /// nanostage's range, and what it sees there is in the tip's way.
    pub fn validate_holding(&self, held: &[u32]) -> Result<(), LayoutError> {
        self.check(held, |_, _| OVERLAP_TOLERANCE_M)
    }

    /// [`Layout::validate_holding`] for measured particles, read from a
    /// file: two that overlap by at most [`TOUCHING_OVERLAP_FRACTION`] of
    /// the smaller radius are touching, each radius reduced to its share
    /// of their distance ([`settle_overlaps`]). Returns those pairs.
    pub fn validate_touching(&mut self, held: &[u32]) -> Result<Vec<Overlap>, LayoutError> {
        self.check(held, |p, q| {
            (TOUCHING_OVERLAP_FRACTION * p.radius_m.min(q.radius_m)).max(OVERLAP_TOLERANCE_M)
        })?;
        Ok(settle_overlaps(&mut self.particles))
    }

    /// Every value finite, radii positive, ids unique, each particle but
    /// the `held` in the field, and no two overlapping by more than
    /// `allowed(p, q)` metres.
    fn check(
        &self,
        held: &[u32],
        allowed: impl Fn(&Particle, &Particle) -> f64,
    ) -> Result<(), LayoutError> {
        check_finite("field width_um", self.field_m[0] * UM_PER_M, Sign::Positive)?;
        check_finite(
            "field height_um",
            self.field_m[1] * UM_PER_M,
            Sign::Positive,
        )?;
        for (what, m) in [
            ("width_um", self.field_m[0]),
            ("height_um", self.field_m[1]),
        ] {
            if !crate::plan::coordinate_in_range(m * UM_PER_M) {
                return Err(LayoutError::FieldTooLarge {
                    what,
                    value: m * UM_PER_M,
                });
            }
        }
        let mut ids = std::collections::HashSet::new();
        for p in &self.particles {
            check_finite(
                &format!("particle {} x_um", p.id),
                p.centre_m.x * UM_PER_M,
                Sign::Any,
            )?;
            check_finite(
                &format!("particle {} y_um", p.id),
                p.centre_m.y * UM_PER_M,
                Sign::Any,
            )?;
            check_finite(
                &format!("particle {} radius_um", p.id),
                p.radius_m * UM_PER_M,
                Sign::Positive,
            )?;
            if !ids.insert(p.id) {
                return Err(LayoutError::DuplicateId(p.id));
            }
            if !held.contains(&p.id) {
                self.check_in_field(p)?;
            }
        }
        let grid = crate::plan::grid::Grid::new(
            self.particles.iter().map(|p| p.centre_m),
            self.max_radius_m() * 2.0,
        );
        for (i, p) in self.particles.iter().enumerate() {
            for j in grid.within(p.centre_m, self.max_radius_m() * 2.0) {
                if j <= i {
                    continue;
                }
                let q = &self.particles[j];
                let overlap = p.radius_m + q.radius_m - (p.centre_m - q.centre_m).norm();
                if overlap > allowed(p, q) {
                    return Err(LayoutError::Overlap {
                        a: p.id,
                        b: q.id,
                        overlap_um: overlap * UM_PER_M,
                        allowed_um: allowed(p, q) * UM_PER_M,
                    });
                }
            }
        }
        Ok(())
    }

    /// `p` fits the field and lies in it, or at most
    /// [`OUTSIDE_FIELD_RADII`] of its radii beyond an edge.
    fn check_in_field(&self, p: &Particle) -> Result<(), LayoutError> {
        if p.radius_m * UM_PER_M > MAX_RADIUS_UM {
            return Err(LayoutError::RadiusNotMicro {
                id: p.id,
                radius_um: p.radius_m * UM_PER_M,
            });
        }
        let [w, h] = self.field_m;
        let (width_um, height_um) = (w * UM_PER_M, h * UM_PER_M);
        if 2.0 * p.radius_m > w.min(h) {
            return Err(LayoutError::LargerThanField {
                id: p.id,
                radius_um: p.radius_m * UM_PER_M,
                width_um,
                height_um,
            });
        }
        if !may_lie_in_field(self.field_m, p.centre_m, p.radius_m) {
            return Err(LayoutError::OutsideField(self.off_field(p.id, p.centre_m)));
        }
        Ok(())
    }

    /// A site for particles of `radius_m` lies no farther outside the
    /// field than a particle may (`OUTSIDE_FIELD_RADII`).
    pub fn check_site_in_field(&self, site: &Site, radius_m: f64) -> Result<(), LayoutError> {
        let c = site.centre_m;
        let beyond = beyond_field_m(self.field_m, c);
        if beyond.is_nan() || beyond > OUTSIDE_FIELD_RADII * radius_m {
            return Err(LayoutError::SiteOutsideField(self.off_field(site.id, c)));
        }
        Ok(())
    }

    /// The ids of the particles centred farther beyond the field than a
    /// push may start ([`may_lie_in_field`]): obstacles, held where they are.
    pub fn beyond_field_ids(&self) -> Vec<u32> {
        (self.particles.iter())
            .filter(|p| !may_lie_in_field(self.field_m, p.centre_m, p.radius_m))
            .map(|p| p.id)
            .collect()
    }

    /// The error payload for `id` at `c`, in um.
    fn off_field(&self, id: u32, c: Vector2<f64>) -> OffField {
        OffField {
            id,
            x_um: c.x * UM_PER_M,
            y_um: c.y * UM_PER_M,
            width_um: self.field_m[0] * UM_PER_M,
            height_um: self.field_m[1] * UM_PER_M,
        }
    }

    /// Particle index by id (ids are unique in a valid layout). Hashed
    /// without the std hasher's DoS resistance: the shortcuts look an id up
    /// for every push of every replay (a twentieth of CMU's planning).
    pub fn index_by_id(&self) -> FxHashMap<u32, usize> {
        self.particles
            .iter()
            .enumerate()
            .map(|(i, p)| (p.id, i))
            .collect()
    }

    /// Particles of 5 um radius at `centres_um` (ids 0, 1, ...) in a
    /// 200 x 200 um field: the unit tests' scenes.
    #[cfg(test)]
    pub(crate) fn of_test_centres_um(centres_um: &[(f64, f64)]) -> Self {
        Layout {
            field_m: [200e-6, 200e-6],
            particles: centres_um
                .iter()
                .enumerate()
                .map(|(i, &(x, y))| Particle {
                    id: i as u32,
                    centre_m: Vector2::new(x, y) * 1e-6,
                    radius_m: 5e-6,
                })
                .collect(),
        }
    }

    /// The upper median particle radius (0 for an empty layout): the batch's
    /// size, which a pattern's default pitch is built for.
    pub fn median_radius_m(&self) -> f64 {
        let mut radii: Vec<f64> = self.particles.iter().map(|p| p.radius_m).collect();
        crate::median::upper_median(&mut radii).unwrap_or(0.0)
    }

    /// Smallest particle radius (0 for an empty layout).
    pub fn min_radius_m(&self) -> f64 {
        self.particles
            .iter()
            .map(|p| p.radius_m)
            .reduce(f64::min)
            .unwrap_or(0.0)
    }

    /// Largest particle radius (0 for an empty layout).
    pub fn max_radius_m(&self) -> f64 {
        self.particles
            .iter()
            .map(|p| p.radius_m)
            .fold(0.0, f64::max)
    }

    /// Serialises to the `nanopush.layout/1` JSON text, no particle marked immovable.
    pub fn to_json(&self) -> String {
        file_text(self, &[])
    }

    /// Parses `nanopush.layout/1` JSON text and validates it, ignoring
    /// immovable marks; `origin` names the source in errors.
    pub fn from_json(text: &str, origin: &str) -> Result<Self, LayoutError> {
        MarkedLayout::from_json(text, origin).map(|m| m.layout)
    }

    /// Reads and validates a layout file, ignoring immovable marks (what a
    /// world or a drawing is built from; a plan reads [`MarkedLayout`]).
    pub fn read(path: &Path) -> Result<Self, LayoutError> {
        MarkedLayout::read(path).map(|m| m.layout)
    }

    /// Writes the layout file, no particle marked immovable.
    pub fn write(&self, path: &Path) -> Result<(), LayoutError> {
        write_text(path, &self.to_json())
    }
}

impl MarkedLayout {
    /// Serialises to the `nanopush.layout/1` JSON text, `"immovable": true`
    /// on the marked particles.
    pub fn to_json(&self) -> String {
        file_text(&self.layout, &self.immovable)
    }

    /// Parses `nanopush.layout/1` JSON text and validates it; `origin` names the source in errors.
    pub fn from_json(text: &str, origin: &str) -> Result<Self, LayoutError> {
        let text = crate::byte_order_mark::without_bom(text);
        let file: LayoutFile =
            serde_json::from_str(text).map_err(
                |source| match crate::file_schema::other_json_schema(text, LAYOUT_SCHEMA) {
                    Some(found) => LayoutError::Schema { found },
                    None => LayoutError::Parse {
                        path: origin.to_string(),
                        source,
                    },
                },
            )?;
        if file.schema != LAYOUT_SCHEMA {
            return Err(LayoutError::Schema { found: file.schema });
        }
        let mut immovable = Vec::new();
        for p in &file.particles {
            match &p.immovable {
                None | Some(serde_json::Value::Bool(false)) => {}
                Some(serde_json::Value::Bool(true)) => immovable.push(p.id),
                Some(other) => {
                    return Err(LayoutError::ImmovableNotBoolean {
                        path: origin.to_string(),
                        id: p.id,
                        found: other.to_string(),
                    });
                }
            }
        }
        let mut layout = Layout {
            field_m: [file.field_um[0] / UM_PER_M, file.field_um[1] / UM_PER_M],
            particles: file
                .particles
                .iter()
                .map(|p| Particle {
                    id: p.id,
                    centre_m: Vector2::new(p.x_um / UM_PER_M, p.y_um / UM_PER_M),
                    radius_m: p.radius_um / UM_PER_M,
                })
                .collect(),
        };
        let touching = layout.validate_touching(&immovable)?;
        if let Some(deepest) = touching.first() {
            tracing::warn!(
                "{origin}: {} of particles {} by up to {:.3} um (particles {} and {}): read as touching particles measured a little large, each radius reduced to its share of their distance",
                counted(touching.len(), "pair"),
                if touching.len() == 1 {
                    "overlaps"
                } else {
                    "overlap"
                },
                deepest.depth_m * UM_PER_M,
                deepest.a,
                deepest.b
            );
        }
        Ok(MarkedLayout { layout, immovable })
    }

    /// Reads and validates a layout file with its immovable marks.
    pub fn read(path: &Path) -> Result<Self, LayoutError> {
        let text = std::fs::read_to_string(path).map_err(|source| LayoutError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let origin = path.display().to_string();
        Self::from_json(&text, &origin).map_err(|e| match e {
            LayoutError::Io { .. }
            | LayoutError::Parse { .. }
            | LayoutError::ImmovableNotBoolean { .. } => e,
            inner => LayoutError::InFile {
                path: origin,
                inner: Box::new(inner),
            },
        })
    }

    /// Writes the layout file with its immovable marks.
    pub fn write(&self, path: &Path) -> Result<(), LayoutError> {
        write_text(path, &self.to_json())
    }
}

/// The `nanopush.layout/1` JSON text of `layout`, the particles in
/// `immovable` marked.
fn file_text(layout: &Layout, immovable: &[u32]) -> String {
    let file = LayoutFile {
        schema: LAYOUT_SCHEMA.to_string(),
        field_um: layout.field_m.map(um_in_file),
        particles: layout
            .particles
            .iter()
            .map(|p| ParticleFile {
                id: p.id,
                x_um: um_in_file(p.centre_m.x),
                y_um: um_in_file(p.centre_m.y),
                radius_um: um_in_file(p.radius_m),
                immovable: immovable.contains(&p.id).then_some(true.into()),
            })
            .collect(),
    };
    serde_json::to_string_pretty(&file).expect("layout serialisation cannot fail")
}

/// Writes a layout file's text to `path`.
fn write_text(path: &Path, text: &str) -> Result<(), LayoutError> {
    std::fs::write(path, text).map_err(|source| LayoutError::Io {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bad value reads as it was written, not as its trip through metres.
    #[test]
    fn bad_values_are_written_short() {
        let cases = [
            (-119.99999999999999, "-120"),
            (-5.0, "-5"),
            (0.25, "0.25"),
            (-0.0, "0"),
            (1e-12, "1e-12"),
            (3e12, "3e12"),
            (f64::NAN, "NaN"),
            (f64::NEG_INFINITY, "-inf"),
        ];
        for (value, text) in cases {
            assert_eq!(short_text(value), text, "{value}");
        }
    }

    fn sample() -> Layout {
        Layout {
            field_m: [120e-6, 100e-6],
            particles: vec![
                Particle {
                    id: 0,
                    centre_m: Vector2::new(10e-6, 20e-6),
                    radius_m: 5e-6,
                },
                Particle {
                    id: 7,
                    centre_m: Vector2::new(30.5e-6, 20e-6),
                    radius_m: 5e-6,
                },
            ],
        }
    }

    #[test]
    fn json_round_trip_keeps_every_value() {
        let layout = sample();
        let back = Layout::from_json(&layout.to_json(), "mem").unwrap();
        assert_eq!(back.particles.len(), 2);
        // A plan given as the layout is named by its schema.
        let plan = r#"{"schema": "nanopush.plan/1", "sites": [], "steps": []}"#;
        assert!(matches!(
            Layout::from_json(plan, "p.json"),
            Err(LayoutError::Schema { found }) if found == "nanopush.plan/1"
        ));
        // Saved by a Windows editor, with a byte-order mark: the same.
        let marked = format!("\u{feff}{}", layout.to_json());
        assert_eq!(Layout::from_json(&marked, "mem").unwrap(), back);
        for (a, b) in layout.particles.iter().zip(&back.particles) {
            assert_eq!(a.id, b.id);
            assert!((a.centre_m - b.centre_m).norm() < 1e-15);
            assert!((a.radius_m - b.radius_m).abs() < 1e-15);
        }
        // Whole micrometres are written whole, whatever float noise the
        // metres carry.
        let noisy = Layout {
            field_m: [120.0 * 1e-6, 100.0 * 1e-6],
            ..layout
        };
        assert!(
            noisy
                .to_json()
                .contains("\"field_um\": [\n    120.0,\n    100.0\n  ]"),
            "{}",
            noisy.to_json()
        );
    }

    /// The immovable mark survives a file round trip, is written only on
    /// the particles it marks, and a file without it (another tool's, an
    /// older one) reads as marking none.
    #[test]
    fn immovable_marks_round_trip_and_a_file_without_them_marks_none() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("marked.json");
        let marked = MarkedLayout {
            layout: sample(),
            immovable: vec![7],
        };
        marked.write(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.matches("\"immovable\": true").count(), 1, "{text}");
        assert!(!text.contains("false"), "{text}");
        assert_eq!(MarkedLayout::read(&path).unwrap(), marked);
        // The plain layout of the same file, and a file without the key.
        assert_eq!(Layout::read(&path).unwrap(), sample());
        assert!(!sample().to_json().contains("immovable"));
        let plain = MarkedLayout::from_json(&sample().to_json(), "mem").unwrap();
        assert_eq!(plain.immovable, Vec::<u32>::new());
        let text = text.replace("\"immovable\": true", "\"immovable\": false");
        let unmarked = MarkedLayout::from_json(&text, "mem").unwrap();
        assert_eq!(unmarked.immovable, Vec::<u32>::new());
    }

    /// A value other than true or false is refused naming the file and
    /// the particle: serde's own error named neither.
    #[test]
    fn a_non_boolean_immovable_is_refused_naming_file_and_particle() {
        let marked = MarkedLayout {
            layout: sample(),
            immovable: vec![7],
        };
        for (value, shown) in [("\"yes\"", "\"yes\""), ("1", "1"), ("null", "null")] {
            let text = marked
                .to_json()
                .replace("\"immovable\": true", &format!("\"immovable\": {value}"));
            let err = MarkedLayout::from_json(&text, "L.json").unwrap_err();
            assert_eq!(
                err.to_string(),
                format!(
                    "layout file L.json: particle 7 immovable is {shown} (must be true or false)"
                )
            );
            assert!(Layout::from_json(&text, "L.json").is_err());
        }
    }

    /// A file's particles that overlap by at most 1 % of a radius (a fit's
    /// error on touching particles) read as touching, their radii reduced;
    /// deeper overlaps are refused, saying what is read as touching.
    #[test]
    fn a_files_particles_overlapping_by_a_fits_error_read_as_touching() {
        let text = |overlap_um: f64| {
            let x = 20.0 + 10.0 - overlap_um;
            format!(
                r#"{{"schema": "nanopush.layout/1", "field_um": [100, 100], "particles": [
                {{"id": 0, "x_um": 20, "y_um": 20, "radius_um": 5}},
                {{"id": 1, "x_um": {x}, "y_um": 20, "radius_um": 5}},
                {{"id": 2, "x_um": 60, "y_um": 60, "radius_um": 5}}]}}"#
            )
        };
        let l = Layout::from_json(&text(0.03), "t").unwrap();
        let r: Vec<f64> = l.particles.iter().map(|p| p.radius_m * 1e6).collect();
        assert!(
            (r[0] - 4.985).abs() < 1e-4 && (r[1] - 4.985).abs() < 1e-4,
            "{r:?}"
        );
        assert_eq!(r[2], 5.0);
        l.validate().unwrap();
        match Layout::from_json(&text(0.08), "t") {
            Err(e @ LayoutError::Overlap { a: 0, b: 1, .. }) => assert_eq!(
                e.to_string(),
                "layout: particles 0 and 1 overlap by 0.080 um, more than the 0.050 um read as touching"
            ),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn rejects_nan_negative_overlap_and_wrong_schema() {
        let mut l = sample();
        l.particles[0].radius_m = -1e-6;
        assert!(matches!(l.validate(), Err(LayoutError::BadValue { .. })));
        let mut l = sample();
        l.particles[1].centre_m.x = f64::NAN;
        assert!(matches!(l.validate(), Err(LayoutError::BadValue { .. })));
        let mut l = sample();
        l.particles[1].centre_m.x = 15e-6;
        assert!(matches!(l.validate(), Err(LayoutError::Overlap { .. })));
        let mut l = sample();
        l.particles.truncate(1);
        l.particles[0].radius_m = 51e-6;
        assert!(matches!(
            l.validate(),
            Err(LayoutError::LargerThanField { id: 0, .. })
        ));
        // A radius no probe pushes is a layout in another unit.
        for r_m in [1e300, 5e-3, 501e-6] {
            l.particles[0].radius_m = r_m;
            l.field_m = [1.0, 1.0];
            let e = l.validate().unwrap_err();
            assert!(
                matches!(e, LayoutError::RadiusNotMicro { id: 0, .. }),
                "{e}"
            );
            assert!(e.to_string().contains("is this one in nm?"), "{e}");
        }
        l.particles[0].radius_m = 500e-6;
        assert!(l.validate().is_ok());
        let text = sample().to_json().replace("layout/1", "layout/9");
        assert!(matches!(
            Layout::from_json(&text, "mem"),
            Err(LayoutError::Schema { .. })
        ));
    }

    #[test]
    fn a_particle_the_field_edge_cuts_is_kept_and_one_far_outside_is_refused() {
        // Cut by the left edge (centre 3 um out, radius 5 um): a frame's
        // edge particle. Read back from a file as written.
        let mut l = sample();
        l.particles[0].centre_m = Vector2::new(-3e-6, 50e-6);
        assert!(Layout::from_json(&l.to_json(), "mem").is_ok());
        // Beyond the top right corner: allowed up to two radii (10 um), so
        // 9.92 um out passes and 10.08 um does not.
        let corner = Vector2::new(120e-6, 100e-6);
        l.particles[0].centre_m = corner + Vector2::new(6e-6, 7.9e-6);
        assert!(l.validate().is_ok());
        l.particles[0].centre_m = corner + Vector2::new(6e-6, 8.1e-6);
        assert!(matches!(
            l.validate(),
            Err(LayoutError::OutsideField(OffField { id: 0, .. }))
        ));
        // Positions in nm instead of um: refused, naming the particle and where.
        let text = sample().to_json().replace("30.5", "30500.0");
        let err = Layout::from_json(&text, "mem").unwrap_err().to_string();
        assert!(
            err.contains("particle 7 at (30500.000, 20.000) um"),
            "{err}"
        );
        assert!(err.contains("outside the 120.0 x 100.0 um field"), "{err}");
        // A site is held to the same rule, and so is the field's size.
        let site = |x: f64, y: f64| Site {
            id: 3,
            centre_m: Vector2::new(x, y) * 1e-6,
        };
        assert!(l.check_site_in_field(&site(126.0, 107.9), 5e-6).is_ok());
        for (x, y) in [(1e9, 0.0), (-5000.0, 80.0), (f64::NAN, 1.0)] {
            let err = l.check_site_in_field(&site(x, y), 5e-6).unwrap_err();
            assert!(err.to_string().starts_with("site 3 at ("), "{err}");
        }
        let mut wide = sample();
        wide.field_m[0] = 2.0;
        let err = wide.validate().unwrap_err().to_string();
        assert!(
            err.contains("field width_um is 2000000.0 (must be at most 1000000 um"),
            "{err}"
        );
        // A mistyped 1e300 is told in exponent form, not in 300 digits.
        let text = sample().to_json().replace("30.5", "1e300");
        let err = Layout::from_json(&text, "mem").unwrap_err().to_string();
        assert!(
            err.contains("particle 7 at (1.000e300, 20.000) um"),
            "{err}"
        );
    }
}
