//! Runs the binary with a deadline: a bad input that hangs it fails the
//! test (naming the command) instead of hanging the suite.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a run said: whether it succeeded, and its stdout then stderr.
pub struct Ran {
    pub ok: bool,
    pub stdout: String,
    pub stderr: String,
}

/// Runs `nanopush args` in `dir`; panics if it is still running after `secs`.
pub fn nanopush_within(dir: &Path, args: &[&str], secs: u64) -> Ran {
    let (out, err) = (dir.join("deadline.stdout"), dir.join("deadline.stderr"));
    let mut child = Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .stdout(Stdio::from(std::fs::File::create(&out).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(&err).unwrap()))
        .spawn()
        .unwrap();
    let started = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if started.elapsed() > Duration::from_secs(secs) {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("nanopush {} still running after {secs} s", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Ran {
        ok: status.success(),
        stdout: std::fs::read_to_string(&out).unwrap(),
        stderr: std::fs::read_to_string(&err).unwrap(),
    }
}
