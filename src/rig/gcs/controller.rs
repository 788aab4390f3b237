//! The GCS 2.0 controller driver: one typed method per command, in the
//! controller's own units (whatever `TMN?`/`TMX?` are expressed in).
//!
//! Every command that sets something is followed by `ERR?` (setting commands
//! answer nothing, so this is the only way to learn they were refused); a
//! non-zero code comes back as [`GcsError::Controller`]. Queries check that the
//! reply names exactly the axes asked for.

use super::controller_error::ControllerError;
use super::error::GcsError;
use super::protocol;
use super::transport::Transport;

/// A connected GCS 2.0 controller.
pub struct GcsController {
    transport: Transport,
}

fn command_text(bytes: &[u8]) -> String {
    match bytes {
        [b] if *b < 32 => format!("#{b}"),
        _ => String::from_utf8_lossy(bytes).trim_end().to_string(),
    }
}

impl GcsController {
    /// Drives the controller behind `transport`.
    pub fn new(transport: Transport) -> Self {
        Self { transport }
    }

    /// Where the controller is reached.
    pub fn endpoint(&self) -> String {
        self.transport.endpoint()
    }

    /// Sends a query and returns its reply lines.
    pub fn query_raw(&mut self, bytes: &[u8]) -> Result<Vec<String>, GcsError> {
        let text = command_text(bytes);
        self.transport.send(bytes)?;
        self.transport.read_reply(&text)
    }

    fn query_single(&mut self, bytes: &[u8]) -> Result<String, GcsError> {
        let text = command_text(bytes);
        let mut lines = self.query_raw(bytes)?;
        if lines.len() != 1 {
            self.transport.mark_out_of_sync();
            return Err(GcsError::MalformedReply {
                command: text,
                reason: format!("expected one line, got {}", lines.len()),
                reply: lines.join("\\n"),
            });
        }
        Ok(lines.remove(0))
    }

    /// Sends a setting command, then `ERR?`; a non-zero code is an error.
    pub fn set_raw(&mut self, bytes: &[u8]) -> Result<(), GcsError> {
        self.transport.send(bytes)?;
        match self.last_error()? {
            None => Ok(()),
            Some(error) => Err(GcsError::Controller {
                command: command_text(bytes),
                error,
            }),
        }
    }

    /// `ERR?`: the pending controller error, cleared by reading it.
    pub fn last_error(&mut self) -> Result<Option<ControllerError>, GcsError> {
        let reply = self.query_single(b"ERR?\n")?;
        let code = protocol::parse_integer("ERR?", &reply)
            .inspect_err(|_| self.transport.mark_out_of_sync())?;
        Ok(ControllerError::from_code(code))
    }

    /// `*IDN?`: the controller's identification string.
    pub fn identify(&mut self) -> Result<String, GcsError> {
        self.query_single(b"*IDN?\n")
    }

    /// `CSV?`: the GCS syntax version (2.0 for the controllers this drives).
    pub fn syntax_version(&mut self) -> Result<f64, GcsError> {
        let reply = self.query_single(b"CSV?\n")?;
        protocol::parse_number("CSV?", &reply)
    }

    /// `SAI?`: the axis identifiers, in controller order.
    pub fn axes(&mut self) -> Result<Vec<String>, GcsError> {
        let lines = self.query_raw(b"SAI?\n")?;
        for line in &lines {
            protocol::validate_axis(line.trim()).map_err(|_| GcsError::MalformedReply {
                command: "SAI?".into(),
                reason: "not an axis identifier".into(),
                reply: line.clone(),
            })?;
        }
        Ok(lines.into_iter().map(|l| l.trim().to_string()).collect())
    }

    fn query_axes<T>(
        &mut self,
        name: &str,
        axes: &[&str],
        parse: impl Fn(&str, &str) -> Result<T, GcsError>,
    ) -> Result<Vec<T>, GcsError> {
        if axes.is_empty() {
            return Err(GcsError::InvalidArgument(format!("{name}: no axes given")));
        }
        let bytes = protocol::format_axes(name, axes)?;
        let lines = self.query_raw(&bytes)?;
        let pairs = protocol::parse_axis_lines(name, &lines, Some(axes))
            .inspect_err(|_| self.transport.mark_out_of_sync())?;
        pairs
            .iter()
            .map(|(_, v)| parse(name, v))
            .collect::<Result<Vec<T>, _>>()
            .inspect_err(|_| self.transport.mark_out_of_sync())
    }

    /// `POS?`: current positions of `axes`.
    pub fn positions(&mut self, axes: &[&str]) -> Result<Vec<f64>, GcsError> {
        self.query_axes("POS?", axes, protocol::parse_number)
    }

