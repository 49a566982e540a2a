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
use crate::format::{format_time, round_time};
use crate::management::ManagementTrack;
use crate::options::{InitialState, RunOptions};
use crate::plots::PLOT_NAMES;
use crate::record::{
    CsvFile, Recorded, Recorder, SAMPLE_INTERVAL_S, SNAPSHOT_INTERVAL_S, Sample, Snapshot, Stop,
    format_step, probe,
};
use crate::scenario::{RunPlan, Scenario};
use crate::steps::Marks;
use crate::summary::{RunIdentity, StepsTaken, Summary, measured};

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

/// A run with its rows and cable snapshots in memory ([`simulate_recorded`]):
/// what `timeseries.csv`, `cable.csv` and `summary.json` hold, whether or not
/// they were written.
#[derive(Debug)]
pub struct Recording {
    /// `summary.json`'s contents (with `stopped` when the run ended early).
    pub summary: Summary,
    /// The rows of `timeseries.csv`, in time order.
    pub samples: Vec<Sample>,
    /// The snapshots of `cable.csv`, in time order.
    pub snapshots: Vec<Snapshot>,
    /// Every file written, in order (none for a run kept in memory only).
    pub files: Vec<PathBuf>,
    /// The checked plan the run followed.
    pub plan: RunPlan,
    /// Why the run ended early, as [`simulate_until`] returns it then
    /// ([`SimError::Stopped`] or [`SimError::Interrupted`]); `None` when it
    /// flew to its end.
    pub ended: Option<SimError>,
}

/// Integrates from the solver's state to the plan's end along its timeline
/// ([`crate::steps`]: the step rule, the output times, the profile's breakpoints),
/// recording every state with `recorder`; `progress` gets the fraction of the
/// simulated time done now and then, and `stop` is asked before every step
/// whether to stop there (`Some`: why, [`simulate_until`]). Returns why it
/// stopped early, if it did (the recorder then holds every state up to the last
/// good one).
///
/// Each state is evaluated once ([`Solver::outputs`]): the recorder measures it,
/// its wave-speed rate sets the next step ([`solver_core::Outputs::wave_rate`]),
/// and the step reuses the evaluation as its first stage. Each step ends at a time
/// the timeline gives ([`Solver::step_to`]), so the clock never drifts.
pub(crate) fn integrate<const N: usize>(
    solver: &mut Solver<f64, N>,
    plan: &RunPlan,
    recorder: &mut Recorder<'_>,
    mut progress: impl FnMut(f64),
    stop: &dyn Fn() -> Option<&'static str>,
) -> Result<Option<Stop>, SimError> {
    let path = &plan.profile;
    let timeline = &plan.timeline;
    let rule = timeline.rule();
    let mut cursor = timeline.cursor();
    let mut marks = Marks::START;
    // Progress at most a thousand times.
    let progress_step = timeline.t_end() / 1000.0;
    let mut next_progress = 0.0;
    // The accuracy bound of the next step from the last step's error (adaptive).
    let mut accuracy = f64::INFINITY;

    // The initial state.
    let mut rate = match solver.outputs(path) {
        Ok(out) => {
            if let Some(failed) = recorder.record(0, &out, marks)? {
                return Err(SimError::Initial(
                    failed.source.unwrap_or(SolveError::NonFinite { joint: 0 }),
                ));
            }
            out.wave_rate()
        }
        Err(e) => return Err(SimError::Initial(e)),
    };
    let mut k: u64 = 0;
    let stopped = loop {
        if cursor.finished() {
            break None;
        }
        if cursor.t() >= next_progress {
            progress(cursor.t() / timeline.t_end());
            next_progress = cursor.t() + progress_step;
        }
        // A stop request ends the run at this step boundary (the state just
        // recorded; `finish` makes it a row and a snapshot like any last state).
        if let Some(requested) = stop() {
            break Some(Stop::requested(requested));
        }
        // The next step: the rule's limit (and the accuracy bound), up to the next
        // stop of the timeline; an adaptive step whose error is too large, or that
        // fails, is undone and taken again shorter.
        let mut limit = rule.allowed(rate).min(accuracy);
        let taken = loop {
            let end = match cursor.next(limit) {
                Ok(end) => end,
                Err(short) => {
                    break Err(Stop::failure(
                        format!(
                            "the step rule asks for steps of {} s at t = {} s, shorter than {} s: the state diverged (or the model's shortest segment is too short for its tension; --dt forces a step)",
                            format_step(short.allowed),
                            format_time(cursor.t()),
                            format_step(crate::steps::MIN_STEP_S)
                        ),
                        None,
                    ));
                }
            };
            let dt = end.t - cursor.t();
            recorder.note_step(dt);
            let adaptive = rule.fixed_step().is_none();
            match solver.step_to_checked(path, end.t) {
                Ok(step) => {
                    let ratio = crate::steps::error_ratio(&step.error());
                    // A NaN ratio (a non-finite estimate) fails the step too.
                    if adaptive && (ratio > 1.0 || ratio.is_nan()) {
                        step.undo();
                        recorder.note_rejection();
                        limit = dt * crate::steps::shrink(ratio);
                        continue;
                    }
                    if adaptive {
                        accuracy = dt * crate::steps::grow(ratio);
                    }
                    recorder.note_accepted(dt);
                    break Ok((end, step.accept()));
                }
                Err(e) if adaptive => {
                    recorder.note_rejection();
                    limit = dt * crate::steps::SHRINK_ON_FAILURE;
                    recorder.last_failure = Some(e);
                }
                Err(e) => break Err(Stop::failure(stop_reason(&e, dt), Some(e))),
            }
        };
        let (end, outputs) = match taken {
            Ok(taken) => taken,
            Err(stop) => break Some(stop),
        };
        cursor.advance(&end);
        marks = end.marks;
        k += 1;
        match outputs {
            Ok(out) => {
                if let Some(failed) = recorder.record(k, &out, marks)? {
                    break Some(failed);
                }
                rate = out.wave_rate();
            }
            Err(e) => break Some(Stop::failure(stop_reason(&e, recorder.last_step), Some(e))),
        }
    };
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
    let out_dir = options
        .out_dir
        .clone()
        .unwrap_or_else(|| Path::new("out").join(&plan.name));
    let recording = with_capacity!(plan.layout.count(), N => simulate_with::<N>(config, plan, Some(&out_dir), options, progress, &stop, wall))?;
    if let Some(e) = recording.ended {
        return Err(e);
    }
    Ok(RunOutput {
        summary: recording.summary,
        out_dir,
        files: recording.files,
        plan: recording.plan,
    })
}

