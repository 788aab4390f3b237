//! Particle identity across frames.
//!
//! Between two frames only the pushed particle moves far, and the executor
//! knows the push, so a pushed track is matched by its distance to the push
//! segment (from -> to): wherever it stopped on the line, short of the target
//! after a lost contact or at the target, it keeps its identity. Matching is greedy by ascending distance inside a
//! gate: with particles a diameter apart and predictions good to a fraction
//! of a radius, greedy and optimal matching agree, and greedy is simple and
//! O(n m log nm). A track not seen in a frame (a missed detection, the tip
//! hiding it) keeps its last position and counts the miss instead of vanishing;
//! a track outside the camera's view is not seen and not counted as missed.

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
    /// Frames in which the track was matched, its first included (a track
    /// seen once may be a false detection).
    pub hits: u32,
    /// Radii of its latest sightings clear of every other particle (at most
    /// [`SIZE_SIGHTINGS`]; see [`Track::own_radius_m`]).
    isolated_radii: Vec<f64>,
}

/// Least gap between a particle's edge and every other particle's for its
/// radius to count as its size. On a synthetic frame at the simulated
/// rig's 0.25 um a pixel (`synth frame`, pairs and rows of 4.8 and 5 um
/// particles), the measured radius was within 15 nm of the truth at gaps
/// of 1 um and more, up to 120 nm off at 0.1-0.75 um.
pub const ISOLATED_GAP_M: f64 = 1e-6;

/// Sightings a particle's own size is the median of.
pub const SIZE_SIGHTINGS: usize = 15;

impl Track {
    /// The particle's own radius: the median of its latest sightings at
    /// least [`ISOLATED_GAP_M`] from every other particle; None before
    /// one (see [`super::particle_sizes`]).
    pub fn own_radius_m(&self) -> Option<f64> {
        let mut r = self.isolated_radii.clone();
        crate::median::upper_median(&mut r)
    }
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

/// A matching cost: the distance of an observation from a track, or None when it may not match.
type MatchCost<'a> = dyn Fn(&Track, &Observation) -> Option<f64> + 'a;

/// How far a particle nobody pushed may move between frames and be matched first (noise, drift).
const STILL_GATE_M: f64 = 1e-6;

/// A track the executor pushed since the last frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moved {
    /// Track id.
    pub id: usize,
    /// Where the push started, metres.
    pub from: [f64; 2],
    /// Where it was meant to end, metres.
    pub to: [f64; 2],
}

