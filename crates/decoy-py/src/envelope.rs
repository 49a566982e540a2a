//! The manoeuvre envelope map's primitives (`decoy_studies::envelope`), which
//! `python/decoy/_envelope.py` composes into `decoy.envelope()`: a map's plan
//! (its `inputs.json` text), one cell of it (what a Ray task runs), the cells a
//! directory still lacks, a cell stored there, and the map made (the cells
//! left mapped on threads, the outputs written) with `decoy envelope --json`'s
//! dict as the result.

use std::path::PathBuf;

use decoy_schema::Manoeuvre;
use decoy_sim::SimError;
use decoy_studies::envelope::{
    Cell, EnvelopePlan, EnvelopeRequest, EnvelopeSpec, map_cell, map_envelope, pending_cells,
    store_cell,
};
use pyo3::prelude::*;

use crate::args::{load_config_for_mapping, segment_count};
use crate::errors::{InputError, sim_error};
use crate::{convert, worker};

/// The plan of a map: `decoy envelope`'s flags as keyword arguments, the
/// defaults filled in and checked; returns its `inputs.json` text.
#[pyfunction]
#[pyo3(signature = (
    manoeuvre, *, altitudes=None, machs=None, segments=None, grading=None, onset=None,
    tolerance=None, mach_gain=None, config=None
))]
#[allow(clippy::too_many_arguments)]
pub fn envelope_plan(
    py: Python<'_>,
    manoeuvre: &str,
    altitudes: Option<Vec<f64>>,
    machs: Option<Vec<f64>>,
    segments: Option<i64>,
    grading: Option<f64>,
    onset: Option<f64>,
    tolerance: Option<f64>,
    mach_gain: Option<f64>,
    config: Option<&Bound<'_, PyAny>>,
) -> PyResult<String> {
    let kind = Manoeuvre::from_name(manoeuvre)
        .filter(|m| {
            matches!(
                m,
                Manoeuvre::PullUp | Manoeuvre::Turn | Manoeuvre::Acceleration
            )
        })
        .ok_or_else(|| {
            InputError::new_err(format!(
                "envelope: --manoeuvre must be pull-up, turn or acceleration, got {manoeuvre:?}"
            ))
        })?;
    let config = load_config_for_mapping(config)?;
    let request = EnvelopeRequest {
        altitudes_m: altitudes,
        machs,
        segments: segment_count(segments)?,
        grading,
        onset_s: onset,
        tolerance,
        mach_gain,
    };
    EnvelopeSpec::new(&config, kind, &request)
        .and_then(|spec| EnvelopePlan::new(&config, &spec))
        .and_then(|plan| plan.to_json())
        .map_err(|e| sim_error(py, &e))
}

/// The plan of `inputs.json`'s text.
fn plan_of(py: Python<'_>, plan: &str) -> PyResult<EnvelopePlan> {
    EnvelopePlan::from_json(plan).map_err(|e| sim_error(py, &e))
}

/// Maps cell `index` (grid order) of `plan` with the GIL released; returns
/// the cell as JSON (for envelope_store).
#[pyfunction]
pub fn envelope_cell(py: Python<'_>, plan: &str, index: usize) -> PyResult<String> {
    let plan = plan_of(py, plan)?;
    let cell = worker::solve(py, |_stop| map_cell(&plan, index))?.map_err(|e| sim_error(py, &e))?;
    serde_json::to_string(&cell).map_err(|e| InputError::new_err(e.to_string()))
}

/// Prepares `out` for `plan` (its inputs.json written, or checked to be the
/// plan's) and returns the cells it lacks, in grid order, and the cells in all.
#[pyfunction]
pub fn envelope_pending(py: Python<'_>, plan: &str, out: PathBuf) -> PyResult<(Vec<usize>, usize)> {
    let plan = plan_of(py, plan)?;
    let pending = pending_cells(&plan, &out).map_err(|e| sim_error(py, &e))?;
    Ok((pending, plan.spec.conditions().len()))
}

/// Writes `cell` (envelope_cell's JSON) as cell `index` of `plan` into `out`,
/// atomically.
#[pyfunction]
pub fn envelope_store(
    py: Python<'_>,
    plan: &str,
    out: PathBuf,
    index: usize,
    cell: &str,
) -> PyResult<()> {
    let plan = plan_of(py, plan)?;
    let cell: Cell = serde_json::from_str(cell).map_err(|e| {
        sim_error(
            py,
            &SimError::invalid("envelope", "cell", format!("is not a cell ({e})")),
        )
    })?;
    store_cell(&plan, &out, index, &cell).map_err(|e| sim_error(py, &e))
}

/// Makes the map of `plan` on `workers` threads (default: the machine's
/// cores) with the GIL released: into `out` when given (resuming the cells it
/// holds, and with `outputs`, writing envelope.json, envelope.csv,
/// summary.txt and limit.png/.svg there); `progress(done, total)` is called
/// after each cell. Returns `decoy envelope --json`'s dict.
#[pyfunction]
#[pyo3(signature = (plan, *, workers=None, out=None, outputs=true, progress=None))]
pub fn envelope_map(
    py: Python<'_>,
    plan: &str,
    workers: Option<i64>,
    out: Option<PathBuf>,
    outputs: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Py<PyAny>> {
    let plan = plan_of(py, plan)?;
    let workers = match workers {
        None => std::thread::available_parallelism()
            .map(usize::from)
            .unwrap_or(1),
        Some(n) if n >= 1 => usize::try_from(n).unwrap_or(usize::MAX),
        Some(n) => {
            return Err(InputError::new_err(format!(
                "command line: --workers must be at least 1, got {n}"
            )));
        }
    };
    // The callback runs on the mapping threads; its exception is kept (the
    // first), and raised once the map is made.
    let failure: std::sync::Mutex<Option<PyErr>> = std::sync::Mutex::new(None);
    let report = |done: usize, all: usize| {
        if let Some(callback) = &progress {
            Python::attach(|py| {
                if let Err(e) = callback.call1(py, (done, all))
                    && let Ok(mut f) = failure.lock()
                {
                    f.get_or_insert(e);
                }
            });
        }
    };
    let made = worker::solve(py, |_stop| {
        let map = map_envelope(&plan.config, &plan.spec, workers, out.as_deref(), &report)?;
        if let (Some(dir), true) = (&out, outputs) {
            map.write_outputs(dir)?;
        }
        Ok::<_, SimError>(map)
    })?;
    if let Some(e) = failure.into_inner().ok().flatten() {
        return Err(e);
    }
    let map = made.map_err(|e| sim_error(py, &e))?;
    Ok(convert::json_to_py(py, &map.json())?.unbind())
}
