//! Why a command failed ([`Failure`], and so its exit code), and the JSON
//! every command prints with `--json`.

use decoy_config::ConfigError;
use decoy_sim::SimError;
use decoy_stream::run::{DeviceError, StreamError};
use decoy_stream::signals::exit_code;
use serde::Serialize;

/// Why a command failed, and so its exit code.
#[derive(Debug)]
pub enum Failure {
    /// Bad command line or configuration: exit code 2.
    Usage(String),
    /// The solver could not produce a result: exit code 1.
    Solver(String),
    /// A signal stopped the run (its outputs are written): exit code 130
    /// (SIGINT) or 143 (SIGTERM), [`exit_code`].
    Interrupted {
        /// What stopped where, and where the outputs are.
        message: String,
        /// The exit code.
        code: u8,
    },
}

impl Failure {
    /// The command's exit code.
    pub fn exit_code(&self) -> u8 {
        match self {
            Failure::Usage(_) => 2,
            Failure::Solver(_) => 1,
            Failure::Interrupted { code, .. } => *code,
        }
    }
    /// What went wrong, in words.
    pub fn message(&self) -> &str {
        match self {
            Failure::Usage(m) | Failure::Solver(m) | Failure::Interrupted { message: m, .. } => m,
        }
    }
    /// The signal `signal` stopped the run: `message` says where.
    pub fn interrupted(signal: &str, message: String) -> Self {
        Failure::Interrupted {
            message,
            code: exit_code(signal),
        }
    }
}

impl From<SimError> for Failure {
    fn from(e: SimError) -> Self {
        if let SimError::Interrupted { signal, .. } = &e {
            Failure::interrupted(signal, e.to_string())
        } else if e.is_usage() {
            Failure::Usage(e.to_string())
        } else {
            Failure::Solver(e.to_string())
        }
    }
}

/// A streamed run's failure (`decoy hil`, `decoy feed`), the same way for
/// every device: a signal's exit code, a usage error, or the run's failure.
impl<E: DeviceError> From<StreamError<E>> for Failure {
    fn from(e: StreamError<E>) -> Self {
        if let StreamError::Interrupted { signal, .. } = &e {
            Failure::interrupted(signal, e.to_string())
        } else if e.is_usage() {
            Failure::Usage(e.to_string())
        } else {
            Failure::Solver(e.to_string())
        }
    }
}

impl From<ConfigError> for Failure {
    fn from(e: ConfigError) -> Self {
        Failure::Usage(e.to_string())
    }
}

/// A usage error (exit code 2) saying `message`.
pub fn usage(message: impl Into<String>) -> Failure {
    Failure::Usage(message.into())
}

/// A run's summary as `--json` prints it: pretty JSON and a newline, as its
/// `summary.json` holds it.
pub fn summary_json<T: Serialize>(summary: &T) -> Result<String, Failure> {
    let mut text = serde_json::to_string_pretty(summary)
        .map_err(|e| Failure::Solver(format!("cannot print the summary: {e}")))?;
    text.push('\n');
    Ok(text)
}

/// `value` as one line of JSON and a newline (a value serde cannot write: an
/// object naming the error).
pub fn to_json<T: Serialize>(value: &T) -> String {
    let mut text =
        serde_json::to_string(value).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"));
    text.push('\n');
    text
}
