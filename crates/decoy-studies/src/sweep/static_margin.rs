//! [`static_margin_sweep`]: where the paper's towing-point rule holds
//! (`decoy sweep static-margin`).
//!
//! The paper's rule: the towing point must be ahead of the decoy's CG (by 5 % of
//! the body length; at most 20 %) for the decoy to settle. Whether it holds depends
//! on how stiff the decoy is aerodynamically: a decoy whose centre of pressure
//! lies far behind its CG is held by its own aerodynamic moment and settles with
//! the towing point well behind the CG; a weakly stable one relies on the cable's
//! pull, which stabilises only with the towing point ahead of the CG.
//!
//! The *aerodynamic static margin* h is the distance of the centre of pressure
//! behind the CG as a fraction of the body length L: `h = (x_cp - x_cg) / L`, with
//! `x_cp = x_mrp - L Cm / CN` at the aero table's first angle above 0 (CN = CL cos
//! a + CD sin a). The study changes h by moving `decoy.x_mrp` (the same forces and
//! moments, shifted along the body), everything else as configured.
//!
//! For each margin it finds the band of towing points at which the decoy settles,
//! at the configured CG, with the settling run of `decoy sweep tow-point` (steady
//! level flight, the decoy pitched +5 deg about its towing point, settled when
//! half the peak-to-peak pitch in the last 2 s is at most 0.1 deg): the stations
//! of a grid from the nose to the tail (every 5 % of the body length), then, about
//! the settled station nearest the CG, the forward and aft ends of its run of
//! settled stations by bisection to the tolerance. A weakly stable decoy has two
//! limits: towed too far aft it diverges (the paper's limit), towed too far
//! forward it flies like a kite and oscillates with growing amplitude.
//!
//! The aft limit's offset from the CG, `d = (x_aft - x_cg) / L`, tells whether the
//! paper's rule holds: it does when `|d| <= 0.05` (the towing point must be ahead
//! of the CG, give or take the rule's 5 %: the CG is where stability ends); a
//! stiff decoy settles towed far behind its CG (`d > 0.05`), and the rule is then
//! not needed. The *boundary margin* is where `d` crosses 0.05, bisected 4 times
//! between the grid margins that bracket it (reported linearly interpolated
//! between the closest margins on either side).

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_plots::{Plot, Series};
use serde::Serialize;

use decoy_sim::error::SimError;
use decoy_sim::format::format_value;

use super::{
    SettlingSpec, StationVariable, SweepRange, cli_invalid, plot, settling_sweep, trim_number,
    write_sweep,
};

/// The rule's smallest recommended distance of the towing point ahead of the CG,
/// fraction of the body length.
pub const RULE_MIN_AHEAD: f64 = 0.05;
/// The rule's largest recommended distance, fraction of the body length.
pub const RULE_MAX_AHEAD: f64 = 0.20;
/// Bisection steps on the boundary margin.
const MARGIN_BISECTIONS: usize = 4;
/// The grid of towing points, fraction of the body length.
const GRID_FRACTION: f64 = 0.05;

/// The distance of the centre of pressure behind the moment reference point, m,
/// at the aero table's first angle above 0 (`-L Cm / CN`).
pub fn centre_of_pressure_offset(config: &SystemConfig) -> Result<f64, SimError> {
    let row = config
        .aero_rows
        .iter()
        .find(|r| r.alpha_deg > 0.0)
        .ok_or_else(|| {
            SimError::invalid(
                &config.source,
                "decoy.aero_table",
                "has no angle of attack above 0, so no centre of pressure".to_owned(),
            )
        })?;
    let a = row.alpha_deg.to_radians();
    let cn = row.cl * a.cos() + row.cd * a.sin();
    if cn.abs() < 1e-12 {
        return Err(SimError::invalid(
            &config.source,
            "decoy.aero_table",
            format!(
                "has no normal force at {} deg, so no centre of pressure",
                row.alpha_deg
            ),
        ));
    }
    Ok(-config.decoy.length * row.cm / cn)
}

/// The decoy's aerodynamic static margin, fraction of the body length (centre of
/// pressure behind the CG; see the module docs).
pub fn static_margin(config: &SystemConfig) -> Result<f64, SimError> {
    let d = &config.decoy;
    Ok((d.x_mrp + centre_of_pressure_offset(config)? - d.x_cg) / d.length)
}

/// `config` with its moment reference point moved so that the static margin is
/// `margin`. Errors: the reference point would leave the body.
pub fn with_static_margin(config: &SystemConfig, margin: f64) -> Result<SystemConfig, SimError> {
    let mut c = config.clone();
    let d = &mut c.decoy;
    let x_mrp = d.x_cg + margin * d.length - centre_of_pressure_offset(config)?;
    if !(0.0..=d.length).contains(&x_mrp) {
        return Err(cli_invalid(
            "--from",
            format!(
                "a static margin of {margin} needs decoy.x_mrp = {x_mrp:.4} m, off the body (0 to {} m)",
                d.length
            ),
        ));
    }
    d.x_mrp = x_mrp;
    Ok(c)
}

