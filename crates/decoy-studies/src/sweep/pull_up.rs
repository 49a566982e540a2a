//! [`pull_up_sweep`]: the largest pull-up rate that keeps the cable out of the
//! exhaust plume (`decoy sweep pull-up-rate`; the paper's advice: below 0.10 rad/s).
//!
//! The paper's pull-up (the built-in `pull-up` scenario: level flight to t = 2 s,
//! the flight path rotating up at the rate for 5 s, then the climb held) is flown
//! at every rate of a grid; the smallest cable-plume clearance over each run
//! (every RK4 step, every joint and segment midpoint) is compared with the
//! margin (default 0: out of the plume). Between the largest grid rate that stays
//! clear (with every slower grid rate clear too) and the next grid rate, which
//! enters, the limit is found by bisection to the tolerance. The result assumes
//! the clearance falls as the rate grows between those two grid rates (the grid
//! shows whether it does elsewhere).

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_plots::{Plot, Series};
use serde::Serialize;

use decoy_sim::error::SimError;
use decoy_sim::format::{format_time, format_value};
use decoy_sim::options::RunOptions;
use decoy_sim::scenario::{MAX_RATE_RADPS, RunPlan, Scenario};
use decoy_sim::trace::{TraceOptions, trace};

use super::{
    MAX_HISTORIES, SweepRange, cli_invalid, csv_row, evenly, plot, trim_number, write_sweep,
};

/// Interval of the clearance histories kept for the plots and `histories.csv`, s.
const PULL_UP_HISTORY_INTERVAL_S: f64 = 0.02;
/// Most bisection steps (the tolerance normally stops it far earlier).
const MAX_BISECTIONS: usize = 30;

/// A pull-up rate search to run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PullUpSpec {
    /// The grid of rates, rad/s, increasing.
    pub rates: Vec<f64>,
    /// Initial Mach number.
    pub mach: f64,
    /// Initial altitude, m.
    pub altitude_m: f64,
    /// Cable segments.
    pub segments: usize,
    /// Segment length ratio (1 = uniform).
    pub grading: f64,
    /// A fixed RK4 time step, s; `None`: the adaptive step rule
    /// (docs/outputs.md, "Time steps").
    pub dt: Option<f64>,
    /// Simulated time of each run, s.
    pub t_end: f64,
    /// Bisection stops when the bracket is at most this wide, rad/s.
    pub tolerance_radps: f64,
    /// A run keeps clear when its smallest cable-plume clearance is at least this, m.
    pub margin_m: f64,
}

impl PullUpSpec {
    /// The default search: 0.02 to 0.20 rad/s by 0.02, Mach 0.6 at 9 km (the
    /// paper's pull-up), `config`'s embedded layout and host time step, 20 s runs,
    /// bisection to 0.001 rad/s, margin 0 (out of the plume).
    pub fn paper(config: &SystemConfig) -> Self {
        PullUpSpec {
            rates: Self::default_range().values().unwrap_or_default(),
            mach: 0.6,
            altitude_m: 9000.0,
            segments: config.solver.segments_embedded,
            grading: config.solver.grading_ratio_embedded,
            dt: None,
            t_end: 20.0,
            tolerance_radps: 0.001,
            margin_m: 0.0,
        }
    }

    /// The default grid: 0.02 to 0.20 rad/s by 0.02.
    pub fn default_range() -> SweepRange {
        SweepRange {
            from: 0.02,
            to: 0.2,
            step: 0.02,
        }
    }

    /// Checks the rates, tolerance and margin (errors name the flags).
    pub fn check(&self) -> Result<(), SimError> {
        let (Some(&first), Some(&last)) = (self.rates.first(), self.rates.last()) else {
            return Err(cli_invalid("--from", "the search has no rate".to_owned()));
        };
        for (flag, v) in [("--from", first), ("--to", last)] {
            if !(v > 0.0 && v <= MAX_RATE_RADPS) {
                return Err(cli_invalid(
                    flag,
                    format!(
                        "a pull-up rate must be above 0 and at most {MAX_RATE_RADPS} rad/s, got {v}"
                    ),
                ));
            }
        }
        if !(self.tolerance_radps.is_finite() && self.tolerance_radps > 0.0) {
            return Err(cli_invalid(
                "--tolerance",
                format!("must be a positive rate, got {}", self.tolerance_radps),
            ));
        }
        if !self.margin_m.is_finite() {
            return Err(cli_invalid(
                "--margin",
                format!("must be a finite distance, got {}", self.margin_m),
            ));
        }
        Ok(())
    }

