//! Camera line defects: a dead, hot or off-gain sensor column or row (or two
//! side by side). One such line sets the probe search's dark level at its
//! counts and cuts the probe's silhouette in two, and the particle search
//! takes its ends for rings, so it is found and filled in from the lines
//! beside it before any stage sees the frame.
//!
//! A line is defective when its mean stands off from the lines on both sides
//! in the same direction while those two agree: a blurred edge of the scene
//! (the probe's, a particle's) lies between its neighbours, so only a feature
//! one or two pixels wide and as long as the frame qualifies. How far off is
//! measured against the frame itself (the spread of every line's second
//! difference, and the per-pixel noise), so 8- and 16-bit cameras, column
//! fixed-pattern noise and interlaced rows do not count.
//!
//! A lossy codec (JPEG, an MJPG or mp4 video's frames) smooths the pixel
//! noise away and rings beside the scene's straight edges, within its 8 px
//! blocks: the columns beside a probe's edge stood off by 1-3 counts in
//! their means along its length, and were taken for sensor lines. In such
//! a frame a place along a line counts only where the scene beside it,
//! within a block, has no step larger than the line's own offset there.

use std::borrow::Cow;
use std::fmt;

use serde::{Deserialize, Serialize};

use super::cpu_dispatch::avx2_dispatch;
use super::frame::Frame;
use super::log_on_change::changed;
use super::noise::{MIN_NOISE_COUNTS, estimate_noise_sigma};
use crate::median::upper_median;

/// Widest run of neighbouring defective lines repaired as one.
pub const MAX_RUN: usize = 2;

/// Fewest lines along an axis for that axis to be looked at: the robust
/// spread needs a population of lines.
const MIN_LINES: usize = 16;

/// A defect's mean is off by at least this many robust spreads of the
/// frame's line second differences (a frame's own column-to-column texture).
const SPREAD_MULTIPLE: f64 = 20.0;

/// ... and by at least this many per-pixel noise sigmas: fainter stripes are
/// lost in the noise of each pixel and do not mislead the detectors.
const NOISE_MULTIPLE: f64 = 4.0;

/// Along a defective line, at least this many pixels (or an eighth of the
/// line, if more; all of a shorter line) stand off their neighbours' line
/// by [`NOISE_MULTIPLE`] noise sigmas the run's way: a sensor line is off
/// along its length, while the centre line of a round feature (a particle
/// in a nearly noiseless frame, whose line means have almost no spread)
/// is off only across the feature.
const MIN_LINE_PIXELS: usize = 64;

/// Lines on either side of a run looked at for an edge of the scene, when
/// a lossy codec has smoothed the frame's noise away: a JPEG or MPEG block,
/// within which the codec's error at an edge stays.
const CODEC_BLOCK: usize = 8;

/// The lines nearest a run, left out of that look: the codec smears a
/// sensor line into them.
const CODEC_SMEAR: usize = 2;

/// Sensor column (x) or row (y).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LineAxis {
    /// A column of pixels (fixed x).
    Column,
    /// A row of pixels (fixed y).
    Row,
}

/// One repaired line (as `nanopush detect --json` writes it too).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LineDefect {
    /// Column or row.
    pub axis: LineAxis,
    /// Its x (column) or y (row), pixels.
    pub index: usize,
    /// Its mean count as read.
    pub mean_counts: f64,
    /// The mean of the good lines beside it (what it was repaired towards).
    pub beside_counts: f64,
}

impl fmt::Display for LineAxis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LineAxis::Column => "column",
            LineAxis::Row => "row",
        })
    }
}

impl LineDefect {
    /// Where it is: "column 200", "row 7".
    pub fn place(&self) -> String {
        format!("{} {}", self.axis, self.index)
    }
}

impl fmt::Display for LineDefect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (mean {:.0} counts, {:.0} beside it)",
            self.place(),
            self.mean_counts,
            self.beside_counts
        )
    }
}

