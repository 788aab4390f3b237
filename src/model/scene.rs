//! Scenes: the TOML description of one push (probe, particle, substrate,
//! materials, interfaces, environment, push), validated into SI.
//!
//! Every field is read as optional and checked here, so an error names the
//! dotted path of the field (`particle.radius_um`) and what is wrong with it;
//! unknown keys are refused (`deny_unknown_fields`) so typos do not pass
//! silently. A dimensional value orders of magnitude outside its plausible
//! range (a unit slip: GPa written in Pa) is refused naming the likely slip;
//! the ranges are one table in `plausible.rs`. Lab units live only in these
//! two files.

use super::cantilever::Cantilever;
use super::contact::{ContactModel, Interface, tabor};
use super::error::ModelError;
use super::friction::criteria::FrictionParams;
use super::plausible::plausible;
use super::push_sim::PushParams;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// The schema string a scene may carry.
pub const SCENE_SCHEMA: &str = "nanopush.scene/1";

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct RawScene {
    schema: Option<String>,
    name: Option<String>,
    probe: Option<RawProbe>,
    particle: Option<RawParticle>,
    substrate: Option<RawSubstrate>,
    materials: Option<BTreeMap<String, RawMaterial>>,
    interfaces: Option<RawInterfaces>,
    motion: Option<RawMotion>,
    environment: Option<RawEnvironment>,
    push: Option<RawPush>,
    neighbours: Option<Vec<RawNeighbour>>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RawProbe {
    length_um: Option<f64>,
    width_um: Option<f64>,
    thickness_um: Option<f64>,
    tip_height_um: Option<f64>,
    tip_radius_nm: Option<f64>,
    material: Option<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RawParticle {
    radius_um: Option<f64>,
    material: Option<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RawSubstrate {
    material: Option<String>,
    tilt_deg: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    youngs_modulus_gpa: Option<f64>,
    poisson_ratio: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RawInterfaces {
    particle_substrate: Option<RawInterface>,
    tip_particle: Option<RawInterface>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RawInterface {
    work_of_adhesion_j_m2: Option<f64>,
    contact_model: Option<String>,
    reduced_modulus_gpa: Option<f64>,
    equilibrium_separation_nm: Option<f64>,
    friction_coefficient: Option<f64>,
    shear_strength_mpa: Option<f64>,
    rolling_friction_nm: Option<f64>,
    rolling_shear_pa_m: Option<f64>,
}

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct RawMotion {
    rolling_kinetic_ratio: Option<f64>,
    sliding_kinetic_ratio: Option<f64>,
}

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields)]
struct RawEnvironment {
    relative_humidity_percent: Option<f64>,
    water_contact_angle_deg: Option<f64>,
    session_time_min: Option<f64>,
    charge_adhesion_gain: Option<f64>,
    charge_time_constant_min: Option<f64>,
    drift_nm_s: Option<f64>,
    drift_direction_deg: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RawPush {
    angle_deg: Option<f64>,
    speed_um_s: Option<f64>,
    duration_s: Option<f64>,
    offset_um: Option<f64>,
    hold_contact_angle: Option<bool>,
    angle_min_deg: Option<f64>,
    angle_max_deg: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct RawNeighbour {
    distance_um: Option<f64>,
}

/// How one interface's contact law is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterfaceSpec {
    /// Reduced modulus E*.
    pub reduced_modulus_pa: f64,
    /// Work of adhesion W.
    pub work_of_adhesion_j_m2: f64,
    /// Pinned law, or `None` for the Tabor choice.
    pub pinned_model: Option<ContactModel>,
    /// z0 for the Tabor parameter.
    pub equilibrium_separation_m: f64,
}

impl InterfaceSpec {
    /// The interface for equivalent radius `r` and largest contact radius `a_max`.
    pub fn interface(&self, r: f64, a_max: f64, override_model: Option<ContactModel>) -> Interface {
        let mu_t = tabor::tabor_parameter(
            r,
            self.reduced_modulus_pa,
            self.work_of_adhesion_j_m2,
            self.equilibrium_separation_m,
        );
        let model = override_model
            .or(self.pinned_model)
            .unwrap_or_else(|| tabor::regime_for(mu_t, self.work_of_adhesion_j_m2));
        Interface {
            radius_m: r,
            reduced_modulus_pa: self.reduced_modulus_pa,
            work_of_adhesion_j_m2: self.work_of_adhesion_j_m2,
            tabor: mu_t,
            model,
            max_radius_m: a_max,
        }
    }
}

/// Static/kinetic thresholds of the mode machine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionParams {
    /// Kinetic/static ratio of the rolling threshold (hysteresis band).
    pub rolling_kinetic_ratio: f64,
    /// Kinetic/static ratio of the sliding threshold.
    pub sliding_kinetic_ratio: f64,
}

/// The environment effects' inputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Environment {
    /// Relative humidity [%].
    pub relative_humidity_percent: f64,
    /// Water contact angle of the surfaces (rad).
    pub water_contact_angle_rad: f64,
    /// Session time elapsed before this push (s).
    pub session_time_s: f64,
    /// Fractional rise of the tip-particle work of adhesion at full charge.
    pub charge_adhesion_gain: f64,
    /// Time constant of the charge build-up (s).
    pub charge_time_constant_s: f64,
    /// Piezo drift's rate [m/s]: the single-push model takes all of it
    /// along the push (the worst case).
    pub drift_m_per_s: f64,
    /// Direction the simulated rig's tip drifts against the sample, in the
    /// stage's frame (from +x towards +y) (rad); default 0 (along x).
    pub drift_direction_rad: f64,
}

/// A validated scene in SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Scene name.
    pub name: String,
    /// Cantilever and tip height.
    pub cantilever: Cantilever,
    /// Tip apex radius R_t.
    pub tip_radius_m: f64,
    /// Particle radius R_p.
    pub particle_radius_m: f64,
    /// Particle-substrate interface.
    pub substrate_interface: InterfaceSpec,
    /// Tip-particle interface.
    pub tip_interface: InterfaceSpec,
    /// Particle-substrate friction laws.
    pub friction: FrictionParams,
    /// Tip-particle Coulomb friction (tip sliding along the sphere).
    pub tip_friction_coefficient: f64,
    /// Hysteresis of the mode machine.
    pub motion: MotionParams,
    /// Environment.
    pub environment: Environment,
    /// Substrate tilt along the push direction (rad) (positive: downhill).
    pub substrate_tilt_rad: f64,
    /// Default push.
    pub push: PushParams,
    /// Push-line offset from the particle centre (m) (spinning arm).
    pub push_offset_m: f64,
    /// Whether the contact angle is held (tip riding over not simulated).
    pub hold_contact_angle: bool,
    /// Allowed contact-angle range for advice (rad).
    pub angle_range_rad: (f64, f64),
    /// Centre distances of particles ahead on the push line (m).
    pub neighbour_distances_m: Vec<f64>,
}

fn need<T>(v: Option<T>, field: &str) -> Result<T, ModelError> {
    v.ok_or_else(|| ModelError::scene(field, "missing"))
}

fn finite(v: f64, field: &str) -> Result<f64, ModelError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ModelError::scene(
            field,
            format!("must be a finite number, got {v}"),
        ))
    }
}