    /// `MOV?`: commanded targets of `axes`.
    pub fn targets(&mut self, axes: &[&str]) -> Result<Vec<f64>, GcsError> {
        self.query_axes("MOV?", axes, protocol::parse_number)
    }

    /// `ONT?`: whether each axis has settled on its target.
    pub fn on_target(&mut self, axes: &[&str]) -> Result<Vec<bool>, GcsError> {
        self.query_axes("ONT?", axes, protocol::parse_bool)
    }

    /// `SVO?`: servo (closed loop) state of each axis.
    pub fn servo(&mut self, axes: &[&str]) -> Result<Vec<bool>, GcsError> {
        self.query_axes("SVO?", axes, protocol::parse_bool)
    }

    /// `VEL?`: closed-loop velocity of each axis, units per second.
    pub fn velocity(&mut self, axes: &[&str]) -> Result<Vec<f64>, GcsError> {
        self.query_axes("VEL?", axes, protocol::parse_number)
    }

    /// `TMN?`: lower travel limit of each axis.
    pub fn travel_min(&mut self, axes: &[&str]) -> Result<Vec<f64>, GcsError> {
        self.query_axes("TMN?", axes, protocol::parse_number)
    }

    /// `TMX?`: upper travel limit of each axis.
    pub fn travel_max(&mut self, axes: &[&str]) -> Result<Vec<f64>, GcsError> {
        self.query_axes("TMX?", axes, protocol::parse_number)
    }

    /// `SVO`: switches servo (closed loop) on or off per axis.
    pub fn set_servo(&mut self, states: &[(&str, bool)]) -> Result<(), GcsError> {
        let pairs: Vec<(&str, f64)> = states
            .iter()
            .map(|&(a, on)| (a, f64::from(u8::from(on))))
            .collect();
        let bytes = protocol::format_axis_values("SVO", &pairs)?;
        self.set_raw(&bytes)
    }

    /// `MOV`: starts absolute moves (returns before motion ends).
    pub fn move_to(&mut self, targets: &[(&str, f64)]) -> Result<(), GcsError> {
        let bytes = protocol::format_axis_values("MOV", targets)?;
        self.set_raw(&bytes)
    }

    /// `MVR`: starts moves relative to the current targets.
    pub fn move_by(&mut self, steps: &[(&str, f64)]) -> Result<(), GcsError> {
        let bytes = protocol::format_axis_values("MVR", steps)?;
        self.set_raw(&bytes)
    }

    /// `VEL`: sets closed-loop velocities, units per second.
    pub fn set_velocity(&mut self, velocities: &[(&str, f64)]) -> Result<(), GcsError> {
        let bytes = protocol::format_axis_values("VEL", velocities)?;
        self.set_raw(&bytes)
    }

    /// `#5`: bit mask of moving axes (bit i for the i-th `SAI?` axis).
    pub fn motion_mask(&mut self) -> Result<u64, GcsError> {
        let reply = self.query_single(&[protocol::MOTION_STATUS])?;
        protocol::parse_hex_mask("#5", &reply).inspect_err(|_| self.transport.mark_out_of_sync())
    }

    /// `#7`: whether the controller is ready for commands.
    pub fn is_ready(&mut self) -> Result<bool, GcsError> {
        let reply = self.query_single(&[protocol::CONTROLLER_READY])?;
        protocol::parse_ready("#7", &reply).inspect_err(|_| self.transport.mark_out_of_sync())
    }

    /// `HLT`: decelerates and stops `axes` (all axes when empty). The error 10
    /// this sets is expected and read away.
    pub fn halt(&mut self, axes: &[&str]) -> Result<(), GcsError> {
        let bytes = protocol::format_axes("HLT", axes)?;
        self.stop_with(&bytes)
    }

    /// `STP`: stops all axes at once. The error 10 it sets is read away.
    pub fn stop_all(&mut self) -> Result<(), GcsError> {
        self.stop_with(b"STP\n")
    }

    fn stop_with(&mut self, bytes: &[u8]) -> Result<(), GcsError> {
        match self.set_raw(bytes) {
            Err(GcsError::Controller {
                error: ControllerError::StoppedByCommand,
                ..
            }) => Ok(()),
            other => other,
        }
    }

    /// Reopens the link after a failure, then halts every axis (a controller
    /// we lost contact with may have been left moving) and clears the errors.
    pub fn reconnect(&mut self) -> Result<(), GcsError> {
        self.transport.reconnect()?;
        self.halt(&[])
    }

    /// Best effort to leave the stage still after a failure: `HLT` on the
    /// current link, and if that fails, reconnect (which halts). Returns
    /// whether the halt was acknowledged.
    pub fn halt_after_failure(&mut self) -> bool {
        if self.halt(&[]).is_ok() {
            return true;
        }
        self.reconnect().is_ok()
    }
}
