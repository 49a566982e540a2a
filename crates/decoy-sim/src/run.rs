//! [`simulate`]: one run of a scenario, from the initial state to the files.

use std::path::{Path, PathBuf};
use std::time::Instant;

use decoy_config::SystemConfig;
use decoy_plots::atomic::{partial_path, write_atomically};
use decoy_schema::columns::{SIMULATE_CABLE, SIMULATE_TIMESERIES};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use solver_core::{AircraftState, Model, SolveError, Solver, State, trim};

use crate::capacity::with_capacity;
use crate::error::SimError;
use crate::format::round_time;
use crate::management::ManagementTrack;
use crate::options::{InitialState, RunOptions};
use crate::plots::PLOT_NAMES;
use crate::record::{
    CsvFile, Recorded, Recorder, SAMPLE_INTERVAL_S, SNAPSHOT_INTERVAL_S, Sample, Stop, probe,
};
use crate::scenario::{RunPlan, Scenario};
use crate::summary::{RunIdentity, Summary, measured};

/// What a finished run produced.
#[derive(Clone, Debug, PartialEq)]
pub struct RunOutput {
    /// `summary.json`'s contents.
    pub summary: Summary,
    /// The output directory.
    pub out_dir: PathBuf,
    /// Every file written, in order.
    pub files: Vec<PathBuf>,
    /// The checked plan the run followed.
    pub plan: RunPlan,
}

/// Integrates `plan.steps` steps from the solver's state, recording every
/// evaluated state with `recorder`; `progress` gets the fraction done now and
/// then, and `stop` is asked before every step whether to stop there (`Some`:
/// why, [`simulate_until`]). Returns why it stopped early, if it did (the
/// recorder then holds every state up to the last good one).
pub(crate) fn integrate<const N: usize>(
    solver: &mut Solver<f64, N>,
    plan: &RunPlan,
    recorder: &mut Recorder<'_>,
    mut progress: impl FnMut(f64),
    stop: &dyn Fn() -> Option<&'static str>,
) -> Result<Option<Stop>, SimError> {
    let path = &plan.profile;
    let steps = plan.steps;
    let initial = match solver.outputs(path) {
        Ok(out) => recorder.record(0, &out)?,
        Err(e) => return Err(SimError::Initial(e)),
    };
    if let Some(stop) = initial {
        return Err(SimError::Initial(
            stop.source.unwrap_or(SolveError::NonFinite { joint: 0 }),
        ));
    }
    progress(0.0);

    let progress_every = (steps / 1000).max(1);
    let mut stopped: Option<Stop> = None;
    for k in 1..=steps {
        // A stop request ends the run at this step boundary: at the state after
        // step k - 1, recorded here (step k's first stage would have recorded it).
        if let Some(requested) = stop() {
            if k > 1 {
                // This state ends the run: recorded as the last one is (a row,
                // a cable snapshot, the management's observation).
                recorder.steps = k - 1;
                stopped = match solver.outputs(path) {
                    Ok(out) => recorder.record(k - 1, &out)?,
                    Err(e) => Some(Stop::failure(stop_reason(&e, plan.dt), Some(e))),
                };
            }
            // A state that proves unusable is the failure it is, not the request.
            stopped.get_or_insert(Stop::requested(requested));
            break;
        }
        // The observer sees the state after step k - 1 (step 0 is recorded above).
        let mut observed = Ok(None);
        let stepped = solver.step_observed(path, plan.dt, |out| {
            if k > 1 {
                observed = recorder.record(k - 1, out);
            }
        });
        if let Some(stop) = observed? {
            stopped = Some(stop);
            break;
        }
        if let Err(e) = stepped {
            stopped = Some(Stop::failure(stop_reason(&e, plan.dt), Some(e)));
            break;
        }
        if k.is_multiple_of(progress_every) {
            progress(k as f64 / steps as f64);
        }
    }
    if stopped.is_none() {
        stopped = match solver.outputs(path) {
            Ok(out) => recorder.record(steps, &out)?,
            Err(e) => Some(Stop::failure(stop_reason(&e, plan.dt), Some(e))),
        };
    }
    recorder.finish()?;
    if stopped.is_none() {
        progress(1.0);
    }
    Ok(stopped)
}

