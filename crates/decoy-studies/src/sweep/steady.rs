//! [`steady_sweep`]: the trim at each Mach number or altitude (`decoy sweep speed|altitude`).

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_plots::{Aspect, Plot, Series};
use serde::Serialize;
use solver_core::SegmentLayout;

use decoy_sim::error::SimError;
use decoy_sim::format::format_value;
use decoy_sim::scenario::{check_altitude, check_mach};
use decoy_sim::trim::{TrimPoint, trim_point};

use super::{SweepRange, cli_invalid, csv_row, plot, trim_number, write_sweep};

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
    /// The paper's sweep (docs/design.md §8) with `config`'s host layout: Mach 0.5 to
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
        layout: decoy_sim::format::describe_layout(&spec.layout),
        points,
    })
}

/// The header of a steady sweep's `sweep.csv`.
pub const STEADY_SWEEP_HEADER: &str = "mach,altitude_m,speed_mps,tension_connection_N,tension_tow_N,tension_max_N,decoy_pitch_deg,decoy_aoa_deg,decoy_cg_behind_m,decoy_cg_below_m,cable_plume_clearance_m";
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
                p.cable_plume_clearance_m,
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
            one(
                format!("Cable clearance to the exhaust plume ({fixed})"),
                "clearance [m]",
                "smallest cable-plume clearance",
                self.points
                    .iter()
                    .map(|p| p.cable_plume_clearance_m)
                    .collect(),
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
    write_sweep(
        dir,
        &[
            ("sweep.csv", sweep.table_csv()),
            ("cable.csv", sweep.cable_csv()),
        ],
        plots.then(|| sweep.plots()),
    )
}
