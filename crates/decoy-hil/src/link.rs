//! The host end of the decoy link over QEMU's UART: [`Link`] sends
//! [`HostMessage`]s and reads [`DeviceMessage`]s with `decoy_link`'s framing, every
//! read with a deadline; [`Session`] is one firmware run under QEMU with its link,
//! QEMU killed when the session ends or is dropped.

use std::collections::VecDeque;
use std::fmt;
use std::io::{self, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use decoy_link::{DeviceMessage, FrameError, HostMessage};

use crate::defmt;
use crate::qemu::{Board, Captured, Qemu, RunError, Supervised};
use crate::serial::{AcceptError, SerialListener};

/// Room of the host's frame decoder (the protocol's largest frame).
pub const DECODER_CAPACITY: usize = decoy_link::MAX_FRAME_BYTES;

/// Default deadline of one answer. A control step takes well under a millisecond of
/// virtual time and QEMU passes a frame in a few milliseconds: a second means the
/// firmware is stuck.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(5);
/// Deadline of QEMU's connection to the UART listener.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(30);
/// Deadline of the boot `Hello` (the firmware trims nothing before it).
pub const HELLO_TIMEOUT: Duration = Duration::from_secs(30);
/// Default life time of one QEMU run.
pub const SESSION_TIMEOUT: Duration = Duration::from_secs(600);

/// Why talking to the firmware failed.
#[derive(Debug)]
pub enum LinkError {
    /// QEMU could not be started.
    Qemu(RunError),
    /// QEMU did not connect its UART.
    Accept(AcceptError),
    /// Reading or writing the socket failed.
    Io(io::Error),
    /// A message could not be encoded.
    Encode(String),
    /// Nothing (or nothing complete) arrived in time.
    TimedOut {
        /// What was awaited.
        awaited: &'static str,
        /// How long.
        timeout: Duration,
    },
    /// The firmware closed the link (QEMU exited).
    Closed,
    /// The firmware sent a frame the host cannot decode.
    Frame(FrameError),
    /// The firmware did not boot into the protocol (no `Hello`).
    Boot {
        /// What went wrong.
        cause: Box<LinkError>,
        /// QEMU's status, stderr and the decoded firmware log.
        output: String,
    },
    /// The firmware answered something else than expected.
    Unexpected {
        /// What was expected.
        expected: &'static str,
        /// What came.
        got: Box<DeviceMessage>,
    },
}

impl fmt::Display for LinkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkError::Qemu(e) => write!(f, "starting QEMU: {e}"),
            LinkError::Accept(e) => write!(f, "{e}"),
            LinkError::Io(e) => write!(f, "the UART link failed: {e}"),
            LinkError::Encode(e) => write!(f, "cannot encode the message: {e}"),
            LinkError::TimedOut { awaited, timeout } => {
                write!(f, "no {awaited} from the firmware within {timeout:?}")
            }
            LinkError::Closed => f.write_str("the firmware closed the link (QEMU exited?)"),
            LinkError::Frame(e) => write!(f, "the firmware sent a bad frame: {e:?}"),
            LinkError::Boot { cause, output } => {
                write!(
                    f,
                    "the firmware did not boot into the link: {cause}\n{output}"
                )
            }
            LinkError::Unexpected { expected, got } => {
                write!(f, "expected {expected} from the firmware, got {got:?}")
            }
        }
    }
}

impl std::error::Error for LinkError {}

impl From<io::Error> for LinkError {
    fn from(e: io::Error) -> Self {
        LinkError::Io(e)
    }
}

/// The host end of the link: a connected stream, the frame decoder, and every byte
/// received (for the determinism check).
pub struct Link {
    stream: TcpStream,
    decoder: decoy_link::Decoder<DECODER_CAPACITY>,
    pending: VecDeque<Result<DeviceMessage, FrameError>>,
    received: Vec<u8>,
    sent_bytes: u64,
    timeout: Duration,
}

impl Link {
    /// Wraps a connected stream; reads time out after [`ANSWER_TIMEOUT`].
    pub fn new(stream: TcpStream) -> Self {
        Link {
            stream,
            decoder: decoy_link::Decoder::new(),
            pending: VecDeque::new(),
            received: Vec::new(),
            sent_bytes: 0,
            timeout: ANSWER_TIMEOUT,
        }
    }

