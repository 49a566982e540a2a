//! The host reference with the target's maths: `crates/hil-reference`, a small
//! program of its own workspace that runs `decoy_link::Controller` with nalgebra's
//! `libm-force` (the `libm` crate's transcendental functions, as on the target).
//!
//! In this workspace the solver is built with `std`, and nalgebra then takes `sin`,
//! `exp`, `powf`... from the platform: the controller's f32 answers differ from the
//! target's by about 1e-5 relative from the first frame on. `hil-reference` gives
//! the target's bits. It is fed exactly what the firmware is fed (wire bytes, and
//! the link supervision's clock) and answers what the firmware answers.

use std::fmt;
use std::io::{self, BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::Duration;

use decoy_link::{DeviceMessage, FrameDecoder, HostMessage};

use crate::firmware::workspace_root;
use crate::qemu::{Captured, RunError, run_with_timeout};

/// The reference program's crate directory.
pub fn crate_dir() -> PathBuf {
    workspace_root().join("crates").join("hil-reference")
}

/// The program [`build`] produces.
pub fn executable() -> PathBuf {
    crate_dir()
        .join("target")
        .join("release")
        .join("hil-reference")
}

/// Why the reference could not be built, started or used.
#[derive(Debug)]
pub enum ReferenceError {
    /// Cargo could not be run.
    Run(RunError),
    /// Its build failed.
    BuildFailed(Captured),
    /// The program could not be started or talked to.
    Io(io::Error),
    /// It answered something that does not decode.
    Protocol(String),
}

impl fmt::Display for ReferenceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReferenceError::Run(e) => write!(f, "building the host reference: {e}"),
            ReferenceError::BuildFailed(out) => {
                write!(
                    f,
                    "the host reference (crates/hil-reference) did not build\n{}",
                    out.describe()
                )
            }
            ReferenceError::Io(e) => write!(f, "the host reference failed: {e}"),
            ReferenceError::Protocol(e) => write!(f, "the host reference answered badly: {e}"),
        }
    }
}

impl std::error::Error for ReferenceError {}

impl From<io::Error> for ReferenceError {
    fn from(e: io::Error) -> Self {
        ReferenceError::Io(e)
    }
}

/// Builds `hil-reference` (release, its own target directory) within `timeout`.
pub fn build(timeout: Duration) -> Result<PathBuf, ReferenceError> {
    let dir = crate_dir();
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.args(["build", "--release", "--manifest-path"])
        .arg(dir.join("Cargo.toml"))
        .current_dir(&dir);
    for var in [
        "RUSTFLAGS",
        "CARGO_ENCODED_RUSTFLAGS",
        "CARGO_BUILD_RUSTFLAGS",
        "CARGO_BUILD_TARGET",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET_DIR",
    ] {
        cmd.env_remove(var);
    }
    let out = run_with_timeout(
        &mut cmd,
        timeout,
        "cargo is not on PATH; install Rust with rustup",
    )
    .map_err(ReferenceError::Run)?;
    if !out.status.success() {
        return Err(ReferenceError::BuildFailed(out));
    }
    Ok(executable())
}

/// A running reference controller (killed on drop).
pub struct Reference {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    decoder: FrameDecoder,
}

impl Reference {
    /// Starts `program` (from [`build`]) with a controller of `precision_bits` (32
    /// or 64) and `segments` segments.
    pub fn start(
        program: &std::path::Path,
        precision_bits: u8,
        segments: usize,
    ) -> Result<Self, ReferenceError> {
        let mut child = Command::new(program)
            .args(["--precision", &precision_bits.to_string()])
            .args(["--segments", &segments.to_string()])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            let _ = child.kill();
            return Err(ReferenceError::Protocol("no pipes".into()));
        };
        Ok(Reference {
            child,
            stdin,
            stdout: BufReader::new(stdout),
            decoder: FrameDecoder::new(),
        })
    }

    /// Feeds the bytes the controller receives; returns every answer they produce.
    pub fn feed(&mut self, bytes: &[u8]) -> Result<Vec<DeviceMessage>, ReferenceError> {
        self.request(0, bytes)
    }

    /// The answer to one message.
    pub fn handle(&mut self, message: &HostMessage) -> Result<DeviceMessage, ReferenceError> {
        let wire =
            crate::link::encode(message).map_err(|e| ReferenceError::Protocol(e.to_string()))?;
        let mut answers = self.feed(&wire)?;
        match (answers.pop(), answers.is_empty()) {
            (Some(answer), true) => Ok(answer),
            _ => Err(ReferenceError::Protocol(format!(
                "not one answer to {message:?}"
            ))),
        }
    }

    /// The answers to `messages`, one each.
    pub fn replay(
        &mut self,
        messages: &[HostMessage],
    ) -> Result<Vec<DeviceMessage>, ReferenceError> {
        messages.iter().map(|m| self.handle(m)).collect()
    }

    /// Polls the link supervision with the clock at `now_ms`.
    pub fn poll_silence(&mut self, now_ms: u32) -> Result<Option<DeviceMessage>, ReferenceError> {
        let mut answers = self.request(1, &now_ms.to_le_bytes())?;
        Ok(answers.pop())
    }

    fn request(&mut self, kind: u8, body: &[u8]) -> Result<Vec<DeviceMessage>, ReferenceError> {
        let mut header = vec![kind];
        header.extend_from_slice(&(body.len() as u32).to_le_bytes());
        self.stdin.write_all(&header)?;
        self.stdin.write_all(body)?;
        self.stdin.flush()?;
        let mut count = [0u8; 4];
        self.stdout.read_exact(&mut count)?;
        let count = u32::from_le_bytes(count) as usize;
        let mut answers = Vec::with_capacity(count);
        let mut byte = [0u8; 1];
        while answers.len() < count {
            self.stdout.read_exact(&mut byte)?;
            if let Some(decoded) = self.decoder.push::<DeviceMessage>(byte[0]) {
                answers.push(decoded.map_err(|e| ReferenceError::Protocol(e.to_string()))?);
            }
        }
        Ok(answers)
    }
}

impl Drop for Reference {
    fn drop(&mut self) {
        // Closing stdin ends it; kill in case it is stuck.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
