//! [`simulate`]: one run of a scenario, from the initial state to the files.

use std::fs::File;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use decoy_config::SystemConfig;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use solver_core::{AircraftState, Model, Outputs, SegmentLayout, SolveError, Solver, State, trim};

use crate::error::SimError;
use crate::geometry::{
    Envelope, ExhaustPlume, FlightPathFrame, cable_plume_clearance, envelope_from_config,
    plume_from_config,
};
use crate::profile::FlightProfile;
use crate::scenario::{MAX_SEGMENTS, RunPlan, Scenario};

/// Interval between the rows of `timeseries.csv`, s (every step when `dt` is longer).
pub const SAMPLE_INTERVAL_S: f64 = 0.01;
/// Interval between the cable snapshots of `cable.csv`, s.
pub const SNAPSHOT_INTERVAL_S: f64 = 1.0;
/// Settling band: the connection tension is settled once it stays within this
/// fraction of its final value.
pub const SETTLING_BAND: f64 = 0.02;
/// A settling time is reported only if the tension then stayed in the band for at
/// least this long before the end of the run, s (otherwise it is `null`).
pub const SETTLING_HOLD_S: f64 = 1.0;
/// Most cable snapshots drawn in the `cable-*` and `tension-profile` plots (evenly
/// chosen among those in `cable.csv`, always with the first and the last).
pub const PLOTTED_SNAPSHOTS: usize = 6;

/// Capacity of the model for small segment counts.
const SMALL_CAPACITY: usize = 32;

/// The header of `timeseries.csv` (units in the names; see `docs/outputs.md`).
pub const TIMESERIES_HEADER: &str = "t_s,tension_connection_N,tension_tow_N,decoy_cg_behind_m,decoy_cg_lateral_m,decoy_cg_below_m,decoy_roll_deg,decoy_pitch_deg,decoy_yaw_deg,decoy_aoa_deg,cable_exhaust_clearance_m,cable_exhaust_closest_along_m,decoy_aircraft_clearance_m,aircraft_speed_mps,aircraft_altitude_m";
/// The header of `cable.csv`.
pub const CABLE_HEADER: &str = "t_s,joint,along_m,behind_m,lateral_m,below_m,tension_N";

/// How the run starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InitialState {
    /// The trim (steady equilibrium) of the flight condition at t = 0.
    #[default]
    Trim,
    /// Every segment along the air's velocity relative to the connection point
    /// (the cable trailing straight behind it), the decoy's axis along the flight
    /// direction with its wings level, nothing rotating.
    Straight,
}

/// Overrides of the scenario's values (the command line's flags) and run options.
#[derive(Clone, Debug, PartialEq)]
pub struct RunOptions {
    /// Number of cable segments.
    pub segments: Option<usize>,
    /// Segment length ratio, short at the decoy (1 = uniform).
    pub grading: Option<f64>,
    /// RK4 time step, s.
    pub dt: Option<f64>,
    /// Simulated time, s.
    pub t_end: Option<f64>,
    /// Initial altitude, m.
    pub altitude: Option<f64>,
    /// Initial Mach number.
    pub mach: Option<f64>,
    /// Flight-path rotation rate, rad/s (pull-up, turn).
    pub rate: Option<f64>,
    /// How the run starts.
    pub initial: InitialState,
    /// Output directory (default `out/<scenario name>`, relative to the working directory).
    pub out_dir: Option<PathBuf>,
    /// Draw the plots (PNG + SVG) as well as the CSV and JSON files.
    pub plots: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            segments: None,
            grading: None,
            dt: None,
            t_end: None,
            altitude: None,
            mach: None,
            rate: None,
            initial: InitialState::Trim,
            out_dir: None,
            plots: true,
        }
    }
}

/// `summary.json`'s `"final"`: the last recorded state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FinalValues {
    /// Connection-point tension, N.
    #[serde(rename = "tension_connection_N")]
    pub tension_connection_n: f64,
    /// Towing-point tension, N.
    #[serde(rename = "tension_tow_N")]
    pub tension_tow_n: f64,
    /// Decoy pitch, deg, positive nose-up.
    pub decoy_pitch_deg: f64,
    /// Decoy CG behind the aircraft reference point along the flight path, m.
    pub decoy_cg_behind_m: f64,
    /// Decoy CG below the flight path, m.
    pub decoy_cg_below_m: f64,
    /// Decoy CG beside the flight path, m (positive left, or outside a left turn).
    pub decoy_cg_lateral_m: f64,
}

