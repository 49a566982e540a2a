//! The report's data: every case it runs ([`collect`]) and the measures taken from them.

use decoy_config::SystemConfig;
use solver_core::SegmentLayout;

use crate::study::{DiscretisationStudy, StudyRow, StudySpec, discretisation_study};
use crate::sweep::{
    PullUpSpec, PullUpSweep, SettlingSpec, SettlingSweep, StaticMarginSpec, StaticMarginSweep,
    StationVariable, SteadySweep, SteadySweepSpec, SteadyVariable, classify_settling, layout_parts,
    pull_up_sweep, settling_sweep, static_margin, static_margin_sweep, steady_sweep, trim_number,
    trim_point,
};
use decoy_sim::error::SimError;
use decoy_sim::options::RunOptions;
use decoy_sim::record::settling_time;
use decoy_sim::scenario::Scenario;
use decoy_sim::trace::{Trace, TraceOptions, trace};

use super::spec::{PULL_UP_RATES, Progress, TURN_AVERAGE_FROM_S, TURN_RATES};

/// A manoeuvre run of the report.
pub(super) struct Manoeuvre {
    pub(super) rate: f64,
    pub(super) trace: Trace,
}

/// Everything the report shows.
pub(super) struct Data {
    pub(super) host: SegmentLayout<f64>,
    pub(super) embedded: SegmentLayout<f64>,
    pub(super) speed: SteadySweep,
    pub(super) altitude: SteadySweep,
    pub(super) study: DiscretisationStudy,
    pub(super) turns: Vec<Manoeuvre>,
    pub(super) turn_slow: Manoeuvre,
    pub(super) turn_mach: f64,
    pub(super) turn_slow_mach: f64,
    pub(super) straight_tension: f64,
    pub(super) straight_tension_slow: f64,
    pub(super) pull_ups: Vec<Manoeuvre>,
    pub(super) tow_point: SettlingSweep,
    pub(super) cg: SettlingSweep,
    /// The search for the largest pull-up rate that keeps the cable out of the plume.
    pub(super) pull_up_limit: PullUpSweep,
    /// The second decoy (weak static stability).
    pub(super) weak: SystemConfig,
    /// Its towing-point and CG settling sweeps.
    pub(super) weak_tow_point: SettlingSweep,
    pub(super) weak_cg: SettlingSweep,
    /// The static margins of the reference and the weak decoys.
    pub(super) margins: (f64, f64),
    /// The towing-point limit against the static margin (the configured decoy's
    /// aerodynamics, its centre of pressure moved).
    pub(super) static_margin: StaticMarginSweep,
}

/// Runs every case of the report: the steady sweeps, the discretisation study,
/// the turns and pull-ups, the towing-point and CG settling sweeps.
pub(super) fn collect<F: FnMut(f64)>(
    config: &SystemConfig,
    progress: &mut Progress<F>,
) -> Result<Data, SimError> {
    let host: SegmentLayout<f64> = config.host_layout();
    let embedded: SegmentLayout<f64> = config.embedded_layout();
    let (host_n, _) = layout_parts(&host);
    let (embedded_n, embedded_ratio) = layout_parts(&embedded);

    let speed = steady_sweep(
        config,
        &SteadySweepSpec::paper(SteadyVariable::Speed, config),
        progress.stage(0.01),
    )?;
    let altitude = steady_sweep(
        config,
        &SteadySweepSpec::paper(SteadyVariable::Altitude, config),
        progress.stage(0.01),
    )?;
    let study = discretisation_study(
        config,
        &StudySpec::default_for(config),
        progress.stage(0.39),
    )?;

    let turn_mach = 0.8;
    let turn_slow_mach = 0.6;
    let run = |scenario: &str, options: RunOptions, p: &mut dyn FnMut(f64)| {
        let scenario = Scenario::builtin(scenario)?;
        let plan = scenario.plan(config, &options)?;
        let what = format!(
            "{} ({})",
            plan.name,
            options
                .rate
                .map_or_else(String::new, |r| format!("{r} rad/s"))
        );
        let t = trace(config, &plan, &TraceOptions::default(), p)?;
        match &t.stopped {
            Some(s) => Err(SimError::Stopped {
                t_s: s.t_s,
                reason: s.reason.clone(),
                source: None,
                out_dir: None,
            }
            .at(what)),
            None => Ok(t),
        }
    };
    let host_options = |rate: f64, mach: f64| RunOptions {
        segments: Some(host_n),
        grading: Some(1.0),
        rate: Some(rate),
        mach: Some(mach),
        plots: false,
        ..RunOptions::default()
    };
    let mut turns = Vec::new();
    for rate in TURN_RATES {
        let trace = run(
            "turn",
            host_options(rate, turn_mach),
            &mut progress.stage(0.08),
        )?;
        turns.push(Manoeuvre { rate, trace });
    }
    let slow_rate = TURN_RATES[TURN_RATES.len() - 1];
    let turn_slow = Manoeuvre {
        rate: slow_rate,
        trace: run(
            "turn",
            host_options(slow_rate, turn_slow_mach),
            &mut progress.stage(0.08),
        )?,
    };
    let altitude_m = 9000.0;
    let straight_tension = trim_point(config, host, altitude_m, turn_mach)?.tension_connection_n;
    let straight_tension_slow =
        trim_point(config, host, altitude_m, turn_slow_mach)?.tension_connection_n;

    let mut pull_ups = Vec::new();
    for rate in PULL_UP_RATES {
        let options = RunOptions {
            segments: Some(embedded_n),
            grading: Some(embedded_ratio),
            rate: Some(rate),
            plots: false,
            ..RunOptions::default()
        };
        let trace = run("pull-up", options, &mut progress.stage(0.01))?;
        pull_ups.push(Manoeuvre { rate, trace });
    }
    let pull_up_limit = pull_up_sweep(config, &PullUpSpec::paper(config), progress.stage(0.06))?;
    let tow_point = settling_sweep(
        config,
        &SettlingSpec::paper(StationVariable::TowPoint, config),
        progress.stage(0.02),
    )?;
    let cg = settling_sweep(
        config,
        &SettlingSpec::paper(StationVariable::Cg, config),
        progress.stage(0.02),
    )?;
    let weak = SystemConfig::weak_stability()?;
    let weak_tow_point = settling_sweep(
        &weak,
        &SettlingSpec::paper(StationVariable::TowPoint, &weak),
        progress.stage(0.02),
    )?;
    let weak_cg = settling_sweep(
        &weak,
        &SettlingSpec::paper(StationVariable::Cg, &weak),
        progress.stage(0.02),
    )?;
    let margins = (static_margin(config)?, static_margin(&weak)?);
    let static_margin = static_margin_sweep(
        config,
        &StaticMarginSpec::paper(config),
        progress.stage(0.1),
    )?;

    Ok(Data {
        host,
        embedded,
        speed,
        altitude,
        study,
        turns,
        turn_slow,
        turn_mach,
        turn_slow_mach,
        straight_tension,
        straight_tension_slow,
        pull_ups,
        tow_point,
        cg,
        pull_up_limit,
        weak,
        weak_tow_point,
        weak_cg,
        margins,
        static_margin,
    })
}

