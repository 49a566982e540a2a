//! Scenario files: what the aircraft does and for how long.
//!
//! A scenario is a small TOML file (`scenarios/*.toml` in the repository; the
//! shipped ones are embedded, so `--scenario acceleration` works from any
//! directory): its `name`, a `description` for people, its `kind` (one of
//! `decoy_schema`'s manoeuvres by name, or `recorded`), the parameters the kind
//! takes (a manoeuvre's are `decoy_schema::ManoeuvreInfo::parameters`, each key
//! `decoy_schema::Parameter::key`; a recorded flight's is its CSV `file`,
//! relative to the scenario file), the simulated time `t_end_s`, and optionally
//! the RK4 step `dt_s`, the `segments` and their `grading`. docs/outputs.md,
//! "Scenarios", documents every key; unknown keys are errors, and so are
//! keys the kind does not take.
//!
//! The command line's flags override the file's values ([`crate::RunOptions`]).
//! [`Scenario::plan`] checks everything and builds the run's flight profile.

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_schema::{Manoeuvre, Need, Parameter};
use serde::{Deserialize, Serialize};
use solver_core::SegmentLayout;
use solver_core::profiles::{ManoeuvreParams, ManoeuvrePath};

use crate::error::SimError;
use crate::flyable::{Flyable, FlyablePullUp, FlyableTurn};
use crate::format::format_number;
use crate::options::RunOptions;
use crate::profile::FlightProfile;
use crate::recorded::RecordedFlight;
use crate::steps::{StepRule, Timeline};

/// The shipped scenarios: name and TOML text (embedded from `scenarios/`).
pub const BUILTIN_SCENARIOS: [(&str, &str); 5] = [
    ("steady", include_str!("../../../scenarios/steady.toml")),
    (
        "acceleration",
        include_str!("../../../scenarios/acceleration.toml"),
    ),
    ("pull-up", include_str!("../../../scenarios/pull-up.toml")),
    ("turn", include_str!("../../../scenarios/turn.toml")),
    ("recorded", include_str!("../../../scenarios/recorded.toml")),
];

/// The shipped recorded-flight example (`scenarios/recorded-example.csv`), which
/// the built-in `recorded` scenario uses.
pub const RECORDED_EXAMPLE_CSV: &str = include_str!("../../../scenarios/recorded-example.csv");
/// The file name the built-in `recorded` scenario refers to.
pub const RECORDED_EXAMPLE_NAME: &str = "recorded-example.csv";

pub use crate::capacity::MAX_SEGMENTS;
/// Altitude range accepted, m (the ISA 1976 model's range above sea level).
pub const ALTITUDE_RANGE_M: (f64, f64) = (0.0, 20_000.0);
/// Largest Mach number accepted.
pub const MAX_MACH: f64 = 2.0;
/// Largest flight-path rotation rate accepted, rad/s.
pub const MAX_RATE_RADPS: f64 = 1.0;
/// Most RK4 steps one run may take.
pub const MAX_STEPS: f64 = 1e9;
/// Grading ratios accepted (the solver's range).
pub const GRADING_RANGE: (f64, f64) = (1.0, 10.0);

/// What the aircraft does: one of `decoy_schema`'s manoeuvres, or a recorded
/// flight. A scenario file names it (`kind = "pull-up"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScenarioKind {
    /// A prescribed manoeuvre, flown by solver-core's profile.
    Manoeuvre(Manoeuvre),
    /// A recorded flight from a CSV file.
    Recorded,
}

/// The name of [`ScenarioKind::Recorded`].
const RECORDED: &str = "recorded";

/// The number of scenario kinds.
const KIND_COUNT: usize = Manoeuvre::ALL.len() + 1;

impl ScenarioKind {
    /// Every kind: the manoeuvres in their order, then a recorded flight.
    pub const ALL: [ScenarioKind; KIND_COUNT] = {
        let mut all = [ScenarioKind::Recorded; KIND_COUNT];
        let mut i = 0;
        while i < Manoeuvre::ALL.len() {
            all[i] = ScenarioKind::Manoeuvre(Manoeuvre::ALL[i]);
            i += 1;
        }
        all
    };

