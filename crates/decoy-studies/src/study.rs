//! The discretisation study (the paper's Figs. 13-14, docs/design.md §7) and the
//! choice of the embedded (reduced) model (docs/design.md §6).
//!
//! [`discretisation_study`] flies the acceleration scenario (Mach 0.6 to 0.8 at
//! 10 m/s² from t = 2 s, 9 km, 25 s) with each discretisation and records the
//! peak connection tension and the decoy pitch oscillation amplitude. The RK4
//! step must resolve the transverse waves on the shortest segment (stable roughly
//! below 1.4 l_min / c, c = sqrt(T/μ), docs/design.md §4), so each run first tries the
//! configuration's host step (1 ms) and halves it after a divergence, up to
//! [`StudySpec::max_halvings`] times; the step used is reported.
//!
//! It then compares candidate embedded models (small segment counts at several
//! grading ratios, and always the configuration's embedded model) with the host
//! model (`solver.segments_host` uniform segments) on the steady trim
//! (connection tension and decoy depth) and on the acceleration's peak tension,
//! and [`choose_embedded`] picks the smallest one within the tolerances.

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_plots::{Plot, Series};
use serde::Serialize;
use solver_core::SegmentLayout;

use crate::sweep::{
    create_dir, csv_row, draw, layout_parts, plot, trim_number, trim_point, write_text,
};
use decoy_sim::error::SimError;
use decoy_sim::options::RunOptions;
use decoy_sim::scenario::Scenario;
use decoy_sim::trace::{Trace, TraceOptions, trace};

/// What the study runs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StudySpec {
    /// Uniform segment counts.
    pub uniform: Vec<usize>,
    /// Graded segment counts, at [`StudySpec::grading`].
    pub graded: Vec<usize>,
    /// Grading ratio of the graded series.
    pub grading: f64,
    /// First RK4 step tried, s.
    pub dt: f64,
    /// Most halvings of the step after divergences.
    pub max_halvings: u32,
    /// The reference (host) model's uniform segment count.
    pub reference_segments: usize,
    /// Candidate embedded models: segment counts ...
    pub embedded_segments: Vec<usize>,
    /// ... at each of these grading ratios (the configuration's embedded model
    /// is a candidate besides).
    pub embedded_ratios: Vec<f64>,
    /// Mach number of the steady trim compared.
    pub trim_mach: f64,
    /// Altitude of the steady trim compared, m.
    pub trim_altitude_m: f64,
    /// Tolerances of the choice.
    pub tolerances: Tolerances,
}

impl StudySpec {
    /// The default study: uniform 10, 20, 50, 100, 200, 300, 400; graded 1.3 at
    /// 8, 12, 16, 20, 24, 32; first step the configuration's host step, up to 6
    /// halvings; reference the host model; embedded candidates 6 to 24 segments at
    /// ratios 1.2, 1.3 and 1.4 (and the configuration's embedded model); trim at
    /// Mach 0.8, 9 km; tolerances 2 % (trim) and 5 % (peak tension).
    pub fn default_for(config: &SystemConfig) -> Self {
        StudySpec {
            uniform: vec![10, 20, 50, 100, 200, 300, 400],
            graded: vec![8, 12, 16, 20, 24, 32],
            grading: 1.3,
            dt: config.solver.time_step_host,
            max_halvings: 6,
            reference_segments: config.solver.segments_host,
            embedded_segments: vec![6, 8, 10, 12, 14, 16, 20, 24],
            embedded_ratios: vec![1.2, 1.3, 1.4],
            trim_mach: 0.8,
            trim_altitude_m: 9000.0,
            tolerances: Tolerances::default(),
        }
    }
}

/// Relative tolerances of the embedded model against the host model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Tolerances {
    /// On the steady trim's connection tension and decoy depth.
    pub trim: f64,
    /// On the acceleration's peak connection tension.
    pub peak: f64,
}

impl Default for Tolerances {
    /// 2 % on the trim, 5 % on the peak tension.
    fn default() -> Self {
        Tolerances {
            trim: 0.02,
            peak: 0.05,
        }
    }
}