    /// Sets the deadline of each [`Link::recv`].
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// The deadline of each [`Link::recv`].
    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    /// Every byte received so far, frames and delimiters as they came.
    pub fn received(&self) -> &[u8] {
        &self.received
    }

    /// Bytes sent so far.
    pub fn sent_bytes(&self) -> u64 {
        self.sent_bytes
    }

    /// Encodes and sends `message` as one wire frame.
    pub fn send(&mut self, message: &HostMessage) -> Result<(), LinkError> {
        let frame = encode(message)?;
        self.send_raw(&frame)
    }

    /// Sends bytes as they are (for corrupted frames and garbage).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.stream.write_all(bytes)?;
        self.stream.flush()?;
        self.sent_bytes += bytes.len() as u64;
        Ok(())
    }

    /// The next message, waiting at most the link's timeout. A frame the host cannot
    /// decode is [`LinkError::Frame`].
    pub fn recv(&mut self) -> Result<DeviceMessage, LinkError> {
        self.recv_within(self.timeout, "answer")
    }

    /// The next message within `timeout`.
    pub fn recv_within(
        &mut self,
        timeout: Duration,
        awaited: &'static str,
    ) -> Result<DeviceMessage, LinkError> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(next) = self.pending.pop_front() {
                return next.map_err(LinkError::Frame);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(LinkError::TimedOut { awaited, timeout });
            }
            if !self.fill(left)? {
                return Err(LinkError::TimedOut { awaited, timeout });
            }
        }
    }

    /// Whether a message arrives within `within` (it is kept for [`Link::recv`]).
    pub fn poll(&mut self, within: Duration) -> Result<bool, LinkError> {
        if !self.pending.is_empty() {
            return Ok(true);
        }
        let deadline = Instant::now() + within;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() || !self.fill(left)? {
                return Ok(!self.pending.is_empty());
            }
            if !self.pending.is_empty() {
                return Ok(true);
            }
        }
    }

    /// Sends `message` and returns the one answer.
    pub fn request(&mut self, message: &HostMessage) -> Result<DeviceMessage, LinkError> {
        self.send(message)?;
        self.recv()
    }

    /// Reads what is available within `left` into the decoder; `false` on timeout.
    fn fill(&mut self, left: Duration) -> Result<bool, LinkError> {
        self.stream
            .set_read_timeout(Some(left.max(Duration::from_millis(1))))?;
        let mut buf = [0u8; 512];
        match self.stream.read(&mut buf) {
            Ok(0) => Err(LinkError::Closed),
            Ok(n) => {
                self.received.extend_from_slice(&buf[..n]);
                for &byte in &buf[..n] {
                    if let Some(decoded) = self.decoder.push::<DeviceMessage>(byte) {
                        self.pending.push_back(decoded);
                    }
                }
                Ok(true)
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                Ok(false)
            }
            Err(e) => Err(LinkError::Io(e)),
        }
    }
}

/// The wire frame of `message` (both delimiters).
pub fn encode(message: &HostMessage) -> Result<Vec<u8>, LinkError> {
    decoy_link::encode_vec(message).map_err(|e| LinkError::Encode(e.to_string()))
}

/// One firmware run under QEMU, its UART connected to a [`Link`].
///
/// QEMU is killed when the session is [`Session::finish`]ed or dropped. A session
/// dropped while the thread panics (a failed test) prints QEMU's stderr and the
/// decoded defmt log to stderr, which the test harness shows with the failure.
pub struct Session {
    qemu: Option<Supervised>,
    emulator: Option<std::thread::JoinHandle<()>>,
    /// The link to the firmware.
    pub link: Link,
    /// The boot message.
    pub hello: decoy_link::Hello,
    elf: PathBuf,
    board: Board,
}