    /// The name used in scenario files (`pull-up`, ...).
    pub const fn name(self) -> &'static str {
        match self {
            ScenarioKind::Manoeuvre(m) => m.name(),
            ScenarioKind::Recorded => RECORDED,
        }
    }

    /// One line for people.
    pub const fn help(self) -> &'static str {
        match self {
            ScenarioKind::Manoeuvre(m) => m.help(),
            ScenarioKind::Recorded => "A recorded flight from a CSV file",
        }
    }

    /// The kind of that name, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The manoeuvre, unless a recorded flight.
    pub const fn manoeuvre(self) -> Option<Manoeuvre> {
        match self {
            ScenarioKind::Manoeuvre(m) => Some(m),
            ScenarioKind::Recorded => None,
        }
    }

    /// Whether a scenario of this kind needs a manoeuvre's `parameter`, or
    /// `None` when it does not take it.
    pub const fn need(self, parameter: Parameter) -> Option<Need> {
        match self {
            ScenarioKind::Manoeuvre(m) => m.need(parameter),
            ScenarioKind::Recorded => None,
        }
    }
}

/// Every kind's name, for serde's messages (`unknown variant ..., expected one
/// of ...`).
const KIND_NAMES: [&str; KIND_COUNT] = {
    let mut names = [""; KIND_COUNT];
    let mut i = 0;
    while i < KIND_COUNT {
        names[i] = ScenarioKind::ALL[i].name();
        i += 1;
    }
    names
};

/// As a unit variant named [`ScenarioKind::name`], as serde derives it for an
/// enum of unit variants in kebab case (so TOML's messages are the same).
impl Serialize for ScenarioKind {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let index = ScenarioKind::ALL
            .iter()
            .position(|k| k == self)
            .unwrap_or_default();
        serializer.serialize_unit_variant("ScenarioKind", index as u32, self.name())
    }
}

impl<'de> Deserialize<'de> for ScenarioKind {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::{self, EnumAccess, Unexpected, VariantAccess, Visitor};
        use std::fmt;

        /// A variant, by name or index.
        struct Field(ScenarioKind);
        impl<'de> Deserialize<'de> for Field {
            fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                struct FieldVisitor;
                impl Visitor<'_> for FieldVisitor {
                    type Value = Field;
                    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                        f.write_str("variant identifier")
                    }
                    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Field, E> {
                        usize::try_from(v)
                            .ok()
                            .and_then(|i| ScenarioKind::ALL.get(i))
                            .map(|k| Field(*k))
                            .ok_or_else(|| {
                                E::invalid_value(
                                    Unexpected::Unsigned(v),
                                    &format!("variant index 0 <= i < {KIND_COUNT}").as_str(),
                                )
                            })
                    }
                    fn visit_str<E: de::Error>(self, v: &str) -> Result<Field, E> {
                        ScenarioKind::from_name(v)
                            .map(Field)
                            .ok_or_else(|| E::unknown_variant(v, &KIND_NAMES))
                    }
                    fn visit_bytes<E: de::Error>(self, v: &[u8]) -> Result<Field, E> {
                        match std::str::from_utf8(v) {
                            Ok(v) => self.visit_str(v),
                            Err(_) => {
                                Err(E::unknown_variant(&String::from_utf8_lossy(v), &KIND_NAMES))
                            }
                        }
                    }
                }
                deserializer.deserialize_identifier(FieldVisitor)
            }
        }

        struct KindVisitor;
        impl<'de> Visitor<'de> for KindVisitor {
            type Value = ScenarioKind;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("enum ScenarioKind")
            }
            fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<ScenarioKind, A::Error> {
                let (Field(kind), variant) = data.variant()?;
                variant.unit_variant()?;
                Ok(kind)
            }
        }

        deserializer.deserialize_enum("ScenarioKind", &KIND_NAMES, KindVisitor)
    }
}

/// Where a scenario came from (for messages and to resolve its `file`).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum ScenarioOrigin {
    /// One of [`BUILTIN_SCENARIOS`].
    Builtin(String),
    /// A file.
    File(PathBuf),
    /// Text given directly ([`Scenario::from_toml`]); `file` paths resolve
    /// against the working directory.
    #[default]
    Text,
}