/// A required positive value, plausible for its key's unit
/// ([`plausible`]: a unit slip is refused).
fn positive(v: Option<f64>, field: &str) -> Result<f64, ModelError> {
    let v = finite(need(v, field)?, field)?;
    if v > 0.0 {
        plausible(v, field)
    } else {
        Err(ModelError::scene(
            field,
            format!("must be positive, got {v}"),
        ))
    }
}

fn in_range(v: f64, lo: f64, hi: f64, field: &str) -> Result<f64, ModelError> {
    let v = finite(v, field)?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(ModelError::scene(
            field,
            format!("must be within {lo}..{hi}, got {v}"),
        ))
    }
}

/// A value (or `default`) that is not negative, plausible for its key's
/// unit ([`plausible`]: a unit slip is refused).
fn non_negative(v: Option<f64>, default: f64, field: &str) -> Result<f64, ModelError> {
    let v = finite(v.unwrap_or(default), field)?;
    if v >= 0.0 {
        plausible(v, field)
    } else {
        Err(ModelError::scene(
            field,
            format!("must not be negative, got {v}"),
        ))
    }
}

/// 1/E* = sum (1 - nu_i^2)/E_i.
fn reduced_modulus(a: &(f64, f64), b: &(f64, f64)) -> f64 {
    1.0 / ((1.0 - a.1 * a.1) / a.0 + (1.0 - b.1 * b.1) / b.0)
}

