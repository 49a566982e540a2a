//! [`SimError`]: why a simulation could not be set up, run or written.

use std::path::PathBuf;

use solver_core::{SolveError, TrimError};

use crate::format::format_number;

/// Why [`crate::simulate`] (or loading a scenario) failed. Every message is one
/// line that names the file, the field, the line or the time concerned.
///
/// [`SimError::is_usage`] tells the command line's usage/configuration errors (the
/// user must change an input) from run-time failures.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// `--scenario NAME` names no shipped scenario (and no file).
    #[error("unknown scenario `{name}`: the shipped scenarios are {}; or give the path of a scenario TOML file", available.join(", "))]
    UnknownScenario {
        /// The name asked for.
        name: String,
        /// The names of the shipped scenarios.
        available: Vec<String>,
    },
    /// A scenario file is malformed or has a missing, unknown or mistyped key.
    #[error("{file}{}: {message}", line_suffix(*line))]
    ScenarioSyntax {
        /// The scenario file (or `built-in NAME.toml`).
        file: String,
        /// 1-based line of the problem, when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A scenario value or a command-line override is missing, out of range or
    /// does not apply to the scenario's kind.
    #[error("{origin}: {field} {message}")]
    InvalidInput {
        /// The scenario file, or `command line`.
        origin: String,
        /// The key (`mach`) or flag (`--mach`).
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// The recorded-flight CSV is malformed or unusable.
    #[error("{file}{}{}: {message}", line_suffix(*line), column_suffix(column.as_deref()))]
    RecordedFlight {
        /// The CSV file.
        file: String,
        /// 1-based line of the problem, when it is one line's.
        line: Option<usize>,
        /// The column concerned, when it is one column's.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A recorded flight implies an acceleration no aircraft flies (above
    /// `recorded::MAX_RECORDED_ACCELERATION_MPS2`, 100 m/s²): a velocity or a time
    /// of the row is wrong.
    #[error("{file}{}: the acceleration implied between the samples at t = {} s and {} s is {} m/s², more than {limit_mps2} m/s² (about 10 g); is a velocity or a time wrong?", line_suffix(*line), format_number(*t0_s), format_number(*t1_s), format_number(*acceleration_mps2))]
    RecordedAcceleration {
        /// The CSV file.
        file: String,
        /// 1-based line of the later sample of the interval.
        line: Option<usize>,
        /// Time of the earlier sample, s.
        t0_s: f64,
        /// Time of the later sample, s.
        t1_s: f64,
        /// The largest acceleration on the interval, m/s².
        acceleration_mps2: f64,
        /// The bound, m/s².
        limit_mps2: f64,
    },
    /// The system configuration is unusable for this run (for example the segment
    /// count exceeds the solver's capacity).
    #[error("{0}")]
    Config(#[from] decoy_config::ConfigError),
    /// No trim (steady equilibrium) exists for the initial flight condition.
    #[error("no trim for the initial flight condition: {0}")]
    NoTrim(#[source] TrimError),
    /// The initial state could not be evaluated.
    #[error("the initial state cannot be evaluated: {0}")]
    Initial(#[source] SolveError),
    /// The integration failed part way (the state diverged, a pivot lost positive
    /// definiteness, or the flight left the atmosphere). The outputs written up to
    /// `t_s` are valid and `summary.json` records `"stopped"`.
    #[error("simulation stopped at t = {t_s} s: {reason}{}", outputs_in(out_dir.as_deref()))]
    Stopped {
        /// Time of the last good state, s.
        t_s: f64,
        /// Why, in words (also in `summary.json`).
        reason: String,
        /// The solver's error, when the solver reported one.
        #[source]
        source: Option<SolveError>,
        /// The output directory (`None`: a run kept in memory only,
        /// [`crate::simulate_recorded`], or a study's).
        out_dir: Option<PathBuf>,
    },
    /// A stop request (from the command line: a signal, SIGINT or SIGTERM) ended
    /// the run at a step boundary ([`crate::simulate_until`]). The outputs up to
    /// `t_s` are written whole and `summary.json`'s `"stopped"` names the
    /// request.
    #[error("interrupted by {signal} at t = {t_s} s{}", outputs_in(out_dir.as_deref()))]
    Interrupted {
        /// Time of the last state, s.
        t_s: f64,
        /// What asked to stop (`SIGINT`; `summary.json`'s `stopped.reason` is `interrupted by SIGINT`).
        signal: &'static str,
        /// The output directory (`None`: a run kept in memory only).
        out_dir: Option<PathBuf>,
    },
    /// An input file (scenario, recorded flight) could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// An output file or directory could not be created or written.
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        /// `write`, `create` ...
        action: &'static str,
        /// The file or directory.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// One point of a sweep or study failed (for example no trim at that value).
    #[error("{point}: {source}")]
    AtPoint {
        /// The point, in words (`Mach 0.95`, `decoy.x_tow = 0.6 m`).
        point: String,
        /// What went wrong there.
        #[source]
        source: Box<SimError>,
    },
    /// A plot could not be drawn or written.
    #[error("cannot write the plot {}: {message}", stem.display())]
    Plot {
        /// The plot's path without extension.
        stem: PathBuf,
        /// The plotting library's message.
        message: String,
    },
}

impl SimError {
    /// True for errors the user fixes by changing an input (scenario, flag,
    /// configuration, recorded flight, an unreadable input file): the command line
    /// exits with code 2 for these and 1 for the others (no trim, integration
    /// stopped, writing the outputs, plotting).
    pub fn is_usage(&self) -> bool {
        if let SimError::AtPoint { source, .. } = self {
            return source.is_usage();
        }
        matches!(
            self,
            SimError::UnknownScenario { .. }
                | SimError::ScenarioSyntax { .. }
                | SimError::InvalidInput { .. }
                | SimError::RecordedFlight { .. }
                | SimError::RecordedAcceleration { .. }
                | SimError::Read { .. }
                | SimError::Config(_)
        )
    }

    /// `self` as the failure of one point of a sweep.
    pub(crate) fn at(self, point: impl Into<String>) -> Self {
        SimError::AtPoint {
            point: point.into(),
            source: Box::new(self),
        }
    }

    /// An [`SimError::InvalidInput`].
    pub(crate) fn invalid(
        origin: impl Into<String>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        SimError::InvalidInput {
            origin: origin.into(),
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Where a stopped run's outputs are, for its message (nothing for a run
/// that wrote none).
fn outputs_in(out_dir: Option<&std::path::Path>) -> String {
    out_dir
        .map(|dir| format!("; the outputs up to then are in {}", dir.display()))
        .unwrap_or_default()
}

fn line_suffix(line: Option<usize>) -> String {
    line.map(|l| format!(", line {l}")).unwrap_or_default()
}

fn column_suffix(column: Option<&str>) -> String {
    column.map(|c| format!(", column {c}")).unwrap_or_default()
}