/// One acceleration run of the study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StudyRow {
    /// `uniform` or `graded R`.
    pub family: String,
    /// Number of segments.
    pub segments: usize,
    /// Grading ratio (1 = uniform).
    pub grading: f64,
    /// Shortest segment, m.
    pub shortest_segment_m: f64,
    /// RK4 step used, s.
    pub dt_s: f64,
    /// Largest connection tension, N.
    #[serde(rename = "max_tension_connection_N")]
    pub max_tension_connection_n: f64,
    /// When, s.
    pub t_at_max_tension_s: f64,
    /// Half the peak-to-peak decoy pitch from the acceleration's start on, deg
    /// (the paper's Fig. 14 plots the full peak-to-peak, twice this).
    pub pitch_amplitude_deg: f64,
    /// Connection tension at the end, N.
    #[serde(rename = "final_tension_connection_N")]
    pub final_tension_connection_n: f64,
    /// Why the run failed even at the shortest step tried, if it did.
    pub stopped: Option<String>,
    /// The run (for plots).
    #[serde(skip)]
    pub trace: Trace,
}

/// Flies the acceleration scenario with `layout`, starting with step `dt` and
/// halving it after a divergence up to `max_halvings` times. Returns the last
/// run (diverged only if every step tried diverged).
pub fn acceleration_run(
    config: &SystemConfig,
    layout: SegmentLayout<f64>,
    dt: f64,
    max_halvings: u32,
    mut progress: impl FnMut(f64),
) -> Result<StudyRow, SimError> {
    let scenario = Scenario::builtin("acceleration")?;
    let (segments, grading) = layout_parts(&layout);
    let mut step = dt;
    let mut halvings = 0;
    loop {
        let options = RunOptions {
            segments: Some(segments),
            grading: Some(grading),
            dt: Some(step),
            plots: false,
            ..RunOptions::default()
        };
        let plan = scenario.plan(config, &options)?;
        let run = trace(config, &plan, &TraceOptions::default(), &mut progress)?;
        if run.stopped.is_some() && halvings < max_halvings {
            step *= 0.5;
            halvings += 1;
            continue;
        }
        let lengths: Vec<f64> = run.joint_along_m.windows(2).map(|w| w[1] - w[0]).collect();
        return Ok(StudyRow {
            family: family(grading),
            segments,
            grading,
            shortest_segment_m: lengths.iter().copied().fold(f64::INFINITY, f64::min),
            dt_s: step,
            max_tension_connection_n: run.max_tension_connection_n,
            t_at_max_tension_s: run.t_at_max_tension_s,
            pitch_amplitude_deg: run.pitch_oscillation_amplitude_deg,
            final_tension_connection_n: run.last().tension_connection,
            stopped: run
                .stopped
                .as_ref()
                .map(|s| format!("t = {} s: {}", s.t_s, s.reason)),
            trace: run,
        });
    }
}

fn family(grading: f64) -> String {
    if grading == 1.0 {
        "uniform".to_owned()
    } else {
        format!("graded {grading}")
    }
}

/// What a candidate model gives, for [`choose_embedded`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ModelMetrics {
    /// Number of segments.
    pub segments: usize,
    /// Grading ratio (1 = uniform).
    pub grading: f64,
    /// RK4 step of its acceleration run, s.
    pub dt_s: f64,
    /// Steady trim: connection tension, N.
    #[serde(rename = "trim_tension_connection_N")]
    pub trim_tension_connection_n: f64,
    /// Steady trim: decoy CG below the flight path, m.
    pub trim_depth_m: f64,
    /// Acceleration: peak connection tension, N.
    #[serde(rename = "peak_tension_connection_N")]
    pub peak_tension_connection_n: f64,
    /// Acceleration: decoy pitch amplitude, deg (reported, not a criterion).
    pub pitch_amplitude_deg: f64,
}

