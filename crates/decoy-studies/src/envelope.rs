//! The manoeuvre envelope map (`decoy envelope`): for every flight condition
//! of a grid of altitude x Mach, the largest pull-up or turn rate, or the
//! largest along-path acceleration, that violates none of the four
//! requirements over the manoeuvre and its aftermath, the requirement that
//! sets it, and the cell's steady-flight margins.
//!
//! **A cell.** Its steady margins are the management's worst margins over 1 s
//! of steady level flight from the trim. Its limit is found by bisection on the
//! rate between 0 and the cap the declared operating envelope allows there
//! (`[envelope]`: the normal load factor's upper bound, n = 1 + V w / g at the
//! pull-up's bottom and n = sqrt(1 + (V w / g)^2) in the turn, and the body rate
//! bound), to [`EnvelopeSpec::tolerance`]: each trial is the shipped scenario
//! (`pull-up`: 5 s of rotation from t = 2 s, then the climb, 20 s; `turn`: from
//! t = 0, 20 s) flown at the cell's altitude and Mach with the trial rate,
//! built over the onset ([`decoy_sim::flyable`]), on the spec's model, and it
//! violates a requirement when the management monitors (the same as
//! `decoy simulate`'s `management` summary) report it violated at any row. The
//! limit is the largest rate found clear; the limiting requirement the one
//! violated first at the smallest rate found violating (or the cap, `load
//! factor` or `body rate`, when the capped rate is clear; or the requirement
//! violated in steady flight, limit 0, when the cell is not clear even there).
//!
//! **Resumable and deterministic.** Each cell's result is written atomically to
//! `cells/` in the output directory as soon as it is known, beside
//! `inputs.json` (the configuration and the spec); a run into a directory that
//! holds a map of the same inputs takes the cells it finds and computes the
//! rest, and one of other inputs is an error. Cells are independent and their
//! results are put in grid order, so the map is the same bits whatever the
//! number of workers or the order they finish in.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use decoy_config::{AeroRow, LimitsFile, SystemConfig};
use decoy_plots::atomic::write_atomically;
use decoy_plots::{HeatMap, write_heatmap};
pub use decoy_schema::Manoeuvre;
use decoy_schema::{PerRequirement, Requirement};
use decoy_sim::{InitialState, RunOptions, Scenario, SimError, describe_layout, simulate_recorded};
use serde::{Deserialize, Serialize};
use solver_core::SegmentLayout;

/// Simulated time of a cell's steady-flight run, s.
const STEADY_S: f64 = 1.0;

/// Flight after an acceleration reached its final speed, s (the shipped
/// acceleration flies 17 s after it).
pub const AFTERMATH_S: f64 = 15.0;

/// The acceleration map's default Mach gain: each cell accelerates by 0.1.
pub const DEFAULT_MACH_GAIN: f64 = 0.1;

/// What to map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EnvelopeSpec {
    /// `pull-up`, `turn` or `acceleration`.
    pub manoeuvre: Manoeuvre,
    /// The grid's altitudes, m.
    pub altitudes_m: Vec<f64>,
    /// The grid's Mach numbers.
    pub machs: Vec<f64>,
    /// Cable segments of the model.
    pub segments: usize,
    /// Segment length ratio, short at the decoy (1: uniform).
    pub grading: f64,
    /// Time over which the rate is built (and the pull-up's removed), s.
    pub onset_s: f64,
    /// Bisection tolerance on the rate, rad/s (on the acceleration, m/s^2).
    pub tolerance: f64,
    /// The acceleration's gain in Mach number from the cell's (acceleration
    /// only; to the envelope's largest Mach at the cell's altitude at most).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mach_gain: Option<f64>,
}

/// What limits a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Limit {
    /// A requirement is violated just above the limit.
    Requirement(Requirement),
    /// The envelope's load factor caps the rate, and the cap is clear.
    LoadFactor,
    /// The envelope's body rate bound caps the rate, and the cap is clear.
    BodyRate,
    /// The envelope's along-path acceleration bound caps the acceleration,
    /// and the cap is clear.
    AccelerationBound,
}

impl Limit {
    /// One letter: the requirement's initial (`P`, `C`, `T`, `E`), `n` (load
    /// factor), `w` (body rate) or `a` (acceleration bound).
    pub fn mark(&self) -> &'static str {
        match self {
            Limit::Requirement(Requirement::Posture) => "P",
            Limit::Requirement(Requirement::Collision) => "C",
            Limit::Requirement(Requirement::Tension) => "T",
            Limit::Requirement(Requirement::Exhaust) => "E",
            Limit::LoadFactor => "n",
            Limit::BodyRate => "w",
            Limit::AccelerationBound => "a",
        }
    }

    /// In words: the requirement's name, `load factor`, `body rate` or
    /// `acceleration bound`.
    pub fn name(&self) -> &'static str {
        match self {
            Limit::Requirement(r) => r.name(),
            Limit::LoadFactor => "load factor",
            Limit::BodyRate => "body rate",
            Limit::AccelerationBound => "acceleration bound",
        }
    }
}

/// One cell of the map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// Altitude, m.
    pub altitude_m: f64,
    /// Mach number.
    pub mach: f64,
    /// The largest rate found clear, rad/s (acceleration, m/s^2).
    pub limit: f64,
    /// The rate the envelope's load factor and body rate allow here, rad/s
    /// (the acceleration its bound allows, m/s^2).
    pub cap: f64,
    /// What sets the limit.
    pub limiting: Limit,
    /// The limiting requirement's worst margin at the limit (in its file
    /// unit); None when the cap limits.
    pub margin: Option<f64>,
    /// Each requirement's worst margin in steady flight (file units).
    pub steady_margins: PerRequirement<Option<f64>>,
    /// Runs flown for the cell.
    pub runs: u32,
    /// The onboard controller's advisory lead on the limiting requirement at
    /// the smallest rate found violating it, s (first violation - first
    /// advisory; negative: late); None when no run violated it, or it was
    /// violated unadvised ([`Cell::advised`]).
    #[serde(default)]
    pub advisory_lead_s: Option<f64>,
    /// Whether that violation was advised at all (None: no run violated a
    /// requirement).
    #[serde(default)]
    pub advised: Option<bool>,
    /// Runs of the cell that stayed clear of every requirement but in which
    /// the controller advised against one (steady flight included).
    #[serde(default)]
    pub advised_clear_runs: u32,
    /// Of those, the runs whose first advisory was false: the manoeuvre
    /// continued (held) to the horizon's end stays clear of every requirement
    /// ("continuing this manoeuvre violates R within the horizon" did not
    /// come true; one more run each).
    #[serde(default)]
    pub false_advisories: u32,
    /// Of those, the runs in which the advised requirement, the manoeuvre
    /// continued, does not even reach its warning level (the advisory line's
    /// own threshold): nuisance advisories. The others are near misses.
    #[serde(default)]
    pub nuisance_advisories: u32,
    /// Runs of the cell that stayed clear of every requirement.
    #[serde(default)]
    pub clear_runs: u32,
    /// Whether the cell's flight condition is inside the declared envelope
    /// (`[envelope]`: its altitude and Mach ranges and its dynamic-pressure
    /// bound). A cell outside (the low, fast corner) is mapped all the same,
    /// for information: the controller flags its frames OUTSIDE_ENVELOPE.
    #[serde(default = "inside_by_default")]
    pub inside_envelope: bool,
}

/// A cell file of a map made before `inside_envelope` was recorded: its
/// directory's `inputs.json` must match the configuration anyway.
fn inside_by_default() -> bool {
    true
}

/// Whether (`altitude` m, Mach `mach`) is inside `config`'s declared envelope:
/// its altitude and Mach ranges, and the Mach number its dynamic-pressure
/// bound allows there (the exact bound: the controller's check flags frames
/// up to `decoy_controller::envelope::Q_TABLE_MAX_INSET` of Mach² inside it).
pub fn inside_envelope(config: &SystemConfig, altitude: f64, mach: f64) -> bool {
    let [h0, h1] = config.envelope.altitude_m;
    let m0 = config.envelope.mach[0];
    (h0..=h1).contains(&altitude)
        && mach >= m0
        && config
            .max_mach_at(altitude)
            .is_some_and(|top| mach <= top * (1.0 + 1e-12))
}

