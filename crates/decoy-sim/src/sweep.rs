//! Parameter sweeps of the paper's steady-flight and decoy-station studies
//! (DESIGN.md §8; the paper's Figs. 15-24).
//!
//! - [`steady_sweep`]: the trim (steady level-flight equilibrium) at each Mach
//!   number at a fixed altitude (`decoy sweep speed`, Figs. 15-18), or at each
//!   altitude at a fixed Mach number (`decoy sweep altitude`, Figs. 19-22): cable
//!   shape and tension profile, decoy pitch and depth, connection and towing
//!   tensions.
//! - [`settling_sweep`]: for each towing-point station at a fixed CG
//!   (`decoy sweep tow-point`) or each CG station at a fixed towing point
//!   (`decoy sweep cg`; Figs. 23-24): the trim of steady level flight (pitch and
//!   connection tension), then a short dynamic run started from that trim with the
//!   decoy pitched nose-up by [`SettlingSpec::pitch_offset_deg`] about its towing
//!   point and no rates (from the straight state, equally pitched, when no trim
//!   exists), classified by [`classify_settling`]: does the decoy settle, and when.
//!
//! [`write_steady_sweep`] and [`write_settling_sweep`] write the tables (CSV) and
//! plots (PNG + SVG); the columns are documented in `docs/sweeps.md`.

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_plots::{Aspect, Plot, PlotError, Series, write_plot, write_stacked};
use serde::Serialize;
use solver_core::{AircraftState, Model, SegmentLayout, Solver, Uniform, trim};

use crate::capacity::with_capacity;
use crate::error::SimError;
use crate::format::format_value;
use crate::geometry::FlightPathFrame;
use crate::options::{InitialState, RunOptions};
use crate::scenario::{
    RunPlan, Scenario, check_altitude, check_grading, check_mach, check_segments,
};
use crate::trace::{Start, TraceOptions, trace};

/// Most points one sweep may have.
pub const MAX_SWEEP_POINTS: usize = 1000;
/// Interval of the pitch histories kept for the plots and `pitch.csv`, s.
const HISTORY_INTERVAL_S: f64 = 0.01;
/// Most pitch histories drawn in one panel (the palette has 10 colours).
const MAX_HISTORIES: usize = 10;

/// The command line's origin for messages.
const CLI: &str = "command line";

fn cli_invalid(field: &str, message: String) -> SimError {
    SimError::invalid(CLI, field, message)
}

/// `from, from + step, ..., to`: the values of a sweep.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SweepRange {
    /// First value.
    pub from: f64,
    /// Last value (included when it is a whole number of steps from `from`).
    pub to: f64,
    /// Increment, > 0.
    pub step: f64,
}

impl SweepRange {
    /// The values, each rounded to 1e-9 (so that 0.5 + 3 x 0.05 prints as 0.65).
    /// Errors (naming `--from`, `--to`, `--step`): a non-finite value, `step <= 0`,
    /// `from > to`, more than [`MAX_SWEEP_POINTS`] values.
    pub fn values(&self) -> Result<Vec<f64>, SimError> {
        for (flag, v) in [
            ("--from", self.from),
            ("--to", self.to),
            ("--step", self.step),
        ] {
            if !v.is_finite() {
                return Err(cli_invalid(
                    flag,
                    format!("must be a finite number, got {v}"),
                ));
            }
        }
        if self.step <= 0.0 {
            return Err(cli_invalid(
                "--step",
                format!("must be positive, got {}", self.step),
            ));
        }
        if self.from > self.to {
            return Err(cli_invalid(
                "--from",
                format!(
                    "{} is above --to {}: the sweep runs upward from --from to --to",
                    self.from, self.to
                ),
            ));
        }
        let intervals = ((self.to - self.from) / self.step * (1.0 + 1e-12) + 1e-9).floor();
        if intervals + 1.0 > MAX_SWEEP_POINTS as f64 {
            return Err(cli_invalid(
                "--step",
                format!(
                    "{} gives {} points from {} to {}, more than {MAX_SWEEP_POINTS}",
                    self.step,
                    intervals + 1.0,
                    self.from,
                    self.to
                ),
            ));
        }
        Ok((0..=intervals as usize)
            .map(|k| round9(self.from + k as f64 * self.step))
            .collect())
    }
}

/// `v` rounded to 1e-9.
fn round9(v: f64) -> f64 {
    (v * 1e9).round() / 1e9 + 0.0
}

/// The segment layout for `segments` and `grading` (1 = uniform), checked
/// (errors name `--segments` and `--grading`).
pub fn layout(segments: usize, grading: f64) -> Result<SegmentLayout<f64>, SimError> {
    check_segments(&cli_invalid, "--segments", segments)?;
    check_grading(&cli_invalid, "--grading", grading)?;
    Ok(if grading == 1.0 {
        SegmentLayout::Uniform { count: segments }
    } else {
        SegmentLayout::Graded {
            count: segments,
            ratio: grading,
        }
    })
}

/// `(segments, grading)` of a layout.
pub fn layout_parts(layout: &SegmentLayout<f64>) -> (usize, f64) {
    match *layout {
        SegmentLayout::Uniform { count } => (count, 1.0),
        SegmentLayout::Graded { count, ratio } => (count, ratio),
    }
}

// ------------------------------------------------------------------ trims

/// One joint of a trimmed cable: distance along the cable from the connection
/// point, behind and below the aircraft reference point (flight-path frame), m,
/// and the tension there, N.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CablePoint {
    /// Distance along the cable from the connection point, m.
    pub along_m: f64,
    /// Behind the aircraft reference point, m.
    pub behind_m: f64,
    /// Below the flight path, m.
    pub below_m: f64,
    /// Tension, N.
    #[serde(rename = "tension_N")]
    pub tension_n: f64,
}

