//! Serves a [`SimController`] over TCP (any number of clients) and over a
//! pseudo-terminal (standing in for a serial port), with injectable faults so
//! that tests can make the controller hang or talk garbage.

use super::protocol;
use super::serial_link::{make_raw, wait_ready};
use super::simulator::{SimConfig, SimController};
use nix::poll::PollFlags;
use std::fs::File;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::fd::OwnedFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A misbehaviour the served controller can be told to show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SimFault {
    /// Behaves like a controller.
    #[default]
    None,
    /// Reads and drops every byte and answers nothing (a hung controller;
    /// axes already moving keep moving).
    Mute,
    /// Executes commands but answers each query with a line of garbage bytes.
    Garbage,
    /// Executes commands but sends each reply without its final line feed.
    PartialLine,
}

struct Shared {
    controller: Mutex<SimController>,
    fault: Mutex<SimFault>,
    shutdown: AtomicBool,
}

/// A running simulated controller; dropping it stops every server thread.
pub struct SimServer {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    tcp_addr: Option<SocketAddr>,
    pty_path: Option<PathBuf>,
}

/// How often server threads look at the shutdown flag.
const POLL: Duration = Duration::from_millis(20);

pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panicked client thread must not take the simulator down with it.
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

impl SimServer {
    /// A simulator with no listeners yet; add them with
    /// [`SimServer::serve_tcp`] and [`SimServer::serve_pty`].
    pub fn new(config: SimConfig) -> Self {
        Self {
            shared: Arc::new(Shared {
                controller: Mutex::new(SimController::new(config, Instant::now())),
                fault: Mutex::new(SimFault::None),
                shutdown: AtomicBool::new(false),
            }),
            threads: Vec::new(),
            tcp_addr: None,
            pty_path: None,
        }
    }

    /// Listens on `addr` (`127.0.0.1:0` picks a free port); returns the bound
    /// address.
    pub fn serve_tcp(&mut self, addr: &str) -> std::io::Result<SocketAddr> {
        let listener = TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        let bound = listener.local_addr()?;
        let shared = Arc::clone(&self.shared);
        self.threads
            .push(std::thread::spawn(move || accept_loop(listener, shared)));
        self.tcp_addr = Some(bound);
        Ok(bound)
    }

    /// Opens a pseudo-terminal pair and serves the controller on its master
    /// side; returns the path of the slave tty for a client to open.
    pub fn serve_pty(&mut self) -> std::io::Result<PathBuf> {
        let pty = nix::pty::openpty(None, None).map_err(std::io::Error::from)?;
        make_raw(&pty.slave, None)?;
        let path = nix::unistd::ttyname(&pty.slave).map_err(std::io::Error::from)?;
        let shared = Arc::clone(&self.shared);
        let (master, slave) = (pty.master, pty.slave);
        self.threads
            .push(std::thread::spawn(move || pty_loop(master, slave, shared)));
        self.pty_path = Some(path.clone());
        Ok(path)
    }

    /// The bound TCP address, if serving TCP.
    pub fn tcp_addr(&self) -> Option<SocketAddr> {
        self.tcp_addr
    }

    /// The slave tty path, if serving a pty.
    pub fn pty_path(&self) -> Option<&PathBuf> {
        self.pty_path.as_ref()
    }

    /// Makes the controller misbehave (or behave again with [`SimFault::None`]).
    pub fn set_fault(&self, fault: SimFault) {
        *lock(&self.shared.fault) = fault;
    }

    /// Runs `f` on the controller state (for tests: positions, motion, errors).
    pub fn inspect<R>(&self, f: impl FnOnce(&SimController, Instant) -> R) -> R {
        f(&lock(&self.shared.controller), Instant::now())
    }

    /// A handle on the controller that other threads can keep: the simulated
    /// microscope reads the motions through it.
    pub fn handle(&self) -> SimHandle {
        SimHandle {
            shared: Arc::clone(&self.shared),
        }
    }

