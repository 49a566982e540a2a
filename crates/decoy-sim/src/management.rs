//! Decoy management in a run's files: the monitors of the four requirements on
//! the run's own solution, and the advisories of the onboard controller flown
//! alongside.
//!
//! - **Levels and margins** (`timeseries.csv`, `summary.json`'s worst margins and
//!   first violations) are `decoy_controller::monitor`'s monitors, the code the
//!   controller runs, applied to the run's solution (300 segments by default) at
//!   every row of `timeseries.csv`.
//! - **Advisories** come from the onboard controller itself
//!   (`decoy_controller::Controller`, the embedded model in f64), sent the
//!   aircraft's state at every row as the State frames of a host would: its
//!   look-ahead says when continuing the manoeuvre violates a requirement. The
//!   advisory lead is the time from the first advisory to the first violation
//!   the run's solution shows: the onboard prediction judged against the
//!   reference solution.
//!
//! `decoy hil` fills the same columns from the firmware's Output frames (levels,
//! margins and advisories all of the embedded model).

use decoy_config::SystemConfig;
use decoy_controller::monitor::{ManagementConfig, Measures, Monitors};
use decoy_controller::path::state_frame;
use decoy_controller::{Controller, Geometry, NoCounter};
use decoy_link::{DeviceMessage, HostMessage, Management, MonitorLevel, REQUIREMENTS};
use serde::{Deserialize, Serialize};
use solver_core::{AircraftState, FlightPath, Outputs};

use crate::format::round_time;

/// Capacity of the onboard controller flown alongside (its look-ahead covers
/// up to [`decoy_controller::PREDICTION_CAPACITY`] segments).
const ONBOARD_CAPACITY: usize = 32;

/// The management columns of one row of `timeseries.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManagementSample {
    /// Levels (0 normal, 1 caution, 2 warning, 3 violated): posture, collision,
    /// tension, exhaust.
    pub levels: [u8; 4],
    /// Margins: posture deg, collision m, tension N, exhaust m.
    pub margins: [f64; 4],
    /// Advisory bits (1 posture, 2 collision, 4 tension, 8 exhaust).
    pub advisories: u8,
    /// Predicted time to violation, s, per requirement (NaN: none predicted).
    pub violation_in: [f64; 4],
}

impl Default for ManagementSample {
    fn default() -> Self {
        ManagementSample {
            levels: [0; 4],
            margins: [f64::NAN; 4],
            advisories: 0,
            violation_in: [f64::NAN; 4],
        }
    }
}

impl ManagementSample {
    /// The columns of an Output's management report (margins in the files'
    /// units: posture in degrees).
    pub fn of_report(m: &Management) -> Self {
        let reports = m.reports();
        ManagementSample {
            levels: reports.map(|r| r.level.index()),
            margins: [
                f64::from(reports[0].margin).to_degrees(),
                f64::from(reports[1].margin),
                f64::from(reports[2].margin),
                f64::from(reports[3].margin),
            ],
            advisories: m.advisories,
            violation_in: reports.map(|r| {
                if r.time_to_violation_s >= 0.0 {
                    f64::from(r.time_to_violation_s)
                } else {
                    f64::NAN
                }
            }),
        }
    }

    /// The CSV header of these columns.
    pub fn header() -> String {
        let units = ["deg", "m", "N", "m"];
        let mut h = String::new();
        for (name, unit) in REQUIREMENTS.iter().zip(units) {
            h.push_str(&format!(",{name}_level,{name}_margin_{unit}"));
        }
        h.push_str(",advisories");
        for name in REQUIREMENTS {
            h.push_str(&format!(",{name}_violation_in_s"));
        }
        h
    }
}

/// The monitors on a run's solution and the onboard controller beside it.
pub(crate) struct ManagementTrack {
    config: ManagementConfig<f64>,
    geometry: Geometry<f64>,
    monitors: Monitors<f64>,
    onboard: Option<Box<Controller<f64, ONBOARD_CAPACITY>>>,
    seq: u32,
    last_frame: Option<f64>,
}

impl ManagementTrack {
    /// For the system `config` (None if its onboard controller cannot be built:
    /// then no advisories).
    pub(crate) fn new(config: &SystemConfig) -> Option<Self> {
        let params = config.params().ok()?;
        let onboard = params
            .controller_config::<f64>(params.embedded_layout())
            .ok()
            .and_then(|c| Controller::<f64, ONBOARD_CAPACITY>::new(c).ok())
            .map(Box::new);
        Some(ManagementTrack {
            config: params.management(),
            geometry: params.geometry(),
            monitors: Monitors::default(),
            onboard,
            seq: 0,
            last_frame: None,
        })
    }