    /// The run plan of one rate (errors name the flags).
    pub fn plan(&self, config: &SystemConfig, rate: f64) -> Result<RunPlan, SimError> {
        let dt = self.dt;
        let options = RunOptions {
            segments: Some(self.segments),
            grading: Some(self.grading),
            dt,
            t_end: Some(self.t_end),
            altitude: Some(self.altitude_m),
            mach: Some(self.mach),
            rate: Some(rate),
            plots: false,
            ..RunOptions::default()
        };
        Scenario::builtin("pull-up")?.plan(config, &options)
    }
}

/// One pull-up of the search.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PullUpPoint {
    /// Flight-path rotation rate, rad/s.
    pub rate_radps: f64,
    /// Flown by the bisection (not on the grid).
    pub bisection: bool,
    /// Smallest cable-plume clearance over the run (every step), m; negative inside.
    pub min_clearance_m: f64,
    /// When the smallest kept sample's clearance occurred, s.
    pub t_at_min_clearance_s: f64,
    /// Where on the cable, m from the connection point.
    pub along_at_min_clearance_m: f64,
    /// The steady clearance before the pull-up (t = 0), m.
    pub initial_clearance_m: f64,
    /// Largest connection tension, N.
    #[serde(rename = "max_tension_connection_N")]
    pub max_tension_connection_n: f64,
    /// Smallest depth of the decoy CG below the flight path, m (negative: above).
    pub min_decoy_depth_m: f64,
    /// Clear: the run completed and its smallest clearance is at least the margin.
    pub clear: bool,
    /// When the run diverged, s (`null` if it completed).
    pub stopped_s: Option<f64>,
    /// `(t, clearance)` every 20 ms.
    #[serde(skip)]
    pub history: Vec<(f64, f64)>,
}

/// The result of a pull-up rate search.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PullUpSweep {
    /// What was run.
    pub spec: PullUpSpec,
    /// Every run, by rate (grid and bisection).
    pub points: Vec<PullUpPoint>,
    /// The largest rate found clear, rad/s (within the tolerance of the limit);
    /// `null` when the slowest grid rate already enters the plume.
    pub limit_radps: Option<f64>,
    /// The slowest rate found to enter the plume, rad/s; `null` when every grid
    /// rate stays clear (the limit is above the grid).
    pub first_entering_radps: Option<f64>,
}

impl PullUpSweep {
    /// The limit in words: "0.104 rad/s (clear at 0.104, enters at 0.105)".
    pub fn describe_limit(&self) -> String {
        match (self.limit_radps, self.first_entering_radps) {
            (Some(lo), Some(hi)) => format!(
                "{} rad/s (clear at {}, in the plume at {} rad/s)",
                trim_number(lo, 4),
                trim_number(lo, 4),
                trim_number(hi, 4)
            ),
            (None, Some(hi)) => format!(
                "below {} rad/s (the slowest rate flown already enters the plume)",
                trim_number(hi, 4)
            ),
            (Some(lo), None) => format!(
                "above {} rad/s (every rate flown keeps clear)",
                trim_number(lo, 4)
            ),
            (None, None) => "not found".to_owned(),
        }
    }
}