/// `summary.json`'s `"stopped"`: where and why a run ended early.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoppedAt {
    /// Time of the last good state, s.
    pub t_s: f64,
    /// Why.
    pub reason: String,
}

/// The contents of `summary.json` (see `docs/outputs.md`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// Number of cable segments.
    pub segments: usize,
    /// RK4 time step, s.
    pub dt: f64,
    /// Simulated time asked for, s.
    pub t_end: f64,
    /// Largest connection-point tension over all steps, N.
    #[serde(rename = "max_tension_connection_N")]
    pub max_tension_connection_n: f64,
    /// When it occurred, s.
    pub t_at_max_tension_s: f64,
    /// Half the peak-to-peak decoy pitch from the manoeuvre start on, deg.
    pub pitch_oscillation_amplitude_deg: f64,
    /// Time from which the connection tension stays within 2 % of its final
    /// value, s; `None` (`null`) when it did not settle.
    pub settling_time_s: Option<f64>,
    /// The last recorded state.
    #[serde(rename = "final")]
    pub final_values: FinalValues,
    /// Smallest clearance of the cable (joints and segment midpoints) to the exhaust
    /// plume over the run, m (negative: inside the plume).
    pub min_cable_clearance_to_exhaust_m: f64,
    /// Smallest clearance of the decoy CG to the aircraft's collision envelope, m.
    pub min_decoy_clearance_to_aircraft_m: f64,
    /// Wall-clock time of the run (model, initial state, integration and CSV
    /// output; not the plots), s.
    pub wall_s: f64,
    /// Present when the integration stopped early.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped: Option<StoppedAt>,
}

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

/// The quantities measured at every step (one row of `timeseries.csv`; frames and
/// signs in `docs/outputs.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Simulation time, s.
    pub t: f64,
    /// Connection-point tension (joint 0), N.
    pub tension_connection: f64,
    /// Towing-point tension (joint N), N.
    pub tension_tow: f64,
    /// Decoy CG from the aircraft reference point, flight-path frame: behind,
    /// lateral (positive toward the outside of the scenario's turn, else left),
    /// below, m.
    pub cg: [f64; 3],
    /// Decoy roll, pitch, yaw (unwrapped), deg, relative to NED.
    pub euler_deg: [f64; 3],
    /// Decoy total angle of attack, deg.
    pub aoa_deg: f64,
    /// Smallest distance from the cable to the exhaust plume's surface, m
    /// (negative inside).
    pub exhaust_clearance: f64,
    /// Where on the cable that closest point is, m from the connection point.
    pub exhaust_along: f64,
    /// Decoy CG to the aircraft's collision envelope, m (negative inside).
    pub decoy_clearance: f64,
    /// Aircraft ground speed, m/s.
    pub speed: f64,
    /// Aircraft reference point altitude, m.
    pub altitude: f64,
}

impl Sample {
    fn csv_row(&self) -> String {
        let values = [
            self.tension_connection,
            self.tension_tow,
            self.cg[0],
            self.cg[1],
            self.cg[2],
            self.euler_deg[0],
            self.euler_deg[1],
            self.euler_deg[2],
            self.aoa_deg,
            self.exhaust_clearance,
            self.exhaust_along,
            self.decoy_clearance,
            self.speed,
            self.altitude,
        ];
        let mut row = format_time(self.t);
        for v in values {
            row.push(',');
            row.push_str(&format_value(v));
        }
        row.push('\n');
        row
    }
}

/// One cable snapshot (the rows of `cable.csv` at one time).
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Snapshot time, s.
    pub t: f64,
    /// Per joint, 0 (connection point) to N (towing point): distance along the
    /// cable from the connection point, then behind, lateral and below the
    /// aircraft reference point (flight-path frame), m, and the tension, N.
    pub joints: Vec<[f64; 5]>,
}

/// What the plots are drawn from.
pub(crate) struct Recorded<'a> {
    pub samples: &'a [Sample],
    pub snapshots: &'a [Snapshot],
}

/// The fixed geometry every measurement needs.
pub(crate) struct Probe {
    plume: ExhaustPlume,
    envelope: Envelope,
    lateral_sign: f64,
    /// Distance along the cable of joint j, m.
    pub joint_along: Vec<f64>,
}

