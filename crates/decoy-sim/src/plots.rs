//! The run's plots (PNG + SVG each, drawn by `decoy-plots`).

use std::path::{Path, PathBuf};

use decoy_plots::{Aspect, Plot, PlotError, Series, write_plot, write_stacked};

use crate::error::SimError;
use crate::format::format_time;
use crate::record::{PLOTTED_SNAPSHOTS, Recorded, Sample, Snapshot};
use crate::scenario::RunPlan;

/// The plots' file stems, in the order they are written.
pub const PLOT_NAMES: [&str; 5] = [
    "tensions",
    "attitude",
    "cable-side",
    "cable-top",
    "tension-profile",
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
    dir: &Path,
) -> Result<Vec<PathBuf>, SimError> {
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
    Ok(files)
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
