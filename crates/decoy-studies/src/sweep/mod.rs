//! Parameter sweeps of the paper's steady-flight and decoy-station studies
//! (docs/design.md §8; the paper's Figs. 15-24).
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

mod pull_up;
mod settling;
mod static_margin;
mod steady;

use std::path::{Path, PathBuf};

use decoy_plots::{Aspect, Plot, PlotError, Series, write_plot, write_stacked};
use serde::Serialize;
use solver_core::SegmentLayout;

use decoy_sim::error::SimError;
use decoy_sim::format::{format_number, format_value};
use decoy_sim::scenario::{check_grading, check_segments};

pub use decoy_sim::trim::{CablePoint, TrimPoint, trim_point};
pub use pull_up::{
    PULL_UP_HISTORY_HEADER, PULL_UP_SWEEP_HEADER, PullUpPoint, PullUpSpec, PullUpSweep,
    pull_up_sweep, write_pull_up_sweep,
};
pub use settling::{
    SETTLING_PITCH_HEADER, SETTLING_SWEEP_HEADER, Settling, SettlingPoint, SettlingSpec,
    SettlingSweep, StationVariable, classify_settling, settling_sweep, write_settling_sweep,
};
pub use static_margin::{
    MarginPoint, RULE_MAX_AHEAD, RULE_MIN_AHEAD, STATIC_MARGIN_HEADER, StaticMarginSpec,
    StaticMarginSweep, centre_of_pressure_offset, static_margin, static_margin_sweep,
    with_static_margin, write_static_margin_sweep,
};
pub use steady::{
    STEADY_CABLE_HEADER, STEADY_SWEEP_HEADER, SteadySweep, SteadySweepSpec, SteadyVariable,
    steady_sweep, write_steady_sweep,
};

/// Most points one sweep may have.
pub const MAX_SWEEP_POINTS: usize = 1000;
/// Interval of the pitch histories kept for the plots and `pitch.csv`, s.
pub(super) const HISTORY_INTERVAL_S: f64 = 0.01;
/// Most pitch histories drawn in one panel (the palette has 10 colours).
pub(super) const MAX_HISTORIES: usize = 10;

/// The command line's origin for messages.
pub(super) const CLI: &str = "command line";

pub(super) fn cli_invalid(field: &str, message: String) -> SimError {
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
                    format!("must be a finite number, got {}", format_number(v)),
                ));
            }
        }
        if self.step <= 0.0 {
            return Err(cli_invalid(
                "--step",
                format!("must be positive, got {}", format_number(self.step)),
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

/// The time steps of a study's runs in words: `fixed steps of 1 ms` or
/// `adaptive steps` (the default rule, docs/outputs.md "Time steps").
pub fn describe_steps(dt: Option<f64>) -> String {
    match dt {
        Some(dt) => format!("fixed steps of {} ms", trim_number(dt * 1000.0, 6)),
        None => "adaptive steps".to_owned(),
    }
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

/// Writes the tables (file name, CSV text) and, with `plots`, the figures
/// (stem, panels) of a sweep into `dir`; returns the files written.
pub(crate) fn write_sweep(
    dir: &Path,
    tables: &[(&str, String)],
    plots: Option<Vec<(&'static str, Vec<Plot>)>>,
) -> Result<Vec<PathBuf>, SimError> {
    create_dir(dir)?;
    let mut files = Vec::new();
    for (name, text) in tables {
        files.push(write_text(&dir.join(name), text)?);
    }
    for (stem, panels) in plots.into_iter().flatten() {
        files.extend(draw(dir, stem, &panels)?);
    }
    Ok(files)
}

/// Creates `dir` and its parents.
pub(crate) fn create_dir(dir: &Path) -> Result<(), SimError> {
    std::fs::create_dir_all(dir).map_err(|source| SimError::Io {
        action: "create the directory",
        path: dir.to_owned(),
        source,
    })
}

/// Writes `text` to `path`, whole ([`decoy_sim::atomic`]).
pub(crate) fn write_text(path: &Path, text: &str) -> Result<PathBuf, SimError> {
    decoy_sim::atomic::write_atomically(path, text.as_bytes()).map_err(|source| SimError::Io {
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