impl Probe {
    /// Measures one evaluated state. `previous_yaw` unwraps the yaw angle.
    fn sample<const N: usize>(
        &self,
        out: &Outputs<'_, f64, N>,
        aircraft: &AircraftState<f64>,
        previous_yaw: Option<f64>,
    ) -> Sample {
        let n = out.segment_count();
        let frame = FlightPathFrame::of(aircraft);
        let rotation = aircraft.rotation();
        let to_body =
            |p: &Vector3<f64>| rotation.inverse_transform_vector(&(p - aircraft.position));
        // Joints and segment midpoints, in the order decoy-link numbers them.
        let (exhaust_clearance, at) = cable_plume_clearance(
            &self.plume,
            aircraft,
            (0..=n).map(|j| out.joint_position(j)),
        );
        let exhaust_along = if at % 2 == 0 {
            self.joint_along[at / 2]
        } else {
            0.5 * (self.joint_along[at / 2] + self.joint_along[at / 2 + 1])
        };
        let (cg, euler, aoa, decoy_clearance) = match out.decoy() {
            Some(d) => {
                let c = frame.components(&(d.cg_position - aircraft.position));
                let (roll, pitch, yaw) = d.euler;
                (
                    [-c.x, self.lateral_sign * -c.y + 0.0, c.z],
                    [roll, pitch, yaw],
                    d.angle_of_attack,
                    self.envelope.clearance(&to_body(&d.cg_position)),
                )
            }
            None => ([f64::NAN; 3], [f64::NAN; 3], f64::NAN, f64::NAN),
        };
        let mut yaw = euler[2].to_degrees();
        if let Some(prev) = previous_yaw {
            yaw += 360.0 * ((prev - yaw) / 360.0).round();
        }
        Sample {
            t: out.time(),
            tension_connection: out.connection_tension(),
            tension_tow: out.tow_tension(),
            cg,
            euler_deg: [euler[0].to_degrees(), euler[1].to_degrees(), yaw],
            aoa_deg: aoa.to_degrees(),
            exhaust_clearance,
            exhaust_along,
            decoy_clearance,
            speed: aircraft.velocity.norm(),
            altitude: aircraft.altitude(),
        }
    }

    /// The cable in the flight-path frame, relative to the aircraft reference point.
    fn snapshot<const N: usize>(
        &self,
        out: &Outputs<'_, f64, N>,
        aircraft: &AircraftState<f64>,
    ) -> Snapshot {
        let frame = FlightPathFrame::of(aircraft);
        let joints = (0..=out.segment_count())
            .map(|j| {
                let c = frame.components(&(out.joint_position(j) - aircraft.position));
                [
                    self.joint_along[j],
                    -c.x,
                    self.lateral_sign * -c.y + 0.0,
                    c.z,
                    out.tension(j),
                ]
            })
            .collect();
        Snapshot {
            t: out.time(),
            joints,
        }
    }
}

/// Running statistics for the summary.
pub(crate) struct Statistics {
    manoeuvre_start: f64,
    pub max_tension: f64,
    pub t_at_max: f64,
    pitch_range: Option<(f64, f64)>,
    pitch_range_all: Option<(f64, f64)>,
    pub min_exhaust: f64,
    pub min_decoy: f64,
}

impl Statistics {
    fn new(manoeuvre_start: f64) -> Self {
        Statistics {
            manoeuvre_start,
            max_tension: f64::NEG_INFINITY,
            t_at_max: 0.0,
            pitch_range: None,
            pitch_range_all: None,
            min_exhaust: f64::INFINITY,
            min_decoy: f64::INFINITY,
        }
    }

    fn add(&mut self, s: &Sample) {
        if s.tension_connection > self.max_tension {
            self.max_tension = s.tension_connection;
            self.t_at_max = s.t;
        }
        let widen = |range: Option<(f64, f64)>, v: f64| {
            Some(range.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))))
        };
        let pitch = s.euler_deg[1];
        self.pitch_range_all = widen(self.pitch_range_all, pitch);
        if s.t >= self.manoeuvre_start - 1e-9 {
            self.pitch_range = widen(self.pitch_range, pitch);
        }
        self.min_exhaust = self.min_exhaust.min(s.exhaust_clearance);
        self.min_decoy = self.min_decoy.min(s.decoy_clearance);
    }

    pub(crate) fn pitch_amplitude(&self) -> f64 {
        self.pitch_range
            .or(self.pitch_range_all)
            .map_or(f64::NAN, |(lo, hi)| 0.5 * (hi - lo))
    }
}

