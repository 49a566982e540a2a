//! The progress bar of long runs: on stderr, only when it is a terminal, not with
//! `--json`, and only once a run is expected to last more than a second.

use std::io::IsTerminal as _;
use std::time::Instant;

/// Show a progress bar only for runs expected to last longer than this, s.
const PROGRESS_BAR_MIN_S: f64 = 1.0;
/// Time before the expected duration is judged, s.
const PROGRESS_ESTIMATE_AFTER_S: f64 = 0.2;

/// A progress bar that appears when a run proves long (see the module docs).
pub struct Progress {
    show: bool,
    started: Instant,
    label: &'static str,
    bar: Option<indicatif::ProgressBar>,
}

impl Progress {
    /// A bar labelled `label` (`simulating`), shown only if stderr is a terminal
    /// and `json` is false.
    pub fn new(label: &'static str, json: bool) -> Self {
        Progress {
            show: !json && std::io::stderr().is_terminal(),
            started: Instant::now(),
            label,
            bar: None,
        }
    }

    /// Reports the fraction done (0 to 1).
    pub fn update(&mut self, fraction: f64) {
        if !self.show {
            return;
        }
        let elapsed = self.started.elapsed().as_secs_f64();
        if self.bar.is_none()
            && elapsed >= PROGRESS_ESTIMATE_AFTER_S
            && fraction < 1.0
            && elapsed / fraction.max(1e-9) > PROGRESS_BAR_MIN_S
        {
            let b = indicatif::ProgressBar::new(1000);
            b.set_style(
                indicatif::ProgressStyle::with_template(&format!(
                    "{{spinner}} {} [{{bar:40}}] {{percent:>3}}% ({{elapsed}} elapsed)",
                    self.label
                ))
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            self.bar = Some(b);
        }
        if let Some(b) = &self.bar {
            b.set_position((fraction.clamp(0.0, 1.0) * 1000.0).round() as u64);
        }
    }

    /// Removes the bar.
    pub fn finish(self) {
        if let Some(b) = self.bar {
            b.finish_and_clear();
        }
    }
}