/// A candidate's relative errors against the reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CandidateErrors {
    /// The candidate.
    #[serde(flatten)]
    pub metrics: ModelMetrics,
    /// |trim connection tension - reference| / reference.
    pub error_trim_tension: f64,
    /// |trim depth - reference| / reference.
    pub error_trim_depth: f64,
    /// |peak tension - reference| / reference.
    pub error_peak_tension: f64,
    /// |pitch amplitude - reference| / reference (not a criterion).
    pub error_pitch_amplitude: f64,
    /// Largest error as a fraction of its tolerance (<= 1: within all).
    pub worst_fraction_of_tolerance: f64,
    /// Within every tolerance.
    pub within_tolerances: bool,
}

/// The result of [`choose_embedded`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EmbeddedChoice {
    /// The reference (host) model.
    pub reference: ModelMetrics,
    /// The tolerances applied.
    pub tolerances: Tolerances,
    /// Every candidate, in the order given.
    pub candidates: Vec<CandidateErrors>,
    /// Index in `candidates` of the chosen one, if any is within the tolerances.
    pub chosen: Option<usize>,
}

fn relative_error(value: f64, reference: f64) -> f64 {
    let e = (value - reference).abs() / reference.abs();
    if e.is_finite() { e } else { f64::INFINITY }
}

/// Picks the embedded model: among the candidates within `tolerances` of the
/// reference (trim connection tension and depth within `tolerances.trim`, peak
/// tension within `tolerances.peak`, relative), the one with the fewest segments;
/// on a tie the one with the smallest largest error relative to its tolerance,
/// then the smaller grading ratio. A non-finite value (a run that diverged) is
/// never within tolerance.
pub fn choose_embedded(
    reference: &ModelMetrics,
    candidates: &[ModelMetrics],
    tolerances: Tolerances,
) -> EmbeddedChoice {
    let rows: Vec<CandidateErrors> = candidates
        .iter()
        .map(|m| {
            let error_trim_tension = relative_error(
                m.trim_tension_connection_n,
                reference.trim_tension_connection_n,
            );
            let error_trim_depth = relative_error(m.trim_depth_m, reference.trim_depth_m);
            let error_peak_tension = relative_error(
                m.peak_tension_connection_n,
                reference.peak_tension_connection_n,
            );
            let worst = (error_trim_tension / tolerances.trim)
                .max(error_trim_depth / tolerances.trim)
                .max(error_peak_tension / tolerances.peak);
            CandidateErrors {
                metrics: *m,
                error_trim_tension,
                error_trim_depth,
                error_peak_tension,
                error_pitch_amplitude: relative_error(
                    m.pitch_amplitude_deg,
                    reference.pitch_amplitude_deg,
                ),
                worst_fraction_of_tolerance: worst,
                within_tolerances: worst <= 1.0,
            }
        })
        .collect();
    let chosen = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.within_tolerances)
        .min_by(|(_, a), (_, b)| {
            a.metrics
                .segments
                .cmp(&b.metrics.segments)
                .then(
                    a.worst_fraction_of_tolerance
                        .total_cmp(&b.worst_fraction_of_tolerance),
                )
                .then(a.metrics.grading.total_cmp(&b.metrics.grading))
        })
        .map(|(i, _)| i);
    EmbeddedChoice {
        reference: *reference,
        tolerances,
        candidates: rows,
        chosen,
    }
}

impl EmbeddedChoice {
    /// The chosen candidate.
    pub fn chosen(&self) -> Option<&CandidateErrors> {
        self.chosen.map(|i| &self.candidates[i])
    }

    /// The candidate with `segments` and `grading`, if it was one.
    pub fn candidate(&self, segments: usize, grading: f64) -> Option<&CandidateErrors> {
        self.candidates
            .iter()
            .find(|c| c.metrics.segments == segments && c.metrics.grading == grading)
    }

