//! `nanopush rig sim-gcs`: a simulated PI GCS 2.0 controller (3 axes,
//! 100 x 100 x 15 um) on a TCP port and optionally a pseudo-terminal, for
//! rehearsing without hardware and for checking clients such as PIPython.

use crate::rig::gcs::{SimAxisConfig, SimConfig, SimServer, interrupt};
use anyhow::Context;
use std::io::Write;
use std::sync::atomic::Ordering;

/// Arguments of `nanopush rig sim-gcs`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// TCP port to listen on (PI controllers use 50000; 0 picks a free one).
    #[arg(long, default_value_t = 50000)]
    pub port: u16,
    /// Address to bind; keep the loopback default unless you mean to expose it.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Also serve on a pseudo-terminal (stands in for a serial port) and print its path.
    #[arg(long)]
    pub pty: bool,
    /// Closed-loop velocity of every axis at start-up, micrometres per second.
    #[arg(long, default_value_t = 100.0)]
    pub velocity_um_s: f64,
}

/// Serves the simulator until Ctrl-C.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.velocity_um_s.is_finite() && args.velocity_um_s > 0.0,
        "--velocity-um-s must be positive, got {}",
        args.velocity_um_s
    );
    let mut config = SimConfig::default();
    config
        .axes
        .iter_mut()
        .for_each(|a: &mut SimAxisConfig| a.velocity = args.velocity_um_s);
    let stop = interrupt::ctrlc_flag().context("installing the Ctrl-C handler")?;
    let mut server = SimServer::new(config);
    let addr = server
        .serve_tcp(&format!("{}:{}", args.host, args.port))
        .with_context(|| format!("binding {}:{}", args.host, args.port))?;
    let mut out = std::io::stdout();
    writeln!(out, "GCS simulator listening on tcp {addr}")?;
    if args.pty {
        let path = server.serve_pty().context("opening a pseudo-terminal")?;
        writeln!(out, "GCS simulator serving on pty {}", path.display())?;
    }
    eprintln!("press Ctrl-C to stop");
    out.flush()?;
    server.run_until(&stop);
    stop.store(false, Ordering::SeqCst);
    Ok(())
}