/// [`simulate_until`] keeping the run in memory: the rows of `timeseries.csv`
/// and the snapshots of `cable.csv` as values, with the summary, whether or
/// not they are written (the `decoy` Python package's `simulate`). The files
/// are written only when `options.out_dir` names a directory (then the same
/// files as [`simulate`], the plots with `options.plots`); `None` writes
/// nothing (where [`simulate`] writes `out/NAME`).
///
/// A run that ends early is still a [`Recording`] (up to its last good state,
/// `summary.stopped` saying why, [`Recording::ended`] the error
/// [`simulate_until`] returns then); a run that cannot start (no trim, an
/// initial state that cannot be evaluated) is the error.
pub fn simulate_recorded(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &RunOptions,
    progress: impl FnMut(f64),
    stop: impl Fn() -> Option<&'static str>,
) -> Result<Recording, SimError> {
    let wall = Instant::now();
    let plan = scenario.plan(config, options)?;
    let out_dir = options.out_dir.clone();
    with_capacity!(plan.layout.count(), N => simulate_with::<N>(config, plan, out_dir.as_deref(), options, progress, &stop, wall))
}

/// A run with a model of capacity `N`, writing its files to `out_dir` when
/// there is one ([`simulate_until`], [`simulate_recorded`]).
fn simulate_with<const N: usize>(
    config: &SystemConfig,
    plan: RunPlan,
    out_dir: Option<&Path>,
    options: &RunOptions,
    progress: impl FnMut(f64),
    stop: &dyn Fn() -> Option<&'static str>,
    wall: Instant,
) -> Result<Recording, SimError> {
    let model: Model<f64, N> = config.model(plan.layout)?;
    let n = model.segment_count();
    let probe = probe(config, &model, plan.lateral_sign);

    let csv_files = match out_dir {
        Some(out_dir) => {
            std::fs::create_dir_all(out_dir).map_err(|source| SimError::Io {
                action: "create the directory",
                path: out_dir.to_owned(),
                source,
            })?;
            clear_output_dir(out_dir)?;
            Some((
                CsvFile::create(out_dir.join("timeseries.csv"), &SIMULATE_TIMESERIES)?,
                CsvFile::create(out_dir.join("cable.csv"), &SIMULATE_CABLE)?,
            ))
        }
        None => None,
    };
    let mut recorder = Recorder::new(
        &plan,
        probe,
        csv_files,
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
    let (steps, rejected, step_range) = (recorder.steps, recorder.rejected, recorder.step_range);
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
        dt: plan.timeline.rule().fixed_step(),
        t_end: plan.t_end,
        steps: Some(StepsTaken {
            rule: plan.timeline.rule().name().to_owned(),
            count: steps,
            rejected,
            min_s: if steps > 0 { step_range.0 } else { 0.0 },
            max_s: step_range.1,
        }),
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
    let mut files = Vec::new();
    if let Some(out_dir) = out_dir {
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
        files.extend([
            out_dir.join("timeseries.csv"),
            out_dir.join("cable.csv"),
            summary_path,
        ]);
    }

    if let Some(e) = not_started {
        return Err(e);
    }
    if let (Some(out_dir), true) = (out_dir, options.plots) {
        let recorded = Recorded {
            samples: &samples,
            snapshots: &snapshots,
        };
        files.extend(crate::plots::write_all(&recorded, &plan, config, out_dir)?);
    }

    let ended = stopped.map(|stop| {
        let t_s = round_time(last.t);
        let out_dir = out_dir.map(Path::to_owned);
        match stop.requested {
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
        }
    });
    Ok(Recording {
        summary,
        samples,
        snapshots,
        files,
        plan,
        ended,
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
fn stop_reason(e: &SolveError, step: f64) -> String {
    match e {
        SolveError::NonFinite { .. } | SolveError::NonPositivePivot { .. } => format!(
            "the state diverged ({e}) in a step of {} s",
            format_step(step)
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
            let out_dir = options.out_dir.clone().unwrap();
            let out = if capacity == SMALL_CAPACITY {
                simulate_with::<SMALL_CAPACITY>(
                    &config,
                    plan,
                    Some(&out_dir),
                    &options,
                    |_| {},
                    &|| None,
                    Instant::now(),
                )
            } else {
                simulate_with::<MAX_SEGMENTS>(
                    &config,
                    plan,
                    Some(&out_dir),
                    &options,
                    |_| {},
                    &|| None,
                    Instant::now(),
                )
            };
            assert!(out.unwrap().ended.is_none());
            std::fs::read(out_dir.join("timeseries.csv")).unwrap()
        };
        let small = run(SMALL_CAPACITY);
        let large = run(MAX_SEGMENTS);
        let _ = std::fs::remove_dir_all(&dir);
        assert!(small == large);
    }

    /// A run kept in memory is the run `simulate` writes: its rows and
    /// snapshots are the files' rows, its summary the file's (but for the wall
    /// time), and it writes nothing. One that diverges is still a recording,
    /// whose error names no directory.
    #[test]
    fn a_recording_is_the_written_run() {
        use decoy_schema::columns::{SIMULATE_CABLE, SIMULATE_TIMESERIES};
        let config = SystemConfig::builtin().unwrap();
        let scenario = Scenario::builtin("pull-up").unwrap();
        let dir = std::env::temp_dir().join(format!("decoy-sim-recording-{}", std::process::id()));
        let options = RunOptions {
            segments: Some(8),
            t_end: Some(2.5),
            out_dir: Some(dir.clone()),
            plots: false,
            ..RunOptions::default()
        };
        let written = simulate(&config, &scenario, &options, |_| {}).unwrap();
        let in_memory = RunOptions {
            out_dir: None,
            ..options.clone()
        };
        let recording = simulate_recorded(&config, &scenario, &in_memory, |_| {}, || None).unwrap();
        assert!(recording.files.is_empty() && recording.ended.is_none());
        let wall = |mut s: Summary| {
            s.wall_s = 0.0;
            s
        };
        assert_eq!(wall(recording.summary.clone()), wall(written.summary));
        let mut timeseries = format!("{}\n", SIMULATE_TIMESERIES.header());
        for sample in &recording.samples {
            timeseries.push_str(&crate::csv_row(&SIMULATE_TIMESERIES, |q| sample.cell(q)));
        }
        let mut cable = format!("{}\n", SIMULATE_CABLE.header());
        for snapshot in &recording.snapshots {
            for j in 0..snapshot.joints.len() {
                cable.push_str(&crate::csv_row(&SIMULATE_CABLE, |q| snapshot.cell(j, q)));
            }
        }
        let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
        assert!(timeseries == read("timeseries.csv"));
        assert!(cable == read("cable.csv"));

        let diverging = RunOptions {
            dt: Some(0.5),
            t_end: Some(10.0),
            ..in_memory
        };
        let stopped = simulate_recorded(&config, &scenario, &diverging, |_| {}, || None).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let t_s = stopped.summary.stopped.as_ref().unwrap().t_s;
        let Some(e @ SimError::Stopped { out_dir: None, .. }) = &stopped.ended else {
            panic!("{:?}", stopped.ended);
        };
        assert!(
            e.to_string()
                .starts_with(&format!("simulation stopped at t = {t_s} s: ")),
            "{e}"
        );
        assert!(!e.to_string().contains("outputs"), "{e}");
        assert_eq!(
            stopped.samples.last().unwrap().t,
            stopped.snapshots.last().unwrap().t
        );
    }
}