    /// The justification in Markdown: the rule, the reference, a table of every
    /// candidate's errors and the choice (deterministic text).
    pub fn justification(&self, configured: (usize, f64)) -> String {
        let r = &self.reference;
        let t = &self.tolerances;
        let mut s = String::new();
        s.push_str(&format!(
            "Rule: the fewest segments whose steady trim (connection tension and decoy depth) is within {} % of the reference and whose peak connection tension in the acceleration case is within {} % (ties: the smallest error relative to its tolerance, then the smaller ratio).\n\n",
            trim_number(100.0 * t.trim, 2),
            trim_number(100.0 * t.peak, 2)
        ));
        s.push_str(&format!(
            "Reference: {} uniform segments: trim connection tension {:.2} N, decoy depth {:.3} m; acceleration peak tension {:.2} N (dt {} ms), pitch amplitude {:.3} deg.\n\n",
            r.segments,
            r.trim_tension_connection_n,
            r.trim_depth_m,
            r.peak_tension_connection_n,
            trim_number(r.dt_s * 1000.0, 6),
            r.pitch_amplitude_deg
        ));
        s.push_str("| segments | ratio | dt [ms] | trim tension [N] | err | depth [m] | err | peak tension [N] | err | pitch ampl. [deg] | err | within |\n");
        s.push_str("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---|\n");
        for (i, c) in self.candidates.iter().enumerate() {
            let m = &c.metrics;
            let mark = if Some(i) == self.chosen {
                "**chosen**"
            } else if c.within_tolerances {
                "yes"
            } else {
                "no"
            };
            s.push_str(&format!(
                "| {} | {} | {} | {:.2} | {} | {:.3} | {} | {:.2} | {} | {:.3} | {} | {mark} |\n",
                m.segments,
                m.grading,
                trim_number(m.dt_s * 1000.0, 6),
                m.trim_tension_connection_n,
                percent(c.error_trim_tension),
                m.trim_depth_m,
                percent(c.error_trim_depth),
                m.peak_tension_connection_n,
                percent(c.error_peak_tension),
                m.pitch_amplitude_deg,
                percent(c.error_pitch_amplitude),
            ));
        }
        s.push('\n');
        match self.chosen() {
            Some(c) => {
                let m = &c.metrics;
                s.push_str(&format!(
                    "Chosen: **{} segments graded {}**: trim tension {} off, depth {} off, peak tension {} off (pitch amplitude {} off).",
                    m.segments,
                    m.grading,
                    percent(c.error_trim_tension),
                    percent(c.error_trim_depth),
                    percent(c.error_peak_tension),
                    percent(c.error_pitch_amplitude)
                ));
                let (n, ratio) = configured;
                if (m.segments, m.grading) == (n, ratio) {
                    s.push_str(" It is the configured embedded model (`solver.segments_embedded`, `solver.grading_ratio_embedded`).\n");
                } else {
                    s.push_str(&format!(
                        " The configuration's embedded model is {n} segments graded {ratio}"
                    ));
                    match self.candidate(n, ratio) {
                        Some(configured) => {
                            s.push_str(&format!(
                                ": trim tension {} off, depth {} off, peak tension {} off, pitch amplitude {} off ({}).\n",
                                percent(configured.error_trim_tension),
                                percent(configured.error_trim_depth),
                                percent(configured.error_peak_tension),
                                percent(configured.error_pitch_amplitude),
                                if configured.within_tolerances {
                                    "also within the tolerances"
                                } else {
                                    "outside the tolerances"
                                }
                            ));
                            if configured.within_tolerances {
                                s.push_str(&format!(
                                    "\nThe configured model is not the smallest within these tolerances: its \
                                     choice also weighs what this study does not fly, the snatch loads of the \
                                     pull-ups and the recorded flight integrated at the firmware's steps within \
                                     its frame budget (`docs/design.md` §6). A system that needs the cheaper \
                                     model sets `solver.segments_embedded = {}` and \
                                     `solver.grading_ratio_embedded = {}` in its configuration.\n",
                                    m.segments, m.grading,
                                ));
                            }
                        }
                        None => s.push_str(" (not among the candidates).\n"),
                    }
                }
            }
            None => s.push_str("No candidate is within the tolerances.\n"),
        }
        s
    }
}