/// The trim of steady level flight at one flight condition.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrimPoint {
    /// Mach number.
    pub mach: f64,
    /// Altitude, m.
    pub altitude_m: f64,
    /// True airspeed, m/s.
    pub speed_mps: f64,
    /// Tension at the connection point (joint 0), N.
    #[serde(rename = "tension_connection_N")]
    pub tension_connection_n: f64,
    /// Tension at the towing point (joint N), N.
    #[serde(rename = "tension_tow_N")]
    pub tension_tow_n: f64,
    /// Largest tension along the cable, N.
    #[serde(rename = "tension_max_N")]
    pub tension_max_n: f64,
    /// Decoy pitch, deg, positive nose-up.
    pub decoy_pitch_deg: f64,
    /// Decoy total angle of attack, deg.
    pub decoy_aoa_deg: f64,
    /// Decoy CG behind the aircraft reference point, m.
    pub decoy_cg_behind_m: f64,
    /// Decoy CG below the flight path (the decoy's depth), m.
    pub decoy_cg_below_m: f64,
    /// The cable, joint 0 (connection point) to joint N (towing point).
    #[serde(skip)]
    pub cable: Vec<CablePoint>,
}

/// The trim of steady level flight at `altitude` m and `mach` with `layout`, and
/// its cable. Errors: no trim ([`SimError::NoTrim`]), an unusable configuration.
pub fn trim_point(
    config: &SystemConfig,
    layout: SegmentLayout<f64>,
    altitude: f64,
    mach: f64,
) -> Result<TrimPoint, SimError> {
    with_capacity!(layout.count(), N => trim_point_with::<N>(config, layout, altitude, mach))
}

fn trim_point_with<const N: usize>(
    config: &SystemConfig,
    layout: SegmentLayout<f64>,
    altitude: f64,
    mach: f64,
) -> Result<TrimPoint, SimError> {
    let model: Model<f64, N> = config.model(layout)?;
    let n = model.segment_count();
    let speed = config.mach_to_speed(altitude, mach)?;
    let aircraft = AircraftState::level(altitude, speed);
    let state = trim(&model, &aircraft).map_err(SimError::NoTrim)?;
    let mut along = vec![0.0];
    for l in model.lengths() {
        along.push(along[along.len() - 1] + l);
    }
    let mut solver: Box<Solver<f64, N>> =
        Box::new(Solver::new(model, state).map_err(SimError::Initial)?);
    let path = Uniform { initial: aircraft };
    let out = solver.outputs(&path).map_err(SimError::Initial)?;
    let frame = FlightPathFrame::of(&aircraft);
    let relative = |p: &nalgebra::Vector3<f64>| frame.components(&(p - aircraft.position));
    let cable: Vec<CablePoint> = (0..=n)
        .map(|j| {
            let c = relative(&out.joint_position(j));
            CablePoint {
                along_m: along[j],
                behind_m: -c.x,
                below_m: c.z,
                tension_n: out.tension(j),
            }
        })
        .collect();
    let (pitch, aoa, cg) = match out.decoy() {
        Some(d) => (
            d.euler.1.to_degrees(),
            d.angle_of_attack.to_degrees(),
            relative(&d.cg_position),
        ),
        None => (f64::NAN, f64::NAN, nalgebra::Vector3::repeat(f64::NAN)),
    };
    Ok(TrimPoint {
        mach,
        altitude_m: altitude,
        speed_mps: speed,
        tension_connection_n: out.connection_tension(),
        tension_tow_n: out.tow_tension(),
        tension_max_n: cable
            .iter()
            .map(|c| c.tension_n)
            .fold(f64::NEG_INFINITY, f64::max),
        decoy_pitch_deg: pitch,
        decoy_aoa_deg: aoa,
        decoy_cg_behind_m: -cg.x,
        decoy_cg_below_m: cg.z,
        cable,
    })
}

// ------------------------------------------------------------------ steady sweeps

/// What a steady sweep varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SteadyVariable {
    /// The Mach number, at a fixed altitude.
    Speed,
    /// The altitude, at a fixed Mach number.
    Altitude,
}

impl SteadyVariable {
    /// `speed` or `altitude`.
    pub fn name(self) -> &'static str {
        match self {
            SteadyVariable::Speed => "speed",
            SteadyVariable::Altitude => "altitude",
        }
    }
}

/// A steady sweep to run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SteadySweepSpec {
    /// What varies.
    pub variable: SteadyVariable,
    /// The Mach numbers (speed sweep) or altitudes, m (altitude sweep).
    pub values: Vec<f64>,
    /// The fixed Mach number of an altitude sweep.
    pub mach: f64,
    /// The fixed altitude of a speed sweep, m.
    pub altitude_m: f64,
    /// Cable discretisation.
    #[serde(skip)]
    pub layout: SegmentLayout<f64>,
}

impl SteadySweepSpec {
    /// The paper's sweep (DESIGN.md §8) with `config`'s host layout: Mach 0.5 to
    /// 0.9 by 0.05 at 9 km, or 3 to 12 km by 1 km at Mach 0.7.
    pub fn paper(variable: SteadyVariable, config: &SystemConfig) -> Self {
        let (range, mach, altitude_m) = Self::paper_range(variable);
        SteadySweepSpec {
            variable,
            values: range.values().unwrap_or_default(),
            mach,
            altitude_m,
            layout: config.host_layout(),
        }
    }

    /// The paper's range of `variable` and the fixed Mach number and altitude.
    pub fn paper_range(variable: SteadyVariable) -> (SweepRange, f64, f64) {
        match variable {
            SteadyVariable::Speed => (
                SweepRange {
                    from: 0.5,
                    to: 0.9,
                    step: 0.05,
                },
                0.7,
                9000.0,
            ),
            SteadyVariable::Altitude => (
                SweepRange {
                    from: 3000.0,
                    to: 12000.0,
                    step: 1000.0,
                },
                0.7,
                9000.0,
            ),
        }
    }

