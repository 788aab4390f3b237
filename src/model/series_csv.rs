//! The push time series as CSV in lab units (written by `simulate --out`,
//! read back by tests and by anyone re-plotting).

use super::push_sim::SeriesRow;
use std::fmt::Write as _;

/// The CSV header (units in the column names).
pub const HEADER: &str =
    "t_s,stage_um,tip_um,particle_um,force_uN,critical_rolling_uN,critical_sliding_uN";

/// Renders rows as CSV; locked critical forces are written as `inf`.
pub fn to_csv(rows: &[SeriesRow]) -> String {
    let mut s = String::from(HEADER);
    s.push('\n');
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{}",
            r.t_s,
            r.stage_m * 1e6,
            r.tip_m * 1e6,
            r.particle_m * 1e6,
            r.force_n * 1e6,
            r.critical_rolling_n * 1e6,
            r.critical_sliding_n * 1e6
        );
    }
    s
}

/// Parses CSV written by [`to_csv`] back into SI rows.
pub fn from_csv(text: &str) -> Result<Vec<SeriesRow>, String> {
    let mut lines = text.lines();
    if lines.next() != Some(HEADER) {
        return Err(format!("expected header `{HEADER}`"));
    }
    lines
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            let v: Vec<f64> = l
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| format!("line {}: {e}", i + 2))?;
            if v.len() != 7 {
                return Err(format!(
                    "line {}: expected 7 columns, got {}",
                    i + 2,
                    v.len()
                ));
            }
            Ok(SeriesRow {
                t_s: v[0],
                stage_m: v[1] * 1e-6,
                tip_m: v[2] * 1e-6,
                particle_m: v[3] * 1e-6,
                force_n: v[4] * 1e-6,
                critical_rolling_n: v[5] * 1e-6,
                critical_sliding_n: v[6] * 1e-6,
            })
        })
        .collect()
}
