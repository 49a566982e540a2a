//! `decoy sweep`, `decoy study` and `decoy report` (the library is the crate
//! `decoy-studies`: `sweep`, `study`, `report`; outputs in `docs/sweeps.md`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use decoy_config::SystemConfig;
use decoy_sim::trim::host_layout;
use decoy_studies::report::{ReportOptions, Verdict, write_report};
use decoy_studies::study::{StudySpec, discretisation_study, write_study};
use decoy_studies::sweep::{
    PullUpSpec, PullUpSweep, StaticMarginSpec, StaticMarginSweep, describe_steps, pull_up_sweep,
    static_margin_sweep, write_pull_up_sweep, write_static_margin_sweep,
};
use decoy_studies::sweep::{
    SettlingSpec, SettlingSweep, StationVariable, SteadySweep, SteadySweepSpec, SteadyVariable,
    SweepRange, settling_sweep, steady_sweep, write_settling_sweep, write_steady_sweep,
};
use serde::Serialize;

use crate::failure::{Failure, to_json, usage};
use crate::progress::Progress;

/// The command that regenerates the report, as the report quotes it.
pub const REPORT_COMMAND: &str = "cargo run --release -p decoy-cli --bin decoy -- report";
/// The report's default directory.
const REPORT_DIR: &str = "docs";

/// What `decoy sweep` varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SweepKind {
    /// Mach number at a fixed altitude (default 0.5 to 0.9 by 0.05 at 9 km): trims.
    Speed,
    /// Altitude at a fixed Mach number (default 3000 to 12000 m by 1000 at Mach 0.7): trims.
    Altitude,
    /// Towing point decoy.x_tow at the configured CG (default 0.05 to 0.6 m by 0.025): settling runs.
    TowPoint,
    /// CG decoy.x_cg at the configured towing point (default 0.05 to 0.5 m by 0.025): settling runs.
    Cg,
    /// Pull-up rate, rad/s (default 0.02 to 0.2 by 0.02 at Mach 0.6, 9 km, then
    /// bisection): the largest rate that keeps the cable out of the exhaust plume.
    PullUpRate,
    /// Aerodynamic static margin, fraction of the body length (default 0 to 0.45 by
    /// 0.05, then bisection): the aftmost settling towing point at each, and where
    /// the paper's towing-point rule holds.
    StaticMargin,
}

impl SweepKind {
    fn name(self) -> &'static str {
        match self {
            SweepKind::Speed => "speed",
            SweepKind::Altitude => "altitude",
            SweepKind::TowPoint => "tow-point",
            SweepKind::Cg => "cg",
            SweepKind::PullUpRate => "pull-up-rate",
            SweepKind::StaticMargin => "static-margin",
        }
    }
}

/// `decoy sweep`.
#[derive(Args, Debug)]
pub struct SweepArgs {
    /// What to vary.
    #[arg(value_enum)]
    kind: SweepKind,
    /// First value (Mach number; altitude, m; station, m from the decoy nose).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    from: Option<f64>,
    /// Last value.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    to: Option<f64>,
    /// Increment (> 0).
    #[arg(long, value_name = "DX", allow_negative_numbers = true)]
    step: Option<f64>,
    /// Fixed Mach number (altitude, tow-point, cg; default 0.7).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    mach: Option<f64>,
    /// Fixed altitude, m (speed, tow-point, cg; default 9000).
    #[arg(long, value_name = "H", allow_negative_numbers = true)]
    altitude: Option<f64>,
    /// Cable segments (default: speed and altitude the configuration's host model,
    /// tow-point and cg its embedded model).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    segments: Option<usize>,
    /// Segment length ratio, short at the decoy (1 = uniform; default as --segments).
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    grading: Option<f64>,
    /// A fixed RK4 step of the runs, s (tow-point, cg, pull-up-rate, static-margin; default: the adaptive step rule, docs/outputs.md "Time steps").
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    dt: Option<f64>,
    /// Simulated time of each settling run, s (tow-point, cg; default 10).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    t_end: Option<f64>,
    /// Initial nose-up decoy pitch perturbation, deg (tow-point, cg; default 5).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pitch_offset: Option<f64>,
    /// Settled: half the peak-to-peak pitch in the final window at most this, deg (tow-point, cg; default 0.1).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    threshold: Option<f64>,
    /// The final window judged, s (tow-point, cg; default 2).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    window: Option<f64>,
    /// Bisection tolerance (pull-up-rate: rad/s, default 0.001; static-margin: the
    /// towing-point limit, m, default 0.5 % of the body length).
    #[arg(long, value_name = "TOL", allow_negative_numbers = true)]
    tolerance: Option<f64>,
    /// Pull-up-rate: a run keeps clear when its smallest cable-plume clearance is at
    /// least this, m (default 0).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    margin: Option<f64>,
    /// Output directory (default: out/sweep-KIND).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Do not draw the plots (CSV only).
    #[arg(long)]
    no_plots: bool,
}