fn distance_to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * ab[0]).hypot(p[1] - a[1] - t * ab[1])
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

    /// How many track ids were handed out so far (ids are 0, 1, 2, ...).
    pub fn ids_issued(&self) -> usize {
        self.next_id
    }

    /// The track with this id, if any.
    pub fn track(&self, id: usize) -> Option<&Track> {
        self.tracks.iter().find(|t| t.id == id)
    }

    /// Matches a frame's observations to tracks. `moved` names the tracks the
    /// executor just pushed, with the push's start and target; `in_view` says
    /// whether a position is inside the frame (tracks outside are not missed).
    pub fn update(
        &mut self,
        observations: &[Observation],
        moved: &[Moved],
        in_view: &dyn Fn(f64, f64) -> bool,
    ) -> TrackUpdate {
        let mut track_taken = vec![false; self.tracks.len()];
        let mut obs_track: Vec<Option<usize>> = vec![None; observations.len()];
        let pushed = |t: &Track| moved.iter().find(|m| m.id == t.id).copied();
        let still = |t: &Track, o: &Observation| {
            (pushed(t).is_none()).then(|| (o.x_m - t.last.x_m).hypot(o.y_m - t.last.y_m))
        };
        let along_push = |t: &Track, o: &Observation| {
            pushed(t).map(|m| distance_to_segment([o.x_m, o.y_m], m.from, m.to))
        };
        // Particles nobody pushed barely move: match them first, tightly, so a
        // pushed particle's line cannot take a neighbour's observation; then the
        // pushed ones along their lines; then whatever is left, loosely.
        let tight = self.gate_m.min(STILL_GATE_M);
        let passes: [(&MatchCost, f64); 3] = [
            (&still, tight),
            (&along_push, self.gate_m),
            (&still, self.gate_m),
        ];
        for (cost, gate) in passes {
            let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
            for (ti, t) in self
                .tracks
                .iter()
                .enumerate()
                .filter(|(ti, _)| !track_taken[*ti])
            {
                for (oi, o) in observations
                    .iter()
                    .enumerate()
                    .filter(|(oi, _)| obs_track[*oi].is_none())
                {
                    if let Some(d) = cost(t, o).filter(|d| *d <= gate) {
                        pairs.push((d, ti, oi));
                    }
                }
            }
            pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (_, ti, oi) in pairs {
                if !track_taken[ti] && obs_track[oi].is_none() {
                    track_taken[ti] = true;
                    obs_track[oi] = Some(ti);
                }
            }
        }
        let mut update = TrackUpdate::default();
        for (ti, taken) in track_taken.iter().enumerate() {
            let t = &mut self.tracks[ti];
            if *taken {
                t.missed_frames = 0;
                t.hits += 1;
            } else if in_view(t.last.x_m, t.last.y_m) {
                t.missed_frames += 1;
                update.missed.push(t.id);
            }
        }
        for (oi, o) in observations.iter().enumerate() {
            let ti = match obs_track[oi] {
                Some(ti) => {
                    self.tracks[ti].last = *o;
                    ti
                }
                None => {
                    let id = self.next_id;
                    self.next_id += 1;
                    self.tracks.push(Track {
                        id,
                        last: *o,
                        missed_frames: 0,
                        hits: 1,
                        isolated_radii: Vec::new(),
                    });
                    update.created.push(id);
                    self.tracks.len() - 1
                }
            };
            if isolated(oi, observations) {
                let sizes = &mut self.tracks[ti].isolated_radii;
                if sizes.len() == SIZE_SIGHTINGS {
                    sizes.remove(0);
                }
                sizes.push(o.radius_m);
            }
            update.ids.push(self.tracks[ti].id);
        }
        update
    }
}