/// Runs `scenario` on the system `config` with the overrides in `options` and
/// writes `timeseries.csv`, `cable.csv`, `summary.json` and (with
/// `options.plots`) the plots to the output directory. `progress` is called with
/// the fraction of steps done (0 to 1) now and then.
///
/// The model is a `Model<f64, 512>` (a `Model<f64, 32>` for up to 32 segments,
/// which gives the same numbers with less to copy); the initial state the trim of the flight
/// condition at t = 0 (or a straight cable, [`InitialState::Straight`]). Every
/// step's state is measured, from RK4's own first-stage evaluation;
/// `timeseries.csv` gets a row every
/// [`SAMPLE_INTERVAL_S`], `cable.csv` a snapshot every [`SNAPSHOT_INTERVAL_S`],
/// both the final state.
///
/// On a failure while stepping (the state diverged, the recurrence met a
/// non-positive pivot, the aircraft left the atmosphere) the CSV files hold every
/// row up to the last good state, `summary.json` records `"stopped"`, the plots
/// are drawn from what there is, and the result is [`SimError::Stopped`].
///
/// The output directory holds only this run's files: before the run starts,
/// [`clear_output_dir`] removes those an earlier run of any command left there.
/// Every file is written under a temporary name and renamed when complete
/// ([`decoy_plots::atomic`]), so none is ever half-written.
pub fn simulate(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &RunOptions,
    progress: impl FnMut(f64),
) -> Result<RunOutput, SimError> {
    simulate_until(config, scenario, options, progress, || None)
}

/// [`simulate`], stopping early when `stop` asks to: it is called before every
/// step, and a `Some(signal)` (the command line passes the name of the signal
/// it received, `SIGINT` or `SIGTERM`) ends the run at that step boundary as a
/// failure would, but for its result: the CSV files hold every state up to
/// then, `summary.json`'s `stopped` has that time and the reason `interrupted
/// by SIGNAL`, the plots are
/// drawn from what was flown, and the result is [`SimError::Interrupted`].
///
/// The library installs no signal handler: the caller decides what `stop`
/// watches (an `AtomicBool` or a signal flag, read with one load).
pub fn simulate_until(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &RunOptions,
    progress: impl FnMut(f64),
    stop: impl Fn() -> Option<&'static str>,
) -> Result<RunOutput, SimError> {
    let wall = Instant::now();
    let plan = scenario.plan(config, options)?;
    with_capacity!(plan.layout.count(), N => simulate_with::<N>(config, plan, options, progress, &stop, wall))
}

