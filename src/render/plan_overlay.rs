//! Overlay of a plan on its layout: particles (grey), sites (circles), pushes
//! (arrows from start to end; buffer/detour pushes in orange), tip travel
//! (faint blue), with a key under the field that says so (a lab user
//! handed the drawing had nothing to read the marks by; [`super::key`]). SVG or PNG through
//! plotters, chosen by the file extension.

use super::key::{KeyEntry, Swatch, draw_key, key_height_px, key_width_px};
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

/// Fill of a particle.
const PARTICLE: RGBColor = RGBColor(170, 170, 170);
/// A push that ends on a site.
const PUSH_TO_SITE: RGBColor = RED;
/// A push that ends elsewhere: to a buffer spot, or a waypoint of a detour.
const PUSH_ELSEWHERE: RGBColor = RGBColor(255, 140, 0);
/// The faint line of the tip's travel.
const TIP_TRAVEL: ShapeStyle = ShapeStyle {
    color: RGBAColor(0, 0, 255, 0.4),
    filled: false,
    stroke_width: 1,
};
/// The key of the drawing's marks, in its order.
const KEY: [KeyEntry; 5] = [
    KeyEntry {
        swatch: Swatch::Disc(PARTICLE),
        label: "particle",
    },
    KeyEntry {
        swatch: Swatch::Ring(BLACK),
        label: "site of the pattern",
    },
    KeyEntry {
        swatch: Swatch::LineToDot(PUSH_TO_SITE),
        label: "push onto a site (dot: where it ends)",
    },
    KeyEntry {
        swatch: Swatch::LineToDot(PUSH_ELSEWHERE),
        label: "push to a buffer spot or waypoint",
    },
    KeyEntry {
        swatch: Swatch::Line(TIP_TRAVEL),
        label: "tip travel between pushes (tip lifted)",
    },
];

/// Draws `plan` over `layout` into `path` (.svg or .png), its key under it.
pub fn draw(plan: &Plan, layout: &Layout, path: &Path) -> anyhow::Result<()> {
    let scale = 6.0; // pixels per um
    let field_px = (
        (layout.field_m[0] * 1e6 * scale).clamp(200.0, 4000.0) as u32,
        (layout.field_m[1] * 1e6 * scale).clamp(200.0, 4000.0) as u32,
    );
    // Wide enough for the key's longest line, the field drawn from the left.
    let (w, h) = (
        field_px.0.max(key_width_px(&KEY)),
        field_px.1 + key_height_px(&KEY),
    );
    match overlay_kind(path)? {
        OverlayKind::Svg => paint(
            SVGBackend::new(path, (w, h)).into_drawing_area(),
            field_px,
            plan,
            layout,
        ),
        OverlayKind::Png => paint(
            BitMapBackend::new(path, (w, h)).into_drawing_area(),
            field_px,
            plan,
            layout,
        ),
    }
}

fn paint<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    field_px: (u32, u32),
    plan: &Plan,
    layout: &Layout,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let map_err =
        |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("overlay drawing failed: {e:?}");
    root.fill(&WHITE).map_err(map_err)?;
    let (field, key) = root.split_vertically(field_px.1);
    draw_key(&key, &KEY).map_err(anyhow::Error::msg)?;
    let root = field.shrink((0, 0), field_px);
    let (pw, ph) = root.dim_in_pixel();
    let fw = layout.field_m[0] * 1e6;
    let sx = pw as f64 / fw;
    let px = |x: f64, y: f64| ((x * 1e6 * sx) as i32, (ph as f64 - y * 1e6 * sx) as i32);
    let rad = |r: f64| (r * 1e6 * sx).max(1.0) as i32;
    for p in &layout.particles {
        root.draw(&Circle::new(
            px(p.centre_m.x, p.centre_m.y),
            rad(p.radius_m),
            PARTICLE.filled(),
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
                let colour = if to_site {
                    PUSH_TO_SITE
                } else {
                    PUSH_ELSEWHERE
                };
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
                    TIP_TRAVEL,
                ))
                .map_err(map_err)?;
            }
            Step::CoarseMove { .. } => {}
        }
    }
    root.present().map_err(map_err)?;
    Ok(())
}