    /// Checks the values and the fixed condition (errors name the flags).
    pub fn check(&self) -> Result<(), SimError> {
        if self.values.is_empty() {
            return Err(cli_invalid("--from", "the sweep has no value".to_owned()));
        }
        let first = self.values[0];
        let last = self.values[self.values.len() - 1];
        match self.variable {
            SteadyVariable::Speed => {
                check_mach(&cli_invalid, "--from", first)?;
                check_mach(&cli_invalid, "--to", last)?;
                check_altitude(&cli_invalid, "--altitude", self.altitude_m)?;
            }
            SteadyVariable::Altitude => {
                check_altitude(&cli_invalid, "--from", first)?;
                check_altitude(&cli_invalid, "--to", last)?;
                check_mach(&cli_invalid, "--mach", self.mach)?;
            }
        }
        Ok(())
    }

    /// The flight condition `(altitude, mach)` of value `v`.
    fn condition(&self, v: f64) -> (f64, f64) {
        match self.variable {
            SteadyVariable::Speed => (self.altitude_m, v),
            SteadyVariable::Altitude => (v, self.mach),
        }
    }
}

/// The result of a steady sweep: one trim per value.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SteadySweep {
    /// What was run.
    #[serde(skip)]
    pub spec: SteadySweepSpec,
    /// What varied.
    pub variable: SteadyVariable,
    /// The fixed Mach number (altitude sweep), else `null`.
    pub fixed_mach: Option<f64>,
    /// The fixed altitude (speed sweep), m, else `null`.
    pub fixed_altitude_m: Option<f64>,
    /// The layout in words.
    pub layout: String,
    /// One trim per value, in order.
    pub points: Vec<TrimPoint>,
}

/// Trims the towed system at every value of `spec`; `progress` gets the fraction
/// done. Errors: bad values ([`SteadySweepSpec::check`]), no trim at a value
/// ([`SimError::AtPoint`]).
pub fn steady_sweep(
    config: &SystemConfig,
    spec: &SteadySweepSpec,
    mut progress: impl FnMut(f64),
) -> Result<SteadySweep, SimError> {
    spec.check()?;
    let mut points = Vec::with_capacity(spec.values.len());
    for (k, &v) in spec.values.iter().enumerate() {
        let (altitude, mach) = spec.condition(v);
        let point = trim_point(config, spec.layout, altitude, mach)
            .map_err(|e| e.at(format!("Mach {mach} at {altitude} m")))?;
        points.push(point);
        progress((k + 1) as f64 / spec.values.len() as f64);
    }
    Ok(SteadySweep {
        spec: spec.clone(),
        variable: spec.variable,
        fixed_mach: (spec.variable == SteadyVariable::Altitude).then_some(spec.mach),
        fixed_altitude_m: (spec.variable == SteadyVariable::Speed).then_some(spec.altitude_m),
        layout: crate::format::describe_layout(&spec.layout),
        points,
    })
}

/// The header of a steady sweep's `sweep.csv`.
pub const STEADY_SWEEP_HEADER: &str = "mach,altitude_m,speed_mps,tension_connection_N,tension_tow_N,tension_max_N,decoy_pitch_deg,decoy_aoa_deg,decoy_cg_behind_m,decoy_cg_below_m";
/// The header of a steady sweep's `cable.csv`.
pub const STEADY_CABLE_HEADER: &str = "mach,altitude_m,joint,along_m,behind_m,below_m,tension_N";

impl SteadySweep {
    /// `sweep.csv`'s text.
    pub fn table_csv(&self) -> String {
        let mut s = format!("{STEADY_SWEEP_HEADER}\n");
        for p in &self.points {
            let row = [
                p.mach,
                p.altitude_m,
                p.speed_mps,
                p.tension_connection_n,
                p.tension_tow_n,
                p.tension_max_n,
                p.decoy_pitch_deg,
                p.decoy_aoa_deg,
                p.decoy_cg_behind_m,
                p.decoy_cg_below_m,
            ];
            s.push_str(&csv_row(&row));
        }
        s
    }

    /// `cable.csv`'s text.
    pub fn cable_csv(&self) -> String {
        let mut s = format!("{STEADY_CABLE_HEADER}\n");
        for p in &self.points {
            for (j, c) in p.cable.iter().enumerate() {
                s.push_str(&format!(
                    "{},{},{j},{},{},{},{}\n",
                    format_value(p.mach),
                    format_value(p.altitude_m),
                    format_value(c.along_m),
                    format_value(c.behind_m),
                    format_value(c.below_m),
                    format_value(c.tension_n)
                ));
            }
        }
        s
    }

    /// The swept values and the axis label.
    fn abscissa(&self) -> (Vec<f64>, &'static str) {
        match self.spec.variable {
            SteadyVariable::Speed => (self.points.iter().map(|p| p.mach).collect(), "Mach number"),
            SteadyVariable::Altitude => (
                self.points.iter().map(|p| p.altitude_m / 1000.0).collect(),
                "altitude [km]",
            ),
        }
    }

    /// The legend label of one point.
    fn label(&self, p: &TrimPoint) -> String {
        match self.spec.variable {
            SteadyVariable::Speed => format!("Mach {}", trim_number(p.mach, 2)),
            SteadyVariable::Altitude => format!("{} km", trim_number(p.altitude_m / 1000.0, 1)),
        }
    }

