//! A simulated PI GCS 2.0 controller: the command interpreter and the motion
//! model, with time passed in so that it is deterministic and testable.
//!
//! It stands in for hardware (none was available) and follows the GCS 2.0
//! manuals as PIPython expects them: setting commands answer nothing and leave
//! an error code for `ERR?` (only the last error is kept, and reading clears
//! it); moves are velocity-limited, so `ONT?` answers 0 and the `#5` bit is set
//! while an axis travels; `MOV` with servo off sets error 5, a target outside
//! `TMN?`..`TMX?` sets 7, `STP`/`HLT`/`#24` stop motion and set 10; an invalid
//! axis sets 15, an unknown command 2, a bad parameter 1.

use super::protocol::{self, READY_BYTE};
use std::time::Instant;

/// One simulated axis, in controller units (micrometres for a nanopositioner).
#[derive(Debug, Clone, PartialEq)]
pub struct SimAxisConfig {
    /// Axis identifier as `SAI?` reports it.
    pub name: String,
    /// Lower travel limit (`TMN?`).
    pub min: f64,
    /// Upper travel limit (`TMX?`).
    pub max: f64,
    /// Start-up closed-loop velocity (`VEL?`), units per second.
    pub velocity: f64,
    /// Largest velocity `VEL` accepts (above it: error 8).
    pub max_velocity: f64,
    /// Position at power-up.
    pub initial_position: f64,
}

/// The whole simulated controller's configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// What `*IDN?` answers.
    pub identity: String,
    /// The axes, in `SAI?` order.
    pub axes: Vec<SimAxisConfig>,
}

impl Default for SimConfig {
    /// A 3-axis piezo nanopositioner: 100 x 100 x 15 um, 100 um/s, starting
    /// mid-range with servos off (as after power-up).
    fn default() -> Self {
        let axis = |name: &str, max: f64| SimAxisConfig {
            name: name.into(),
            min: 0.0,
            max,
            velocity: 100.0,
            max_velocity: 10_000.0,
            initial_position: max / 2.0,
        };
        Self {
            identity: "(c)2026 nanopush, GCS simulator E-727.3SDA, 0000000000, 01.000".into(),
            axes: vec![axis("1", 100.0), axis("2", 100.0), axis("3", 15.0)],
        }
    }
}

impl SimConfig {
    /// A 2-axis coarse XY stage controller (a C-884 driving two linear
    /// stages): 25 x 25 mm of travel in millimetres, 1 mm/s, starting
    /// mid-travel with servos off.
    pub fn coarse() -> Self {
        let axis = |name: &str| SimAxisConfig {
            name: name.into(),
            min: 0.0,
            max: 25.0,
            velocity: 1.0,
            max_velocity: 20.0,
            initial_position: 12.5,
        };
        Self {
            identity: "(c)2026 nanopush, GCS simulator C-884.4DC, 0000000000, 01.000".into(),
            axes: vec![axis("1"), axis("2")],
        }
    }
}

#[derive(Debug, Clone)]
struct AxisState {
    servo: bool,
    velocity: f64,
    start_position: f64,
    start_time: Instant,
    target: f64,
    /// Simulated seconds per wall-clock second.
    time_scale: f64,
}

impl AxisState {
    fn position(&self, now: Instant) -> f64 {
        let dt = now.saturating_duration_since(self.start_time).as_secs_f64() * self.time_scale;
        travel(self.start_position, self.target, self.velocity, dt)
    }

    fn moving(&self, now: Instant) -> bool {
        self.position(now) != self.target
    }

    fn retarget(&mut self, target: f64, now: Instant) {
        self.start_position = self.position(now);
        self.start_time = now;
        self.target = target;
    }

    fn stop(&mut self, now: Instant) {
        let here = self.position(now);
        self.retarget(here, now);
    }
}

/// Where an axis that left `from` for `target` at `velocity` is after `dt_s`.
/// Exactly `target` once reached (`from + (target - from)` need not be
/// `target` in floating point, and an axis a rounding error short of its
/// target would never be on target).
fn travel(from: f64, target: f64, velocity: f64, dt_s: f64) -> f64 {
    let distance = target - from;
    let travelled = velocity * dt_s;
    if travelled >= distance.abs() {
        target
    } else {
        from + travelled.copysign(distance)
    }
}

