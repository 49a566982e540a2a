//! Decoy management in a run's files: the monitors of the requirements on
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
use decoy_link::{DeviceMessage, HostMessage, Management, MonitorLevel};
use decoy_schema::{PerRequirement, Requirement};
use serde::{Deserialize, Serialize};
use solver_core::{AircraftState, FlightPath, Outputs};

use crate::format::round_time;

/// Capacity of the onboard controller flown alongside (its look-ahead covers
/// up to [`decoy_controller::PREDICTION_CAPACITY`] segments).
const ONBOARD_CAPACITY: usize = 32;

/// The management columns of one row of `timeseries.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManagementSample {
    /// Levels (0 normal, 1 caution, 2 warning, 3 violated).
    pub levels: PerRequirement<u8>,
    /// Margins, each in its requirement's file unit ([`Requirement::file_unit`]:
    /// the posture's in degrees).
    pub margins: PerRequirement<f64>,
    /// Advisory bits ([`Requirement::bit`]).
    pub advisories: u8,
    /// Predicted time to violation, s, per requirement (NaN: none predicted).
    pub violation_in: PerRequirement<f64>,
}

impl Default for ManagementSample {
    fn default() -> Self {
        ManagementSample {
            levels: PerRequirement::splat(0),
            margins: PerRequirement::splat(f64::NAN),
            advisories: 0,
            violation_in: PerRequirement::splat(f64::NAN),
        }
    }
}

impl ManagementSample {
    /// The columns of an Output's management report (margins in the files'
    /// units: posture in degrees).
    pub fn of_report(m: &Management) -> Self {
        ManagementSample {
            levels: m.reports.map(|r| r.level.index()),
            margins: m
                .reports
                .map_with(|requirement, r| requirement.to_file_unit(f64::from(r.margin))),
            advisories: m.advisories,
            violation_in: m.reports.map(|r| {
                if r.time_to_violation_s >= 0.0 {
                    f64::from(r.time_to_violation_s)
                } else {
                    f64::NAN
                }
            }),
        }
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
            margins: margins.map_with(Requirement::to_file_unit),
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
    /// Smallest margin over the run (in the requirement's file unit: the
    /// posture's in degrees); null if never measured.
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

/// `summary.json`'s `"management"`: an entry per requirement, keyed by its name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct ManagementSummary {
    /// Each requirement's entry.
    pub requirements: PerRequirement<RequirementSummary>,
}

impl ManagementSummary {
    /// From the rows (time, management columns) in time order.
    pub fn of_rows<'a>(rows: impl IntoIterator<Item = (f64, &'a ManagementSample)>) -> Self {
        let mut summary = PerRequirement::<RequirementSummary>::default();
        for (t, m) in rows {
            for (requirement, s) in summary.iter_mut() {
                let margin = m.margins[requirement];
                if margin.is_finite() {
                    s.worst_margin = Some(s.worst_margin.map_or(margin, |w| w.min(margin)));
                }
                if s.first_violation_s.is_none()
                    && m.levels[requirement] == MonitorLevel::Violated.index()
                {
                    s.first_violation_s = Some(round_time(t));
                }
                if s.first_advisory_s.is_none() && m.advisories & requirement.bit() != 0 {
                    s.first_advisory_s = Some(round_time(t));
                }
            }
        }
        for (_, s) in summary.iter_mut() {
            if let (Some(v), Some(a)) = (s.first_violation_s, s.first_advisory_s) {
                s.advisory_lead_s = Some(round_time(v - a));
            }
        }
        ManagementSummary {
            requirements: summary,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_finds_first_events_and_leads() {
        let row = |level: u8, margin: f64, advisories: u8| {
            let mut m = ManagementSample {
                levels: PerRequirement::splat(0),
                margins: PerRequirement::splat(5.0),
                advisories,
                violation_in: PerRequirement::splat(f64::NAN),
            };
            m.levels.exhaust = level;
            m.margins.exhaust = margin;
            m.margins.tension = 400.0;
            m
        };
        let rows = [
            (0.0, row(0, 1.0, 0)),
            (1.0, row(1, 0.4, 8)),
            (2.5, row(3, -0.2, 8)),
            (3.0, row(3, -0.5, 8)),
            (4.0, row(0, 0.8, 0)),
        ];
        let s = ManagementSummary::of_rows(rows.iter().map(|(t, m)| (*t, m))).requirements;
        assert_eq!(s.exhaust.worst_margin, Some(-0.5));
        assert_eq!(s.exhaust.first_violation_s, Some(2.5));
        assert_eq!(s.exhaust.first_advisory_s, Some(1.0));
        assert_eq!(s.exhaust.advisory_lead_s, Some(1.5));
        assert_eq!(s.posture.first_violation_s, None);
        assert_eq!(s.posture.advisory_lead_s, None);
        assert_eq!(s.tension.worst_margin, Some(400.0));
    }
}
