//! The recorder: what a run measures at every step (the probe, the running
//! statistics) and keeps or writes (`timeseries.csv` rows, `cable.csv` snapshots).

use std::path::PathBuf;

use decoy_config::SystemConfig;
use decoy_plots::atomic::AtomicFile;
use nalgebra::Vector3;
use solver_core::{AircraftState, Model, Outputs, SolveError};

use crate::error::SimError;
use crate::format::{Cell, csv_row, format_time};
use crate::geometry::{
    Envelope, ExhaustPlume, FlightPathFrame, cable_plume_clearance_below, envelope_from_config,
    plume_from_config,
};
use crate::management::{ManagementSample, ManagementTrack};
use crate::profile::FlightProfile;
use crate::scenario::RunPlan;
use crate::steps::Marks;
use decoy_schema::Quantity;
use decoy_schema::columns::{SIMULATE_CABLE, SIMULATE_TIMESERIES};

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
    /// Decoy management: levels, margins, advisories (`docs/outputs.md`).
    pub management: ManagementSample,
}

impl Sample {
    /// A sample of no state (a run that did not start): every value NaN, t = 0.
    pub(crate) fn unknown() -> Sample {
        Sample {
            t: 0.0,
            tension_connection: f64::NAN,
            tension_tow: f64::NAN,
            cg: [f64::NAN; 3],
            euler_deg: [f64::NAN; 3],
            aoa_deg: f64::NAN,
            exhaust_clearance: f64::NAN,
            exhaust_along: f64::NAN,
            decoy_clearance: f64::NAN,
            speed: f64::NAN,
            altitude: f64::NAN,
            management: ManagementSample::default(),
        }
    }

    /// The sample's cell of the column holding `quantity` (`None`: the sample
    /// does not measure it): what `timeseries.csv` writes, and `decoy hil`'s
    /// file for the columns the two share.
    pub fn cell(&self, quantity: Quantity) -> Option<Cell> {
        let m = &self.management;
        Some(match quantity {
            Quantity::Time => Cell::Time(self.t),
            Quantity::TensionConnection => Cell::Value(self.tension_connection),
            Quantity::TensionTow => Cell::Value(self.tension_tow),
            Quantity::DecoyCgBehind => Cell::Value(self.cg[0]),
            Quantity::DecoyCgLateral => Cell::Value(self.cg[1]),
            Quantity::DecoyCgBelow => Cell::Value(self.cg[2]),
            Quantity::DecoyRoll => Cell::Value(self.euler_deg[0]),
            Quantity::DecoyPitch => Cell::Value(self.euler_deg[1]),
            Quantity::DecoyYaw => Cell::Value(self.euler_deg[2]),
            Quantity::DecoyAoa => Cell::Value(self.aoa_deg),
            Quantity::CableExhaustClearance => Cell::Value(self.exhaust_clearance),
            Quantity::CableExhaustClosestAlong => Cell::Value(self.exhaust_along),
            Quantity::DecoyAircraftClearance => Cell::Value(self.decoy_clearance),
            Quantity::AircraftSpeed => Cell::Value(self.speed),
            Quantity::AircraftAltitude => Cell::Value(self.altitude),
            Quantity::Level(r) => Cell::Count(u64::from(m.levels[r])),
            Quantity::Margin(r) => Cell::Value(m.margins[r]),
            Quantity::Advisories => Cell::Count(u64::from(m.advisories)),
            Quantity::ViolationIn(r) => {
                // -1 where no violation is predicted (as on the wire).
                let v = m.violation_in[r];
                Cell::Value(if v.is_finite() { v } else { -1.0 })
            }
            _ => return None,
        })
    }