    /// The condition held fixed, in words.
    pub fn fixed_condition(&self) -> String {
        match self.spec.variable {
            SteadyVariable::Speed => {
                format!("H = {} km", trim_number(self.spec.altitude_m / 1000.0, 3))
            }
            SteadyVariable::Altitude => format!("Mach {}", trim_number(self.spec.mach, 3)),
        }
    }

    /// The four plots: cable shapes, tension profiles, decoy pitch and depth,
    /// connection and towing tensions (the paper's Figs. 15-18 or 19-22).
    pub fn plots(&self) -> Vec<(&'static str, Vec<Plot>)> {
        let fixed = self.fixed_condition();
        let (x, x_label) = self.abscissa();
        let shapes = Plot {
            title: format!("Cable shape in steady level flight ({fixed})"),
            x_label: "behind the aircraft [m]".into(),
            y_label: "below the flight path [m]".into(),
            series: self
                .points
                .iter()
                .map(|p| Series {
                    label: self.label(p),
                    x: p.cable.iter().map(|c| c.behind_m).collect(),
                    y: p.cable.iter().map(|c| c.below_m).collect(),
                })
                .collect(),
            aspect: Aspect::Free,
            invert_y: true,
        };
        let profiles = plot(
            format!("Tension along the cable ({fixed})"),
            "distance along the cable from the connection point [m]",
            "tension [N]",
            self.points
                .iter()
                .map(|p| Series {
                    label: self.label(p),
                    x: p.cable.iter().map(|c| c.along_m).collect(),
                    y: p.cable.iter().map(|c| c.tension_n).collect(),
                })
                .collect(),
        );
        let one = |title: String, y_label: &str, label: &str, y: Vec<f64>| {
            plot(
                title,
                x_label,
                y_label,
                vec![Series {
                    label: label.into(),
                    x: x.clone(),
                    y,
                }],
            )
        };
        let decoy = vec![
            one(
                format!("Decoy pitch ({fixed})"),
                "pitch [deg]",
                "pitch",
                self.points.iter().map(|p| p.decoy_pitch_deg).collect(),
            ),
            one(
                format!("Decoy CG below the flight path ({fixed})"),
                "depth [m]",
                "depth",
                self.points.iter().map(|p| p.decoy_cg_below_m).collect(),
            ),
        ];
        let tensions = vec![
            one(
                format!("Connection-point (maximum) tension ({fixed})"),
                "tension [N]",
                "connection point",
                self.points.iter().map(|p| p.tension_connection_n).collect(),
            ),
            one(
                format!("Towing-point tension ({fixed})"),
                "tension [N]",
                "towing point",
                self.points.iter().map(|p| p.tension_tow_n).collect(),
            ),
        ];
        vec![
            ("cable-shapes", vec![shapes]),
            ("tension-profiles", vec![profiles]),
            ("decoy", decoy),
            ("tensions", tensions),
        ]
    }
}

/// Writes `sweep.csv`, `cable.csv` and (with `plots`) the plots of `sweep` into
/// `dir`; returns the files written.
pub fn write_steady_sweep(
    sweep: &SteadySweep,
    dir: &Path,
    plots: bool,
) -> Result<Vec<PathBuf>, SimError> {
    create_dir(dir)?;
    let mut files = vec![
        write_text(&dir.join("sweep.csv"), &sweep.table_csv())?,
        write_text(&dir.join("cable.csv"), &sweep.cable_csv())?,
    ];
    if plots {
        for (stem, panels) in sweep.plots() {
            files.extend(draw(dir, stem, &panels)?);
        }
    }
    Ok(files)
}

// ------------------------------------------------------------------ settling

/// Which decoy station a settling sweep varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StationVariable {
    /// The towing point `decoy.x_tow`, at the configured CG.
    TowPoint,
    /// The CG `decoy.x_cg`, at the configured towing point.
    Cg,
}

impl StationVariable {
    /// `tow-point` or `cg`.
    pub fn name(self) -> &'static str {
        match self {
            StationVariable::TowPoint => "tow-point",
            StationVariable::Cg => "cg",
        }
    }

    /// The configuration key varied.
    pub fn key(self) -> &'static str {
        match self {
            StationVariable::TowPoint => "decoy.x_tow",
            StationVariable::Cg => "decoy.x_cg",
        }
    }
}

/// A settling sweep to run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SettlingSpec {
    /// What varies.
    pub variable: StationVariable,
    /// The stations, m from the decoy nose.
    pub values: Vec<f64>,
    /// Mach number of the steady level flight.
    pub mach: f64,
    /// Altitude, m.
    pub altitude_m: f64,
    /// Cable segments.
    pub segments: usize,
    /// Segment length ratio (1 = uniform).
    pub grading: f64,
    /// RK4 time step, s.
    pub dt: f64,
    /// Simulated time of each run, s.
    pub t_end: f64,
    /// Initial nose-up pitch perturbation of the decoy about its towing point, deg.
    pub pitch_offset_deg: f64,
    /// The final window in which the pitch must have settled, s.
    pub window_s: f64,
    /// Settled: half the peak-to-peak pitch in the final window at most this, deg;
    /// also the band of the settling time.
    pub threshold_deg: f64,
}

impl SettlingSpec {
    /// The default study: `variable` over its default range, Mach 0.7 at 9 km,
    /// `config`'s embedded layout (16 segments graded 1.3), its host time step,
    /// 10 s runs, +5 deg, a 2 s window and a 0.1 deg threshold.
    pub fn paper(variable: StationVariable, config: &SystemConfig) -> Self {
        SettlingSpec {
            variable,
            values: Self::default_range(variable).values().unwrap_or_default(),
            mach: 0.7,
            altitude_m: 9000.0,
            segments: config.solver.segments_embedded,
            grading: config.solver.grading_ratio_embedded,
            dt: config.solver.time_step_host,
            t_end: 10.0,
            pitch_offset_deg: 5.0,
            window_s: 2.0,
            threshold_deg: 0.1,
        }
    }