/// Which study `decoy study` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StudyKind {
    /// Peak tension and pitch amplitude of the acceleration case against the
    /// segment count, and the choice of the embedded model.
    Discretisation,
}

/// `decoy study`.
#[derive(Args, Debug)]
pub struct StudyArgs {
    /// The study.
    #[arg(value_enum)]
    kind: StudyKind,
    /// Output directory (default: out/study-discretisation).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Do not draw the plots (CSV and Markdown only).
    #[arg(long)]
    no_plots: bool,
}

/// `decoy report`.
#[derive(Args, Debug)]
pub struct ReportArgs {
    /// Directory of the report; the figures go to DIR/figures.
    #[arg(long, value_name = "DIR", default_value = REPORT_DIR)]
    out: PathBuf,
}

/// A flag that the sweep kind does not use is an error.
fn not_for(kind: SweepKind, flag: &str, given: bool, kinds: &str) -> Result<(), Failure> {
    if given {
        Err(usage(format!(
            "{flag} does not apply to `decoy sweep {}` (only {kinds})",
            kind.name()
        )))
    } else {
        Ok(())
    }
}

/// The range of `args`, each bound defaulting to `default`'s.
fn range(args: &SweepArgs, default: SweepRange) -> Result<Vec<f64>, Failure> {
    let range = SweepRange {
        from: args.from.unwrap_or(default.from),
        to: args.to.unwrap_or(default.to),
        step: args.step.unwrap_or(default.step),
    };
    Ok(range.values()?)
}

