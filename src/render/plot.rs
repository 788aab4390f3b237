//! A small reusable line chart: named time series -> SVG and PNG (plotters).
//! Used for the push plots and the model study; any module can draw with it.

use plotters::prelude::*;
use std::path::Path;

/// One named line.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// (x, y) points; non-finite points are skipped (a locked critical force is +inf).
    pub points: Vec<(f64, f64)>,
}

/// A line chart with axis labels (put units in them) and a legend.
#[derive(Debug, Clone)]
pub struct LineChart {
    /// Title above the plot.
    pub title: String,
    /// X-axis label with unit.
    pub x_label: String,
    /// Y-axis label with unit.
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
    /// Draw markers on points (for sparse data such as a study).
    pub markers: bool,
    /// Join points with lines (false: a scatter plot with markers).
    pub lines: bool,
    /// Use a logarithmic x axis (positive x only).
    pub log_x: bool,
}

const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
];

impl LineChart {
    fn bounds(&self) -> (f64, f64, f64, f64) {
        let pts = self
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|p| p.0.is_finite() && p.1.is_finite() && (!self.log_x || p.0 > 0.0));
        let (mut x0, mut x1, mut y0, mut y1) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for &(x, y) in pts {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if !x0.is_finite() {
            return (0.0, 1.0, 0.0, 1.0);
        }
        if x1 <= x0 {
            x1 = x0 + 1.0;
        }
        if y1 <= y0 {
            y1 = y0 + 1.0;
        }
        let pad = 0.05 * (y1 - y0);
        (x0, x1, (y0 - pad).min(0.0f64.max(y0 - pad)), y1 + pad)
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: DrawingArea<DB, plotters::coord::Shift>,
    ) -> Result<(), String>
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (x0, x1, y0, y1) = self.bounds();
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(&self.title, ("sans-serif", 24))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70);
        macro_rules! body {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(&self.x_label)
                    .y_desc(&self.y_label)
                    .label_style(("sans-serif", 16))
                    .draw()
                    .map_err(|e| e.to_string())?;
                for (i, s) in self.series.iter().enumerate() {
                    let color = PALETTE[i % PALETTE.len()];
                    let pts: Vec<(f64, f64)> = s
                        .points
                        .iter()
                        .copied()
                        .filter(|p| {
                            p.0.is_finite() && p.1.is_finite() && (!self.log_x || p.0 > 0.0)
                        })
                        .collect();
                    if self.lines {
                        chart
                            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                            .map_err(|e| e.to_string())?
                            .label(s.name.clone())
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                            });
                    }
                    if self.markers || !self.lines {
                        let drawn = chart
                            .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
                            .map_err(|e| e.to_string())?;
                        if !self.lines {
                            drawn
                                .label(s.name.clone())
                                .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
                        }
                    }
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 16))
                    .position(if self.lines {
                        SeriesLabelPosition::UpperLeft
                    } else {
                        SeriesLabelPosition::MiddleRight
                    })
                    .draw()
                    .map_err(|e| e.to_string())?;
            }};
        }
        if self.log_x {
            body!(
                builder
                    .build_cartesian_2d((x0..x1).log_scale(), y0..y1)
                    .map_err(|e| e.to_string())?
            );
        } else {
            body!(
                builder
                    .build_cartesian_2d(x0..x1, y0..y1)
                    .map_err(|e| e.to_string())?
            );
        }
        root.present().map_err(|e| e.to_string())
    }

    /// Writes the chart as SVG.
    pub fn write_svg(&self, path: &Path, size: (u32, u32)) -> Result<(), String> {
        self.draw(SVGBackend::new(path, size).into_drawing_area())
    }

    /// Writes the chart as PNG.
    pub fn write_png(&self, path: &Path, size: (u32, u32)) -> Result<(), String> {
        self.draw(BitMapBackend::new(path, size).into_drawing_area())
    }

    /// Writes `stem.svg` and `stem.png` in `dir`; returns both paths.
    pub fn write_both(&self, dir: &Path, stem: &str) -> Result<Vec<std::path::PathBuf>, String> {
        let svg = dir.join(format!("{stem}.svg"));
        let png = dir.join(format!("{stem}.png"));
        self.write_svg(&svg, (900, 560))?;
        self.write_png(&png, (900, 560))?;
        Ok(vec![svg, png])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_svg_and_png_with_labels() {
        let dir = tempfile::tempdir().unwrap();
        let chart = LineChart {
            title: "t".into(),
            x_label: "time [s]".into(),
            y_label: "force [uN]".into(),
            series: vec![Series {
                name: "a".into(),
                points: vec![(0.0, 0.0), (1.0, 2.0), (2.0, f64::INFINITY)],
            }],
            markers: true,
            lines: true,
            log_x: false,
        };
        let paths = chart.write_both(dir.path(), "c").unwrap();
        let svg = std::fs::read_to_string(&paths[0]).unwrap();
        assert!(svg.contains("time [s]") && svg.contains("force [uN]"));
        let img = image::open(&paths[1]).unwrap();
        assert_eq!((img.width(), img.height()), (900, 560));
    }
}