impl ScenarioOrigin {
    /// How messages name it.
    pub fn describe(&self) -> String {
        match self {
            ScenarioOrigin::Builtin(name) => format!("built-in scenario {name}.toml"),
            ScenarioOrigin::File(path) => path.display().to_string(),
            ScenarioOrigin::Text => "scenario".to_owned(),
        }
    }
}

/// A scenario file's contents (see the module docs for the keys).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name; also the default output directory `out/<name>`.
    pub name: String,
    /// One line for people.
    #[serde(default)]
    pub description: String,
    /// What the aircraft does.
    pub kind: ScenarioKind,
    /// Initial altitude, m.
    pub altitude_m: Option<f64>,
    /// Initial Mach number.
    pub mach: Option<f64>,
    /// Final Mach number (acceleration).
    pub final_mach: Option<f64>,
    /// Start of the acceleration, s.
    pub accel_start_s: Option<f64>,
    /// Along-track acceleration magnitude, m/s^2.
    pub acceleration_mps2: Option<f64>,
    /// Flight-path rotation rate, rad/s (pull-up, turn).
    pub rate_radps: Option<f64>,
    /// Start of the rotation, s (pull-up, turn).
    pub start_s: Option<f64>,
    /// Duration of the rotation, s (pull-up).
    pub duration_s: Option<f64>,
    /// Time to build (and, for the pull-up, to remove) the rotation rate, s
    /// (pull-up, turn; [`crate::flyable`]); none or 0: the paper's step in
    /// the rate.
    #[serde(default)]
    pub onset_s: Option<f64>,
    /// Recorded-flight CSV, relative to the scenario file (recorded).
    pub file: Option<String>,
    /// Simulated time, s.
    pub t_end_s: f64,
    /// RK4 time step, s.
    pub dt_s: Option<f64>,
    /// Number of cable segments.
    pub segments: Option<usize>,
    /// Segment length ratio (1 = uniform).
    pub grading: Option<f64>,
    /// Where the scenario came from.
    #[serde(skip)]
    pub origin: ScenarioOrigin,
}

/// Everything a run needs, checked: produced by [`Scenario::plan`].
#[derive(Clone, Debug, PartialEq)]
pub struct RunPlan {
    /// Scenario name.
    pub name: String,
    /// Scenario kind.
    pub kind: ScenarioKind,
    /// The aircraft's trajectory.
    pub profile: FlightProfile,
    /// Cable discretisation.
    pub layout: SegmentLayout<f64>,
    /// Where the RK4 steps end: the step rule, the output times, the profile's
    /// breakpoints and the end ([`crate::steps`]).
    pub timeline: Timeline,
    /// Simulated time, s (the run ends at exactly this time).
    pub t_end: f64,
    /// +1 when the reported lateral offset is positive to the left of the flight
    /// path, -1 when positive to the right (left turns, so that the outside of the
    /// turn is positive).
    pub lateral_sign: f64,
}

impl RunPlan {
    /// The flight condition the run starts from, in words, as flown (after the
    /// command line's overrides): `Mach 0.600 at 9000 m (182.31 m/s airspeed)`,
    /// with the rotation rate for a pull-up or turn.
    pub fn describe_initial_condition(&self, config: &SystemConfig) -> String {
        let aircraft = self.profile.initial_condition();
        let altitude = aircraft.altitude();
        let wind = nalgebra::Vector3::from(config.environment.wind_ned);
        let airspeed = (aircraft.velocity - wind).norm();
        let mach = match config.speed_of_sound(altitude) {
            Ok(a) => format!("Mach {:.3}", airspeed / a),
            Err(_) => "Mach unknown".to_owned(),
        };
        let mut text = format!("{mach} at {altitude:.0} m ({airspeed:.2} m/s airspeed)");
        // A rotating manoeuvre's rate, in its own words (`turning at ...`).
        let rotation = match &self.profile {
            FlightProfile::Manoeuvre(path) => path.rate().map(|rate| (rate, None)),
            FlightProfile::Flyable(path) => Some((path.rate(), Some(path.onset()))),
            FlightProfile::Recorded(_) => None,
        };
        if let (Some(manoeuvre), Some((rate, onset))) = (self.kind.manoeuvre(), rotation)
            && let Some(words) = manoeuvre.info().rotation
        {
            text.push_str(&format!(
                ", {words} at {} rad/s from t = {} s",
                format_number(rate),
                format_number(self.profile.manoeuvre_start())
            ));
            if let Some(onset) = onset {
                text.push_str(&format!(" (built over {} s)", format_number(onset)));
            }
        }
        text
    }
}