    /// The default stations: towing point 0.05 to 0.60 m, CG 0.05 to 0.50 m, by
    /// 0.025 m (for the reference decoy of 0.9 m, with CG 0.27 m and towing point
    /// 0.12 m, both cross the other station and reach instability).
    pub fn default_range(variable: StationVariable) -> SweepRange {
        match variable {
            StationVariable::TowPoint => SweepRange {
                from: 0.05,
                to: 0.6,
                step: 0.025,
            },
            StationVariable::Cg => SweepRange {
                from: 0.05,
                to: 0.5,
                step: 0.025,
            },
        }
    }

    /// Checks everything but the plan (errors name the flags).
    pub fn check(&self, config: &SystemConfig) -> Result<(), SimError> {
        if self.values.is_empty() {
            return Err(cli_invalid("--from", "the sweep has no value".to_owned()));
        }
        let length = config.decoy.length;
        for (flag, v) in [
            ("--from", self.values[0]),
            ("--to", self.values[self.values.len() - 1]),
        ] {
            if !(0.0..=length).contains(&v) {
                return Err(cli_invalid(
                    flag,
                    format!(
                        "{v} m: {} must be on the decoy body, 0 to {length} m from the nose",
                        self.variable.key()
                    ),
                ));
            }
        }
        let offset = self.pitch_offset_deg;
        if !(offset.is_finite() && offset.abs() <= 45.0) {
            return Err(cli_invalid(
                "--pitch-offset",
                format!("must be between -45 and 45 deg, got {offset}"),
            ));
        }
        if !(self.threshold_deg.is_finite() && self.threshold_deg > 0.0) {
            return Err(cli_invalid(
                "--threshold",
                format!("must be a positive angle, got {}", self.threshold_deg),
            ));
        }
        if !(self.window_s.is_finite() && self.window_s > 0.0 && self.window_s < self.t_end) {
            return Err(cli_invalid(
                "--window",
                format!(
                    "must be positive and shorter than --t-end {} s, got {}",
                    self.t_end, self.window_s
                ),
            ));
        }
        Ok(())
    }

    /// The run plan (steady level flight; errors name the flags).
    pub fn plan(&self, config: &SystemConfig) -> Result<RunPlan, SimError> {
        let options = RunOptions {
            segments: Some(self.segments),
            grading: Some(self.grading),
            dt: Some(self.dt),
            t_end: Some(self.t_end),
            altitude: Some(self.altitude_m),
            mach: Some(self.mach),
            initial: InitialState::Trim,
            plots: false,
            ..RunOptions::default()
        };
        Scenario::builtin("steady")?.plan(config, &options)
    }

    /// `config` with the station set to `value`.
    fn configured(&self, config: &SystemConfig, value: f64) -> SystemConfig {
        let mut c = config.clone();
        match self.variable {
            StationVariable::TowPoint => c.decoy.x_tow = value,
            StationVariable::Cg => c.decoy.x_cg = value,
        }
        c
    }
}

/// Whether and when the decoy pitch settled ([`classify_settling`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Settling {
    /// Half the peak-to-peak pitch in the final window was at most the threshold
    /// and the run completed.
    pub settled: bool,
    /// Half the peak-to-peak pitch in the final window, deg.
    pub final_amplitude_deg: f64,
    /// Mean pitch in the final window, deg.
    pub final_pitch_deg: f64,
    /// When settled: the time from which the pitch stays within the threshold of
    /// the final pitch, s.
    pub settling_time_s: Option<f64>,
}

/// Classifies a pitch history `(t, pitch_deg)` (in time order): the final window
/// is the last `window_s` seconds; the decoy settled when the run `completed`,
/// the history covers at least the window, and half the peak-to-peak pitch in the
/// window is at most `threshold_deg`. The settling time is then the first time
/// after the last sample farther than `threshold_deg` from the window's mean pitch
/// (the first sample's time if none is).
pub fn classify_settling(
    history: &[(f64, f64)],
    window_s: f64,
    threshold_deg: f64,
    completed: bool,
) -> Settling {
    let Some(&(t_last, _)) = history.last() else {
        return Settling {
            settled: false,
            final_amplitude_deg: f64::NAN,
            final_pitch_deg: f64::NAN,
            settling_time_s: None,
        };
    };
    let start = t_last - window_s;
    let window: Vec<f64> = history
        .iter()
        .filter(|(t, _)| *t >= start - 1e-9)
        .map(|&(_, p)| p)
        .collect();
    let (lo, hi) = window
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let amplitude = 0.5 * (hi - lo);
    let mean = window.iter().sum::<f64>() / window.len() as f64;
    let covered = t_last - history[0].0 >= window_s - 1e-9;
    let settled = completed && covered && amplitude <= threshold_deg;
    let settling_time_s = settled.then(|| {
        match history
            .iter()
            .rposition(|&(_, p)| (p - mean).abs() > threshold_deg)
        {
            None => history[0].0,
            Some(i) => history[(i + 1).min(history.len() - 1)].0,
        }
    });
    Settling {
        settled,
        final_amplitude_deg: amplitude,
        final_pitch_deg: mean,
        settling_time_s,
    }
}

