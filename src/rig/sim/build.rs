//! A simulated rig for a scene and a particle layout, with the defaults a lab
//! would recognise: a 100 x 100 x 15 um nanostage, a camera at 0.25 um/px that
//! sees the whole stage range with a margin, and the coarse stage centring the
//! nanostage's range on the layout's field.

use super::model_physics::ModelPhysics;
use super::rig::{SimCameraConfig, SimRig};
use super::stage::{SimStage, SimStageConfig};
use super::world::{SimParticle, World};
use crate::model::Scene;
use crate::plan::Layout;
use crate::rig::RigError;
use crate::rig::stage::CoarseStage;

/// Camera resolution of the simulated rig, micrometres per pixel.
pub const SIM_UM_PER_PX: f64 = 0.25;
/// Margin the simulated camera sees around the nanostage range, micrometres.
pub const SIM_CAMERA_MARGIN_UM: f64 = 20.0;

/// The simulated world of a layout: its particles (ground truth) and the
/// scene's tip friction. Shared by the simulated rig and the simulated
/// microscope that watches the GCS controller simulator.
pub fn world_for(scene: &Scene, layout: &Layout) -> World {
    World {
        particles: layout
            .particles
            .iter()
            .map(|p| SimParticle {
                id: p.id as usize,
                x_m: p.centre_m.x,
                y_m: p.centre_m.y,
                radius_m: p.radius_m,
            })
            .collect(),
        tip_friction: scene.tip_friction_coefficient,
    }
}

/// The coarse offset that centres a nanostage range of `range_m` on a
/// layout's field of `field_m` (zero along an axis where the range covers
/// the field): where the simulated rig, and the simulated microscope under
/// a coarse GCS controller, start.
pub fn centring_offset(field_m: [f64; 2], range_m: [f64; 2]) -> [f64; 2] {
    [0, 1].map(|i| (field_m[i] - range_m[i]).max(0.0) / 2.0)
}

/// Builds the simulated rig: world from `layout`, physics from `scene`, noise from `seed`.
pub fn build_sim_rig(scene: &Scene, layout: &Layout, seed: u64) -> Result<SimRig, RigError> {
    let world = world_for(scene, layout);
    let config = SimStageConfig {
        drift_m_per_s: {
            let env = &scene.environment;
            let (sin, cos) = env.drift_direction_rad.sin_cos();
            [env.drift_m_per_s * cos, env.drift_m_per_s * sin]
        },
        ..SimStageConfig::default()
    };
    let range_um = [
        (config.range[0].max_m - config.range[0].min_m) * 1e6,
        (config.range[1].max_m - config.range[1].min_m) * 1e6,
    ];
    let centre_offset = centring_offset(layout.field_m, range_um.map(|r| r * 1e-6));
    let stage = SimStage::new(
        world,
        Box::new(ModelPhysics::new(scene.clone())),
        config,
        seed,
    );
    let camera = SimCameraConfig::covering(range_um, SIM_CAMERA_MARGIN_UM, SIM_UM_PER_PX);
    let mut rig = SimRig::new(stage, camera, seed);
    rig.move_coarse(centre_offset)?;
    Ok(rig)
}
