//! The run's plots (PNG + SVG each, drawn by `decoy-plots`).

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_link::MonitorLevel;
use decoy_plots::{
    Aspect, Plot, PlotError, Series, write_plot, write_stacked, write_stacked_shaded,
};
use decoy_schema::{PerRequirement, Requirement};

use crate::geometry::{Envelope, ExhaustPlume, envelope_from_config, plume_from_config};

use crate::error::SimError;
use crate::format::format_time;
use crate::record::{PLOTTED_SNAPSHOTS, Recorded, Sample, Snapshot};
use crate::scenario::RunPlan;

/// The plots' file stems, in the order they are written.
pub const PLOT_NAMES: [&str; 6] = [
    "tensions",
    "attitude",
    "cable-side",
    "cable-top",
    "tension-profile",
    "management",
];

/// A quantity of a sample, named.
type Quantity = (&'static str, fn(&Sample) -> f64);

/// The file stems [`write_comparison_plots`] writes, in order.
pub const COMPARISON_PLOT_NAMES: [&str; 2] = ["tensions", "attitude"];

fn series(label: &str, samples: &[Sample], y: impl Fn(&Sample) -> f64) -> Series {
    Series {
        label: label.to_owned(),
        x: samples.iter().map(|s| s.t).collect(),
        y: samples.iter().map(y).collect(),
    }
}

fn plot(title: String, x_label: &str, y_label: &str, series: Vec<Series>) -> Plot {
    Plot {
        title,
        x_label: x_label.to_owned(),
        y_label: y_label.to_owned(),
        series,
        aspect: Aspect::Free,
        invert_y: false,
    }
}

/// Up to [`PLOTTED_SNAPSHOTS`] snapshots evenly spread, first and last included.
fn chosen(snapshots: &[Snapshot]) -> Vec<&Snapshot> {
    let m = snapshots.len();
    if m <= PLOTTED_SNAPSHOTS {
        return snapshots.iter().collect();
    }
    let mut indices: Vec<usize> = (0..PLOTTED_SNAPSHOTS)
        .map(|i| (i * (m - 1) + (PLOTTED_SNAPSHOTS - 1) / 2) / (PLOTTED_SNAPSHOTS - 1))
        .collect();
    indices.dedup();
    indices.into_iter().map(|i| &snapshots[i]).collect()
}

fn snapshot_series(snapshots: &[&Snapshot], x: usize, y: usize) -> Vec<Series> {
    snapshots
        .iter()
        .map(|s| Series {
            label: format!("t = {} s", format_time(s.t)),
            x: s.joints.iter().map(|j| j[x]).collect(),
            y: s.joints.iter().map(|j| j[y]).collect(),
        })
        .collect()
}

/// Draws every plot into `dir`; returns the files written.
pub(crate) fn write_all(
    recorded: &Recorded<'_>,
    plan: &RunPlan,
    config: &SystemConfig,
    dir: &Path,
) -> Result<Vec<PathBuf>, SimError> {
    let plume = plume_from_config::<f64>(&config.aircraft);
    let envelope = envelope_from_config::<f64>(&config.aircraft);
    let samples = recorded.samples;
    let name = &plan.name;
    let time = "t [s]";
    let mut files = Vec::new();
    let mut emit = |stem: &str, result: Result<[PathBuf; 2], PlotError>| match result {
        Ok(paths) => {
            files.extend(paths);
            Ok(())
        }
        Err(e) => Err(SimError::Plot {
            stem: dir.join(stem),
            message: e.to_string(),
        }),
    };

    let tensions = plot(
        format!("{name}: cable tension"),
        time,
        "tension [N]",
        vec![
            series("connection point", samples, |s| s.tension_connection),
            series("towing point", samples, |s| s.tension_tow),
        ],
    );
    emit("tensions", write_plot(&tensions, &dir.join("tensions")))?;

    let pitch = plot(
        format!("{name}: decoy pitch and angle of attack"),
        time,
        "angle [deg]",
        vec![
            series("pitch", samples, |s| s.euler_deg[1]),
            series("angle of attack", samples, |s| s.aoa_deg),
        ],
    );
    let yaw = plot(
        format!("{name}: decoy yaw (heading, unwrapped)"),
        time,
        "yaw [deg]",
        vec![series("yaw", samples, |s| s.euler_deg[2])],
    );
    emit(
        "attitude",
        write_stacked(&[pitch, yaw], &dir.join("attitude")),
    )?;

    let shown = chosen(recorded.snapshots);
    // Joint columns: along 0, behind 1, lateral 2, below 3, tension 4.
    let mut side = plot(
        format!("{name}: cable, side view (flight-path frame)"),
        "behind the aircraft [m]",
        "below the flight path [m]",
        snapshot_series(&shown, 1, 3),
    );
    side.series
        .extend(outlines(&plume, &envelope, View::Side, plan.lateral_sign));
    side.invert_y = true;
    emit("cable-side", write_plot(&side, &dir.join("cable-side")))?;

    let top = plot(
        format!(
            "{name}: cable, top view (flight-path frame, lateral positive {})",
            if plan.lateral_sign > 0.0 {
                "left"
            } else {
                "right"
            }
        ),
        "behind the aircraft [m]",
        "lateral [m]",
        snapshot_series(&shown, 1, 2),
    );
    let mut top = top;
    top.series
        .extend(outlines(&plume, &envelope, View::Top, plan.lateral_sign));
    emit("cable-top", write_plot(&top, &dir.join("cable-top")))?;

    let profile = plot(
        format!("{name}: tension along the cable"),
        "distance along the cable from the connection point [m]",
        "tension [N]",
        snapshot_series(&shown, 0, 4),
    );
    emit(
        "tension-profile",
        write_plot(&profile, &dir.join("tension-profile")),
    )?;

    files.extend(write_management_plot(name, samples, config, dir)?);
    Ok(files)
}

/// Draws the management timeline (`management.png/.svg`, [`management_panels`])
/// of `samples`, against the thresholds of `config`, into `dir`; returns the
/// files written.
pub fn write_management_plot(
    name: &str,
    samples: &[Sample],
    config: &SystemConfig,
    dir: &Path,
) -> Result<Vec<PathBuf>, SimError> {
    let (panels, shaded) = management_panels(name, samples, config);
    write_stacked_shaded(&panels, &shaded, &dir.join("management"))
        .map(Vec::from)
        .map_err(|e| SimError::Plot {
            stem: dir.join("management"),
            message: e.to_string(),
        })
}

/// The level thresholds of each requirement's margin in its file unit
/// ([`Requirement::file_unit`]), labelled (`caution 3 m`): caution and warning,
/// and for the tension both its sides (over-tension and slack), whose margins
/// share the column. None when `config` gives no management configuration.
pub fn margin_bands(config: &SystemConfig) -> Option<PerRequirement<Vec<(String, f64)>>> {
    let management = config.params().ok()?.management();
    Some(PerRequirement::from_fn(|requirement| {
        let unit = requirement.file_unit();
        let pair = |side: &str, t: &decoy_controller::monitor::LevelThresholds<f64>| {
            let caution = requirement.to_file_unit(t.caution);
            let warning = requirement.to_file_unit(t.warning);
            [
                (format!("{side}caution {caution} {unit}"), caution),
                (format!("{side}warning {warning} {unit}"), warning),
            ]
        };
        match requirement {
            Requirement::Tension => {
                let mut bands = pair("over-tension ", &management.thresholds[requirement]).to_vec();
                bands.extend(pair("slack ", &management.slack_thresholds));
                bands
            }
            _ => pair("", &management.thresholds[requirement]).to_vec(),
        }
    }))
}

/// The management timeline: per requirement a panel with its margin (in the
/// file's unit, negative: violated) over time against its caution and warning
/// thresholds ([`margin_bands`], horizontal lines) and zero, the margin drawn
/// again where the look-ahead's advisory stands (continuing the manoeuvre
/// violates the requirement), and the violations shaded.
pub fn management_panels(
    name: &str,
    samples: &[Sample],
    config: &SystemConfig,
) -> (Vec<Plot>, Vec<Vec<(f64, f64)>>) {
    let bands = margin_bands(config);
    let span = match (samples.first(), samples.last()) {
        (Some(a), Some(b)) => vec![a.t, b.t],
        _ => Vec::new(),
    };
    let level_line = |label: String, value: f64| Series {
        label,
        x: span.clone(),
        y: vec![value; span.len()],
    };
    let mut panels = Vec::new();
    let mut shaded = Vec::new();
    for requirement in Requirement::ALL {
        let margin = series("margin", samples, |s| s.management.margins[requirement]);
        let advisory = series("advisory (look-ahead: continuing violates)", samples, |s| {
            if s.management.advisories & requirement.bit() != 0 {
                s.management.margins[requirement]
            } else {
                f64::NAN
            }
        });
        let mut lines = vec![margin, advisory];
        if let Some(bands) = &bands {
            lines.extend(
                bands[requirement]
                    .iter()
                    .map(|(label, value)| level_line(label.clone(), *value)),
            );
        }
        lines.push(level_line("violated below 0".to_owned(), 0.0));
        let unit = requirement.file_unit();
        panels.push(plot(
            format!("{name}: {} margin", requirement.name()),
            "t [s]",
            &format!("margin [{unit}]"),
            lines,
        ));
        let violated = MonitorLevel::Violated.index();
        let mut intervals = Vec::new();
        let mut start: Option<f64> = None;
        for s in samples {
            match (s.management.levels[requirement] == violated, start) {
                (true, None) => start = Some(s.t),
                (false, Some(t0)) => {
                    intervals.push((t0, s.t));
                    start = None;
                }
                _ => {}
            }
        }
        if let (Some(t0), Some(last)) = (start, samples.last()) {
            intervals.push((t0, last.t));
        }
        shaded.push(intervals);
    }
    (panels, shaded)
}

/// Which view of the flight-path frame an outline is drawn in.
#[derive(Clone, Copy, PartialEq)]
enum View {
    /// Behind and below.
    Side,
    /// Behind and lateral.
    Top,
}

/// The exhaust plume's and the collision capsule's outlines in a cable view, as
/// the body frame lies in the flight-path frame with the body x axis along the
/// velocity (the built-in profiles' attitude): behind = -x, below = z, lateral =
/// -y times the run's lateral sign.
fn outlines(
    plume: &ExhaustPlume,
    envelope: &Envelope,
    view: View,
    lateral_sign: f64,
) -> Vec<Series> {
    let project = |p: nalgebra::Vector3<f64>| -> (f64, f64) {
        match view {
            View::Side => (-p.x, p.z),
            View::Top => (-p.x, lateral_sign * -p.y + 0.0),
        }
    };
    // The view plane's normal in the body frame.
    let normal = match view {
        View::Side => nalgebra::Vector3::y(),
        View::Top => nalgebra::Vector3::z(),
    };
    let mut series = Vec::new();
    let mut add = |label: &str, points: Vec<Option<nalgebra::Vector3<f64>>>| {
        let (x, y): (Vec<f64>, Vec<f64>) = points
            .into_iter()
            .map(|p| p.map_or((f64::NAN, f64::NAN), project))
            .unzip();
        series.push(Series {
            label: label.to_owned(),
            x,
            y,
        });
    };
    // The plume: its silhouette in the view plane, a trapezoid.
    let side = plume.axis.cross(&normal);
    if side.norm() > 1e-9 {
        let side = side.normalize();
        let end = plume.nozzle + plume.axis * plume.length;
        let r1 = plume.nozzle_radius + plume.length * plume.tan_half_angle;
        add(
            "exhaust plume",
            vec![
                Some(plume.nozzle + side * plume.nozzle_radius),
                Some(end + side * r1),
                Some(end - side * r1),
                Some(plume.nozzle - side * plume.nozzle_radius),
                Some(plume.nozzle + side * plume.nozzle_radius),
            ],
        );
    }
    // The capsule: two sides and two half circles.
    let axis = envelope.aft - envelope.fore;
    let side = axis.cross(&normal);
    if side.norm() > 1e-9 {
        let side = side.normalize();
        let along = axis.normalize();
        let r = envelope.radius;
        let mut points = Vec::new();
        let steps = 16;
        for i in 0..=steps {
            let a = std::f64::consts::PI * f64::from(i) / f64::from(steps);
            points.push(Some(
                envelope.aft + side * (r * a.cos()) + along * (r * a.sin()),
            ));
        }
        for i in 0..=steps {
            let a = std::f64::consts::PI * f64::from(i) / f64::from(steps);
            points.push(Some(
                envelope.fore - side * (r * a.cos()) - along * (r * a.sin()),
            ));
        }
        points.push(points[0]);
        add("aircraft envelope", points);
    }
    series
}

/// Draws the time-series plots of several runs of one scenario on common axes
/// (`tensions`: connection- and towing-point tension; `attitude`: decoy pitch and
/// angle of attack, and yaw), one line per run and quantity, labelled
/// `"<run label>: <quantity>"`; for example the firmware in the loop beside the
/// host solver (`decoy hil`). Returns the files written (PNG and SVG of each of
/// [`COMPARISON_PLOT_NAMES`]).
pub fn write_comparison_plots(
    name: &str,
    runs: &[(&str, &[Sample])],
    dir: &Path,
) -> Result<Vec<PathBuf>, SimError> {
    let time = "t [s]";
    let mut files = Vec::new();
    let mut emit = |stem: &str, result: Result<[PathBuf; 2], PlotError>| match result {
        Ok(paths) => {
            files.extend(paths);
            Ok(())
        }
        Err(e) => Err(SimError::Plot {
            stem: dir.join(stem),
            message: e.to_string(),
        }),
    };
    let lines = |quantities: &[Quantity]| -> Vec<Series> {
        runs.iter()
            .flat_map(|(label, samples)| {
                quantities
                    .iter()
                    .map(move |(what, y)| series(&format!("{label}: {what}"), samples, y))
            })
            .collect()
    };
    let tensions = plot(
        format!("{name}: cable tension"),
        time,
        "tension [N]",
        lines(&[
            ("connection point", |s| s.tension_connection),
            ("towing point", |s| s.tension_tow),
        ]),
    );
    emit("tensions", write_plot(&tensions, &dir.join("tensions")))?;
    let pitch = plot(
        format!("{name}: decoy pitch and angle of attack"),
        time,
        "angle [deg]",
        lines(&[
            ("pitch", |s| s.euler_deg[1]),
            ("angle of attack", |s| s.aoa_deg),
        ]),
    );
    let yaw = plot(
        format!("{name}: decoy yaw"),
        time,
        "yaw [deg]",
        lines(&[("yaw", |s| s.euler_deg[2])]),
    );
    emit(
        "attitude",
        write_stacked(&[pitch, yaw], &dir.join("attitude")),
    )?;
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chosen_snapshots_spread_evenly() {
        let snaps: Vec<Snapshot> = (0..26)
            .map(|i| Snapshot {
                t: f64::from(i),
                joints: Vec::new(),
            })
            .collect();
        let times: Vec<f64> = chosen(&snaps).iter().map(|s| s.t).collect();
        assert_eq!(times, vec![0.0, 5.0, 10.0, 15.0, 20.0, 25.0]);
        let times: Vec<f64> = chosen(&snaps[..4]).iter().map(|s| s.t).collect();
        assert_eq!(times.len(), 4);
    }
}