/// A relative error as a percentage with 3 decimals.
fn percent(e: f64) -> String {
    if e.is_finite() {
        format!("{:.3} %", 100.0 * e)
    } else {
        "n/a".to_owned()
    }
}

/// The whole study's results.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiscretisationStudy {
    /// What was run.
    pub spec: StudySpec,
    /// The acceleration runs of the uniform and graded series, in the order given.
    pub rows: Vec<StudyRow>,
    /// The embedded model's choice.
    pub embedded: EmbeddedChoice,
    /// The configured embedded model `(segments, grading)`.
    pub configured_embedded: (usize, f64),
}

/// Runs the study `spec` on `config`; `progress` gets the fraction done.
pub fn discretisation_study(
    config: &SystemConfig,
    spec: &StudySpec,
    mut progress: impl FnMut(f64),
) -> Result<DiscretisationStudy, SimError> {
    let layouts = |counts: &[usize], ratio: f64| -> Result<Vec<SegmentLayout<f64>>, SimError> {
        counts
            .iter()
            .map(|&n| crate::sweep::layout(n, ratio))
            .collect()
    };
    let mut series = layouts(&spec.uniform, 1.0)?;
    series.extend(layouts(&spec.graded, spec.grading)?);
    let reference_layout = crate::sweep::layout(spec.reference_segments, 1.0)?;
    let mut embedded = Vec::new();
    for &ratio in &spec.embedded_ratios {
        embedded.extend(layouts(&spec.embedded_segments, ratio)?);
    }
    // The configured embedded model is always a candidate, so that the study says
    // how the model the product flies compares.
    let configured = crate::sweep::layout(
        config.solver.segments_embedded,
        config.solver.grading_ratio_embedded,
    )?;
    if !embedded.contains(&configured) {
        embedded.push(configured);
    }
    // Every distinct layout is run once; the cost of a run is about its segment
    // count (more when the step is halved, not known in advance).
    let mut distinct: Vec<SegmentLayout<f64>> = Vec::new();
    for l in series
        .iter()
        .chain([&reference_layout])
        .chain(embedded.iter())
    {
        if !distinct.contains(l) {
            distinct.push(*l);
        }
    }
    let total: f64 = distinct.iter().map(|l| l.count() as f64).sum();
    let mut done = 0.0;
    let mut runs: Vec<(SegmentLayout<f64>, StudyRow)> = Vec::new();
    for l in &distinct {
        let weight = l.count() as f64 / total;
        let row = acceleration_run(config, *l, spec.dt, spec.max_halvings, |f| {
            progress(done + weight * f.min(1.0))
        })
        .map_err(|e| e.at(decoy_sim::format::describe_layout(l)))?;
        done += weight;
        runs.push((*l, row));
    }
    let find = |l: &SegmentLayout<f64>| -> &StudyRow {
        &runs
            .iter()
            .find(|(k, _)| k == l)
            .expect("every layout was run")
            .1
    };
    let metrics = |l: &SegmentLayout<f64>| -> Result<ModelMetrics, SimError> {
        let row = find(l);
        let trimmed = trim_point(config, *l, spec.trim_altitude_m, spec.trim_mach)
            .map_err(|e| e.at(decoy_sim::format::describe_layout(l)))?;
        Ok(ModelMetrics {
            segments: row.segments,
            grading: row.grading,
            dt_s: row.dt_s,
            trim_tension_connection_n: trimmed.tension_connection_n,
            trim_depth_m: trimmed.decoy_cg_below_m,
            peak_tension_connection_n: if row.stopped.is_some() {
                f64::NAN
            } else {
                row.max_tension_connection_n
            },
            pitch_amplitude_deg: row.pitch_amplitude_deg,
        })
    };
    let reference = metrics(&reference_layout)?;
    let candidates = embedded
        .iter()
        .map(metrics)
        .collect::<Result<Vec<_>, _>>()?;
    let choice = choose_embedded(&reference, &candidates, spec.tolerances);
    let rows = series.iter().map(|l| find(l).clone()).collect();
    progress(1.0);
    Ok(DiscretisationStudy {
        spec: spec.clone(),
        rows,
        embedded: choice,
        configured_embedded: (
            config.solver.segments_embedded,
            config.solver.grading_ratio_embedded,
        ),
    })
}