/// One station of a settling sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SettlingPoint {
    /// Towing point, m from the nose.
    pub x_tow_m: f64,
    /// CG, m from the nose.
    pub x_cg_m: f64,
    /// A trim (stable steady equilibrium) exists.
    pub trim_exists: bool,
    /// Decoy pitch at the trim, deg (`null` without trim).
    pub trim_pitch_deg: Option<f64>,
    /// Connection (maximum) tension at the trim, N (`null` without trim).
    #[serde(rename = "trim_tension_connection_N")]
    pub trim_tension_connection_n: Option<f64>,
    /// The dynamic run's classification.
    #[serde(flatten)]
    pub settling: Settling,
    /// Largest connection tension over the dynamic run, N.
    #[serde(rename = "max_tension_connection_N")]
    pub max_tension_connection_n: f64,
    /// When the dynamic run diverged, s (`null` if it completed).
    pub stopped_s: Option<f64>,
    /// Decoy pitch `(t, deg)` every 10 ms of the dynamic run.
    #[serde(skip)]
    pub pitch_history: Vec<(f64, f64)>,
}

impl SettlingPoint {
    /// The varied station's value.
    pub fn station(&self, variable: StationVariable) -> f64 {
        match variable {
            StationVariable::TowPoint => self.x_tow_m,
            StationVariable::Cg => self.x_cg_m,
        }
    }
}

/// The result of a settling sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SettlingSweep {
    /// What was run.
    pub spec: SettlingSpec,
    /// The fixed station (CG of a tow-point sweep, towing point of a CG sweep), m.
    pub fixed_station_m: f64,
    /// One result per station, in order.
    pub points: Vec<SettlingPoint>,
}

/// Runs the settling study `spec` (see the module docs); `progress` gets the
/// fraction done. Errors: bad inputs (naming the flags), an unusable configuration.
/// A run that diverges is a result (not settled, `stopped_s`), not an error.
pub fn settling_sweep(
    config: &SystemConfig,
    spec: &SettlingSpec,
    mut progress: impl FnMut(f64),
) -> Result<SettlingSweep, SimError> {
    spec.check(config)?;
    let plan = spec.plan(config)?;
    let layout = plan.layout;
    let options = TraceOptions {
        start: Start::TrimElseStraight,
        pitch_offset_deg: spec.pitch_offset_deg,
        sample_interval_s: plan.dt,
        snapshot_interval_s: plan.t_end * 2.0,
    };
    let count = spec.values.len();
    let mut points = Vec::with_capacity(count);
    for (k, &value) in spec.values.iter().enumerate() {
        let point_name = format!("{} = {value} m", spec.variable.key());
        let config = spec.configured(config, value);
        config
            .validate()
            .map_err(|e| SimError::from(e).at(point_name.clone()))?;
        let trimmed = match trim_point(&config, layout, spec.altitude_m, spec.mach) {
            Ok(t) => Some(t),
            Err(SimError::NoTrim(_)) => None,
            Err(e) => return Err(e.at(point_name)),
        };
        let base = k as f64 / count as f64;
        let run = trace(&config, &plan, &options, |f| {
            progress(base + f / count as f64)
        })
        .map_err(|e| e.at(point_name.clone()))?;
        let history: Vec<(f64, f64)> = run.samples.iter().map(|s| (s.t, s.euler_deg[1])).collect();
        let settling = classify_settling(
            &history,
            spec.window_s,
            spec.threshold_deg,
            run.stopped.is_none(),
        );
        let every = ((HISTORY_INTERVAL_S / plan.dt).round() as usize).max(1);
        let mut pitch_history: Vec<(f64, f64)> = history.iter().step_by(every).copied().collect();
        if let (Some(last), Some(kept)) = (history.last(), pitch_history.last())
            && kept.0 < last.0
        {
            pitch_history.push(*last);
        }
        points.push(SettlingPoint {
            x_tow_m: config.decoy.x_tow,
            x_cg_m: config.decoy.x_cg,
            trim_exists: trimmed.is_some(),
            trim_pitch_deg: trimmed.as_ref().map(|t| t.decoy_pitch_deg),
            trim_tension_connection_n: trimmed.as_ref().map(|t| t.tension_connection_n),
            settling,
            max_tension_connection_n: run.max_tension_connection_n,
            stopped_s: run.stopped.as_ref().map(|s| s.t_s),
            pitch_history,
        });
        progress((k + 1) as f64 / count as f64);
    }
    Ok(SettlingSweep {
        fixed_station_m: match spec.variable {
            StationVariable::TowPoint => config.decoy.x_cg,
            StationVariable::Cg => config.decoy.x_tow,
        },
        spec: spec.clone(),
        points,
    })
}

/// The header of a settling sweep's `sweep.csv`.
pub const SETTLING_SWEEP_HEADER: &str = "x_tow_m,x_cg_m,trim_exists,trim_pitch_deg,trim_tension_connection_N,settled,settling_time_s,final_amplitude_deg,final_pitch_deg,max_tension_connection_N,stopped_s";
/// The header of a settling sweep's `pitch.csv`.
pub const SETTLING_PITCH_HEADER: &str = "x_tow_m,x_cg_m,t_s,decoy_pitch_deg";