/// The commands' default scene, relative to the project folder.
pub const DEFAULT_SCENE_PATH: &str = "calib/paper-ps-ito.toml";

/// The scenes commands use by default (the paper scene and the two hard
/// cases the model study runs), built in for commands run outside the
/// project folder (path relative to it, text).
const BUILT_IN_SCENES: [(&str, &str); 3] = [
    (
        DEFAULT_SCENE_PATH,
        include_str!("../../calib/paper-ps-ito.toml"),
    ),
    (
        "calib/hard-nanoparticle-sliding.toml",
        include_str!("../../calib/hard-nanoparticle-sliding.toml"),
    ),
    (
        "calib/hard-high-adhesion.toml",
        include_str!("../../calib/hard-high-adhesion.toml"),
    ),
];

/// Paths of the built-in scenes, the paper scene first.
pub fn built_in_scene_paths() -> impl Iterator<Item = &'static str> {
    BUILT_IN_SCENES.iter().map(|(path, _)| *path)
}

/// The text of the scene file at `path`, or of the built-in copy when a
/// built-in scene's path is not there (a command run from another folder):
/// what [`Scene::load`] reads, and what a recording keeps of the scene
/// (a run outside the project folder had recorded none).
pub fn scene_text(path: &Path) -> Result<String, ModelError> {
    if !path.exists()
        && let Some((_, text)) = BUILT_IN_SCENES.iter().find(|(p, _)| path == Path::new(p))
    {
        return Ok((*text).to_owned());
    }
    std::fs::read_to_string(path).map_err(|e| ModelError::SceneText(format!("cannot read: {e}")))
}

/// A scene, said for a person given another file for one.
const SCENE_WANTED: &str =
    "a scene (nanopush.scene/1: probe, particle, materials, ...; see calib/paper-ps-ito.toml)";

impl Scene {
    /// Reads and validates a scene file. A built-in scene's path falls back
    /// to the built-in copy when it is not there (a command run from another
    /// folder).
    pub fn load(path: &Path) -> Result<Scene, ModelError> {
        Scene::from_toml_str(&scene_text(path)?)
    }

    /// Parses and validates scene TOML text.
    pub fn from_toml_str(text: &str) -> Result<Scene, ModelError> {
        if let Some(kind) = crate::file_schema::other_toml_kind(text, SCENE_SCHEMA, SCENE_WANTED) {
            return Err(kind.into());
        }
        let raw: RawScene = toml::from_str(text).map_err(|e| {
            let msg = e.message().to_string();
            ModelError::SceneText(format!("line {}: {msg}", line_of(text, e.span())))
        })?;
        raw.validate()
    }
}

fn line_of(text: &str, span: Option<std::ops::Range<usize>>) -> usize {
    // Newlines before the span, plus one (`lines()` of the text before it
    // missed the span's own line when it starts one).
    span.map_or(0, |s| {
        text.as_bytes()[..s.start.min(text.len())]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1
    })
}

