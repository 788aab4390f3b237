//! A misbehaving controller: silence, garbage, partial lines, a dropped link
//! and random bytes all end in typed errors within the timeout, and the stage
//! is not left moving.

mod rig_gcs_common;

use nanopush::rig::gcs::{
    ByteLink, FirstMoveConfirmation, GcsController, GcsError, GcsStage, SafetyLimits, SimConfig,
    SimFault, SimServer, SoftLimit, StageSettings, TcpLink, Transport,
};
use proptest::prelude::*;
use rig_gcs_common::TIMEOUT;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

fn connect() -> (SimServer, GcsController) {
    let mut sim = SimServer::new(SimConfig::default());
    let addr = sim.serve_tcp("127.0.0.1:0").unwrap();
    let link = TcpLink::connect(&addr.to_string(), TIMEOUT).unwrap();
    (
        sim,
        GcsController::new(Transport::new(Box::new(link), TIMEOUT)),
    )
}

fn moving(sim: &SimServer) -> bool {
    sim.inspect(|c, now| c.any_moving(now))
}

#[test]
fn silent_controller_times_out_and_is_halted_on_reconnect() {
    let (sim, mut ctrl) = connect();
    ctrl.set_servo(&[("1", true)]).unwrap();
    ctrl.set_velocity(&[("1", 10.0)]).unwrap();
    ctrl.move_to(&[("1", 99.0)]).unwrap();
    sim.set_fault(SimFault::Mute);
    let started = Instant::now();
    let err = ctrl.positions(&["1"]).unwrap_err();
    assert!(matches!(err, GcsError::Timeout { .. }), "{err}");
    assert!(
        started.elapsed() < TIMEOUT * 4,
        "timeout took {:?}",
        started.elapsed()
    );
    assert!(
        moving(&sim),
        "the stage keeps moving while the controller is silent"
    );
    sim.set_fault(SimFault::None);
    ctrl.reconnect().unwrap();
    assert!(!moving(&sim), "reconnect did not halt the stage");
    assert!(ctrl.positions(&["1"]).unwrap()[0] < 99.0);
}

#[test]
fn garbage_reply_is_malformed_and_the_link_recovers() {
    let (sim, mut ctrl) = connect();
    sim.set_fault(SimFault::Garbage);
    let err = ctrl.positions(&["1"]).unwrap_err();
    assert!(matches!(err, GcsError::MalformedReply { .. }), "{err}");
    assert!(err.is_link_failure());
    let err = ctrl.last_error().unwrap_err();
    assert!(matches!(err, GcsError::MalformedReply { .. }), "{err}");
    sim.set_fault(SimFault::None);
    assert_eq!(ctrl.positions(&["1"]).unwrap(), vec![50.0]);
}

#[test]
fn partial_line_times_out_with_what_arrived() {
    let (sim, mut ctrl) = connect();
    sim.set_fault(SimFault::PartialLine);
    match ctrl.positions(&["2"]).unwrap_err() {
        GcsError::Timeout { partial, .. } => assert_eq!(partial, "2=50"),
        other => panic!("expected a timeout, got {other}"),
    }
    sim.set_fault(SimFault::None);
    assert_eq!(
        ctrl.positions(&["2"]).unwrap(),
        vec![50.0],
        "stale bytes were dropped"
    );
}

#[test]
fn closed_link_is_a_typed_io_error() {
    let (sim, mut ctrl) = connect();
    drop(sim);
    let started = Instant::now();
    let err = ctrl.identify().unwrap_err();
    assert!(
        matches!(err, GcsError::Io { .. } | GcsError::Timeout { .. }),
        "{err}"
    );
    assert!(started.elapsed() < TIMEOUT * 4);
    assert!(ctrl.reconnect().is_err(), "nobody listens any more");
}

fn stage(ctrl: GcsController) -> GcsStage {
    stage_settling_within(ctrl, Duration::from_secs(5))
}

/// [`stage`], waiting `settle_timeout` for its axes to be on target.
fn stage_settling_within(ctrl: GcsController, settle_timeout: Duration) -> GcsStage {
    let settings = StageSettings {
        axes: vec!["1".into(), "2".into()],
        unit_m: 1e-6,
        limits: SafetyLimits {
            soft_limits: vec![
                SoftLimit {
                    min_m: 1e-6,
                    max_m: 99e-6
                };
                2
            ],
            max_step_m: 50e-6,
            max_speed_m_per_s: 1e-3,
        },
        settle_timeout,
        poll_interval: Duration::from_millis(5),
    };
    GcsStage::new(
        ctrl,
        settings,
        FirstMoveConfirmation::NotNeeded,
        Arc::new(AtomicBool::new(false)),
    )
    .unwrap()
}

