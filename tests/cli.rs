//! The binary's contract: help works, unknown commands fail with a non-zero exit.

use std::process::Command;

fn nanopush() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nanopush"))
}

#[test]
fn help_lists_every_top_level_command() {
    let out = nanopush().arg("--help").output().expect("run nanopush");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for cmd in [
        "simulate", "study", "detect", "plan", "assemble", "dry-run", "rig",
    ] {
        assert!(text.contains(cmd), "--help does not list `{cmd}`:\n{text}");
    }
}

#[test]
fn unknown_command_exits_non_zero() {
    let out = nanopush()
        .arg("no-such-command")
        .output()
        .expect("run nanopush");
    assert!(!out.status.success());
}