/// The map: the spec and its cells in grid order (altitude-major).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EnvelopeMap {
    /// What was mapped.
    pub spec: EnvelopeSpec,
    /// The cells, altitude by altitude, each altitude's Mach numbers in order.
    pub cells: Vec<Cell>,
    /// Cells taken from an earlier run into the same directory.
    pub resumed: usize,
    /// Whether the controller flown beside the runs had the configuration's
    /// envelope map on board (made for it), which advises too.
    pub onboard_map: bool,
}

/// A map's inputs, what an output directory's `inputs.json` holds: the
/// configuration and the spec. Its JSON ([`EnvelopePlan::to_json`]) is what
/// another engine's workers get to map a cell ([`map_cell`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EnvelopePlan {
    /// The system.
    pub config: SystemConfig,
    /// The system's aerodynamic table (its TOML names the file, and
    /// `SystemConfig` does not serialize the rows): a map of another table is
    /// a map of other inputs.
    aero_rows: Vec<AeroRow>,
    /// What to map.
    pub spec: EnvelopeSpec,
    /// The text of the envelope map on board of the controller flown beside
    /// the runs (the configuration's map file, when it was made for it: its
    /// advisories use it), or None (the controller then has no map and
    /// advises by its look-ahead alone). Absent from the JSON when None.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    onboard_map: Option<String>,
}

impl EnvelopePlan {
    /// The plan of `spec` on `config`, checked.
    pub fn new(config: &SystemConfig, spec: &EnvelopeSpec) -> Result<EnvelopePlan, SimError> {
        spec.check(config)?;
        Ok(EnvelopePlan {
            config: config.clone(),
            aero_rows: config.aero_rows.clone(),
            spec: spec.clone(),
            onboard_map: config.limits.and(config.limits_text.clone()),
        })
    }

    /// `inputs.json`'s text (pretty, one newline at the end).
    pub fn to_json(&self) -> Result<String, SimError> {
        to_json(self, Path::new("inputs.json"))
    }

    /// The plan of `inputs.json`'s text, checked.
    pub fn from_json(text: &str) -> Result<EnvelopePlan, SimError> {
        let plan: EnvelopePlan = serde_json::from_str(text).map_err(|e| {
            SimError::invalid(
                "envelope plan",
                "inputs",
                format!("is not a map's inputs.json ({e})"),
            )
        })?;
        let mut plan = plan;
        plan.config.aero_rows = plan.aero_rows.clone();
        plan.config.source = "the map's inputs.json".to_owned();
        plan.config.validate()?;
        if let Some(text) = &plan.onboard_map {
            let name = "the map's inputs.json (onboard_map)";
            let file = LimitsFile::parse(name, text)?;
            plan.config.limits = Some(file.to_map(name, &plan.config)?);
            plan.config.limits_text = Some(text.clone());
        }
        plan.spec.check(&plan.config)?;
        Ok(plan)
    }
}

/// What a map asks for, each value None for its default
/// ([`EnvelopeSpec::new`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EnvelopeRequest {
    /// The altitudes, m (default: the configuration's `[envelope]` altitudes by 3000 m).
    pub altitudes_m: Option<Vec<f64>>,
    /// The Mach numbers (default: the `[envelope]` Mach range by 0.1 and its
    /// upper end; for the acceleration, those at least the gain below it and the
    /// upper end less the gain).
    pub machs: Option<Vec<f64>>,
    /// Cable segments (default: the configuration's `solver.segments_host`).
    pub segments: Option<usize>,
    /// Segment length ratio (default 1, uniform).
    pub grading: Option<f64>,
    /// Onset, s (default 0.5; pull-up and turn only).
    pub onset_s: Option<f64>,
    /// Bisection tolerance (default 0.005 rad/s; 0.05 m/s^2 for the acceleration).
    pub tolerance: Option<f64>,
    /// The acceleration's Mach gain (default 0.1; acceleration only).
    pub mach_gain: Option<f64>,
}

/// The default onset, s.
pub const DEFAULT_ONSET_S: f64 = 0.5;
/// The default tolerance on a rate, rad/s.
pub const DEFAULT_RATE_TOLERANCE: f64 = 0.005;
/// The default tolerance on an acceleration, m/s^2.
pub const DEFAULT_ACCELERATION_TOLERANCE: f64 = 0.05;

impl EnvelopeSpec {
    /// The spec of `request` for `manoeuvre` on `config`: the defaults filled
    /// in, checked ([`EnvelopeSpec::check`]).
    pub fn new(
        config: &SystemConfig,
        manoeuvre: Manoeuvre,
        request: &EnvelopeRequest,
    ) -> Result<EnvelopeSpec, SimError> {
        let invalid = |field: &str, message: String| SimError::invalid("envelope", field, message);
        let accelerates = manoeuvre == Manoeuvre::Acceleration;
        if accelerates && request.onset_s.is_some_and(|t| t != 0.0) {
            return Err(invalid(
                "--onset",
                "applies to a pull-up or a turn, not to an acceleration".to_owned(),
            ));
        }
        if !accelerates && request.mach_gain.is_some() {
            return Err(invalid(
                "--mach-gain",
                format!("applies to an acceleration, not to a {}", manoeuvre.name()),
            ));
        }
        let mach_gain = accelerates.then(|| request.mach_gain.unwrap_or(DEFAULT_MACH_GAIN));
        if let (Some(gain), None) = (mach_gain, &request.machs)
            && gain > 0.0
            && default_machs(config, mach_gain).is_empty()
        {
            let [lo, hi] = config.envelope.mach;
            return Err(invalid(
                "--mach-gain",
                format!(
                    "{gain} leaves no Mach number of the envelope ({lo} to {hi}) to accelerate from: give a smaller gain"
                ),
            ));
        }
        let spec = EnvelopeSpec {
            manoeuvre,
            altitudes_m: request.altitudes_m.clone().unwrap_or_else(|| {
                let [lo, hi] = config.envelope.altitude_m;
                let steps = ((hi - lo) / 3000.0 + 1e-9).floor().max(0.0) as usize;
                (0..=steps).map(|i| lo + 3000.0 * i as f64).collect()
            }),
            machs: request
                .machs
                .clone()
                .unwrap_or_else(|| default_machs(config, mach_gain)),
            segments: request.segments.unwrap_or(config.solver.segments_host),
            grading: request.grading.unwrap_or(1.0),
            onset_s: if accelerates {
                0.0
            } else {
                request.onset_s.unwrap_or(DEFAULT_ONSET_S)
            },
            tolerance: request.tolerance.unwrap_or(if accelerates {
                DEFAULT_ACCELERATION_TOLERANCE
            } else {
                DEFAULT_RATE_TOLERANCE
            }),
            mach_gain,
        };
        spec.check(config)?;
        Ok(spec)
    }