impl RawScene {
    fn validate(self) -> Result<Scene, ModelError> {
        if let Some(s) = &self.schema
            && s != SCENE_SCHEMA
        {
            return Err(ModelError::scene(
                "schema",
                format!("expected \"{SCENE_SCHEMA}\", got \"{s}\""),
            ));
        }
        let materials = need(self.materials, "materials")?;
        let mut mats = BTreeMap::new();
        for (name, m) in &materials {
            let e = positive(
                m.youngs_modulus_gpa,
                &format!("materials.{name}.youngs_modulus_gpa"),
            )? * 1e9;
            let field = format!("materials.{name}.poisson_ratio");
            let nu = in_range(need(m.poisson_ratio, &field)?, -1.0, 0.5, &field)?;
            if nu <= -1.0 {
                // G = E / 2(1 + nu): the torsional spring would be infinite.
                return Err(ModelError::scene(
                    &field,
                    format!("must be above -1 (no isotropic solid reaches it), got {nu}"),
                ));
            }
            mats.insert(name.clone(), (e, nu));
        }
        let material = |name: Option<String>, field: &str| -> Result<(f64, f64), ModelError> {
            let name = need(name, field)?;
            mats.get(&name).copied().ok_or_else(|| {
                ModelError::scene(
                    field,
                    format!(
                        "unknown material \"{name}\" (defined: {})",
                        mats.keys().cloned().collect::<Vec<_>>().join(", ")
                    ),
                )
            })
        };
        let probe = need(self.probe, "probe")?;
        let probe_mat = material(probe.material, "probe.material")?;
        let cantilever = Cantilever {
            length_m: positive(probe.length_um, "probe.length_um")? * 1e-6,
            width_m: positive(probe.width_um, "probe.width_um")? * 1e-6,
            thickness_m: positive(probe.thickness_um, "probe.thickness_um")? * 1e-6,
            youngs_modulus_pa: probe_mat.0,
            poisson_ratio: probe_mat.1,
            tip_height_m: positive(probe.tip_height_um, "probe.tip_height_um")? * 1e-6,
        };
        let tip_radius_m = positive(probe.tip_radius_nm, "probe.tip_radius_nm")? * 1e-9;
        let particle = need(self.particle, "particle")?;
        let particle_radius_m = positive(particle.radius_um, "particle.radius_um")? * 1e-6;
        let particle_mat = material(particle.material, "particle.material")?;
        let substrate = need(self.substrate, "substrate")?;
        let substrate_mat = material(substrate.material, "substrate.material")?;
        let substrate_tilt_rad = in_range(
            substrate.tilt_deg.unwrap_or(0.0),
            -30.0,
            30.0,
            "substrate.tilt_deg",
        )?
        .to_radians();

        let interfaces = need(self.interfaces, "interfaces")?;
        let ps = need(
            interfaces.particle_substrate,
            "interfaces.particle_substrate",
        )?;
        let tp = need(interfaces.tip_particle, "interfaces.tip_particle")?;
        let spec = |r: &RawInterface,
                    prefix: &str,
                    mats: (&(f64, f64), &(f64, f64))|
         -> Result<InterfaceSpec, ModelError> {
            let w = non_negative(
                Some(need(
                    r.work_of_adhesion_j_m2,
                    &format!("{prefix}.work_of_adhesion_j_m2"),
                )?),
                0.0,
                &format!("{prefix}.work_of_adhesion_j_m2"),
            )?;
            let pinned_model = match r.contact_model.as_deref() {
                None | Some("auto") => None,
                Some(s) => Some(ContactModel::parse(s).ok_or_else(|| {
                    ModelError::scene(format!("{prefix}.contact_model"), format!("unknown contact model \"{s}\" (use auto, hertz, dmt, jkr, maugis-dugdale)"))
                })?),
            };
            let reduced_modulus_pa = match r.reduced_modulus_gpa {
                Some(v) => positive(Some(v), &format!("{prefix}.reduced_modulus_gpa"))? * 1e9,
                None => reduced_modulus(mats.0, mats.1),
            };
            let z0 = match r.equilibrium_separation_nm {
                Some(v) => {
                    positive(Some(v), &format!("{prefix}.equilibrium_separation_nm"))? * 1e-9
                }
                None => tabor::DEFAULT_EQUILIBRIUM_SEPARATION_M,
            };
            Ok(InterfaceSpec {
                reduced_modulus_pa,
                work_of_adhesion_j_m2: w,
                pinned_model,
                equilibrium_separation_m: z0,
            })
        };
        let substrate_interface = spec(
            &ps,
            "interfaces.particle_substrate",
            (&particle_mat, &substrate_mat),
        )?;
        let tip_interface = spec(&tp, "interfaces.tip_particle", (&probe_mat, &particle_mat))?;
        let p = "interfaces.particle_substrate";
        let friction = FrictionParams {
            sliding_coefficient: in_range(
                need(
                    ps.friction_coefficient,
                    &format!("{p}.friction_coefficient"),
                )?,
                0.0,
                10.0,
                &format!("{p}.friction_coefficient"),
            )?,
            shear_strength_pa: non_negative(
                Some(need(
                    ps.shear_strength_mpa,
                    &format!("{p}.shear_strength_mpa"),
                )?),
                0.0,
                &format!("{p}.shear_strength_mpa"),
            )? * 1e6,
            rolling_coefficient_m: non_negative(
                Some(need(
                    ps.rolling_friction_nm,
                    &format!("{p}.rolling_friction_nm"),
                )?),
                0.0,
                &format!("{p}.rolling_friction_nm"),
            )? * 1e-9,
            rolling_shear_n_per_m: non_negative(
                Some(need(
                    ps.rolling_shear_pa_m,
                    &format!("{p}.rolling_shear_pa_m"),
                )?),
                0.0,
                &format!("{p}.rolling_shear_pa_m"),
            )?,
        };
        let tip_friction_coefficient = in_range(
            tp.friction_coefficient.unwrap_or(0.0),
            0.0,
            10.0,
            "interfaces.tip_particle.friction_coefficient",
        )?;

        let motion_raw = self.motion.unwrap_or_default();
        let motion = MotionParams {
            rolling_kinetic_ratio: in_range(
                motion_raw.rolling_kinetic_ratio.unwrap_or(0.99),
                0.5,
                1.0,
                "motion.rolling_kinetic_ratio",
            )?,
            sliding_kinetic_ratio: in_range(
                motion_raw.sliding_kinetic_ratio.unwrap_or(0.9),
                0.5,
                1.0,
                "motion.sliding_kinetic_ratio",
            )?,
        };
        let env = self.environment.unwrap_or_default();
        let environment = Environment {
            relative_humidity_percent: in_range(
                env.relative_humidity_percent.unwrap_or(0.0),
                0.0,
                100.0,
                "environment.relative_humidity_percent",
            )?,
            water_contact_angle_rad: in_range(
                env.water_contact_angle_deg.unwrap_or(30.0),
                0.0,
                180.0,
                "environment.water_contact_angle_deg",
            )?
            .to_radians(),
            session_time_s: non_negative(
                env.session_time_min,
                0.0,
                "environment.session_time_min",
            )? * 60.0,
            charge_adhesion_gain: non_negative(
                env.charge_adhesion_gain,
                0.0,
                "environment.charge_adhesion_gain",
            )?,
            charge_time_constant_s: positive(
                Some(env.charge_time_constant_min.unwrap_or(30.0)),
                "environment.charge_time_constant_min",
            )? * 60.0,
            drift_m_per_s: plausible(
                finite(env.drift_nm_s.unwrap_or(0.0), "environment.drift_nm_s")?,
                "environment.drift_nm_s",
            )? * 1e-9,
            drift_direction_rad: finite(
                env.drift_direction_deg.unwrap_or(0.0),
                "environment.drift_direction_deg",
            )?
            .to_radians(),
        };

        let push = need(self.push, "push")?;
        let angle = need(push.angle_deg, "push.angle_deg")?;
        let angle = finite(angle, "push.angle_deg")?;
        if !(angle > 0.0 && angle < 90.0) {
            return Err(ModelError::scene(
                "push.angle_deg",
                format!("contact angle must be inside 0..90 deg (exclusive), got {angle}"),
            ));
        }
        let push_params = PushParams {
            contact_angle_rad: angle.to_radians(),
            speed_m_per_s: positive(push.speed_um_s, "push.speed_um_s")? * 1e-6,
            duration_s: positive(push.duration_s, "push.duration_s")?,
        };
        let amin = in_range(
            push.angle_min_deg.unwrap_or(10.0),
            0.1,
            89.9,
            "push.angle_min_deg",
        )?;
        let amax = in_range(
            push.angle_max_deg.unwrap_or(80.0),
            0.1,
            89.9,
            "push.angle_max_deg",
        )?;
        if amin > amax {
            return Err(ModelError::scene(
                "push.angle_min_deg",
                format!("{amin} is above push.angle_max_deg {amax}"),
            ));
        }
        let push_offset_m = finite(push.offset_um.unwrap_or(0.0), "push.offset_um")? * 1e-6;
        // A push line a particle radius or more off the centre misses the
        // particle: the tip passes beside it (it had been simulated as a
        // spinning push with an onset).
        if push_offset_m.abs() >= particle_radius_m {
            return Err(ModelError::scene(
                "push.offset_um",
                format!(
                    "{} um: the push line misses a particle of radius {:.2} um",
                    push_offset_m * 1e6,
                    particle_radius_m * 1e6
                ),
            ));
        }
        let mut neighbour_distances_m = Vec::new();
        for (i, n) in self.neighbours.unwrap_or_default().iter().enumerate() {
            let key = format!("neighbours[{i}].distance_um");
            let d = positive(n.distance_um, &key)? * 1e-6;
            // Centre to centre: closer than a diameter, the two overlap.
            if d < 2.0 * particle_radius_m {
                return Err(ModelError::scene(
                    &key,
                    format!(
                        "{} um is less than a particle diameter ({:.2} um): the two would overlap",
                        d * 1e6,
                        2.0 * particle_radius_m * 1e6
                    ),
                ));
            }
            neighbour_distances_m.push(d);
        }
        Ok(Scene {
            name: self.name.unwrap_or_else(|| "unnamed".into()),
            cantilever,
            tip_radius_m,
            particle_radius_m,
            substrate_interface,
            tip_interface,
            friction,
            tip_friction_coefficient,
            motion,
            environment,
            substrate_tilt_rad,
            push: push_params,
            push_offset_m,
            hold_contact_angle: push.hold_contact_angle.unwrap_or(true),
            angle_range_rad: (amin.to_radians(), amax.to_radians()),
            neighbour_distances_m,
        })
    }
}

