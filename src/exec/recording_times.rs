//! Where a recording's frame times come from, and saying so: the stage
//! log's times, else the recording's `frame_interval_s`, else the interval
//! the frames state (a video's frame rate, a TIFF stack's ImageJ
//! description), else 1 s. The model's advice depends on the session's
//! time, so a user is told which was taken, and when two disagree.

use crate::vision::frame_stream::StatedInterval;

/// The frames' times as a recording gives them.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTimes {
    /// Seconds between frames, used without a stage log.
    pub interval_s: f64,
    /// Where the times come from, for the output: "frame interval 0.5 s,
    /// from the stack's ImageJ description".
    pub origin: String,
    /// What a user would not guess: a default taken, a given interval
    /// unused or at odds with the frames' own.
    pub warning: Option<String>,
}

/// Relative difference above which a given interval and the frames' own disagree.
const DISAGREE: f64 = 1e-6;

/// The frame times of a recording with or without a stage log, the
/// `frame_interval_s` its description gives and what its frames state.
pub fn frame_times(
    has_stage_log: bool,
    given_s: Option<f64>,
    stated: Option<StatedInterval>,
) -> FrameTimes {
    let interval = |s: f64, from: &str| format!("frame interval {} s, from {from}", seconds(s));
    let (interval_s, origin, warning) = match (has_stage_log, given_s, stated) {
        (true, given, _) => (
            given.or(stated.map(|s| s.seconds)).unwrap_or(1.0),
            "frame times from the stage log".to_owned(),
            given.map(|dt| {
                format!(
                    "frame_interval_s = {} is not used: the stage log's times are",
                    seconds(dt)
                )
            }),
        ),
        (false, Some(dt), stated) => (
            dt,
            interval(dt, "the recording's frame_interval_s"),
            stated
                .filter(|s| (s.seconds - dt).abs() > DISAGREE * dt)
                .map(|s| {
                    format!(
                        "frame_interval_s = {} is used, but {} says {} s",
                        seconds(dt),
                        s.from,
                        seconds(s.seconds)
                    )
                }),
        ),
        (false, None, Some(s)) => (s.seconds, interval(s.seconds, s.from), None),
        (false, None, None) => (
            1.0,
            "frame interval 1 s, assumed".to_owned(),
            Some(
                "frames are taken 1 s apart (no stage log, no frame_interval_s, no frame rate in the frames): \
                 set frame_interval_s if they were not"
                    .to_owned(),
            ),
        ),
    };
    FrameTimes {
        interval_s,
        origin,
        warning,
    }
}

/// Seconds to six decimals, trailing zeros left out ("0.5", "0.033333").
fn seconds(s: f64) -> String {
    let text = format!("{s:.6}");
    text.trim_end_matches('0').trim_end_matches('.').to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    const STACK: StatedInterval = StatedInterval {
        seconds: 0.5,
        from: "the stack's ImageJ description",
    };

    #[test]
    fn the_times_taken_are_said_and_a_given_interval_wins_over_the_frames() {
        let stated = frame_times(false, None, Some(STACK));
        assert_eq!(stated.interval_s, 0.5);
        assert_eq!(
            stated.origin,
            "frame interval 0.5 s, from the stack's ImageJ description"
        );
        assert_eq!(stated.warning, None);
        let given = frame_times(false, Some(2.0), Some(STACK));
        assert_eq!(given.interval_s, 2.0);
        assert_eq!(
            given.origin,
            "frame interval 2 s, from the recording's frame_interval_s"
        );
        assert_eq!(
            given.warning.as_deref(),
            Some("frame_interval_s = 2 is used, but the stack's ImageJ description says 0.5 s")
        );
        assert_eq!(frame_times(false, Some(0.5), Some(STACK)).warning, None);
        assert_eq!(frame_times(false, Some(0.5), None).warning, None);
    }

    #[test]
    fn frame_times_from_a_default_or_beside_a_stage_log_are_said() {
        let default = frame_times(false, None, None);
        assert_eq!(default.interval_s, 1.0);
        let warning = default.warning.expect("1 s assumed");
        assert!(
            warning.starts_with("frames are taken 1 s apart"),
            "{warning}"
        );
        let logged = frame_times(true, Some(0.5), Some(STACK));
        assert_eq!(logged.origin, "frame times from the stage log");
        let ignored = logged.warning.expect("not used");
        assert!(
            ignored.starts_with("frame_interval_s = 0.5 is not used"),
            "{ignored}"
        );
        assert_eq!(frame_times(true, None, Some(STACK)).warning, None);
        assert_eq!(seconds(1.0 / 30.0), "0.033333");
    }
}
