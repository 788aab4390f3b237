//! The two push plots (force vs time, position vs time) and the CSV, written
//! into one directory; shared by `simulate --out` and `demo`.

use super::push_sim::SeriesRow;
use super::series_csv;
use crate::render::plot::{LineChart, Series};
use std::path::{Path, PathBuf};

/// Writes `push-series.csv`, `push-force.{svg,png}` and `push-position.{svg,png}`.
pub fn write_push_outputs(
    dir: &Path,
    title: &str,
    rows: &[SeriesRow],
) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let csv = dir.join("push-series.csv");
    std::fs::write(&csv, series_csv::to_csv(rows))
        .map_err(|e| format!("cannot write {}: {e}", csv.display()))?;
    let line = |name: &str, f: &dyn Fn(&SeriesRow) -> f64| Series {
        name: name.into(),
        points: rows.iter().map(|r| (r.t_s, f(r))).collect(),
    };
    let force = LineChart {
        title: format!("{title}: pushing force vs critical forces"),
        x_label: "time [s]".into(),
        y_label: "force [uN]".into(),
        series: vec![
            line("pushing force F_T", &|r| r.force_n * 1e6),
            line("critical rolling F_r*", &|r| r.critical_rolling_n * 1e6),
            line("critical sliding F_s*", &|r| r.critical_sliding_n * 1e6),
        ],
        markers: false,
        lines: true,
        log_x: false,
    };
    let position = LineChart {
        title: format!("{title}: positions along the push"),
        x_label: "time [s]".into(),
        y_label: "position [um]".into(),
        series: vec![
            line("stage", &|r| r.stage_m * 1e6),
            line("tip apex", &|r| r.tip_m * 1e6),
            line("particle", &|r| r.particle_m * 1e6),
        ],
        markers: false,
        lines: true,
        log_x: false,
    };
    let mut out = vec![csv];
    out.extend(force.write_both(dir, "push-force")?);
    out.extend(position.write_both(dir, "push-position")?);
    Ok(out)
}