/// How every axis moves from one instant on, until the next [`Motion`]: the
/// record a simulated world needs to move a probe the way the controller
/// moved its axes (see [`SimController::record_motions`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// When the axes started to move this way.
    pub at: Instant,
    /// Axis positions at `at`, controller units.
    pub from: Vec<f64>,
    /// Axis targets, controller units.
    pub targets: Vec<f64>,
    /// Axis velocities, controller units per simulated second.
    pub velocities: Vec<f64>,
    /// Simulated seconds per wall-clock second.
    pub time_scale: f64,
}

impl Motion {
    /// Axis positions `wall_s` wall-clock seconds after `at`.
    pub fn positions_after(&self, wall_s: f64) -> Vec<f64> {
        let dt = wall_s.max(0.0) * self.time_scale;
        (0..self.from.len())
            .map(|i| travel(self.from[i], self.targets[i], self.velocities[i], dt))
            .collect()
    }

    /// Wall-clock seconds after `at` at which each axis is on target.
    pub fn arrivals_s(&self) -> Vec<f64> {
        (0..self.from.len())
            .map(|i| {
                let d = (self.targets[i] - self.from[i]).abs();
                if d == 0.0 {
                    0.0
                } else {
                    d / self.velocities[i] / self.time_scale
                }
            })
            .collect()
    }
}

/// Commands the simulator knows, as `HLP?` lists them (PIPython reads this
/// list to decide which functions a controller supports).
const HELP: &[(&str, &str)] = &[
    ("#5", "Request Motion Status"),
    ("#7", "Request Controller Ready Status"),
    ("#24", "Stop All Axes"),
    ("*IDN?", "Get Device Identification"),
    ("CSV?", "Get Current Syntax Version"),
    ("ERR?", "Get Error Number"),
    ("HLP?", "Get List Of Available Commands"),
    ("HLT [{<AxisID>}]", "Halt Motion Smoothly"),
    ("MOV {<AxisID> <Position>}", "Set Target Position"),
    ("MOV? [{<AxisID>}]", "Get Target Position"),
    (
        "MVR {<AxisID> <Distance>}",
        "Set Target Relative To Current Position",
    ),
    ("ONT? [{<AxisID>}]", "Get On Target State"),
    ("POS? [{<AxisID>}]", "Get Real Position"),
    ("SAI? [ALL]", "Get List Of Current Axis Identifiers"),
    ("STP", "Stop All Axes"),
    ("SVO {<AxisID> <ServoState>}", "Set Servo Mode"),
    ("SVO? [{<AxisID>}]", "Get Servo Mode"),
    ("TMN? [{<AxisID>}]", "Get Minimum Commandable Position"),
    ("TMX? [{<AxisID>}]", "Get Maximum Commandable Position"),
    ("VEL {<AxisID> <Velocity>}", "Set Closed-Loop Velocity"),
    ("VEL? [{<AxisID>}]", "Get Closed-Loop Velocity"),
];

fn help_lines() -> Vec<String> {
    let mut lines = vec!["The following commands are available:".to_string()];
    lines.extend(HELP.iter().map(|(cmd, what)| format!("{cmd} {what}")));
    lines.push("end of help".into());
    lines
}

/// The simulated controller: feed it command lines, get reply lines.
#[derive(Debug, Clone)]
pub struct SimController {
    config: SimConfig,
    axes: Vec<AxisState>,
    last_error: i32,
    motions: Option<Vec<Motion>>,
}

/// Parsed `axis value` pairs, or the GCS error code that parsing set.
type Pairs = Result<Vec<(usize, String)>, i32>;

impl SimController {
    /// A controller at power-up: servos off, axes at their initial positions.
    pub fn new(config: SimConfig, now: Instant) -> Self {
        let axes = config
            .axes
            .iter()
            .map(|a| AxisState {
                servo: false,
                velocity: a.velocity,
                start_position: a.initial_position,
                start_time: now,
                target: a.initial_position,
                time_scale: 1.0,
            })
            .collect();
        Self {
            config,
            axes,
            last_error: 0,
            motions: None,
        }
    }