    /// The sample's row of `timeseries.csv`.
    fn csv_row(&self) -> String {
        csv_row(&SIMULATE_TIMESERIES, |q| self.cell(q))
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
    /// An upper bound of the distance between consecutive points of the plume
    /// clearance's search (joints and segment midpoints): half the longest
    /// segment, plus 1e-9 of it for the rounding of the joint positions, m.
    pub point_spacing: f64,
}

impl Probe {
    /// The cable's smallest clearance to the exhaust plume and where it is (m
    /// from the connection point), from the joints of a state with the aircraft
    /// at `aircraft`, if below `bound`. Joints and segment midpoints, in the
    /// order decoy-link numbers them; the pruned search evaluates only the
    /// points near enough to the plume to matter (the same result, bit for bit,
    /// as the controller's search of every point).
    fn exhaust_below(
        &self,
        joints: &[Vector3<f64>],
        aircraft: &AircraftState<f64>,
        bound: f64,
    ) -> Option<(f64, f64)> {
        let (clearance, at) = cable_plume_clearance_below(
            &self.plume,
            aircraft,
            joints.iter().copied(),
            self.point_spacing,
            bound,
        )?;
        let along = if at % 2 == 0 {
            self.joint_along[at / 2]
        } else {
            0.5 * (self.joint_along[at / 2] + self.joint_along[at / 2 + 1])
        };
        Some((clearance, along))
    }

    /// The exhaust clearance and where it is, as [`Probe::exhaust_below`] with
    /// no bound (infinity and the connection point for no clearance at all).
    fn exhaust(&self, joints: &[Vector3<f64>], aircraft: &AircraftState<f64>) -> (f64, f64) {
        self.exhaust_below(joints, aircraft, f64::INFINITY)
            .unwrap_or((f64::INFINITY, self.joint_along[0]))
    }

