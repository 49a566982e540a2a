//! What the report flies and how it states its results, shared by its parts:
//! its files, the rates it flies, the options, the claims table's rows and
//! verdicts, and the split of the progress between its stages.

use std::path::PathBuf;

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

/// What [`super::write_report`] needs besides the configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportOptions {
    /// The directory of the report (`docs`); figures go to `<dir>/figures`.
    pub out_dir: PathBuf,
    /// The command that generates the report, quoted in it.
    pub command: String,
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
    pub(crate) fn word(self) -> &'static str {
        match self {
            Verdict::Agrees => "yes",
            Verdict::Partly => "partly",
            Verdict::Disagrees => "no",
        }
    }

    pub(crate) fn of(ok: bool) -> Self {
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