/// A static-margin study to run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StaticMarginSpec {
    /// The static margins, fraction of the body length, increasing.
    pub margins: Vec<f64>,
    /// The settling run and its classification (its `values` are unused).
    pub settling: SettlingSpec,
    /// The towing-point bisection stops when its bracket is at most this, m.
    pub tolerance_m: f64,
    /// Bisection steps on the boundary margin (between the grid margins that
    /// bracket it).
    pub boundary_bisections: usize,
}

impl StaticMarginSpec {
    /// The default study: margins 0 to 0.4 by 0.1 (the reference decoy's is
    /// 0.41), the settling runs of `decoy sweep tow-point`, tolerance 1 % of the
    /// body length.
    pub fn paper(config: &SystemConfig) -> Self {
        StaticMarginSpec {
            margins: Self::default_range().values().unwrap_or_default(),
            settling: SettlingSpec::paper(StationVariable::TowPoint, config),
            tolerance_m: 0.01 * config.decoy.length,
            boundary_bisections: MARGIN_BISECTIONS,
        }
    }

    /// The default margins.
    pub fn default_range() -> SweepRange {
        SweepRange {
            from: 0.0,
            to: 0.4,
            step: 0.1,
        }
    }
}

/// One static margin of the study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MarginPoint {
    /// Static margin, fraction of the body length.
    pub static_margin: f64,
    /// Flown by the bisection of the boundary (not on the grid).
    pub bisection: bool,
    /// Centre of pressure, m from the nose.
    pub x_cp_m: f64,
    /// The moment reference point that gives this margin, m from the nose.
    pub x_mrp_m: f64,
    /// The foremost towing point of the settled band, m from the nose (within the
    /// tolerance; 0: the nose); `null` when no station of the grid settles.
    pub x_tow_forward_m: Option<f64>,
    /// The aftmost towing point of the settled band, m from the nose.
    pub x_tow_aft_m: Option<f64>,
    /// `(x_tow_forward - x_cg) / L` (negative: ahead of the CG).
    pub forward_offset: Option<f64>,
    /// `(x_tow_aft - x_cg) / L` (positive: the decoy settles towed behind its CG).
    pub aft_offset: Option<f64>,
    /// The rule's "ahead of the CG" holds: `|aft_offset| <= 0.05`.
    pub must_be_ahead: bool,
    /// Every towing point 5 to 20 % of the body length ahead of the CG settles.
    pub rule_band_settles: bool,
    /// Settling runs flown for this margin.
    pub runs: usize,
}

/// The result of a static-margin study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StaticMarginSweep {
    /// What was run.
    pub spec: StaticMarginSpec,
    /// The configured CG, m from the nose.
    pub x_cg_m: f64,
    /// Body length, m.
    pub length_m: f64,
    /// The configured decoy's own static margin.
    pub configured_margin: f64,
    /// Every margin, grid and bisection, increasing.
    pub points: Vec<MarginPoint>,
    /// The margin at which the limit crosses the CG (linear between the two
    /// closest margins that bracket it), `null` when the grid does not bracket it.
    pub boundary_margin: Option<f64>,
}

impl StaticMarginSweep {
    /// The largest margin whose aft limit is within the rule's 5 % of the CG (or
    /// ahead) and the smallest larger one whose aft limit is farther behind.
    pub fn bracket(&self) -> Option<(f64, f64)> {
        let below = self
            .points
            .iter()
            .filter(|p| p.aft_offset.is_some_and(|d| d <= RULE_MIN_AHEAD))
            .map(|p| p.static_margin)
            .fold(f64::NEG_INFINITY, f64::max);
        let above = self
            .points
            .iter()
            .filter(|p| p.aft_offset.is_some_and(|d| d > RULE_MIN_AHEAD) && p.static_margin > below)
            .map(|p| p.static_margin)
            .fold(f64::INFINITY, f64::min);
        (below.is_finite() && above.is_finite()).then_some((below, above))
    }
}