    /// Measures one evaluated state, whose joint positions are `joints`.
    /// `previous_yaw` unwraps the yaw angle. The exhaust clearance is exact
    /// when `exhaust_bound` is `None`; with `Some(bound)` (a step between output
    /// rows, whose clearance only lowers the run's smallest) it is exact only if
    /// below the bound, else it is the bound and its place NaN, and the second
    /// value is false.
    fn sample<const N: usize>(
        &self,
        out: &Outputs<'_, f64, N>,
        joints: &[Vector3<f64>],
        aircraft: &AircraftState<f64>,
        previous_yaw: Option<f64>,
        exhaust_bound: Option<f64>,
    ) -> (Sample, bool) {
        let frame = FlightPathFrame::of(aircraft);
        let rotation = aircraft.rotation();
        let to_body =
            |p: &Vector3<f64>| rotation.inverse_transform_vector(&(p - aircraft.position));
        let ((exhaust_clearance, exhaust_along), exact) = match exhaust_bound {
            None => (self.exhaust(joints, aircraft), true),
            Some(bound) => match self.exhaust_below(joints, aircraft, bound) {
                Some(found) => (found, true),
                None => ((bound, f64::NAN), false),
            },
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
        let sample = Sample {
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
            management: ManagementSample::default(),
        };
        (sample, exact)
    }

    /// The snapshot of `raw` (the cable in the flight-path frame, relative to
    /// the aircraft reference point, with the aircraft at `aircraft`).
    fn snapshot_of(&self, raw: &RawCable, aircraft: &AircraftState<f64>) -> Snapshot {
        let frame = FlightPathFrame::of(aircraft);
        Snapshot {
            t: raw.t,
            joints: raw
                .joints
                .iter()
                .zip(&raw.tensions)
                .zip(&self.joint_along)
                .map(|((p, &tension), &along)| {
                    let c = frame.components(&(p - aircraft.position));
                    [along, -c.x, self.lateral_sign * -c.y + 0.0, c.z, tension]
                })
                .collect(),
        }
    }
}

/// The cable of one evaluated state as the solver gives it (NED joint
/// positions and joint tensions): what a snapshot and an exact exhaust
/// clearance are computed from when they are asked for, kept every step.
#[derive(Clone, Debug, Default)]
pub(crate) struct RawCable {
    /// The state's time, s.
    t: f64,
    /// Joint positions, NED, m (0 = connection point).
    joints: Vec<Vector3<f64>>,
    /// Joint tensions, N.
    tensions: Vec<f64>,
}

impl RawCable {
    /// Copies the cable of `out` into `self` (reusing its storage).
    fn capture<const N: usize>(&mut self, out: &Outputs<'_, f64, N>) {
        let joints = 0..=out.segment_count();
        self.t = out.time();
        self.joints.clear();
        self.joints
            .extend(joints.clone().map(|j| out.joint_position(j)));
        self.tensions.clear();
        self.tensions.extend(joints.map(|j| out.tension(j)));
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
    pub(crate) fn new(manoeuvre_start: f64) -> Self {
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

    pub(crate) fn add(&mut self, s: &Sample) {
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

/// A CSV file written row by row under its partial name
/// ([`decoy_plots::atomic::AtomicFile`]) and renamed to its name by
/// [`CsvFile::finish`] once the run has ended (finished, failed or stopped): the
/// name never holds part of a file.
pub(crate) struct CsvFile {
    file: AtomicFile,
}

impl CsvFile {
    /// Creates `path` (under its partial name) with the header of `file`.
    pub(crate) fn create(path: PathBuf, file: &decoy_schema::CsvFile) -> Result<Self, SimError> {
        let header = file.header();
        let file = AtomicFile::create(&path).map_err(|source| SimError::Io {
            action: "create",
            path: path.clone(),
            source,
        })?;
        let mut csv = CsvFile { file };
        csv.write(&format!("{header}\n"))?;
        Ok(csv)
    }

    fn write(&mut self, text: &str) -> Result<(), SimError> {
        self.file
            .write_all(text.as_bytes())
            .map_err(|source| SimError::Io {
                action: "write",
                path: self.file.path().to_owned(),
                source,
            })
    }

    /// Gives the file its name, complete.
    pub(crate) fn finish(mut self) -> Result<(), SimError> {
        self.file.commit().map_err(|source| SimError::Io {
            action: "write",
            path: self.file.path().to_owned(),
            source,
        })
    }
}

/// Time from which the connection tension of `samples` (the rows of
/// `timeseries.csv`) stays within the settling band about its last value; `None`
/// unless it then stayed there for [`SETTLING_HOLD_S`].
pub fn settling_time(samples: &[Sample]) -> Option<f64> {
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

impl Snapshot {
    /// The cell of joint `j`'s row of `cable.csv` in the column holding
    /// `quantity` (`None`: not a column of the snapshot).
    pub fn cell(&self, j: usize, quantity: Quantity) -> Option<Cell> {
        let [along, behind, lateral, below, tension] = *self.joints.get(j)?;
        Some(match quantity {
            Quantity::Time => Cell::Time(self.t),
            Quantity::Joint => Cell::Count(j as u64),
            Quantity::Along => Cell::Value(along),
            Quantity::Behind => Cell::Value(behind),
            Quantity::Lateral => Cell::Value(lateral),
            Quantity::Below => Cell::Value(below),
            Quantity::Tension => Cell::Value(tension),
            _ => return None,
        })
    }
}

/// How many output intervals of `interval` s make `every` s (at least one).
fn intervals(every: f64, interval: f64) -> u64 {
    ((every / interval).round() as u64).max(1)
}

/// A step in seconds, for messages: its shortest round-trip form.
pub(crate) fn format_step(step: f64) -> String {
    crate::format::format_number(step)
}

/// Writes the snapshot's rows to `cable.csv` (one write).
fn write_snapshot(csv: &mut CsvFile, snapshot: &Snapshot) -> Result<(), SimError> {
    let mut text = String::with_capacity(snapshot.joints.len() * 64);
    for j in 0..snapshot.joints.len() {
        text.push_str(&csv_row(&SIMULATE_CABLE, |q| snapshot.cell(j, q)));
    }
    csv.write(&text)
}

/// Everything measured and written from the evaluated states, in step order.
///
/// It is fed the outputs at the state each step starts from ([`Solver::outputs`],
/// whose evaluation the step then reuses as RK4's first stage), so measuring every
/// step costs no extra evaluation. Every state is measured (the statistics: peaks,
/// minima, the pitch amplitude); the states at the run's output times (every
/// 10 ms, [`crate::steps`]) are the rows, kept every `rows_every` of them, and
/// every `rows_per_snapshot`-th is a cable snapshot; the first and the last state
/// are both. The CSV files are optional: an in-memory run (`trace`) keeps only the
/// samples and snapshots.
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
    /// The cable at the last good state (kept every step, so that a run that
    /// stops can still end `cable.csv` with it, and its last row have its exact
    /// exhaust clearance).
    last_raw: RawCable,
    /// Scratch for the cable of the state being recorded.
    candidate_raw: RawCable,
    /// Whether the last good sample's exhaust clearance is exact (a step
    /// between rows measures it only below the run's smallest).
    last_exact: bool,
    /// True once a state has been recorded.
    pub recorded_any: bool,
    pub last_written: bool,
    /// Keep every this many output times as a row.
    pub rows_every: u64,
    /// Take a snapshot every this many output times.
    pub rows_per_snapshot: u64,
    /// Output times seen so far (the first state's is number 0).
    pub rows_seen: u64,
    /// The last step taken, s (for the message of a divergence).
    pub last_step: f64,
    /// Steps that stood.
    pub steps: u64,
    /// Steps undone (an adaptive step whose error estimate was too large, or that
    /// failed) and taken again shorter.
    pub rejected: u64,
    /// The solver's error of the last step that failed and was taken again.
    pub last_failure: Option<SolveError>,
    /// The shortest and the longest step that stood, s.
    pub step_range: (f64, f64),
    /// The management monitors and the onboard controller (runs that write files).
    pub management: Option<ManagementTrack>,
}

/// Why a run stopped early.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Stop {
    /// In words (`summary.json`'s `stopped.reason`).
    pub reason: String,
    /// The solver's error, when the solver reported one.
    pub source: Option<SolveError>,
    /// The stop request that ended the run (the name of the signal the command
    /// line received, `SIGINT`), when one did rather than a failure.
    pub requested: Option<&'static str>,
}

impl Stop {
    /// A failure: `reason` in words, the solver's error if it reported one.
    pub(crate) fn failure(reason: String, source: Option<SolveError>) -> Self {
        Stop {
            reason,
            source,
            requested: None,
        }
    }

    /// A stop requested from outside the run (`signal`: the signal's name;
    /// the reason is `interrupted by SIGINT`).
    pub(crate) fn requested(signal: &'static str) -> Self {
        Stop {
            reason: format!("interrupted by {signal}"),
            source: None,
            requested: Some(signal),
        }
    }
}

impl<'a> Recorder<'a> {
    /// A recorder for `plan` keeping a sample every `sample_interval` s and a
    /// snapshot every `snapshot_interval` s (both whole numbers of the plan's
    /// output interval, at least one), writing the CSV files given.
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
            last_raw: RawCable::default(),
            candidate_raw: RawCable::default(),
            last_exact: true,
            recorded_any: false,
            last_written: false,
            rows_every: intervals(sample_interval, plan.timeline.row_interval()),
            rows_per_snapshot: intervals(snapshot_interval, plan.timeline.row_interval()),
            rows_seen: 0,
            last_step: 0.0,
            steps: 0,
            rejected: 0,
            last_failure: None,
            step_range: (f64::INFINITY, 0.0),
            management: None,
        }
    }

    /// Records the evaluation `out` of the state after step `k`, whose time is
    /// what `marks` says on the run's timeline. `Ok(Some)` when the state cannot
    /// be used (the run stops at the previous one).
    pub(crate) fn record<const N: usize>(
        &mut self,
        k: u64,
        out: &Outputs<'_, f64, N>,
        marks: Marks,
    ) -> Result<Option<Stop>, SimError> {
        let t = out.time();
        let aircraft = self.path.state_at(t);
        let row = self.rows_seen;
        let write_row = marks.end || (marks.row && row.is_multiple_of(self.rows_every));
        let take_snapshot = marks.end || (marks.row && row.is_multiple_of(self.rows_per_snapshot));
        let previous_yaw = (k > 0).then_some(self.last.euler_deg[2]);
        self.candidate_raw.capture(out);
        // A state that is not written needs its exhaust clearance only if it
        // lowers the run's smallest.
        let bound = (!write_row).then_some(self.statistics.min_exhaust);
        let (mut sample, exact) = self.probe.sample(
            out,
            &self.candidate_raw.joints,
            &aircraft,
            previous_yaw,
            bound,
        );
        if !(sample.tension_connection.is_finite() && sample.tension_tow.is_finite()) {
            return Ok(Some(Stop::failure(
                format!(
                    "the cable tension became non-finite at t = {} s: the state diverged (the last step was {} s)",
                    format_time(t),
                    format_step(self.last_step)
                ),
                None,
            )));
        }
        if write_row && let Some(track) = &mut self.management {
            sample.management = track.observe(out, &aircraft, self.path);
        }
        if marks.row {
            self.rows_seen += 1;
        }
        self.last = sample;
        self.last_exact = exact;
        std::mem::swap(&mut self.last_raw, &mut self.candidate_raw);
        self.recorded_any = true;
        self.statistics.add(&sample);
        self.last_written = write_row;
        if write_row {
            if let Some(csv) = &mut self.timeseries {
                csv.write(&sample.csv_row())?;
            }
            self.samples.push(sample);
        }
        if take_snapshot {
            self.keep_last_cable()?;
        }
        Ok(None)
    }

    /// Notes a step of `dt` s about to be taken.
    pub(crate) fn note_step(&mut self, dt: f64) {
        self.last_step = dt;
    }

    /// Counts a step of `dt` s that stood.
    pub(crate) fn note_accepted(&mut self, dt: f64) {
        self.steps += 1;
        self.step_range = (self.step_range.0.min(dt), self.step_range.1.max(dt));
    }

    /// Counts the last step as undone.
    pub(crate) fn note_rejection(&mut self) {
        self.rejected += 1;
    }

    /// Keeps (and writes) the snapshot of the last good state.
    fn keep_last_cable(&mut self) -> Result<(), SimError> {
        let aircraft = self.path.state_at(self.last_raw.t);
        let snapshot = self.probe.snapshot_of(&self.last_raw, &aircraft);
        if let Some(csv) = &mut self.cable {
            write_snapshot(csv, &snapshot)?;
        }
        self.snapshots.push(snapshot);
        Ok(())
    }

    /// Keeps (and writes) the last good state's row if it fell between rows, and
    /// its cable snapshot if it fell between snapshots (a run that stopped).
    pub(crate) fn finish(&mut self) -> Result<(), SimError> {
        if !self.recorded_any {
            return Ok(());
        }
        if self.snapshots.last().map(|s| s.t) != Some(self.last.t) {
            self.keep_last_cable()?;
        }
        if !self.last_written {
            if !self.last_exact {
                let aircraft = self.path.state_at(self.last.t);
                (self.last.exhaust_clearance, self.last.exhaust_along) =
                    self.probe.exhaust(&self.last_raw.joints, &aircraft);
                self.last_exact = true;
            }
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
    let longest = model.lengths().iter().fold(0.0f64, |a, &l| a.max(l));
    Probe {
        plume: plume_from_config(&config.aircraft),
        envelope: envelope_from_config(&config.aircraft),
        lateral_sign,
        joint_along,
        point_spacing: 0.5 * longest * (1.0 + 1e-9),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use solver_core::{Solver, trim};

    /// A row of `timeseries.csv` and of `cable.csv` has a cell for every
    /// column of the schema, in its order: the values land under their names.
    #[test]
    fn rows_have_every_column_of_the_schema_in_order() {
        let mut sample = Sample {
            t: 2.5,
            tension_connection: 1000.5,
            tension_tow: 40.25,
            cg: [100.0, -0.0, 12.0],
            euler_deg: [0.5, 2.0, -3.0],
            aoa_deg: 2.0625,
            exhaust_clearance: 1.5,
            exhaust_along: 5.25,
            decoy_clearance: 90.0,
            speed: 180.0,
            altitude: 9000.0,
            ..Sample::default()
        };
        sample.management.levels.collision = 2;
        sample.management.margins.posture = 7.5;
        sample.management.advisories = 0b0100;
        sample.management.violation_in.tension = 1.25;
        assert!(crate::format::missing_cells(&SIMULATE_TIMESERIES, |q| sample.cell(q)).is_empty());
        let row = sample.csv_row();
        let cells: Vec<&str> = row.trim_end().split(',').collect();
        assert_eq!(cells.len(), SIMULATE_TIMESERIES.columns.len());
        let at = |name: &str| cells[SIMULATE_TIMESERIES.names().position(|n| n == name).unwrap()];
        assert_eq!(
            [
                "t_s",
                "tension_connection_N",
                "tension_tow_N",
                "decoy_cg_lateral_m",
                "decoy_pitch_deg",
                "decoy_aoa_deg",
                "cable_exhaust_closest_along_m",
                "collision_level",
                "posture_margin_deg",
                "advisories",
                "tension_violation_in_s",
                "exhaust_violation_in_s",
            ]
            .map(at),
            [
                "2.5",
                "1000.500000",
                "40.250000",
                "0.000000",
                "2.000000",
                "2.062500",
                "5.250000",
                "2",
                "7.500000",
                "4",
                "1.250000",
                "-1.000000",
            ]
        );

        let snapshot = Snapshot {
            t: 1.0,
            joints: vec![[0.0, 4.0, 0.0, 1.0, 900.0], [10.0, 13.5, 0.25, 2.0, 880.5]],
        };
        assert!(crate::format::missing_cells(&SIMULATE_CABLE, |q| snapshot.cell(1, q)).is_empty());
        assert_eq!(
            csv_row(&SIMULATE_CABLE, |q| snapshot.cell(1, q)),
            "1,1,10.000000,13.500000,0.250000,2.000000,880.500000\n"
        );
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
            let out = solver.outputs(&path).unwrap();
            let mut raw = RawCable::default();
            raw.capture(&out);
            let (sample, _) = probe.sample(&out, &raw.joints, &aircraft, None, None);

            let mut controller: Controller<f64, 16> =
                Controller::new(config.controller_config(layout).unwrap()).unwrap();
            // Steady frames while the controller initialises (its trim, over
            // a few frames in f64): the first Output is the trim at its frame.
            let frame = |k: u32| AircraftStateFrame {
                seq: k,
                time_s: 0.01 * f64::from(k),
                position_ned_m: [speed * 0.01 * f64::from(k), 0.0, -9000.0],
                velocity_ned_mps: [speed as f32, 0.0, 0.0],
                acceleration_ned_mps2: [0.0; 3],
                attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
                body_rate_radps: [0.0; 3],
                body_angular_acceleration_radps2: [0.0; 3],
            };
            let o = (0..64)
                .find_map(|k| {
                    match controller.handle(HostMessage::State(frame(k)), &mut NoCounter) {
                        DeviceMessage::Output(o) => Some(o),
                        DeviceMessage::Status(_) => None,
                        other => panic!("Mach {mach}: {other:?}"),
                    }
                })
                .unwrap_or_else(|| panic!("no output at Mach {mach}"));
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
