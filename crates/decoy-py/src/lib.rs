//! # decoy-py: the towed-decoy solver in Python
//!
//! The extension module `decoy._native` of the Python package `decoy`
//! (`python/decoy/__init__.py` re-exports it; the API with its types is
//! `python/decoy/__init__.pyi`), built by maturin as an abi3 wheel (CPython 3.10
//! and later) from the same crates as the `decoy` command line, and installed
//! into `.venv/` by `cargo xtask setup`:
//!
//! - `trim(altitude, mach, *, segments, grading, config)`: `decoy trim --json`'s
//!   dict ([`decoy_sim::trim::level_trim`]);
//! - `simulate(scenario, *, rate, onset, altitude, mach, t_end, segments,
//!   grading, dt, initial, config, out, plots)`: `decoy simulate`'s run
//!   ([`decoy_sim::simulate_recorded`]) as a `Simulation`: the summary
//!   (`summary.json`'s dict), the time series and the cable snapshots (the
//!   columns of `timeseries.csv` and `cable.csv` as NumPy arrays); files only
//!   with `out=`;
//! - `envelope_plan`, `envelope_cell`, `envelope_pending`, `envelope_store`,
//!   `envelope_map` (`envelope`): the manoeuvre envelope map's primitives,
//!   which `python/decoy/_envelope.py` composes into `decoy.envelope()` (on
//!   threads here, or as Ray tasks);
//! - `builtin_config()`, `builtin_scenario(name)`, `SCENARIOS`: the built-in
//!   configuration and shipped scenarios as dicts, to edit and pass back;
//! - the exceptions (`errors`): `DecoyError` and its kinds, with the command
//!   line's messages.
//!
//! The solver runs on a thread of its own with the GIL released (`worker`), so
//! Python threads run beside it; Ctrl-C stops it at a step boundary with
//! KeyboardInterrupt; a panic is a `DecoyError`, never an abort. The numbers are
//! the command line's, bit for bit (`clients/python/tests/test_solver.py`).

use std::path::PathBuf;

use decoy_schema::columns::{SIMULATE_CABLE, SIMULATE_TIMESERIES};
use decoy_sim::trim::{TrimRequest, level_trim};
use decoy_sim::{BUILTIN_SCENARIOS, InitialState, Recording, RunOptions, Scenario, SimError};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyMapping, PyString, PyTuple};

mod args;
mod convert;
mod envelope;
mod errors;
mod worker;

use args::{load_config, segment_count};
use errors::{argument_error, sim_error};

/// How a dict given as the scenario is named in messages (before its TOML's).
const SCENARIO_DICT: &str = "scenario dict";

/// The result of `simulate`: the run's summary, time series and cable
/// snapshots, as `decoy simulate` writes them to `summary.json`,
/// `timeseries.csv` and `cable.csv` (docs/outputs.md).
#[pyclass(module = "decoy", frozen, get_all)]
struct Simulation {
    /// `summary.json`'s content as a dict (`stopped` present when the run ended early).
    summary: Py<PyDict>,
    /// `timeseries.csv`'s columns: column name to a 1-D float64 array of its
    /// rows (every 10 ms, the initial and final states), at full precision.
    timeseries: Py<PyDict>,
    /// `cable.csv`'s columns: column name to a 1-D float64 array of its rows,
    /// every snapshot's joints 0 to N one after the other (`reshape(-1, N + 1)`
    /// gives one row per snapshot).
    cable: Py<PyDict>,
    /// The files written (`out=`), in order; empty for a run kept in memory.
    files: Py<PyList>,
}

#[pymethods]
impl Simulation {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let summary = self.summary.bind(py);
        let get = |key: &str| -> PyResult<String> {
            Ok(match summary.get_item(key)? {
                Some(v) => v.repr()?.to_string(),
                None => "None".to_owned(),
            })
        };
        let rows = match self.timeseries.bind(py).values().iter().next() {
            Some(column) => column.len()?,
            None => 0,
        };
        let stopped = match summary.get_item("stopped")? {
            Some(_) => ", stopped",
            None => "",
        };
        Ok(format!(
            "<decoy.Simulation scenario={} segments={} t_end={} rows={rows}{stopped}>",
            get("scenario")?,
            get("segments")?,
            get("t_end")?
        ))
    }
}

