//! Wall-clock rig time for hardware: seconds since the rig was opened, shared
//! by the stage and the cameras so that a frame's time and a move's time can
//! be compared. File modification times map onto the same axis.

use std::time::{Instant, SystemTime};

/// The zero of rig time on hardware (a copyable pair of monotonic and system clocks).
#[derive(Debug, Clone, Copy)]
pub struct WallClock {
    start: Instant,
    start_system: SystemTime,
    /// Rig time at the start, seconds.
    origin_s: f64,
}

impl WallClock {
    /// Rig time zero is now.
    pub fn start() -> Self {
        Self::continuing_from(0.0)
    }

    /// Rig time `origin_s` is now: a resumed run goes on from where its
    /// journal stopped, so its times keep rising.
    pub fn continuing_from(origin_s: f64) -> Self {
        Self {
            start: Instant::now(),
            start_system: SystemTime::now(),
            origin_s,
        }
    }

    /// Rig seconds now (monotonic).
    pub fn now_s(&self) -> f64 {
        self.origin_s + self.start.elapsed().as_secs_f64()
    }

    /// Rig time of a system timestamp (a file's modification time); before
    /// the origin for times before the start.
    pub fn system_time_s(&self, at: SystemTime) -> f64 {
        self.origin_s
            + match at.duration_since(self.start_system) {
                Ok(after) => after.as_secs_f64(),
                Err(before) => -before.duration().as_secs_f64(),
            }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn system_times_map_onto_rig_time_both_sides_of_zero() {
        let clock = WallClock::start();
        let later = clock.start_system + Duration::from_millis(1500);
        let earlier = clock.start_system - Duration::from_millis(250);
        assert!((clock.system_time_s(later) - 1.5).abs() < 1e-9);
        assert!((clock.system_time_s(earlier) + 0.25).abs() < 1e-9);
        let a = clock.now_s();
        std::thread::sleep(Duration::from_millis(5));
        assert!(clock.now_s() > a);
        let resumed = WallClock::continuing_from(100.0);
        assert!(resumed.now_s() >= 100.0 && resumed.now_s() < 101.0);
        let later = resumed.start_system + Duration::from_millis(1500);
        assert!((resumed.system_time_s(later) - 101.5).abs() < 1e-9);
    }
}
