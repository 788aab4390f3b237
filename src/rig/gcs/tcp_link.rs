//! TCP link to a controller (PI controllers listen on port 50000).

use super::transport::ByteLink;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::Duration;

/// A TCP connection that can be reopened to the same address.
pub struct TcpLink {
    addr: SocketAddr,
    connect_timeout: Duration,
    stream: Option<TcpStream>,
}

impl TcpLink {
    /// Resolves `address` (`host:port`) and connects within `connect_timeout`.
    pub fn connect(address: &str, connect_timeout: Duration) -> std::io::Result<Self> {
        if !address.contains(':') {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "address {address:?} has no port: write host:port (a PI controller listens on port 50000: \"{address}:50000\")"
                ),
            ));
        }
        let addr = address.to_socket_addrs()?.next().ok_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{address} resolves to nothing"),
            )
        })?;
        let mut link = Self {
            addr,
            connect_timeout,
            stream: None,
        };
        link.reopen()?;
        Ok(link)
    }

    fn stream(&mut self) -> std::io::Result<&mut TcpStream> {
        self.stream
            .as_mut()
            .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotConnected, "not connected"))
    }
}

impl ByteLink for TcpLink {
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let stream = self.stream()?;
        stream.write_all(bytes)?;
        stream.flush()
    }

    fn read_some(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<Option<usize>> {
        let stream = self.stream()?;
        // A zero timeout means "block forever" to std: never pass it.
        stream.set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        match stream.read(buf) {
            Ok(n) => Ok(Some(n)),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                Ok(None)
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => Ok(None),
            Err(e) => Err(e),
        }
    }

    fn reopen(&mut self) -> std::io::Result<()> {
        if let Some(old) = self.stream.take() {
            let _ = old.shutdown(std::net::Shutdown::Both);
        }
        let stream = TcpStream::connect_timeout(&self.addr, self.connect_timeout)?;
        stream.set_nodelay(true)?;
        stream.set_write_timeout(Some(self.connect_timeout.max(Duration::from_millis(1))))?;
        self.stream = Some(stream);
        Ok(())
    }

    fn endpoint(&self) -> String {
        format!("tcp {}", self.addr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An address without its port says so, with PI's port to add (it
    /// had read "invalid socket address").
    #[test]
    fn an_address_without_a_port_says_what_to_write() {
        let err = TcpLink::connect("127.0.0.1", Duration::from_millis(100))
            .err()
            .unwrap();
        assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
        assert!(
            err.to_string().contains("write host:port")
                && err.to_string().contains("127.0.0.1:50000"),
            "{err}"
        );
    }
}
