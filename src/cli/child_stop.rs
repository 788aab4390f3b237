//! A child process run to its end, or stopped on Ctrl-C: the child is
//! passed the interrupt (SIGINT, so it stops as it stops on Ctrl-C: a run
//! journals and reports its stop), and ended if it has not stopped
//! [`STOP_WAIT`] later. A terminal's Ctrl-C reaches the child by itself
//! (one process group), a `kill -INT` of the parent alone did not: `study
//! assemble` had finished the seed in progress first.

use std::io::Read;
use std::process::{Child, Command, Output, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How long a child passed the interrupt has to stop before it is ended.
pub const STOP_WAIT: Duration = Duration::from_secs(2);

/// How often the child and the flag are looked at.
const POLL: Duration = Duration::from_millis(20);

/// Runs `command` with its output captured, as [`Command::output`] does,
/// passing `interrupt` on to it when raised.
pub fn run_stopping_on(mut command: Command, interrupt: &AtomicBool) -> std::io::Result<Output> {
    let mut child = command
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    let stdout = reader(child.stdout.take());
    let stderr = reader(child.stderr.take());
    let mut passed_on: Option<Instant> = None;
    let status = loop {
        if let Some(status) = child.try_wait()? {
            break status;
        }
        match passed_on {
            None if interrupt.load(Ordering::SeqCst) => {
                interrupt_child(&child);
                passed_on = Some(Instant::now());
            }
            Some(at) if at.elapsed() >= STOP_WAIT => {
                // Ended, not waited for: its journal's lines are whole
                // but for a last one cut short, which a reader cuts off.
                let _ = child.kill();
            }
            _ => {}
        }
        std::thread::sleep(POLL);
    };
    Ok(Output {
        status,
        stdout: stdout.join().unwrap_or_default(),
        stderr: stderr.join().unwrap_or_default(),
    })
}

/// SIGINT to the child, still unreaped (so its id is still its own).
fn interrupt_child(child: &Child) {
    use nix::sys::signal::{Signal, kill};
    use nix::unistd::Pid;
    if let Ok(id) = i32::try_from(child.id()) {
        let _ = kill(Pid::from_raw(id), Signal::SIGINT);
    }
}

/// Reads a pipe to its end on a thread of its own (both pipes at once, so
/// a child filling one does not block on it).
fn reader<R: Read + Send + 'static>(pipe: Option<R>) -> std::thread::JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut p) = pipe {
            let _ = p.read_to_end(&mut bytes);
        }
        bytes
    })
}
