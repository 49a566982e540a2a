//! `summary.json`: its contents ([`Summary`]) and [`summarize`], which measures
//! them from a run's samples.

use serde::{Deserialize, Serialize};

use crate::format::round_time;
use crate::management::ManagementSummary;
use crate::record::{Sample, Statistics, settling_time};

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

/// The RK4 steps of a host run (`summary.json`'s `steps`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepsTaken {
    /// `adaptive` (`decoy_sim::steps`) or `fixed`.
    pub rule: String,
    /// How many steps stood.
    pub count: u64,
    /// How many were undone and taken again shorter (their error estimate too
    /// large, or the step failed).
    pub rejected: u64,
    /// The shortest step, s.
    pub min_s: f64,
    /// The longest step, s.
    pub max_s: f64,
}

/// The contents of `summary.json` (see `docs/outputs.md`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// Number of cable segments.
    pub segments: usize,
    /// The fixed RK4 step, s (`--dt`, a scenario's `dt_s`, or the longest step
    /// of a firmware or bridge run's controller); `null` when the step rule chose
    /// the steps (`steps`).
    pub dt: Option<f64>,
    /// Simulated time asked for, s.
    pub t_end: f64,
    /// The steps a host run took: the rule and how many, how short, how long.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steps: Option<StepsTaken>,
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
    /// Decoy management: per requirement its worst margin, first violation, first
    /// advisory and the advisory's lead (`docs/outputs.md`).
    #[serde(default)]
    pub management: ManagementSummary,
    /// Present when the integration stopped early.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped: Option<StoppedAt>,
}

/// The summary of a run measured elsewhere (for example by the firmware in the
/// loop, `decoy hil`) from its samples, with the same definitions as
/// `simulate`'s: `samples` in time order, every one of them measured (maxima,
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
    let run = RunIdentity {
        scenario,
        segments,
        dt: Some(dt),
        t_end,
        steps: None,
    };
    measured(&run, &statistics, samples, &last, wall_s, stopped)
}

/// What names a run in its summary: scenario, segments, step and simulated time.
pub(crate) struct RunIdentity<'a> {
    pub scenario: &'a str,
    pub segments: usize,
    pub dt: Option<f64>,
    pub t_end: f64,
    pub steps: Option<StepsTaken>,
}

/// The summary of a run from its running `statistics` (every step), its kept
/// `samples` (the rows of `timeseries.csv`, for the settling time) and its `last`
/// good sample; `stopped` says why it ended early.
pub(crate) fn measured(
    run: &RunIdentity<'_>,
    statistics: &Statistics,
    samples: &[Sample],
    last: &Sample,
    wall_s: f64,
    stopped: Option<String>,
) -> Summary {
    Summary {
        scenario: run.scenario.to_owned(),
        segments: run.segments,
        dt: run.dt,
        t_end: run.t_end,
        steps: run.steps.clone(),
        max_tension_connection_n: statistics.max_tension,
        // No measured state (a run that could not start): no time either (`null`).
        t_at_max_tension_s: if statistics.max_tension.is_finite() {
            round_time(statistics.t_at_max)
        } else {
            f64::NAN
        },
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
        management: ManagementSummary::of_rows(samples.iter().map(|s| (s.t, &s.management))),
        stopped: stopped.map(|reason| StoppedAt {
            t_s: round_time(last.t),
            reason,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