    /// Measures one row's state (`out`, the aircraft at `aircraft`) and sends the
    /// onboard controller the aircraft's state from `path` at that time.
    pub(crate) fn observe<const N: usize, P: FlightPath<f64> + ?Sized>(
        &mut self,
        out: &Outputs<'_, f64, N>,
        aircraft: &AircraftState<f64>,
        path: &P,
    ) -> ManagementSample {
        let measures = Measures::of(out, aircraft, &self.geometry, &self.config);
        let margins = self.monitors.update(&measures, &self.config);
        let t = out.time();
        let mut sample = ManagementSample {
            levels: self.monitors.monitors.map(|m| m.level.index()),
            margins: [margins[0].to_degrees(), margins[1], margins[2], margins[3]],
            ..ManagementSample::default()
        };
        if let Some(onboard) = &mut self.onboard
            && self.last_frame.is_none_or(|last| t > last)
        {
            let frame = state_frame(self.seq, t, &path.state_at(t));
            self.seq = self.seq.wrapping_add(1);
            self.last_frame = Some(t);
            if let DeviceMessage::Output(o) =
                onboard.handle(HostMessage::State(frame), &mut NoCounter)
            {
                let onboard = ManagementSample::of_report(&o.management);
                sample.advisories = onboard.advisories;
                sample.violation_in = onboard.violation_in;
            }
        }
        sample
    }
}

/// `summary.json`'s `"management"` entry of one requirement.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RequirementSummary {
    /// Smallest margin over the run (posture deg, collision m, tension N,
    /// exhaust m); null if never measured.
    pub worst_margin: Option<f64>,
    /// First time the requirement was violated (level violated), s; null if never.
    pub first_violation_s: Option<f64>,
    /// First time the look-ahead advised that continuing the manoeuvre violates
    /// it, s; null if never.
    pub first_advisory_s: Option<f64>,
    /// first_violation_s - first_advisory_s, s (negative: the advisory came
    /// late); null unless both happened.
    pub advisory_lead_s: Option<f64>,
}

/// `summary.json`'s `"management"`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ManagementSummary {
    /// Decoy posture, margin in deg.
    pub posture: RequirementSummary,
    /// Collision with the aircraft, margin in m.
    pub collision: RequirementSummary,
    /// Cable tension, margin in N.
    pub tension: RequirementSummary,
    /// Cable in the exhaust plume, margin in m.
    pub exhaust: RequirementSummary,
}

impl ManagementSummary {
    /// From the rows (time, management columns) in time order.
    pub fn of_rows<'a>(rows: impl IntoIterator<Item = (f64, &'a ManagementSample)>) -> Self {
        let mut summary = [RequirementSummary::default(); 4];
        for (t, m) in rows {
            for (k, s) in summary.iter_mut().enumerate() {
                let margin = m.margins[k];
                if margin.is_finite() {
                    s.worst_margin = Some(s.worst_margin.map_or(margin, |w| w.min(margin)));
                }
                if s.first_violation_s.is_none() && m.levels[k] == MonitorLevel::Violated.index() {
                    s.first_violation_s = Some(round_time(t));
                }
                if s.first_advisory_s.is_none() && m.advisories & (1 << k) != 0 {
                    s.first_advisory_s = Some(round_time(t));
                }
            }
        }
        for s in &mut summary {
            if let (Some(v), Some(a)) = (s.first_violation_s, s.first_advisory_s) {
                s.advisory_lead_s = Some(round_time(v - a));
            }
        }
        let [posture, collision, tension, exhaust] = summary;
        ManagementSummary {
            posture,
            collision,
            tension,
            exhaust,
        }
    }

    /// The four entries in report order.
    pub fn entries(&self) -> [(&'static str, &RequirementSummary); 4] {
        [
            (REQUIREMENTS[0], &self.posture),
            (REQUIREMENTS[1], &self.collision),
            (REQUIREMENTS[2], &self.tension),
            (REQUIREMENTS[3], &self.exhaust),
        ]
    }
}

/// The units of the four margins in the files.
pub const MARGIN_UNITS: [&str; 4] = ["deg", "m", "N", "m"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_finds_first_events_and_leads() {
        let row = |level: u8, margin: f64, advisories: u8| ManagementSample {
            levels: [0, 0, 0, level],
            margins: [5.0, 3.0, 400.0, margin],
            advisories,
            violation_in: [f64::NAN; 4],
        };
        let rows = [
            (0.0, row(0, 1.0, 0)),
            (1.0, row(1, 0.4, 8)),
            (2.5, row(3, -0.2, 8)),
            (3.0, row(3, -0.5, 8)),
            (4.0, row(0, 0.8, 0)),
        ];
        let s = ManagementSummary::of_rows(rows.iter().map(|(t, m)| (*t, m)));
        assert_eq!(s.exhaust.worst_margin, Some(-0.5));
        assert_eq!(s.exhaust.first_violation_s, Some(2.5));
        assert_eq!(s.exhaust.first_advisory_s, Some(1.0));
        assert_eq!(s.exhaust.advisory_lead_s, Some(1.5));
        assert_eq!(s.posture.first_violation_s, None);
        assert_eq!(s.posture.advisory_lead_s, None);
        assert_eq!(s.tension.worst_margin, Some(400.0));
    }
}
