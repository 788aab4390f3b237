//! The typed result of one simulated push.

use super::critical_force::CriticalForces;
use super::effects::ActiveEffect;
use super::mode_machine::Mode;
use serde::{Deserialize, Serialize};

/// How a push ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Outcome {
    /// The particle rolled with the tip to the end of the push.
    Rolling,
    /// The particle slid with the tip to the end of the push.
    Sliding,
    /// The off-axis push spun the particle: it turns around the tip (contact lost).
    Spinning,
    /// Nothing moved within the push.
    Stuck,
    /// The substrate load fell below pull-off: the particle left the substrate.
    Detached,
    /// The tip climbed over the particle.
    TipSlippedOver,
    /// The tip twisted beyond its valid range (theta -> 90 deg) and lost the particle.
    ContactLost,
    /// The pushed particle reached a neighbour.
    ParticleContact,
}

impl Outcome {
    /// The kebab-case name used in JSON and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Rolling => "rolling",
            Outcome::Sliding => "sliding",
            Outcome::Spinning => "spinning",
            Outcome::Stuck => "stuck",
            Outcome::Detached => "detached",
            Outcome::TipSlippedOver => "tip-slipped-over",
            Outcome::ContactLost => "contact-lost",
            Outcome::ParticleContact => "particle-contact",
        }
    }
}

/// Everything one push produced.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PushResult {
    /// Motion mode at the end (or at the terminal event).
    pub mode: Mode,
    /// How the push ended.
    pub outcome: Outcome,
    /// Onset time of motion, `None` when nothing moved.
    pub onset_s: Option<f64>,
    /// Pushing force at onset (N).
    pub force_at_onset_n: Option<f64>,
    /// Time the push ended (duration or terminal event) (s).
    pub end_s: f64,
    /// Particle displacement at the end (m).
    pub displacement_m: f64,
    /// Stage travel at the end (m).
    pub stage_travel_m: f64,
    /// Pushing force at the end (N).
    pub force_at_end_n: f64,
    /// Critical forces at onset (or at the end when nothing moved).
    pub critical: CriticalForces,
    /// Pushing-force angle psi (rad).
    pub force_angle_rad: f64,
    /// Pushing-force ramp before onset [N/m of stage travel].
    pub force_per_travel_n_per_m: f64,
    /// Margin against the tip riding over: 1 - slip/arc at onset (or end);
    /// `None` when the scene holds the contact angle.
    pub ride_over_margin: Option<f64>,
    /// Effects that were simulated, and why.
    pub active_effects: Vec<ActiveEffect>,
    /// Remarks on approximations taken (capped contacts, etc.).
    pub notes: Vec<String>,
}