impl Simulation {
    /// The Python value of a recording.
    fn of(py: Python<'_>, recording: &Recording) -> PyResult<Simulation> {
        let samples = &recording.samples;
        let timeseries = convert::columns(py, &SIMULATE_TIMESERIES, samples.len(), |row, q| {
            samples[row].cell(q)
        })?;
        let joints: Vec<(usize, usize)> = recording
            .snapshots
            .iter()
            .enumerate()
            .flat_map(|(s, snapshot)| (0..snapshot.joints.len()).map(move |j| (s, j)))
            .collect();
        let cable = convert::columns(py, &SIMULATE_CABLE, joints.len(), |row, q| {
            let (s, j) = joints[row];
            recording.snapshots[s].cell(j, q)
        })?;
        let files = PyList::empty(py);
        for file in &recording.files {
            files.append(file.display().to_string())?;
        }
        Ok(Simulation {
            summary: convert::json_to_py(py, &recording.summary)?
                .cast_into::<PyDict>()?
                .unbind(),
            timeseries: timeseries.unbind(),
            cable: cable.unbind(),
            files: files.unbind(),
        })
    }
}

/// The scenario: a shipped name or a TOML path (as `--scenario`), a path-like
/// object a TOML file, a dict that file's keys.
fn load_scenario(py: Python<'_>, scenario: &Bound<'_, PyAny>) -> PyResult<Scenario> {
    let loaded = if let Ok(name) = scenario.cast::<PyString>() {
        Scenario::load(name.to_str()?)
    } else if scenario.cast::<PyMapping>().is_ok() {
        Scenario::from_toml(&convert::toml_text(scenario, SCENARIO_DICT)?)
    } else if scenario.hasattr("__fspath__")? {
        Scenario::from_file(scenario.extract::<PathBuf>()?)
    } else {
        return Err(PyTypeError::new_err(format!(
            "scenario: expected a shipped scenario's name, a path or a dict, got a {}",
            scenario.get_type().name()?
        )));
    };
    loaded.map_err(|e| sim_error(py, &e))
}

/// The steady level-flight trim of the towed system, as `decoy trim --json`.
///
/// altitude: aircraft altitude, m (0 to 20000); mach: Mach number (above 0, at
/// most 2); segments: cable segments (default: the configuration's
/// solver.segments_host); grading: segment length ratio, short at the decoy
/// (1 = uniform); config: the system (None: the built-in reference system; a
/// TOML path; a dict of its tables).
///
/// Returns the dict `decoy trim --json` prints: decoy_pitch_deg,
/// tension_connection_N, tension_tow_N, decoy_cg_behind_m, decoy_cg_below_m,
/// decoy_cg_behind_connection_m, decoy_cg_below_connection_m and
/// tension_profile_N (joints 0 to N). Raises InputError, ConfigError or
/// SolverError with the command line's message.
#[pyfunction]
#[pyo3(signature = (altitude, mach, *, segments=None, grading=None, config=None))]
fn trim(
    py: Python<'_>,
    altitude: f64,
    mach: f64,
    segments: Option<i64>,
    grading: Option<f64>,
    config: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    let config = load_config(config)?;
    let request = TrimRequest {
        altitude,
        mach,
        segments: segment_count(segments)?,
        grading,
    };
    let trimmed = worker::solve(py, |_stop| level_trim(&config, &request))?;
    match trimmed {
        Ok(t) => Ok(convert::json_to_py(py, &t.report())?.unbind()),
        Err(e) => Err(sim_error(py, &e)),
    }
}

