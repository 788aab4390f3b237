//! GCS 2.0 wire format: formatting commands and parsing replies.
//!
//! A command is ASCII text ended by a line feed (`MOV 1 10.5 2 3\n`); a few
//! single-byte commands (`#5`, `#7`, `#24`) are sent as the control character
//! alone. A reply is one or more lines; every line but the last ends in a space
//! before the line feed, which is how a reader knows more lines follow. Axis
//! replies are `axis=value` per line. Bytes are decoded as Latin-1 so that the
//! `#7` answers (0xB1 / 0xB0) survive. Written by hand because no crate speaks
//! GCS; the format is small and fully covered by the tests below.

use super::error::GcsError;

/// `#5`: ask which axes are moving (answer: hexadecimal bit mask).
pub const MOTION_STATUS: u8 = 5;
/// `#7`: ask whether the controller is ready (answer: 0xB1 ready, 0xB0 busy).
pub const CONTROLLER_READY: u8 = 7;
/// `#24`: stop all axes at once, like `STP`.
pub const STOP_ALL: u8 = 24;
/// `#7` answer byte meaning "ready".
pub const READY_BYTE: char = '\u{B1}';
/// `#7` answer byte meaning "not ready".
pub const NOT_READY_BYTE: char = '\u{B0}';

/// Checks that an axis identifier can be put on the wire (1..=16 ASCII
/// letters, digits or underscores).
pub fn validate_axis(axis: &str) -> Result<(), GcsError> {
    let ok = !axis.is_empty()
        && axis.len() <= 16
        && axis.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_');
    if ok {
        Ok(())
    } else {
        Err(GcsError::InvalidArgument(format!(
            "axis identifier {axis:?} must be 1 to 16 ASCII letters, digits or underscores"
        )))
    }
}

/// The first axis identifier named twice in `axes`, if any, ignoring case.
/// A stage with a repeated axis would send two targets to one motor and
/// none to another; "x" and "X" count as one, since a controller that
/// takes either for the same axis would do just that (the safe reading).
pub fn repeated_axis(axes: &[String]) -> Option<&str> {
    axes.iter()
        .enumerate()
        .find(|(i, a)| axes[..*i].iter().any(|b| b.eq_ignore_ascii_case(a)))
        .map(|(_, a)| a.as_str())
}

/// Formats a command with optional plain arguments: `format_command("SAI?", &[])`
/// gives `SAI?\n`.
pub fn format_command(name: &str, args: &[&str]) -> Vec<u8> {
    let mut line = name.to_string();
    for arg in args {
        line.push(' ');
        line.push_str(arg);
    }
    line.push('\n');
    line.into_bytes()
}

/// Formats a command with `axis value` pairs, e.g. `MOV 1 10.5 2 3`. Rejects
/// bad axis names and non-finite values before anything is sent.
pub fn format_axis_values(name: &str, pairs: &[(&str, f64)]) -> Result<Vec<u8>, GcsError> {
    let mut args = Vec::with_capacity(pairs.len() * 2);
    for (axis, value) in pairs {
        validate_axis(axis)?;
        if !value.is_finite() {
            return Err(GcsError::InvalidArgument(format!(
                "{name}: value for axis {axis} is {value}, not a finite number"
            )));
        }
        args.push(axis.to_string());
        args.push(format_number(*value));
    }
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    Ok(format_command(name, &refs))
}

/// Formats a number the way GCS accepts it: plain decimal, never an exponent.
pub fn format_number(value: f64) -> String {
    // Rust's `Display` for f64 is shortest-round-trip and never uses exponents.
    let text = format!("{value}");
    if text == "-0" { "0".into() } else { text }
}

/// Formats a command on axes only, e.g. `SVO? 1 2` or `HLT 1`.
pub fn format_axes(name: &str, axes: &[&str]) -> Result<Vec<u8>, GcsError> {
    for axis in axes {
        validate_axis(axis)?;
    }
    Ok(format_command(name, axes))
}

/// True if this raw line (ending in `\n`) is the last line of a reply.
pub fn is_last_line(line: &[u8]) -> bool {
    !line.ends_with(b" \n")
}

/// Decodes a raw line as Latin-1 and strips the line feed and the
/// continuation space.
pub fn decode_line(line: &[u8]) -> String {
    let body = line.strip_suffix(b"\n").unwrap_or(line);
    let body = body.strip_suffix(b"\r").unwrap_or(body);
    let body = body.strip_suffix(b" ").unwrap_or(body);
    body.iter().map(|&b| char::from(b)).collect()
}

fn malformed(command: &str, reason: impl Into<String>, reply: &str) -> GcsError {
    GcsError::MalformedReply {
        command: command.trim_end().to_string(),
        reason: reason.into(),
        reply: reply.to_string(),
    }
}

/// Splits `axis=value` reply lines into pairs, checking the answered axes are
/// exactly the ones asked for (in order) when `expected` is given.
pub fn parse_axis_lines(
    command: &str,
    lines: &[String],
    expected: Option<&[&str]>,
) -> Result<Vec<(String, String)>, GcsError> {
    let mut pairs = Vec::with_capacity(lines.len());
    for line in lines {
        let (axis, value) = line
            .split_once('=')
            .ok_or_else(|| malformed(command, "expected `axis=value`", line))?;
        let axis = axis.trim();
        if validate_axis(axis).is_err() {
            return Err(malformed(command, "bad axis identifier", line));
        }
        pairs.push((axis.to_string(), value.trim().to_string()));
    }
    if let Some(expected) = expected {
        let got: Vec<&str> = pairs.iter().map(|(a, _)| a.as_str()).collect();
        if got != expected {
            return Err(malformed(
                command,
                format!("answered axes {got:?}, asked for {expected:?}"),
                &lines.join("\\n"),
            ));
        }
    }
    Ok(pairs)
}

