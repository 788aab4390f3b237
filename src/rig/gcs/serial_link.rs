//! Serial (RS-232 / USB virtual COM) link, opened as a raw tty with termios.
//!
//! Opened directly through `nix` rather than the `serialport` crate so that no
//! system library (libudev) is needed; all a GCS link needs is raw 8N1 at a
//! fixed baud rate, and reads bounded by `poll`.

use super::transport::ByteLink;
use nix::fcntl::{OFlag, open};
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};
use nix::sys::stat::Mode;
use nix::sys::termios::{self, BaudRate, SetArg};
use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::AsFd;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// A raw serial tty (8 data bits, no parity, 1 stop bit, no flow control).
pub struct SerialLink {
    path: PathBuf,
    baud: u32,
    file: Option<File>,
}

/// Maps a baud rate in bits per second to the termios constant.
pub fn baud_rate(baud: u32) -> Option<BaudRate> {
    Some(match baud {
        9600 => BaudRate::B9600,
        19200 => BaudRate::B19200,
        38400 => BaudRate::B38400,
        57600 => BaudRate::B57600,
        115200 => BaudRate::B115200,
        230400 => BaudRate::B230400,
        460800 => BaudRate::B460800,
        921600 => BaudRate::B921600,
        _ => return None,
    })
}

fn to_io(e: nix::Error) -> std::io::Error {
    std::io::Error::from(e)
}

/// Puts a tty into raw mode at `baud` (used for both ends of a pty pair too).
pub fn make_raw(fd: impl AsFd, baud: Option<BaudRate>) -> std::io::Result<()> {
    let mut tio = termios::tcgetattr(fd.as_fd()).map_err(to_io)?;
    termios::cfmakeraw(&mut tio);
    tio.control_flags |= termios::ControlFlags::CLOCAL | termios::ControlFlags::CREAD;
    tio.control_flags &= !(termios::ControlFlags::CSTOPB | termios::ControlFlags::PARENB);
    if let Some(baud) = baud {
        termios::cfsetspeed(&mut tio, baud).map_err(to_io)?;
    }
    termios::tcsetattr(fd.as_fd(), SetArg::TCSANOW, &tio).map_err(to_io)
}

/// Waits until `fd` is readable (`POLLIN`) or writable, at most `timeout`.
pub fn wait_ready(fd: impl AsFd, flags: PollFlags, timeout: Duration) -> std::io::Result<bool> {
    let ms = u16::try_from(timeout.as_millis()).unwrap_or(u16::MAX);
    let mut fds = [PollFd::new(fd.as_fd(), flags)];
    match poll(&mut fds, PollTimeout::from(ms)) {
        Ok(n) => Ok(n > 0),
        Err(nix::Error::EINTR) => Ok(false),
        Err(e) => Err(to_io(e)),
    }
}

impl SerialLink {
    /// Opens `path` at `baud` bits per second.
    pub fn open(path: impl Into<PathBuf>, baud: u32) -> std::io::Result<Self> {
        if baud_rate(baud).is_none() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("unsupported baud rate {baud} (use 9600 .. 921600)"),
            ));
        }
        let mut link = Self {
            path: path.into(),
            baud,
            file: None,
        };
        link.reopen()?;
        Ok(link)
    }

    fn file(&mut self) -> std::io::Result<&mut File> {
        self.file
            .as_mut()
            .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotConnected, "tty not open"))
    }
}

impl ByteLink for SerialLink {
    fn write_all(&mut self, mut bytes: &[u8]) -> std::io::Result<()> {
        let deadline = Instant::now() + Duration::from_secs(2);
        let file = self.file()?;
        while !bytes.is_empty() {
            match file.write(bytes) {
                Ok(n) => bytes = &bytes[n..],
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        return Err(std::io::Error::new(
                            std::io::ErrorKind::TimedOut,
                            "tty write timed out",
                        ));
                    }
                    wait_ready(&*file, PollFlags::POLLOUT, left)?;
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    fn read_some(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<Option<usize>> {
        let file = self.file()?;
        if !wait_ready(&*file, PollFlags::POLLIN, timeout)? {
            return Ok(None);
        }
        match file.read(buf) {
            Ok(n) => Ok(Some(n)),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::Interrupted
                ) =>
            {
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }

    fn reopen(&mut self) -> std::io::Result<()> {
        self.file = None;
        let fd = open(
            &self.path,
            OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_NONBLOCK | OFlag::O_CLOEXEC,
            Mode::empty(),
        )
        .map_err(to_io)?;
        make_raw(&fd, baud_rate(self.baud))?;
        self.file = Some(File::from(fd));
        Ok(())
    }

    fn endpoint(&self) -> String {
        format!("serial {} @ {} baud", self.path.display(), self.baud)
    }
}