/// `decoy sweep KIND`.
pub fn sweep_command(
    config: &SystemConfig,
    args: &SweepArgs,
    json: bool,
) -> Result<String, Failure> {
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("sweep-{}", args.kind.name())));
    let settling_flags = [
        ("--dt", args.dt.is_some()),
        ("--t-end", args.t_end.is_some()),
        ("--pitch-offset", args.pitch_offset.is_some()),
        ("--threshold", args.threshold.is_some()),
        ("--window", args.window.is_some()),
    ];
    let search_flags = [
        ("--tolerance", args.tolerance.is_some()),
        ("--margin", args.margin.is_some()),
    ];
    if !matches!(args.kind, SweepKind::PullUpRate | SweepKind::StaticMargin) {
        for (flag, given) in search_flags {
            not_for(args.kind, flag, given, "pull-up-rate, static-margin")?;
        }
    }
    let mut bar = Progress::new("sweeping", json);
    match args.kind {
        SweepKind::Speed | SweepKind::Altitude => {
            let variable = if args.kind == SweepKind::Speed {
                not_for(
                    args.kind,
                    "--mach",
                    args.mach.is_some(),
                    "altitude, tow-point, cg",
                )?;
                SteadyVariable::Speed
            } else {
                not_for(
                    args.kind,
                    "--altitude",
                    args.altitude.is_some(),
                    "speed, tow-point, cg",
                )?;
                SteadyVariable::Altitude
            };
            for (flag, given) in settling_flags {
                not_for(args.kind, flag, given, "tow-point, cg, static-margin")?;
            }
            let (default, mach, altitude) = SteadySweepSpec::paper_range(variable);
            let spec = SteadySweepSpec {
                variable,
                values: range(args, default)?,
                mach: args.mach.unwrap_or(mach),
                altitude_m: args.altitude.unwrap_or(altitude),
                layout: host_layout(config, args.segments, args.grading)?,
            };
            let sweep = steady_sweep(config, &spec, |f| bar.update(f));
            bar.finish();
            let sweep = sweep?;
            let files = write_steady_sweep(&sweep, &out, !args.no_plots)?;
            if json {
                return Ok(to_json(&sweep));
            }
            Ok(steady_text(config, &sweep, &out, &files))
        }
        SweepKind::PullUpRate => {
            for (flag, given) in settling_flags {
                if flag != "--dt" && flag != "--t-end" {
                    not_for(args.kind, flag, given, "tow-point, cg, static-margin")?;
                }
            }
            let mut spec = PullUpSpec::paper(config);
            spec.rates = range(args, PullUpSpec::default_range())?;
            spec.mach = args.mach.unwrap_or(spec.mach);
            spec.altitude_m = args.altitude.unwrap_or(spec.altitude_m);
            if let Some(n) = args.segments {
                spec.segments = n;
                spec.grading = 1.0;
            }
            spec.grading = args.grading.unwrap_or(spec.grading);
            spec.dt = args.dt.or(spec.dt);
            spec.t_end = args.t_end.unwrap_or(spec.t_end);
            spec.tolerance_radps = args.tolerance.unwrap_or(spec.tolerance_radps);
            spec.margin_m = args.margin.unwrap_or(spec.margin_m);
            let sweep = pull_up_sweep(config, &spec, |f| bar.update(f));
            bar.finish();
            let sweep = sweep?;
            let files = write_pull_up_sweep(&sweep, &out, !args.no_plots)?;
            if json {
                return Ok(to_json(&sweep));
            }
            Ok(pull_up_text(config, &sweep, &out, &files))
        }
        SweepKind::StaticMargin => {
            not_for(args.kind, "--margin", args.margin.is_some(), "pull-up-rate")?;
            let mut spec = StaticMarginSpec::paper(config);
            spec.margins = range(args, StaticMarginSpec::default_range())?;
            let settling = &mut spec.settling;
            settling.mach = args.mach.unwrap_or(settling.mach);
            settling.altitude_m = args.altitude.unwrap_or(settling.altitude_m);
            if let Some(n) = args.segments {
                settling.segments = n;
                settling.grading = 1.0;
            }
            settling.grading = args.grading.unwrap_or(settling.grading);
            settling.dt = args.dt.or(settling.dt);
            settling.t_end = args.t_end.unwrap_or(settling.t_end);
            settling.pitch_offset_deg = args.pitch_offset.unwrap_or(settling.pitch_offset_deg);
            settling.threshold_deg = args.threshold.unwrap_or(settling.threshold_deg);
            settling.window_s = args.window.unwrap_or(settling.window_s);
            spec.tolerance_m = args.tolerance.unwrap_or(spec.tolerance_m);
            let sweep = static_margin_sweep(config, &spec, |f| bar.update(f));
            bar.finish();
            let sweep = sweep?;
            let files = write_static_margin_sweep(&sweep, &out, !args.no_plots)?;
            if json {
                return Ok(to_json(&sweep));
            }
            Ok(static_margin_text(config, &sweep, &out, &files))
        }
        SweepKind::TowPoint | SweepKind::Cg => {
            let variable = if args.kind == SweepKind::TowPoint {
                StationVariable::TowPoint
            } else {
                StationVariable::Cg
            };
            let mut spec = SettlingSpec::paper(variable, config);
            spec.values = range(args, SettlingSpec::default_range(variable))?;
            spec.mach = args.mach.unwrap_or(spec.mach);
            spec.altitude_m = args.altitude.unwrap_or(spec.altitude_m);
            if let Some(n) = args.segments {
                spec.segments = n;
                spec.grading = 1.0;
            }
            spec.grading = args.grading.unwrap_or(spec.grading);
            spec.dt = args.dt.or(spec.dt);
            spec.t_end = args.t_end.unwrap_or(spec.t_end);
            spec.pitch_offset_deg = args.pitch_offset.unwrap_or(spec.pitch_offset_deg);
            spec.threshold_deg = args.threshold.unwrap_or(spec.threshold_deg);
            spec.window_s = args.window.unwrap_or(spec.window_s);
            let sweep = settling_sweep(config, &spec, |f| bar.update(f));
            bar.finish();
            let sweep = sweep?;
            let files = write_settling_sweep(&sweep, &out, !args.no_plots)?;
            if json {
                return Ok(to_json(&sweep));
            }
            Ok(settling_text(config, &sweep, &out, &files))
        }
    }
}