/// The header of `discretisation.csv`.
pub const STUDY_HEADER: &str = "segments,grading,shortest_segment_m,dt_s,max_tension_connection_N,t_at_max_tension_s,pitch_amplitude_deg,final_tension_connection_N,stopped";
/// The header of `embedded-candidates.csv`.
pub const CANDIDATES_HEADER: &str = "segments,grading,dt_s,trim_tension_connection_N,trim_depth_m,peak_tension_connection_N,pitch_amplitude_deg,error_trim_tension,error_trim_depth,error_peak_tension,error_pitch_amplitude,within_tolerances,chosen";

impl DiscretisationStudy {
    /// The rows of one family (`uniform` when `graded` is false).
    pub fn family(&self, graded: bool) -> Vec<&StudyRow> {
        self.rows
            .iter()
            .filter(|r| (r.grading != 1.0) == graded)
            .collect()
    }

    /// The reference row (the host model), if it is among the rows.
    pub fn reference_row(&self) -> Option<&StudyRow> {
        self.rows
            .iter()
            .find(|r| r.grading == 1.0 && r.segments == self.spec.reference_segments)
    }

    /// `discretisation.csv`'s text.
    pub fn table_csv(&self) -> String {
        let mut s = format!("{STUDY_HEADER}\n");
        for r in &self.rows {
            let values = csv_row(&[
                r.grading,
                r.shortest_segment_m,
                r.dt_s,
                r.max_tension_connection_n,
                r.t_at_max_tension_s,
                r.pitch_amplitude_deg,
                r.final_tension_connection_n,
            ]);
            s.push_str(&format!(
                "{},{},{}\n",
                r.segments,
                values.trim_end(),
                r.stopped.as_deref().unwrap_or("").replace([',', '\n'], ";")
            ));
        }
        s
    }

    /// `embedded-candidates.csv`'s text.
    pub fn candidates_csv(&self) -> String {
        let mut s = format!("{CANDIDATES_HEADER}\n");
        for (i, c) in self.embedded.candidates.iter().enumerate() {
            let m = &c.metrics;
            let values = csv_row(&[
                m.grading,
                m.dt_s,
                m.trim_tension_connection_n,
                m.trim_depth_m,
                m.peak_tension_connection_n,
                m.pitch_amplitude_deg,
                c.error_trim_tension,
                c.error_trim_depth,
                c.error_peak_tension,
                c.error_pitch_amplitude,
            ]);
            s.push_str(&format!(
                "{},{},{},{}\n",
                m.segments,
                values.trim_end(),
                c.within_tolerances,
                Some(i) == self.embedded.chosen
            ));
        }
        s
    }

    /// The study table in Markdown.
    pub fn table_markdown(&self) -> String {
        let mut s = String::from(
            "| model | segments | shortest segment [m] | dt [ms] | peak tension [N] | at t [s] | pitch ampl. [deg] | final tension [N] |\n|:---|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for r in &self.rows {
            let stopped = if r.stopped.is_some() {
                " (diverged)"
            } else {
                ""
            };
            s.push_str(&format!(
                "| {}{stopped} | {} | {:.3} | {} | {:.2} | {:.3} | {:.3} | {:.2} |\n",
                r.family,
                r.segments,
                r.shortest_segment_m,
                trim_number(r.dt_s * 1000.0, 6),
                r.max_tension_connection_n,
                r.t_at_max_tension_s,
                r.pitch_amplitude_deg,
                r.final_tension_connection_n
            ));
        }
        s
    }

