//! A command interrupted as Ctrl-C interrupts it: SIGINT (`kill -INT`) to
//! the process alone once its output has reached a given point, timed from
//! the press to its exit, or as soon as it can take the press.
// Each test binary uses its own part.
#![allow(dead_code)]

use std::io::BufRead;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// What an interrupted command left.
pub struct Interrupted {
    /// Its stdout lines after the press, and its stderr and status.
    pub after: Vec<String>,
    /// Its exit status and stderr (stdout is in `after`).
    pub output: Output,
    /// From the press to its exit.
    pub stopped_in: Duration,
}

/// Runs `command`, checks its first stdout lines start as `first_lines`
/// say, waits `then`, presses Ctrl-C and waits for it to end.
pub fn interrupt_after(mut command: Command, first_lines: &[&str], then: Duration) -> Interrupted {
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    for start in first_lines {
        let line = lines.next().unwrap().unwrap();
        assert!(
            line.starts_with(start),
            "{line:?} does not start with {start:?}"
        );
    }
    std::thread::sleep(then);
    let pressed = press_ctrl_c(&child);
    let after = lines.map(Result::unwrap).collect();
    let output = child.wait_with_output().unwrap();
    Interrupted {
        after,
        output,
        stopped_in: pressed.elapsed(),
    }
}

impl Interrupted {
    /// Its stderr, once checked that it failed, within 5 s of the press,
    /// and that its stderr starts with `answer` (the press answered first).
    pub fn stopped_at_once(&self, answer: &str) -> String {
        let stderr = String::from_utf8_lossy(&self.output.stderr).into_owned();
        assert!(!self.output.status.success(), "{stderr}");
        let stopped_in = self.stopped_in;
        assert!(
            stopped_in.as_secs_f64() < 5.0,
            "stopped {stopped_in:?} after the press: {stderr}"
        );
        assert!(stderr.starts_with(answer), "{stderr}");
        stderr
    }
}

/// True once process `pid` catches SIGINT, i.e. has its Ctrl-C handler
/// installed: bit SIGINT-1 of `SigCgt` in /proc/PID/status (Linux). Before
/// that (the program still loading its libraries) Ctrl-C ends it at once,
/// with nothing written: no program can answer it there.
pub fn catches_sigint(pid: u32) -> bool {
    const SIGINT: u32 = 2;
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("SigCgt:").map(|h| h.trim().to_owned()))
        })
        .and_then(|h| u64::from_str_radix(&h, 16).ok())
        .is_some_and(|mask| mask & (1 << (SIGINT - 1)) != 0)
}

/// Waits (up to 30 s) until `child` catches Ctrl-C: a press sent earlier
/// would test the loader, not the program.
pub fn wait_until_caught(child: &Child) {
    let started = Instant::now();
    while !catches_sigint(child.id()) {
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "no Ctrl-C handler was installed"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// Runs `command`, presses Ctrl-C as soon as it can take it and waits for
/// it to end.
pub fn interrupt_once_caught(mut command: Command) -> Interrupted {
    let child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until_caught(&child);
    let pressed = press_ctrl_c(&child);
    let output = child.wait_with_output().unwrap();
    let after = String::from_utf8_lossy(&output.stdout)
        .lines()
        .map(str::to_owned)
        .collect();
    Interrupted {
        after,
        output,
        stopped_in: pressed.elapsed(),
    }
}

/// Sends `child` alone SIGINT, as Ctrl-C does; when it was sent.
pub fn press_ctrl_c(child: &Child) -> Instant {
    let pressed = Instant::now();
    let sent = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    pressed
}