/// True when `values` never decreases (`rising`) or never increases.
pub(super) fn monotone(values: &[f64], rising: bool) -> bool {
    values
        .windows(2)
        .all(|w| if rising { w[1] >= w[0] } else { w[1] <= w[0] })
}

/// The decoy pitch and depth over a sweep, in words ("pitch a to b deg, depth c
/// to d m (both growing)"), and whether both grow (`rising`) or both fall.
pub(super) fn pitch_and_depth_trend(
    points: &[crate::sweep::TrimPoint],
    rising: bool,
) -> (String, bool) {
    let pitch: Vec<f64> = points.iter().map(|p| p.decoy_pitch_deg).collect();
    let depth: Vec<f64> = points.iter().map(|p| p.decoy_cg_below_m).collect();
    let ok = monotone(&pitch, rising) && monotone(&depth, rising);
    let word = if rising { "growing" } else { "falling" };
    let measured = format!(
        "pitch {:.2} to {:.2} deg, depth {:.2} to {:.2} m ({}both {word})",
        pitch[0],
        pitch[pitch.len() - 1],
        depth[0],
        depth[depth.len() - 1],
        if ok { "" } else { "not " }
    );
    (measured, ok)
}

/// (max - min) / mean.
pub(super) fn spread(values: &[f64]) -> f64 {
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    (hi - lo) / (values.iter().sum::<f64>() / values.len() as f64)
}

/// Mean of `f` over the samples from `from` s on.
pub(super) fn mean_from(
    trace: &Trace,
    from: f64,
    f: impl Fn(&decoy_sim::record::Sample) -> f64,
) -> f64 {
    let values: Vec<f64> = trace
        .samples
        .iter()
        .filter(|s| s.t >= from - 1e-9)
        .map(f)
        .collect();
    values.iter().sum::<f64>() / values.len() as f64
}

/// Minimum and maximum of `f` over the samples in `[from, to]`.
pub(super) fn range_in(
    trace: &Trace,
    from: f64,
    to: f64,
    f: impl Fn(&decoy_sim::record::Sample) -> f64,
) -> (f64, f64) {
    trace
        .samples
        .iter()
        .filter(|s| s.t >= from - 1e-9 && s.t <= to + 1e-9)
        .map(f)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

/// Spearman-free check of a trend: the fraction of pairs `(i, j)` ordered the
/// same way in `x` and `y` (1: `y` grows with `x` throughout; 0: falls).
pub(super) fn concordance(x: &[f64], y: &[f64]) -> f64 {
    let (mut same, mut total) = (0usize, 0usize);
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            if x[i] == x[j] || y[i] == y[j] {
                continue;
            }
            total += 1;
            if (x[j] > x[i]) == (y[j] > y[i]) {
                same += 1;
            }
        }
    }
    if total == 0 {
        f64::NAN
    } else {
        same as f64 / total as f64
    }
}