    /// The plots: peak tension and pitch amplitude against the segment count
    /// (one panel per family with the reference as a line, and a panel of the
    /// relative difference from the reference on log scales), and tension
    /// histories of a few models.
    pub fn plots(&self) -> Vec<(&'static str, Vec<Plot>)> {
        let reference = self.reference_row();
        let name = |graded: bool| {
            if graded {
                format!("graded {}", self.spec.grading)
            } else {
                "uniform".to_owned()
            }
        };
        let panel = |graded: bool, what: &str, y_label: &str, y: fn(&StudyRow) -> f64| {
            let rows = self.family(graded);
            let x: Vec<f64> = rows.iter().map(|r| r.segments as f64).collect();
            let mut series = vec![Series {
                label: name(graded),
                x: x.clone(),
                y: rows.iter().map(|r| y(r)).collect(),
            }];
            if let (Some(r), false) = (reference, x.is_empty()) {
                series.push(Series {
                    label: format!("{} uniform (reference)", r.segments),
                    x: vec![x[0], x[x.len() - 1]],
                    y: vec![y(r), y(r)],
                });
            }
            plot(
                format!("{what}: {} segments", name(graded)),
                "number of segments",
                y_label,
                series,
            )
        };
        let difference = |what: &str, y: fn(&StudyRow) -> f64| -> Option<Plot> {
            let r = reference?;
            let series = [false, true]
                .into_iter()
                .map(|graded| {
                    let rows = self.family(graded);
                    Series {
                        label: name(graded),
                        x: rows
                            .iter()
                            .map(|row| (row.segments as f64).log10())
                            .collect(),
                        y: rows
                            .iter()
                            .map(|row| ((y(row) - y(r)).abs() / y(r).abs()).log10())
                            .collect(),
                    }
                })
                .filter(|s| s.y.iter().any(|v| v.is_finite()))
                .collect::<Vec<_>>();
            (!series.is_empty()).then(|| {
                plot(
                    format!("{what}: relative difference from {} uniform", r.segments),
                    "log10(number of segments)",
                    "log10(|difference| / reference)",
                    series,
                )
            })
        };
        let mut figures = Vec::new();
        for (stem, what, y_label, y) in [
            (
                "peak-tension-vs-segments",
                "Peak connection tension, acceleration case",
                "peak tension [N]",
                (|r: &StudyRow| r.max_tension_connection_n) as fn(&StudyRow) -> f64,
            ),
            (
                "pitch-amplitude-vs-segments",
                "Decoy pitch amplitude, acceleration case",
                "half peak-to-peak pitch [deg]",
                |r: &StudyRow| r.pitch_amplitude_deg,
            ),
        ] {
            let mut panels: Vec<Plot> = [false, true]
                .into_iter()
                .filter(|g| !self.family(*g).is_empty())
                .map(|g| panel(g, what, y_label, y))
                .collect();
            panels.extend(difference(what, y));
            if !panels.is_empty() {
                figures.push((stem, panels));
            }
        }
        let panels: Vec<Plot> = [false, true]
            .into_iter()
            .filter_map(|graded| {
                // The coarsest models' tension spikes can dwarf the rest: show the
                // two coarsest within 3 times the reference's peak, and the
                // reference (else the finest).
                let limit = reference.map_or(f64::INFINITY, |r| 3.0 * r.max_tension_connection_n);
                let rows: Vec<&StudyRow> = self
                    .family(graded)
                    .into_iter()
                    .filter(|r| r.stopped.is_none() && r.max_tension_connection_n <= limit)
                    .collect();
                let last = *rows
                    .iter()
                    .find(|r| reference.is_some_and(|reference| std::ptr::eq(**r, reference)))
                    .or(rows.last())?;
                let mut shown: Vec<&StudyRow> = rows.iter().take(2).copied().collect();
                if !shown.iter().any(|r| std::ptr::eq(*r, last)) {
                    shown.push(last);
                }
                Some(plot(
                    format!("Connection tension, acceleration case: {}", name(graded)),
                    "t [s]",
                    "tension [N]",
                    shown
                        .iter()
                        .map(|r| Series {
                            label: format!("N = {}", r.segments),
                            x: r.trace.samples.iter().map(|s| s.t).collect(),
                            y: r.trace
                                .samples
                                .iter()
                                .map(|s| s.tension_connection)
                                .collect(),
                        })
                        .collect(),
                ))
            })
            .collect();
        if !panels.is_empty() {
            figures.push(("tension-histories", panels));
        }
        figures
    }
}