/// What a finished session leaves: QEMU's output and the decoded log.
#[derive(Debug)]
pub struct SessionLog {
    /// QEMU's exit status and raw output (stdout: defmt frames).
    pub qemu: Captured,
    /// The decoded defmt log, or why it could not be decoded.
    pub log: String,
    /// Whether QEMU was still running when the session ended (the firmware never
    /// exits on its own: a QEMU that is gone has crashed or the firmware halted).
    pub was_running: bool,
}

impl Session {
    /// Boots `elf` on `board` with its UART on a fresh TCP port, accepts the
    /// connection and reads the boot [`decoy_link::Hello`]; QEMU is the
    /// [`crate::qemu::default_program`] (`$DECOY_QEMU`, else `qemu-system-arm`).
    pub fn start(elf: &Path, board: Board) -> Result<Self, LinkError> {
        Self::start_with(elf, Qemu::new().board(board))
    }

    /// [`Session::start`] with the launcher `qemu`: its binary and board (the
    /// session sets the UART and the time limit).
    pub fn start_with(elf: &Path, qemu: Qemu) -> Result<Self, LinkError> {
        let board = qemu.get_board();
        let listener = SerialListener::bind()?;
        let qemu = qemu.serial(listener.qemu_serial()).timeout(SESSION_TIMEOUT);
        let mut child = qemu.spawn(elf).map_err(LinkError::Qemu)?;
        let stream = match listener.accept(CONNECT_TIMEOUT, Some(&mut child)) {
            Ok(stream) => stream,
            Err(e) => {
                let detail = child
                    .stop()
                    .map(|out| out.describe())
                    .unwrap_or_else(|e| e.to_string());
                return Err(LinkError::Accept(match e {
                    AcceptError::QemuExited => AcceptError::Io(io::Error::other(format!(
                        "QEMU exited before connecting its UART\n{detail}"
                    ))),
                    other => other,
                }));
            }
        };
        let mut link = Link::new(stream);
        let hello = match link.recv_within(HELLO_TIMEOUT, "Hello at boot") {
            Ok(DeviceMessage::Hello(hello)) => hello,
            Ok(other) => {
                return Err(boot_failure(
                    LinkError::Unexpected {
                        expected: "Hello",
                        got: Box::new(other),
                    },
                    child,
                    elf,
                ));
            }
            Err(e) => return Err(boot_failure(e, child, elf)),
        };
        let session = Session {
            qemu: Some(child),
            emulator: None,
            link,
            hello,
            elf: elf.to_owned(),
            board,
        };
        Ok(session)
    }

