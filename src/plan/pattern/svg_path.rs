//! SVG patterns: every path of a drawing (lines, curves and shapes, after
//! their transforms) sampled at the pitch. One SVG user unit is a
//! micrometre, and y goes down the page, as in a bitmap.
//!
//! Sites follow each path a pitch apart in straight-line distance (a
//! divider walked along it), so a corner does not bring two sites closer
//! than the pitch; a site that would fall within a pitch of an earlier one
//! (where paths cross, touch or close) is left out.
//!
//! Only outlines give sites: a fill's interior gives none (a filled shape is
//! a bitmap pattern) and embedded images are ignored. Text is refused: there
//! are no fonts to draw it with, and dropping it would drop the letters.

use super::{Pattern, PatternError};
use crate::plan::occupancy::Occupancy;
use crate::plan::value_sign::Sign;
use nalgebra::Vector2;
use std::path::Path;

/// Most sites a drawing may give: a long path at a small pitch is more
/// likely a wrong pitch or unit than a pattern (CMU has 31).
pub const MAX_SVG_SITES: usize = 1_000_000;

/// Pieces a curve is flattened into per pitch of its control polygon's
/// length: fine enough that the sites lie within about 0.1 % of the pitch
/// of the true curve.
const PIECES_PER_PITCH: f64 = 16.0;

/// Reads an SVG file as a pattern at `pitch_m`.
pub fn read_svg(path: &Path, pitch_m: f64) -> Result<Pattern, PatternError> {
    let origin = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| PatternError::File {
        path: origin.clone(),
        message: e.to_string(),
    })?;
    pattern_from_svg(&text, pitch_m, &origin)
}

/// Sites along the paths of the SVG document `text` at `pitch_m`.
pub fn pattern_from_svg(text: &str, pitch_m: f64, origin: &str) -> Result<Pattern, PatternError> {
    super::check_value("pitch_um", pitch_m * 1e6, Sign::Positive)?;
    let tree =
        usvg::Tree::from_str(text, &usvg::Options::default()).map_err(|e| PatternError::File {
            path: origin.into(),
            message: format!("not an SVG drawing: {e}"),
        })?;
    refuse_text(text, origin)?;
    let pitch_um = pitch_m * 1e6;
    let mut polylines = Vec::new();
    collect_polylines(tree.root(), pitch_um, &mut polylines);
    // Sites as points kept a pitch (less rounding) apart.
    let mut sites = Occupancy::empty(pitch_um);
    let near = pitch_um * (1.0 - 1e-6);
    for line in &polylines {
        let span = loop_span(line, pitch_um).unwrap_or(pitch_um);
        let within = divide(line, span, |p| {
            if sites.disc_free(p, 0.0, None, near) {
                sites.push(p, 0.0);
            }
            sites.pos.len() <= MAX_SVG_SITES
        });
        if !within {
            return Err(PatternError::File {
                path: origin.into(),
                message: format!(
                    "more than {MAX_SVG_SITES} sites at a pitch of {pitch_um} um: is the pitch or the drawing's unit (1 user unit = 1 um) right?"
                ),
            });
        }
    }
    // A drawing within one pitch gives one site: a heart whose viewBox
    // scaled it to 6 um had planned as one site, "pushes 0", without a word.
    if sites.pos.len() == 1 {
        let points: Vec<Vector2<f64>> = polylines.iter().flatten().copied().collect();
        let (lo, hi) = super::bbox(&points);
        return Err(PatternError::File {
            path: origin.into(),
            message: format!(
                "its paths span {:.2} x {:.2} um, within one pitch ({pitch_um} um): one site. Draw it larger (1 user unit = 1 um, after any viewBox) or give a smaller --pitch-um",
                hi.x - lo.x,
                hi.y - lo.y
            ),
        });
    }
    let offsets = sites
        .pos
        .iter()
        .map(|p| Vector2::new(p.x, -p.y) * 1e-6)
        .collect();
    Pattern::from_offsets(offsets, &format!("{origin} has no path"))
}