    /// The limit's unit: `rad/s`, or `m/s^2` for the acceleration.
    pub fn unit(&self) -> &'static str {
        if self.manoeuvre == Manoeuvre::Acceleration {
            "m/s^2"
        } else {
            "rad/s"
        }
    }

    /// The Mach number an acceleration from `mach` at `altitude` (m) ends at:
    /// the gain above it, the envelope's largest Mach there at most (its Mach
    /// range's upper end, or its dynamic-pressure bound's); from a condition
    /// already beyond the dynamic-pressure bound, the Mach range's upper end
    /// at most (None for a rotation).
    pub fn final_mach(&self, config: &SystemConfig, altitude: f64, mach: f64) -> Option<f64> {
        let top = config
            .max_mach_at(altitude)
            .filter(|&top| mach <= top)
            .unwrap_or(config.envelope.mach[1]);
        self.mach_gain.map(|gain| (mach + gain).min(top))
    }

    /// Checks the spec: a pull-up, turn or acceleration, a non-empty grid, a
    /// positive tolerance, a non-negative onset; for the acceleration, a
    /// positive Mach gain and Mach numbers below the envelope's upper one.
    pub fn check(&self, config: &SystemConfig) -> Result<(), SimError> {
        let invalid = |field: &str, message: String| SimError::invalid("envelope", field, message);
        if !matches!(
            self.manoeuvre,
            Manoeuvre::PullUp | Manoeuvre::Turn | Manoeuvre::Acceleration
        ) {
            return Err(invalid(
                "--manoeuvre",
                format!(
                    "must be pull-up, turn or acceleration, got {}",
                    self.manoeuvre.name()
                ),
            ));
        }
        if !(self.onset_s >= 0.0 && self.onset_s.is_finite()) {
            return Err(invalid(
                "--onset",
                format!(
                    "must be a non-negative number of seconds, got {}",
                    self.onset_s
                ),
            ));
        }
        match (self.manoeuvre, self.mach_gain) {
            (Manoeuvre::Acceleration, Some(gain)) => {
                if !(gain > 0.0 && gain.is_finite()) {
                    return Err(invalid(
                        "--mach-gain",
                        format!("must be positive, got {gain}"),
                    ));
                }
                let top = config.envelope.mach[1];
                if let Some(m) = self.machs.iter().find(|&&m| m >= top || m.is_nan()) {
                    return Err(invalid(
                        "--machs",
                        format!(
                            "an acceleration map's Mach numbers must be below the envelope's upper Mach {top} (the acceleration from each ends there at most), got {m}"
                        ),
                    ));
                }
            }
            (Manoeuvre::Acceleration, None) => {
                return Err(invalid(
                    "mach_gain",
                    "an acceleration map needs its Mach gain".to_owned(),
                ));
            }
            (_, Some(_)) => {
                return Err(invalid(
                    "--mach-gain",
                    format!(
                        "applies to an acceleration, not to a {}",
                        self.manoeuvre.name()
                    ),
                ));
            }
            (_, None) => {}
        }
        if self.altitudes_m.is_empty() || self.machs.is_empty() {
            return Err(invalid(
                "--altitudes/--machs",
                "the grid needs at least one altitude and one Mach number".to_owned(),
            ));
        }
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(invalid(
                "tolerance",
                format!("must be positive, got {}", self.tolerance),
            ));
        }
        Ok(())
    }

    /// The model in words (`300 uniform segments`, decoy-sim's
    /// [`describe_layout`]).
    pub fn describe_model(&self) -> String {
        describe_layout(&if self.grading == 1.0 {
            SegmentLayout::Uniform {
                count: self.segments,
            }
        } else {
            SegmentLayout::Graded {
                count: self.segments,
                ratio: self.grading,
            }
        })
    }

    /// The manoeuvre in words: `rates built over 0.5 s`, or `accelerating by
    /// Mach 0.1 (to 0.95 at most) then 15 s on`.
    pub fn describe_manoeuvre(&self) -> String {
        match self.mach_gain {
            Some(gain) => format!(
                "accelerating from each Mach by {gain} (to the envelope's largest Mach at that altitude at most), then {AFTERMATH_S} s on"
            ),
            None => format!("rates built over {} s", self.onset_s),
        }
    }

    /// What the map's runs fly, for the controller's cover (docs/protocol.md
    /// §3, "Advisories from the map"): the longest the manoeuvre lasts from its
    /// entry and how long the runs fly on after it, s. The pull-up: its
    /// rotation with the onset that ends it, then the climb to the run's end;
    /// the turn: the whole run, turning. None for the acceleration, whose
    /// extent is a Mach gain, not a time (the map covers none).
    pub fn cover(&self) -> Result<Option<(f64, f64)>, SimError> {
        if self.mach_gain.is_some() {
            return Ok(None);
        }
        let scenario = Scenario::builtin(self.manoeuvre.name())?;
        let start = scenario.start_s.unwrap_or_default();
        let run = scenario.t_end_s - start;
        Ok(Some(match scenario.duration_s {
            Some(duration) => {
                let lasts = (duration + self.onset_s).min(run);
                (lasts, run - lasts)
            }
            None => (run, 0.0),
        }))
    }

    /// The cells' flight conditions (altitude m, Mach) in grid order.
    pub fn conditions(&self) -> Vec<(f64, f64)> {
        self.altitudes_m
            .iter()
            .flat_map(|&h| self.machs.iter().map(move |&m| (h, m)))
            .collect()
    }
}

/// The default Mach numbers: from the envelope's lower end by 0.1, and its
/// upper end; for an acceleration of `gain`, those the gain below the upper
/// end at least, and the upper end less the gain.
fn default_machs(config: &SystemConfig, gain: Option<f64>) -> Vec<f64> {
    let [lo, hi] = config.envelope.mach;
    let round = |m: f64| (m * 1000.0).round() / 1000.0;
    // The acceleration's top: rounded down to 0.001 (so that a small gain
    // still leaves it below the upper Mach), 1e-6 for the subtraction's ulps.
    let top = match gain {
        Some(gain) => ((hi - gain) * 1000.0 + 1e-6).floor() / 1000.0,
        None => round(hi),
    };
    let mut machs: Vec<f64> = (0..)
        .map(|i| round(lo + 0.1 * f64::from(i)))
        .take_while(|m| *m <= top + 1e-9)
        .collect();
    if machs.last().is_none_or(|m| *m < top - 1e-9) && top >= lo {
        machs.push(top);
    }
    machs
}

/// The rate the envelope allows at speed `speed` (m/s): the load factor's and
/// the body rate's caps, the smaller and which it is (for the acceleration,
/// the along-path acceleration's bound).
fn cap(config: &SystemConfig, manoeuvre: Manoeuvre, speed: f64) -> (f64, Limit) {
    if manoeuvre == Manoeuvre::Acceleration {
        return (
            config.envelope.max_along_path_acceleration_mps2,
            Limit::AccelerationBound,
        );
    }
    let g = config.environment.gravity;
    let n = config.envelope.load_factor[1];
    let load = match manoeuvre {
        Manoeuvre::Turn => g * (n * n - 1.0).max(0.0).sqrt() / speed,
        _ => (n - 1.0).max(0.0) * g / speed,
    };
    let body = config.envelope.max_body_rate_radps;
    if load <= body {
        (load, Limit::LoadFactor)
    } else {
        (body, Limit::BodyRate)
    }
}

/// The outcome of one trial: the requirement violated first (if any) and
/// every requirement's worst margin.
struct Trial {
    violated: Option<Requirement>,
    margins: PerRequirement<Option<f64>>,
    /// The violated requirement's advisory lead, s (first violation - first
    /// advisory; None: not advised before it).
    lead: Option<f64>,
    /// The first advisory against any requirement, s, and the requirement.
    first_advisory: Option<(f64, Requirement)>,
    /// Each requirement's highest level over the run (0 normal to 3 violated).
    worst_levels: PerRequirement<u8>,
}

/// Flies `scenario` at the cell's condition with `rate` (None: the scenario's
/// own kind without a rate, steady flight) for `t_end` (None: the scenario's).
/// An acceleration's `rate` is its along-path acceleration, m/s^2: from the
/// cell's Mach to the spec's final Mach, then [`AFTERMATH_S`] on.
fn fly(
    config: &SystemConfig,
    spec: &EnvelopeSpec,
    scenario: &Scenario,
    condition: (f64, f64),
    rate: Option<f64>,
    t_end: Option<f64>,
) -> Result<Trial, SimError> {
    fly_held(config, spec, scenario, condition, rate, t_end, None)
}

/// [`fly`], with the manoeuvre held until `hold_until` (s) when given: the
/// pull-up's rotation not ended before it, the acceleration going on to the
/// speed it reaches then.
fn fly_held(
    config: &SystemConfig,
    spec: &EnvelopeSpec,
    scenario: &Scenario,
    (altitude, mach): (f64, f64),
    rate: Option<f64>,
    t_end: Option<f64>,
    hold_until: Option<f64>,
) -> Result<Trial, SimError> {
    let mut options = RunOptions {
        segments: Some(spec.segments),
        grading: Some(spec.grading),
        t_end,
        altitude: Some(altitude),
        mach: Some(mach),
        rate,
        onset: rate.map(|_| spec.onset_s),
        initial: InitialState::Trim,
        plots: false,
        ..RunOptions::default()
    };
    let changed;
    let scenario = match (spec.final_mach(config, altitude, mach), rate) {
        (Some(final_mach), Some(acceleration)) => {
            let speed = config.mach_to_speed(altitude, mach)?;
            let gain = config.mach_to_speed(altitude, final_mach)? - speed;
            let start = scenario.accel_start_s.unwrap_or_default();
            let final_mach = match hold_until {
                Some(until) => {
                    let held = speed + acceleration * (until - start);
                    final_mach.max(held / config.speed_of_sound(altitude)?)
                }
                None => final_mach,
            };
            changed = Scenario {
                final_mach: Some(final_mach),
                acceleration_mps2: Some(acceleration),
                t_end_s: start + gain / acceleration + AFTERMATH_S,
                ..scenario.clone()
            };
            options.rate = None;
            options.onset = None;
            &changed
        }
        (None, Some(_)) if hold_until.is_some() && scenario.duration_s.is_some() => {
            let start = scenario.start_s.unwrap_or_default();
            let held = hold_until.unwrap_or_default() - start;
            changed = Scenario {
                duration_s: scenario.duration_s.map(|d| d.max(held)),
                ..scenario.clone()
            };
            &changed
        }
        _ => scenario,
    };
    let recording = simulate_recorded(config, scenario, &options, |_| {}, || None)?;
    if let Some(e) = recording.ended {
        return Err(e);
    }
    let requirements = recording.summary.management.requirements;
    let violated = Requirement::ALL
        .into_iter()
        .filter_map(|r| requirements[r].first_violation_s.map(|t| (t, r)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, r)| r);
    Ok(Trial {
        violated,
        margins: requirements.map(|r| r.worst_margin),
        lead: violated.and_then(|r| requirements[r].advisory_lead_s),
        first_advisory: Requirement::ALL
            .into_iter()
            .filter_map(|r| requirements[r].first_advisory_s.map(|t| (t, r)))
            .min_by(|a, b| a.0.total_cmp(&b.0)),
        worst_levels: recording
            .samples
            .iter()
            .fold(PerRequirement::splat(0u8), |worst, s| {
                let levels = s.management.levels;
                PerRequirement {
                    posture: worst.posture.max(levels.posture),
                    collision: worst.collision.max(levels.collision),
                    tension: worst.tension.max(levels.tension),
                    exhaust: worst.exhaust.max(levels.exhaust),
                }
            }),
    })
}