impl Scenario {
    /// The names of the shipped scenarios.
    pub fn builtin_names() -> Vec<String> {
        BUILTIN_SCENARIOS
            .iter()
            .map(|(n, _)| (*n).to_owned())
            .collect()
    }

    /// A shipped scenario by name.
    pub fn builtin(name: &str) -> Result<Self, SimError> {
        let (name, text) = BUILTIN_SCENARIOS
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| SimError::UnknownScenario {
                name: name.to_owned(),
                available: Self::builtin_names(),
            })?;
        Self::parse(text, ScenarioOrigin::Builtin((*name).to_owned()))
    }

    /// A scenario file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, SimError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| SimError::Read {
            path: path.to_owned(),
            source,
        })?;
        Self::parse(&text, ScenarioOrigin::File(path.to_owned()))
    }

    /// A scenario from TOML text.
    pub fn from_toml(text: &str) -> Result<Self, SimError> {
        Self::parse(text, ScenarioOrigin::Text)
    }

    /// `--scenario NAME|FILE`: a shipped scenario's name, else the path of a file.
    /// Something that is neither a shipped name nor an existing file is an
    /// [`SimError::UnknownScenario`] listing the shipped names (unless it looks
    /// like a path, `*.toml` or with a `/`: then the read error).
    pub fn load(name_or_path: &str) -> Result<Self, SimError> {
        if BUILTIN_SCENARIOS.iter().any(|(n, _)| *n == name_or_path) {
            return Self::builtin(name_or_path);
        }
        let path = Path::new(name_or_path);
        let looks_like_path = name_or_path.ends_with(".toml")
            || name_or_path.contains('/')
            || name_or_path.contains(std::path::MAIN_SEPARATOR);
        if looks_like_path || path.is_file() {
            return Self::from_file(path);
        }
        Err(SimError::UnknownScenario {
            name: name_or_path.to_owned(),
            available: Self::builtin_names(),
        })
    }

    fn parse(text: &str, origin: ScenarioOrigin) -> Result<Self, SimError> {
        let mut scenario: Scenario =
            toml::from_str(text).map_err(|e| toml_error(&origin.describe(), text, &e))?;
        scenario.origin = origin;
        Ok(scenario)
    }

    /// Applies the overrides of `options`, checks every value, and builds the run
    /// plan (the flight profile is computed with `config`'s atmosphere and gravity;
    /// a recorded flight's CSV is read and validated here).
    pub fn plan(&self, config: &SystemConfig, options: &RunOptions) -> Result<RunPlan, SimError> {
        check_options(options)?;
        let origin = self.origin.describe();
        let invalid = |field: &str, message: String| SimError::invalid(&origin, field, message);
        let kind = self.kind;

        // Overrides that do not apply to this kind are errors, not silently ignored.
        let cli = "command line";
        let applies = |flag: &str, given: bool, ok: bool, kinds: &str| {
            if given && !ok {
                Err(SimError::invalid(
                    cli,
                    flag,
                    format!("does not apply to a {} scenario ({kinds})", kind.name()),
                ))
            } else {
                Ok(())
            }
        };
        let recorded = kind == ScenarioKind::Recorded;
        let rotates = kind.need(Parameter::Rate).is_some();
        applies(
            "--altitude",
            options.altitude.is_some(),
            !recorded,
            "a recorded flight has its own altitude",
        )?;
        applies(
            "--mach",
            options.mach.is_some(),
            !recorded,
            "a recorded flight has its own speed",
        )?;
        applies(
            "--rate",
            options.rate.is_some(),
            rotates,
            &format!("only {} scenarios have a rate", rate_kinds()),
        )?;

        // The keys the kind needs (required) and takes (the manoeuvre's
        // parameters, a recorded flight's file), in Parameter::ALL's order.
        let keys = Parameter::ALL
            .map(|p| (p.key(), self.value(p).is_some(), kind.need(p)))
            .into_iter()
            .chain([(
                "file",
                self.file.is_some(),
                recorded.then_some(Need::Required),
            )]);
        for (key, present, need) in keys {
            if !present && need == Some(Need::Required) {
                return Err(invalid(
                    key,
                    format!("is required for a {} scenario", kind.name()),
                ));
            }
            if present && need.is_none() {
                return Err(invalid(
                    key,
                    format!("does not apply to a {} scenario", kind.name()),
                ));
            }
        }

        let name = self.name.trim();
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
            || name.starts_with('.')
        {
            return Err(invalid(
                "name",
                format!(
                    "must be letters, digits, `-`, `_` or `.` (it names the output directory), got `{}`",
                    self.name
                ),
            ));
        }

        // Values: overrides first (already checked), then the file's, then the
        // configuration's; each error names where its value came from.
        let from_file = |field: &str| Source::new(&origin, field);
        let from_config = |field: &str| Source::new(&config.source, field);
        let (t_end, t_end_source) = match options.t_end {
            Some(t) => (t, Source::new(cli, "--t-end")),
            None => (self.t_end_s, from_file("t_end_s")),
        };
        t_end_source.check(check_positive, t_end)?;
        // The step: a fixed one from the command line or the file, else the
        // adaptive rule bounded by the configuration's longest step.
        let fixed = match (options.dt, self.dt_s) {
            (Some(dt), _) => Some((dt, Source::new(cli, "--dt"))),
            (None, Some(dt)) => Some((dt, from_file("dt_s"))),
            (None, None) => None,
        };
        let rule = match fixed {
            Some((dt, dt_source)) => {
                dt_source.check(check_positive, dt)?;
                if dt > t_end {
                    return Err(dt_source.invalid(format!(
                        "{} s is longer than the simulated time {} s ({})",
                        format_number(dt),
                        format_number(t_end),
                        t_end_source.describe()
                    )));
                }
                let steps = (t_end / dt * (1.0 - 1e-12)).ceil();
                if steps > MAX_STEPS {
                    return Err(t_end_source.invalid(format!(
                        "{} s asks for {steps:.1e} steps of {} s ({}), more than {}",
                        format_number(t_end),
                        format_number(dt),
                        dt_source.describe(),
                        format_number(MAX_STEPS)
                    )));
                }
                StepRule::Fixed { dt }
            }
            None => StepRule::Adaptive,
        };
        let (segments, segments_source) = match (options.segments, self.segments) {
            (Some(n), _) => (n, Source::new(cli, "--segments")),
            (None, Some(n)) => (n, from_file("segments")),
            (None, None) => (
                config.solver.segments_host,
                from_config("solver.segments_host"),
            ),
        };
        check_segments(
            &|f, m| segments_source.invalid_as(f, m),
            &segments_source.field,
            segments,
        )?;
        let grading = options.grading.or(self.grading).unwrap_or(1.0);
        check_grading(&invalid, "grading", grading)?;
        let layout = if grading == 1.0 {
            SegmentLayout::Uniform { count: segments }
        } else {
            SegmentLayout::Graded {
                count: segments,
                ratio: grading,
            }
        };

        let altitude = options.altitude.or(self.altitude_m);
        let mach = options.mach.or(self.mach);
        let rate = options.rate.or(self.rate_radps);
        let speed = |mach: f64, key: &str| -> Result<f64, SimError> {
            check_mach(&invalid, key, mach)?;
            let h = altitude.unwrap_or(0.0);
            Ok(config.mach_to_speed(h, mach)?)
        };
        if let Some(h) = altitude {
            check_altitude(&invalid, "altitude_m", h)?;
        }
        if let Some(w) = rate {
            check_rate(&invalid, "rate_radps", w)?;
        }
        let onset = match (options.onset, self.onset_s) {
            (Some(t), _) => Some((t, Source::new(cli, "--onset"))),
            (None, Some(t)) => Some((t, from_file("onset_s"))),
            (None, None) => None,
        };
        if let Some((t, source)) = &onset {
            source.check(check_non_negative, *t)?;
        }
        let mut lateral_sign = 1.0;
        let profile = match kind {
            ScenarioKind::Manoeuvre(manoeuvre) => {
                // The overrides' values, else the file's.
                let value = |p: Parameter| match p {
                    Parameter::Altitude => altitude,
                    Parameter::Mach => mach,
                    Parameter::Rate => rate,
                    _ => self.value(p),
                };
                let params = manoeuvre_params(
                    manoeuvre,
                    &value,
                    config.environment.gravity,
                    &speed,
                    &invalid,
                )?;
                let path = ManoeuvrePath::new(manoeuvre, &params);
                if path.turns_left() {
                    lateral_sign = -1.0;
                }
                flown_with_onset(path, onset)?
            }
            ScenarioKind::Recorded => {
                if let Some((_, source)) = &onset {
                    return Err(source.invalid(
                        "applies to a pull-up or a turn, not a recorded flight".to_owned(),
                    ));
                }
                let file = self.file.as_deref().unwrap_or_default();
                let flight = self.load_recording(file)?;
                flight.check_mach(config, MAX_MACH)?;
                let duration = flight.duration();
                if t_end > duration * (1.0 + 1e-12) {
                    return Err(SimError::invalid(
                        if options.t_end.is_some() {
                            cli
                        } else {
                            &origin
                        },
                        if options.t_end.is_some() {
                            "--t-end"
                        } else {
                            "t_end_s"
                        },
                        format!(
                            "{} s is longer than the recording `{file}` ({} s)",
                            format_number(t_end),
                            format_number(duration)
                        ),
                    ));
                }
                FlightProfile::Recorded(flight)
            }
        };
        let profile_breakpoints = profile.breakpoints(t_end);
        Ok(RunPlan {
            name: name.to_owned(),
            kind,
            profile,
            layout,
            timeline: Timeline::new(rule, profile_breakpoints, t_end),
            t_end,
            lateral_sign,
        })
    }

    /// The file's value of a manoeuvre's `parameter`.
    fn value(&self, parameter: Parameter) -> Option<f64> {
        match parameter {
            Parameter::Altitude => self.altitude_m,
            Parameter::Mach => self.mach,
            Parameter::FinalMach => self.final_mach,
            Parameter::AccelerationStart => self.accel_start_s,
            Parameter::Acceleration => self.acceleration_mps2,
            Parameter::Rate => self.rate_radps,
            Parameter::Start => self.start_s,
            Parameter::Duration => self.duration_s,
        }
    }

    /// Reads the recording `file`: the embedded example for the built-in
    /// scenario, else relative to the scenario file's directory.
    fn load_recording(&self, file: &str) -> Result<RecordedFlight, SimError> {
        if file.trim().is_empty() {
            return Err(SimError::invalid(
                self.origin.describe(),
                "file",
                "must name the recorded-flight CSV",
            ));
        }
        let path = match &self.origin {
            ScenarioOrigin::Builtin(_) if file == RECORDED_EXAMPLE_NAME => {
                return RecordedFlight::parse(
                    &format!("built-in {RECORDED_EXAMPLE_NAME}"),
                    RECORDED_EXAMPLE_CSV,
                );
            }
            ScenarioOrigin::File(scenario) => scenario
                .parent()
                .unwrap_or_else(|| Path::new("."))
                .join(file),
            _ => PathBuf::from(file),
        };
        let text = std::fs::read_to_string(&path).map_err(|source| SimError::Read {
            path: path.clone(),
            source,
        })?;
        RecordedFlight::parse(&path.display().to_string(), &text)
    }
}

