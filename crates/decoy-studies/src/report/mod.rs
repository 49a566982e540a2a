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
mod spec;

use std::path::PathBuf;

use decoy_config::SystemConfig;

use crate::sweep::{create_dir, draw, write_text};
use decoy_sim::error::SimError;

pub use figures::recompress_png;
pub use spec::{
    Claim, FIGURES_DIR, PULL_UP_RATES, REPORT_FILE, ReportOptions, TURN_AVERAGE_FROM_S, TURN_RATES,
    Verdict,
};

use claims::claims;
use data::collect;
use figures::figures;
use render::render;
use spec::Progress;

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