/// How the manoeuvre continued judges an advisory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Judgement {
    /// A requirement is violated within the horizon: the advisory was right.
    Confirmed,
    /// Nothing is violated, but the advised requirement reaches its warning
    /// level (the advisory line's own threshold): a near miss.
    NearMiss,
    /// The advised requirement stays above its warning level: a nuisance.
    Nuisance,
}

/// Whether an advisory at `advised_at` (s) in a clear run of `scenario` at
/// `condition` with `rate` was right: the look-ahead says "continuing this
/// manoeuvre violates a requirement within the horizon", so the manoeuvre is
/// flown again continued (the pull-up's rotation or the acceleration held,
/// when the advisory came while they lasted; level flight before they
/// started; the turn and the climb as they are) to the horizon's end, and the
/// advisory was right when a requirement is violated by then.
fn advisory_confirmed(
    config: &SystemConfig,
    spec: &EnvelopeSpec,
    (scenario, steady): (&Scenario, &Scenario),
    condition: (f64, f64),
    rate: Option<f64>,
    (advised_at, advised): (f64, Requirement),
) -> Result<Judgement, SimError> {
    let until = advised_at + config.management.horizon_s;
    let start = scenario
        .accel_start_s
        .or(scenario.start_s)
        .unwrap_or_default();
    // When the manoeuvre's rotation or acceleration ends (the turn's never).
    let ends = match (rate, spec.final_mach(config, condition.0, condition.1)) {
        (Some(a), Some(final_mach)) => {
            let gain = config.mach_to_speed(condition.0, final_mach)?
                - config.mach_to_speed(condition.0, condition.1)?;
            start + gain / a
        }
        _ => start + scenario.duration_s.unwrap_or(f64::INFINITY),
    };
    let continued = match rate {
        Some(_) if advised_at >= start => fly_held(
            config,
            spec,
            scenario,
            condition,
            rate,
            Some(until),
            (advised_at <= ends).then_some(until),
        )?,
        _ => fly(config, spec, steady, condition, None, Some(until))?,
    };
    Ok(if continued.violated.is_some() {
        Judgement::Confirmed
    } else if continued.worst_levels[advised] >= 2 {
        Judgement::NearMiss
    } else {
        Judgement::Nuisance
    })
}

/// Maps the cell `index` (grid order, [`EnvelopeSpec::conditions`]) of
/// `plan`: what a worker of another engine runs.
pub fn map_cell(plan: &EnvelopePlan, index: usize) -> Result<Cell, SimError> {
    let conditions = plan.spec.conditions();
    let &condition = conditions.get(index).ok_or_else(|| {
        SimError::invalid(
            "envelope",
            "cell",
            format!(
                "index {index} is outside the grid of {} cells",
                conditions.len()
            ),
        )
    })?;
    map_condition(&plan.config, &plan.spec, condition)
}

/// Maps one cell.
fn map_condition(
    config: &SystemConfig,
    spec: &EnvelopeSpec,
    (altitude, mach): (f64, f64),
) -> Result<Cell, SimError> {
    let point = format!("{altitude} m, Mach {mach}");
    let at = |e: SimError| e.at(point.clone());
    let steady = Scenario::builtin("steady").map_err(at)?;
    let manoeuvre = Scenario::builtin(spec.manoeuvre.name()).map_err(at)?;
    let condition = (altitude, mach);
    let speed = config
        .mach_to_speed(altitude, mach)
        .map_err(|e| at(e.into()))?;
    let (cap, capped_by) = cap(config, spec.manoeuvre, speed);
    // Every trial's advisories: the false ones (a clear run advised against)
    // and the lead of the last violation (the smallest violating rate's).
    let mut tally = Tally::default();
    let scenarios = (&manoeuvre, &steady);
    let judge = |condition: (f64, f64), rate: Option<f64>| {
        move |advisory: (f64, Requirement)| {
            advisory_confirmed(config, spec, scenarios, condition, rate, advisory)
        }
    };
    let steady_trial = tally
        .note(
            fly(config, spec, &steady, condition, None, Some(STEADY_S)),
            judge(condition, None),
        )
        .map_err(at)?;
    let cell = |limit: f64, limiting: Limit, margin: Option<f64>, tally: &Tally| Cell {
        altitude_m: altitude,
        mach,
        limit,
        cap,
        limiting,
        margin,
        steady_margins: steady_trial.margins,
        runs: tally.runs,
        advisory_lead_s: tally.lead,
        advised: tally.advised,
        false_advisories: tally.false_advisories,
        nuisance_advisories: tally.nuisance_advisories,
        advised_clear_runs: tally.advised_clear_runs,
        clear_runs: tally.clear_runs,
        inside_envelope: inside_envelope(config, altitude, mach),
    };
    if let Some(r) = steady_trial.violated {
        return Ok(cell(
            0.0,
            Limit::Requirement(r),
            steady_trial.margins[r],
            &tally,
        ));
    }
    // An acceleration ends in steady flight at the final Mach: not clear
    // there, not clear at any acceleration.
    if let Some(final_mach) = spec.final_mach(config, altitude, mach) {
        let arrived = tally
            .note(
                fly(
                    config,
                    spec,
                    &steady,
                    (altitude, final_mach),
                    None,
                    Some(STEADY_S),
                ),
                judge((altitude, final_mach), None),
            )
            .map_err(at)?;
        if let Some(r) = arrived.violated {
            return Ok(cell(0.0, Limit::Requirement(r), arrived.margins[r], &tally));
        }
    }
    let at_cap = tally
        .note(
            fly(config, spec, &manoeuvre, condition, Some(cap), None),
            judge(condition, Some(cap)),
        )
        .map_err(at)?;
    let Some(mut limiting) = at_cap.violated else {
        return Ok(cell(cap, capped_by, None, &tally));
    };
    // Bisection: `lo` clear, `hi` violating `limiting` first.
    let (mut lo, mut hi) = (0.0, cap);
    let mut margin = steady_trial.margins[limiting];
    let mut clear_margins = steady_trial.margins;
    while hi - lo > spec.tolerance {
        let mid = 0.5 * (lo + hi);
        let trial = tally
            .note(
                fly(config, spec, &manoeuvre, condition, Some(mid), None),
                judge(condition, Some(mid)),
            )
            .map_err(at)?;
        match trial.violated {
            Some(r) => {
                hi = mid;
                limiting = r;
            }
            None => {
                lo = mid;
                clear_margins = trial.margins;
            }
        }
        margin = clear_margins[limiting];
    }
    Ok(cell(lo, Limit::Requirement(limiting), margin, &tally))
}

/// What a cell's trials said of the advisories.
#[derive(Default)]
struct Tally {
    runs: u32,
    clear_runs: u32,
    advised_clear_runs: u32,
    false_advisories: u32,
    nuisance_advisories: u32,
    /// The last violating trial's lead and whether it was advised (the
    /// bisection's violating rates fall, so the last is the smallest).
    lead: Option<f64>,
    advised: Option<bool>,
}

