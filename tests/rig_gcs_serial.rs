//! The GCS driver against the simulator over a pseudo-terminal pair, which
//! stands in for a serial port (same raw-tty code path as /dev/ttyUSB0).

mod rig_gcs_common;

use nanopush::rig::gcs::{GcsController, SerialLink, SimConfig, SimServer, Transport};
use rig_gcs_common::TIMEOUT;

fn connect() -> (SimServer, GcsController) {
    let mut sim = SimServer::new(SimConfig::default());
    let path = sim.serve_pty().unwrap();
    let link = SerialLink::open(&path, 115_200).unwrap();
    (
        sim,
        GcsController::new(Transport::new(Box::new(link), TIMEOUT)),
    )
}

#[test]
fn serial_moves_queries_and_typed_errors() {
    let (sim, mut ctrl) = connect();
    rig_gcs_common::moves_queries_and_errors(&mut ctrl, &sim);
}

#[test]
fn serial_reconnect_halts_the_stage() {
    let (sim, mut ctrl) = connect();
    rig_gcs_common::reconnect_halts(&mut ctrl, &sim);
}

#[test]
fn unsupported_baud_and_missing_tty_are_refused() {
    assert!(SerialLink::open("/dev/null", 12345).is_err());
    assert!(SerialLink::open("/nonexistent/tty", 115_200).is_err());
}