/// The profile that flies `path` with the onset `onset` (and where it was
/// given): the step profile without one (or 0), else the pull-up or the turn
/// built over it ([`crate::flyable`]; a pull-up's onset at most its duration).
fn flown_with_onset(
    path: ManoeuvrePath,
    onset: Option<(f64, Source)>,
) -> Result<FlightProfile, SimError> {
    let Some((onset, source)) = onset.filter(|(t, _)| *t > 0.0) else {
        return Ok(FlightProfile::Manoeuvre(path));
    };
    match path {
        ManoeuvrePath::PullUp(p) if onset > p.duration => Err(source.invalid(format!(
            "{} s is longer than the pull-up's duration {} s (the rate must be built before it is removed)",
            format_number(onset),
            format_number(p.duration)
        ))),
        ManoeuvrePath::PullUp(p) => Ok(FlightProfile::Flyable(Flyable::PullUp(
            FlyablePullUp::new(p, onset),
        ))),
        ManoeuvrePath::Turn(p) => Ok(FlightProfile::Flyable(Flyable::Turn(FlyableTurn::new(
            p, onset,
        )))),
        ManoeuvrePath::Level(_) => Err(source.invalid(
            "applies to a pull-up or a turn, not to level flight or an acceleration".to_owned(),
        )),
    }
}