/// A move longer than the settle timeout allows, the controller answering
/// all along, is "not on target", naming the rig file's field, not a
/// controller that did not answer; the stage is halted.
#[test]
fn a_move_that_does_not_settle_in_time_is_told_from_a_silent_controller() {
    let (sim, ctrl) = connect();
    let mut stage = stage_settling_within(ctrl, Duration::from_millis(100));
    stage.enable_servo().unwrap();
    stage.set_speed_m_per_s(10e-6).unwrap();
    stage.start_move_m(&[90e-6, 50e-6]).unwrap();
    let err = stage.wait_settled().unwrap_err();
    assert!(matches!(err, GcsError::NotSettled { .. }), "{err}");
    assert!(
        err.to_string()
            .contains("not on target within 100ms (the rig file's settle_timeout_ms)"),
        "{err}"
    );
    assert!(!moving(&sim), "a failed wait must halt the stage");
}

#[test]
fn garbage_while_moving_leaves_the_stage_halted() {
    let (sim, ctrl) = connect();
    let mut stage = stage(ctrl);
    stage.enable_servo().unwrap();
    stage.set_speed_m_per_s(10e-6).unwrap();
    stage.start_move_m(&[90e-6, 50e-6]).unwrap();
    sim.set_fault(SimFault::Garbage);
    let err = stage.wait_settled().unwrap_err();
    assert!(matches!(err, GcsError::MalformedReply { .. }), "{err}");
    assert!(!moving(&sim), "a failed wait must halt the stage");
}

#[test]
fn silence_while_moving_then_recovery_leaves_the_stage_halted() {
    let (sim, ctrl) = connect();
    let mut stage = stage(ctrl);
    stage.enable_servo().unwrap();
    stage
        .controller()
        .set_velocity(&[("1", 10.0), ("2", 10.0)])
        .unwrap();
    stage.start_move_m(&[90e-6, 50e-6]).unwrap();
    sim.set_fault(SimFault::Mute);
    let err = stage.wait_settled().unwrap_err();
    assert!(matches!(err, GcsError::Timeout { .. }), "{err}");
    // The controller could not be reached to halt it; once it answers again,
    // dropping the stage (which still knows it may be moving) halts it.
    assert!(moving(&sim));
    sim.set_fault(SimFault::None);
    drop(stage);
    assert!(!moving(&sim), "drop did not halt the stage");
}

/// Replies with fixed bytes to whatever is sent.
struct ScriptedLink(Vec<u8>);

impl ByteLink for ScriptedLink {
    fn write_all(&mut self, _: &[u8]) -> std::io::Result<()> {
        Ok(())
    }
    fn read_some(&mut self, buf: &mut [u8], _: Duration) -> std::io::Result<Option<usize>> {
        if self.0.is_empty() {
            return Ok(None);
        }
        let n = buf.len().min(self.0.len()).min(7);
        buf[..n].copy_from_slice(&self.0[..n]);
        self.0.drain(..n);
        Ok(Some(n))
    }
    fn reopen(&mut self) -> std::io::Result<()> {
        Ok(())
    }
    fn endpoint(&self) -> String {
        "scripted".into()
    }
}

/// A link that never stops sending bytes without a line feed.
struct FloodLink;

impl ByteLink for FloodLink {
    fn write_all(&mut self, _: &[u8]) -> std::io::Result<()> {
        Ok(())
    }
    fn read_some(&mut self, buf: &mut [u8], _: Duration) -> std::io::Result<Option<usize>> {
        buf.fill(b'x');
        Ok(Some(buf.len()))
    }
    fn reopen(&mut self) -> std::io::Result<()> {
        Ok(())
    }
    fn endpoint(&self) -> String {
        "flood".into()
    }
}

#[test]
fn endless_input_is_an_error_not_a_hang() {
    let timeout = Duration::from_millis(50);
    let mut ctrl = GcsController::new(Transport::new(Box::new(FloodLink), timeout));
    let started = Instant::now();
    let err = ctrl.positions(&["1"]).unwrap_err();
    assert!(
        matches!(
            err,
            GcsError::MalformedReply { .. } | GcsError::Timeout { .. }
        ),
        "{err}"
    );
    // The next command first discards stale input, which must also give up.
    let err = ctrl.identify().unwrap_err();
    assert!(matches!(err, GcsError::MalformedReply { .. }), "{err}");
    assert!(
        started.elapsed() < Duration::from_secs(2),
        "took {:?}",
        started.elapsed()
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn random_reply_bytes_never_panic_or_hang(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let mut ctrl = GcsController::new(Transport::new(Box::new(ScriptedLink(bytes)), Duration::from_millis(10)));
        let started = Instant::now();
        let result = ctrl.positions(&["1", "2"]);
        prop_assert!(started.elapsed() < Duration::from_secs(1));
        if let Ok(values) = result {
            prop_assert_eq!(values.len(), 2);
            prop_assert!(values.iter().all(|v| v.is_finite()));
        }
        let _ = ctrl.motion_mask();
        let _ = ctrl.last_error();
    }
}
