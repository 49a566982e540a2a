//! The exceptions of the `decoy` package and how the solver's typed errors map
//! onto them. Each exception's message is the line the `decoy` command line
//! prints after `error: ` for the same input.

use decoy_sim::SimError;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::{PyTypeInfo, create_exception};

create_exception!(
    decoy,
    DecoyError,
    PyException,
    "Every error of the decoy package; the message is the decoy command line's for the same input."
);
create_exception!(
    decoy,
    ConfigError,
    DecoyError,
    "The system configuration (a path or a dict) cannot be read, parsed or validated, or does not suit the run."
);
create_exception!(
    decoy,
    ScenarioError,
    DecoyError,
    "The scenario is unknown, or its file, dict or recorded flight cannot be read or parsed."
);
create_exception!(
    decoy,
    InputError,
    DecoyError,
    "A value of the scenario or an argument is missing, out of range or does not apply to the scenario's kind."
);
create_exception!(
    decoy,
    SolverError,
    DecoyError,
    "The solver could not produce a result: no trim for the flight condition, an initial state that cannot be evaluated."
);
create_exception!(
    decoy,
    Stopped,
    SolverError,
    "The integration stopped part way (the state diverged, or the flight left the atmosphere); `result` holds the run up to its last good state, `t_s` its time."
);
create_exception!(
    decoy,
    OutputError,
    DecoyError,
    "An output file or plot (`out=`) could not be written."
);

/// Adds the exception classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("DecoyError", py.get_type::<DecoyError>())?;
    m.add("ConfigError", py.get_type::<ConfigError>())?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("SolverError", py.get_type::<SolverError>())?;
    m.add("Stopped", py.get_type::<Stopped>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    Ok(())
}

/// The message as the command line prints it: one line.
fn one_line(e: &impl std::fmt::Display) -> String {
    e.to_string().replace('\n', " ")
}

/// A configuration that cannot be loaded.
pub fn config_error(e: &decoy_config::ConfigError) -> PyErr {
    ConfigError::new_err(one_line(e))
}

/// The exception class of a solver error (of the error a sweep's point wraps:
/// the message stays the whole one).
fn class_of<'py>(py: Python<'py>, e: &SimError) -> Bound<'py, pyo3::types::PyType> {
    match e {
        SimError::UnknownScenario { .. }
        | SimError::ScenarioSyntax { .. }
        | SimError::RecordedFlight { .. }
        | SimError::RecordedAcceleration { .. }
        | SimError::Read { .. } => ScenarioError::type_object(py),
        SimError::InvalidInput { .. } => InputError::type_object(py),
        SimError::Config(_) => ConfigError::type_object(py),
        SimError::NoTrim(_) | SimError::Initial(_) => SolverError::type_object(py),
        SimError::Stopped { .. } => Stopped::type_object(py),
        SimError::Io { .. } | SimError::Plot { .. } => OutputError::type_object(py),
        SimError::AtPoint { source, .. } => class_of(py, source),
        // A stop request is the caller's (KeyboardInterrupt, raised by
        // `worker::solve`); a variant added later is at least a DecoyError.
        _ => DecoyError::type_object(py),
    }
}

/// The Python exception of a solver error, with the command line's message.
pub fn sim_error(py: Python<'_>, e: &SimError) -> PyErr {
    PyErr::from_type(class_of(py, e), one_line(e))
}

/// An argument the command line would have refused: `command line: FLAG
/// MESSAGE`, as the solver's checks word it.
pub fn argument_error(flag: &str, message: String) -> PyErr {
    InputError::new_err(format!("command line: {flag} {message}"))
}