/// The parameters of `manoeuvre` from `value` (the overrides' and the file's),
/// each checked in [`Parameter::ALL`]'s order (altitude and rate are checked
/// already): Mach numbers become speeds (`speed`); a parameter the manoeuvre
/// does not take stays 0, one it may omit is 0 when omitted.
fn manoeuvre_params(
    manoeuvre: Manoeuvre,
    value: &dyn Fn(Parameter) -> Option<f64>,
    gravity: f64,
    speed: &dyn Fn(f64, &str) -> Result<f64, SimError>,
    invalid: &Invalid<'_>,
) -> Result<ManoeuvreParams, SimError> {
    let mut params = ManoeuvreParams {
        gravity,
        ..ManoeuvreParams::default()
    };
    for parameter in Parameter::ALL {
        if manoeuvre.need(parameter).is_none() {
            continue;
        }
        let key = parameter.key();
        let v = value(parameter).unwrap_or_default();
        match parameter {
            Parameter::Altitude => params.altitude = v,
            Parameter::Rate => params.rate = v,
            Parameter::Mach => params.speed = speed(v, key)?,
            Parameter::FinalMach => params.final_speed = speed(v, key)?,
            Parameter::AccelerationStart | Parameter::Start => {
                check_non_negative(invalid, key, v)?;
                params.start = v;
            }
            Parameter::Acceleration => {
                check_positive(invalid, key, v)?;
                params.acceleration = v;
            }
            Parameter::Duration => {
                check_positive(invalid, key, v)?;
                params.duration = v;
            }
        }
    }
    Ok(params)
}