/// Flies a scenario as `decoy simulate` does and returns the run in memory.
///
/// scenario: a shipped scenario's name (SCENARIOS), the path of a scenario TOML
/// file, or a dict of its keys (builtin_scenario(name) gives one to edit).
/// The keyword arguments override the scenario as the command line's flags do:
/// rate (--rate, rad/s), onset (--onset, s: a pull-up's or turn's rate built
/// over it; 0: the paper's step), altitude (--altitude, m), mach (--mach), t_end
/// (--t-end, s), segments (--segments), grading (--grading), dt (--dt, s: a
/// fixed RK4 step; None: the scenario's step rule), initial ("trim" or
/// "straight", --initial); config: the system (None: the built-in reference
/// system; a TOML path; a dict of its tables). out: a directory to write the
/// files `decoy simulate --out` writes (None: nothing is written); plots:
/// draw the plots there too (False: --no-plots).
///
/// Returns a Simulation: summary (summary.json's dict), timeseries and cable
/// (the columns of timeseries.csv and cable.csv as float64 arrays), files.
/// Raises ScenarioError, InputError, ConfigError, SolverError, OutputError
/// with the command line's message; Stopped (a SolverError) when the
/// integration stopped part way, with the run up to then as its `result`;
/// KeyboardInterrupt at Ctrl-C (the run stops at the next step).
#[pyfunction]
#[pyo3(signature = (
    scenario, *, rate=None, onset=None, altitude=None, mach=None, t_end=None, segments=None,
    grading=None, dt=None, initial="trim", config=None, out=None, plots=true
))]
#[allow(clippy::too_many_arguments)]
fn simulate(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    rate: Option<f64>,
    onset: Option<f64>,
    altitude: Option<f64>,
    mach: Option<f64>,
    t_end: Option<f64>,
    segments: Option<i64>,
    grading: Option<f64>,
    dt: Option<f64>,
    initial: &str,
    config: Option<&Bound<'_, PyAny>>,
    out: Option<PathBuf>,
    plots: bool,
) -> PyResult<Simulation> {
    let initial = match initial {
        "trim" => InitialState::Trim,
        "straight" => InitialState::Straight,
        other => {
            return Err(argument_error(
                "--initial",
                format!("must be \"trim\" or \"straight\", got \"{other}\""),
            ));
        }
    };
    let config = load_config(config)?;
    let scenario = load_scenario(py, scenario)?;
    let options = RunOptions {
        segments: segment_count(segments)?,
        grading,
        dt,
        t_end,
        altitude,
        mach,
        rate,
        onset,
        initial,
        out_dir: out,
        plots,
    };
    let run = worker::solve(py, |stop| {
        decoy_sim::simulate_recorded(&config, &scenario, &options, |_| {}, stop)
    })?;
    let recording = run.map_err(|e| sim_error(py, &e))?;
    let simulation = Simulation::of(py, &recording)?;
    match &recording.ended {
        None => Ok(simulation),
        Some(e @ SimError::Stopped { t_s, .. }) => {
            let err = sim_error(py, e);
            let value = err.value(py);
            value.setattr("t_s", *t_s)?;
            value.setattr("result", Bound::new(py, simulation)?)?;
            Err(err)
        }
        Some(e) => Err(sim_error(py, e)),
    }
}

/// The built-in reference system (config/reference-system.toml) as a dict of
/// its tables: edit it and pass it as `config=` (its aero_table,
/// "decoy-aero.csv", is the built-in table unless the working directory has a
/// file of that name).
#[pyfunction]
fn builtin_config(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let table: toml::Table = toml::from_str(decoy_config::BUILTIN_TOML)
        .map_err(|e| errors::ConfigError::new_err(e.to_string()))?;
    convert::table_to_py(py, &table)
}

/// A shipped scenario (SCENARIOS) as a dict of its keys: edit it and pass it
/// to simulate(). An unknown name raises ScenarioError.
#[pyfunction]
fn builtin_scenario<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
    let text = BUILTIN_SCENARIOS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, text)| *text)
        .ok_or_else(|| {
            let unknown = SimError::UnknownScenario {
                name: name.to_owned(),
                available: Scenario::builtin_names(),
            };
            sim_error(py, &unknown)
        })?;
    let table: toml::Table =
        toml::from_str(text).map_err(|e| errors::ScenarioError::new_err(e.to_string()))?;
    convert::table_to_py(py, &table)
}

/// The module `decoy._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<Simulation>()?;
    m.add_function(wrap_pyfunction!(trim, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(builtin_config, m)?)?;
    m.add_function(wrap_pyfunction!(builtin_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(envelope::envelope_plan, m)?)?;
    m.add_function(wrap_pyfunction!(envelope::envelope_cell, m)?)?;
    m.add_function(wrap_pyfunction!(envelope::envelope_pending, m)?)?;
    m.add_function(wrap_pyfunction!(envelope::envelope_store, m)?)?;
    m.add_function(wrap_pyfunction!(envelope::envelope_map, m)?)?;
    let names: Vec<&str> = BUILTIN_SCENARIOS.iter().map(|(n, _)| *n).collect();
    m.add("SCENARIOS", PyTuple::new(m.py(), names)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