/// The frame with its defective lines filled in from the lines beside them
/// (borrowed unchanged when it has none), and the lines repaired.
pub fn repair_line_defects(frame: &Frame) -> (Cow<'_, Frame>, Vec<LineDefect>) {
    let (w, h) = (frame.width(), frame.height());
    let (column_means, row_means) = line_means(frame);
    // The per-pixel noise floor is asked only when the lines' own spread
    // finds a candidate (most frames have none, and it is most of the cost).
    let runs = |noise_sigma| {
        (
            defective_runs(&column_means, noise_sigma),
            defective_runs(&row_means, noise_sigma),
        )
    };
    let (columns, rows) = runs(0.0);
    if columns.is_empty() && rows.is_empty() {
        return (Cow::Borrowed(frame), Vec::new());
    }
    let noise = estimate_noise_sigma(frame);
    let (mut columns, mut rows) = runs(noise);
    let px = frame.pixels();
    // The white estimate at its quantisation floor: the pixel noise is
    // smoothed away (a lossy codec, or no noise at all).
    let smoothed = noise <= MIN_NOISE_COUNTS;
    let column_place = |line, along| along * w + line;
    let row_place = |line, along| line * w + along;
    columns.retain(|run| run.off_along(px, (h, w), noise, smoothed, column_place));
    rows.retain(|run| run.off_along(px, (w, h), noise, smoothed, row_place));
    if columns.is_empty() && rows.is_empty() {
        return (Cow::Borrowed(frame), Vec::new());
    }
    let mut pixels = px.to_vec();
    let mut defects = Vec::new();
    for run in &columns {
        fill_run(run, h, &mut pixels, column_place);
        defects.extend(run.defects(LineAxis::Column, &column_means));
    }
    for run in &rows {
        fill_run(run, w, &mut pixels, row_place);
        defects.extend(run.defects(LineAxis::Row, &row_means));
    }
    let repaired = Frame::new(w, h, pixels, frame.bit_depth())
        .expect("same size as a valid frame, filled with its own finite counts");
    (Cow::Owned(repaired), defects)
}

/// Warns when `source`'s set of repaired lines first appears or changes (a
/// camera's defects persist frame after frame: the log says so once, not
/// thirty times a second).
pub fn report(source: &str, defects: &[LineDefect]) {
    if defects.is_empty() {
        return;
    }
    let lines: Vec<String> = defects
        .iter()
        .map(|d| format!("{} {}", d.axis, d.index))
        .collect();
    if changed(format!("line defects of {source}"), lines.join(", ")) {
        let list: Vec<String> = defects.iter().map(ToString::to_string).collect();
        tracing::warn!(
            "{source}: camera line defect repaired from the lines beside it: {} \
             (a dead, hot or off-gain sensor line; detections there rest on its neighbours)",
            list.join(", ")
        );
    }
}

/// Rows summed in f32 before the column sums take them into f64: 128 rows
/// of 16-bit counts stay below 2^24, exact in f32, and the f32 adds
/// vectorise (f64 sums took four times as long).
const ROW_BLOCK: usize = 128;

avx2_dispatch!(
    /// Mean count of every column and of every row, in one pass.
    fn line_means(frame: &Frame) -> (Vec<f64>, Vec<f64>) => line_means_lanes
);

#[inline(always)]
fn line_means_lanes(frame: &Frame) -> (Vec<f64>, Vec<f64>) {
    let (w, h) = (frame.width(), frame.height());
    let mut columns = vec![0.0f64; w];
    let mut block = vec![0.0f32; w];
    let mut rows = Vec::with_capacity(h);
    for rows_block in frame.pixels().chunks(ROW_BLOCK * w) {
        block.fill(0.0);
        for row in rows_block.chunks_exact(w) {
            for (sum, &p) in block.iter_mut().zip(row) {
                *sum += p;
            }
            rows.push(lane_sum(row) / w as f64);
        }
        for (sum, &b) in columns.iter_mut().zip(&block) {
            *sum += f64::from(b);
        }
    }
    for sum in &mut columns {
        *sum /= h as f64;
    }
    (columns, rows)
}

/// Sum of a row in sixteen f32 lanes, vectorised (each lane adds at most a
/// few hundred counts of 16 bits, exact in f32 for integer counts).
#[inline(always)]
fn lane_sum(row: &[f32]) -> f64 {
    let mut lanes = [0.0f32; 16];
    let chunks = row.chunks_exact(16);
    let rest: f64 = chunks.remainder().iter().map(|&p| f64::from(p)).sum();
    for chunk in chunks {
        for (lane, &p) in lanes.iter_mut().zip(chunk) {
            *lane += p;
        }
    }
    rest + lanes.iter().map(|&l| f64::from(l)).sum::<f64>()
}

