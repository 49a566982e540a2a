//! [`settling_sweep`]: the decoy settling from a pitched trim at each towing-point
//! or CG station (`decoy sweep tow-point|cg`).

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_plots::{Plot, Series};
use serde::Serialize;

use decoy_sim::error::SimError;
use decoy_sim::format::format_value;
use decoy_sim::options::{InitialState, RunOptions};
use decoy_sim::scenario::{RunPlan, Scenario};
use decoy_sim::trace::{Start, TraceOptions, trace};
use decoy_sim::trim::trim_point;

use super::{
    HISTORY_INTERVAL_S, MAX_HISTORIES, SweepRange, cli_invalid, evenly, plot, trim_number,
    write_sweep,
};

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
    /// A fixed RK4 time step, s; `None`: the adaptive step rule
    /// (docs/outputs.md, "Time steps").
    pub dt: Option<f64>,
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
    /// `config`'s embedded layout (`solver.segments_embedded` graded by
    /// `solver.grading_ratio_embedded`), its host time step,
    /// 10 s runs, +5 deg, a 2 s window and a 0.1 deg threshold.
    pub fn paper(variable: StationVariable, config: &SystemConfig) -> Self {
        SettlingSpec {
            variable,
            values: Self::default_range(variable).values().unwrap_or_default(),
            mach: 0.7,
            altitude_m: 9000.0,
            segments: config.solver.segments_embedded,
            grading: config.solver.grading_ratio_embedded,
            dt: None,
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
        let dt = self.dt;
        let options = RunOptions {
            segments: Some(self.segments),
            grading: Some(self.grading),
            dt,
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
        sample_interval_s: plan.timeline.row_interval(),
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
        let every = ((HISTORY_INTERVAL_S / plan.timeline.row_interval()).round() as usize).max(1);
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
                    decoy_sim::format::format_time(t),
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
    write_sweep(
        dir,
        &[
            ("sweep.csv", sweep.table_csv()),
            ("pitch.csv", sweep.pitch_csv()),
        ],
        plots.then(|| sweep.plots()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