fn files_text(s: &mut String, out: &Path, files: &[PathBuf]) {
    let _ = writeln!(s, "Files written to {}:", out.display());
    for file in files {
        let name = file.file_name().map_or_else(
            || file.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        let _ = writeln!(s, "  {name}");
    }
}

fn steady_text(
    config: &SystemConfig,
    sweep: &SteadySweep,
    out: &Path,
    files: &[PathBuf],
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Steady level-flight trims, {} sweep at {} ({}, {})",
        sweep.spec.variable.name(),
        sweep.fixed_condition(),
        sweep.layout,
        config.source
    );
    let _ = writeln!(
        s,
        "{:>6} {:>10} {:>9} {:>12} {:>11} {:>11} {:>10} {:>10} {:>10}",
        "Mach",
        "altitude",
        "speed",
        "T connection",
        "T towing",
        "pitch",
        "CG behind",
        "CG below",
        "to plume"
    );
    let _ = writeln!(
        s,
        "{:>6} {:>10} {:>9} {:>12} {:>11} {:>11} {:>10} {:>10} {:>10}",
        "", "[m]", "[m/s]", "[N]", "[N]", "[deg]", "[m]", "[m]", "[m]"
    );
    for p in &sweep.points {
        let _ = writeln!(
            s,
            "{:>6.3} {:>10.0} {:>9.2} {:>12.3} {:>11.3} {:>11.4} {:>10.3} {:>10.3} {:>10.3}",
            p.mach,
            p.altitude_m,
            p.speed_mps,
            p.tension_connection_n,
            p.tension_tow_n,
            p.decoy_pitch_deg,
            p.decoy_cg_behind_m,
            p.decoy_cg_below_m,
            p.cable_plume_clearance_m
        );
    }
    files_text(&mut s, out, files);
    s
}

fn settling_text(
    config: &SystemConfig,
    sweep: &SettlingSweep,
    out: &Path,
    files: &[PathBuf],
) -> String {
    let spec = &sweep.spec;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Decoy settling, {} sweep of {} ({} fixed at {} m), Mach {} at {} m ({})",
        spec.variable.name(),
        spec.variable.key(),
        match spec.variable {
            StationVariable::TowPoint => "decoy.x_cg",
            StationVariable::Cg => "decoy.x_tow",
        },
        sweep.fixed_station_m,
        spec.mach,
        spec.altitude_m,
        config.source
    );
    let _ = writeln!(
        s,
        "  from trim (the straight cable where none) with the decoy pitched {:+} deg; {} segments graded {}, {}, {} s;",
        spec.pitch_offset_deg,
        spec.segments,
        spec.grading,
        describe_steps(spec.dt),
        spec.t_end
    );
    let _ = writeln!(
        s,
        "  settled: half the peak-to-peak pitch in the last {} s at most {} deg",
        spec.window_s, spec.threshold_deg
    );
    let _ = writeln!(
        s,
        "{:>8} {:>8} {:>5} {:>11} {:>11} {:>8} {:>10} {:>11} {:>10}",
        "x_tow",
        "x_cg",
        "trim",
        "trim pitch",
        "trim T",
        "settled",
        "settling",
        "final ampl",
        "diverged"
    );
    let _ = writeln!(
        s,
        "{:>8} {:>8} {:>5} {:>11} {:>11} {:>8} {:>10} {:>11} {:>10}",
        "[m]", "[m]", "", "[deg]", "[N]", "", "[s]", "[deg]", "at [s]"
    );
    let opt = |v: Option<f64>, d: usize| v.map_or("-".to_owned(), |v| format!("{v:.d$}"));
    for p in &sweep.points {
        let _ = writeln!(
            s,
            "{:>8.3} {:>8.3} {:>5} {:>11} {:>11} {:>8} {:>10} {:>11.4} {:>10}",
            p.x_tow_m,
            p.x_cg_m,
            if p.trim_exists { "yes" } else { "no" },
            opt(p.trim_pitch_deg, 3),
            opt(p.trim_tension_connection_n, 2),
            if p.settling.settled { "yes" } else { "NO" },
            opt(p.settling.settling_time_s, 3),
            p.settling.final_amplitude_deg,
            opt(p.stopped_s, 3)
        );
    }
    files_text(&mut s, out, files);
    s
}

