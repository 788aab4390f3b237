//! Command-line interface: argument parsing and dispatch. Each subcommand lives
//! in its own file with its `Args` and `run`; the library does the work.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

mod assemble;
mod assemble_rig;
mod calibrate;
mod child_stop;
mod demo;
mod detect;
mod distinct_outputs;
mod dry_run;
mod dry_run_worker;
mod error_message;
mod folder_flag;
mod go_on;
mod made_folder;
mod pattern_args;
mod plan;
mod rig_calibrate;
mod rig_probe;
mod rig_sim_gcs;
mod simulate;
mod stage_csv;
mod study_assemble;
mod study_model;
mod study_plan;
mod study_vision;
mod synth_frame;
mod synth_layout;
mod verify_plan;

/// Vision-in-the-loop automated assembly of micro/nanoparticles with a probe.
#[derive(Parser, Debug)]
#[command(name = "nanopush", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the demonstration job on the simulated rig and print where its report is.
    Demo(demo::Args),
    /// Simulate one push of a particle with the pushing model.
    Simulate(simulate::Args),
    /// Show what accuracy costs in time.
    #[command(subcommand)]
    Study(StudyCommand),
    /// Detect particles and the probe tip in a microscope frame.
    Detect(detect::Args),
    /// Fit the pixel-to-stage calibration from a recording of known tip moves.
    Calibrate(calibrate::Args),
    /// Make synthetic data: microscope frames or particle layouts.
    #[command(subcommand)]
    Synth(SynthCommand),
    /// Plan pushes that assemble a target pattern.
    Plan(plan::Args),
    /// Replay a plan geometrically and report collisions and errors.
    VerifyPlan(verify_plan::Args),
    /// Assemble a pattern on a rig (the simulated rig by default).
    Assemble(assemble::Args),
    /// Detect, track and plan on a recording, showing what would be commanded.
    DryRun(dry_run::Args),
    /// Hardware rig tools.
    #[command(subcommand)]
    Rig(RigCommand),
}

#[derive(Subcommand, Debug)]
enum StudyCommand {
    /// Pushing-model solver settings against error and time.
    Model(study_model::Args),
    /// Particle locators against error, the Cramer-Rao bound and time.
    Vision(study_vision::Args),
    /// Assignment and ordering methods against distance ratio and time.
    Plan(study_plan::Args),
    /// Many seeded closed-loop runs against the assembly acceptance figures.
    Assemble(study_assemble::Args),
}

#[derive(Subcommand, Debug)]
enum SynthCommand {
    /// Render a synthetic microscope frame with its ground truth.
    Frame(synth_frame::Args),
    /// Generate a synthetic particle layout.
    Layout(synth_layout::Args),
}

#[derive(Subcommand, Debug)]
enum RigCommand {
    /// Run a simulated PI GCS 2.0 controller on a TCP port.
    SimGcs(rig_sim_gcs::Args),
    /// Read-only: print identity, axes, ranges, positions and errors of a rig.
    Probe(rig_probe::Args),
    /// Measure the camera's pixel-to-stage calibration: move the tip over
    /// the view, record a frame at each stop, fit the map.
    Calibrate(rig_calibrate::Args),
}

/// Parses the command line, runs the command and maps errors to a non-zero exit.
pub fn main() -> ExitCode {
    end_quietly_on_closed_pipe();
    let cli = parse_command_line();
    show_warnings();
    let checking = matches!(cli.command, Command::VerifyPlan(_));
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", error_message::error_message(&err));
            if checking {
                ExitCode::from(verify_plan::exit_code(&err))
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// The command line, where a negative number is a value everywhere: `--seed
/// -1` is then refused as a seed ("invalid value '-1' for '--seed'"), not
/// as an unknown argument, and a flag that takes negative values needs no
/// mark of its own.
fn parse_command_line() -> Cli {
    fn negative_numbers_are_values(command: clap::Command) -> clap::Command {
        command
            .allow_negative_numbers(true)
            .mut_subcommands(negative_numbers_are_values)
    }
    let matches = negative_numbers_are_values(Cli::command()).get_matches();
    Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
}

/// `nanopush detect frame.png | head` ends the way `ls | head` does, not
/// with a panic and a backtrace: Rust ignores SIGPIPE, so the default is
/// put back. Safe for the rig: std's sockets write with MSG_NOSIGNAL, a
/// serial line raises no SIGPIPE, and the hardware commands print to
/// stdout only once the run and its journal are done.
fn end_quietly_on_closed_pipe() {
    use nix::sys::signal::{SigHandler, Signal, signal};
    // SAFETY: called first thing in main, before any other thread exists;
    // SIG_DFL installs no handler code.
    if let Err(e) = unsafe { signal(Signal::SIGPIPE, SigHandler::SigDfl) } {
        eprintln!("warning: SIGPIPE left ignored ({e})");
    }
}

/// Warnings (rig: skipped frame files, discarded frames, halts) and the
/// placement's progress through a field that refuses its best centres go
/// to stderr; `RUST_LOG` (e.g. `nanopush=debug`) shows more, such as the
/// planner's stage times.
fn show_warnings() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new("warn,nanopush::plan::placement=info")
    });
    // Colour codes only for a terminal, not in a log file.
    let _ = tracing_subscriber::fmt()
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_writer(std::io::stderr)
        .with_env_filter(filter)
        .try_init();
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Demo(a) => demo::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Study(StudyCommand::Model(a)) => study_model::run(a),
        Command::Study(StudyCommand::Vision(a)) => study_vision::run(a),
        Command::Study(StudyCommand::Plan(a)) => study_plan::run(a),
        Command::Study(StudyCommand::Assemble(a)) => study_assemble::run(a),
        Command::Detect(a) => detect::run(a),
        Command::Calibrate(a) => calibrate::run(a),
        Command::Synth(SynthCommand::Frame(a)) => synth_frame::run(a),
        Command::Synth(SynthCommand::Layout(a)) => synth_layout::run(a),
        Command::Plan(a) => plan::run(a),
        Command::VerifyPlan(a) => verify_plan::run(a),
        Command::Assemble(a) => assemble::run(a),
        Command::DryRun(a) => dry_run::run(a),
        Command::Rig(RigCommand::SimGcs(a)) => rig_sim_gcs::run(a),
        Command::Rig(RigCommand::Probe(a)) => rig_probe::run(a),
        Command::Rig(RigCommand::Calibrate(a)) => rig_calibrate::run(a),
    }
}