/// Neighbouring defective lines `first..first + len`, with the good lines
/// beside them (one at a frame edge).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Run {
    first: usize,
    len: usize,
    before: Option<usize>,
    after: Option<usize>,
    /// Its means stand above its neighbours' (else below).
    bright: bool,
}

impl Run {
    fn lines(&self) -> std::ops::Range<usize> {
        self.first..self.first + self.len
    }

    /// What the k-th line of the run would read at one place along it, from
    /// the good lines beside it there: the line between them, or the one.
    fn expected(&self, k: usize, before: Option<f32>, after: Option<f32>) -> f32 {
        match (before, after) {
            (Some(b), Some(a)) => b + (k + 1) as f32 / (self.len + 1) as f32 * (a - b),
            (Some(v), None) | (None, Some(v)) => v,
            (None, None) => unreachable!("a run has a good line beside it"),
        }
    }

    /// True when enough of the run's places along its length stand off
    /// (see [`MIN_LINE_PIXELS`]); `(length, across)` are the lines' length
    /// and their number. In a `smoothed` frame a place beside an edge of
    /// the scene does not count ([`Self::beside_an_edge`]).
    fn off_along(
        &self,
        pixels: &[f32],
        (length, across): (usize, usize),
        noise_sigma: f64,
        smoothed: bool,
        place: impl Fn(usize, usize) -> usize,
    ) -> bool {
        let by = (NOISE_MULTIPLE * noise_sigma) as f32;
        let needed = MIN_LINE_PIXELS.max(length / 8).min(length);
        let off = (0..length)
            .filter(|&along| {
                let before = self.before.map(|l| pixels[place(l, along)]);
                let after = self.after.map(|l| pixels[place(l, along)]);
                let mut least = f32::INFINITY;
                let all_off = self.lines().enumerate().all(|(k, line)| {
                    let o = pixels[place(line, along)] - self.expected(k, before, after);
                    least = least.min(o.abs());
                    if self.bright { o > by } else { o < -by }
                });
                all_off && !(smoothed && self.beside_an_edge(pixels, across, along, least, &place))
            })
            .count();
        off >= needed
    }

    /// True when, at `along`, two neighbouring pixels within a codec block
    /// on either side of the run (its [`CODEC_SMEAR`] nearest lines left
    /// out) differ by more than the run's offset `off` there: a lossy
    /// codec's ringing beside an edge of the scene, while a sensor line
    /// stands off where the scene beside it is flat (the codec's own
    /// smearing of it is smaller than the line's offset).
    fn beside_an_edge(
        &self,
        pixels: &[f32],
        across: usize,
        along: usize,
        off: f32,
        place: impl Fn(usize, usize) -> usize,
    ) -> bool {
        let last = self.first + self.len - 1;
        let lo = self.first.saturating_sub(CODEC_BLOCK);
        let hi = (last + CODEC_BLOCK).min(across - 1);
        (lo..hi)
            .filter(|&x| x + 1 + CODEC_SMEAR < self.first || x > last + CODEC_SMEAR)
            .any(|x| (pixels[place(x + 1, along)] - pixels[place(x, along)]).abs() > off)
    }

    fn beside_mean(&self, means: &[f64]) -> f64 {
        let beside: Vec<f64> = [self.before, self.after]
            .into_iter()
            .flatten()
            .map(|l| means[l])
            .collect();
        beside.iter().sum::<f64>() / beside.len() as f64
    }

    fn defects(&self, axis: LineAxis, means: &[f64]) -> Vec<LineDefect> {
        let beside_counts = self.beside_mean(means);
        self.lines()
            .map(|index| LineDefect {
                axis,
                index,
                mean_counts: means[index],
                beside_counts,
            })
            .collect()
    }
}