impl Tally {
    /// Counts `trial`; a clear trial that was advised against is judged by
    /// `judge` (of the first advisory's time and requirement:
    /// [`advisory_confirmed`]), one more run.
    fn note(
        &mut self,
        trial: Result<Trial, SimError>,
        judge: impl FnOnce((f64, Requirement)) -> Result<Judgement, SimError>,
    ) -> Result<Trial, SimError> {
        let trial = trial?;
        self.runs += 1;
        if trial.violated.is_some() {
            self.lead = trial.lead;
            self.advised = Some(trial.lead.is_some());
        } else {
            self.clear_runs += 1;
            if let Some(advisory) = trial.first_advisory {
                self.advised_clear_runs += 1;
                self.runs += 1;
                match judge(advisory)? {
                    Judgement::Confirmed => {}
                    Judgement::NearMiss => self.false_advisories += 1,
                    Judgement::Nuisance => {
                        self.false_advisories += 1;
                        self.nuisance_advisories += 1;
                    }
                }
            }
        }
        Ok(trial)
    }
}

/// Maps `spec` over its grid with `workers` threads (at least one), writing
/// each cell to `out_dir/cells/` as it is known (and reusing those a run of
/// the same inputs left there); `progress` is told (cells done, cells in all)
/// after every cell.
pub fn map_envelope(
    config: &SystemConfig,
    spec: &EnvelopeSpec,
    workers: usize,
    out_dir: Option<&Path>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<EnvelopeMap, SimError> {
    spec.check(config)?;
    let conditions = spec.conditions();
    let mut done: Vec<Option<Cell>> = vec![None; conditions.len()];
    if let Some(dir) = out_dir {
        prepare_dir(config, spec, dir)?;
        for (slot, &condition) in done.iter_mut().zip(&conditions) {
            *slot = read_cell(&cell_path(dir, condition))?;
        }
    }
    let resumed = done.iter().filter(|c| c.is_some()).count();
    let todo: Vec<usize> = (0..conditions.len())
        .filter(|&i| done[i].is_none())
        .collect();
    let finished = AtomicUsize::new(resumed);
    progress(resumed, conditions.len());
    let next = AtomicUsize::new(0);
    let results = Mutex::new(done);
    let failure: Mutex<Option<(usize, SimError)>> = Mutex::new(None);
    std::thread::scope(|scope| {
        for _ in 0..workers.clamp(1, todo.len().max(1)) {
            scope.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&i) = todo.get(k) else { break };
                    if failure.lock().map(|f| f.is_some()).unwrap_or(true) {
                        break;
                    }
                    let outcome = map_condition(config, spec, conditions[i]).and_then(|cell| {
                        if let Some(dir) = out_dir {
                            write_cell(&cell_path(dir, conditions[i]), &cell)?;
                        }
                        Ok(cell)
                    });
                    match outcome {
                        Ok(cell) => {
                            if let Ok(mut r) = results.lock() {
                                r[i] = Some(cell);
                            }
                            let n = finished.fetch_add(1, Ordering::Relaxed) + 1;
                            progress(n, conditions.len());
                        }
                        Err(e) => {
                            if let Ok(mut f) = failure.lock() {
                                // The first cell in grid order among the failed.
                                if f.as_ref().is_none_or(|(j, _)| i < *j) {
                                    *f = Some((i, e));
                                }
                            }
                        }
                    }
                }
            });
        }
    });
    if let Some((_, e)) = failure.into_inner().ok().flatten() {
        return Err(e);
    }
    let cells = results
        .into_inner()
        .map_err(|_| SimError::invalid("envelope", "workers", "a worker panicked".to_owned()))?
        .into_iter()
        .map(|c| c.expect("every cell mapped"))
        .collect();
    Ok(EnvelopeMap {
        spec: spec.clone(),
        cells,
        resumed,
        onboard_map: config.limits.is_some(),
    })
}

/// The cells of `plan` that `dir` does not hold yet, in grid order, having
/// prepared `dir` as [`map_envelope`] does (its `inputs.json` written, or
/// checked to be `plan`'s).
pub fn pending_cells(plan: &EnvelopePlan, dir: &Path) -> Result<Vec<usize>, SimError> {
    prepare_dir(&plan.config, &plan.spec, dir)?;
    let mut pending = Vec::new();
    for (i, condition) in plan.spec.conditions().into_iter().enumerate() {
        if read_cell(&cell_path(dir, condition))?.is_none() {
            pending.push(i);
        }
    }
    Ok(pending)
}

/// Every cell of `plan`'s map in `dir`, in grid order; a cell missing is an
/// error that says how to finish the map.
pub(crate) fn read_map_cells(plan: &EnvelopePlan, dir: &Path) -> Result<Vec<Cell>, SimError> {
    let conditions = plan.spec.conditions();
    let mut cells = Vec::with_capacity(conditions.len());
    let mut missing = 0;
    for condition in conditions {
        match read_cell(&cell_path(dir, condition))? {
            Some(cell) => cells.push(cell),
            None => missing += 1,
        }
    }
    if missing > 0 {
        return Err(SimError::invalid(
            dir.display().to_string(),
            "map",
            format!(
                "is not complete: {missing} of {} cells are not mapped yet (finish it by running the same `decoy envelope` into it again: it resumes)",
                cells.len() + missing
            ),
        ));
    }
    Ok(cells)
}

/// Writes `cell`, cell `index` of `plan` mapped elsewhere ([`map_cell`]),
/// atomically into `dir` (prepared by [`pending_cells`]), where
/// [`map_envelope`] takes it; a cell not of that index's condition is an
/// error.
pub fn store_cell(
    plan: &EnvelopePlan,
    dir: &Path,
    index: usize,
    cell: &Cell,
) -> Result<(), SimError> {
    let condition = plan.spec.conditions().get(index).copied();
    if condition != Some((cell.altitude_m, cell.mach)) {
        return Err(SimError::invalid(
            "envelope",
            "cell",
            format!(
                "the cell of {} m, Mach {} is not cell {index} of the grid",
                cell.altitude_m, cell.mach
            ),
        ));
    }
    prepare_dir(&plan.config, &plan.spec, dir)?;
    write_cell(&cell_path(dir, (cell.altitude_m, cell.mach)), cell)
}

/// Creates `dir` and its `cells/`, and writes `inputs.json` there, or checks
/// that the one there is of the same inputs.
fn prepare_dir(config: &SystemConfig, spec: &EnvelopeSpec, dir: &Path) -> Result<(), SimError> {
    let io = |action: &'static str, path: &Path| {
        let path = path.to_owned();
        move |source| SimError::Io {
            action,
            path,
            source,
        }
    };
    let cells = dir.join("cells");
    std::fs::create_dir_all(&cells).map_err(io("create the directory", &cells))?;
    let inputs = EnvelopePlan {
        config: config.clone(),
        aero_rows: config.aero_rows.clone(),
        spec: spec.clone(),
        onboard_map: config.limits.and(config.limits_text.clone()),
    };
    let path = dir.join("inputs.json");
    let json = to_json(&inputs, &path)?;
    match std::fs::read_to_string(&path) {
        Ok(existing) if existing == json => Ok(()),
        Ok(_) => Err(SimError::invalid(
            path.display().to_string(),
            "inputs",
            "the directory holds a map of other inputs (configuration, manoeuvre, grid, model, onset, Mach gain, tolerance or the map on board its advisories use): give another --out, or remove it".to_owned(),
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            write_atomically(&path, json.as_bytes()).map_err(io("write", &path))
        }
        Err(e) => Err(io("read", &path)(e)),
    }
}

/// A cell's file in `dir`.
fn cell_path(dir: &Path, (altitude, mach): (f64, f64)) -> PathBuf {
    dir.join("cells").join(format!("h{altitude}-m{mach}.json"))
}