/// [`simulate_until`] with a model of capacity `N`.
fn simulate_with<const N: usize>(
    config: &SystemConfig,
    plan: RunPlan,
    options: &RunOptions,
    progress: impl FnMut(f64),
    stop: &dyn Fn() -> Option<&'static str>,
    wall: Instant,
) -> Result<RunOutput, SimError> {
    let out_dir = options
        .out_dir
        .clone()
        .unwrap_or_else(|| Path::new("out").join(&plan.name));
    let model: Model<f64, N> = config.model(plan.layout)?;
    let n = model.segment_count();
    let probe = probe(config, &model, plan.lateral_sign);

    std::fs::create_dir_all(&out_dir).map_err(|source| SimError::Io {
        action: "create the directory",
        path: out_dir.clone(),
        source,
    })?;
    clear_output_dir(&out_dir)?;
    let timeseries_path = out_dir.join("timeseries.csv");
    let cable_path = out_dir.join("cable.csv");
    let files = (
        CsvFile::create(timeseries_path.clone(), &SIMULATE_TIMESERIES)?,
        CsvFile::create(cable_path.clone(), &SIMULATE_CABLE)?,
    );
    let mut recorder = Recorder::new(
        &plan,
        probe,
        Some(files),
        SAMPLE_INTERVAL_S,
        SNAPSHOT_INTERVAL_S,
    );
    recorder.management = ManagementTrack::new(config);
    // A run that cannot start (no trim, an initial state that cannot be
    // evaluated) still leaves a summary that says so.
    let started = initial_solver(model, options.initial, &plan)
        .and_then(|mut solver| integrate(&mut solver, &plan, &mut recorder, progress, stop));
    let (stopped, not_started) = match started {
        Ok(stopped) => (stopped, None),
        Err(e @ (SimError::NoTrim(_) | SimError::Initial(_))) => (
            Some(Stop::failure(format!("the run could not start: {e}"), None)),
            Some(e),
        ),
        Err(e) => return Err(e),
    };
    let recorded_any = recorder.recorded_any;
    let Recorder {
        timeseries,
        cable,
        statistics,
        samples,
        snapshots,
        last,
        ..
    } = recorder;
    // The CSV files get their names, complete.
    for csv in [timeseries, cable].into_iter().flatten() {
        csv.finish()?;
    }

    let identity = RunIdentity {
        scenario: &plan.name,
        segments: n,
        dt: plan.dt,
        t_end: plan.t_end,
    };
    // Without a recorded state the final values are unknown (`null`).
    let last = if recorded_any {
        last
    } else {
        Sample::unknown()
    };
    let summary = measured(
        &identity,
        &statistics,
        &samples,
        &last,
        wall.elapsed().as_secs_f64(),
        stopped.as_ref().map(|stop| stop.reason.clone()),
    );
    let summary_path = out_dir.join("summary.json");
    let mut json = serde_json::to_string_pretty(&summary).map_err(|e| SimError::Io {
        action: "write",
        path: summary_path.clone(),
        source: std::io::Error::other(e),
    })?;
    json.push('\n');
    write_atomically(&summary_path, json.as_bytes()).map_err(|source| SimError::Io {
        action: "write",
        path: summary_path.clone(),
        source,
    })?;
    let mut files = vec![timeseries_path, cable_path, summary_path];

    if let Some(e) = not_started {
        return Err(e);
    }
    if options.plots {
        let recorded = Recorded {
            samples: &samples,
            snapshots: &snapshots,
        };
        files.extend(crate::plots::write_all(&recorded, &plan, config, &out_dir)?);
    }

    if let Some(stop) = stopped {
        let t_s = round_time(last.t);
        return Err(match stop.requested {
            Some(signal) => SimError::Interrupted {
                t_s,
                signal,
                out_dir,
            },
            None => SimError::Stopped {
                t_s,
                reason: stop.reason,
                source: stop.source,
                out_dir,
            },
        });
    }
    Ok(RunOutput {
        summary,
        out_dir,
        files,
        plan,
    })
}

/// The solver at the run's initial state: the trim of the flight condition at
/// t = 0 ([`SimError::NoTrim`] when there is none) or the straight cable.
fn initial_solver<const N: usize>(
    model: Model<f64, N>,
    initial: InitialState,
    plan: &RunPlan,
) -> Result<Box<Solver<f64, N>>, SimError> {
    let aircraft = plan.profile.initial_condition();
    let state = match initial {
        InitialState::Trim => trim(&model, &aircraft).map_err(SimError::NoTrim)?,
        InitialState::Straight => straight_state(&model, &aircraft),
    };
    Ok(Box::new(
        Solver::new(model, state).map_err(SimError::Initial)?,
    ))
}

/// `decoy hil`'s firmware log (the decoded defmt log of the run), in its output
/// directory.
pub const FIRMWARE_LOG: &str = "firmware.log";

/// The file stem of `decoy hil`'s instruction-count plot.
pub const INSTRUCTIONS_PLOT: &str = "instructions";

/// The names of every file `decoy simulate` writes into its output directory.
pub fn output_file_names() -> Vec<String> {
    let mut names: Vec<String> = ["timeseries.csv", "cable.csv", "summary.json"]
        .map(str::to_owned)
        .to_vec();
    for stem in PLOT_NAMES {
        names.extend(["png", "svg"].map(|ext| format!("{stem}.{ext}")));
    }
    names
}

