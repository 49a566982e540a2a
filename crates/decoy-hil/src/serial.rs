//! The UART's host end: a TCP listener QEMU connects to as a client
//! (`-serial tcp:127.0.0.1:PORT,nodelay=on`, docs/toolchain.md §4).
//!
//! The listener binds port 0, so the system picks a free port and tests running in
//! parallel never collide. It is bound before QEMU starts; accepting waits with a
//! deadline and gives up early if QEMU exits.

use std::fmt;
use std::io;
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::thread;
use std::time::{Duration, Instant};

use crate::qemu::Supervised;

/// Pause between polls of the listener.
const ACCEPT_POLL: Duration = Duration::from_millis(2);

/// Why QEMU's UART connection did not arrive.
#[derive(Debug)]
pub enum AcceptError {
    /// The listener failed.
    Io(io::Error),
    /// Nothing connected within the time limit.
    TimedOut(Duration),
    /// QEMU exited before it connected (its output tells why).
    QemuExited,
}

impl fmt::Display for AcceptError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AcceptError::Io(e) => write!(f, "the UART listener failed: {e}"),
            AcceptError::TimedOut(t) => {
                write!(f, "QEMU did not connect to the UART listener within {t:?}")
            }
            AcceptError::QemuExited => f.write_str("QEMU exited before connecting its UART"),
        }
    }
}

impl std::error::Error for AcceptError {}

/// A bound, not yet connected, UART listener on 127.0.0.1.
#[derive(Debug)]
pub struct SerialListener {
    listener: TcpListener,
    address: SocketAddr,
}

impl SerialListener {
    /// Binds 127.0.0.1 on a port the system chooses.
    pub fn bind() -> io::Result<Self> {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?;
        let address = listener.local_addr()?;
        Ok(SerialListener { listener, address })
    }

    /// The port it listens on.
    pub fn port(&self) -> u16 {
        self.address.port()
    }

    /// QEMU's `-serial` value for this listener (`tcp:127.0.0.1:PORT,nodelay=on`;
    /// without `nodelay` the throughput drops about 25 times).
    pub fn qemu_serial(&self) -> String {
        format!("tcp:127.0.0.1:{},nodelay=on", self.port())
    }

    /// Waits up to `timeout` for one connection; with `qemu`, gives up as soon as
    /// that process exits. The stream is blocking, with `TCP_NODELAY` set.
    pub fn accept(
        self,
        timeout: Duration,
        mut qemu: Option<&mut Supervised>,
    ) -> Result<TcpStream, AcceptError> {
        let fail = AcceptError::Io;
        self.listener.set_nonblocking(true).map_err(fail)?;
        let deadline = Instant::now() + timeout;
        loop {
            match self.listener.accept() {
                Ok((stream, _)) => {
                    stream.set_nonblocking(false).map_err(fail)?;
                    stream.set_nodelay(true).map_err(fail)?;
                    return Ok(stream);
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                Err(e) => return Err(fail(e)),
            }
            if let Some(child) = qemu.as_deref_mut()
                && !child.is_running()
            {
                return Err(AcceptError::QemuExited);
            }
            if Instant::now() >= deadline {
                return Err(AcceptError::TimedOut(timeout));
            }
            thread::sleep(ACCEPT_POLL);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    #[test]
    fn ports_are_ephemeral_and_distinct() {
        let a = SerialListener::bind().unwrap();
        let b = SerialListener::bind().unwrap();
        assert_ne!(a.port(), 0);
        assert_ne!(a.port(), b.port());
        assert_eq!(
            a.qemu_serial(),
            format!("tcp:127.0.0.1:{},nodelay=on", a.port())
        );
    }

    #[test]
    fn accepts_a_client() {
        let listener = SerialListener::bind().unwrap();
        let port = listener.port();
        let client = thread::spawn(move || {
            let mut s = TcpStream::connect((Ipv4Addr::LOCALHOST, port)).unwrap();
            s.write_all(b"hello").unwrap();
        });
        let mut stream = listener.accept(Duration::from_secs(10), None).unwrap();
        let mut buf = Vec::new();
        stream.read_to_end(&mut buf).unwrap();
        client.join().unwrap();
        assert_eq!(buf, b"hello");
    }

    #[test]
    fn accept_times_out() {
        let listener = SerialListener::bind().unwrap();
        let started = Instant::now();
        let err = listener
            .accept(Duration::from_millis(100), None)
            .unwrap_err();
        assert!(matches!(err, AcceptError::TimedOut(_)), "{err}");
        assert!(started.elapsed() < Duration::from_secs(5));
    }

    #[test]
    fn accept_gives_up_when_the_process_exits() {
        let listener = SerialListener::bind().unwrap();
        let mut child = Supervised::spawn(
            std::process::Command::new("sh").args(["-c", "exit 3"]),
            Duration::from_secs(10),
            "",
        )
        .unwrap();
        let started = Instant::now();
        let err = listener
            .accept(Duration::from_secs(30), Some(&mut child))
            .unwrap_err();
        assert!(matches!(err, AcceptError::QemuExited), "{err}");
        assert!(started.elapsed() < Duration::from_secs(10));
    }
}
