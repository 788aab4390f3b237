//! The motion-mode state machine with hysteresis (spec case 8).
//!
//! A particle at rest starts the mode whose *static* threshold the pushing
//! force reaches first. A moving particle keeps its mode while the other
//! modes' static thresholds stay above its *kinetic* threshold
//! (kinetic = ratio x static). Near a rolling/sliding tie this band stops
//! chatter between the modes.

use super::critical_force::CriticalForces;
use super::scene::MotionParams;
use serde::{Deserialize, Serialize};

/// How the particle moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// At rest.
    Stuck,
    /// Rolling on the substrate.
    Rolling,
    /// Sliding on the substrate.
    Sliding,
    /// Spinning about the substrate normal.
    Spinning,
}

/// The machine: current mode plus its hysteresis parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeMachine {
    /// Current mode.
    pub mode: Mode,
    /// Kinetic/static ratios.
    pub motion: MotionParams,
}

impl ModeMachine {
    /// A particle at rest.
    pub fn new(motion: MotionParams) -> Self {
        ModeMachine {
            mode: Mode::Stuck,
            motion,
        }
    }

    /// The static threshold of `mode` (+inf when locked or at rest).
    pub fn static_threshold(c: &CriticalForces, mode: Mode) -> f64 {
        match mode {
            Mode::Stuck => f64::INFINITY,
            Mode::Rolling => c.rolling.or_inf(),
            Mode::Sliding => c.sliding.or_inf(),
            Mode::Spinning => c.spinning.or_inf(),
        }
    }

    /// The kinetic threshold of the current mode (force held while moving).
    pub fn kinetic_threshold(&self, c: &CriticalForces) -> f64 {
        let s = Self::static_threshold(c, self.mode);
        match self.mode {
            Mode::Rolling => s * self.motion.rolling_kinetic_ratio,
            Mode::Sliding => s * self.motion.sliding_kinetic_ratio,
            _ => s,
        }
    }

    /// The mode with the lowest static threshold (ties: rolling, then sliding).
    pub fn cheapest(c: &CriticalForces) -> (Mode, f64) {
        let mut best = (Mode::Stuck, f64::INFINITY);
        for m in [Mode::Rolling, Mode::Sliding, Mode::Spinning] {
            let f = Self::static_threshold(c, m);
            if f < best.1 {
                best = (m, f);
            }
        }
        best
    }

    /// Updates the mode for pushing force `force_n`; returns the new mode.
    pub fn step(&mut self, force_n: f64, c: &CriticalForces) -> Mode {
        let (cheap, f_cheap) = Self::cheapest(c);
        self.mode = match self.mode {
            Mode::Stuck if force_n >= f_cheap => cheap,
            Mode::Stuck => Mode::Stuck,
            current => {
                if cheap != current && f_cheap < self.kinetic_threshold(c) {
                    cheap
                } else if force_n < self.kinetic_threshold(c) && force_n < f_cheap {
                    Mode::Stuck
                } else {
                    current
                }
            }
        };
        self.mode
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::critical_force::Critical;

    fn forces(r: f64, s: f64) -> CriticalForces {
        CriticalForces {
            rolling: Critical::Force(r),
            sliding: Critical::Force(s),
            spinning: Critical::Locked,
            detach: Critical::Locked,
            tip_contact_capped: false,
        }
    }

    #[test]
    fn a_near_tie_does_not_chatter() {
        let mut m = ModeMachine::new(MotionParams {
            rolling_kinetic_ratio: 0.95,
            sliding_kinetic_ratio: 0.9,
        });
        assert_eq!(m.step(1.0, &forces(1.0, 1.01)), Mode::Rolling);
        // Sliding becomes marginally cheaper: inside the band, keep rolling.
        assert_eq!(m.step(0.99, &forces(1.0, 0.99)), Mode::Rolling);
        assert_eq!(m.step(0.99, &forces(1.0, 1.01)), Mode::Rolling);
        // Clearly cheaper: switch.
        assert_eq!(m.step(0.9, &forces(1.0, 0.8)), Mode::Sliding);
    }

    #[test]
    fn a_moving_particle_stops_below_the_kinetic_threshold() {
        let mut m = ModeMachine::new(MotionParams {
            rolling_kinetic_ratio: 0.9,
            sliding_kinetic_ratio: 0.9,
        });
        m.step(1.0, &forces(1.0, 2.0));
        assert_eq!(m.step(0.95, &forces(1.0, 2.0)), Mode::Rolling);
        assert_eq!(m.step(0.85, &forces(1.0, 2.0)), Mode::Stuck);
    }
}