/// Refuses a drawing with text in it. usvg (built without fonts) drops text
/// without a word, and a drawing's letters are most likely the pattern: the
/// user would get the other paths' sites and never know the letters were
/// left out.
fn refuse_text(text: &str, origin: &str) -> Result<(), PatternError> {
    // usvg reports a document that does not parse; nothing to add here.
    let Ok(doc) = roxmltree::Document::parse(text) else {
        return Ok(());
    };
    let texts = doc
        .descendants()
        .filter(|n| n.has_tag_name(("http://www.w3.org/2000/svg", "text")))
        .filter(|n| {
            n.descendants()
                .any(|d| d.text().is_some_and(|t| !t.trim().is_empty()))
        })
        .count();
    if texts == 0 {
        return Ok(());
    }
    Err(PatternError::File {
        path: origin.into(),
        message: format!(
            "holds {texts} text element(s), which nanopush cannot turn into sites (no fonts): \
             convert the text to paths (Inkscape: Path > Object to Path) or give the letters with --text"
        ),
    })
}

/// Each subpath of every path under `group`, flattened, in user units with
/// the transforms applied.
fn collect_polylines(group: &usvg::Group, pitch_um: f64, out: &mut Vec<Vec<Vector2<f64>>>) {
    for node in group.children() {
        match node {
            usvg::Node::Group(g) => collect_polylines(g, pitch_um, out),
            usvg::Node::Path(p) => {
                let ts = p.abs_transform();
                let at = |pt: usvg::tiny_skia_path::Point| {
                    let mut pt = pt;
                    ts.map_point(&mut pt);
                    Vector2::new(f64::from(pt.x), f64::from(pt.y))
                };
                flatten(p.data(), at, pitch_um, out);
            }
            usvg::Node::Image(_) | usvg::Node::Text(_) => {}
        }
    }
}

/// Subpaths of `path` as polylines (curves cut into pieces).
fn flatten(
    path: &usvg::tiny_skia_path::Path,
    at: impl Fn(usvg::tiny_skia_path::Point) -> Vector2<f64>,
    pitch_um: f64,
    out: &mut Vec<Vec<Vector2<f64>>>,
) {
    use usvg::tiny_skia_path::PathSegment;
    let mut line: Vec<Vector2<f64>> = Vec::new();
    let mut finish = |line: &mut Vec<Vector2<f64>>| {
        if !line.is_empty() {
            out.push(std::mem::take(line));
        }
    };
    for segment in path.segments() {
        let last = line.last().copied();
        match segment {
            PathSegment::MoveTo(p) => {
                finish(&mut line);
                line.push(at(p));
            }
            PathSegment::LineTo(p) => line.push(at(p)),
            PathSegment::QuadTo(c, p) => {
                let from = last.unwrap_or_else(|| at(c));
                bezier(&[from, at(c), at(p)], pitch_um, &mut line);
            }
            PathSegment::CubicTo(c1, c2, p) => {
                let from = last.unwrap_or_else(|| at(c1));
                bezier(&[from, at(c1), at(c2), at(p)], pitch_um, &mut line);
            }
            PathSegment::Close => {
                if let Some(&first) = line.first() {
                    line.push(first);
                }
            }
        }
    }
    finish(&mut line);
}

/// Appends the points of the Bezier curve with control points `ctrl` after
/// its first one (already in `line`), by de Casteljau's evaluation.
fn bezier(ctrl: &[Vector2<f64>], pitch_um: f64, line: &mut Vec<Vector2<f64>>) {
    let polygon: f64 = ctrl.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    let pieces = ((polygon / pitch_um * PIECES_PER_PITCH).ceil() as usize).clamp(1, 1 << 16);
    for k in 1..=pieces {
        let t = k as f64 / pieces as f64;
        let mut pts = ctrl.to_vec();
        for n in (1..pts.len()).rev() {
            for i in 0..n {
                pts[i] = pts[i] * (1.0 - t) + pts[i + 1] * t;
            }
        }
        line.push(pts[0]);
    }
}