/// Writes `discretisation.csv`, `embedded-candidates.csv`, `embedded-model.md`
/// and (with `plots`) the plots into `dir`; returns the files written.
pub fn write_study(
    study: &DiscretisationStudy,
    dir: &Path,
    plots: bool,
) -> Result<Vec<PathBuf>, SimError> {
    create_dir(dir)?;
    let mut md = String::from("# Embedded model: justification\n\n");
    md.push_str(&study.embedded.justification(study.configured_embedded));
    let mut files = vec![
        write_text(&dir.join("discretisation.csv"), &study.table_csv())?,
        write_text(
            &dir.join("embedded-candidates.csv"),
            &study.candidates_csv(),
        )?,
        write_text(&dir.join("embedded-model.md"), &md)?,
    ];
    if plots {
        for (stem, panels) in study.plots() {
            files.extend(draw(dir, stem, &panels)?);
        }
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(segments: usize, grading: f64, tension: f64, depth: f64, peak: f64) -> ModelMetrics {
        ModelMetrics {
            segments,
            grading,
            dt_s: 1e-3,
            trim_tension_connection_n: tension,
            trim_depth_m: depth,
            peak_tension_connection_n: peak,
            pitch_amplitude_deg: 1.0,
        }
    }

    #[test]
    fn the_fewest_segments_within_every_tolerance_win() {
        let reference = metrics(300, 1.0, 100.0, 10.0, 200.0);
        let candidates = [
            // 6 segments: trim tension 3 % off: out.
            metrics(6, 1.4, 103.0, 10.0, 200.0),
            // 8 segments graded 1.2: peak 6 % off: out.
            metrics(8, 1.2, 100.5, 10.1, 212.0),
            // 8 segments graded 1.3 and 1.4: both in; 1.4 has the smaller worst error.
            metrics(8, 1.3, 101.5, 10.0, 201.0),
            metrics(8, 1.4, 100.5, 10.05, 208.0),
            // 16 segments: in, but more segments.
            metrics(16, 1.3, 100.0, 10.0, 200.0),
            // Diverged: never in.
            metrics(4, 1.3, 100.0, 10.0, f64::NAN),
        ];
        let choice = choose_embedded(&reference, &candidates, Tolerances::default());
        let within: Vec<bool> = choice
            .candidates
            .iter()
            .map(|c| c.within_tolerances)
            .collect();
        assert_eq!(within, vec![false, false, true, true, true, false]);
        // 8/1.3: worst 1.5/2 = 0.75; 8/1.4: max(0.25, 0.25, 0.8) = 0.8 -> 8/1.3 wins.
        assert_eq!(choice.chosen, Some(2));
        let c = choice.chosen().unwrap();
        assert!((c.error_trim_tension - 0.015).abs() < 1e-12);
        assert!((c.worst_fraction_of_tolerance - 0.75).abs() < 1e-12);
        let text = choice.justification((16, 1.3));
        assert!(text.contains("**chosen**"));
        assert!(text.contains("8 segments graded 1.3"));
        assert!(text.contains("16 segments graded 1.3"));
    }

    #[test]
    fn equal_errors_prefer_the_smaller_ratio_and_nothing_within_is_none() {
        let reference = metrics(300, 1.0, 100.0, 10.0, 200.0);
        let same = [
            metrics(10, 1.4, 101.0, 10.0, 200.0),
            metrics(10, 1.2, 101.0, 10.0, 200.0),
        ];
        let choice = choose_embedded(&reference, &same, Tolerances::default());
        assert_eq!(choice.chosen, Some(1));
        let none = choose_embedded(
            &reference,
            &[metrics(10, 1.3, 150.0, 10.0, 200.0)],
            Tolerances::default(),
        );
        assert_eq!(none.chosen, None);
        assert!(none.justification((16, 1.3)).contains("No candidate"));
    }
}