/// A CSV file written row by row, each row with one `write` so that the file
/// stays valid (whole rows) if the run stops.
pub(crate) struct CsvFile {
    file: File,
    path: PathBuf,
}

impl CsvFile {
    fn create(path: PathBuf, header: &str) -> Result<Self, SimError> {
        let file = File::create(&path).map_err(|source| SimError::Io {
            action: "create",
            path: path.clone(),
            source,
        })?;
        let mut csv = CsvFile { file, path };
        csv.write(&format!("{header}\n"))?;
        Ok(csv)
    }

    fn write(&mut self, text: &str) -> Result<(), SimError> {
        self.file
            .write_all(text.as_bytes())
            .map_err(|source| SimError::Io {
                action: "write",
                path: self.path.clone(),
                source,
            })
    }
}

/// Time from which the connection tension of `samples` (the rows of
/// `timeseries.csv`) stays within the settling band about its last value; `None`
/// unless it then stayed there for [`SETTLING_HOLD_S`].
pub(crate) fn settling_time(samples: &[Sample]) -> Option<f64> {
    let last = samples.last()?;
    let final_tension = last.tension_connection;
    let band = SETTLING_BAND * final_tension.abs();
    let outside = samples
        .iter()
        .rposition(|s| (s.tension_connection - final_tension).abs() > band);
    let settled = match outside {
        None => samples[0].t,
        Some(i) => samples[i + 1].t,
    };
    (last.t - settled >= SETTLING_HOLD_S - 1e-9).then_some(settled)
}

/// Writes the snapshot's rows to `cable.csv` (one write).
fn write_snapshot(csv: &mut CsvFile, snapshot: &Snapshot) -> Result<(), SimError> {
    let t = format_time(snapshot.t);
    let mut text = String::with_capacity(snapshot.joints.len() * 64);
    for (j, [along, behind, lateral, below, tension]) in snapshot.joints.iter().enumerate() {
        text.push_str(&format!(
            "{t},{j},{},{},{},{},{}\n",
            format_value(*along),
            format_value(*behind),
            format_value(*lateral),
            format_value(*below),
            format_value(*tension)
        ));
    }
    csv.write(&text)
}

/// Everything measured and written from the evaluated states, in step order.
///
/// It is fed the outputs of RK4's first stage ([`Solver::step_observed`]), which
/// evaluates the dynamics at the state before each step anyway, so measuring every
/// step costs no extra evaluation. The CSV files are optional: an in-memory run
/// ([`crate::trace()`]) keeps only the samples and snapshots.
pub(crate) struct Recorder<'a> {
    pub path: &'a FlightProfile,
    pub probe: Probe,
    pub timeseries: Option<CsvFile>,
    pub cable: Option<CsvFile>,
    pub statistics: Statistics,
    pub samples: Vec<Sample>,
    pub snapshots: Vec<Snapshot>,
    /// The last good sample.
    pub last: Sample,
    pub last_written: bool,
    pub sample_every: u64,
    pub snapshot_every: u64,
    pub steps: u64,
    pub dt: f64,
}

/// The summary of a run measured elsewhere (for example by the firmware in the
/// loop, `decoy hil`) from its samples, with the same definitions as
/// [`simulate`]'s: `samples` in time order, every one of them measured (maxima,
/// minima, pitch amplitude from `manoeuvre_start` on) and taken as the rows of
/// `timeseries.csv` (settling time). `stopped` says why such a run ended early.
#[allow(clippy::too_many_arguments)]
pub fn summarize(
    scenario: &str,
    segments: usize,
    dt: f64,
    t_end: f64,
    manoeuvre_start: f64,
    samples: &[Sample],
    wall_s: f64,
    stopped: Option<String>,
) -> Summary {
    let mut statistics = Statistics::new(manoeuvre_start);
    for s in samples {
        statistics.add(s);
    }
    let last = samples.last().copied().unwrap_or_default();
    Summary {
        scenario: scenario.to_owned(),
        segments,
        dt,
        t_end,
        max_tension_connection_n: statistics.max_tension,
        t_at_max_tension_s: round_time(statistics.t_at_max),
        pitch_oscillation_amplitude_deg: statistics.pitch_amplitude(),
        settling_time_s: if stopped.is_some() {
            None
        } else {
            settling_time(samples).map(round_time)
        },
        final_values: FinalValues {
            tension_connection_n: last.tension_connection,
            tension_tow_n: last.tension_tow,
            decoy_pitch_deg: last.euler_deg[1],
            decoy_cg_behind_m: last.cg[0],
            decoy_cg_below_m: last.cg[2],
            decoy_cg_lateral_m: last.cg[1],
        },
        min_cable_clearance_to_exhaust_m: statistics.min_exhaust,
        min_decoy_clearance_to_aircraft_m: statistics.min_decoy,
        wall_s,
        stopped: stopped.map(|reason| StoppedAt {
            t_s: round_time(last.t),
            reason,
        }),
    }
}

