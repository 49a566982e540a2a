//! [`ConfigError`]: why a configuration could not be loaded or used, each
//! variant naming the file and, where there is one, the field or the line.

use std::ops::Range;
use std::path::PathBuf;

use solver_core::AtmosphereError;

/// Why a configuration could not be loaded or used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// A file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The TOML is malformed, or has a missing, unknown or mistyped field.
    #[error("{file}{}: {message}", line_suffix(*line))]
    Toml {
        /// The TOML file (for a field of an overlay, the file that wrote it).
        file: String,
        /// 1-based line of the problem, when known.
        line: Option<usize>,
        /// What is wrong (names the field and its table).
        message: String,
    },
    /// The aerodynamic table is malformed or unusable.
    #[error("{file}{}: {message}", line_suffix(*line))]
    AeroCsv {
        /// The CSV file.
        file: String,
        /// 1-based line of the problem, when it is one line's.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A field has a value outside its physical range (non-finite, not positive, ...).
    #[error("{file}: {field} {message}")]
    Invalid {
        /// The TOML file that gave the value (an overlay or its base).
        file: String,
        /// The field, as `table.key` (for example `decoy.mass`).
        field: String,
        /// What is wrong with its value.
        message: String,
    },
    /// `environment.atmosphere` names a model the solver does not have.
    #[error("{file}: environment.atmosphere = \"{name}\" is not supported (only \"ISA-1976\")")]
    UnsupportedAtmosphere {
        /// The TOML file.
        file: String,
        /// The name given.
        name: String,
    },
    /// The `base` keys of overlays lead back to a file already in the chain.
    #[error("{file}: base = \"{base}\" makes a cycle ({})", chain.join(" -> "))]
    BaseCycle {
        /// The file whose `base` closes the cycle.
        file: String,
        /// The `base` it names.
        base: String,
        /// The files of the chain, from the one loaded to the repeated one.
        chain: Vec<String>,
    },
    /// The solver rejected the model built from the configuration (for example too
    /// many segments for its capacity).
    #[error("{0}")]
    Solver(#[from] solver_core::ConfigError),
    /// The envelope map on board (`envelope.limits_map`) was made for another
    /// configuration.
    #[error(
        "{file} was made for another configuration than {config} (its config_hash is {found}, \
         the configuration's {expected}): map the envelope again and write the file with \
         `decoy limits-table` (docs/envelope.md, \"On board\"), or remove `limits_map` from \
         [envelope]"
    )]
    StaleLimits {
        /// The map file.
        file: String,
        /// The configuration (its source).
        config: String,
        /// The hash the file gives.
        found: String,
        /// The configuration's.
        expected: String,
    },
    /// The atmosphere cannot give air properties at the requested altitude.
    #[error("{0}")]
    Atmosphere(#[from] AtmosphereError),
}

/// A map file made for another configuration than the one that names it
/// (kept by `SystemConfig::stale_limits`; `SystemConfig::check_limits`
/// turns it into [`ConfigError::StaleLimits`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StaleLimits {
    /// The map file.
    pub file: String,
    /// The configuration (its source).
    pub config: String,
    /// The hash the file gives.
    pub found: String,
    /// The configuration's.
    pub expected: String,
}

impl StaleLimits {
    /// As an error.
    pub fn error(&self) -> ConfigError {
        ConfigError::StaleLimits {
            file: self.file.clone(),
            config: self.config.clone(),
            found: self.found.clone(),
            expected: self.expected.clone(),
        }
    }
}

fn line_suffix(line: Option<usize>) -> String {
    line.map(|l| format!(", line {l}")).unwrap_or_default()
}

/// A one-line TOML error in `file` (whose text is `text`): the line of `span`,
/// the message, and the table the line is in.
pub(crate) fn toml_error(
    file: &str,
    text: &str,
    message: &str,
    span: Option<Range<usize>>,
) -> ConfigError {
    let mut message = message.trim().replace('\n', " ");
    let mut line = None;
    if let Some(span) = span {
        let start = span.start.min(text.len());
        line = Some(text[..start].matches('\n').count() + 1);
        let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
        let table = text[..line_end]
            .lines()
            .filter_map(|l| {
                let l = l.trim();
                l.strip_prefix('[')
                    .and_then(|rest| rest.split(']').next())
                    .map(str::trim)
            })
            .next_back();
        if let Some(table) = table {
            message = format!("{message} (in [{table}])");
        }
    }
    ConfigError::Toml {
        file: file.to_owned(),
        line,
        message,
    }
}
