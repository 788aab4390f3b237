//! Push advice for the executor: which contact angle, how long to push.
//!
//! For each contact angle on a grid over the scene's allowed range the push
//! is simulated; angles whose push does not carry the particle (stuck,
//! detached, spinning, tip over, contact lost) or whose margin against the
//! tip riding over is below [`MIN_RIDE_OVER_MARGIN`] are rejected, and the
//! angle with the earliest onset wins. The duration is the time at which
//! the particle has travelled the requested distance.

use super::error::ModelError;
use super::mode_machine::Mode;
use super::outcome::Outcome;
use super::push_sim::{PushParams, simulate_push};
use super::scene::Scene;
use serde::Serialize;

/// Smallest accepted margin against the tip riding over (fraction of the arc).
pub const MIN_RIDE_OVER_MARGIN: f64 = 0.2;
/// Number of contact angles tried across the allowed range.
pub const ANGLE_GRID: usize = 25;

/// What the model advises for one push.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PushAdvice {
    /// Contact angle to use (rad).
    pub contact_angle_rad: f64,
    /// Push duration: predicted onset plus travel (s).
    pub duration_s: f64,
    /// Predicted onset of motion (s).
    pub onset_s: f64,
    /// Critical force of the predicted mode (N).
    pub critical_force_n: f64,
    /// Predicted motion mode.
    pub mode: Mode,
    /// Margin against the tip riding over at onset (`None`: not simulated).
    pub ride_over_margin: Option<f64>,
}

/// Chooses the contact angle and duration to move the particle by `push_distance_m`.
pub fn advise_push(scene: &Scene, push_distance_m: f64) -> Result<PushAdvice, ModelError> {
    if !(push_distance_m.is_finite() && push_distance_m > 0.0) {
        return Err(ModelError::Push {
            field: "push_distance_um",
            problem: format!("must be positive, got {}", push_distance_m * 1e6),
        });
    }
    let (lo, hi) = scene.angle_range_rad;
    let v = scene.push.speed_m_per_s;
    let search_duration = scene.push.duration_s + push_distance_m / v;
    let mut best: Option<PushAdvice> = None;
    let mut rejections = Vec::new();
    for i in 0..ANGLE_GRID {
        let phi = if ANGLE_GRID == 1 {
            lo
        } else {
            lo + (hi - lo) * i as f64 / (ANGLE_GRID - 1) as f64
        };
        let params = PushParams {
            contact_angle_rad: phi,
            speed_m_per_s: v,
            duration_s: search_duration,
        };
        let r = simulate_push(scene, &params)?;
        let moved = matches!(r.outcome, Outcome::Rolling | Outcome::Sliding);
        let margin_ok = r.ride_over_margin.is_none_or(|m| m >= MIN_RIDE_OVER_MARGIN);
        let (Some(onset), true, true) = (r.onset_s, moved, margin_ok) else {
            rejections.push(format!(
                "{:.1} deg: {}",
                phi.to_degrees(),
                if moved {
                    "ride-over margin too small"
                } else {
                    r.outcome.name()
                }
            ));
            continue;
        };
        let critical = match r.mode {
            Mode::Sliding => r.critical.sliding.or_inf(),
            _ => r.critical.rolling.or_inf(),
        };
        // After onset the particle lags the stage by F/k: x = V_eff t - F/k.
        let v_eff = r.stage_travel_m / r.end_s;
        let duration = (push_distance_m + r.force_at_end_n / r.force_per_travel_n_per_m) / v_eff;
        let advice = PushAdvice {
            contact_angle_rad: phi,
            duration_s: duration.max(onset),
            onset_s: onset,
            critical_force_n: critical,
            mode: r.mode,
            ride_over_margin: r.ride_over_margin,
        };
        if best.as_ref().is_none_or(|b| advice.onset_s < b.onset_s) {
            best = Some(advice);
        }
    }
    best.ok_or_else(|| ModelError::NoSafeAngle {
        min_deg: lo.to_degrees(),
        max_deg: hi.to_degrees(),
        why: rejections.join("; "),
    })
}