/// The names of every file a run writes into its output directory, whichever
/// command it is (`decoy simulate`'s [`output_file_names`], and those of `decoy
/// hil` and `decoy feed` it does not write: [`FIRMWARE_LOG`] and the
/// [`INSTRUCTIONS_PLOT`]; their other files have `simulate`'s names).
pub fn known_output_file_names() -> Vec<String> {
    let mut names = output_file_names();
    names.push(FIRMWARE_LOG.to_owned());
    names.extend(["png", "svg"].map(|ext| format!("{INSTRUCTIONS_PLOT}.{ext}")));
    names
}

/// Prepares `dir` for a run: removes every file of [`known_output_file_names`]
/// that an earlier run (of any command) left there, and their partial files
/// (`NAME.partial`, [`decoy_plots::atomic`]) of a run killed while writing, so
/// that the directory holds only the new run's files and no earlier summary can
/// be taken for its own, even if the new run fails before it writes one. Any
/// other file stays. A directory that does not exist is left so.
///
/// Every command that writes an output directory calls this before its run
/// starts (after its options are checked).
pub fn clear_output_dir(dir: &Path) -> Result<(), SimError> {
    for name in known_output_file_names() {
        let path = dir.join(name);
        for path in [partial_path(&path), path] {
            match std::fs::remove_file(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(source) => {
                    return Err(SimError::Io {
                        action: "remove the previous run's",
                        path,
                        source,
                    });
                }
            }
        }
    }
    Ok(())
}

/// Why stepping stopped, in words.
fn stop_reason(e: &SolveError, dt: f64) -> String {
    match e {
        SolveError::NonFinite { .. } | SolveError::NonPositivePivot { .. } => format!(
            "the state diverged ({e}); is the time step {dt} s too long for this discretisation?"
        ),
        SolveError::Input(input) => format!("the aircraft state is unusable: {input}"),
        other => other.to_string(),
    }
}

/// Every segment along the air's velocity relative to the connection point, the
/// decoy aligned with the flight direction, wings level, nothing rotating.
pub(crate) fn straight_state<const N: usize>(
    model: &Model<f64, N>,
    aircraft: &AircraftState<f64>,
) -> State<f64, N> {
    let params = model.params();
    let connection = aircraft.point(&params.connection_point);
    let relative_air = params.environment.wind - connection.velocity;
    let trailing = if relative_air.norm() > 1e-9 {
        relative_air.normalize()
    } else {
        Vector3::z()
    };
    let mut state = State::<f64, N>::default();
    for e in &mut state.directions[..model.segment_count()] {
        *e = trailing;
    }
    let x = -trailing;
    let right = Vector3::z().cross(&x);
    let y = if right.norm() > 1e-9 {
        right.normalize()
    } else {
        Vector3::y()
    };
    let z = x.cross(&y);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
        Matrix3::from_columns(&[x, y, z]),
    ));
    state.decoy_attitude = [q.w, q.i, q.j, q.k];
    state
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::capacity::{MAX_SEGMENTS, SMALL_CAPACITY};

    #[test]
    fn model_capacity_does_not_change_the_numbers() {
        let config = SystemConfig::builtin().unwrap();
        let scenario = Scenario::builtin("turn").unwrap();
        let dir = std::env::temp_dir().join(format!("decoy-sim-capacity-{}", std::process::id()));
        let run = |capacity: usize| {
            let options = RunOptions {
                segments: Some(16),
                grading: Some(1.3),
                t_end: Some(0.3),
                out_dir: Some(dir.join(capacity.to_string())),
                plots: false,
                ..RunOptions::default()
            };
            let plan = scenario.plan(&config, &options).unwrap();
            let out = if capacity == SMALL_CAPACITY {
                simulate_with::<SMALL_CAPACITY>(
                    &config,
                    plan,
                    &options,
                    |_| {},
                    &|| None,
                    Instant::now(),
                )
            } else {
                simulate_with::<MAX_SEGMENTS>(
                    &config,
                    plan,
                    &options,
                    |_| {},
                    &|| None,
                    Instant::now(),
                )
            };
            std::fs::read(out.unwrap().out_dir.join("timeseries.csv")).unwrap()
        };
        let small = run(SMALL_CAPACITY);
        let large = run(MAX_SEGMENTS);
        let _ = std::fs::remove_dir_all(&dir);
        assert!(small == large);
    }
}