/// Why a run stopped early: the reason in words and the solver's error.
pub(crate) type Stop = (String, Option<SolveError>);

impl<'a> Recorder<'a> {
    /// A recorder for `plan` keeping a sample every `sample_interval` s and a
    /// snapshot every `snapshot_interval` s (both at least every step), writing
    /// the CSV files given.
    pub(crate) fn new(
        plan: &'a RunPlan,
        probe: Probe,
        files: Option<(CsvFile, CsvFile)>,
        sample_interval: f64,
        snapshot_interval: f64,
    ) -> Self {
        let (timeseries, cable) = match files {
            Some((t, c)) => (Some(t), Some(c)),
            None => (None, None),
        };
        Recorder {
            path: &plan.profile,
            probe,
            timeseries,
            cable,
            statistics: Statistics::new(plan.profile.manoeuvre_start()),
            samples: Vec::new(),
            snapshots: Vec::new(),
            last: Sample::default(),
            last_written: false,
            sample_every: ((sample_interval / plan.dt).round() as u64).max(1),
            snapshot_every: ((snapshot_interval / plan.dt).round() as u64).max(1),
            steps: plan.steps,
            dt: plan.dt,
        }
    }

    /// Records the evaluation `out` of the state after step `k`. `Ok(Some)` when the
    /// state cannot be used (the run stops at the previous one).
    fn record<const N: usize>(
        &mut self,
        k: u64,
        out: &Outputs<'_, f64, N>,
    ) -> Result<Option<Stop>, SimError> {
        let t = out.time();
        let aircraft = self.path.state_at(t);
        let write_row = k == 0 || k.is_multiple_of(self.sample_every) || k == self.steps;
        let take_snapshot = k == 0 || k.is_multiple_of(self.snapshot_every) || k == self.steps;
        let previous_yaw = (k > 0).then_some(self.last.euler_deg[2]);
        let sample = self.probe.sample(out, &aircraft, previous_yaw);
        let snapshot = take_snapshot.then(|| self.probe.snapshot(out, &aircraft));
        if !(sample.tension_connection.is_finite() && sample.tension_tow.is_finite()) {
            return Ok(Some((
                format!(
                    "the cable tension became non-finite at t = {} s: the state diverged (is the time step {} s too long?)",
                    format_time(t),
                    self.dt
                ),
                None,
            )));
        }
        self.last = sample;
        self.statistics.add(&sample);
        self.last_written = write_row;
        if write_row {
            if let Some(csv) = &mut self.timeseries {
                csv.write(&sample.csv_row())?;
            }
            self.samples.push(sample);
        }
        if let Some(snapshot) = snapshot {
            if let Some(csv) = &mut self.cable {
                write_snapshot(csv, &snapshot)?;
            }
            self.snapshots.push(snapshot);
        }
        Ok(None)
    }

    /// Keeps (and writes) the last good state's row if it fell between rows.
    fn finish(&mut self) -> Result<(), SimError> {
        if !self.last_written {
            if let Some(csv) = &mut self.timeseries {
                csv.write(&self.last.csv_row())?;
            }
            self.samples.push(self.last);
            self.last_written = true;
        }
        Ok(())
    }
}

