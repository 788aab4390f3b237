//! The GCS driver against the simulator over loopback TCP.

mod rig_gcs_common;

use nanopush::rig::gcs::{GcsController, SimConfig, SimServer, TcpLink, Transport};
use rig_gcs_common::TIMEOUT;

fn connect() -> (SimServer, GcsController) {
    let mut sim = SimServer::new(SimConfig::default());
    let addr = sim.serve_tcp("127.0.0.1:0").unwrap();
    let link = TcpLink::connect(&addr.to_string(), TIMEOUT).unwrap();
    (
        sim,
        GcsController::new(Transport::new(Box::new(link), TIMEOUT)),
    )
}

#[test]
fn tcp_moves_queries_and_typed_errors() {
    let (sim, mut ctrl) = connect();
    rig_gcs_common::moves_queries_and_errors(&mut ctrl, &sim);
}

#[test]
fn tcp_reconnect_halts_the_stage() {
    let (sim, mut ctrl) = connect();
    rig_gcs_common::reconnect_halts(&mut ctrl, &sim);
}

#[test]
fn tcp_connection_refused_is_a_typed_io_error() {
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let err = TcpLink::connect(&format!("127.0.0.1:{port}"), TIMEOUT);
    assert!(err.is_err());
}
