//! Overlay of a plan on its layout: particles (grey), sites (circles), pushes
//! (arrows from start to end; buffer/detour pushes in orange), tip travel
//! (dashed blue). SVG or PNG through plotters, chosen by the file extension.

use crate::plan::layout::Layout;
use crate::plan::{Plan, Step};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// The kinds of overlay file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OverlayKind {
    Svg,
    Png,
}

/// The kind `path` names by its extension; asked before planning, so an
/// unknown one is refused before anything is written.
pub fn overlay_kind(path: &Path) -> anyhow::Result<OverlayKind> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "svg" => Ok(OverlayKind::Svg),
        "png" => Ok(OverlayKind::Png),
        other => anyhow::bail!(
            "overlay {}: unknown extension {other:?}, use .svg or .png",
            path.display()
        ),
    }
}

/// Draws `plan` over `layout` into `path` (.svg or .png).
pub fn draw(plan: &Plan, layout: &Layout, path: &Path) -> anyhow::Result<()> {
    let scale = 6.0; // pixels per um
    let w = (layout.field_m[0] * 1e6 * scale).clamp(200.0, 4000.0) as u32;
    let h = (layout.field_m[1] * 1e6 * scale).clamp(200.0, 4000.0) as u32;
    match overlay_kind(path)? {
        OverlayKind::Svg => paint(
            SVGBackend::new(path, (w, h)).into_drawing_area(),
            plan,
            layout,
        ),
        OverlayKind::Png => paint(
            BitMapBackend::new(path, (w, h)).into_drawing_area(),
            plan,
            layout,
        ),
    }
}

fn paint<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    plan: &Plan,
    layout: &Layout,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let map_err =
        |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("overlay drawing failed: {e:?}");
    root.fill(&WHITE).map_err(map_err)?;
    let (pw, ph) = root.dim_in_pixel();
    let fw = layout.field_m[0] * 1e6;
    let sx = pw as f64 / fw;
    let px = |x: f64, y: f64| ((x * 1e6 * sx) as i32, (ph as f64 - y * 1e6 * sx) as i32);
    let rad = |r: f64| (r * 1e6 * sx).max(1.0) as i32;
    for p in &layout.particles {
        root.draw(&Circle::new(
            px(p.centre_m.x, p.centre_m.y),
            rad(p.radius_m),
            RGBColor(170, 170, 170).filled(),
        ))
        .map_err(map_err)?;
    }
    let r = layout.max_radius_m();
    for s in &plan.sites {
        root.draw(&Circle::new(
            px(s.centre_m.x, s.centre_m.y),
            rad(r),
            BLACK.stroke_width(1),
        ))
        .map_err(map_err)?;
    }
    let site_pts: Vec<_> = plan.sites.iter().map(|s| s.centre_m).collect();
    for step in &plan.steps {
        match step {
            Step::Push { from_m, to_m, .. } => {
                let to_site = site_pts.iter().any(|s| (s - to_m).norm() < 1e-9);
                let colour = if to_site { RED } else { RGBColor(255, 140, 0) };
                root.draw(&PathElement::new(
                    vec![px(from_m.x, from_m.y), px(to_m.x, to_m.y)],
                    colour.stroke_width(2),
                ))
                .map_err(map_err)?;
                root.draw(&Circle::new(px(to_m.x, to_m.y), 3, colour.filled()))
                    .map_err(map_err)?;
            }
            Step::TipTravel { from_m, to_m } => {
                root.draw(&PathElement::new(
                    vec![px(from_m.x, from_m.y), px(to_m.x, to_m.y)],
                    BLUE.mix(0.4).stroke_width(1),
                ))
                .map_err(map_err)?;
            }
            Step::CoarseMove { .. } => {}
        }
    }
    root.present().map_err(map_err)?;
    Ok(())
}