/// Runs the study (see the module docs); `progress` gets the fraction done.
/// Errors: bad inputs (naming the flags), a margin that would put the moment
/// reference point off the body, an unusable configuration.
pub fn static_margin_sweep(
    config: &SystemConfig,
    spec: &StaticMarginSpec,
    mut progress: impl FnMut(f64),
) -> Result<StaticMarginSweep, SimError> {
    if spec.margins.is_empty() {
        return Err(cli_invalid("--from", "the study has no margin".to_owned()));
    }
    if !(spec.tolerance_m.is_finite() && spec.tolerance_m > 0.0) {
        return Err(cli_invalid(
            "--tolerance",
            format!("must be a positive distance, got {}", spec.tolerance_m),
        ));
    }
    let mut check = spec.settling.clone();
    check.values = vec![config.decoy.x_tow];
    check.check(config)?;
    let configured_margin = static_margin(config)?;
    let length = config.decoy.length;
    let step = GRID_FRACTION * length;
    let stations: Vec<f64> = (0..=((length / step).round() as usize))
        .map(|k| super::round9((k as f64 * step).min(length)))
        .collect();
    let per_margin = stations.len() as f64 + 2.0 * (step / spec.tolerance_m).max(1.0).log2().ceil();
    let total = (spec.margins.len() + spec.boundary_bisections) as f64 * per_margin;
    let mut runs_done = 0usize;
    let x_cg = config.decoy.x_cg;
    let mut evaluate = |margin: f64, bisection: bool| -> Result<MarginPoint, SimError> {
        let c = with_static_margin(config, margin)?;
        let mut runs = 0usize;
        let mut settles = |x_tow: f64| -> Result<bool, SimError> {
            let mut s = spec.settling.clone();
            s.values = vec![x_tow];
            let base = runs_done as f64 / total;
            let sweep = settling_sweep(&c, &s, |f| progress((base + f / total).min(1.0)))
                .map_err(|e| e.at(format!("static margin {margin}")))?;
            runs += 1;
            runs_done += 1;
            Ok(sweep.points[0].settling.settled)
        };
        let mut settled = Vec::with_capacity(stations.len());
        for &x in &stations {
            settled.push(settles(x)?);
        }
        // The settled station nearest the CG, and its run of settled stations.
        let seed = (0..stations.len())
            .filter(|&k| settled[k])
            .min_by(|&a, &b| {
                (stations[a] - x_cg)
                    .abs()
                    .total_cmp(&(stations[b] - x_cg).abs())
            });
        let (forward, aft) = match seed {
            None => (None, None),
            Some(k) => {
                let mut first = k;
                while first > 0 && settled[first - 1] {
                    first -= 1;
                }
                let mut last = k;
                while last + 1 < stations.len() && settled[last + 1] {
                    last += 1;
                }
                let mut bisect = |mut good: f64, mut bad: f64| -> Result<f64, SimError> {
                    while (bad - good).abs() > spec.tolerance_m {
                        let mid = super::round9(0.5 * (good + bad));
                        if settles(mid)? {
                            good = mid;
                        } else {
                            bad = mid;
                        }
                    }
                    Ok(good)
                };
                let forward = if first == 0 {
                    stations[0]
                } else {
                    bisect(stations[first], stations[first - 1])?
                };
                let aft = if last + 1 == stations.len() {
                    stations[last]
                } else {
                    bisect(stations[last], stations[last + 1])?
                };
                (Some(forward), Some(aft))
            }
        };
        let offset = |x: Option<f64>| x.map(|x| (x - x_cg) / length);
        let (forward_offset, aft_offset) = (offset(forward), offset(aft));
        Ok(MarginPoint {
            static_margin: margin,
            bisection,
            x_cp_m: c.decoy.x_cg + margin * length,
            x_mrp_m: c.decoy.x_mrp,
            x_tow_forward_m: forward,
            x_tow_aft_m: aft,
            forward_offset,
            aft_offset,
            must_be_ahead: aft_offset.is_some_and(|d| d.abs() <= RULE_MIN_AHEAD),
            rule_band_settles: forward_offset.is_some_and(|d| d <= -RULE_MAX_AHEAD)
                && aft_offset.is_some_and(|d| d >= -RULE_MIN_AHEAD),
            runs,
        })
    };
    let mut margins = spec.margins.clone();
    margins.sort_by(f64::total_cmp);
    margins.dedup();
    let mut points = Vec::new();
    for &m in &margins {
        points.push(evaluate(m, false)?);
    }
    // Bisect where the aft limit leaves the rule's 5 % behind the CG, between
    // the bracketing grid margins.
    let beyond = |p: &MarginPoint| p.aft_offset.is_some_and(|d| d > RULE_MIN_AHEAD);
    let crossing = points
        .windows(2)
        .position(|w| w[0].aft_offset.is_some() && !beyond(&w[0]) && beyond(&w[1]));
    if let Some(k) = crossing {
        let (mut lo, mut hi) = (points[k].static_margin, points[k + 1].static_margin);
        for _ in 0..spec.boundary_bisections {
            let mid = super::round9(0.5 * (lo + hi));
            let p = evaluate(mid, true)?;
            if beyond(&p) {
                hi = mid;
            } else {
                lo = mid;
            }
            points.push(p);
        }
    }
    points.sort_by(|a, b| a.static_margin.total_cmp(&b.static_margin));
    let sweep = StaticMarginSweep {
        spec: spec.clone(),
        x_cg_m: config.decoy.x_cg,
        length_m: length,
        configured_margin,
        boundary_margin: None,
        points,
    };
    let boundary_margin = sweep.bracket().map(|(lo, hi)| {
        let offset = |m: f64| {
            sweep
                .points
                .iter()
                .find(|p| p.static_margin == m)
                .and_then(|p| p.aft_offset)
                .unwrap_or(RULE_MIN_AHEAD)
        };
        let (d0, d1) = (offset(lo), offset(hi));
        if d1 > d0 {
            lo + (hi - lo) * (RULE_MIN_AHEAD - d0) / (d1 - d0)
        } else {
            0.5 * (lo + hi)
        }
    });
    progress(1.0);
    Ok(StaticMarginSweep {
        boundary_margin,
        ..sweep
    })
}