fn read_cell(path: &Path) -> Result<Option<Cell>, SimError> {
    match std::fs::read_to_string(path) {
        Ok(text) => serde_json::from_str(&text).map(Some).map_err(|e| {
            SimError::invalid(
                path.display().to_string(),
                "cell",
                format!("is not a cell of a map ({e}): remove it to map the cell again"),
            )
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(SimError::Io {
            action: "read",
            path: path.to_owned(),
            source,
        }),
    }
}

fn write_cell(path: &Path, cell: &Cell) -> Result<(), SimError> {
    let json = to_json(cell, path)?;
    write_atomically(path, json.as_bytes()).map_err(|source| SimError::Io {
        action: "write",
        path: path.to_owned(),
        source,
    })
}

fn to_json(value: &impl Serialize, path: &Path) -> Result<String, SimError> {
    serde_json::to_string_pretty(value)
        .map(|mut s| {
            s.push('\n');
            s
        })
        .map_err(|e| SimError::Io {
            action: "write",
            path: path.to_owned(),
            source: std::io::Error::other(e),
        })
}

impl EnvelopeMap {
    /// Writes the heat map ([`EnvelopeMap::heatmap`]) as `limit.png` and
    /// `limit.svg` in `dir`; returns the files.
    pub fn write_heatmap(&self, dir: &Path) -> Result<[PathBuf; 2], SimError> {
        let stem = dir.join("limit");
        write_heatmap(&self.heatmap(), &stem).map_err(|e| SimError::Plot {
            stem,
            message: e.to_string(),
        })
    }

    /// Writes the map's outputs into `dir` (atomically, each): `envelope.json`
    /// ([`EnvelopeMap::json`]), `envelope.csv`, `summary.txt` and the heat map
    /// `limit.png/.svg`; returns the files.
    pub fn write_outputs(&self, dir: &Path) -> Result<Vec<PathBuf>, SimError> {
        let write = |name: &str, text: &str| -> Result<PathBuf, SimError> {
            let path = dir.join(name);
            write_atomically(&path, text.as_bytes()).map_err(|source| SimError::Io {
                action: "write",
                path: path.clone(),
                source,
            })?;
            Ok(path)
        };
        let json = to_json(&self.json(), &dir.join("envelope.json"))?;
        let mut files = vec![
            write("envelope.json", &json)?,
            write("envelope.csv", &self.csv())?,
            write("summary.txt", &self.summary())?,
        ];
        files.extend(self.write_heatmap(dir)?);
        Ok(files)
    }

    /// `envelope.csv`: a row per cell, grid order (limit and cap in rad/s, or
    /// m/s^2 for the acceleration: the column names say which).
    pub fn csv(&self) -> String {
        let unit = if self.spec.manoeuvre == Manoeuvre::Acceleration {
            "mps2"
        } else {
            "radps"
        };
        let mut out = format!(
            "altitude_m,mach,limit_{unit},cap_{unit},limiting,margin,steady_posture_margin_deg,steady_collision_margin_m,steady_tension_margin_N,steady_exhaust_margin_m,advisory_lead_s,runs,clear_runs,advised_clear_runs,false_advisories,nuisance_advisories,inside_envelope\n",
        );
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v}"));
        for c in &self.cells {
            let s = &c.steady_margins;
            out.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                c.altitude_m,
                c.mach,
                c.limit,
                c.cap,
                c.limiting.name(),
                opt(c.margin),
                opt(s.posture),
                opt(s.collision),
                opt(s.tension),
                opt(s.exhaust),
                opt(c.advisory_lead_s),
                c.runs,
                c.clear_runs,
                c.advised_clear_runs,
                c.false_advisories,
                c.nuisance_advisories,
                c.inside_envelope
            ));
        }
        out
    }

    /// The JSON `--json` prints: `{"manoeuvre", "cells": [{"altitude_m",
    /// "mach", "limit", "limiting_requirement", "margin", "cap",
    /// "steady_margins": {posture, collision, tension, exhaust}}]}`.
    pub fn json(&self) -> serde_json::Value {
        let mut value = serde_json::json!({
            "manoeuvre": self.spec.manoeuvre.name(),
            "limit_unit": self.spec.unit(),
            "onset_s": self.spec.onset_s,
            "segments": self.spec.segments,
            "grading": self.spec.grading,
            "tolerance": self.spec.tolerance,
            "cells": self.cells.iter().map(|c| serde_json::json!({
                "altitude_m": c.altitude_m,
                "mach": c.mach,
                "limit": c.limit,
                "limiting_requirement": c.limiting.name(),
                "margin": c.margin,
                "cap": c.cap,
                "advisory_lead_s": c.advisory_lead_s,
                "advised": c.advised,
                "runs": c.runs,
                "clear_runs": c.clear_runs,
                "advised_clear_runs": c.advised_clear_runs,
                "false_advisories": c.false_advisories,
                "nuisance_advisories": c.nuisance_advisories,
                "inside_envelope": c.inside_envelope,
                "steady_margins": {
                    "posture": c.steady_margins.posture,
                    "collision": c.steady_margins.collision,
                    "tension": c.steady_margins.tension,
                    "exhaust": c.steady_margins.exhaust,
                },
            })).collect::<Vec<_>>(),
        });
        if let (Some(gain), Some(object)) = (self.spec.mach_gain, value.as_object_mut()) {
            object.insert("mach_gain".to_owned(), gain.into());
        }
        value
    }

    /// The heat map of the limits over Mach x altitude (highest altitude on
    /// top), each cell marked with what limits it; for the pull-up, the
    /// contour of the paper's 0.10 rad/s.
    pub fn heatmap(&self) -> HeatMap {
        let spec = &self.spec;
        let n = spec.machs.len();
        let rows: Vec<&[Cell]> = self.cells.chunks(n).rev().collect();
        let pull_up = spec.manoeuvre == Manoeuvre::PullUp;
        let accelerates = spec.manoeuvre == Manoeuvre::Acceleration;
        HeatMap {
            title: format!(
                "{}: largest {} clear of every requirement [{}]",
                spec.manoeuvre.name(),
                if accelerates {
                    "along-path acceleration"
                } else {
                    "rate"
                },
                spec.unit()
            ),
            subtitle: vec![
                format!("{}, {}", spec.describe_model(), spec.describe_manoeuvre()),
                format!(
                    "bisected to {} {}; thin lines every {} {}",
                    spec.tolerance,
                    spec.unit(),
                    self.level_step(),
                    spec.unit()
                ),
                format!(
                    "limited by P posture, C collision, T tension, E exhaust; {}: the envelope's cap{}",
                    if accelerates {
                        "a acceleration bound"
                    } else {
                        "n load factor, w body rate"
                    },
                    if pull_up {
                        "; thick line: 0.10 rad/s, the paper's advice"
                    } else {
                        ""
                    }
                ),
            ]
            .into_iter()
            .chain(
                (!self.cells.iter().all(|c| c.inside_envelope))
                    .then(|| "*: outside the declared envelope (its dynamic-pressure bound), mapped for information".to_owned()),
            )
            .collect(),
            x_label: "Mach".to_owned(),
            y_label: "altitude [m]".to_owned(),
            columns: spec.machs.iter().map(|m| format!("{m}")).collect(),
            rows: spec
                .altitudes_m
                .iter()
                .rev()
                .map(|h| format!("{h}"))
                .collect(),
            values: rows
                .iter()
                .map(|r| r.iter().map(|c| c.limit).collect())
                .collect(),
            marks: rows
                .iter()
                .map(|r| {
                    r.iter()
                        .map(|c| {
                            let outside = if c.inside_envelope { "" } else { "*" };
                            format!("{}{outside}", c.limiting.mark())
                        })
                        .collect()
                })
                .collect(),
            decimals: if accelerates { 2 } else { 3 },
            contour: pull_up.then_some(0.10),
            levels: self.levels(),
        }
    }

    /// The heat map's iso-line step: 0.05 rad/s, or 2 m/s^2.
    fn level_step(&self) -> f64 {
        if self.spec.manoeuvre == Manoeuvre::Acceleration {
            2.0
        } else {
            0.05
        }
    }

    /// The heat map's iso-lines: multiples of [`EnvelopeMap::level_step`] up
    /// to the largest limit (the pull-up's 0.10 is its thick contour).
    fn levels(&self) -> Vec<f64> {
        let step = self.level_step();
        let top = self.cells.iter().map(|c| c.limit).fold(0.0, f64::max);
        (1..)
            .map(|k| (f64::from(k) * step * 1e6).round() / 1e6)
            .take_while(|&level| level <= top)
            .filter(|&level| !(self.spec.manoeuvre == Manoeuvre::PullUp && level == 0.10))
            .collect()
    }

    /// The onboard look-ahead's advisories over the map, in words: how many
    /// of the cells' violations (at the smallest violating rate) were
    /// advised at least 1 s ahead, later, or not at all, and the false
    /// advisories in the runs that stayed clear.
    pub fn advisories(&self) -> String {
        let inside: Vec<&Cell> = self.cells.iter().filter(|c| c.inside_envelope).collect();
        let violated: Vec<&Cell> = inside
            .iter()
            .copied()
            .filter(|c| c.advised.is_some())
            .collect();
        let ahead = violated
            .iter()
            .filter(|c| c.advisory_lead_s.is_some_and(|l| l >= 1.0))
            .count();
        let late = violated
            .iter()
            .filter(|c| c.advisory_lead_s.is_some_and(|l| l < 1.0))
            .count();
        let missed = violated.iter().filter(|c| c.advised == Some(false)).count();
        let clear: u32 = inside.iter().map(|c| c.clear_runs).sum();
        let advised_clear: u32 = inside.iter().map(|c| c.advised_clear_runs).sum();
        let false_advisories: u32 = inside.iter().map(|c| c.false_advisories).sum();
        let nuisance: u32 = inside.iter().map(|c| c.nuisance_advisories).sum();
        let cells_false = inside.iter().filter(|c| c.false_advisories > 0).count();
        let outside = self.cells.len() - inside.len();
        format!(
            "Advisories (the onboard controller: its look-ahead{}), over the {} cells inside the declared envelope: of {} cells' violations (at the smallest violating rate), {ahead} advised at least 1 s ahead, {late} less than 1 s ahead, {missed} not advised; of {clear} runs that stayed clear, {advised_clear} were advised against, {false_advisories} falsely (the manoeuvre continued to the horizon stays clear; {cells_false} cells), {nuisance} of them without even reaching the warning level{}\n",
            if self.onboard_map {
                " and the envelope map on board"
            } else {
                " alone: no envelope map on board made for this configuration"
            },
            inside.len(),
            violated.len(),
            if outside > 0 {
                format!(" ({outside} cells outside it not counted)")
            } else {
                String::new()
            }
        )
    }

    /// The map in words: per altitude a line of the limits over Mach (with the
    /// limiting requirement's initial), and where the paper's 0.10 rad/s
    /// pull-up advice holds.
    pub fn summary(&self) -> String {
        let spec = &self.spec;
        let accelerates = spec.manoeuvre == Manoeuvre::Acceleration;
        let mut out = format!(
            "{} envelope: largest {} clear of every requirement, {} ({}, {}, to {} {}); P posture, C collision, T tension, E exhaust, {}\n",
            spec.manoeuvre.name(),
            if accelerates {
                "along-path acceleration"
            } else {
                "rate"
            },
            spec.unit(),
            spec.describe_model(),
            spec.describe_manoeuvre(),
            spec.tolerance,
            spec.unit(),
            if accelerates {
                "a acceleration bound"
            } else {
                "n load factor, w body rate"
            }
        );
        out.push_str("altitude \\ Mach");
        for m in &spec.machs {
            out.push_str(&format!(" {m:>9}"));
        }
        out.push('\n');
        for (row, h) in self.cells.chunks(spec.machs.len()).zip(&spec.altitudes_m) {
            out.push_str(&format!("{:>13} m", h));
            for c in row {
                if accelerates {
                    out.push_str(&format!(" {:>7.2} {}", c.limit, c.limiting.mark()));
                } else {
                    out.push_str(&format!(" {:>7.3} {}", c.limit, c.limiting.mark()));
                }
            }
            out.push('\n');
        }
        let outside: Vec<String> = self
            .cells
            .iter()
            .filter(|c| !c.inside_envelope)
            .map(|c| format!("{} m Mach {}", c.altitude_m, c.mach))
            .collect();
        if !outside.is_empty() {
            out.push_str(&format!(
                "Outside the declared envelope (its dynamic-pressure bound), mapped for information: {}\n",
                outside.join(", ")
            ));
        }
        out.push_str(&self.advisories());
        if spec.manoeuvre == Manoeuvre::PullUp {
            let holds = self.cells.iter().filter(|c| c.limit >= 0.10).count();
            out.push_str(&format!(
                "The paper's advice (pull-up rate below 0.10 rad/s keeps clear) holds in {holds} of {} cells",
                self.cells.len()
            ));
            let short: Vec<String> = self
                .cells
                .iter()
                .filter(|c| c.limit < 0.10)
                .map(|c| format!("{} m Mach {}", c.altitude_m, c.mach))
                .collect();
            if short.is_empty() {
                out.push_str(".\n");
            } else {
                out.push_str(&format!(
                    "; 0.10 rad/s is not clear at {}.\n",
                    short.join(", ")
                ));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> EnvelopeSpec {
        EnvelopeSpec {
            manoeuvre: Manoeuvre::PullUp,
            altitudes_m: vec![3000.0, 9000.0],
            machs: vec![0.6, 0.8],
            segments: 12,
            grading: 1.26,
            onset_s: 0.5,
            tolerance: 0.01,
            mach_gain: None,
        }
    }

    /// Flies a requirement-limited cell's limit again (clear) and the limit
    /// plus the tolerance (violating `r`'s cell).
    fn assert_bisected(
        config: &SystemConfig,
        spec: &EnvelopeSpec,
        manoeuvre: &Scenario,
        c: &Cell,
        r: Requirement,
    ) {
        let condition = (c.altitude_m, c.mach);
        let clear = fly(config, spec, manoeuvre, condition, Some(c.limit), None).unwrap();
        assert_eq!(clear.violated, None, "{c:?}");
        let above = (c.limit + spec.tolerance).min(c.cap);
        let over = fly(config, spec, manoeuvre, condition, Some(above), None).unwrap();
        assert!(
            over.violated.is_some(),
            "{c:?}: {r:?} not violated at {above}"
        );
    }

    fn out(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("decoy-envelope-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    /// The map is the same whatever the workers; a cell's limit is clear and
    /// the next rate up by the tolerance is not (flown again independently);
    /// a map resumes from the cells it finds and refuses a directory of other
    /// inputs.
    #[test]
    fn the_map_is_deterministic_bisected_and_resumable() {
        let config = SystemConfig::builtin().unwrap();
        let spec = spec();
        let none = |_: usize, _: usize| {};
        let one = map_envelope(&config, &spec, 1, None, &none).unwrap();
        let dir = out("resume");
        let two = map_envelope(&config, &spec, 2, Some(&dir), &none).unwrap();
        assert_eq!(one.cells, two.cells);
        assert_eq!(two.resumed, 0);
        let manoeuvre = Scenario::builtin("pull-up").unwrap();
        for c in &one.cells {
            assert!(c.limit <= c.cap && c.runs >= 2, "{c:?}");
            // A violation was met (and its advisory judged) exactly when a
            // requirement limits; the tallies are of the cell's runs.
            assert_eq!(
                c.advised.is_some(),
                matches!(c.limiting, Limit::Requirement(_)),
                "{c:?}"
            );
            assert_eq!(c.advised == Some(true), c.advisory_lead_s.is_some());
            assert!(
                c.nuisance_advisories <= c.false_advisories
                    && c.false_advisories <= c.advised_clear_runs
                    && c.advised_clear_runs <= c.clear_runs
                    && c.clear_runs <= c.runs
            );
            if let Limit::Requirement(r) = c.limiting {
                assert_bisected(&config, &spec, &manoeuvre, c, r);
            }
        }
        // Remove a cell: the next run maps it again and takes the others.
        std::fs::remove_file(cell_path(&dir, (9000.0, 0.8))).unwrap();
        let counted = AtomicUsize::new(0);
        let count = |done: usize, _: usize| {
            counted.store(done, Ordering::Relaxed);
        };
        let resumed = map_envelope(&config, &spec, 2, Some(&dir), &count).unwrap();
        assert_eq!(resumed.resumed, 3);
        assert_eq!(resumed.cells, one.cells);
        assert_eq!(counted.load(Ordering::Relaxed), 4);
        // Other inputs: an error, the directory untouched.
        let other = EnvelopeSpec {
            onset_s: 0.25,
            ..spec.clone()
        };
        let e = map_envelope(&config, &other, 1, Some(&dir), &none).unwrap_err();
        assert!(e.to_string().contains("a map of other inputs"), "{e}");
        assert_eq!(
            map_envelope(&config, &spec, 1, Some(&dir), &none)
                .unwrap()
                .resumed,
            4
        );
        // The summary marks the limits and the paper's advice.
        let text = one.summary();
        assert!(text.contains("The paper's advice"), "{text}");
        // The test's configuration is the built-in one, its map on board.
        assert!(
            text.contains(
                "Advisories (the onboard controller: its look-ahead and the envelope map on board), over the 4 cells inside the declared envelope: of 4 cells"
            ),
            "{text}"
        );
        assert_eq!(one.csv().lines().count(), 5);
    }

    /// The acceleration map: defaults (Mach numbers the gain below the upper
    /// one, the tolerance in m/s^2), a limit clear and the next acceleration
    /// up violating, the final speed's steady flight taken into account, the
    /// outputs in m/s^2, and a Plan's cell the same as the map's.
    #[test]
    fn the_acceleration_map_bisects_the_acceleration() {
        let config = SystemConfig::builtin().unwrap();
        let defaults = EnvelopeSpec::new(
            &config,
            Manoeuvre::Acceleration,
            &EnvelopeRequest::default(),
        )
        .unwrap();
        assert_eq!(defaults.machs, vec![0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.85]);
        assert_eq!(defaults.mach_gain, Some(0.1));
        assert_eq!(defaults.tolerance, DEFAULT_ACCELERATION_TOLERANCE);
        assert_eq!(defaults.final_mach(&config, 9000.0, 0.85), Some(0.95));
        // Low down the dynamic-pressure bound caps it (sea level: Mach 0.805);
        // from beyond it, the Mach range's upper end.
        let top = config.max_mach_at(0.0).unwrap();
        assert!((top - 0.8053).abs() < 1e-3, "{top}");
        assert_eq!(defaults.final_mach(&config, 0.0, 0.75), Some(top));
        assert_eq!(defaults.final_mach(&config, 0.0, 0.85), Some(0.95));
        assert!(inside_envelope(&config, 0.0, 0.8));
        assert!(!inside_envelope(&config, 0.0, 0.81));
        assert!(inside_envelope(&config, 3000.0, 0.95));
        assert!(!inside_envelope(&config, 3000.0, 0.96));
        let gain = |g: f64| {
            EnvelopeSpec::new(
                &config,
                Manoeuvre::Acceleration,
                &EnvelopeRequest {
                    mach_gain: Some(g),
                    ..EnvelopeRequest::default()
                },
            )
        };
        assert_eq!(gain(0.0001).unwrap().machs.last(), Some(&0.949));
        assert_eq!(gain(0.25).unwrap().machs.last(), Some(&0.7));
        let e = gain(0.7).unwrap_err().to_string();
        assert!(e.contains("--mach-gain 0.7 leaves no Mach number"), "{e}");
        let spec = EnvelopeSpec::new(
            &config,
            Manoeuvre::Acceleration,
            &EnvelopeRequest {
                altitudes_m: Some(vec![0.0, 9000.0, 15000.0]),
                machs: Some(vec![0.3, 0.85]),
                segments: Some(12),
                grading: Some(1.26),
                tolerance: Some(0.5),
                ..EnvelopeRequest::default()
            },
        )
        .unwrap();
        let none = |_: usize, _: usize| {};
        let map = map_envelope(&config, &spec, 2, None, &none).unwrap();
        let manoeuvre = Scenario::builtin("acceleration").unwrap();
        let mut bisected = 0;
        for c in &map.cells {
            assert!(c.limit <= c.cap && c.cap == 10.0, "{c:?}");
            if let (Limit::Requirement(r), true) = (c.limiting, c.limit > 0.0) {
                bisected += 1;
                assert_bisected(&config, &spec, &manoeuvre, c, r);
            }
        }
        // 15 km, Mach 0.3: the posture limits below the bound (9.26 m/s^2 at
        // 300 segments, docs/envelope.md): a bisected cell, flown again above.
        assert_eq!(bisected, 1, "{:?}", map.cells);
        assert_eq!(
            map.cells[4].limiting,
            Limit::Requirement(Requirement::Posture)
        );
        // Sea level, Mach 0.85 to 0.95: the tension is violated in steady
        // flight at Mach 0.95 (docs/envelope.md), so no acceleration is clear.
        let sea = &map.cells[1];
        assert_eq!(
            (sea.limit, sea.limiting),
            (0.0, Limit::Requirement(Requirement::Tension)),
            "{sea:?}"
        );
        assert!(sea.steady_margins.tension.unwrap() > 0.0, "{sea:?}");
        assert!(
            map.csv()
                .starts_with("altitude_m,mach,limit_mps2,cap_mps2,")
        );
        let json = map.json();
        assert_eq!(json["limit_unit"], "m/s^2");
        assert_eq!(json["mach_gain"], 0.1);
        assert!(map.summary().contains("largest along-path acceleration"));
        // A cell mapped from the plan (another engine's worker) is the map's.
        let plan = EnvelopePlan::from_json(
            &EnvelopePlan::new(&config, &spec)
                .unwrap()
                .to_json()
                .unwrap(),
        )
        .unwrap();
        assert_eq!(map_cell(&plan, 4).unwrap(), map.cells[4]);
        assert!(
            map_cell(&plan, 6)
                .unwrap_err()
                .to_string()
                .contains("outside the grid of 6 cells")
        );
    }

    /// An advisory is judged by the manoeuvre continued to the horizon's end:
    /// one in steady flight or before the pull-up is false (level flight
    /// stays clear); one in the climb after a 0.16 rad/s pull-up (the
    /// look-ahead's, at 7.93 s: the cable enters the plume at 9.91 s) comes
    /// true, and the same after a 0.05 rad/s pull-up does not.
    #[test]
    fn advisories_are_judged_by_the_manoeuvre_continued() {
        let config = SystemConfig::builtin().unwrap();
        let spec = spec();
        let pull_up = Scenario::builtin("pull-up").unwrap();
        let steady = Scenario::builtin("steady").unwrap();
        let scenarios = (&pull_up, &steady);
        let condition = (9000.0, 0.6);
        let judge = |rate: Option<f64>, at: f64| {
            advisory_confirmed(
                &config,
                &spec,
                scenarios,
                condition,
                rate,
                (at, Requirement::Exhaust),
            )
            .unwrap()
        };
        assert_eq!(judge(None, 0.5), Judgement::Nuisance);
        // Before the rotation starts (t = 2 s): level flight continued.
        assert_eq!(judge(Some(0.16), 1.0), Judgement::Nuisance);
        assert_eq!(judge(Some(0.16), 7.93), Judgement::Confirmed);
        assert_eq!(judge(Some(0.05), 7.93), Judgement::Nuisance);
    }

    #[test]
    fn bad_specs_are_typed_errors() {
        let config = SystemConfig::builtin().unwrap();
        let none = |_: usize, _: usize| {};
        for (spec, message) in [
            (
                EnvelopeSpec {
                    manoeuvre: Manoeuvre::Steady,
                    ..spec()
                },
                "--manoeuvre must be pull-up, turn or acceleration, got steady",
            ),
            (
                EnvelopeSpec {
                    machs: vec![],
                    ..spec()
                },
                "at least one altitude and one Mach number",
            ),
            (
                EnvelopeSpec {
                    tolerance: 0.0,
                    ..spec()
                },
                "tolerance must be positive",
            ),
            (
                EnvelopeSpec {
                    onset_s: f64::NAN,
                    ..spec()
                },
                "--onset must be a non-negative number of seconds, got NaN",
            ),
            (
                EnvelopeSpec {
                    mach_gain: Some(0.1),
                    ..spec()
                },
                "--mach-gain applies to an acceleration, not to a pull-up",
            ),
            (
                EnvelopeSpec {
                    manoeuvre: Manoeuvre::Acceleration,
                    mach_gain: Some(0.1),
                    machs: vec![0.6, 0.95],
                    ..spec()
                },
                "must be below the envelope's upper Mach 0.95",
            ),
            (
                EnvelopeSpec {
                    manoeuvre: Manoeuvre::Acceleration,
                    mach_gain: Some(-0.1),
                    ..spec()
                },
                "--mach-gain must be positive, got -0.1",
            ),
        ] {
            let e = map_envelope(&config, &spec, 1, None, &none).unwrap_err();
            assert!(e.to_string().contains(message), "{e}");
        }
        let onset = EnvelopeSpec::new(
            &config,
            Manoeuvre::Acceleration,
            &EnvelopeRequest {
                onset_s: Some(0.5),
                ..EnvelopeRequest::default()
            },
        )
        .unwrap_err();
        assert!(
            onset
                .to_string()
                .contains("--onset applies to a pull-up or a turn"),
            "{onset}"
        );
        // A Mach the solver rejects: the cell named.
        let e = map_envelope(
            &config,
            &EnvelopeSpec {
                machs: vec![2.5],
                altitudes_m: vec![9000.0],
                ..spec()
            },
            1,
            None,
            &none,
        )
        .unwrap_err();
        assert!(e.to_string().contains("9000 m, Mach 2.5"), "{e}");
    }
}