/// Flies the pull-up at every rate of `spec` and bisects the limit (see the
/// module docs); `progress` gets the fraction done (the bisection counted as
/// a few more runs). Errors: bad inputs (naming the flags), an unusable
/// configuration, no trim at the initial condition. A run that diverges is a
/// result (not clear, `stopped_s`).
pub fn pull_up_sweep(
    config: &SystemConfig,
    spec: &PullUpSpec,
    mut progress: impl FnMut(f64),
) -> Result<PullUpSweep, SimError> {
    spec.check()?;
    let mut rates = spec.rates.clone();
    rates.sort_by(f64::total_cmp);
    rates.dedup();
    let bisections = ((rates.get(1).map_or(0.0, |r| r - rates[0]) / spec.tolerance_radps)
        .max(1.0)
        .log2()
        .ceil() as usize)
        .min(MAX_BISECTIONS);
    let total = (rates.len() + bisections) as f64;
    let mut done = 0usize;
    let mut fly = |rate: f64, bisection: bool| -> Result<PullUpPoint, SimError> {
        let base = done as f64 / total;
        let point = fly_pull_up(config, spec, rate, bisection, |f| {
            progress(base + f / total)
        })?;
        done += 1;
        progress((done as f64 / total).min(1.0));
        Ok(point)
    };
    let mut points = Vec::with_capacity(rates.len() + bisections);
    for &rate in &rates {
        points.push(fly(rate, false)?);
    }
    // The first grid rate that is not clear; every slower one is.
    let first_out = points.iter().position(|p| !p.clear);
    let (mut limit, mut entering) = match first_out {
        None => (points.last().map(|p| p.rate_radps), None),
        Some(0) => (None, Some(points[0].rate_radps)),
        Some(k) => (Some(points[k - 1].rate_radps), Some(points[k].rate_radps)),
    };
    if let (Some(mut lo), Some(mut hi)) = (limit, entering) {
        let mut steps = 0;
        while hi - lo > spec.tolerance_radps * (1.0 + 1e-9) && steps < MAX_BISECTIONS {
            let mid = super::round9(0.5 * (lo + hi));
            let point = fly(mid, true)?;
            if point.clear {
                lo = mid;
            } else {
                hi = mid;
            }
            points.push(point);
            steps += 1;
        }
        limit = Some(lo);
        entering = Some(hi);
    }
    points.sort_by(|a, b| a.rate_radps.total_cmp(&b.rate_radps));
    progress(1.0);
    Ok(PullUpSweep {
        spec: spec.clone(),
        points,
        limit_radps: limit,
        first_entering_radps: entering,
    })
}

fn fly_pull_up(
    config: &SystemConfig,
    spec: &PullUpSpec,
    rate: f64,
    bisection: bool,
    progress: impl FnMut(f64),
) -> Result<PullUpPoint, SimError> {
    let plan = spec.plan(config, rate)?;
    let options = TraceOptions {
        sample_interval_s: plan.timeline.row_interval(),
        snapshot_interval_s: plan.t_end * 2.0,
        ..TraceOptions::default()
    };
    let what = format!("pull-up at {rate} rad/s");
    let run = trace(config, &plan, &options, progress).map_err(|e| e.at(what))?;
    let (mut t_min, mut along_min, mut best) = (0.0, f64::NAN, f64::INFINITY);
    let mut min_depth = f64::INFINITY;
    for s in &run.samples {
        if s.exhaust_clearance < best {
            (best, t_min, along_min) = (s.exhaust_clearance, s.t, s.exhaust_along);
        }
        min_depth = min_depth.min(s.cg[2]);
    }
    let every =
        ((PULL_UP_HISTORY_INTERVAL_S / plan.timeline.row_interval()).round() as usize).max(1);
    let mut history: Vec<(f64, f64)> = run
        .samples
        .iter()
        .step_by(every)
        .map(|s| (s.t, s.exhaust_clearance))
        .collect();
    if let (Some(last), Some(kept)) = (run.samples.last(), history.last())
        && kept.0 < last.t
    {
        history.push((last.t, last.exhaust_clearance));
    }
    let completed = run.stopped.is_none();
    Ok(PullUpPoint {
        rate_radps: rate,
        bisection,
        min_clearance_m: run.min_cable_clearance_to_exhaust_m,
        t_at_min_clearance_s: t_min,
        along_at_min_clearance_m: along_min,
        initial_clearance_m: run.samples[0].exhaust_clearance,
        max_tension_connection_n: run.max_tension_connection_n,
        min_decoy_depth_m: min_depth,
        clear: completed && run.min_cable_clearance_to_exhaust_m >= spec.margin_m,
        stopped_s: run.stopped.as_ref().map(|s| s.t_s),
        history,
    })
}

