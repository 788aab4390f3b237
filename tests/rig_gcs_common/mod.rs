//! Scenarios shared by the TCP and serial (pty) tests of the GCS driver.
// Each test binary that includes this module uses only part of it.
#![allow(dead_code)]

use nanopush::rig::gcs::{ControllerError, GcsController, GcsError, SimServer};
use std::time::{Duration, Instant};

/// Reply timeout used by the tests: long enough for a loaded CI machine,
/// short enough that the timeout tests finish quickly.
pub const TIMEOUT: Duration = Duration::from_millis(500);

/// Polls `ONT?` until every axis is on target (at most 5 s).
pub fn wait_on_target(ctrl: &mut GcsController, axes: &[&str]) {
    let deadline = Instant::now() + Duration::from_secs(5);
    while !ctrl.on_target(axes).unwrap().iter().all(|&b| b) {
        assert!(Instant::now() < deadline, "axes {axes:?} never settled");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Identity, axes, servo, absolute and relative moves, queries, and the
/// errors 5, 7, 10 and 15 as typed errors.
pub fn moves_queries_and_errors(ctrl: &mut GcsController, sim: &SimServer) {
    assert!(ctrl.identify().unwrap().contains("GCS simulator"));
    assert_eq!(ctrl.syntax_version().unwrap(), 2.0);
    assert!(ctrl.is_ready().unwrap());
    assert_eq!(ctrl.axes().unwrap(), vec!["1", "2", "3"]);
    assert_eq!(ctrl.travel_max(&["1", "3"]).unwrap(), vec![100.0, 15.0]);
    assert_eq!(ctrl.travel_min(&["2"]).unwrap(), vec![0.0]);

    let err = ctrl.move_to(&[("1", 10.0)]).unwrap_err();
    assert_eq!(
        err.controller_error(),
        Some(ControllerError::ServoOff),
        "{err}"
    );

    ctrl.set_servo(&[("1", true), ("2", true)]).unwrap();
    assert_eq!(
        ctrl.servo(&["1", "2", "3"]).unwrap(),
        vec![true, true, false]
    );
    // Axis 1 slow (1 s for 20 um) so that "moving" is seen even on a loaded machine.
    ctrl.set_velocity(&[("1", 20.0)]).unwrap();
    assert_eq!(ctrl.velocity(&["1"]).unwrap(), vec![20.0]);

    ctrl.move_to(&[("1", 70.0), ("2", 40.0)]).unwrap();
    assert_eq!(
        ctrl.motion_mask().unwrap() & 0b1,
        0b1,
        "#5 bit set while moving"
    );
    assert_eq!(ctrl.on_target(&["1"]).unwrap(), vec![false]);
    assert_eq!(ctrl.targets(&["1", "2"]).unwrap(), vec![70.0, 40.0]);
    wait_on_target(ctrl, &["1", "2"]);
    assert_eq!(ctrl.positions(&["1", "2"]).unwrap(), vec![70.0, 40.0]);
    assert_eq!(ctrl.motion_mask().unwrap(), 0);

    ctrl.move_by(&[("2", -5.5)]).unwrap();
    wait_on_target(ctrl, &["2"]);
    assert_eq!(ctrl.positions(&["2"]).unwrap(), vec![34.5]);

    let err = ctrl.move_to(&[("1", 100.5)]).unwrap_err();
    assert_eq!(
        err.controller_error(),
        Some(ControllerError::PositionOutOfLimits),
        "{err}"
    );
    let err = ctrl.move_to(&[("7", 1.0)]).unwrap_err();
    assert_eq!(
        err.controller_error(),
        Some(ControllerError::InvalidAxis),
        "{err}"
    );
    let err = ctrl.set_velocity(&[("1", 1e9)]).unwrap_err();
    assert_eq!(
        err.controller_error(),
        Some(ControllerError::VelocityOutOfLimits),
        "{err}"
    );
    let err = ctrl.set_raw(b"XYZ 1\n").unwrap_err();
    assert_eq!(
        err.controller_error(),
        Some(ControllerError::UnknownCommand),
        "{err}"
    );

    // STP mid-move: motion stops, error 10 surfaces typed through set_raw,
    // while stop_all() treats it as the expected outcome.
    ctrl.move_to(&[("1", 10.0)]).unwrap();
    std::thread::sleep(Duration::from_millis(30));
    let err = ctrl.set_raw(b"STP\n").unwrap_err();
    assert!(
        matches!(
            err,
            GcsError::Controller {
                error: ControllerError::StoppedByCommand,
                ..
            }
        ),
        "{err}"
    );
    assert!(
        !sim.inspect(|c, now| c.any_moving(now)),
        "STP left the stage moving"
    );
    let stopped_at = ctrl.positions(&["1"]).unwrap()[0];
    assert!(
        stopped_at > 10.0 && stopped_at < 70.0,
        "stopped mid-way, at {stopped_at}"
    );
    ctrl.move_to(&[("1", 60.0)]).unwrap();
    ctrl.stop_all().unwrap();
    assert_eq!(ctrl.last_error().unwrap(), None);
}

/// After the link is dropped and reopened the controller answers again and
/// every axis has been halted.
pub fn reconnect_halts(ctrl: &mut GcsController, sim: &SimServer) {
    ctrl.set_servo(&[("1", true)]).unwrap();
    ctrl.set_velocity(&[("1", 10.0)]).unwrap();
    let here = ctrl.positions(&["1"]).unwrap()[0];
    let far = if here < 50.0 { 95.0 } else { 5.0 };
    ctrl.move_to(&[("1", far)]).unwrap();
    ctrl.reconnect().unwrap();
    assert!(
        !sim.inspect(|c, now| c.any_moving(now)),
        "reconnect did not halt the stage"
    );
    assert_eq!(
        ctrl.last_error().unwrap(),
        None,
        "halt's error 10 was read away"
    );
    assert_ne!(ctrl.positions(&["1"]).unwrap()[0], far);
}