/// For a closed `line` (it ends where it starts), the divider's span at
/// least `pitch` whose last step lands on the start, so the sites round a
/// loop are evenly spaced: at the pitch itself the walk ends short of the
/// start and the site there, within a pitch of the first, is left out,
/// which leaves a gap of up to two pitches (18.6 um on a circle of radius
/// 20 at 10.5). None for an open line or a loop too small for two sites.
fn loop_span(line: &[Vector2<f64>], pitch: f64) -> Option<f64> {
    let (&first, &last) = (line.first()?, line.last()?);
    if line.len() < 3 || (last - first).norm() > 1e-9 * pitch {
        return None;
    }
    // A loop of more sites than a pattern may hold is refused by the
    // caller; the bisection's 60 walks along it would only delay that.
    let length: f64 = line.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    if length / pitch > MAX_SVG_SITES as f64 {
        return None;
    }
    let count = |span: f64| {
        let mut n = 0usize;
        let mut end = first;
        divide(line, span, |p| {
            n += 1;
            end = p;
            true
        });
        (n, end)
    };
    // Sites the plain divider keeps: all but a last one within a pitch of
    // the start.
    let (n, end) = count(pitch);
    let sites = if (end - first).norm() < pitch * (1.0 - 1e-6) {
        n - 1
    } else {
        n
    };
    if sites < 2 {
        return None;
    }
    // The widest span that still takes `sites` steps: its last step ends
    // on the start (the loop's end).
    let (mut lo, mut hi) = (pitch, pitch * 2.0_f64.max(sites as f64));
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if count(mid).0 > sites {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

/// Walks `line` with a divider of span `pitch`: calls `site` at its start
/// and at each point a pitch in straight line from the one before, while
/// `site` returns true; false if it stopped the walk.
fn divide(line: &[Vector2<f64>], pitch: f64, mut site: impl FnMut(Vector2<f64>) -> bool) -> bool {
    let Some(&start) = line.first() else {
        return true;
    };
    if !site(start) {
        return false;
    }
    let mut last = start;
    for w in line.windows(2) {
        let (a, b) = (w[0], w[1]);
        let d = b - a;
        let dd = d.norm_squared();
        if dd == 0.0 {
            continue;
        }
        // Points a + t d at distance pitch from `last`, in order along the
        // segment: the larger root of |a - last + t d|^2 = pitch^2.
        let mut t0 = 0.0;
        loop {
            let f = a - last;
            let (half_b, c) = (f.dot(&d), f.norm_squared() - pitch * pitch);
            let disc = half_b * half_b - dd * c;
            if disc < 0.0 {
                break;
            }
            let t = (-half_b + disc.sqrt()) / dd;
            if t > 1.0 || t < t0 {
                break;
            }
            last = a + d * t;
            if !site(last) {
                return false;
            }
            t0 = t;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn svg(body: &str) -> String {
        format!(r#"<svg xmlns="http://www.w3.org/2000/svg" width="500" height="500">{body}</svg>"#)
    }

    fn sites_um(body: &str, pitch_um: f64) -> Vec<Vector2<f64>> {
        pattern_from_svg(&svg(body), pitch_um * 1e-6, "mem")
            .unwrap()
            .offsets_m
            .iter()
            .map(|p| p * 1e6)
            .collect()
    }

    fn least_spacing(sites: &[Vector2<f64>]) -> f64 {
        let mut least = f64::INFINITY;
        for (i, a) in sites.iter().enumerate() {
            for b in &sites[i + 1..] {
                least = least.min((a - b).norm());
            }
        }
        least
    }

    #[test]
    fn a_straight_path_gives_sites_a_pitch_apart_from_its_start() {
        // 52.5 um down the page at a pitch of 10.5: 6 sites, the first at
        // the top (y up on the stage).
        let s = sites_um(r#"<path d="M 10 20 L 10 72.5" stroke="black"/>"#, 10.5);
        assert_eq!(s.len(), 6);
        for (k, p) in s.iter().enumerate() {
            assert!(p.x.abs() < 1e-4, "{p:?}");
            assert!((p.y - (26.25 - 10.5 * k as f64)).abs() < 1e-4, "{k}: {p:?}");
        }
    }

    /// A drawing within one pitch is refused, saying its size: it had
    /// given one site and planned "pushes 0".
    #[test]
    fn a_drawing_within_one_pitch_is_refused_with_its_size() {
        let shrunk = r#"<svg xmlns="http://www.w3.org/2000/svg" width="6" height="6" viewBox="0 0 600 600"><circle cx="300" cy="300" r="250" fill="none" stroke="black"/></svg>"#;
        let e = pattern_from_svg(shrunk, 10.5e-6, "mem")
            .unwrap_err()
            .to_string();
        assert!(e.contains("span 5.00 x 5.00 um, within one pitch"), "{e}");
        let small = svg(r#"<circle cx="100" cy="100" r="3" fill="none" stroke="black"/>"#);
        assert!(pattern_from_svg(&small, 10.5e-6, "mem").is_err());
    }

    #[test]
    fn a_circle_gives_sites_on_it_no_closer_than_the_pitch() {
        let s = sites_um(
            r#"<circle cx="100" cy="100" r="20" fill="none" stroke="black"/>"#,
            10.5,
        );
        // A divider of 10.5 on a radius of 20 turns 0.531 rad a step: 11
        // steps, the 12th would come within a pitch of the first.
        assert_eq!(s.len(), 11);
        // All on the circle through three of them, of radius 20 (the
        // drawing's 4 Bezier arcs and their flattening stay within 0.02 um).
        let (a, b, c) = (s[0], s[4], s[8]);
        let d = 2.0 * (a.x * (b.y - c.y) + b.x * (c.y - a.y) + c.x * (a.y - b.y));
        let centre = Vector2::new(
            (a.norm_squared() * (b.y - c.y)
                + b.norm_squared() * (c.y - a.y)
                + c.norm_squared() * (a.y - b.y))
                / d,
            (a.norm_squared() * (c.x - b.x)
                + b.norm_squared() * (a.x - c.x)
                + c.norm_squared() * (b.x - a.x))
                / d,
        );
        for p in &s {
            let r = (p - centre).norm();
            assert!((r - 20.0).abs() < 0.02, "{r}");
        }
        // Evenly round the loop: each site's nearest neighbour alike.
        let nearest: Vec<f64> = (0..s.len())
            .map(|i| least_spacing(&[s[i], s[(i + 1) % s.len()]]))
            .collect();
        let (least, most) = nearest
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &d| (a.min(d), b.max(d)));
        assert!(least >= 10.5 * (1.0 - 1e-6), "{least}");
        assert!(most - least < 0.05, "{nearest:?}");
    }

    #[test]
    fn transforms_apply_and_crossing_paths_share_no_site() {
        // Scaled twice: a 10-unit line is 20 um, 3 sites at a pitch of 10.
        let s = sites_um(
            r#"<g transform="translate(100,0) scale(2)"><path d="M 0 0 L 10 0" stroke="black"/></g>"#,
            10.0,
        );
        assert_eq!(s.len(), 3);
        let width = s.iter().map(|p| p.x).fold(f64::MIN, f64::max)
            - s.iter().map(|p| p.x).fold(f64::MAX, f64::min);
        assert!((width - 20.0).abs() < 1e-4, "{width}");
        // A plus sign: both arms pass the centre, which holds one site.
        let plus = sites_um(
            r#"<path d="M 0 20 L 40 20 M 20 0 L 20 40" stroke="black"/>"#,
            10.0,
        );
        assert_eq!(plus.len(), 9);
        assert!(least_spacing(&plus) >= 10.0 * (1.0 - 1e-6));
    }

    #[test]
    fn a_drawing_without_paths_or_not_svg_is_refused_by_name() {
        let empty = pattern_from_svg(&svg(""), 10e-6, "empty.svg").unwrap_err();
        assert!(matches!(empty, PatternError::Empty(_)), "{empty}");
        let junk = pattern_from_svg("not xml", 10e-6, "junk.svg").unwrap_err();
        assert!(
            junk.to_string().contains("junk.svg: not an SVG drawing"),
            "{junk}"
        );
        let tiny = pattern_from_svg(
            &svg(r#"<circle cx="500" cy="500" r="400" stroke="black"/>"#),
            1e-10,
            "tiny.svg",
        )
        .unwrap_err();
        assert!(tiny.to_string().contains("more than"), "{tiny}");
        let tiny_line = pattern_from_svg(
            &svg(r#"<path d="M 0 0 L 1000 0" stroke="black"/>"#),
            1e-10,
            "tiny.svg",
        )
        .unwrap_err();
        assert!(tiny_line.to_string().contains("more than"), "{tiny_line}");
    }

    #[test]
    fn a_drawing_with_text_is_refused_not_read_without_its_letters() {
        let line = r#"<path d="M 10 20 L 10 72.5" stroke="black"/>"#;
        let lettered = format!(r#"{line}<g><text x="50" y="50">C<tspan>MU</tspan></text></g>"#);
        let e = pattern_from_svg(&svg(&lettered), 10e-6, "letters.svg").unwrap_err();
        assert!(
            e.to_string()
                .contains("letters.svg: holds 1 text element(s)"),
            "{e}"
        );
        // An empty text element (an editor's leftover) holds no letters.
        let empty_text = format!(r#"{line}<text x="5" y="5">  </text>"#);
        assert_eq!(
            pattern_from_svg(&svg(&empty_text), 10.5e-6, "mem")
                .unwrap()
                .offsets_m
                .len(),
            6
        );
    }
}