/// The kinds with a rate, in words: `pull-up and turn`.
fn rate_kinds() -> String {
    let names: Vec<&str> = Manoeuvre::ALL
        .into_iter()
        .filter(|m| m.has_rate())
        .map(Manoeuvre::name)
        .collect();
    match names.split_last() {
        Some((last, [])) => (*last).to_owned(),
        Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
        None => "no".to_owned(),
    }
}

/// Where a value of a run comes from (the command line, a scenario file, the
/// configuration) and under which name, for its error messages.
struct Source {
    /// `command line`, the scenario file, or the configuration file.
    origin: String,
    /// The flag, key or configuration field.
    field: String,
}

impl Source {
    fn new(origin: &str, field: &str) -> Self {
        Source {
            origin: origin.to_owned(),
            field: field.to_owned(),
        }
    }

    /// An [`SimError::InvalidInput`] about this value.
    fn invalid(&self, message: String) -> SimError {
        SimError::invalid(&self.origin, &self.field, message)
    }

    /// The same, for a checker that passes the field back.
    fn invalid_as(&self, _field: &str, message: String) -> SimError {
        self.invalid(message)
    }

    /// Runs `check` on `v` with this source's origin and field.
    fn check(
        &self,
        check: fn(&Invalid<'_>, &str, f64) -> Result<(), SimError>,
        v: f64,
    ) -> Result<(), SimError> {
        check(&|f, m| self.invalid_as(f, m), &self.field, v)
    }

    /// The field and where it is, in words (`--t-end on the command line`,
    /// `t_end_s in steady.toml`).
    fn describe(&self) -> String {
        if self.origin == "command line" {
            format!("{} on the command line", self.field)
        } else {
            format!("{} in {}", self.field, self.origin)
        }
    }
}

/// Checks the command-line overrides, naming the flags.
fn check_options(o: &RunOptions) -> Result<(), SimError> {
    let cli = |field: &str, message: String| SimError::invalid("command line", field, message);
    if let Some(n) = o.segments {
        check_segments(&cli, "--segments", n)?;
    }
    if let Some(r) = o.grading {
        check_grading(&cli, "--grading", r)?;
    }
    if let Some(dt) = o.dt {
        check_positive(&cli, "--dt", dt)?;
    }
    if let Some(t) = o.t_end {
        check_positive(&cli, "--t-end", t)?;
    }
    if let Some(h) = o.altitude {
        check_altitude(&cli, "--altitude", h)?;
    }
    if let Some(m) = o.mach {
        check_mach(&cli, "--mach", m)?;
    }
    if let Some(w) = o.rate {
        check_rate(&cli, "--rate", w)?;
    }
    Ok(())
}

/// How a check names a bad value: the field (key or flag) and what is wrong
/// with it, as a [`SimError`] of the origin the caller knows.
pub type Invalid<'a> = dyn Fn(&str, String) -> SimError + 'a;

pub(crate) fn check_finite(invalid: &Invalid<'_>, field: &str, v: f64) -> Result<(), SimError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must be a finite number, got {}", format_number(v)),
        ))
    }
}