/// Parses a finite decimal number from a reply value.
pub fn parse_number(command: &str, value: &str) -> Result<f64, GcsError> {
    match value.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(malformed(command, "expected a finite number", value)),
    }
}

/// Parses a GCS boolean (`0` or `1`).
pub fn parse_bool(command: &str, value: &str) -> Result<bool, GcsError> {
    match value.trim() {
        "0" => Ok(false),
        "1" => Ok(true),
        _ => Err(malformed(command, "expected 0 or 1", value)),
    }
}

/// Parses a decimal integer (the `ERR?` answer).
pub fn parse_integer(command: &str, value: &str) -> Result<i32, GcsError> {
    value
        .trim()
        .parse::<i32>()
        .map_err(|_| malformed(command, "expected an integer", value))
}

/// Parses the `#5` answer: a hexadecimal bit mask, bit i set when the i-th
/// axis (in `SAI?` order) is moving.
pub fn parse_hex_mask(command: &str, value: &str) -> Result<u64, GcsError> {
    let text = value.trim();
    let text = text
        .strip_prefix("0x")
        .or_else(|| text.strip_prefix("0X"))
        .unwrap_or(text);
    u64::from_str_radix(text, 16)
        .map_err(|_| malformed(command, "expected a hexadecimal bit mask", value))
}

/// Parses the `#7` answer.
pub fn parse_ready(command: &str, value: &str) -> Result<bool, GcsError> {
    match value.trim_matches(|c| c == ' ' || c == '\n') {
        s if s == READY_BYTE.to_string() => Ok(true),
        s if s == NOT_READY_BYTE.to_string() => Ok(false),
        _ => Err(malformed(command, "expected 0xB1 or 0xB0", value)),
    }
}

/// Formats reply lines for sending: every line but the last gets a trailing
/// space, then each gets a line feed (used by the simulator). Encodes Latin-1.
pub fn encode_reply(lines: &[String]) -> Vec<u8> {
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        out.extend(
            line.chars()
                .map(|c| u8::try_from(u32::from(c)).unwrap_or(b'?')),
        );
        if i + 1 < lines.len() {
            out.push(b' ');
        }
        out.push(b'\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_axis_named_twice_in_any_case_is_repeated() {
        let axes = |names: &[&str]| names.iter().map(|n| n.to_string()).collect::<Vec<_>>();
        assert_eq!(repeated_axis(&axes(&["1", "2", "3"])), None);
        assert_eq!(repeated_axis(&axes(&["1", "2", "1"])), Some("1"));
        assert_eq!(repeated_axis(&axes(&["x", "y", "X"])), Some("X"));
    }

    #[test]
    fn commands_are_formatted_with_plain_decimals() {
        let bytes = format_axis_values("MOV", &[("1", 10.5), ("2", -0.000001)]).unwrap();
        assert_eq!(bytes, b"MOV 1 10.5 2 -0.000001\n");
        assert_eq!(format_command("ERR?", &[]), b"ERR?\n");
        assert_eq!(format_number(-0.0), "0");
        assert_eq!(format_number(1e21), "1000000000000000000000");
    }

    #[test]
    fn bad_values_and_axes_are_refused() {
        assert!(matches!(
            format_axis_values("MOV", &[("1", f64::NAN)]),
            Err(GcsError::InvalidArgument(_))
        ));
        assert!(format_axes("HLT", &["a b"]).is_err());
        assert!(format_axes("HLT", &[""]).is_err());
        assert!(format_axes("HLT", &["X_1"]).is_ok());
    }

    #[test]
    fn continuation_lines_end_in_space() {
        assert!(!is_last_line(b"1=0.5 \n"));
        assert!(is_last_line(b"2=0.5\n"));
        assert_eq!(decode_line(b"1=0.5 \n"), "1=0.5");
        let encoded = encode_reply(&["1=0.5".into(), "2=1".into()]);
        assert_eq!(encoded, b"1=0.5 \n2=1\n");
    }

    #[test]
    fn axis_lines_are_checked_against_the_question() {
        let lines = vec!["1=0.5".to_string(), "2=1".to_string()];
        let pairs = parse_axis_lines("POS?", &lines, Some(&["1", "2"])).unwrap();
        assert_eq!(pairs[1], ("2".to_string(), "1".to_string()));
        assert!(parse_axis_lines("POS?", &lines, Some(&["1"])).is_err());
        assert!(parse_axis_lines("POS?", &["garbage".to_string()], None).is_err());
    }

    #[test]
    fn values_parse_or_fail_typed() {
        assert_eq!(parse_number("POS?", " 1.25 ").unwrap(), 1.25);
        assert!(parse_number("POS?", "nan").is_err());
        assert!(parse_number("POS?", "1,2").is_err());
        assert!(parse_bool("ONT?", "2").is_err());
        assert_eq!(parse_hex_mask("#5", "A").unwrap(), 10);
        assert!(parse_hex_mask("#5", "zz").is_err());
        assert!(parse_ready("#7", "\u{B1}").unwrap());
        assert!(!parse_ready("#7", "\u{B0}").unwrap());
        assert!(parse_ready("#7", "1").is_err());
        assert_eq!(parse_integer("ERR?", "10").unwrap(), 10);
    }

    #[test]
    fn latin1_survives_decode_and_encode() {
        let bytes = encode_reply(&[READY_BYTE.to_string()]);
        assert_eq!(bytes, vec![0xB1, b'\n']);
        assert_eq!(decode_line(&bytes), READY_BYTE.to_string());
    }
}
