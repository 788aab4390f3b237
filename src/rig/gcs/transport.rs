//! Line framing over a byte link: sending commands and reading whole replies
//! with a deadline, so that no read can hang.

use super::error::GcsError;
use super::protocol;
use std::time::{Duration, Instant};

/// A raw, reconnectable byte pipe to a controller (TCP socket, serial tty, or
/// the dry-run recorder). Implementations must never block longer than asked.
pub trait ByteLink: Send {
    /// Writes all bytes (or fails).
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()>;
    /// Reads what is available within `timeout`: `Ok(None)` when nothing came,
    /// `Ok(Some(0))` when the other side closed the link.
    fn read_some(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<Option<usize>>;
    /// Closes and opens the link again.
    fn reopen(&mut self) -> std::io::Result<()>;
    /// Where the link goes, for messages (`127.0.0.1:50000`, `/dev/ttyUSB0`).
    fn endpoint(&self) -> String;
}

/// Longest reply line accepted before the reply is called malformed.
const MAX_LINE_BYTES: usize = 64 * 1024;
/// Most lines accepted in one reply before it is called malformed.
const MAX_REPLY_LINES: usize = 4096;

/// Sends GCS commands and reads complete, possibly multi-line, replies.
pub struct Transport {
    link: Box<dyn ByteLink>,
    timeout: Duration,
    pending: Vec<u8>,
    /// Set after a timeout or a malformed reply: stale bytes may still arrive
    /// and must be discarded before the next command.
    needs_resync: bool,
}

impl Transport {
    /// Wraps a link; `timeout` bounds the wait for each reply.
    pub fn new(link: Box<dyn ByteLink>, timeout: Duration) -> Self {
        Self {
            link,
            timeout,
            pending: Vec::new(),
            needs_resync: false,
        }
    }

    /// The reply timeout in force.
    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    /// Where the link goes.
    pub fn endpoint(&self) -> String {
        self.link.endpoint()
    }

    fn io_error(&self, source: std::io::Error) -> GcsError {
        GcsError::Io {
            endpoint: self.link.endpoint(),
            source,
        }
    }

    /// Sends raw command bytes (already formatted and checked).
    pub fn send(&mut self, bytes: &[u8]) -> Result<(), GcsError> {
        if self.needs_resync {
            self.discard_input()?;
        }
        self.link.write_all(bytes).map_err(|e| self.io_error(e))
    }

    /// Drops buffered and in-flight input (waits briefly for stragglers, but
    /// never longer than the reply timeout: a link that keeps talking is an
    /// error, not a reason to hang).
    pub fn discard_input(&mut self) -> Result<(), GcsError> {
        self.pending.clear();
        let deadline = Instant::now() + self.timeout;
        let mut buf = [0u8; 1024];
        loop {
            match self.link.read_some(&mut buf, Duration::from_millis(20)) {
                Ok(Some(n)) if n > 0 => {
                    if Instant::now() >= deadline {
                        return Err(GcsError::MalformedReply {
                            command: "(discarding stale input)".into(),
                            reason: format!("the controller kept sending for {:?}", self.timeout),
                            reply: String::from_utf8_lossy(&buf[..n.min(64)]).into_owned(),
                        });
                    }
                }
                Ok(_) => break,
                Err(e) => return Err(self.io_error(e)),
            }
        }
        self.needs_resync = false;
        Ok(())
    }

    /// Reads one complete reply to `command` (all its lines, decoded).
    pub fn read_reply(&mut self, command: &str) -> Result<Vec<String>, GcsError> {
        let deadline = Instant::now() + self.timeout;
        let mut lines = Vec::new();
        loop {
            let raw = self.read_raw_line(command, deadline)?;
            let last = protocol::is_last_line(&raw);
            lines.push(protocol::decode_line(&raw));
            if last {
                return Ok(lines);
            }
            if lines.len() >= MAX_REPLY_LINES {
                self.needs_resync = true;
                return Err(GcsError::MalformedReply {
                    command: command.to_string(),
                    reason: format!("more than {MAX_REPLY_LINES} continuation lines"),
                    reply: String::new(),
                });
            }
        }
    }

    fn read_raw_line(&mut self, command: &str, deadline: Instant) -> Result<Vec<u8>, GcsError> {
        let mut buf = [0u8; 1024];
        loop {
            if let Some(pos) = self.pending.iter().position(|&b| b == b'\n') {
                return Ok(self.pending.drain(..=pos).collect());
            }
            if self.pending.len() > MAX_LINE_BYTES {
                self.needs_resync = true;
                let reply = String::from_utf8_lossy(&self.pending[..64]).into_owned();
                return Err(GcsError::MalformedReply {
                    command: command.to_string(),
                    reason: format!("line longer than {MAX_LINE_BYTES} bytes without a line feed"),
                    reply,
                });
            }
            let now = Instant::now();
            if now >= deadline {
                self.needs_resync = true;
                let partial = String::from_utf8_lossy(&self.pending).into_owned();
                self.pending.clear();
                return Err(GcsError::Timeout {
                    command: command.to_string(),
                    timeout: self.timeout,
                    partial,
                });
            }
            match self.link.read_some(&mut buf, deadline - now) {
                Ok(Some(0)) => {
                    self.needs_resync = true;
                    let err = std::io::Error::new(
                        std::io::ErrorKind::UnexpectedEof,
                        "the controller closed the connection",
                    );
                    return Err(self.io_error(err));
                }
                Ok(Some(n)) => self.pending.extend_from_slice(&buf[..n]),
                Ok(None) => {}
                Err(e) => {
                    self.needs_resync = true;
                    return Err(self.io_error(e));
                }
            }
        }
    }

    /// Marks the reply stream as untrustworthy (e.g. after a malformed reply),
    /// so stale bytes are dropped before the next command.
    pub fn mark_out_of_sync(&mut self) {
        self.needs_resync = true;
    }

    /// Closes and reopens the link, dropping any buffered input.
    pub fn reconnect(&mut self) -> Result<(), GcsError> {
        self.pending.clear();
        self.link.reopen().map_err(|e| self.io_error(e))?;
        self.needs_resync = false;
        Ok(())
    }
}
