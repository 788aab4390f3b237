//! Particle identity across frames.
//!
//! Between two frames only the pushed particle moves far, and the executor
//! knows where it commanded it to go, so each track is matched at its
//! *predicted* position. Matching is greedy by ascending distance inside a
//! gate: with particles a diameter apart and predictions good to a fraction
//! of a radius, greedy and optimal matching agree, and greedy is simple and
//! O(n m log nm). A track not seen in a frame (a missed detection, the tip
//! hiding it) keeps its last position and counts the miss instead of vanishing.

/// A particle seen in one frame, in stage metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Centre x in stage metres.
    pub x_m: f64,
    /// Centre y in stage metres.
    pub y_m: f64,
    /// Radius in metres.
    pub radius_m: f64,
}

/// A particle followed across frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Stable identity, never reused.
    pub id: usize,
    /// Last known position and size.
    pub last: Observation,
    /// Frames in a row in which the track was not matched.
    pub missed_frames: u32,
}

/// What one update did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrackUpdate {
    /// For each observation, the id of the track it now belongs to.
    pub ids: Vec<usize>,
    /// Tracks that got no observation this frame.
    pub missed: Vec<usize>,
    /// Tracks created for observations that matched nothing.
    pub created: Vec<usize>,
}

/// Keeps particle identities across frames.
#[derive(Debug, Clone)]
pub struct Tracker {
    tracks: Vec<Track>,
    gate_m: f64,
    next_id: usize,
}

impl Tracker {
    /// Starts with no tracks; `gate_m` is the farthest an observation may lie
    /// from a track's predicted position and still be that track.
    pub fn new(gate_m: f64) -> Self {
        Self {
            tracks: Vec::new(),
            gate_m,
            next_id: 0,
        }
    }

    /// The current tracks, in id order.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// The track with this id, if any.
    pub fn track(&self, id: usize) -> Option<&Track> {
        self.tracks.iter().find(|t| t.id == id)
    }

    /// Matches a frame's observations to tracks. `predicted` overrides the
    /// expected position of the tracks the executor just moved (id, x_m, y_m).
    pub fn update(
        &mut self,
        observations: &[Observation],
        predicted: &[(usize, f64, f64)],
    ) -> TrackUpdate {
        let expected = |t: &Track| {
            predicted
                .iter()
                .find(|(id, ..)| *id == t.id)
                .map_or((t.last.x_m, t.last.y_m), |&(_, x, y)| (x, y))
        };
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (ti, t) in self.tracks.iter().enumerate() {
            let (ex, ey) = expected(t);
            for (oi, o) in observations.iter().enumerate() {
                let d = (o.x_m - ex).hypot(o.y_m - ey);
                if d <= self.gate_m {
                    pairs.push((d, ti, oi));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut track_taken = vec![false; self.tracks.len()];
        let mut obs_track: Vec<Option<usize>> = vec![None; observations.len()];
        for (_, ti, oi) in pairs {
            if !track_taken[ti] && obs_track[oi].is_none() {
                track_taken[ti] = true;
                obs_track[oi] = Some(ti);
            }
        }
        let mut update = TrackUpdate::default();
        for (ti, taken) in track_taken.iter().enumerate() {
            let t = &mut self.tracks[ti];
            if *taken {
                t.missed_frames = 0;
            } else {
                t.missed_frames += 1;
                update.missed.push(t.id);
            }
        }
        for (oi, o) in observations.iter().enumerate() {
            let id = match obs_track[oi] {
                Some(ti) => {
                    self.tracks[ti].last = *o;
                    self.tracks[ti].id
                }
                None => {
                    let id = self.next_id;
                    self.next_id += 1;
                    self.tracks.push(Track {
                        id,
                        last: *o,
                        missed_frames: 0,
                    });
                    update.created.push(id);
                    id
                }
            };
            update.ids.push(id);
        }
        update
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs(x_um: f64, y_um: f64) -> Observation {
        Observation {
            x_m: x_um * 1e-6,
            y_m: y_um * 1e-6,
            radius_m: 5e-6,
        }
    }

    #[test]
    fn first_frame_creates_one_track_per_observation() {
        let mut t = Tracker::new(4e-6);
        let u = t.update(&[obs(0.0, 0.0), obs(20.0, 0.0)], &[]);
        assert_eq!(u.ids, vec![0, 1]);
        assert_eq!(u.created, vec![0, 1]);
    }

    #[test]
    fn a_pushed_particle_keeps_its_id_through_its_prediction() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(0.0, 0.0), obs(20.0, 0.0)], &[]);
        // Particle 0 was pushed 25 um to the right, past particle 1's old place;
        // observations come in another order.
        let u = t.update(&[obs(20.5, 0.0), obs(25.2, 0.3)], &[(0, 25e-6, 0.0)]);
        assert_eq!(u.ids, vec![1, 0]);
        assert!(u.created.is_empty() && u.missed.is_empty());
        assert!((t.track(0).unwrap().last.x_m - 25.2e-6).abs() < 1e-12);
    }

    #[test]
    fn a_missed_detection_keeps_the_track_and_counts_the_miss() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(0.0, 0.0), obs(20.0, 0.0)], &[]);
        let u = t.update(&[obs(20.1, 0.0)], &[]);
        assert_eq!(u.missed, vec![0]);
        assert_eq!(t.track(0).unwrap().missed_frames, 1);
        let u = t.update(&[obs(0.1, 0.0), obs(20.1, 0.0)], &[]);
        assert_eq!(u.ids, vec![0, 1]);
        assert_eq!(t.track(0).unwrap().missed_frames, 0);
    }

    #[test]
    fn an_observation_outside_every_gate_is_a_new_track() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(0.0, 0.0)], &[]);
        let u = t.update(&[obs(0.0, 0.0), obs(50.0, 50.0)], &[]);
        assert_eq!(u.ids, vec![0, 1]);
        assert_eq!(u.created, vec![1]);
    }
}
