//! [`write_report`]: `docs/paper-reproduction.md` and its figures, every claim of
//! the paper side by side with what this project computes for its reference
//! system (`decoy report`).
//!
//! The text is deterministic: no dates, no wall times, only computed numbers
//! printed with fixed decimals, so regenerating gives identical text (and, with
//! `decoy-plots`, identical figures).
//!
//! Models: the host model (`solver.segments_host` = 300 uniform segments, the
//! paper's converged discretisation) where a claim is about the paper's converged
//! model (steady trims, the acceleration peak, turn against straight flight, the
//! discretisation study); the embedded model (`solver.segments_embedded` graded
//! by `solver.grading_ratio_embedded`, named in the text from the configuration)
//! for the pull-up rates and the towing-point and CG settling runs.

mod claims;
mod data;
mod figures;
mod render;

use std::path::PathBuf;

use decoy_config::SystemConfig;

use crate::error::SimError;
use crate::sweep::{create_dir, draw, write_text};

pub use figures::recompress_png;

use claims::claims;
use data::collect;
use figures::figures;
use render::render;

/// The report's file name.
pub const REPORT_FILE: &str = "paper-reproduction.md";
/// The figures' directory, relative to the report.
pub const FIGURES_DIR: &str = "figures";
/// Turn rates flown, rad/s (the paper's Fig. 30-31 case is 0.20).
pub const TURN_RATES: [f64; 3] = [0.05, 0.10, 0.20];
/// Pull-up rates flown, rad/s (the paper's).
pub const PULL_UP_RATES: [f64; 3] = [0.05, 0.10, 0.20];
/// The turn's tension is averaged from this time on, s (after the entry transient).
pub const TURN_AVERAGE_FROM_S: f64 = 5.0;

/// What [`write_report`] needs besides the configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportOptions {
    /// The directory of the report (`docs`); figures go to `<dir>/figures`.
    pub out_dir: PathBuf,
    /// The command that generates the report, quoted in it.
    pub command: String,
}

/// What [`write_report`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportOutput {
    /// The report.
    pub report: PathBuf,
    /// Every file written (the report last).
    pub files: Vec<PathBuf>,
    /// The claims table: `(claim, paper, ours, verdict)`.
    pub claims: Vec<Claim>,
    /// The embedded model's choice in words.
    pub embedded_choice: String,
}

/// One row of the claims table.
#[derive(Clone, Debug, PartialEq)]
pub struct Claim {
    /// What the paper claims.
    pub claim: String,
    /// The paper's number or statement.
    pub paper: String,
    /// What this project computes.
    pub ours: String,
    /// `agrees`, `partly`, `disagrees`.
    pub verdict: Verdict,
    /// Why, in a few words (the section has the details).
    pub why: String,
}

/// Whether the project reproduces a claim.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Reproduced.
    Agrees,
    /// Reproduced in part (the trend but not the number, or in part of the range).
    Partly,
    /// Not reproduced.
    Disagrees,
}

impl Verdict {
    pub(super) fn word(self) -> &'static str {
        match self {
            Verdict::Agrees => "yes",
            Verdict::Partly => "partly",
            Verdict::Disagrees => "no",
        }
    }

    pub(super) fn of(ok: bool) -> Self {
        if ok {
            Verdict::Agrees
        } else {
            Verdict::Disagrees
        }
    }
}

/// Splits the overall progress between stages by their expected cost.
pub(super) struct Progress<F: FnMut(f64)> {
    pub(super) report: F,
    pub(super) done: f64,
}

impl<F: FnMut(f64)> Progress<F> {
    /// A callback for a stage worth `weight` of the whole.
    pub(super) fn stage(&mut self, weight: f64) -> impl FnMut(f64) + '_ {
        let base = self.done;
        self.done += weight;
        move |f: f64| (self.report)((base + weight * f.clamp(0.0, 1.0)).min(1.0))
    }
}

/// Runs every case and writes `<out_dir>/paper-reproduction.md` and its figures
/// (PNG + SVG) in `<out_dir>/figures`; `progress` gets the fraction done.
pub fn write_report(
    config: &SystemConfig,
    options: &ReportOptions,
    progress: impl FnMut(f64),
) -> Result<ReportOutput, SimError> {
    let mut progress = Progress {
        report: progress,
        done: 0.0,
    };
    let data = collect(config, &mut progress)?;

    let figures_dir = options.out_dir.join(FIGURES_DIR);
    create_dir(&figures_dir)?;
    let mut files = Vec::new();
    for (stem, panels) in figures(&data) {
        let [png, svg] = draw(&figures_dir, &stem, &panels)?;
        recompress_png(&png)?;
        files.extend([png, svg]);
    }
    let claims = claims(&data);
    let text = render(config, options, &data, &claims);
    let report = write_text(&options.out_dir.join(REPORT_FILE), &text)?;
    files.push(report.clone());
    (progress.report)(1.0);
    let embedded_choice = match data.study.embedded.chosen() {
        Some(c) => format!(
            "{} segments graded {}",
            c.metrics.segments, c.metrics.grading
        ),
        None => "none within the tolerances".to_owned(),
    };
    Ok(ReportOutput {
        report,
        files,
        claims,
        embedded_choice,
    })
}