/// The runs of at most [`MAX_RUN`] lines whose means all stand off the same
/// way, by more than the threshold, from the line between the good lines
/// beside them, while those two differ by less than half that (at a frame
/// edge: the good line and the next one in). A blurred edge of the scene
/// fails the second test: its neighbours differ by its whole step.
fn defective_runs(means: &[f64], noise_sigma: f64) -> Vec<Run> {
    let n = means.len();
    if n < MIN_LINES {
        return Vec::new();
    }
    let threshold = threshold(means, noise_sigma);
    let mut runs = Vec::new();
    let mut first = 0;
    while first < n {
        let found = (1..=MAX_RUN).find_map(|len| {
            let end = first + len;
            if end > n {
                return None;
            }
            let before = first.checked_sub(1);
            let after = (end < n).then_some(end);
            // The run's expected means (the line between its neighbours, or
            // the one neighbour's level at an edge) and how far apart the
            // neighbours are.
            let (from, to, spread) = match (before, after) {
                (Some(b), Some(a)) => (means[b], means[a], (means[a] - means[b]).abs()),
                (None, Some(a)) if a + 1 < n => {
                    (means[a], means[a], (means[a] - means[a + 1]).abs())
                }
                (Some(b), None) if b >= 1 => (means[b], means[b], (means[b] - means[b - 1]).abs()),
                _ => return None,
            };
            let offs: Vec<f64> = (first..end)
                .map(|k| {
                    let t = (k + 1 - first) as f64 / (len + 1) as f64;
                    means[k] - (from + t * (to - from))
                })
                .collect();
            let least = offs.iter().map(|o| o.abs()).fold(f64::INFINITY, f64::min);
            let one_way = offs.iter().all(|&o| o > 0.0) || offs.iter().all(|&o| o < 0.0);
            (one_way && least > threshold && spread <= 0.5 * least).then_some(Run {
                first,
                len,
                before,
                after,
                bright: offs[0] > 0.0,
            })
        });
        match found {
            Some(run) => {
                first += run.len;
                runs.push(run);
            }
            None => first += 1,
        }
    }
    runs
}

/// How far a line's mean must stand off its neighbours to be a defect: the
/// larger of [`SPREAD_MULTIPLE`] robust spreads of every interior line's
/// second difference and [`NOISE_MULTIPLE`] per-pixel noise sigmas.
fn threshold(means: &[f64], noise_sigma: f64) -> f64 {
    let mut second: Vec<f64> = means
        .windows(3)
        .map(|w| w[1] - 0.5 * (w[0] + w[2]))
        .collect();
    let centre = upper_median(&mut second).unwrap_or(0.0);
    let mut deviations: Vec<f64> = second.iter().map(|d| (d - centre).abs()).collect();
    let spread = 1.4826 * upper_median(&mut deviations).unwrap_or(0.0);
    (SPREAD_MULTIPLE * spread).max(NOISE_MULTIPLE * noise_sigma)
}