/// The header of a pull-up search's `sweep.csv`.
pub const PULL_UP_SWEEP_HEADER: &str = "rate_radps,bisection,clear,min_clearance_m,t_at_min_clearance_s,along_at_min_clearance_m,initial_clearance_m,max_tension_connection_N,min_decoy_depth_m,stopped_s";
/// The header of a pull-up search's `histories.csv`.
pub const PULL_UP_HISTORY_HEADER: &str = "rate_radps,t_s,cable_exhaust_clearance_m";

impl PullUpSweep {
    /// `sweep.csv`'s text.
    pub fn table_csv(&self) -> String {
        let mut s = format!("{PULL_UP_SWEEP_HEADER}\n");
        for p in &self.points {
            s.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{}\n",
                format_value(p.rate_radps),
                p.bisection,
                p.clear,
                format_value(p.min_clearance_m),
                format_time(p.t_at_min_clearance_s),
                format_value(p.along_at_min_clearance_m),
                format_value(p.initial_clearance_m),
                format_value(p.max_tension_connection_n),
                format_value(p.min_decoy_depth_m),
                p.stopped_s.map(format_time).unwrap_or_default(),
            ));
        }
        s
    }

    /// `histories.csv`'s text.
    pub fn histories_csv(&self) -> String {
        let mut s = format!("{PULL_UP_HISTORY_HEADER}\n");
        for p in &self.points {
            for &(t, c) in &p.history {
                s.push_str(&format!(
                    "{},{},{}",
                    format_value(p.rate_radps),
                    format_time(t),
                    csv_row(&[c])
                ));
            }
        }
        s
    }

    /// The flight condition in words, for example "Mach 0.6, 9 km".
    pub fn condition(&self) -> String {
        format!(
            "Mach {}, {} km",
            trim_number(self.spec.mach, 3),
            trim_number(self.spec.altitude_m / 1000.0, 3)
        )
    }

    /// The plots: the smallest clearance against the rate with the margin and the
    /// limit; the clearance against time for some of the rates.
    pub fn plots(&self) -> Vec<(&'static str, Vec<Plot>)> {
        let condition = self.condition();
        let x: Vec<f64> = self.points.iter().map(|p| p.rate_radps).collect();
        let mut limit = plot(
            format!(
                "Smallest cable-plume clearance in the pull-up ({condition}); limit {}",
                self.describe_limit()
            ),
            "pull-up rate [rad/s]",
            "smallest clearance [m]",
            vec![
                Series {
                    label: "smallest cable-plume clearance".into(),
                    x: x.clone(),
                    y: self.points.iter().map(|p| p.min_clearance_m).collect(),
                },
                Series {
                    label: format!("margin {} m", trim_number(self.spec.margin_m, 3)),
                    x: x.clone(),
                    y: vec![self.spec.margin_m; x.len()],
                },
            ],
        );
        if let Some(l) = self.limit_radps {
            let (lo, hi) = self
                .points
                .iter()
                .map(|p| p.min_clearance_m)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                });
            limit.series.push(Series {
                label: format!("limit {} rad/s", trim_number(l, 4)),
                x: vec![l, l],
                y: vec![lo, hi],
            });
        }
        let grid: Vec<&PullUpPoint> = self.points.iter().filter(|p| !p.bisection).collect();
        let histories = plot(
            format!("Cable-plume clearance during the pull-up ({condition})"),
            "t [s]",
            "clearance [m]",
            evenly(&grid, MAX_HISTORIES)
                .into_iter()
                .map(|p| Series {
                    label: format!("{} rad/s", trim_number(p.rate_radps, 4)),
                    x: p.history.iter().map(|h| h.0).collect(),
                    y: p.history.iter().map(|h| h.1).collect(),
                })
                .collect(),
        );
        vec![
            ("limit", vec![limit]),
            ("clearance-histories", vec![histories]),
        ]
    }
}

/// Writes `sweep.csv`, `histories.csv` and (with `plots`) the plots of `sweep`
/// into `dir`; returns the files written.
pub fn write_pull_up_sweep(
    sweep: &PullUpSweep,
    dir: &Path,
    plots: bool,
) -> Result<Vec<PathBuf>, SimError> {
    write_sweep(
        dir,
        &[
            ("sweep.csv", sweep.table_csv()),
            ("histories.csv", sweep.histories_csv()),
        ],
        plots.then(|| sweep.plots()),
    )
}
