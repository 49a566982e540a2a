//! The firmware's log: defmt frames on QEMU's stdout (semihosting), decoded on the
//! host by `defmt-print -e ELF` (installed by `cargo xtask setup`).
//!
//! The log is decoded after the run, from the bytes QEMU printed, so that the
//! firmware's timing does not depend on the decoder. It is shown when a test fails.

use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use crate::qemu::{RunError, Supervised};

/// The host decoder of defmt frames.
pub const DEFMT_PRINT: &str = "defmt-print";

/// What to tell the user when `defmt-print` is missing.
pub const DEFMT_PRINT_MISSING_HINT: &str = "the defmt log decoder is not installed; run `cargo xtask setup` (it runs `cargo install defmt-print --locked`)";

/// Time limit of one decoding.
const DECODE_TIMEOUT: Duration = Duration::from_secs(60);

/// Why a log could not be decoded.
#[derive(Debug)]
pub enum DefmtError {
    /// `defmt-print` could not be run (not installed, or it timed out).
    Run(RunError),
    /// The raw log could not be handed to it.
    Io {
        /// The temporary file of the raw log.
        path: PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// `defmt-print` ran and failed (for example: the ELF has no defmt table).
    Failed {
        /// Its exit status and error output.
        stderr: String,
    },
}

impl fmt::Display for DefmtError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DefmtError::Run(e) => write!(f, "decoding the firmware log: {e}"),
            DefmtError::Io { path, error } => {
                write!(f, "cannot write the raw log {}: {error}", path.display())
            }
            DefmtError::Failed { stderr } => {
                write!(f, "`{DEFMT_PRINT}` failed to decode the log: {stderr}")
            }
        }
    }
}

impl std::error::Error for DefmtError {}

/// Whether `defmt-print` runs here.
pub fn available() -> bool {
    Command::new(DEFMT_PRINT)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Fails with the setup hint when `defmt-print` is missing (tests call this first,
/// so that a missing decoder is a failure saying what to do, not a silent skip).
pub fn require() -> Result<(), DefmtError> {
    if available() {
        Ok(())
    } else {
        Err(DefmtError::Run(RunError::NotFound {
            program: DEFMT_PRINT.to_owned(),
            hint: DEFMT_PRINT_MISSING_HINT,
        }))
    }
}

/// Decodes `raw` (what QEMU printed on stdout) with the defmt table of `elf`; returns
/// the log as text, one line per message.
pub fn decode(elf: &Path, raw: &[u8]) -> Result<String, DefmtError> {
    if raw.is_empty() {
        return Ok(String::new());
    }
    let path =
        std::env::temp_dir().join(format!("hil-defmt-{}-{}.bin", std::process::id(), unique()));
    fs::write(&path, raw).map_err(|error| DefmtError::Io {
        path: path.clone(),
        error,
    })?;
    let stdin = fs::File::open(&path).map_err(|error| DefmtError::Io {
        path: path.clone(),
        error,
    });
    let result = stdin.and_then(|file| {
        let mut cmd = Command::new(DEFMT_PRINT);
        cmd.arg("-e").arg(elf);
        Supervised::spawn_with_stdin(
            &mut cmd,
            Stdio::from(file),
            DECODE_TIMEOUT,
            DEFMT_PRINT_MISSING_HINT,
        )
        .and_then(Supervised::wait)
        .map_err(DefmtError::Run)
    });
    // The raw bytes are only a means of feeding the decoder.
    let _ = fs::remove_file(&path);
    let out = result?;
    if !out.status.success() {
        return Err(DefmtError::Failed {
            stderr: format!("{}: {}", out.status, out.stderr_text().trim()),
        });
    }
    Ok(out.stdout_text())
}

/// A number unique within this process, for temporary file names.
fn unique() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// The decoded log, or the reason it could not be decoded and the raw size: what
/// a failure message shows.
pub fn describe(elf: &Path, raw: &[u8]) -> String {
    match decode(elf, raw) {
        Ok(text) if text.trim().is_empty() => "(the firmware logged nothing)".to_owned(),
        Ok(text) => text,
        Err(e) => format!("({e}; {} raw bytes)", raw.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_log_needs_no_decoder() {
        assert_eq!(decode(Path::new("no.elf"), &[]).unwrap(), "");
    }

    #[test]
    fn the_missing_decoder_message_says_to_run_setup() {
        assert!(DEFMT_PRINT_MISSING_HINT.contains("cargo xtask setup"));
    }
}
