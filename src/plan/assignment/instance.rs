//! Assignment instances: the benchmark block (sites in a compact square,
//! particles around it) and the `nanopush.assignment-instance/1` JSON file
//! that carries an instance to the scipy peer script and back.

use nalgebra::Vector2;

/// Schema tag of an instance file.
pub const INSTANCE_SCHEMA: &str = "nanopush.assignment-instance/1";

/// The benchmark instance: a compact square block of `n` sites at pitch 11 um
/// (10 um particles, 1 um gap) centred in a square field where 2n particles
/// (uniform, seeded, gaps >= 1 um) cover 10 % of the area. Metres.
pub fn block_instance(n: usize, seed: u64) -> (Vec<Vector2<f64>>, crate::plan::Layout) {
    use crate::plan::synth_layout::{LayoutKind, SynthParams, synth_layout};
    let r = 5e-6;
    let m = 2 * n;
    let side = (m as f64 * std::f64::consts::PI * r * r / 0.10).sqrt();
    let cols = (n as f64).sqrt().ceil() as usize;
    let pitch = 11e-6;
    let half = (cols as f64 - 1.0) * pitch / 2.0;
    let c = side / 2.0;
    let sites = (0..n)
        .map(|i| {
            Vector2::new(
                c - half + (i % cols) as f64 * pitch,
                c - half + (i / cols) as f64 * pitch,
            )
        })
        .collect();
    let p = SynthParams {
        n: m,
        field_m: [side, side],
        radius_m: r,
        min_gap_m: 1e-6,
        polydisperse: false,
        kind: LayoutKind::Uniform,
        seed,
    };
    let layout = synth_layout(&p).expect("10 % coverage is always placeable");
    (sites, layout)
}

/// Writes an instance as JSON (`{"schema", "sites": [[x_um, y_um]...],
/// "particles": [...]}`), for `scripts/peers/scipy_lsa.py`.
pub fn instance_json(sites: &[Vector2<f64>], parts: &[Vector2<f64>]) -> String {
    let um = |v: &[Vector2<f64>]| v.iter().map(|p| [p.x * 1e6, p.y * 1e6]).collect::<Vec<_>>();
    serde_json::json!({"schema": INSTANCE_SCHEMA, "sites": um(sites), "particles": um(parts)})
        .to_string()
}

/// Why an instance file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum InstanceError {
    /// Not JSON of the expected shape.
    #[error("assignment instance: {0}")]
    Json(#[from] serde_json::Error),
    /// Another schema.
    #[error("assignment instance: schema is {0:?}, expected {INSTANCE_SCHEMA:?}")]
    Schema(String),
    /// A coordinate is NaN or infinite.
    #[error("assignment instance: {what} {index} has a non-finite coordinate")]
    NotFinite {
        /// "site" or "particle".
        what: &'static str,
        /// Index in its list.
        index: usize,
    },
}

/// Sites and particles of an instance, metres.
pub type Instance = (Vec<Vector2<f64>>, Vec<Vector2<f64>>);

/// Reads what [`instance_json`] writes: (sites, particles) in metres.
pub fn read_instance_json(text: &str) -> Result<Instance, InstanceError> {
    #[derive(serde::Deserialize)]
    struct File {
        schema: String,
        sites: Vec<[f64; 2]>,
        particles: Vec<[f64; 2]>,
    }
    let f: File = serde_json::from_str(text)?;
    if f.schema != INSTANCE_SCHEMA {
        return Err(InstanceError::Schema(f.schema));
    }
    let metres = |what: &'static str, v: Vec<[f64; 2]>| {
        v.into_iter()
            .enumerate()
            .map(|(index, [x, y])| {
                if x.is_finite() && y.is_finite() {
                    Ok(Vector2::new(x * 1e-6, y * 1e-6))
                } else {
                    Err(InstanceError::NotFinite { what, index })
                }
            })
            .collect::<Result<Vec<_>, _>>()
    };
    Ok((metres("site", f.sites)?, metres("particle", f.particles)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_instance_file_reads_back() {
        let (sites, layout) = block_instance(20, 3);
        let parts: Vec<_> = layout.particles.iter().map(|p| p.centre_m).collect();
        assert_eq!((sites.len(), parts.len()), (20, 40));
        let (s2, p2) = read_instance_json(&instance_json(&sites, &parts)).unwrap();
        for (a, b) in sites.iter().zip(&s2).chain(parts.iter().zip(&p2)) {
            assert!((a - b).norm() < 1e-15, "{a} vs {b}");
        }
        assert!(matches!(
            read_instance_json(r#"{"schema": "x", "sites": [], "particles": []}"#),
            Err(InstanceError::Schema(_))
        ));
        // JSON has no NaN or infinity; an overflowing number is refused too.
        let huge = r#"{"schema": "nanopush.assignment-instance/1", "sites": [[1e999, 0]], "particles": []}"#;
        assert!(read_instance_json(huge).is_err());
    }
}