fn pull_up_text(
    config: &SystemConfig,
    sweep: &PullUpSweep,
    out: &Path,
    files: &[PathBuf],
) -> String {
    let spec = &sweep.spec;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Pull-up rate limit for the exhaust plume: {} ({})",
        sweep.condition(),
        config.source
    );
    let _ = writeln!(
        s,
        "  level to t = 2 s, the flight path rotating up for 5 s, then the climb held; {} segments graded {}, {}, {} s;",
        spec.segments,
        spec.grading,
        describe_steps(spec.dt),
        spec.t_end
    );
    let _ = writeln!(
        s,
        "  clear: the smallest cable-plume clearance over the run at least {} m; bisection to {} rad/s",
        spec.margin_m, spec.tolerance_radps
    );
    let _ = writeln!(
        s,
        "{:>8} {:>6} {:>11} {:>8} {:>8} {:>10} {:>10} {:>10}",
        "rate", "clear", "clearance", "at t", "along", "peak T", "min depth", "diverged"
    );
    let _ = writeln!(
        s,
        "{:>8} {:>6} {:>11} {:>8} {:>8} {:>10} {:>10} {:>10}",
        "[rad/s]", "", "[m]", "[s]", "[m]", "[N]", "[m]", "at [s]"
    );
    for p in &sweep.points {
        let _ = writeln!(
            s,
            "{:>8.4} {:>6} {:>11.3} {:>8.3} {:>8.2} {:>10.1} {:>10.2} {:>10}{}",
            p.rate_radps,
            if p.clear { "yes" } else { "NO" },
            p.min_clearance_m,
            p.t_at_min_clearance_s,
            p.along_at_min_clearance_m,
            p.max_tension_connection_n,
            p.min_decoy_depth_m,
            p.stopped_s.map_or("-".to_owned(), |t| format!("{t:.3}")),
            if p.bisection { "  (bisection)" } else { "" }
        );
    }
    let _ = writeln!(
        s,
        "Largest rate keeping the cable out of the plume: {}",
        sweep.describe_limit()
    );
    files_text(&mut s, out, files);
    s
}

fn static_margin_text(
    config: &SystemConfig,
    sweep: &StaticMarginSweep,
    out: &Path,
    files: &[PathBuf],
) -> String {
    let spec = &sweep.spec.settling;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Towing-point rule against the aerodynamic static margin: x_cg = {} m, body {} m, Mach {} at {} m ({}; its own margin {:.1} %)",
        sweep.x_cg_m,
        sweep.length_m,
        spec.mach,
        spec.altitude_m,
        config.source,
        100.0 * sweep.configured_margin
    );
    let _ = writeln!(
        s,
        "  the band of towing points that settle from a {:+} deg pitch ({} segments graded {}, {}, {} s; settled: half the peak-to-peak pitch in the last {} s at most {} deg)",
        spec.pitch_offset_deg,
        spec.segments,
        spec.grading,
        describe_steps(spec.dt),
        spec.t_end,
        spec.window_s,
        spec.threshold_deg
    );
    let _ = writeln!(
        s,
        "{:>8} {:>8} {:>8} {:>9} {:>9} {:>9} {:>9} {:>12} {:>10} {:>5}",
        "margin",
        "x_cp",
        "x_mrp",
        "fwd x_tow",
        "aft x_tow",
        "fwd - cg",
        "aft - cg",
        "ahead of CG",
        "5-20 % ok",
        "runs"
    );
    let _ = writeln!(
        s,
        "{:>8} {:>8} {:>8} {:>9} {:>9} {:>9} {:>9} {:>12} {:>10} {:>5}",
        "[% L]", "[m]", "[m]", "[m]", "[m]", "[% L]", "[% L]", "", "", ""
    );
    let m = |v: Option<f64>| v.map_or("none".to_owned(), |x| format!("{x:.4}"));
    let pct = |v: Option<f64>| v.map_or("-".to_owned(), |d| format!("{:+.2}", 100.0 * d));
    let yes = |b: bool| if b { "yes" } else { "no" };
    for p in &sweep.points {
        let _ = writeln!(
            s,
            "{:>8.2} {:>8.4} {:>8.4} {:>9} {:>9} {:>9} {:>9} {:>12} {:>10} {:>5}{}",
            100.0 * p.static_margin,
            p.x_cp_m,
            p.x_mrp_m,
            m(p.x_tow_forward_m),
            m(p.x_tow_aft_m),
            pct(p.forward_offset),
            pct(p.aft_offset),
            yes(p.must_be_ahead),
            yes(p.rule_band_settles),
            p.runs,
            if p.bisection { "  (bisection)" } else { "" }
        );
    }
    let _ = writeln!(
        s,
        "The towing point must be ahead of the CG (the aft limit within 5 % of it) below a static margin of {}",
        sweep.describe_boundary()
    );
    files_text(&mut s, out, files);
    s
}