/// The measuring geometry of a run of `model` (plume, envelope, distances along
/// the cable).
pub(crate) fn probe<const N: usize>(
    config: &SystemConfig,
    model: &Model<f64, N>,
    lateral_sign: f64,
) -> Probe {
    let mut joint_along = Vec::with_capacity(model.segment_count() + 1);
    joint_along.push(0.0);
    for l in model.lengths() {
        joint_along.push(joint_along[joint_along.len() - 1] + l);
    }
    Probe {
        plume: plume_from_config(&config.aircraft),
        envelope: envelope_from_config(&config.aircraft),
        lateral_sign,
        joint_along,
    }
}

/// Integrates `plan.steps` steps from the solver's state, recording every
/// evaluated state with `recorder`; `progress` gets the fraction done now and
/// then. Returns why it stopped early, if it did (the recorder then holds every
/// state up to the last good one).
pub(crate) fn integrate<const N: usize>(
    solver: &mut Solver<f64, N>,
    plan: &RunPlan,
    recorder: &mut Recorder<'_>,
    mut progress: impl FnMut(f64),
) -> Result<Option<Stop>, SimError> {
    let path = &plan.profile;
    let steps = plan.steps;
    let initial = match solver.outputs(path) {
        Ok(out) => recorder.record(0, &out)?,
        Err(e) => return Err(SimError::Initial(e)),
    };
    if let Some((_, error)) = initial {
        return Err(SimError::Initial(
            error.unwrap_or(SolveError::NonFinite { joint: 0 }),
        ));
    }
    progress(0.0);

    let progress_every = (steps / 1000).max(1);
    let mut stopped: Option<Stop> = None;
    for k in 1..=steps {
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
            stopped = Some((stop_reason(&e, plan.dt), Some(e)));
            break;
        }
        if k.is_multiple_of(progress_every) {
            progress(k as f64 / steps as f64);
        }
    }
    if stopped.is_none() {
        stopped = match solver.outputs(path) {
            Ok(out) => recorder.record(steps, &out)?,
            Err(e) => Some((stop_reason(&e, plan.dt), Some(e))),
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
pub fn simulate(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &RunOptions,
    progress: impl FnMut(f64),
) -> Result<RunOutput, SimError> {
    let wall = Instant::now();
    let plan = scenario.plan(config, options)?;
    if plan.layout.count() <= SMALL_CAPACITY {
        simulate_with::<SMALL_CAPACITY>(config, plan, options, progress, wall)
    } else {
        simulate_with::<MAX_SEGMENTS>(config, plan, options, progress, wall)
    }
}

/// [`simulate`] with a model of capacity `N`.
fn simulate_with<const N: usize>(
    config: &SystemConfig,
    plan: RunPlan,
    options: &RunOptions,
    progress: impl FnMut(f64),
    wall: Instant,
) -> Result<RunOutput, SimError> {
    let out_dir = options
        .out_dir
        .clone()
        .unwrap_or_else(|| Path::new("out").join(&plan.name));
    let model: Model<f64, N> = config.model(plan.layout)?;
    let n = model.segment_count();
    let initial = plan.profile.initial_condition();
    let state = match options.initial {
        InitialState::Trim => trim(&model, &initial).map_err(SimError::NoTrim)?,
        InitialState::Straight => straight_state(&model, &initial),
    };
    let probe = probe(config, &model, plan.lateral_sign);
    let mut solver: Box<Solver<f64, N>> =
        Box::new(Solver::new(model, state).map_err(SimError::Initial)?);

    std::fs::create_dir_all(&out_dir).map_err(|source| SimError::Io {
        action: "create the directory",
        path: out_dir.clone(),
        source,
    })?;
    let timeseries_path = out_dir.join("timeseries.csv");
    let cable_path = out_dir.join("cable.csv");
    let files = (
        CsvFile::create(timeseries_path.clone(), TIMESERIES_HEADER)?,
        CsvFile::create(cable_path.clone(), CABLE_HEADER)?,
    );
    let mut recorder = Recorder::new(
        &plan,
        probe,
        Some(files),
        SAMPLE_INTERVAL_S,
        SNAPSHOT_INTERVAL_S,
    );
    let stopped = integrate(&mut solver, &plan, &mut recorder, progress)?;
    let Recorder {
        timeseries,
        cable,
        statistics,
        samples,
        snapshots,
        last,
        ..
    } = recorder;
    drop((timeseries, cable));

    let summary = Summary {
        scenario: plan.name.clone(),
        segments: n,
        dt: plan.dt,
        t_end: plan.t_end,
        max_tension_connection_n: statistics.max_tension,
        t_at_max_tension_s: round_time(statistics.t_at_max),
        pitch_oscillation_amplitude_deg: statistics.pitch_amplitude(),
        settling_time_s: if stopped.is_some() {
            None
        } else {
            settling_time(&samples).map(round_time)
        },
        final_values: FinalValues {
            tension_connection_n: last.tension_connection,
            tension_tow_n: last.tension_tow,
            decoy_pitch_deg: last.euler_deg[1],
            decoy_cg_behind_m: last.cg[0],
            decoy_cg_below_m: last.cg[2],
            decoy_cg_lateral_m: last.cg[1],
        },
        min_cable_clearance_to_exhaust_m: statistics.min_exhaust,
        min_decoy_clearance_to_aircraft_m: statistics.min_decoy,
        wall_s: wall.elapsed().as_secs_f64(),
        stopped: stopped.as_ref().map(|(reason, _)| StoppedAt {
            t_s: round_time(last.t),
            reason: reason.clone(),
        }),
    };
    let summary_path = out_dir.join("summary.json");
    let mut json = serde_json::to_string_pretty(&summary).map_err(|e| SimError::Io {
        action: "write",
        path: summary_path.clone(),
        source: std::io::Error::other(e),
    })?;
    json.push('\n');
    std::fs::write(&summary_path, json).map_err(|source| SimError::Io {
        action: "write",
        path: summary_path.clone(),
        source,
    })?;
    let mut files = vec![timeseries_path, cable_path, summary_path];

    if options.plots {
        let recorded = Recorded {
            samples: &samples,
            snapshots: &snapshots,
        };
        files.extend(crate::plots::write_all(&recorded, &plan, &out_dir)?);
    }

    if let Some((reason, source)) = stopped {
        return Err(SimError::Stopped {
            t_s: round_time(last.t),
            reason,
            source,
            out_dir,
        });
    }
    Ok(RunOutput {
        summary,
        out_dir,
        files,
        plan,
    })
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

/// A time summed from steps, rounded to the nanosecond (8.076 rather than 8.076000000000963).
pub(crate) fn round_time(t: f64) -> f64 {
    (t * 1e9).round() / 1e9
}

/// Times in the CSV files: up to nine decimals, trailing zeros dropped.
pub fn format_time(t: f64) -> String {
    let s = format!("{t:.9}");
    let s = s.trim_end_matches('0');
    let s = s.strip_suffix('.').unwrap_or(s);
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

/// Values in the CSV files: six decimals (no negative zero).
pub fn format_value(v: f64) -> String {
    let s = format!("{v:.6}");
    if s == "-0.000000" {
        "0.000000".to_owned()
    } else {
        s
    }
}

/// The layout in words ("300 uniform segments").
pub fn describe_layout(layout: &SegmentLayout<f64>) -> String {
    match *layout {
        SegmentLayout::Uniform { count } => format!("{count} uniform segments"),
        SegmentLayout::Graded { count, ratio } => {
            format!("{count} segments graded {ratio} (short at the decoy)")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_formats() {
        assert_eq!(format_time(0.0), "0");
        assert_eq!(format_time(1.234_000_000_000_2), "1.234");
        assert_eq!(format_time(2.0), "2");
        assert_eq!(format_value(-1e-9), "0.000000");
        assert_eq!(format_value(1.5), "1.500000");
    }

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
                simulate_with::<SMALL_CAPACITY>(&config, plan, &options, |_| {}, Instant::now())
            } else {
                simulate_with::<MAX_SEGMENTS>(&config, plan, &options, |_| {}, Instant::now())
            };
            std::fs::read(out.unwrap().out_dir.join("timeseries.csv")).unwrap()
        };
        let small = run(SMALL_CAPACITY);
        let large = run(MAX_SEGMENTS);
        let _ = std::fs::remove_dir_all(&dir);
        assert!(small == large);
    }

    #[test]
    fn summarize_measures_the_samples() {
        let sample = |t: f64, tension_connection: f64, pitch: f64| Sample {
            t,
            tension_connection,
            euler_deg: [0.0, pitch, 0.0],
            exhaust_clearance: -t,
            decoy_clearance: 10.0 + t,
            ..Sample::default()
        };
        let samples: Vec<Sample> = (0..=300)
            .map(|k| {
                let t = f64::from(k) * 0.01;
                let bump = if (1.0..1.2).contains(&t) { 50.0 } else { 0.0 };
                sample(
                    t,
                    100.0 + bump,
                    if t >= 1.0 { 2.0 + bump / 50.0 } else { 2.0 },
                )
            })
            .collect();
        let s = summarize("x", 16, 0.005, 3.0, 1.0, &samples, 0.5, None);
        assert_eq!(s.max_tension_connection_n, 150.0);
        assert_eq!(s.t_at_max_tension_s, 1.0);
        assert_eq!(s.pitch_oscillation_amplitude_deg, 0.5);
        assert_eq!(s.settling_time_s, Some(1.2));
        assert_eq!(s.final_values.tension_connection_n, 100.0);
        assert_eq!(s.min_cable_clearance_to_exhaust_m, -3.0);
        assert_eq!(s.min_decoy_clearance_to_aircraft_m, 10.0);
        let stopped = summarize("x", 16, 0.005, 3.0, 1.0, &samples, 0.5, Some("why".into()));
        assert_eq!(stopped.settling_time_s, None);
        assert_eq!(stopped.stopped.unwrap().t_s, 3.0);
    }

    #[test]
    fn settling_needs_the_hold() {
        let sample = |t: f64, tension_connection: f64| Sample {
            t,
            tension_connection,
            ..Sample::default()
        };
        let mut samples = vec![
            sample(0.0, 100.0),
            sample(1.0, 150.0),
            sample(2.0, 101.0),
            sample(3.5, 100.0),
        ];
        assert_eq!(settling_time(&samples), Some(2.0));
        samples.push(sample(3.6, 120.0));
        assert_eq!(settling_time(&samples), None);
    }

    /// The onboard controller (decoy-link, f64) and `decoy simulate`'s probe report
    /// the same tensions, decoy position and clearances for the same trimmed state.
    #[test]
    fn the_controller_and_the_probe_agree() {
        use decoy_controller::{Controller, NoCounter};
        use decoy_link::{AircraftStateFrame, DeviceMessage, HostMessage};
        let config = SystemConfig::builtin().unwrap();
        let layout = config.embedded_layout();
        let model = config.model::<f64, 16>(layout).unwrap();
        for mach in [0.5, 0.6, 0.8] {
            let speed = config.mach_to_speed(9000.0, mach).unwrap();
            let aircraft = AircraftState::<f64>::level(9000.0, speed);
            let mut solver = Solver::new(model, trim(&model, &aircraft).unwrap()).unwrap();
            let path = solver_core::Uniform { initial: aircraft };
            let probe = probe(&config, &model, 1.0);
            let sample = probe.sample(&solver.outputs(&path).unwrap(), &aircraft, None);

            let mut controller: Controller<f64, 16> =
                Controller::new(config.controller_config(layout).unwrap()).unwrap();
            let frame = AircraftStateFrame {
                seq: 1,
                time_s: 0.0,
                position_ned_m: [0.0, 0.0, -9000.0],
                velocity_ned_mps: [speed as f32, 0.0, 0.0],
                acceleration_ned_mps2: [0.0; 3],
                attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
                body_rate_radps: [0.0; 3],
                body_angular_acceleration_radps2: [0.0; 3],
            };
            let DeviceMessage::Output(o) =
                controller.handle(HostMessage::State(frame), &mut NoCounter)
            else {
                panic!("no output at Mach {mach}");
            };
            // The frame carries the speed in f32: agreement to that rounding.
            let close = |a: f32, b: f64, tol: f64| {
                assert!(
                    (f64::from(a) - b).abs() <= tol * (1.0 + b.abs()),
                    "Mach {mach}: {a} vs {b}"
                )
            };
            close(o.connection_tension_n, sample.tension_connection, 1e-5);
            close(o.tow_tension_n, sample.tension_tow, 1e-5);
            close(o.cable_clearance_exhaust_m, sample.exhaust_clearance, 1e-5);
            close(o.decoy_clearance_aircraft_m, sample.decoy_clearance, 1e-5);
            // The probe reports "behind" and "below"; the frame x forward, z down.
            close(o.decoy_position_fp_m[0], -sample.cg[0], 1e-5);
            close(o.decoy_position_fp_m[2], sample.cg[2], 1e-5);
            close(
                o.decoy_euler_rel_rad[1],
                sample.euler_deg[1].to_radians(),
                1e-5,
            );
        }
    }
}