impl SettlingSweep {
    /// `sweep.csv`'s text (empty fields for missing values).
    pub fn table_csv(&self) -> String {
        let opt = |v: Option<f64>| v.map(format_value).unwrap_or_default();
        let mut s = format!("{SETTLING_SWEEP_HEADER}\n");
        for p in &self.points {
            s.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{},{}\n",
                format_value(p.x_tow_m),
                format_value(p.x_cg_m),
                p.trim_exists,
                opt(p.trim_pitch_deg),
                opt(p.trim_tension_connection_n),
                p.settling.settled,
                opt(p.settling.settling_time_s),
                format_value(p.settling.final_amplitude_deg),
                format_value(p.settling.final_pitch_deg),
                format_value(p.max_tension_connection_n),
                opt(p.stopped_s),
            ));
        }
        s
    }

    /// `pitch.csv`'s text: every point's pitch history.
    pub fn pitch_csv(&self) -> String {
        let mut s = format!("{SETTLING_PITCH_HEADER}\n");
        for p in &self.points {
            let stations = format!("{},{}", format_value(p.x_tow_m), format_value(p.x_cg_m));
            for &(t, pitch) in &p.pitch_history {
                s.push_str(&format!(
                    "{stations},{},{}\n",
                    crate::format::format_time(t),
                    format_value(pitch)
                ));
            }
        }
        s
    }

    /// The varied stations.
    fn stations(&self) -> Vec<f64> {
        self.points
            .iter()
            .map(|p| p.station(self.spec.variable))
            .collect()
    }

    /// The x axis label and the fixed station in words.
    fn axis(&self) -> (&'static str, String) {
        match self.spec.variable {
            StationVariable::TowPoint => (
                "towing point x_tow [m from the nose]",
                format!("x_cg = {} m", trim_number(self.fixed_station_m, 3)),
            ),
            StationVariable::Cg => (
                "CG x_cg [m from the nose]",
                format!("x_tow = {} m", trim_number(self.fixed_station_m, 3)),
            ),
        }
    }

    /// The plots: settling time and final amplitude, trim pitch and tension
    /// (Figs. 23-24), pitch histories.
    pub fn plots(&self) -> Vec<(&'static str, Vec<Plot>)> {
        let x = self.stations();
        let (x_label, fixed) = self.axis();
        let m = self.spec.mach;
        let h = self.spec.altitude_m / 1000.0;
        let condition = format!(
            "{fixed}, Mach {}, {} km",
            trim_number(m, 3),
            trim_number(h, 3)
        );
        let single = |title: String, y_label: &str, label: &str, y: Vec<f64>| {
            plot(
                title,
                x_label,
                y_label,
                vec![Series {
                    label: label.into(),
                    x: x.clone(),
                    y,
                }],
            )
        };
        let settling_time = single(
            format!(
                "Settling time after +{} deg pitch (gaps: not settled; {condition})",
                trim_number(self.spec.pitch_offset_deg, 3)
            ),
            "settling time [s]",
            "settling time",
            self.points
                .iter()
                .map(|p| p.settling.settling_time_s.unwrap_or(f64::NAN))
                .collect(),
        );
        let mut settling_time = settling_time;
        if self.points.iter().any(|p| !p.settling.settled) {
            settling_time.series.push(Series {
                label: "not settled (drawn at 0)".into(),
                x: x.clone(),
                y: self
                    .points
                    .iter()
                    .map(|p| if p.settling.settled { f64::NAN } else { 0.0 })
                    .collect(),
            });
        }
        let mut amplitude = single(
            format!(
                "Pitch amplitude in the last {} s (log10; settled below the line)",
                trim_number(self.spec.window_s, 3)
            ),
            "log10(amplitude [deg])",
            "half peak-to-peak pitch",
            self.points
                .iter()
                .map(|p| p.settling.final_amplitude_deg.max(1e-6).log10())
                .collect(),
        );
        amplitude.series.push(Series {
            label: format!("threshold {} deg", trim_number(self.spec.threshold_deg, 3)),
            x: x.clone(),
            y: vec![self.spec.threshold_deg.log10(); x.len()],
        });
        let trim_pitch = single(
            format!("Decoy pitch at trim (gaps: no trim; {condition})"),
            "pitch [deg]",
            "pitch",
            self.points
                .iter()
                .map(|p| p.trim_pitch_deg.unwrap_or(f64::NAN))
                .collect(),
        );
        let trim_tension = single(
            format!("Connection (maximum) tension at trim ({condition})"),
            "tension [N]",
            "connection point",
            self.points
                .iter()
                .map(|p| p.trim_tension_connection_n.unwrap_or(f64::NAN))
                .collect(),
        );
        let name = |p: &SettlingPoint| {
            format!(
                "{} = {} m",
                match self.spec.variable {
                    StationVariable::TowPoint => "x_tow",
                    StationVariable::Cg => "x_cg",
                },
                trim_number(p.station(self.spec.variable), 3)
            )
        };
        let histories = |settled: bool| -> Vec<Series> {
            let chosen: Vec<&SettlingPoint> = self
                .points
                .iter()
                .filter(|p| p.settling.settled == settled && !p.pitch_history.is_empty())
                .collect();
            evenly(&chosen, MAX_HISTORIES)
                .into_iter()
                .map(|p| Series {
                    label: name(p),
                    x: p.pitch_history.iter().map(|h| h.0).collect(),
                    y: p.pitch_history.iter().map(|h| h.1).collect(),
                })
                .collect()
        };
        let mut panels = Vec::new();
        for (settled, what) in [(true, "settled"), (false, "not settled")] {
            let series = histories(settled);
            if !series.is_empty() {
                panels.push(plot(
                    format!(
                        "Decoy pitch after the +{} deg perturbation: {what}",
                        trim_number(self.spec.pitch_offset_deg, 3)
                    ),
                    "t [s]",
                    "pitch [deg]",
                    series,
                ));
            }
        }
        let mut plots = vec![
            ("settling", vec![settling_time, amplitude]),
            ("trim", vec![trim_pitch, trim_tension]),
        ];
        if !panels.is_empty() {
            plots.push(("pitch-histories", panels));
        }
        plots
    }
}

/// Writes `sweep.csv`, `pitch.csv` and (with `plots`) the plots of `sweep` into
/// `dir`; returns the files written.
pub fn write_settling_sweep(
    sweep: &SettlingSweep,
    dir: &Path,
    plots: bool,
) -> Result<Vec<PathBuf>, SimError> {
    create_dir(dir)?;
    let mut files = vec![
        write_text(&dir.join("sweep.csv"), &sweep.table_csv())?,
        write_text(&dir.join("pitch.csv"), &sweep.pitch_csv())?,
    ];
    if plots {
        for (stem, panels) in sweep.plots() {
            files.extend(draw(dir, stem, &panels)?);
        }
    }
    Ok(files)
}

