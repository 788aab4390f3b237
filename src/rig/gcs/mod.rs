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

pub use confirmation::{FirstMoveConfirmation, OperatorWait};
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

/// Opens the stage a rig file describes, behind all host-side checks:
/// [`connect`], then [`stage_on`].
pub fn open_stage(
    rig: &RigFile,
    dry_run: bool,
    waive_confirmation: bool,
    interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Result<(GcsStage, Option<SentLog>), GcsError> {
    let (controller, log) = connect(rig, dry_run)?;
    let opening = StageOpening {
        dry_run,
        waive_confirmation,
        interrupt,
        operator_wait: OperatorWait::default(),
    };
    let stage = stage_on(controller, &rig.stage, rig.stage_settings(), &opening)?;
    Ok((stage, log))
}

/// How a stage is opened: what [`stage_on`] needs besides the controller
/// and the rig file's section (both stages of a rig are opened alike).
#[derive(Clone)]
pub struct StageOpening {
    /// A dry run: no confirmation is asked (nothing real moves).
    pub dry_run: bool,
    /// The explicit CLI flag that waives the confirmation before the
    /// first move on real hardware.
    pub waive_confirmation: bool,
    /// The Ctrl-C flag (see [`crate::rig::interrupt::ctrlc_flag`]).
    pub interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>,
    /// Where the stages add the time their confirmation waited.
    pub operator_wait: OperatorWait,
}

/// A controller section of the rig file (its `[stage]`, or its coarse
/// stage's) on a connected `controller`, as a stage behind all host-side
/// checks under `settings`: its axes on the controller (its soft limits
/// within their travel are checked by the line stage over it); the first
/// move asks for confirmation on real hardware unless `opening` is a dry
/// run or waives it. Apart from [`connect`], so that `rig probe` checks
/// the controller it has just queried as `assemble` checks it.
pub fn stage_on(
    controller: GcsController,
    section: &StageSection,
    settings: StageSettings,
    opening: &StageOpening,
) -> Result<GcsStage, GcsError> {
    let interrupt = std::sync::Arc::clone(&opening.interrupt);
    let confirmation = FirstMoveConfirmation::for_rig(
        section.real_hardware,
        opening.dry_run,
        opening.waive_confirmation,
        std::sync::Arc::clone(&interrupt),
        opening.operator_wait.clone(),
    );
    GcsStage::new(controller, settings, confirmation, interrupt)
}