impl Scene {
    /// The two interfaces at this scene's radii, optionally forcing a law.
    pub fn interfaces(&self, override_model: Option<ContactModel>) -> (Interface, Interface) {
        let rp = self.particle_radius_m;
        let rt = self.tip_radius_m;
        let s = self.substrate_interface.interface(rp, rp, override_model);
        let t = self
            .tip_interface
            .interface(rp * rt / (rp + rt), rt.min(rp), override_model);
        (s, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper scene's TOML.
    fn paper_text() -> &'static str {
        BUILT_IN_SCENES
            .iter()
            .find(|(p, _)| p.ends_with("paper-ps-ito.toml"))
            .expect("the paper scene is built in")
            .1
    }

    /// A neighbour overlapping the particle and a push line that misses it
    /// are refused, naming the key; a touching neighbour is allowed.
    #[test]
    fn impossible_geometry_is_refused() {
        let paper = paper_text();
        let with = |extra: &str| Scene::from_toml_str(&format!("{paper}\n{extra}\n"));
        let err = with("[[neighbours]]\ndistance_um = 3.0")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("neighbours[0].distance_um") && err.contains("overlap"),
            "{err}"
        );
        assert!(with("[[neighbours]]\ndistance_um = 10.0").is_ok());
        let offset = |o: f64| {
            paper.replace(
                "duration_s = 30.0",
                &format!("duration_s = 30.0\noffset_um = {o}"),
            )
        };
        let err = Scene::from_toml_str(&offset(50.0)).unwrap_err().to_string();
        assert!(
            err.contains("push.offset_um") && err.contains("misses"),
            "{err}"
        );
        assert!(Scene::from_toml_str(&offset(-5.0)).is_err());
        assert!(Scene::from_toml_str(&offset(2.0)).is_ok());
        // A Poisson ratio of -1 makes the torsional spring infinite.
        let poisson = |nu: &str| {
            paper.replacen(
                "poisson_ratio = 0.27 ",
                &format!("poisson_ratio = {nu} "),
                1,
            )
        };
        assert!(paper.contains("poisson_ratio = 0.27 "));
        let err = Scene::from_toml_str(&poisson("-1.0"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("poisson_ratio") && err.contains("above -1"),
            "{err}"
        );
        assert!(Scene::from_toml_str(&poisson("-0.5")).is_ok());
    }

    /// Unit slips (a value written in another unit than its key's, orders of
    /// magnitude off) are refused naming the key, the value with its unit,
    /// the plausible range and the likely slip; before, 169e9 under
    /// `youngs_modulus_gpa` simulated a cantilever ramp of 3.9e16 N/m.
    #[test]
    fn unit_slips_are_refused_naming_the_key_and_the_slip() {
        let paper = paper_text();
        // (line in the paper scene, the line with the slip, key, value as
        // said, slip said)
        let slips = [
            (
                "youngs_modulus_gpa = 169.0",
                "youngs_modulus_gpa = 169e9",
                "materials.silicon.youngs_modulus_gpa",
                "1.69e11 GPa",
                "Pa",
            ),
            (
                "youngs_modulus_gpa = 3.4 ",
                "youngs_modulus_gpa = 3400.0 ",
                "materials.polystyrene.youngs_modulus_gpa",
                "3400 GPa",
                "MPa",
            ),
            (
                "length_um = 225.0",
                "length_um = 225e-6",
                "probe.length_um",
                "2.25e-4 um",
                "m",
            ),
            (
                "width_um = 48.0",
                "width_um = 48e-6",
                "probe.width_um",
                "4.8e-5 um",
                "m",
            ),
            (
                "thickness_um = 1.0",
                "thickness_um = 1e-6",
                "probe.thickness_um",
                "1e-6 um",
                "m",
            ),
            (
                "tip_height_um = 12.0",
                "tip_height_um = 12e-6",
                "probe.tip_height_um",
                "1.2e-5 um",
                "m",
            ),
            (
                "tip_radius_nm = 20.0",
                "tip_radius_nm = 20e-9",
                "probe.tip_radius_nm",
                "2e-8 nm",
                "m",
            ),
            (
                "radius_um = 5.0 ",
                "radius_um = 5e-6 ",
                "particle.radius_um",
                "5e-6 um",
                "m",
            ),
            (
                "work_of_adhesion_j_m2 = 0.1",
                "work_of_adhesion_j_m2 = 100.0",
                "interfaces.particle_substrate.work_of_adhesion_j_m2",
                "100 J/m^2",
                "mJ/m^2",
            ),
            (
                "reduced_modulus_gpa = 4.11",
                "reduced_modulus_gpa = 4.11e9",
                "interfaces.particle_substrate.reduced_modulus_gpa",
                "4.11e9 GPa",
                "Pa",
            ),
            (
                "contact_model = \"jkr\"",
                "contact_model = \"jkr\"\nequilibrium_separation_nm = 3e-10",
                "interfaces.particle_substrate.equilibrium_separation_nm",
                "3e-10 nm",
                "m",
            ),
            (
                "shear_strength_mpa = 28.0",
                "shear_strength_mpa = 28e6",
                "interfaces.particle_substrate.shear_strength_mpa",
                "2.8e7 MPa",
                "Pa",
            ),
            (
                "rolling_friction_nm = 80.0",
                "rolling_friction_nm = 80e-9",
                "interfaces.particle_substrate.rolling_friction_nm",
                "8e-8 nm",
                "m",
            ),
            (
                "rolling_shear_pa_m = 98.5",
                "rolling_shear_pa_m = 98500.0e3",
                "interfaces.particle_substrate.rolling_shear_pa_m",
                "9.85e7 Pa m",
                "mN/m",
            ),
            (
                "speed_um_s = 1.0",
                "speed_um_s = 1e-6",
                "push.speed_um_s",
                "1e-6 um/s",
                "m/s",
            ),
            (
                "duration_s = 30.0",
                "duration_s = 3e7",
                "push.duration_s",
                "3e7 s",
                "us",
            ),
        ];
        let extra = [
            (
                "[environment]\nsession_time_min = 1.2e8",
                "environment.session_time_min",
                "1.2e8 min",
                "ms",
            ),
            (
                "[environment]\ncharge_time_constant_min = 1.8e7",
                "environment.charge_time_constant_min",
                "1.8e7 min",
                "ms",
            ),
            (
                "[environment]\ncharge_adhesion_gain = 300.0",
                "environment.charge_adhesion_gain",
                "300",
                "%",
            ),
            (
                "[environment]\ndrift_nm_s = -2000.0",
                "environment.drift_nm_s",
                "-2000 nm/s",
                "pm/s",
            ),
            (
                "[[neighbours]]\ndistance_um = 12e-6",
                "neighbours[0].distance_um",
                "1.2e-5 um",
                "m",
            ),
        ];
        let texts =
            slips
                .iter()
                .map(|(from, to, key, said, slip)| {
                    assert!(paper.contains(from), "{from} is not in the paper scene");
                    (paper.replacen(from, to, 1), *key, *said, *slip)
                })
                .chain(extra.iter().map(|(add, key, said, slip)| {
                    (format!("{paper}\n{add}\n"), *key, *said, *slip)
                }));
        for (text, key, said, slip) in texts {
            match Scene::from_toml_str(&text) {
                Err(ModelError::Scene { field, problem }) => {
                    assert_eq!(field, key, "{problem}");
                    assert!(
                        problem.starts_with(&format!("{said} is implausible"))
                            && problem.contains("plausible range is ")
                            && problem.contains(&format!("looks like {slip}: the key ")),
                        "{key}: {problem}"
                    );
                }
                other => panic!("{key} = {said} was not refused as a slip: {other:?}"),
            }
        }
    }

    /// Every scene shipped (calib/ and the recorded fixtures) and the
    /// extremes the tests and the spec's hard cases write still load: a
    /// nanocluster particle, strong adhesion, no adhesion, a slow push.
    #[test]
    fn shipped_scenes_and_hard_cases_still_load() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut loaded = Vec::new();
        let calib = std::fs::read_dir(root.join("calib")).unwrap();
        let fixture = root.join("fixtures/recordings/sim-L-seed6/scene.toml");
        for path in calib.map(|e| e.unwrap().path()).chain([fixture]) {
            let text = std::fs::read_to_string(&path).unwrap();
            if text.contains(SCENE_SCHEMA) {
                Scene::from_toml_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                loaded.push(path);
            }
        }
        assert!(loaded.len() >= 4, "{loaded:?}");
        let paper = paper_text();
        for (from, to) in [
            ("radius_um = 5.0 ", "radius_um = 0.01 "),
            ("radius_um = 5.0 ", "radius_um = 50.0 "),
            ("work_of_adhesion_j_m2 = 0.1", "work_of_adhesion_j_m2 = 1.0"),
            ("work_of_adhesion_j_m2 = 0.1", "work_of_adhesion_j_m2 = 0.0"),
            ("reduced_modulus_gpa = 4.11", "reduced_modulus_gpa = 500.0"),
            ("reduced_modulus_gpa = 4.11", "reduced_modulus_gpa = 0.1"),
            ("speed_um_s = 1.0", "speed_um_s = 0.001"),
            ("speed_um_s = 1.0", "speed_um_s = 100.0"),
            ("shear_strength_mpa = 28.0", "shear_strength_mpa = 200.0"),
            ("rolling_shear_pa_m = 98.5", "rolling_shear_pa_m = 300.0"),
        ] {
            assert!(paper.contains(from), "{from}");
            let text = paper.replacen(from, to, 1);
            assert!(Scene::from_toml_str(&text).is_ok(), "{to}");
        }
    }