    /// A stand-in for the firmware on the host: `controller` (the very controller
    /// the firmware runs) on a thread behind the same TCP link, polled for silence
    /// with a wall-clock millisecond clock. It tests the harness itself without
    /// QEMU; the thread ends when the session's link closes.
    pub fn emulated<T: solver_core::Real + Send + 'static, const N: usize>(
        mut controller: Box<decoy_controller::Controller<T, N>>,
        board: Board,
    ) -> Result<Self, LinkError> {
        let listener = SerialListener::bind()?;
        let port = listener.port();
        let device = std::thread::Builder::new()
            .name("emulated-controller".into())
            .spawn(move || {
                let Ok(mut stream) = TcpStream::connect((std::net::Ipv4Addr::LOCALHOST, port))
                else {
                    return;
                };
                let started = Instant::now();
                let mut decoder = decoy_link::FrameDecoder::new();
                let send = |stream: &mut TcpStream, m: &DeviceMessage| {
                    encode_device(m).is_ok_and(|bytes| stream.write_all(&bytes).is_ok())
                };
                let hello = controller.hello(&board.info());
                if !send(&mut stream, &hello) {
                    return;
                }
                let _ = stream.set_read_timeout(Some(Duration::from_millis(5)));
                let mut buf = [0u8; 512];
                loop {
                    let now_ms = started.elapsed().as_millis() as u32;
                    if let Some(status) = controller.poll_silence(now_ms)
                        && !send(&mut stream, &status)
                    {
                        return;
                    }
                    match stream.read(&mut buf) {
                        Ok(0) => return,
                        Ok(n) => {
                            let mut answers = Vec::new();
                            controller.handle_bytes(
                                &mut decoder,
                                &buf[..n],
                                &mut decoy_controller::NoCounter,
                                |a| answers.push(*a),
                            );
                            for a in &answers {
                                if !send(&mut stream, a) {
                                    return;
                                }
                            }
                        }
                        Err(e)
                            if matches!(
                                e.kind(),
                                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                            ) => {}
                        Err(_) => return,
                    }
                }
            })?;
        let stream = listener
            .accept(CONNECT_TIMEOUT, None)
            .map_err(LinkError::Accept)?;
        let mut link = Link::new(stream);
        let hello = match link.recv_within(HELLO_TIMEOUT, "Hello at boot")? {
            DeviceMessage::Hello(hello) => hello,
            other => {
                return Err(LinkError::Unexpected {
                    expected: "Hello",
                    got: Box::new(other),
                });
            }
        };
        Ok(Session {
            qemu: None,
            emulator: Some(device),
            link,
            hello,
            elf: PathBuf::new(),
            board,
        })
    }

    /// The ELF that runs.
    pub fn elf(&self) -> &Path {
        &self.elf
    }

    /// The board it runs on.
    pub fn board(&self) -> Board {
        self.board
    }

    /// Whether the firmware still runs (QEMU has not exited: no crash, no halt).
    pub fn device_running(&mut self) -> bool {
        match (&mut self.qemu, &self.emulator) {
            (Some(q), _) => q.is_running(),
            (None, Some(e)) => !e.is_finished(),
            (None, None) => false,
        }
    }

    /// Stops QEMU and decodes the firmware's log.
    pub fn finish(mut self) -> SessionLog {
        self.stop_qemu()
    }

    /// The decoded log so far is only available after QEMU stopped; this stops it.
    fn stop_qemu(&mut self) -> SessionLog {
        let Some(mut child) = self.qemu.take() else {
            let was_running = self.emulator.as_ref().is_some_and(|e| !e.is_finished());
            // An emulated device ends when the link closes.
            let _ = self.link.stream.shutdown(std::net::Shutdown::Both);
            if let Some(device) = self.emulator.take() {
                let _ = device.join();
            }
            return SessionLog {
                qemu: empty_capture(),
                log: "(no firmware log: emulated device)".to_owned(),
                was_running,
            };
        };
        let was_running = child.is_running();
        let qemu = child.stop().unwrap_or_else(|_| empty_capture());
        let log = defmt::describe(&self.elf, &qemu.stdout);
        SessionLog {
            qemu,
            log,
            was_running,
        }
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        if self.qemu.is_none() {
            self.stop_qemu();
            return;
        }
        let panicking = std::thread::panicking();
        let log = self.stop_qemu();
        if panicking {
            eprintln!(
                "--- firmware session ({} on {}) ---\nQEMU: {} (was running: {})\n--- QEMU stderr ---\n{}\n--- firmware log (defmt) ---\n{}",
                self.elf.display(),
                self.board,
                log.qemu.status,
                log.was_running,
                log.qemu.stderr_text(),
                log.log
            );
        }
    }
}

/// The wire frame of a device message (for the emulated device).
fn encode_device(message: &DeviceMessage) -> Result<Vec<u8>, LinkError> {
    decoy_link::encode_vec(message).map_err(|e| LinkError::Encode(e.to_string()))
}

/// Stops a QEMU whose firmware did not say `Hello`, keeping what it printed.
fn boot_failure(cause: LinkError, child: Supervised, elf: &Path) -> LinkError {
    let output = match child.stop() {
        Ok(out) => format!(
            "QEMU: {}\n--- QEMU stderr ---\n{}\n--- firmware log (defmt) ---\n{}",
            out.status,
            out.stderr_text(),
            defmt::describe(elf, &out.stdout)
        ),
        Err(e) => e.to_string(),
    };
    LinkError::Boot {
        cause: Box::new(cause),
        output,
    }
}

fn empty_capture() -> Captured {
    use std::os::unix::process::ExitStatusExt;
    Captured {
        status: std::process::ExitStatus::from_raw(0),
        stdout: Vec::new(),
        stderr: Vec::new(),
        elapsed: Duration::ZERO,
    }
}