// ------------------------------------------------------------------ helpers

/// A plot with free aspect and upward y.
pub(crate) fn plot(title: String, x_label: &str, y_label: &str, series: Vec<Series>) -> Plot {
    Plot {
        title,
        x_label: x_label.to_owned(),
        y_label: y_label.to_owned(),
        series,
        aspect: Aspect::Free,
        invert_y: false,
    }
}

/// Up to `most` of `items`, evenly spread, first and last included.
pub(crate) fn evenly<T: Copy>(items: &[T], most: usize) -> Vec<T> {
    let m = items.len();
    if m <= most {
        return items.to_vec();
    }
    if most < 2 {
        return items.iter().copied().take(most).collect();
    }
    let mut indices: Vec<usize> = (0..most)
        .map(|i| (i * (m - 1) + (most - 1) / 2) / (most - 1))
        .collect();
    indices.dedup();
    indices.into_iter().map(|i| items[i]).collect()
}

/// `v` with at most `decimals` decimals, trailing zeros dropped (0.50 -> 0.5).
pub(crate) fn trim_number(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".to_owned()
        } else {
            s.to_owned()
        }
    } else {
        s
    }
}

/// One CSV row of values (six decimals).
pub(crate) fn csv_row(values: &[f64]) -> String {
    let mut row = values
        .iter()
        .map(|v| format_value(*v))
        .collect::<Vec<_>>()
        .join(",");
    row.push('\n');
    row
}

/// Creates `dir` and its parents.
pub(crate) fn create_dir(dir: &Path) -> Result<(), SimError> {
    std::fs::create_dir_all(dir).map_err(|source| SimError::Io {
        action: "create the directory",
        path: dir.to_owned(),
        source,
    })
}

/// Writes `text` to `path`.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<PathBuf, SimError> {
    std::fs::write(path, text).map_err(|source| SimError::Io {
        action: "write",
        path: path.to_owned(),
        source,
    })?;
    Ok(path.to_owned())
}

/// Draws one figure (one plot, or several stacked) as `dir/stem.png` and `.svg`.
pub(crate) fn draw(dir: &Path, stem: &str, panels: &[Plot]) -> Result<[PathBuf; 2], SimError> {
    let path = dir.join(stem);
    let result: Result<[PathBuf; 2], PlotError> = if panels.len() == 1 {
        write_plot(&panels[0], &path)
    } else {
        write_stacked(panels, &path)
    };
    result.map_err(|e| SimError::Plot {
        stem: path,
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_round_and_include_the_end() {
        let r = SweepRange {
            from: 0.5,
            to: 0.9,
            step: 0.05,
        };
        let v = r.values().unwrap();
        assert_eq!(v.len(), 9);
        assert_eq!(v[3], 0.65);
        assert_eq!(v[8], 0.9);
        let one = SweepRange {
            from: 0.7,
            to: 0.7,
            step: 0.1,
        };
        assert_eq!(one.values().unwrap(), vec![0.7]);
    }

    #[test]
    fn bad_ranges_name_the_flag() {
        let bad = |from: f64, to: f64, step: f64, flag: &str| {
            let e = SweepRange { from, to, step }.values().unwrap_err();
            assert!(e.is_usage());
            assert!(e.to_string().contains(flag), "{e}");
        };
        bad(0.5, 0.9, 0.0, "--step");
        bad(0.5, 0.9, -0.1, "--step");
        bad(0.9, 0.5, 0.1, "--from");
        bad(f64::NAN, 0.5, 0.1, "--from");
        bad(0.0, 1.0, 1e-6, "--step");
    }

    #[test]
    fn settling_classification() {
        // A decaying oscillation that ends below 0.1 deg: settled, at the last excursion.
        let decaying: Vec<(f64, f64)> = (0..=1000)
            .map(|k| {
                let t = k as f64 * 0.01;
                (t, 1.0 + 5.0 * (-t).exp() * (10.0 * t).cos())
            })
            .collect();
        let s = classify_settling(&decaying, 2.0, 0.1, true);
        assert!(s.settled);
        let t = s.settling_time_s.unwrap();
        assert!(t > 3.0 && t < 4.0, "{t}");
        assert!((s.final_pitch_deg - 1.0).abs() < 1e-3);
        // The same history from a run that diverged is not settled.
        assert!(!classify_settling(&decaying, 2.0, 0.1, false).settled);
        // A sustained oscillation is not settled.
        let sustained: Vec<(f64, f64)> = (0..=1000)
            .map(|k| (k as f64 * 0.01, 0.5 * (10.0 * k as f64 * 0.01).sin()))
            .collect();
        let s = classify_settling(&sustained, 2.0, 0.1, true);
        assert!(!s.settled && s.settling_time_s.is_none());
        assert!((s.final_amplitude_deg - 0.5).abs() < 0.01);
        // Too short a history cannot show it settled.
        assert!(!classify_settling(&sustained[..100], 2.0, 1.0, true).settled);
    }

    #[test]
    fn evenly_spread_keeps_the_ends() {
        let v: Vec<usize> = (0..23).collect();
        let e = evenly(&v, 10);
        assert_eq!(e.len(), 10);
        assert_eq!((e[0], e[9]), (0, 22));
        assert_eq!(evenly(&v[..4], 10), vec![0, 1, 2, 3]);
    }

    #[test]
    fn numbers_drop_trailing_zeros() {
        assert_eq!(trim_number(0.5, 2), "0.5");
        assert_eq!(trim_number(12.0, 1), "12");
        assert_eq!(trim_number(0.125, 3), "0.125");
        assert_eq!(trim_number(-0.0001, 2), "0");
    }
}