/// The header of a static-margin study's `sweep.csv`.
pub const STATIC_MARGIN_HEADER: &str = "static_margin,bisection,x_cp_m,x_mrp_m,x_tow_forward_m,x_tow_aft_m,forward_offset,aft_offset,must_be_ahead,rule_band_settles,runs";

impl StaticMarginSweep {
    /// `sweep.csv`'s text (empty fields: no settling towing point).
    pub fn table_csv(&self) -> String {
        let opt = |v: Option<f64>| v.map(format_value).unwrap_or_default();
        let mut s = format!("{STATIC_MARGIN_HEADER}\n");
        for p in &self.points {
            s.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{},{}\n",
                format_value(p.static_margin),
                p.bisection,
                format_value(p.x_cp_m),
                format_value(p.x_mrp_m),
                opt(p.x_tow_forward_m),
                opt(p.x_tow_aft_m),
                opt(p.forward_offset),
                opt(p.aft_offset),
                p.must_be_ahead,
                p.rule_band_settles,
                p.runs
            ));
        }
        s
    }

    /// The boundary in words.
    pub fn describe_boundary(&self) -> String {
        match (self.boundary_margin, self.bracket()) {
            (Some(b), Some((lo, hi))) => format!(
                "{:.1} % of the body length (the aft limit is within 5 % of the CG at {:.1} %, farther behind at {:.1} %)",
                100.0 * b,
                100.0 * lo,
                100.0 * hi
            ),
            _ => "not bracketed by the margins flown".to_owned(),
        }
    }

    /// The plot: the settled band's limits (offsets from the CG) against the
    /// margin, with the CG and the rule's 5 % and 20 %.
    pub fn plots(&self) -> Vec<(&'static str, Vec<Plot>)> {
        let x: Vec<f64> = self
            .points
            .iter()
            .map(|p| 100.0 * p.static_margin)
            .collect();
        let flat = |label: String, v: f64| Series {
            label,
            x: x.clone(),
            y: vec![v; x.len()],
        };
        let pct = |v: Option<f64>| v.map_or(f64::NAN, |d| 100.0 * d);
        let limit = plot(
            format!(
                "Settled band of towing points against the aerodynamic static margin (x_cg = {} m, Mach {}, {} km)",
                trim_number(self.x_cg_m, 3),
                trim_number(self.spec.settling.mach, 3),
                trim_number(self.spec.settling.altitude_m / 1000.0, 3)
            ),
            "static margin (centre of pressure behind the CG) [% of body length]",
            "towing point behind the CG [% of body length]",
            vec![
                Series {
                    label: "aft limit".into(),
                    x: x.clone(),
                    y: self.points.iter().map(|p| pct(p.aft_offset)).collect(),
                },
                Series {
                    label: "forward limit".into(),
                    x: x.clone(),
                    y: self.points.iter().map(|p| pct(p.forward_offset)).collect(),
                },
                flat("CG".into(), 0.0),
                flat(
                    format!(
                        "the rule's {} % ahead",
                        trim_number(100.0 * RULE_MIN_AHEAD, 1)
                    ),
                    -100.0 * RULE_MIN_AHEAD,
                ),
                flat(
                    format!(
                        "the rule's {} % ahead",
                        trim_number(100.0 * RULE_MAX_AHEAD, 1)
                    ),
                    -100.0 * RULE_MAX_AHEAD,
                ),
            ],
        );
        vec![("limit", vec![limit])]
    }
}

/// Writes `sweep.csv` and (with `plots`) the plot of `sweep` into `dir`; returns
/// the files written.
pub fn write_static_margin_sweep(
    sweep: &StaticMarginSweep,
    dir: &Path,
    plots: bool,
) -> Result<Vec<PathBuf>, SimError> {
    write_sweep(
        dir,
        &[("sweep.csv", sweep.table_csv())],
        plots.then(|| sweep.plots()),
    )
}
