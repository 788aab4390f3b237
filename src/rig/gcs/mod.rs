//! PI GCS 2.0 stage driver, controller simulator and host-side safety.
//!
//! Layers, bottom up: [`ByteLink`] (TCP, serial tty, dry-run recorder) ->
//! [`Transport`] (line framing, reply deadlines) -> [`GcsController`] (one
//! typed method per GCS command, controller units, `ERR?` after every setting
//! command) -> [`GcsStage`] (metres, soft limits and step limits checked before
//! sending, confirmation, halt on Ctrl-C / failure / drop). [`SimController`]
//! and [`SimServer`] stand in for hardware, which nanopush was not tested on.

pub mod confirmation;
pub mod controller;
pub mod controller_error;
pub mod dry_run_link;
pub mod error;
pub mod protocol;
pub mod rig_file;
pub mod safety;
pub mod serial_link;
pub mod sim_server;
pub mod sim_world;
pub mod simulator;
pub mod stage;
pub mod tcp_link;
pub mod transport;

pub use confirmation::FirstMoveConfirmation;
pub use controller::GcsController;
pub use controller_error::ControllerError;
pub use dry_run_link::{DryRunLink, SentLog};
pub use error::GcsError;
pub use rig_file::{
    CameraSource, CoarseSection, LinkKind, RigFile, RigFileError, StageDriver, StageSection,
};
pub use safety::{SafetyLimits, SafetyViolation, SoftLimit};
pub use serial_link::SerialLink;
pub use sim_server::{SimFault, SimHandle, SimServer};
pub use sim_world::{CoarseAxes, GcsSimWorld, TipAxes};
pub use simulator::{Motion, SimAxisConfig, SimConfig, SimController};
pub use stage::{GcsStage, StageSettings};
pub use tcp_link::TcpLink;
pub use transport::{ByteLink, Transport};

/// Opens the link a rig file names for its nanostage and returns a driver
/// on it. With `dry_run`, nothing is opened: the returned log receives every
/// byte that would have been sent, and an in-process simulator answers.
pub fn connect(rig: &RigFile, dry_run: bool) -> Result<(GcsController, Option<SentLog>), GcsError> {
    connect_section(&rig.stage, dry_run, SimConfig::default())
}

/// [`connect`] for the rig file's coarse stage (a dry run is answered by
/// [`SimConfig::coarse`]).
pub fn connect_coarse(
    coarse: &CoarseSection,
    dry_run: bool,
) -> Result<(GcsController, Option<SentLog>), GcsError> {
    connect_section(&coarse.stage, dry_run, SimConfig::coarse())
}

/// Opens the link of one controller section; `dry_run_sim` answers a dry run.
fn connect_section(
    section: &StageSection,
    dry_run: bool,
    dry_run_sim: SimConfig,
) -> Result<(GcsController, Option<SentLog>), GcsError> {
    let timeout = section.reply_timeout();
    let endpoint = section.address.clone();
    let io = |source| GcsError::Io {
        endpoint: endpoint.clone(),
        source,
    };
    let (link, log): (Box<dyn ByteLink>, Option<SentLog>) = if dry_run {
        let (link, log) = DryRunLink::new(dry_run_sim);
        (Box::new(link), Some(log))
    } else {
        match section.link {
            LinkKind::Tcp => (
                Box::new(TcpLink::connect(&section.address, timeout).map_err(io)?),
                None,
            ),
            LinkKind::Serial => (
                Box::new(SerialLink::open(&section.address, section.baud).map_err(io)?),
                None,
            ),
        }
    };
    Ok((GcsController::new(Transport::new(link, timeout)), log))
}

/// Opens the stage a rig file describes, behind all host-side checks: the
/// first move asks for confirmation on real hardware unless `dry_run` or
/// `waive_confirmation` (the explicit CLI flag); `interrupt` is the Ctrl-C
/// flag (see [`crate::rig::interrupt::ctrlc_flag`]).
pub fn open_stage(
    rig: &RigFile,
    dry_run: bool,
    waive_confirmation: bool,
    interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Result<(GcsStage, Option<SentLog>), GcsError> {
    open_section(
        &rig.stage,
        rig.stage_settings(),
        SimConfig::default(),
        dry_run,
        waive_confirmation,
        interrupt,
    )
}

/// [`open_stage`] for the rig file's coarse stage: the same checks under its
/// own limits, its own confirmation on real hardware, the same Ctrl-C flag.
pub fn open_coarse_stage(
    coarse: &CoarseSection,
    dry_run: bool,
    waive_confirmation: bool,
    interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Result<(GcsStage, Option<SentLog>), GcsError> {
    open_section(
        &coarse.stage,
        coarse.stage_settings(),
        SimConfig::coarse(),
        dry_run,
        waive_confirmation,
        interrupt,
    )
}

/// Opens one controller section as a checked stage under `settings`.
fn open_section(
    section: &StageSection,
    settings: StageSettings,
    dry_run_sim: SimConfig,
    dry_run: bool,
    waive_confirmation: bool,
    interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Result<(GcsStage, Option<SentLog>), GcsError> {
    let (controller, log) = connect_section(section, dry_run, dry_run_sim)?;
    let confirmation = FirstMoveConfirmation::for_rig(
        section.real_hardware,
        dry_run,
        waive_confirmation,
        std::sync::Arc::clone(&interrupt),
    );
    let stage = GcsStage::new(controller, settings, confirmation, interrupt)?;
    Ok((stage, log))
}
