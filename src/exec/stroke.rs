//! One push as stage moves: approach above the particle's path, lower to the
//! height that gives the chosen contact angle, stroke along the push line,
//! lift. Pure geometry, so the executor's moves can be checked without a rig.
//!
//! The tip apex is treated as a point: at apex height `z = R (1 + cos phi)`
//! it meets the sphere on a horizontal circle of radius `R sin phi`, so the
//! contact normal makes the angle `phi` with the substrate normal.

use crate::rig::stage::StageXyz;

/// The moves of one push, in stage metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    /// Above the approach point, at the safe height.
    pub above: StageXyz,
    /// The approach point, lowered to contact height, clear of the particle.
    pub approach: StageXyz,
    /// Where the tip slows to the pushing speed on its way from the
    /// approach point: [`StrokeRequest::slow_approach_m`] before it touches
    /// the particle (the approach point itself when that is no nearer).
    pub slow_from: StageXyz,
    /// Where the stroke ends (at contact height).
    pub end: StageXyz,
    /// Above the end, at the safe height.
    pub lift: StageXyz,
    /// Stage travel from first touch to the end of the stroke.
    pub travel_after_contact_m: f64,
}

/// What a push asks of the stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrokeRequest {
    /// Particle centre now, metres.
    pub from: [f64; 2],
    /// Where the particle should end, metres.
    pub to: [f64; 2],
    /// Particle radius.
    pub radius_m: f64,
    /// Contact angle from the substrate normal (0..90 deg).
    pub contact_angle_rad: f64,
    /// Stage travel after first touch that moves the particle by |to - from|
    /// (the model's push duration times the speed).
    pub travel_after_contact_m: f64,
    /// Gap between the tip and the particle at the approach point.
    pub clearance_m: f64,
    /// How far before the particle the tip slows to the pushing speed: the
    /// rest of the gap it crosses faster (the placement errors the gap
    /// allows for are tens of nm, and at 1 um/s every 0.1 um of it took
    /// 0.1 s a push).
    pub slow_approach_m: f64,
    /// Tip height that clears every particle.
    pub safe_z_m: f64,
}

/// Why a stroke cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StrokeError {
    /// From and to coincide: there is no push direction.
    #[error("the particle is already at its target: no push direction")]
    NoDirection,
    /// A value is NaN, infinite or out of its range.
    #[error("{0} is not valid for a stroke")]
    Invalid(&'static str),
}

/// Lays out the stage moves of one push.
pub fn plan_stroke(r: &StrokeRequest) -> Result<Stroke, StrokeError> {
    let finite = [r.from[0], r.from[1], r.to[0], r.to[1]]
        .iter()
        .all(|v| v.is_finite());
    if !finite {
        return Err(StrokeError::Invalid("a particle position"));
    }
    if !(r.radius_m.is_finite() && r.radius_m > 0.0) {
        return Err(StrokeError::Invalid("the particle radius"));
    }
    let phi = r.contact_angle_rad;
    if !(phi.is_finite() && phi > 0.0 && phi <= std::f64::consts::FRAC_PI_2) {
        return Err(StrokeError::Invalid("the contact angle"));
    }
    if !(r.travel_after_contact_m.is_finite() && r.travel_after_contact_m >= 0.0) {
        return Err(StrokeError::Invalid("the stroke travel"));
    }
    if !(r.slow_approach_m.is_finite() && r.slow_approach_m >= 0.0) {
        return Err(StrokeError::Invalid("the slow approach"));
    }
    let d = [r.to[0] - r.from[0], r.to[1] - r.from[1]];
    let length = d[0].hypot(d[1]);
    if length <= 0.0 {
        return Err(StrokeError::NoDirection);
    }
    let u = [d[0] / length, d[1] / length];
    let z = r.radius_m * (1.0 + phi.cos());
    let section = r.radius_m * phi.sin();
    let back = section + r.clearance_m;
    let approach_xy = [r.from[0] - u[0] * back, r.from[1] - u[1] * back];
    let reach = r.clearance_m + r.travel_after_contact_m;
    let end_xy = [approach_xy[0] + u[0] * reach, approach_xy[1] + u[1] * reach];
    let fast = (r.clearance_m - r.slow_approach_m).max(0.0);
    Ok(Stroke {
        above: [approach_xy[0], approach_xy[1], r.safe_z_m],
        approach: [approach_xy[0], approach_xy[1], z],
        slow_from: [
            approach_xy[0] + u[0] * fast,
            approach_xy[1] + u[1] * fast,
            z,
        ],
        end: [end_xy[0], end_xy[1], z],
        lift: [end_xy[0], end_xy[1], r.safe_z_m],
        travel_after_contact_m: r.travel_after_contact_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::sim::world::contact_angle_at_height;

    fn request() -> StrokeRequest {
        StrokeRequest {
            from: [10e-6, 20e-6],
            to: [10e-6, 40e-6],
            radius_m: 5e-6,
            contact_angle_rad: 45f64.to_radians(),
            travel_after_contact_m: 23e-6,
            clearance_m: 1e-6,
            slow_approach_m: 0.25e-6,
            safe_z_m: 12e-6,
        }
    }

    #[test]
    fn the_stroke_starts_clear_behind_the_particle_and_lies_on_the_push_line() {
        let s = plan_stroke(&request()).unwrap();
        let section = 5e-6 * 45f64.to_radians().sin();
        assert!((s.approach[0] - 10e-6).abs() < 1e-15);
        assert!((s.approach[1] - (20e-6 - section - 1e-6)).abs() < 1e-15);
        // From first touch the stage travels exactly the requested distance.
        let touch = 20e-6 - section;
        assert!((s.end[1] - touch - 23e-6).abs() < 1e-15);
        // The tip slows 0.25 um before it touches, on the push line.
        assert!((s.slow_from[1] - (touch - 0.25e-6)).abs() < 1e-15);
        assert!((s.slow_from[0] - 10e-6).abs() < 1e-15);
        assert_eq!(s.slow_from[2], s.approach[2]);
        // A slow approach longer than the gap slows from the approach point.
        let mut wide = request();
        wide.slow_approach_m = 2e-6;
        let s = plan_stroke(&wide).unwrap();
        assert_eq!(s.slow_from, s.approach);
        assert_eq!(s.above[2], 12e-6);
        assert_eq!(s.lift[2], 12e-6);
    }

    #[test]
    fn the_contact_height_gives_the_chosen_angle_in_the_simulated_world() {
        for deg in [20.0_f64, 45.0, 70.0] {
            let mut r = request();
            r.contact_angle_rad = deg.to_radians();
            let s = plan_stroke(&r).unwrap();
            let back = contact_angle_at_height(s.approach[2], r.radius_m).to_degrees();
            assert!((back - deg).abs() < 1e-9);
        }
    }

    #[test]
    fn degenerate_requests_are_refused() {
        let mut r = request();
        r.to = r.from;
        assert_eq!(plan_stroke(&r), Err(StrokeError::NoDirection));
        let mut r = request();
        r.contact_angle_rad = f64::NAN;
        assert!(matches!(plan_stroke(&r), Err(StrokeError::Invalid(_))));
        let mut r = request();
        r.travel_after_contact_m = -1.0;
        assert!(matches!(plan_stroke(&r), Err(StrokeError::Invalid(_))));
        let mut r = request();
        r.slow_approach_m = f64::NAN;
        assert!(matches!(plan_stroke(&r), Err(StrokeError::Invalid(_))));
    }
}