    /// The drift's direction is read in degrees and refused when not a number.
    #[test]
    fn the_drift_direction_is_read_and_checked() {
        let paper = paper_text();
        let with =
            |extra: &str| Scene::from_toml_str(&format!("{paper}\n[environment]\n{extra}\n"));
        let s = with("drift_nm_s = 2\ndrift_direction_deg = 90").unwrap();
        assert!((s.environment.drift_direction_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(
            with("drift_nm_s = 2")
                .unwrap()
                .environment
                .drift_direction_rad,
            0.0
        );
        let err = with("drift_direction_deg = nan").unwrap_err().to_string();
        assert!(err.contains("environment.drift_direction_deg"), "{err}");
    }

    /// A misspelt key is named with its own line, whether it starts the
    /// line or is indented (the first was reported a line early).
    #[test]
    fn a_misspelt_key_is_named_with_its_line() {
        let paper = paper_text();
        let line = paper
            .lines()
            .position(|l| l.starts_with("speed_um_s"))
            .expect("a speed line")
            + 1;
        for (from, to) in [("speed_um_s", "sped_um_s"), ("speed_um_s", "  sped_um_s")] {
            let typo = paper.replacen(&format!("\n{from}"), &format!("\n{to}"), 1);
            let err = Scene::from_toml_str(&typo).unwrap_err().to_string();
            assert!(
                err.contains(&format!("line {line}:")) && err.contains("sped_um_s"),
                "{err}"
            );
        }
    }
}