/// Fills a run's pixels, line by line along its length, by linear
/// interpolation between the good lines beside it (a copy of the one good
/// line at a frame edge). `place(line, along)` is the pixel's index.
fn fill_run(run: &Run, length: usize, pixels: &mut [f32], place: impl Fn(usize, usize) -> usize) {
    for along in 0..length {
        let before = run.before.map(|l| pixels[place(l, along)]);
        let after = run.after.map(|l| pixels[place(l, along)]);
        for (k, line) in run.lines().enumerate() {
            pixels[place(line, along)] = run.expected(k, before, after);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    const W: usize = 96;
    const H: usize = 80;

    /// A smooth background (a gradient), a probe-like dark band with
    /// blurred vertical and horizontal edges, and Gaussian noise of 20 counts.
    fn scene(seed: u64) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, 20.0).unwrap();
        let edge = |d: f64| 1.0 / (1.0 + (-d / 0.8).exp());
        let mut px = Vec::with_capacity(W * H);
        for y in 0..H {
            for x in 0..W {
                let band = edge(x as f64 - 40.0) * edge(60.0 - x as f64) * edge(y as f64 - 30.0);
                let v = 20_000.0 + 40.0 * x as f64 - 25.0 * y as f64 - 15_000.0 * band;
                px.push((v + noise.sample(&mut rng)) as f32);
            }
        }
        px
    }

    fn frame(px: Vec<f32>) -> Frame {
        Frame::new(W, H, px, 16).unwrap()
    }

    /// No defect found, and the frame itself handed back, not a copy.
    fn assert_left_alone(f: &Frame) {
        let (repaired, defects) = repair_line_defects(f);
        assert!(defects.is_empty(), "{defects:?}");
        assert!(matches!(repaired, Cow::Borrowed(_)));
    }

    #[test]
    fn sharp_edges_interlacing_and_column_offsets_are_not_defects() {
        let mut px = scene(1);
        // Interlaced rows (every other row 60 counts up) and column
        // fixed-pattern offsets of a few counts: the frame's own texture.
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let offsets: Vec<f32> = (0..W)
            .map(|_| Normal::new(0.0, 8.0).unwrap().sample(&mut rng) as f32)
            .collect();
        for y in 0..H {
            for x in 0..W {
                px[y * W + x] += offsets[x] + if y % 2 == 0 { 60.0 } else { 0.0 };
            }
        }
        assert_left_alone(&frame(px));
    }

    #[test]
    fn dead_hot_paired_and_edge_lines_are_filled_from_their_neighbours() {
        let clean = scene(3);
        let mut px = clean.clone();
        for y in 0..H {
            px[y * W + 50] = 0.0; // dead column across the dark band
            px[y * W + 70] *= 0.6; // off-gain column
            px[y * W + 71] *= 0.6; // ... and its neighbour
            px[y * W] = 65_535.0; // hot column at the frame's edge
        }
        for x in 0..W {
            px[20 * W + x] = 65_535.0; // hot row
        }
        let f = frame(px);
        let (repaired, defects) = repair_line_defects(&f);
        let found: Vec<(LineAxis, usize)> = defects.iter().map(|d| (d.axis, d.index)).collect();
        assert_eq!(
            found,
            [
                (LineAxis::Column, 0),
                (LineAxis::Column, 50),
                (LineAxis::Column, 70),
                (LineAxis::Column, 71),
                (LineAxis::Row, 20),
            ]
        );
        // Dead but for the hot row's pixel; beside it the scene, partly the band.
        assert!(defects[1].mean_counts < 1_000.0, "{}", defects[1]);
        assert!(defects[1].beside_counts > 10_000.0, "{}", defects[1]);
        // Every repaired pixel is its neighbours' interpolation (a copy of
        // the one good neighbour at the edge), so close to the clean frame
        // where the scene is smooth: within the noise of two pixels.
        let r = repaired.as_ref();
        for y in (0..H).filter(|&y| y != 20) {
            let at = |x: usize| r.at(x, y);
            assert_eq!(at(50), 0.5 * (at(49) + at(51)), "row {y}");
            assert_eq!(at(0), at(1), "row {y}");
            let third = at(69) + (at(72) - at(69)) / 3.0;
            assert!((at(70) - third).abs() < 1e-2, "row {y}");
            for x in [70, 71] {
                assert!((at(x) - clean[y * W + x]).abs() < 100.0, "({x}, {y})");
            }
        }
        for x in 1..W {
            assert!((r.at(x, 20) - clean[20 * W + x]).abs() < 100.0, "({x}, 20)");
        }
    }

    #[test]
    fn a_round_feature_of_a_noiseless_frame_is_not_a_defect() {
        // Without noise the line means have almost no spread, and the
        // centre lines of a round spot stand off their neighbours (the
        // same way on both sides): only the pixels along a line tell them
        // from a sensor line. Rounded to counts, as a 16-bit camera's. (One
        // spot: with many, the lines through them make the spread.)
        let spots = [(50.0, 41.0)];
        let mut px = Vec::with_capacity(W * H);
        for y in 0..H {
            for x in 0..W {
                let spots_here: f64 = spots
                    .iter()
                    .map(|&(sx, sy)| {
                        let r2 = (x as f64 - sx).powi(2) + (y as f64 - sy).powi(2);
                        5_000.0 * (-r2 / 18.0).exp()
                    })
                    .sum();
                px.push((20_000.0 + spots_here).round() as f32);
            }
        }
        assert_left_alone(&frame(px));
    }

    #[test]
    fn small_frames_and_lines_a_frame_wide_feature_crosses_are_left_alone() {
        // Too few rows to judge columns by: nothing is touched.
        let mut px = vec![100.0f32; 10 * 10];
        px[55] = 0.0;
        for y in 0..10 {
            px[y * 10 + 4] = 0.0;
        }
        assert_left_alone(&Frame::new(10, 10, px, 8).unwrap());
        // A dark band three columns wide is scene, not a sensor line.
        let mut px = scene(4);
        for y in 0..H {
            for x in 20..23 {
                px[y * W + x] = 100.0;
            }
        }
        assert_left_alone(&frame(px));
    }
}
