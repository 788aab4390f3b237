//! A simulated rig for a scene and a particle layout, with the defaults a lab
//! would recognise: a 100 x 100 x 15 um nanostage, a camera at 0.25 um/px
//! (finer for particles it would show under 12 px across) that sees the whole
//! stage range with a margin, and the coarse stage centring the nanostage's
//! range on the layout's field.

use super::model_physics::ModelPhysics;
use super::rig::{SimCameraConfig, SimRig};
use super::stage::{SimStage, SimStageConfig};
use super::world::{SimParticle, World};
use crate::model::Scene;
use crate::plan::Layout;
use crate::rig::RigError;
use crate::rig::stage::CoarseStage;

/// Camera resolution of the simulated rig, micrometres per pixel, for
/// particles it shows at least [`SIM_MIN_PARTICLE_PX`] across.
pub const SIM_UM_PER_PX: f64 = 0.25;
/// Fewest pixels across the simulated camera shows the layout's smallest
/// particle, down to [`SIM_FINEST_UM_PER_PX`]: the frame's particles are drawn
/// as rings, which the detector's ring model fits from 10 px across, and at
/// 8 px (2 um spheres at 0.25 um/px) its spot model locks onto pieces of the
/// ring, centres jumping about 0.9 um between frames, and the loop's pushes
/// miss (0 of 8 runs done, against 8 of 8 at 12 px).
pub const SIM_MIN_PARTICLE_PX: f64 = 12.0;
/// Finest resolution the simulated camera takes (a 100x oil objective's
/// pixel on a common sensor); smaller particles are shown smaller.
pub const SIM_FINEST_UM_PER_PX: f64 = 0.1;
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

/// The simulated camera's resolution for particles of `radius_m`, um/px:
/// [`SIM_UM_PER_PX`], or finer where that shows them under
/// [`SIM_MIN_PARTICLE_PX`] across, never finer than [`SIM_FINEST_UM_PER_PX`].
pub fn sim_um_per_px(radius_m: f64) -> f64 {
    let fits_um_per_px = 2.0 * radius_m * 1e6 / SIM_MIN_PARTICLE_PX;
    fits_um_per_px.clamp(SIM_FINEST_UM_PER_PX, SIM_UM_PER_PX)
}

/// How many pixels across the simulated camera shows a particle of `radius_m`.
pub fn sim_px_across(radius_m: f64) -> f64 {
    2.0 * radius_m * 1e6 / sim_um_per_px(radius_m)
}

/// The layout's smallest particle radius (infinite where it has none: the
/// default resolution).
pub fn smallest_radius_m(layout: &Layout) -> f64 {
    layout
        .particles
        .iter()
        .map(|p| p.radius_m)
        .fold(f64::INFINITY, f64::min)
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
    let camera = SimCameraConfig::covering(
        range_um,
        SIM_CAMERA_MARGIN_UM,
        sim_um_per_px(smallest_radius_m(layout)),
    );
    let mut rig = SimRig::new(stage, camera, seed);
    rig.move_coarse(centre_offset)?;
    Ok(rig)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_simulated_camera_shows_small_particles_finer() {
        // 10 um spheres: the default, 40 px across.
        assert_eq!(sim_um_per_px(5e-6), SIM_UM_PER_PX);
        assert_eq!(sim_um_per_px(f64::INFINITY), SIM_UM_PER_PX);
        // 2 um spheres: 8 px at the default; 12 px finer.
        assert!((sim_um_per_px(1e-6) - 2.0 / 12.0).abs() < 1e-12);
        assert!((sim_px_across(1e-6) - SIM_MIN_PARTICLE_PX).abs() < 1e-9);
        // 0.6 um spheres: at the finest, 6 px.
        assert_eq!(sim_um_per_px(0.3e-6), SIM_FINEST_UM_PER_PX);
        assert!((sim_px_across(0.3e-6) - 6.0).abs() < 1e-9);
    }
}