    /// Runs simulated time `scale` times faster than the wall clock (1 by
    /// default), so that slow pushes rehearse quickly; velocities stay in
    /// units per simulated second. Motions under way are restarted from
    /// where they are.
    pub fn set_time_scale(&mut self, scale: f64, now: Instant) {
        let scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        };
        for a in &mut self.axes {
            let target = a.target;
            a.retarget(target, now);
            a.time_scale = scale;
        }
        self.note_motion(now);
    }

    /// Starts keeping a [`Motion`] for every change of motion (moves, halts,
    /// velocity changes), beginning with the state at `now`, until taken
    /// with [`SimController::take_motions`]. Off by default, so a long-running
    /// simulator does not grow.
    pub fn record_motions(&mut self, now: Instant) {
        self.motions = Some(Vec::new());
        self.note_motion(now);
    }

    /// The motions recorded since the last call, oldest first.
    pub fn take_motions(&mut self) -> Vec<Motion> {
        self.motions
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    fn note_motion(&mut self, now: Instant) {
        let Some(log) = self.motions.as_mut() else {
            return;
        };
        log.push(Motion {
            at: now,
            from: self.axes.iter().map(|a| a.position(now)).collect(),
            targets: self.axes.iter().map(|a| a.target).collect(),
            velocities: self.axes.iter().map(|a| a.velocity).collect(),
            time_scale: self.axes.first().map_or(1.0, |a| a.time_scale),
        });
    }

    /// The configuration it was built with.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// Current position of axis `index` (for tests and the dry-run log).
    pub fn position(&self, index: usize, now: Instant) -> Option<f64> {
        self.axes.get(index).map(|a| a.position(now))
    }

    /// True if any axis is still travelling.
    pub fn any_moving(&self, now: Instant) -> bool {
        self.axes.iter().any(|a| a.moving(now))
    }

    /// The pending error code (what `ERR?` would answer), without clearing it.
    pub fn pending_error(&self) -> i32 {
        self.last_error
    }

    fn axis_index(&self, name: &str) -> Option<usize> {
        self.config.axes.iter().position(|a| a.name == name)
    }

    /// Axis indices named in `args`, or all axes when none are named.
    fn axes_arg(&self, args: &[&str]) -> Result<Vec<usize>, i32> {
        if args.is_empty() || (args.len() == 1 && args[0].eq_ignore_ascii_case("ALL")) {
            return Ok((0..self.axes.len()).collect());
        }
        args.iter().map(|a| self.axis_index(a).ok_or(15)).collect()
    }

    fn pairs(&self, args: &[&str]) -> Pairs {
        if args.is_empty() || args.len() % 2 != 0 {
            return Err(1);
        }
        args.chunks(2)
            .map(|c| Ok((self.axis_index(c[0]).ok_or(15)?, c[1].to_string())))
            .collect()
    }

    fn numbers(&self, args: &[&str]) -> Result<Vec<(usize, f64)>, i32> {
        self.pairs(args)?
            .into_iter()
            .map(|(i, v)| match v.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok((i, x)),
                _ => Err(1),
            })
            .collect()
    }

    fn axis_reply(&self, axes: &[usize], value: impl Fn(usize) -> String) -> Vec<String> {
        axes.iter()
            .map(|&i| format!("{}={}", self.config.axes[i].name, value(i)))
            .collect()
    }

    /// Handles a single-byte command (`#5`, `#7`, `#24`); `None` if `byte`
    /// is not one.
    pub fn handle_control_byte(&mut self, byte: u8, now: Instant) -> Option<Vec<String>> {
        match byte {
            protocol::MOTION_STATUS => {
                let mask = self
                    .axes
                    .iter()
                    .enumerate()
                    .filter(|(_, a)| a.moving(now))
                    .fold(0u64, |m, (i, _)| m | (1 << i));
                Some(vec![format!("{mask:X}")])
            }
            protocol::CONTROLLER_READY => {
                // The simulator has no start-up or wave-generator phase: always ready.
                Some(vec![READY_BYTE.to_string()])
            }
            protocol::STOP_ALL => {
                self.stop_all(now);
                Some(Vec::new())
            }
            _ => None,
        }
    }

    fn stop_all(&mut self, now: Instant) {
        for a in &mut self.axes {
            a.stop(now);
        }
        self.last_error = 10;
        self.note_motion(now);
    }

    /// Feeds raw bytes from a client: control bytes act at once, other bytes
    /// collect in `line` until a line feed. Returns each non-empty reply.
    pub fn feed(&mut self, line: &mut Vec<u8>, bytes: &[u8], now: Instant) -> Vec<Vec<String>> {
        let mut replies = Vec::new();
        for &b in bytes {
            let reply = match line
                .is_empty()
                .then(|| self.handle_control_byte(b, now))
                .flatten()
            {
                Some(r) => r,
                None if b == b'\n' => {
                    let text: String = line.drain(..).map(char::from).collect();
                    self.handle_line(text.trim_end_matches('\r'), now)
                }
                None => {
                    // Bound the buffer: a flood without line feeds is dropped.
                    if line.len() < 64 * 1024 {
                        line.push(b);
                    }
                    continue;
                }
            };
            if !reply.is_empty() {
                replies.push(reply);
            }
        }
        replies
    }

    /// Handles one command line (without the line feed); returns the reply
    /// lines, or an empty vector for commands that answer nothing.
    pub fn handle_line(&mut self, line: &str, now: Instant) -> Vec<String> {
        let mut words = line.split_whitespace();
        let Some(name) = words.next() else {
            return Vec::new();
        };
        let args: Vec<&str> = words.collect();
        tracing::debug!("sim-gcs: {line}");
        let outcome = self.dispatch(&name.to_ascii_uppercase(), &args, now);
        match outcome {
            Ok(reply) => reply,
            Err(code) => {
                self.last_error = code;
                Vec::new()
            }
        }
    }

    fn dispatch(&mut self, name: &str, args: &[&str], now: Instant) -> Result<Vec<String>, i32> {
        let no_args = |r: Vec<String>| if args.is_empty() { Ok(r) } else { Err(1) };
        match name {
            "*IDN?" => no_args(vec![self.config.identity.clone()]),
            "CSV?" => no_args(vec!["2.0".into()]),
            "HLP?" => no_args(help_lines()),
            "ERR?" => {
                let code = std::mem::take(&mut self.last_error);
                no_args(vec![code.to_string()])
            }
            "SAI?" => {
                if args.len() > 1 || args.first().is_some_and(|a| !a.eq_ignore_ascii_case("ALL")) {
                    return Err(1);
                }
                Ok(self.config.axes.iter().map(|a| a.name.clone()).collect())
            }
            "SVO?" => {
                let axes = self.axes_arg(args)?;
                Ok(self.axis_reply(&axes, |i| u8::from(self.axes[i].servo).to_string()))
            }
            "POS?" => {
                let axes = self.axes_arg(args)?;
                Ok(self.axis_reply(&axes, |i| {
                    protocol::format_number(self.axes[i].position(now))
                }))
            }
            "MOV?" => {
                let axes = self.axes_arg(args)?;
                Ok(self.axis_reply(&axes, |i| protocol::format_number(self.axes[i].target)))
            }
            "ONT?" => {
                let axes = self.axes_arg(args)?;
                Ok(self.axis_reply(&axes, |i| u8::from(!self.axes[i].moving(now)).to_string()))
            }
            "VEL?" => {
                let axes = self.axes_arg(args)?;
                Ok(self.axis_reply(&axes, |i| protocol::format_number(self.axes[i].velocity)))
            }
            "TMN?" => {
                let axes = self.axes_arg(args)?;
                Ok(self.axis_reply(&axes, |i| protocol::format_number(self.config.axes[i].min)))
            }
            "TMX?" => {
                let axes = self.axes_arg(args)?;
                Ok(self.axis_reply(&axes, |i| protocol::format_number(self.config.axes[i].max)))
            }
            "SVO" => {
                let pairs = self.pairs(args)?;
                let mut states = Vec::with_capacity(pairs.len());
                for (i, v) in pairs {
                    states.push((
                        i,
                        match v.as_str() {
                            "0" => false,
                            "1" => true,
                            _ => return Err(1),
                        },
                    ));
                }
                for (i, on) in states {
                    let axis = &mut self.axes[i];
                    if !on {
                        axis.stop(now);
                    }
                    axis.servo = on;
                }
                self.note_motion(now);
                Ok(Vec::new())
            }
            "MOV" | "MVR" => {
                let moves = self.numbers(args)?;
                let mut targets = Vec::with_capacity(moves.len());
                for (i, value) in moves {
                    if !self.axes[i].servo {
                        return Err(5);
                    }
                    let target = if name == "MVR" {
                        self.axes[i].target + value
                    } else {
                        value
                    };
                    let limits = &self.config.axes[i];
                    if !(limits.min..=limits.max).contains(&target) {
                        return Err(7);
                    }
                    targets.push((i, target));
                }
                for (i, target) in targets {
                    self.axes[i].retarget(target, now);
                }
                self.note_motion(now);
                Ok(Vec::new())
            }
            "VEL" => {
                let values = self.numbers(args)?;
                if values
                    .iter()
                    .any(|&(i, v)| v <= 0.0 || v > self.config.axes[i].max_velocity)
                {
                    return Err(8);
                }
                for (i, v) in values {
                    let target = self.axes[i].target;
                    self.axes[i].retarget(target, now);
                    self.axes[i].velocity = v;
                }
                self.note_motion(now);
                Ok(Vec::new())
            }
            "HLT" => {
                let axes = self.axes_arg(args)?;
                for i in axes {
                    self.axes[i].stop(now);
                }
                self.last_error = 10;
                self.note_motion(now);
                Ok(Vec::new())
            }
            "STP" => {
                if !args.is_empty() {
                    return Err(1);
                }
                self.stop_all(now);
                Ok(Vec::new())
            }
            _ => Err(2),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn sim() -> (SimController, Instant) {
        let t0 = Instant::now();
        (SimController::new(SimConfig::default(), t0), t0)
    }

    #[test]
    fn moves_are_velocity_limited() {
        let (mut c, t0) = sim();
        c.handle_line("SVO 1 1", t0);
        c.handle_line("MOV 1 60", t0);
        assert_eq!(c.handle_line("ERR?", t0), vec!["0"]);
        let mid = t0 + Duration::from_millis(50);
        assert_eq!(c.handle_line("ONT? 1", mid), vec!["1=0"]);
        assert_eq!(c.handle_control_byte(5, mid).unwrap(), vec!["1"]);
        let pos: f64 = c.handle_line("POS? 1", mid)[0][2..].parse().unwrap();
        assert!(
            (pos - 55.0).abs() < 1e-9,
            "50 um start + 100 um/s * 50 ms, got {pos}"
        );
        let end = t0 + Duration::from_millis(200);
        assert_eq!(c.handle_line("ONT? 1", end), vec!["1=1"]);
        assert_eq!(c.handle_line("POS? 1", end), vec!["1=60"]);
        assert_eq!(c.handle_control_byte(5, end).unwrap(), vec!["0"]);
    }

    #[test]
    fn errors_5_7_10_15_2_1_are_set() {
        let (mut c, t0) = sim();
        let err = |c: &mut SimController| c.handle_line("ERR?", t0)[0].clone();
        c.handle_line("MOV 1 10", t0);
        assert_eq!(err(&mut c), "5");
        c.handle_line("SVO 1 1", t0);
        c.handle_line("MOV 1 101", t0);
        assert_eq!(err(&mut c), "7");
        assert_eq!(
            c.handle_line("MOV? 1", t0),
            vec!["1=50"],
            "refused move keeps target"
        );
        c.handle_line("MOV 9 1", t0);
        assert_eq!(err(&mut c), "15");
        c.handle_line("FOO", t0);
        assert_eq!(err(&mut c), "2");
        c.handle_line("MOV 1 abc", t0);
        assert_eq!(err(&mut c), "1");
        c.handle_line("VEL 1 0", t0);
        assert_eq!(err(&mut c), "8");
        c.handle_line("MOV 1 90", t0);
        c.handle_line("STP", t0 + Duration::from_millis(100));
        assert_eq!(err(&mut c), "10");
        assert_eq!(err(&mut c), "0", "ERR? clears the error");
        assert!(!c.any_moving(t0 + Duration::from_millis(100)));
    }

    #[test]
    fn an_axis_arrives_exactly_on_target_whatever_the_rounding() {
        let (mut c, t0) = sim();
        c.handle_line("SVO 1 1", t0);
        c.handle_line("MOV 1 98", t0);
        let t1 = t0 + Duration::from_secs(1);
        // 98 + (18.196826997 - 98) is 18.196826997000002 in f64.
        c.handle_line("MOV 1 18.196826997", t1);
        let t2 = t1 + Duration::from_secs(1);
        assert_eq!(c.handle_line("ONT? 1", t2), vec!["1=1"]);
        assert_eq!(c.handle_line("POS? 1", t2), vec!["1=18.196826997"]);
    }

    #[test]
    fn multi_axis_queries_answer_in_order() {
        let (mut c, t0) = sim();
        assert_eq!(c.handle_line("TMX?", t0), vec!["1=100", "2=100", "3=15"]);
        assert_eq!(c.handle_line("SAI?", t0), vec!["1", "2", "3"]);
        assert_eq!(c.handle_line("SVO? 3 1", t0), vec!["3=0", "1=0"]);
        assert_eq!(c.handle_line("CSV?", t0), vec!["2.0"]);
    }
}