/// `decoy study discretisation`.
pub fn study_command(
    config: &SystemConfig,
    args: &StudyArgs,
    json: bool,
) -> Result<String, Failure> {
    let StudyKind::Discretisation = args.kind;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join("study-discretisation"));
    let spec = StudySpec::default_for(config);
    let mut bar = Progress::new("studying", json);
    let study = discretisation_study(config, &spec, |f| bar.update(f));
    bar.finish();
    let study = study?;
    let files = write_study(&study, &out, !args.no_plots)?;
    if json {
        return Ok(to_json(&study));
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Discretisation study: acceleration case (Mach 0.6 to 0.8 at 10 m/s^2 from t = 2 s, 9 km, 25 s), {}",
        config.source
    );
    let _ = writeln!(
        s,
        "  each run starts at dt = {} s and halves it after a divergence (at most {} times)",
        spec.dt, spec.max_halvings
    );
    let _ = writeln!(
        s,
        "{:>12} {:>9} {:>10} {:>10} {:>12} {:>9} {:>11} {:>11}",
        "model", "segments", "l_min", "dt", "peak T", "at t", "pitch ampl", "final T"
    );
    let _ = writeln!(
        s,
        "{:>12} {:>9} {:>10} {:>10} {:>12} {:>9} {:>11} {:>11}",
        "", "", "[m]", "[s]", "[N]", "[s]", "[deg]", "[N]"
    );
    for r in &study.rows {
        let _ = writeln!(
            s,
            "{:>12} {:>9} {:>10.4} {:>10} {:>12.3} {:>9.3} {:>11.4} {:>11.3}{}",
            r.family,
            r.segments,
            r.shortest_segment_m,
            r.dt_s,
            r.max_tension_connection_n,
            r.t_at_max_tension_s,
            r.pitch_amplitude_deg,
            r.final_tension_connection_n,
            if r.stopped.is_some() {
                "  diverged"
            } else {
                ""
            }
        );
    }
    let _ = writeln!(s, "\nEmbedded model");
    let _ = writeln!(
        s,
        "{}",
        study.embedded.justification(study.configured_embedded)
    );
    files_text(&mut s, &out, &files);
    Ok(s)
}

/// `decoy report`'s JSON.
#[derive(Serialize)]
struct ReportJson {
    report: PathBuf,
    files: Vec<PathBuf>,
    embedded_choice: String,
    claims: Vec<ClaimJson>,
}

#[derive(Serialize)]
struct ClaimJson {
    claim: String,
    paper: String,
    ours: String,
    reproduced: &'static str,
}

/// `decoy report`.
pub fn report_command(
    config: &SystemConfig,
    args: &ReportArgs,
    config_path: Option<&Path>,
    json: bool,
) -> Result<String, Failure> {
    let mut command = REPORT_COMMAND.to_owned();
    if let Some(path) = config_path {
        let _ = write!(command, " --config {}", path.display());
    }
    if args.out != Path::new(REPORT_DIR) {
        let _ = write!(command, " --out {}", args.out.display());
    }
    if args.out.as_os_str().is_empty() {
        return Err(usage("--out must name a directory"));
    }
    let options = ReportOptions {
        out_dir: args.out.clone(),
        command,
    };
    let mut bar = Progress::new("reporting", json);
    let output = write_report(config, &options, |f| bar.update(f));
    bar.finish();
    let output = output?;
    let verdict = |v: Verdict| match v {
        Verdict::Agrees => "yes",
        Verdict::Partly => "partly",
        Verdict::Disagrees => "no",
    };
    if json {
        return Ok(to_json(&ReportJson {
            report: output.report.clone(),
            files: output.files.clone(),
            embedded_choice: output.embedded_choice.clone(),
            claims: output
                .claims
                .iter()
                .map(|c| ClaimJson {
                    claim: c.claim.clone(),
                    paper: c.paper.clone(),
                    ours: c.ours.clone(),
                    reproduced: verdict(c.verdict),
                })
                .collect(),
        }));
    }
    let bytes: u64 = output
        .files
        .iter()
        .filter_map(|f| std::fs::metadata(f).ok())
        .map(|m| m.len())
        .sum();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Wrote {} and {} figure files ({:.1} MB in all)",
        output.report.display(),
        output.files.len() - 1,
        bytes as f64 / 1e6
    );
    let _ = writeln!(s, "Embedded model chosen: {}", output.embedded_choice);
    let _ = writeln!(s, "Claims of the paper (reproduced?):");
    for c in &output.claims {
        let _ = writeln!(s, "  [{:>6}] {}", verdict(c.verdict), c.claim);
    }
    Ok(s)
}