pub(crate) fn check_positive(invalid: &Invalid<'_>, field: &str, v: f64) -> Result<(), SimError> {
    check_finite(invalid, field, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must be positive, got {}", format_number(v)),
        ))
    }
}

fn check_non_negative(invalid: &Invalid<'_>, field: &str, v: f64) -> Result<(), SimError> {
    check_finite(invalid, field, v)?;
    if v >= 0.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must not be negative, got {}", format_number(v)),
        ))
    }
}

/// An altitude within [`ALTITUDE_RANGE_M`].
pub fn check_altitude(invalid: &Invalid<'_>, field: &str, h: f64) -> Result<(), SimError> {
    let (lo, hi) = ALTITUDE_RANGE_M;
    if h.is_finite() && (lo..=hi).contains(&h) {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must be between {lo} and {hi} m, got {}", format_number(h)),
        ))
    }
}

/// A Mach number above 0 and at most [`MAX_MACH`].
pub fn check_mach(invalid: &Invalid<'_>, field: &str, m: f64) -> Result<(), SimError> {
    if m.is_finite() && m > 0.0 && m <= MAX_MACH {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!(
                "must be above 0 and at most {MAX_MACH}, got {}",
                format_number(m)
            ),
        ))
    }
}

fn check_rate(invalid: &Invalid<'_>, field: &str, w: f64) -> Result<(), SimError> {
    if w.is_finite() && w.abs() <= MAX_RATE_RADPS {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!(
                "must be a rate between -{MAX_RATE_RADPS} and {MAX_RATE_RADPS} rad/s, got {}",
                format_number(w)
            ),
        ))
    }
}

/// A segment count from 1 to [`MAX_SEGMENTS`].
pub fn check_segments(invalid: &Invalid<'_>, field: &str, n: usize) -> Result<(), SimError> {
    if (1..=MAX_SEGMENTS).contains(&n) {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must be between 1 and {MAX_SEGMENTS}, got {n}"),
        ))
    }
}

/// A grading ratio within [`GRADING_RANGE`].
pub fn check_grading(invalid: &Invalid<'_>, field: &str, r: f64) -> Result<(), SimError> {
    let (lo, hi) = GRADING_RANGE;
    if r.is_finite() && (lo..=hi).contains(&r) {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!(
                "must be a length ratio between {lo} and {hi}, got {}",
                format_number(r)
            ),
        ))
    }
}

/// A one-line TOML error with the line of the problem.
fn toml_error(file: &str, text: &str, error: &toml::de::Error) -> SimError {
    let message = error.message().trim().replace('\n', " ");
    let line = error.span().map(|span| {
        let start = span.start.min(text.len());
        text[..start].matches('\n').count() + 1
    });
    SimError::ScenarioSyntax {
        file: file.to_owned(),
        line,
        message,
    }
}
