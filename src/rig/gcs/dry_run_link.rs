//! A link that sends nothing: it records the exact bytes a command would put
//! on the wire and answers from an in-process simulator, so a whole session
//! can be rehearsed (`--dry-run`) without touching hardware.

use super::simulator::{SimConfig, SimController};
use super::transport::ByteLink;
use super::{protocol, sim_server};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The bytes a dry run would have sent, one entry per write, shared so that
/// the caller can read them after the link is boxed into a transport.
pub type SentLog = Arc<Mutex<Vec<Vec<u8>>>>;

/// Records writes and answers them from a [`SimController`].
pub struct DryRunLink {
    controller: SimController,
    log: SentLog,
    line: Vec<u8>,
    replies: Vec<u8>,
}

impl DryRunLink {
    /// A dry-run link answering like a controller configured by `config`.
    pub fn new(config: SimConfig) -> (Self, SentLog) {
        let log = SentLog::default();
        let link = Self {
            controller: SimController::new(config, Instant::now()),
            log: Arc::clone(&log),
            line: Vec::new(),
            replies: Vec::new(),
        };
        (link, log)
    }
}

impl ByteLink for DryRunLink {
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        tracing::info!("dry run: would send {:?}", String::from_utf8_lossy(bytes));
        sim_server::lock(&self.log).push(bytes.to_vec());
        for reply in self.controller.feed(&mut self.line, bytes, Instant::now()) {
            self.replies.extend(protocol::encode_reply(&reply));
        }
        Ok(())
    }

    fn read_some(&mut self, buf: &mut [u8], _timeout: Duration) -> std::io::Result<Option<usize>> {
        if self.replies.is_empty() {
            return Ok(None);
        }
        let n = buf.len().min(self.replies.len());
        buf[..n].copy_from_slice(&self.replies[..n]);
        self.replies.drain(..n);
        Ok(Some(n))
    }

    fn reopen(&mut self) -> std::io::Result<()> {
        self.line.clear();
        self.replies.clear();
        Ok(())
    }

    fn endpoint(&self) -> String {
        "dry run (nothing is sent)".into()
    }
}
