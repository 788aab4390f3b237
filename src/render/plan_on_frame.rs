//! A plan drawn over the microscope frame it was planned from (`nanopush
//! plan --frame FRAME --calib FILE --overlay plan.png`). The user checks
//! the plan against what the camera showed, not only against the planner's
//! own picture of it: a particle the detector missed or a site over dirt
//! shows here and nowhere else. Drawn like the run animation's frames
//! ([`draw_run_frame`]): sites, the particles planned with, every push as an
//! arrow, and the tip's apex when the frame showed it; under the frame, a
//! key naming those marks ([`super::key`]), as the drawing over a layout has.

use super::key::with_key_below;
use super::run_overlay::{RunOverlay, draw_run_frame, key};
use crate::calib::camera_map::CameraCalibration;
use crate::plan::layout::Layout;
use crate::plan::{Plan, Step};
use crate::vision::frame::Frame;
use image::RgbImage;
use nalgebra::Vector2;

/// `plan` (sites and pushes), the particles of `layout` and the tip at
/// `tip_m` over `frame`, placed in its pixels by `calibration` (the frame
/// taken with the coarse stage at its origin, as `plan --frame` assumes).
/// The key of the marks goes under the frame, the picture widened if the
/// frame is narrower than the key's lines. Errors are the calibration's (not
/// invertible) or the drawing's, as text.
pub fn draw_plan_on_frame(
    plan: &Plan,
    layout: &Layout,
    tip_m: Option<Vector2<f64>>,
    frame: &Frame,
    calibration: &CameraCalibration,
) -> Result<RgbImage, String> {
    let px = |p: Vector2<f64>| {
        calibration
            .stage_to_pixel(p.x, p.y)
            .map_err(|e| format!("cannot draw on the frame: {e}"))
    };
    let m_per_px = calibration.m_per_px();
    let particles_px = layout
        .particles
        .iter()
        .map(|p| px(p.centre_m).map(|[x, y]| [x, y, p.radius_m / m_per_px]))
        .collect::<Result<_, _>>()?;
    let plan_px = plan
        .steps
        .iter()
        .filter_map(Step::push_move)
        .map(|(_, from, to)| Ok([px(from)?, px(to)?]))
        .collect::<Result<_, String>>()?;
    let s = &plan.summary;
    let overlay = RunOverlay {
        sites_px: plan
            .sites
            .iter()
            .map(|s| px(s.centre_m))
            .collect::<Result<_, _>>()?,
        site_radius_px: layout.max_radius_m() / m_per_px,
        particles_px,
        plan_px,
        push_px: None,
        tip_px: tip_m.map(px).transpose()?,
        caption: format!(
            "plan: {}, {}, push {:.1} um, tip travel {:.1} um",
            crate::wording::counted(plan.sites.len(), "site"),
            crate::wording::counted(s.pushes, "push"),
            s.push_distance_m * 1e6,
            s.tip_travel_m * 1e6
        ),
    };
    with_key_below(&draw_run_frame(frame, &overlay, 1.0)?, &key(&overlay))
}
