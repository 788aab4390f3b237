//! The lab-unit summary of a push: what `nanopush simulate --json` prints
//! (schema `nanopush.push-summary/1`), readable back with serde.

use super::effects::ActiveEffect;
use super::outcome::PushResult;
use serde::{Deserialize, Serialize};

/// Schema string of [`PushSummary`].
pub const SUMMARY_SCHEMA: &str = "nanopush.push-summary/1";

/// One push in lab units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[allow(non_snake_case)]
pub struct PushSummary {
    /// Always [`SUMMARY_SCHEMA`].
    pub schema: String,
    /// Scene name.
    pub scene: String,
    /// Contact angle (deg).
    pub angle_deg: f64,
    /// Stage speed [um/s].
    pub speed_um_s: f64,
    /// Push duration (s).
    pub duration_s: f64,
    /// Final motion mode.
    pub mode: String,
    /// How the push ended.
    pub outcome: String,
    /// Onset of motion, null when nothing moved (s).
    pub onset_s: Option<f64>,
    /// Pushing force at onset (uN).
    pub force_at_onset_uN: Option<f64>,
    /// Particle displacement at the end (um).
    pub displacement_um: f64,
    /// Critical rolling force at onset (or end), null when locked (uN).
    pub critical_rolling_uN: Option<f64>,
    /// Critical sliding force at onset (or end), null when locked (uN).
    pub critical_sliding_uN: Option<f64>,
    /// Pushing-force angle psi (deg).
    pub force_angle_deg: f64,
    /// Force ramp before onset [N/m].
    pub force_ramp_n_per_m: f64,
    /// Margin against the tip riding over (null when not simulated).
    pub ride_over_margin: Option<f64>,
    /// End of the push (duration or terminal event) (s).
    pub end_s: f64,
    /// Pushing force at the end (uN); absent from summaries before 2026-11-29.
    #[serde(default)]
    pub force_at_end_uN: Option<f64>,
    /// Simulated effects and why.
    pub active_effects: Vec<ActiveEffect>,
    /// Approximations taken.
    pub notes: Vec<String>,
}

impl PushSummary {
    /// Converts a result (SI) to lab units.
    pub fn from_result(
        scene: &str,
        angle_deg: f64,
        speed_um_s: f64,
        duration_s: f64,
        r: &PushResult,
    ) -> Self {
        let mode = serde_json::to_value(r.mode)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default();
        PushSummary {
            schema: SUMMARY_SCHEMA.into(),
            scene: scene.into(),
            angle_deg,
            speed_um_s,
            duration_s,
            mode,
            outcome: r.outcome.name().into(),
            onset_s: r.onset_s,
            force_at_onset_uN: r.force_at_onset_n.map(|f| f * 1e6),
            displacement_um: r.displacement_m * 1e6,
            critical_rolling_uN: r.critical.rolling.force().map(|f| f * 1e6),
            critical_sliding_uN: r.critical.sliding.force().map(|f| f * 1e6),
            force_angle_deg: r.force_angle_rad.to_degrees(),
            force_ramp_n_per_m: r.force_per_travel_n_per_m,
            ride_over_margin: r.ride_over_margin,
            end_s: r.end_s,
            force_at_end_uN: Some(r.force_at_end_n * 1e6),
            active_effects: r.active_effects.clone(),
            notes: r.notes.clone(),
        }
    }

    /// A few readable lines for the terminal.
    pub fn to_text(&self) -> String {
        let opt =
            |v: Option<f64>, unit: &str| v.map_or("none".to_string(), |v| format!("{v:.3} {unit}"));
        // A mode with no critical force can never start ("none" read as
        // "not computed").
        let critical = |v: Option<f64>| {
            v.map_or("locked (cannot start)".to_string(), |v| {
                format!("{v:.3} uN")
            })
        };
        let ended = match self.force_at_end_uN {
            Some(f) => format!("{:.3} s, force {f:.3} uN", self.end_s),
            None => format!("{:.3} s", self.end_s),
        };
        let mut s = format!(
            "scene {}: contact angle {:.1} deg, {:.3} um/s for {:.1} s\n  outcome: {} (mode {})\n  onset: {}, force at onset: {}\n  ended: {ended}\n  displacement: {:.3} um\n  critical rolling: {}, critical sliding: {}\n  force angle {:.1} deg, ramp {:.4} N/m\n  effects:\n",
            self.scene,
            self.angle_deg,
            self.speed_um_s,
            self.duration_s,
            self.outcome,
            self.mode,
            opt(self.onset_s, "s"),
            opt(self.force_at_onset_uN, "uN"),
            self.displacement_um,
            critical(self.critical_rolling_uN),
            critical(self.critical_sliding_uN),
            self.force_angle_deg,
            self.force_ramp_n_per_m,
        );
        for e in &self.active_effects {
            s.push_str(&format!("    - {}: {}\n", e.name, e.reason));
        }
        for n in &self.notes {
            s.push_str(&format!("  note: {n}\n"));
        }
        s
    }
}