    /// Blocks until `stop` becomes true (for the `sim-gcs` command).
    pub fn run_until(&self, stop: &AtomicBool) {
        while !stop.load(Ordering::SeqCst) {
            std::thread::sleep(POLL);
        }
    }
}

/// Shared access to a served controller (see [`SimServer::handle`]); it does
/// not keep the server threads alive.
#[derive(Clone)]
pub struct SimHandle {
    shared: Arc<Shared>,
}

impl SimHandle {
    /// Runs `f` on the controller, at the current instant.
    pub fn with<R>(&self, f: impl FnOnce(&mut SimController, Instant) -> R) -> R {
        f(&mut lock(&self.shared.controller), Instant::now())
    }
}

impl Drop for SimServer {
    fn drop(&mut self) {
        self.shared.shutdown.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// Turns incoming bytes into replies for one client, applying the fault.
struct Session {
    shared: Arc<Shared>,
    line: Vec<u8>,
}

impl Session {
    fn feed(&mut self, bytes: &[u8]) -> Vec<u8> {
        let fault = *lock(&self.shared.fault);
        if fault == SimFault::Mute {
            self.line.clear();
            return Vec::new();
        }
        let replies = lock(&self.shared.controller).feed(&mut self.line, bytes, Instant::now());
        let mut out = Vec::new();
        for reply in replies {
            match fault {
                SimFault::Garbage => out.extend_from_slice(b"\x00\xfe%#garbage=\x07\n"),
                SimFault::PartialLine => {
                    let mut bytes = protocol::encode_reply(&reply);
                    bytes.pop();
                    out.extend(bytes);
                }
                _ => out.extend(protocol::encode_reply(&reply)),
            }
        }
        out
    }
}

fn accept_loop(listener: TcpListener, shared: Arc<Shared>) {
    let mut clients = Vec::new();
    while !shared.shutdown.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((stream, _)) => {
                let shared = Arc::clone(&shared);
                clients.push(std::thread::spawn(move || tcp_client(stream, shared)));
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => std::thread::sleep(POLL),
            Err(e) => {
                tracing::warn!("sim-gcs: accept failed: {e}");
                std::thread::sleep(POLL);
            }
        }
    }
    for c in clients {
        let _ = c.join();
    }
}

fn tcp_client(mut stream: TcpStream, shared: Arc<Shared>) {
    if stream.set_read_timeout(Some(POLL)).is_err() {
        return;
    }
    let _ = stream.set_nodelay(true);
    let mut session = Session {
        shared: Arc::clone(&shared),
        line: Vec::new(),
    };
    let mut buf = [0u8; 1024];
    while !shared.shutdown.load(Ordering::SeqCst) {
        match stream.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => {
                let out = session.feed(&buf[..n]);
                if !out.is_empty() && stream.write_all(&out).is_err() {
                    return;
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) => {}
            Err(_) => return,
        }
    }
}

fn pty_loop(master: OwnedFd, slave: OwnedFd, shared: Arc<Shared>) {
    // The slave end stays open here so the master does not see a hang-up
    // between one client closing the tty and the next opening it.
    let _keep_open = slave;
    let mut file = File::from(master);
    let mut session = Session {
        shared: Arc::clone(&shared),
        line: Vec::new(),
    };
    let mut buf = [0u8; 1024];
    while !shared.shutdown.load(Ordering::SeqCst) {
        match wait_ready(&file, PollFlags::POLLIN, POLL) {
            Ok(true) => {}
            Ok(false) => continue,
            Err(_) => return,
        }
        match file.read(&mut buf) {
            Ok(0) => std::thread::sleep(POLL),
            Ok(n) => {
                let out = session.feed(&buf[..n]);
                if !out.is_empty() && file.write_all(&out).is_err() {
                    return;
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => std::thread::sleep(POLL),
        }
    }
}