/// Acceleration figures from the host model's run.
pub(super) struct Acceleration<'a> {
    pub(super) row: &'a StudyRow,
    pub(super) post_peak: (f64, f64),
    pub(super) tension_settling_s: Option<f64>,
    /// The first move of the pitch by more than 0.1 deg after the acceleration
    /// starts: `(time, change)`.
    pub(super) pitch_first_move: Option<(f64, f64)>,
    pub(super) pitch_max: (f64, f64),
    pub(super) pitch_settling_s: Option<f64>,
}

pub(super) fn acceleration(data: &Data) -> Option<Acceleration<'_>> {
    let row = data.study.reference_row()?;
    let t = &row.trace;
    let end = t.last().t;
    let peak = row.t_at_max_tension_s;
    let post_peak = range_in(t, peak + 0.5, end, |s| s.tension_connection);
    let start = data
        .study
        .rows
        .first()
        .map_or(2.0, |r| r.trace.plan.profile.manoeuvre_start());
    let pitch_start = t
        .samples
        .iter()
        .find(|s| s.t >= start - 1e-9)
        .map_or(f64::NAN, |s| s.euler_deg[1]);
    let pitch_first_move = t
        .samples
        .iter()
        .filter(|s| s.t >= start - 1e-9)
        .find(|s| (s.euler_deg[1] - pitch_start).abs() > 0.1)
        .map(|s| (s.t, s.euler_deg[1] - pitch_start));
    let pitch_max = t.samples.iter().map(|s| (s.t, s.euler_deg[1])).fold(
        (0.0, f64::NEG_INFINITY),
        |best, v| {
            if v.1 > best.1 { v } else { best }
        },
    );
    let history: Vec<(f64, f64)> = t.samples.iter().map(|s| (s.t, s.euler_deg[1])).collect();
    let pitch = classify_settling(&history, 2.0, 0.02, t.stopped.is_none());
    Some(Acceleration {
        row,
        post_peak,
        tension_settling_s: settling_time(&t.samples),
        pitch_first_move,
        pitch_max,
        pitch_settling_s: pitch.settling_time_s,
    })
}

/// Turn: the mean connection tension from [`TURN_AVERAGE_FROM_S`] on, minus the
/// straight trim's.
pub(super) fn turn_excess(m: &Manoeuvre, straight: f64) -> f64 {
    mean_from(&m.trace, TURN_AVERAGE_FROM_S, |s| s.tension_connection) - straight
}

/// Turn: the mean lateral (outward) offset of the decoy CG from
/// [`TURN_AVERAGE_FROM_S`] on, m.
pub(super) fn turn_outward(m: &Manoeuvre) -> f64 {
    mean_from(&m.trace, TURN_AVERAGE_FROM_S, |s| s.cg[1])
}

/// Settled stations of a settling sweep, `(station, settling time)`.
pub(super) fn settled(sweep: &SettlingSweep) -> Vec<(f64, f64)> {
    sweep
        .points
        .iter()
        .filter_map(|p| {
            p.settling
                .settling_time_s
                .map(|t| (p.station(sweep.spec.variable), t))
        })
        .collect()
}

/// The settled range of stations in words and whether any station with the towing
/// point behind the CG settled.
pub(super) fn settled_range(sweep: &SettlingSweep) -> (String, bool) {
    let s = settled(sweep);
    let behind = sweep
        .points
        .iter()
        .any(|p| p.settling.settled && p.x_tow_m > p.x_cg_m);
    let unsettled: Vec<String> = sweep
        .points
        .iter()
        .filter(|p| !p.settling.settled)
        .map(|p| trim_number(p.station(sweep.spec.variable), 3))
        .collect();
    let text = match (s.first(), s.last()) {
        (Some(a), Some(b)) => format!(
            "settles for {} from {} to {} m{}",
            sweep.spec.variable.key(),
            trim_number(a.0, 3),
            trim_number(b.0, 3),
            if unsettled.is_empty() {
                String::new()
            } else {
                format!("; not at {} m", unsettled.join(", "))
            }
        ),
        _ => "never settles".to_owned(),
    };
    (text, behind)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trend_helpers() {
        assert!(monotone(&[1.0, 2.0, 2.0, 3.0], true));
        assert!(!monotone(&[1.0, 2.0, 1.5], true));
        assert!(monotone(&[3.0, 2.0, 1.0], false));
        assert!((spread(&[9.0, 10.0, 11.0]) - 0.2).abs() < 1e-12);
        assert_eq!(concordance(&[1.0, 2.0, 3.0], &[1.0, 4.0, 9.0]), 1.0);
        assert_eq!(concordance(&[1.0, 2.0, 3.0], &[9.0, 4.0, 1.0]), 0.0);
        assert!(concordance(&[1.0], &[1.0]).is_nan());
    }
}