/// Whether observation `i` is at least [`ISOLATED_GAP_M`] from every other.
fn isolated(i: usize, observations: &[Observation]) -> bool {
    let o = &observations[i];
    observations.iter().enumerate().all(|(j, u)| {
        j == i || (o.x_m - u.x_m).hypot(o.y_m - u.y_m) - o.radius_m - u.radius_m >= ISOLATED_GAP_M
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: fn(f64, f64) -> bool = |_, _| true;

    fn obs(x_um: f64, y_um: f64) -> Observation {
        Observation {
            x_m: x_um * 1e-6,
            y_m: y_um * 1e-6,
            radius_m: 5e-6,
        }
    }

    /// A particle's own size comes only from sightings 1 um or more clear
    /// of every other: 0.5 um from a neighbour it has none; moved 2 um
    /// away, its radius there (5.2 um, not the touching sighting's 5.1).
    #[test]
    fn a_particles_own_size_is_taken_only_clear_of_the_others() {
        let mut tracker = Tracker::new(3e-6);
        let at = |x_um: f64, r_um: f64| Observation {
            radius_m: r_um * 1e-6,
            ..obs(x_um, 10.0)
        };
        tracker.update(&[at(10.0, 5.0), at(20.5, 5.1)], &[], &ALL);
        assert_eq!(tracker.track(1).unwrap().own_radius_m(), None);
        let moved = Moved {
            id: 1,
            from: [20.5e-6, 10e-6],
            to: [22e-6, 10e-6],
        };
        tracker.update(&[at(10.0, 5.0), at(22.0, 5.2)], &[moved], &ALL);
        let own = |id| tracker.track(id).unwrap().own_radius_m().unwrap();
        assert!((own(1) - 5.2e-6).abs() < 1e-15, "{}", own(1));
        assert!((own(0) - 5e-6).abs() < 1e-15, "{}", own(0));
    }

    #[test]
    fn hits_count_the_frames_a_track_was_seen_in() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(10.0, 10.0)], &[], &ALL);
        t.update(&[obs(10.0, 10.0), obs(40.0, 40.0)], &[], &ALL);
        t.update(&[obs(10.0, 10.0)], &[], &ALL);
        let hits: Vec<(usize, u32, u32)> = t
            .tracks()
            .iter()
            .map(|k| (k.id, k.hits, k.missed_frames))
            .collect();
        // The second particle was seen once (a possible false detection) and then missed.
        assert_eq!(hits, vec![(0, 3, 0), (1, 1, 1)]);
        assert_eq!(t.ids_issued(), 2);
    }

    #[test]
    fn first_frame_creates_one_track_per_observation() {
        let mut t = Tracker::new(4e-6);
        let u = t.update(&[obs(0.0, 0.0), obs(20.0, 0.0)], &[], &ALL);
        assert_eq!(u.ids, vec![0, 1]);
        assert_eq!(u.created, vec![0, 1]);
    }

    #[test]
    fn a_pushed_particle_keeps_its_id_through_its_prediction() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(0.0, 0.0), obs(20.0, 0.0)], &[], &ALL);
        // Particle 0 was pushed 25 um to the right, past particle 1's old place;
        // observations come in another order.
        let push = Moved {
            id: 0,
            from: [0.0, 0.0],
            to: [25e-6, 0.0],
        };
        let u = t.update(&[obs(20.5, 0.0), obs(25.2, 0.3)], &[push], &ALL);
        assert_eq!(u.ids, vec![1, 0]);
        assert!(u.created.is_empty() && u.missed.is_empty());
        assert!((t.track(0).unwrap().last.x_m - 25.2e-6).abs() < 1e-12);
    }

    #[test]
    fn a_missed_detection_keeps_the_track_and_counts_the_miss() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(0.0, 0.0), obs(20.0, 0.0)], &[], &ALL);
        let u = t.update(&[obs(20.1, 0.0)], &[], &ALL);
        assert_eq!(u.missed, vec![0]);
        assert_eq!(t.track(0).unwrap().missed_frames, 1);
        let u = t.update(&[obs(0.1, 0.0), obs(20.1, 0.0)], &[], &ALL);
        assert_eq!(u.ids, vec![0, 1]);
        assert_eq!(t.track(0).unwrap().missed_frames, 0);
    }

    #[test]
    fn a_push_that_lost_contact_keeps_the_identity_of_the_particle_left_behind() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(0.0, 0.0), obs(0.0, 30.0)], &[], &ALL);
        let push = Moved {
            id: 0,
            from: [0.0, 0.0],
            to: [25e-6, 0.0],
        };
        // The particle moved only 6 um: far from its target, on its push line.
        let u = t.update(&[obs(6.0, 0.1), obs(0.0, 30.0)], &[push], &ALL);
        assert_eq!(u.ids, vec![0, 1]);
        assert!(u.created.is_empty());
    }

    #[test]
    fn a_track_outside_the_view_is_not_missed() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(0.0, 0.0), obs(200.0, 0.0)], &[], &ALL);
        let left_half = |x: f64, _: f64| x < 100e-6;
        let u = t.update(&[obs(0.0, 0.0)], &[], &left_half);
        assert!(u.missed.is_empty());
        assert_eq!(t.track(1).unwrap().missed_frames, 0);
    }

    #[test]
    fn an_observation_outside_every_gate_is_a_new_track() {
        let mut t = Tracker::new(4e-6);
        t.update(&[obs(0.0, 0.0)], &[], &ALL);
        let u = t.update(&[obs(0.0, 0.0), obs(50.0, 50.0)], &[], &ALL);
        assert_eq!(u.ids, vec![0, 1]);
        assert_eq!(u.created, vec![1]);
    }
}
