//! # decoy-config: the towed decoy system's configuration
//!
//! A system is described by a TOML file (environment, aircraft, cable, decoy,
//! solver) plus a CSV table of the decoy's aerodynamic coefficients that the TOML
//! names in `decoy.aero_table`. The project's reference system
//! (`config/reference-system.toml` + `config/decoy-aero.csv`) is embedded in the
//! crate, so [`SystemConfig::builtin`] works from any directory.
//!
//! Loading validates everything once and reports the first problem as a typed
//! [`ConfigError`] whose message names the file, the field or the CSV line.
//! [`SystemConfig::model_params`] then turns the configuration into the solver's
//! [`ModelParams`] for any scalar type and segment layout.
//!
//! Units SI; world frame NED (z down, altitude = -z); aircraft points in the
//! aircraft body frame (FRD); decoy stations are distances behind the decoy nose.
//!
//! ```
//! use decoy_config::SystemConfig;
//! use solver_core::Model;
//! let config = SystemConfig::builtin().unwrap();
//! let model: Model<f32, 16> = config.model(config.embedded_layout()).unwrap();
//! assert_eq!(model.segment_count(), 12);
//! let speed = config.mach_to_speed(9000.0, 0.8).unwrap();
//! assert!((speed - 243.0).abs() < 1.0);
//! ```

use std::path::{Path, PathBuf};

pub use decoy_controller::{
    AeroRows, ControllerConfig, ManagementParams, PerRequirement, SystemParams, Thresholds,
};
use serde::{Deserialize, Serialize};
use solver_core::aero::AERO_TABLE_CAPACITY;
use solver_core::{
    AeroTable, AeroTableError, Atmosphere, AtmosphereError, Model, ModelParams, Real,
    SegmentLayout, Vec3,
};

/// The built-in system description (`config/reference-system.toml`).
pub const BUILTIN_TOML: &str = include_str!("../../../config/reference-system.toml");
/// The built-in decoy aerodynamic table (`config/decoy-aero.csv`).
pub const BUILTIN_AERO_CSV: &str = include_str!("../../../config/decoy-aero.csv");
/// How errors in the built-in TOML name their file.
pub const BUILTIN_TOML_NAME: &str = "built-in reference-system.toml";
/// How errors in the built-in aerodynamic table name their file.
pub const BUILTIN_AERO_NAME: &str = "built-in decoy-aero.csv";
/// The second decoy's moment reference point, m from the nose
/// (`config/weak-stability-decoy.toml`: the reference system with this and the
/// towing point changed, a weakly stable decoy, static margin 10 % of its length,
/// under which the paper's towing-point rule holds).
pub const WEAK_STABILITY_X_MRP: f64 = 0.1715;
/// The second decoy's towing point, m from the nose: 5 % of the body length ahead
/// of the CG, as the paper's rule recommends.
pub const WEAK_STABILITY_X_TOW: f64 = 0.225;
/// How the built-in weak-stability decoy names itself.
pub const WEAK_STABILITY_NAME: &str = "built-in weak-stability-decoy.toml";
/// The only atmosphere model supported (`environment.atmosphere`).
pub const SUPPORTED_ATMOSPHERE: &str = "ISA-1976";
/// The header line of the aerodynamic table.
pub const AERO_CSV_HEADER: [&str; 4] = ["alpha_deg", "cl", "cd", "cm"];

/// Why a configuration could not be loaded or used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// A file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The TOML is malformed, or has a missing, unknown or mistyped field.
    #[error("{file}{}: {message}", line_suffix(*line))]
    Toml {
        /// The TOML file.
        file: String,
        /// 1-based line of the problem, when known.
        line: Option<usize>,
        /// What is wrong (names the field and its table).
        message: String,
    },
    /// The aerodynamic table is malformed or unusable.
    #[error("{file}{}: {message}", line_suffix(*line))]
    AeroCsv {
        /// The CSV file.
        file: String,
        /// 1-based line of the problem, when it is one line's.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A field has a value outside its physical range (non-finite, not positive, ...).
    #[error("{file}: {field} {message}")]
    Invalid {
        /// The TOML file.
        file: String,
        /// The field, as `table.key` (for example `decoy.mass`).
        field: String,
        /// What is wrong with its value.
        message: String,
    },
    /// `environment.atmosphere` names a model the solver does not have.
    #[error("{file}: environment.atmosphere = \"{name}\" is not supported (only \"ISA-1976\")")]
    UnsupportedAtmosphere {
        /// The TOML file.
        file: String,
        /// The name given.
        name: String,
    },
    /// The solver rejected the model built from the configuration (for example too
    /// many segments for its capacity).
    #[error("{0}")]
    Solver(#[from] solver_core::ConfigError),
    /// The atmosphere cannot give air properties at the requested altitude.
    #[error("{0}")]
    Atmosphere(#[from] AtmosphereError),
}

fn line_suffix(line: Option<usize>) -> String {
    line.map(|l| format!(", line {l}")).unwrap_or_default()
}

/// `[environment]`: gravity, atmosphere and wind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentConfig {
    /// Gravitational acceleration, m/s^2, along +z (NED).
    pub gravity: f64,
    /// Atmosphere model name; only `"ISA-1976"` is supported.
    pub atmosphere: String,
    /// Specific gas constant of air, J/(kg K).
    pub gas_constant: f64,
    /// Ratio of specific heats.
    pub gamma: f64,
    /// Steady wind (air velocity over ground), NED, m/s.
    pub wind_ned: [f64; 3],
}

/// `[aircraft]`: points on the aircraft, body frame (FRD), m, relative to the
/// aircraft reference point whose motion the flight profile prescribes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AircraftConfig {
    /// Cable hinge on the aircraft.
    pub connection_point: [f64; 3],
    /// Centre of the engine nozzle exit.
    pub exhaust_nozzle: [f64; 3],
    /// Plume axis (need not be unit length, must not be zero).
    pub exhaust_axis: [f64; 3],
    /// Nozzle exit radius, m.
    pub exhaust_nozzle_radius: f64,
    /// Half angle of the plume cone, degrees.
    pub exhaust_half_angle_deg: f64,
    /// Length of the hot plume core considered dangerous to the cable, m.
    pub exhaust_length: f64,
    /// Fore end point of the fuselage collision capsule.
    pub envelope_fore: [f64; 3],
    /// Aft end point of the fuselage collision capsule.
    pub envelope_aft: [f64; 3],
    /// Radius of the collision capsule, m.
    pub envelope_radius: f64,
}

/// `[cable]`: the tow cable.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CableConfig {
    /// Deployed length, m.
    pub length: f64,
    /// Diameter, m.
    pub diameter: f64,
    /// Mass per unit length, kg/m.
    pub linear_density: f64,
    /// Young's modulus, Pa (the model is inextensible; used to report strain).
    pub elastic_modulus: f64,
    /// Management limit on the connection-point tension, N.
    pub allowable_tension: f64,
    /// Cross-flow drag coefficient on the normal velocity component.
    pub cd_normal: f64,
    /// Skin-friction coefficient on the tangential velocity component.
    pub cf_tangential: f64,
}

/// `[decoy]`: the towed body. Stations are metres behind the nose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecoyConfig {
    /// Mass, kg.
    pub mass: f64,
    /// Body length, m (aerodynamic reference length).
    pub length: f64,
    /// Body diameter, m (reference area pi d^2 / 4).
    pub diameter: f64,
    /// Centre of gravity station, m.
    pub x_cg: f64,
    /// Towing point (cable hinge) station, m.
    pub x_tow: f64,
    /// Principal moments of inertia about the CG (roll, pitch, yaw), kg m^2.
    pub inertia_cg: [f64; 3],
    /// Moment reference point station of the aerodynamic table, m.
    pub x_mrp: f64,
    /// The aerodynamic table file, relative to the TOML file's directory.
    pub aero_table: String,
    /// Pitch/yaw damping derivative, per rad.
    pub cm_q: f64,
    /// Roll damping derivative, per rad.
    pub cl_p: f64,
}

/// `[solver]`: discretisation and time step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverConfig {
    /// Uniform segment count of the host model.
    pub segments_host: usize,
    /// Segment count of the reduced (embedded) model.
    pub segments_embedded: usize,
    /// Length ratio between neighbouring segments of the embedded model (>= 1).
    pub grading_ratio_embedded: f64,
    /// RK4 time step of the host model, s.
    pub time_step_host: f64,
}

/// `[management]`: the decoy-management monitors and the look-ahead, with one
/// table per requirement (`[management.<name>]`, `decoy_schema::Requirement`).
/// Optional in a file: without it, the reference values ([`ManagementSection::default`],
/// the same as `config/reference-system.toml`'s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManagementSection {
    /// Look-ahead horizon, s.
    pub horizon_s: f64,
    /// Look-ahead RK4 steps per frame.
    pub prediction_steps_per_frame: u32,
    /// Longest look-ahead RK4 step, s.
    pub prediction_max_step_s: f64,
    /// Segments of the look-ahead's model (graded as the embedded model; at
    /// most `decoy_controller::PREDICTION_CAPACITY`).
    pub prediction_segments: usize,
    /// `[management.posture]`.
    pub posture: PostureSection,
    /// `[management.collision]`.
    pub collision: CollisionSection,
    /// `[management.tension]`.
    pub tension: TensionSection,
    /// `[management.exhaust]`.
    pub exhaust: ExhaustSection,
}

/// `[management.posture]`, degrees and seconds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PostureSection {
    /// Largest acceptable pitch/yaw oscillation amplitude, deg.
    pub amplitude_limit_deg: f64,
    /// Sliding window of the oscillation amplitude, s.
    pub window_s: f64,
    /// Caution below this margin, deg.
    pub caution_deg: f64,
    /// Warning below this margin, deg.
    pub warning_deg: f64,
    /// Hysteresis, deg.
    pub hysteresis_deg: f64,
}

/// `[management.collision]`, metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CollisionSection {
    /// Required clearance of the decoy and cable to the aircraft's capsule, m.
    pub min_clearance_m: f64,
    /// Cable length from the connection point not checked, m.
    pub cable_exclusion_m: f64,
    /// Caution below this margin, m.
    pub caution_m: f64,
    /// Warning below this margin, m.
    pub warning_m: f64,
    /// Hysteresis, m.
    pub hysteresis_m: f64,
}

/// `[management.tension]`, newtons (the allowable is `cable.allowable_tension`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TensionSection {
    /// Over-tension side: caution below this margin to the allowable, N.
    pub caution_n: f64,
    /// Over-tension side: warning below this margin, N.
    pub warning_n: f64,
    /// Over-tension side: hysteresis, N.
    pub hysteresis_n: f64,
    /// Tension below which the cable counts as slack (violated), N.
    pub slack_n: f64,
    /// Slack side: caution when the lowest tension is less than this above `slack_n`, N.
    pub slack_caution_n: f64,
    /// Slack side: warning below this margin, N.
    pub slack_warning_n: f64,
    /// Slack side: hysteresis, N.
    pub slack_hysteresis_n: f64,
}

/// `[management.exhaust]`, metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExhaustSection {
    /// Required clearance of the cable to the plume, m.
    pub min_clearance_m: f64,
    /// Caution below this margin, m.
    pub caution_m: f64,
    /// Warning below this margin, m.
    pub warning_m: f64,
    /// Hysteresis, m.
    pub hysteresis_m: f64,
}

/// `[envelope]`: the operating envelope the controller guarantees (frame cost,
/// accuracy), within the wider physical bounds that reject a frame
/// (docs/protocol.md §4). Optional in a file: without it, the reference values
/// ([`EnvelopeSection::default`], `config/reference-system.toml`'s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvelopeSection {
    /// Altitude of the aircraft reference point, m: [low, high].
    pub altitude_m: [f64; 2],
    /// Mach number: [low, high].
    pub mach: [f64; 2],
    /// Normal load factor, g: [low, high].
    pub load_factor: [f64; 2],
    /// Largest |body rate|, rad/s.
    pub max_body_rate_radps: f64,
    /// Largest |acceleration along the velocity|, m/s^2.
    pub max_along_path_acceleration_mps2: f64,
}

impl Default for EnvelopeSection {
    /// The reference values.
    fn default() -> Self {
        let e = decoy_controller::EnvelopeParams::REFERENCE;
        EnvelopeSection {
            altitude_m: e.altitude_m,
            mach: e.mach,
            load_factor: e.load_factor,
            max_body_rate_radps: e.max_body_rate_radps,
            max_along_path_acceleration_mps2: e.max_along_path_acceleration_mps2,
        }
    }
}

impl EnvelopeSection {
    /// The plain values.
    pub fn params(&self) -> decoy_controller::EnvelopeParams {
        decoy_controller::EnvelopeParams {
            altitude_m: self.altitude_m,
            mach: self.mach,
            load_factor: self.load_factor,
            max_body_rate_radps: self.max_body_rate_radps,
            max_along_path_acceleration_mps2: self.max_along_path_acceleration_mps2,
        }
    }

    /// Each range ordered and inside the physical bounds a frame is rejected
    /// beyond (docs/protocol.md §4): the envelope says what the controller
    /// guarantees within what it accepts.
    fn validate(&self, c: &Checker<'_>) -> Result<(), ConfigError> {
        use decoy_controller::validate::{
            MAX_ACCELERATION_MPS2, MAX_ALTITUDE_M, MAX_BODY_RATE_RADPS, MAX_MACH, MIN_ALTITUDE_M,
        };
        let g_limit = f64::from(MAX_ACCELERATION_MPS2) / 9.80665;
        let ranges = [
            (
                "envelope.altitude_m",
                self.altitude_m,
                MIN_ALTITUDE_M,
                MAX_ALTITUDE_M,
            ),
            ("envelope.mach", self.mach, 0.0, MAX_MACH),
            ("envelope.load_factor", self.load_factor, -g_limit, g_limit),
        ];
        for (field, [low, high], min, max) in ranges {
            c.range(&format!("{field}[0]"), low, min, max)?;
            c.range(&format!("{field}[1]"), high, min, max)?;
            if low > high {
                return Err(c.invalid(
                    field,
                    format!("the low end {low} is above the high end {high}"),
                ));
            }
        }
        c.range(
            "envelope.max_body_rate_radps",
            self.max_body_rate_radps,
            0.0,
            f64::from(MAX_BODY_RATE_RADPS),
        )?;
        c.range(
            "envelope.max_along_path_acceleration_mps2",
            self.max_along_path_acceleration_mps2,
            0.0,
            f64::from(MAX_ACCELERATION_MPS2),
        )
    }
}

impl Default for ManagementSection {
    /// The reference values (`config/reference-system.toml` states them and why).
    fn default() -> Self {
        ManagementSection {
            horizon_s: 3.0,
            prediction_steps_per_frame: 5,
            prediction_max_step_s: 0.013,
            prediction_segments: 12,
            posture: PostureSection {
                amplitude_limit_deg: 10.0,
                window_s: 2.0,
                caution_deg: 5.0,
                warning_deg: 2.5,
                hysteresis_deg: 0.5,
            },
            collision: CollisionSection {
                min_clearance_m: 1.0,
                cable_exclusion_m: 10.0,
                caution_m: 3.0,
                warning_m: 1.5,
                hysteresis_m: 0.25,
            },
            tension: TensionSection {
                caution_n: 300.0,
                warning_n: 150.0,
                hysteresis_n: 20.0,
                slack_n: 2.0,
                slack_caution_n: 8.0,
                slack_warning_n: 4.0,
                slack_hysteresis_n: 1.0,
            },
            exhaust: ExhaustSection {
                min_clearance_m: 0.0,
                caution_m: 0.5,
                warning_m: 0.25,
                hysteresis_m: 0.05,
            },
        }
    }
}

impl ManagementSection {
    /// The plain values, SI (angles in rad).
    pub fn params(&self) -> ManagementParams {
        let (p, c, t, e) = (&self.posture, &self.collision, &self.tension, &self.exhaust);
        ManagementParams {
            // Each requirement's section (in its unit; the margins' units are
            // `Requirement::unit`: radians for the posture's degrees).
            thresholds: PerRequirement {
                posture: Thresholds {
                    caution: p.caution_deg.to_radians(),
                    warning: p.warning_deg.to_radians(),
                    hysteresis: p.hysteresis_deg.to_radians(),
                },
                collision: Thresholds {
                    caution: c.caution_m,
                    warning: c.warning_m,
                    hysteresis: c.hysteresis_m,
                },
                tension: Thresholds {
                    caution: t.caution_n,
                    warning: t.warning_n,
                    hysteresis: t.hysteresis_n,
                },
                exhaust: Thresholds {
                    caution: e.caution_m,
                    warning: e.warning_m,
                    hysteresis: e.hysteresis_m,
                },
            },
            posture_amplitude_limit: p.amplitude_limit_deg.to_radians(),
            posture_window_s: p.window_s,
            collision_min_clearance: c.min_clearance_m,
            collision_cable_exclusion: c.cable_exclusion_m,
            slack_tension: t.slack_n,
            slack: Thresholds {
                caution: t.slack_caution_n,
                warning: t.slack_warning_n,
                hysteresis: t.slack_hysteresis_n,
            },
            exhaust_min_clearance: e.min_clearance_m,
            horizon_s: self.horizon_s,
            prediction_steps_per_frame: self.prediction_steps_per_frame,
            prediction_max_step_s: self.prediction_max_step_s,
            prediction_segments: self.prediction_segments,
        }
    }

    fn validate(&self, c: &Checker<'_>) -> Result<(), ConfigError> {
        c.range("management.horizon_s", self.horizon_s, 0.1, 30.0)?;
        if !(1..=64).contains(&self.prediction_steps_per_frame) {
            return Err(c.invalid(
                "management.prediction_steps_per_frame",
                format!(
                    "must be between 1 and 64, got {}",
                    self.prediction_steps_per_frame
                ),
            ));
        }
        c.range(
            "management.prediction_max_step_s",
            self.prediction_max_step_s,
            1e-4,
            0.05,
        )?;
        if !(1..=decoy_controller::PREDICTION_CAPACITY).contains(&self.prediction_segments) {
            return Err(c.invalid(
                "management.prediction_segments",
                format!(
                    "must be between 1 and {} (the look-ahead's capacity), got {}",
                    decoy_controller::PREDICTION_CAPACITY,
                    self.prediction_segments
                ),
            ));
        }
        let p = &self.posture;
        c.positive(
            "management.posture.amplitude_limit_deg",
            p.amplitude_limit_deg,
        )?;
        c.range(
            "management.posture.window_s",
            p.window_s,
            4.0 * decoy_controller::monitor::POSTURE_SAMPLE_S,
            decoy_controller::monitor::MAX_POSTURE_WINDOW_S,
        )?;
        c.levels(
            "management.posture",
            "deg",
            p.caution_deg,
            p.warning_deg,
            p.hysteresis_deg,
        )?;
        let k = &self.collision;
        c.non_negative("management.collision.min_clearance_m", k.min_clearance_m)?;
        c.non_negative(
            "management.collision.cable_exclusion_m",
            k.cable_exclusion_m,
        )?;
        c.levels(
            "management.collision",
            "m",
            k.caution_m,
            k.warning_m,
            k.hysteresis_m,
        )?;
        let t = &self.tension;
        c.non_negative("management.tension.slack_n", t.slack_n)?;
        c.levels(
            "management.tension",
            "n",
            t.caution_n,
            t.warning_n,
            t.hysteresis_n,
        )?;
        c.levels(
            "management.tension.slack",
            "n",
            t.slack_caution_n,
            t.slack_warning_n,
            t.slack_hysteresis_n,
        )?;
        let e = &self.exhaust;
        c.finite("management.exhaust.min_clearance_m", e.min_clearance_m)?;
        c.levels(
            "management.exhaust",
            "m",
            e.caution_m,
            e.warning_m,
            e.hysteresis_m,
        )?;
        Ok(())
    }
}

/// One row of the decoy aerodynamic table.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AeroRow {
    /// Total angle of attack, degrees.
    pub alpha_deg: f64,
    /// Lift coefficient.
    pub cl: f64,
    /// Drag coefficient.
    pub cd: f64,
    /// Pitching moment coefficient about the moment reference point, positive nose-up.
    pub cm: f64,
}

impl AeroRow {
    /// `[alpha_deg, cl, cd, cm]`, the form [`AeroTable::from_degrees`] takes.
    pub fn to_array(self) -> [f64; 4] {
        [self.alpha_deg, self.cl, self.cd, self.cm]
    }
}

/// A validated towed-decoy system: every table of the TOML file plus the parsed
/// aerodynamic table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SystemConfig {
    /// Gravity, atmosphere, wind.
    pub environment: EnvironmentConfig,
    /// Connection point, exhaust plume and collision envelope on the aircraft.
    pub aircraft: AircraftConfig,
    /// The tow cable.
    pub cable: CableConfig,
    /// The decoy.
    pub decoy: DecoyConfig,
    /// Discretisation and time step.
    pub solver: SolverConfig,
    /// Decoy management: monitors and look-ahead (optional: the reference values).
    #[serde(default)]
    pub management: ManagementSection,
    /// The operating envelope the controller guarantees (optional: the
    /// reference values).
    #[serde(default)]
    pub envelope: EnvelopeSection,
    /// The decoy aerodynamic table read from `decoy.aero_table`.
    #[serde(skip)]
    pub aero_rows: Vec<AeroRow>,
    /// Where the TOML came from (a path, or the built-in name), for messages.
    #[serde(skip)]
    pub source: String,
}

impl SystemConfig {
    /// The project's reference system, embedded in the binary.
    pub fn builtin() -> Result<Self, ConfigError> {
        Self::parse(BUILTIN_TOML, BUILTIN_TOML_NAME, |_| {
            Ok((BUILTIN_AERO_NAME.to_owned(), BUILTIN_AERO_CSV.to_owned()))
        })
    }

    /// The second decoy, built in: the reference system with the decoy's moment
    /// reference point at [`WEAK_STABILITY_X_MRP`] and its towing point at
    /// [`WEAK_STABILITY_X_TOW`] (what
    /// `config/weak-stability-decoy.toml` describes; a test checks they agree).
    pub fn weak_stability() -> Result<Self, ConfigError> {
        let mut config = Self::builtin()?;
        config.decoy.x_mrp = WEAK_STABILITY_X_MRP;
        config.decoy.x_tow = WEAK_STABILITY_X_TOW;
        config.source = WEAK_STABILITY_NAME.to_owned();
        config.validate()?;
        Ok(config)
    }

    /// Loads a system TOML file; `decoy.aero_table` is resolved relative to the
    /// TOML file's directory (or used as is when absolute).
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let text = read(path)?;
        let base = path.parent().unwrap_or_else(|| Path::new("."));
        Self::parse(&text, &path.display().to_string(), |aero_table| {
            let csv_path = base.join(aero_table);
            let csv = read(&csv_path)?;
            Ok((csv_path.display().to_string(), csv))
        })
    }

    /// Parses a system from TOML text and the text of its aerodynamic table (the
    /// TOML's `decoy.aero_table` is then only a name used in messages).
    pub fn from_str(toml_text: &str, aero_csv_text: &str) -> Result<Self, ConfigError> {
        Self::parse(toml_text, "configuration", |aero_table| {
            Ok((aero_table.to_owned(), aero_csv_text.to_owned()))
        })
    }

    fn parse(
        toml_text: &str,
        toml_name: &str,
        load_csv: impl FnOnce(&str) -> Result<(String, String), ConfigError>,
    ) -> Result<Self, ConfigError> {
        let mut config: SystemConfig =
            toml::from_str(toml_text).map_err(|e| toml_error(toml_name, toml_text, &e))?;
        config.source = toml_name.to_owned();
        config.validate()?;
        let (csv_name, csv_text) = load_csv(&config.decoy.aero_table)?;
        config.aero_rows = parse_aero_csv(&csv_name, &csv_text)?;
        Ok(config)
    }

    /// Checks every field of the TOML tables (not the aerodynamic table, which is
    /// checked when parsed): finite numbers, positive masses and lengths, stations
    /// on the body, a supported atmosphere.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let c = Checker { file: &self.source };
        let env = &self.environment;
        if env.atmosphere != SUPPORTED_ATMOSPHERE {
            return Err(ConfigError::UnsupportedAtmosphere {
                file: self.source.clone(),
                name: env.atmosphere.clone(),
            });
        }
        // Physical ranges (docs/configuration in config/reference-system.toml's
        // header): a value outside one is a typing error or a unit slip, never a
        // flight condition, and would trim to nonsense rather than fail.
        c.positive("environment.gravity", env.gravity)?;
        c.range("environment.gravity", env.gravity, 9.7, 9.9)?;
        c.positive("environment.gas_constant", env.gas_constant)?;
        c.range("environment.gas_constant", env.gas_constant, 280.0, 300.0)?;
        c.positive("environment.gamma", env.gamma)?;
        c.range("environment.gamma", env.gamma, 1.3, 1.45)?;
        c.finite_vec("environment.wind_ned", env.wind_ned)?;
        let [north, east, down] = env.wind_ned;
        let horizontal = north.hypot(east);
        if horizontal > MAX_WIND_MPS {
            return Err(c.invalid(
                "environment.wind_ned",
                format!(
                    "must have a horizontal speed of at most {MAX_WIND_MPS} m/s (the strongest jet-stream winds), got {horizontal} m/s"
                ),
            ));
        }
        c.range(
            "environment.wind_ned[2]",
            down,
            -MAX_VERTICAL_WIND_MPS,
            MAX_VERTICAL_WIND_MPS,
        )?;

        let a = &self.aircraft;
        for (field, point) in [
            ("aircraft.connection_point", a.connection_point),
            ("aircraft.exhaust_nozzle", a.exhaust_nozzle),
            ("aircraft.exhaust_axis", a.exhaust_axis),
            ("aircraft.envelope_fore", a.envelope_fore),
            ("aircraft.envelope_aft", a.envelope_aft),
        ] {
            c.finite_vec(field, point)?;
            for (i, v) in point.iter().enumerate() {
                c.range(
                    &format!("{field}[{i}]"),
                    *v,
                    -MAX_BODY_OFFSET_M,
                    MAX_BODY_OFFSET_M,
                )?;
            }
        }
        if a.exhaust_axis.iter().all(|v| *v == 0.0) {
            return Err(c.invalid(
                "aircraft.exhaust_axis",
                "must not be the zero vector".to_owned(),
            ));
        }
        c.range(
            "aircraft.exhaust_nozzle_radius",
            a.exhaust_nozzle_radius,
            0.0,
            5.0,
        )?;
        c.range(
            "aircraft.exhaust_half_angle_deg",
            a.exhaust_half_angle_deg,
            0.0,
            89.0,
        )?;
        c.range("aircraft.exhaust_length", a.exhaust_length, 0.0, 500.0)?;
        c.range("aircraft.envelope_radius", a.envelope_radius, 0.0, 20.0)?;

        let cable = &self.cable;
        c.positive("cable.length", cable.length)?;
        c.range("cable.length", cable.length, 1.0, 1000.0)?;
        c.positive("cable.diameter", cable.diameter)?;
        c.range("cable.diameter", cable.diameter, 1e-4, 0.05)?;
        c.positive("cable.linear_density", cable.linear_density)?;
        c.range("cable.linear_density", cable.linear_density, 1e-4, 5.0)?;
        c.positive("cable.elastic_modulus", cable.elastic_modulus)?;
        c.range("cable.elastic_modulus", cable.elastic_modulus, 1e8, 1e12)?;
        c.positive("cable.allowable_tension", cable.allowable_tension)?;
        c.range("cable.allowable_tension", cable.allowable_tension, 1.0, 1e6)?;
        c.non_negative("cable.cd_normal", cable.cd_normal)?;
        c.range("cable.cd_normal", cable.cd_normal, 0.0, 3.0)?;
        c.non_negative("cable.cf_tangential", cable.cf_tangential)?;
        c.range("cable.cf_tangential", cable.cf_tangential, 0.0, 0.5)?;

        let d = &self.decoy;
        c.positive("decoy.mass", d.mass)?;
        c.range("decoy.mass", d.mass, 0.1, 500.0)?;
        c.positive("decoy.length", d.length)?;
        c.range("decoy.length", d.length, 0.1, 10.0)?;
        c.positive("decoy.diameter", d.diameter)?;
        c.range("decoy.diameter", d.diameter, 0.01, 2.0)?;
        c.range("decoy.x_cg", d.x_cg, 0.0, d.length)?;
        c.range("decoy.x_tow", d.x_tow, 0.0, d.length)?;
        c.range("decoy.x_mrp", d.x_mrp, 0.0, d.length)?;
        for (axis, value) in ["roll", "pitch", "yaw"].iter().zip(d.inertia_cg) {
            c.positive(&format!("decoy.inertia_cg ({axis})"), value)?;
            c.range(&format!("decoy.inertia_cg ({axis})"), value, 1e-6, 1e4)?;
        }
        c.range("decoy.cm_q", d.cm_q, -1e4, 1e4)?;
        c.range("decoy.cl_p", d.cl_p, -1e4, 1e4)?;
        if d.aero_table.trim().is_empty() {
            return Err(c.invalid(
                "decoy.aero_table",
                "must name the aerodynamic table file".to_owned(),
            ));
        }

        let s = &self.solver;
        if s.segments_host == 0 {
            return Err(c.invalid("solver.segments_host", "must be at least 1".to_owned()));
        }
        if s.segments_embedded == 0 {
            return Err(c.invalid("solver.segments_embedded", "must be at least 1".to_owned()));
        }
        c.range(
            "solver.grading_ratio_embedded",
            s.grading_ratio_embedded,
            1.0,
            10.0,
        )?;
        c.positive("solver.time_step_host", s.time_step_host)?;
        c.range("solver.time_step_host", s.time_step_host, 1e-6, 0.01)?;
        self.management.validate(&c)?;
        self.envelope.validate(&c)?;
        Ok(())
    }

    /// The system as plain numbers ([`SystemParams`]): what the solver's model,
    /// the geometry and the onboard controller are built from, on the host and (by
    /// the firmware's build script) on the target. Fails only if the aerodynamic
    /// table has more rows than the solver's table holds.
    pub fn params(&self) -> Result<SystemParams, ConfigError> {
        let (env, a, c, d, s) = (
            &self.environment,
            &self.aircraft,
            &self.cable,
            &self.decoy,
            &self.solver,
        );
        let mut aero_rows: AeroRows = [[0.0; 4]; AERO_TABLE_CAPACITY];
        if self.aero_rows.len() > aero_rows.len() {
            return Err(ConfigError::Solver(
                AeroTableError::TooManyRows {
                    rows: self.aero_rows.len(),
                    capacity: AERO_TABLE_CAPACITY,
                }
                .into(),
            ));
        }
        for (slot, row) in aero_rows.iter_mut().zip(&self.aero_rows) {
            *slot = row.to_array();
        }
        Ok(SystemParams {
            gravity: env.gravity,
            gas_constant: env.gas_constant,
            gamma: env.gamma,
            wind_ned: env.wind_ned,
            connection_point: a.connection_point,
            exhaust_nozzle: a.exhaust_nozzle,
            exhaust_axis: a.exhaust_axis,
            exhaust_nozzle_radius: a.exhaust_nozzle_radius,
            exhaust_half_angle_deg: a.exhaust_half_angle_deg,
            exhaust_length: a.exhaust_length,
            envelope_fore: a.envelope_fore,
            envelope_aft: a.envelope_aft,
            envelope_radius: a.envelope_radius,
            cable_length: c.length,
            cable_diameter: c.diameter,
            cable_linear_density: c.linear_density,
            cable_cd_normal: c.cd_normal,
            cable_cf_tangential: c.cf_tangential,
            allowable_tension: c.allowable_tension,
            decoy_mass: d.mass,
            decoy_length: d.length,
            decoy_diameter: d.diameter,
            decoy_x_cg: d.x_cg,
            decoy_x_tow: d.x_tow,
            decoy_x_mrp: d.x_mrp,
            decoy_inertia_cg: d.inertia_cg,
            decoy_cm_q: d.cm_q,
            decoy_cl_p: d.cl_p,
            aero_rows,
            aero_row_count: self.aero_rows.len(),
            segments_embedded: s.segments_embedded,
            grading_ratio_embedded: s.grading_ratio_embedded,
            management: self.management.params(),
            envelope: self.envelope.params(),
        })
    }

    /// The atmosphere model with the configured constants.
    pub fn atmosphere<T: Real>(&self) -> Atmosphere<T> {
        let env = &self.environment;
        Atmosphere::Isa1976 {
            gas_constant: T::lit(env.gas_constant),
            gamma: T::lit(env.gamma),
            gravity: T::lit(env.gravity),
        }
    }

    /// The host model's layout: `solver.segments_host` uniform segments.
    pub fn host_layout<T: Real>(&self) -> SegmentLayout<T> {
        SegmentLayout::Uniform {
            count: self.solver.segments_host,
        }
    }

    /// The embedded model's layout: `solver.segments_embedded` segments graded by
    /// `solver.grading_ratio_embedded` (short at the decoy).
    pub fn embedded_layout<T: Real>(&self) -> SegmentLayout<T> {
        SegmentLayout::Graded {
            count: self.solver.segments_embedded,
            ratio: T::lit(self.solver.grading_ratio_embedded),
        }
    }

    /// The decoy aerodynamic table in the solver's form.
    pub fn aero_table<T: Real>(&self) -> Result<AeroTable<T>, ConfigError> {
        let rows: Vec<[f64; 4]> = self.aero_rows.iter().map(|r| r.to_array()).collect();
        AeroTable::from_degrees(&rows).map_err(|e| ConfigError::Solver(e.into()))
    }

    /// The solver's model parameters for this system with the given segment layout
    /// (the decoy at the end of the chain, the ISA 1976 atmosphere), built by
    /// [`SystemParams::model_params`]: the one conversion, shared with the firmware.
    pub fn model_params<T: Real>(
        &self,
        layout: SegmentLayout<T>,
    ) -> Result<ModelParams<T>, ConfigError> {
        self.params()?
            .model_params(layout)
            .map_err(|e| ConfigError::Solver(e.into()))
    }

    /// The onboard controller's configuration for this system with `layout` (the
    /// model, the exhaust plume and collision capsule, the allowable tension), built
    /// by [`SystemParams::controller_config`] exactly as the firmware builds its own.
    pub fn controller_config<T: Real>(
        &self,
        layout: SegmentLayout<T>,
    ) -> Result<ControllerConfig<T>, ConfigError> {
        self.params()?
            .controller_config(layout)
            .map_err(|e| ConfigError::Solver(e.into()))
    }

    /// Builds and validates the solver model with capacity `N` for `layout`
    /// ([`ConfigError::Solver`] if, for example, `layout` has more than `N` segments).
    pub fn model<T: Real, const N: usize>(
        &self,
        layout: SegmentLayout<T>,
    ) -> Result<Model<T, N>, ConfigError> {
        Ok(Model::new(self.model_params(layout)?)?)
    }

    /// ISA speed of sound at `altitude` (m, positive up), m/s.
    pub fn speed_of_sound(&self, altitude: f64) -> Result<f64, ConfigError> {
        Ok(self.atmosphere::<f64>().at(altitude)?.speed_of_sound)
    }

    /// True airspeed for Mach number `mach` at `altitude` (m), m/s: Mach times the
    /// ISA speed of sound there. Errors outside the atmosphere's altitude range.
    pub fn mach_to_speed(&self, altitude: f64, mach: f64) -> Result<f64, ConfigError> {
        Ok(mach * self.speed_of_sound(altitude)?)
    }
}

/// A `[x, y, z]` triple as a solver vector.
pub fn vec3<T: Real>(v: [f64; 3]) -> Vec3<T> {
    Vec3::new(T::lit(v[0]), T::lit(v[1]), T::lit(v[2]))
}

fn read(path: &Path) -> Result<String, ConfigError> {
    std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
        path: path.to_owned(),
        source,
    })
}

/// Field checks that name the file and the field.
struct Checker<'a> {
    file: &'a str,
}

/// Largest horizontal wind speed a configuration may give, m/s: the strongest
/// jet-stream cores measured are about 110 m/s.
pub const MAX_WIND_MPS: f64 = 120.0;
/// Largest steady vertical wind, m/s (mountain waves reach about 20 m/s).
pub const MAX_VERTICAL_WIND_MPS: f64 = 25.0;
/// Largest offset of an aircraft station from the reference point, per body
/// axis, m: twice the length of the largest towing aircraft (a B-52, 48 m).
pub const MAX_BODY_OFFSET_M: f64 = 100.0;
/// Largest magnitude of an aerodynamic coefficient of the table (on the body's
/// cross-section, so a slender body's broadside drag is large: the reference
/// table reaches 21.6).
pub const MAX_AERO_COEFFICIENT: f64 = 50.0;

impl Checker<'_> {
    fn invalid(&self, field: &str, message: String) -> ConfigError {
        ConfigError::Invalid {
            file: self.file.to_owned(),
            field: field.to_owned(),
            message,
        }
    }
    fn finite(&self, field: &str, v: f64) -> Result<(), ConfigError> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be a finite number, got {v}")))
        }
    }
    fn finite_vec(&self, field: &str, v: [f64; 3]) -> Result<(), ConfigError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must hold finite numbers, got {v:?}")))
        }
    }
    fn positive(&self, field: &str, v: f64) -> Result<(), ConfigError> {
        self.finite(field, v)?;
        if v > 0.0 {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be positive, got {v}")))
        }
    }
    fn non_negative(&self, field: &str, v: f64) -> Result<(), ConfigError> {
        self.finite(field, v)?;
        if v >= 0.0 {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must not be negative, got {v}")))
        }
    }
    /// Caution, warning and hysteresis of a monitor (`<table>.caution_<unit>`, ...):
    /// finite, 0 <= warning <= caution, hysteresis >= 0.
    fn levels(
        &self,
        table: &str,
        unit: &str,
        caution: f64,
        warning: f64,
        hysteresis: f64,
    ) -> Result<(), ConfigError> {
        self.non_negative(&format!("{table}.warning_{unit}"), warning)?;
        self.non_negative(&format!("{table}.hysteresis_{unit}"), hysteresis)?;
        self.finite(&format!("{table}.caution_{unit}"), caution)?;
        if caution < warning {
            return Err(self.invalid(
                &format!("{table}.caution_{unit}"),
                format!("must not be below the warning threshold {warning}, got {caution}"),
            ));
        }
        Ok(())
    }
    fn range(&self, field: &str, v: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
        self.finite(field, v)?;
        if (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be between {lo} and {hi}, got {v}")))
        }
    }
}

/// A one-line TOML error: the line of the problem, the message, and the table it is in.
fn toml_error(file: &str, text: &str, error: &toml::de::Error) -> ConfigError {
    let mut message = error.message().trim().replace('\n', " ");
    let mut line = None;
    if let Some(span) = error.span() {
        let start = span.start.min(text.len());
        line = Some(text[..start].matches('\n').count() + 1);
        let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
        let table = text[..line_end]
            .lines()
            .filter_map(|l| {
                let l = l.trim();
                l.strip_prefix('[')
                    .and_then(|rest| rest.split(']').next())
                    .map(str::trim)
            })
            .next_back();
        if let Some(table) = table {
            message = format!("{message} (in [{table}])");
        }
    }
    ConfigError::Toml {
        file: file.to_owned(),
        line,
        message,
    }
}

/// Parses the aerodynamic table CSV: `#` comment lines and blank lines are skipped,
/// the first other line must be the header `alpha_deg,cl,cd,cm`, every following
/// line one row of four numbers. The rows must be finite, strictly increasing in
/// angle and span 0 to 180 degrees.
pub fn parse_aero_csv(file: &str, text: &str) -> Result<Vec<AeroRow>, ConfigError> {
    let error = |line: Option<usize>, message: String| ConfigError::AeroCsv {
        file: file.to_owned(),
        line,
        message,
    };
    let mut header_seen = false;
    let mut rows = Vec::new();
    let mut line_numbers = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let number = index + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if !header_seen {
            if fields != AERO_CSV_HEADER {
                return Err(error(
                    Some(number),
                    format!("expected the header `alpha_deg,cl,cd,cm`, found `{line}`"),
                ));
            }
            header_seen = true;
            continue;
        }
        if fields.len() != 4 {
            return Err(error(
                Some(number),
                format!(
                    "expected 4 values (alpha_deg,cl,cd,cm), found {}: `{line}`",
                    fields.len()
                ),
            ));
        }
        let mut values = [0.0; 4];
        for ((value, name), field) in values.iter_mut().zip(AERO_CSV_HEADER).zip(&fields) {
            let parsed: f64 = field
                .parse()
                .map_err(|_| error(Some(number), format!("{name}: `{field}` is not a number")))?;
            if !parsed.is_finite() {
                return Err(error(
                    Some(number),
                    format!("{name}: `{field}` is not a finite number"),
                ));
            }
            *value = parsed;
        }
        for (name, value) in AERO_CSV_HEADER[1..].iter().zip(&values[1..]) {
            let low = if *name == "cd" {
                0.0
            } else {
                -MAX_AERO_COEFFICIENT
            };
            if !(low..=MAX_AERO_COEFFICIENT).contains(value) {
                return Err(error(
                    Some(number),
                    format!("{name} must be between {low} and {MAX_AERO_COEFFICIENT}, got {value}"),
                ));
            }
        }
        rows.push(AeroRow {
            alpha_deg: values[0],
            cl: values[1],
            cd: values[2],
            cm: values[3],
        });
        line_numbers.push(number);
    }
    if !header_seen {
        return Err(error(
            None,
            "no header line `alpha_deg,cl,cd,cm` found".to_owned(),
        ));
    }
    let arrays: Vec<[f64; 4]> = rows.iter().map(|r| r.to_array()).collect();
    AeroTable::<f64>::from_degrees(&arrays).map_err(|e| match e {
        AeroTableError::NotIncreasing { row } => error(
            Some(line_numbers[row]),
            format!(
                "alpha_deg {} does not increase on the previous row's {} (angles must increase strictly)",
                rows[row].alpha_deg,
                rows[row - 1].alpha_deg
            ),
        ),
        AeroTableError::NonFinite { row } => error(Some(line_numbers[row]), "a value is not finite".to_owned()),
        AeroTableError::DoesNotCover0To180 => error(
            None,
            format!(
                "alpha_deg must run from 0 to 180 degrees, the table runs from {} to {}",
                rows[0].alpha_deg,
                rows[rows.len() - 1].alpha_deg
            ),
        ),
        other => error(None, other.to_string()),
    })?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(from: &str, to: &str) -> String {
        assert!(BUILTIN_TOML.contains(from), "test edit `{from}` not found");
        BUILTIN_TOML.replacen(from, to, 1)
    }

    #[test]
    fn the_management_section_is_optional_and_checked() {
        let config = SystemConfig::builtin().unwrap();
        // The reference file states the defaults explicitly.
        assert_eq!(config.management, ManagementSection::default());
        // Without the section: the same values.
        let start = BUILTIN_TOML.find("[management]").unwrap();
        let without = SystemConfig::from_str(&BUILTIN_TOML[..start], BUILTIN_AERO_CSV).unwrap();
        assert_eq!(without.management, config.management);
        // A warning threshold above the caution one is named.
        let bad = BUILTIN_TOML.replace("warning_m = 0.25", "warning_m = 0.75");
        let e = SystemConfig::from_str(&bad, BUILTIN_AERO_CSV).unwrap_err();
        assert!(
            e.to_string().contains("management.exhaust.caution_m"),
            "{e}"
        );
        // The usable angle of attack of the reference table: where its restoring
        // moment stops growing, 40 degrees.
        let params = config.params().unwrap();
        assert!((params.usable_angle_of_attack().to_degrees() - 40.0).abs() < 1e-9);
    }

    /// `[management]` has one table per requirement, named as it
    /// (`[management.posture]`, ...), and no other.
    #[test]
    fn the_management_tables_are_the_requirements() {
        let section = toml::Value::try_from(ManagementSection::default()).unwrap();
        let tables: Vec<&str> = section
            .as_table()
            .unwrap()
            .iter()
            .filter(|(_, v)| v.is_table())
            .map(|(k, _)| k.as_str())
            .collect();
        let mut names: Vec<&str> = decoy_controller::Requirement::ALL
            .iter()
            .map(|r| r.name())
            .collect();
        names.sort_unstable();
        let mut tables = tables;
        tables.sort_unstable();
        assert_eq!(tables, names);
    }

    #[test]
    fn builtin_parses_and_builds_models() {
        let config = SystemConfig::builtin().unwrap();
        assert_eq!(config.environment.atmosphere, "ISA-1976");
        assert_eq!(config.aircraft.connection_point, [-2.0, 0.0, 1.7]);
        assert_eq!(config.aircraft.exhaust_half_angle_deg, 3.0);
        assert_eq!(config.aircraft.exhaust_length, 35.0);
        assert_eq!(config.aircraft.envelope_radius, 1.6);
        assert_eq!(config.cable.allowable_tension, 1200.0);
        assert_eq!(config.decoy.inertia_cg, [0.0025, 0.27, 0.27]);
        assert_eq!(config.solver.segments_host, 300);
        assert_eq!(config.aero_rows.len(), 35);
        assert_eq!(
            config.aero_rows[1],
            AeroRow {
                alpha_deg: 2.0,
                cl: 0.428087,
                cd: 0.464949,
                cm: -0.092994
            }
        );

        let host: Model<f64, 300> = config.model(config.host_layout()).unwrap();
        assert_eq!(host.segment_count(), 300);
        assert!((host.lengths().iter().sum::<f64>() - 100.0).abs() < 1e-9);
        let (decoy, _) = host.decoy().unwrap();
        assert_eq!(decoy.mass, 4.0);
        assert_eq!(decoy.aero.rows(), 35);

        let embedded: Model<f32, 16> = config.model(config.embedded_layout()).unwrap();
        let l = embedded.lengths();
        assert_eq!(l.len(), 12);
        assert!((l[0] / l[11] - 1.26f32.powi(11)).abs() < 1e-2);
    }

    #[test]
    fn from_str_and_from_file_match_builtin() {
        let builtin = SystemConfig::builtin().unwrap();
        let parsed = SystemConfig::from_str(BUILTIN_TOML, BUILTIN_AERO_CSV).unwrap();
        assert_eq!(parsed.aero_rows, builtin.aero_rows);
        assert_eq!(parsed.decoy, builtin.decoy);
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/reference-system.toml");
        let file = SystemConfig::from_file(&path).unwrap();
        assert_eq!(file.cable, builtin.cable);
        assert_eq!(file.aero_rows, builtin.aero_rows);
    }

    #[test]
    fn weak_stability_file_is_the_builtin_weak_decoy() {
        let reference = SystemConfig::builtin().unwrap();
        let weak = SystemConfig::weak_stability().unwrap();
        assert!(weak.decoy.x_mrp < reference.decoy.x_mrp);
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/weak-stability-decoy.toml");
        let file = SystemConfig::from_file(&path).unwrap();
        // The file repeats the reference system's sections: they must agree, so
        // that `--config config/weak-stability-decoy.toml` flies what the report does.
        assert_eq!(file.environment, weak.environment);
        assert_eq!(file.aircraft, weak.aircraft);
        assert_eq!(file.cable, weak.cable);
        assert_eq!(file.decoy, weak.decoy);
        assert_eq!(file.aero_rows, weak.aero_rows);
    }

    #[test]
    fn too_many_segments_is_a_solver_error() {
        let config = SystemConfig::builtin().unwrap();
        let err = config.model::<f64, 16>(config.host_layout()).unwrap_err();
        assert!(
            matches!(
                err,
                ConfigError::Solver(solver_core::ConfigError::TooManySegments { .. })
            ),
            "{err}"
        );
    }

    #[test]
    fn missing_field_is_named() {
        let toml = with("mass = 4.0 ", "# no mass ");
        let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
        assert!(matches!(err, ConfigError::Toml { .. }), "{err:?}");
        let message = err.to_string();
        assert!(
            message.contains("missing field `mass`") && message.contains("decoy"),
            "{message}"
        );
    }

    #[test]
    fn unknown_field_is_named_with_its_line() {
        let toml = with("cl_p = -0.3", "cl_p = -0.3\ncl_r = 1.0");
        let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
        let line = toml.lines().position(|l| l.starts_with("cl_r")).unwrap() + 1;
        match &err {
            ConfigError::Toml {
                line: Some(l),
                message,
                ..
            } => {
                assert_eq!(*l, line);
                assert!(message.contains("unknown field `cl_r`"), "{message}");
            }
            other => panic!("wrong error {other:?}"),
        }
        assert!(err.to_string().contains(&format!("line {line}")), "{err}");
    }

    /// Issue 27, item 8: every number of the configuration has a physical range.
    /// Each numeric value of the reference system's TOML (every element of an
    /// array too) set to a huge value, then to its negative, is rejected as
    /// `Invalid` naming its own field (`wind_ned = [1e30, 0, 0]` trimmed to
    /// 4.37e57 N before).
    #[test]
    fn every_configuration_number_has_a_physical_range() {
        let reference: toml::Table = toml::from_str(BUILTIN_TOML).unwrap();
        let mut checked = 0;
        for (table, keys) in &reference {
            let toml::Value::Table(keys) = keys else {
                continue;
            };
            for (key, value) in keys {
                let elements = match value {
                    toml::Value::Array(a) => a.len(),
                    toml::Value::Float(_) => 0,
                    _ => continue,
                };
                for element in 0..elements.max(1) {
                    for huge in [1e30, -1e30] {
                        let mut edited = reference.clone();
                        let slot = edited[table.as_str()]
                            .as_table_mut()
                            .unwrap()
                            .get_mut(key.as_str())
                            .unwrap();
                        let slot = match slot {
                            toml::Value::Array(a) => &mut a[element],
                            other => other,
                        };
                        *slot = toml::Value::Float(huge);
                        let text = toml::to_string(&edited).unwrap();
                        let field = format!("{table}.{key}");
                        match SystemConfig::from_str(&text, BUILTIN_AERO_CSV) {
                            Err(ConfigError::Invalid { field: named, .. }) => assert!(
                                named.starts_with(&field),
                                "{field}[{element}] = {huge}: blamed on {named}"
                            ),
                            other => panic!("{field}[{element}] = {huge}: {other:?}"),
                        }
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 100, "{checked} values checked");
        // The aerodynamic table's coefficients too.
        for (edit, named) in [
            ("\n0,1e30,0.450000,-0.000000", "cl"),
            ("\n0,0.000000,-0.1,-0.000000", "cd"),
            ("\n0,0.000000,0.450000,-1e30", "cm"),
        ] {
            let csv = BUILTIN_AERO_CSV.replacen("\n0,0.000000,0.450000,-0.000000", edit, 1);
            assert_ne!(csv, BUILTIN_AERO_CSV, "the row at 0 degrees");
            match SystemConfig::from_str(BUILTIN_TOML, &csv) {
                Err(ConfigError::AeroCsv { message, .. }) => {
                    assert!(
                        message.starts_with(&format!("{named} must be between")),
                        "{message}"
                    )
                }
                other => panic!("{named}: {other:?}"),
            }
        }
    }

    #[test]
    fn negative_mass_is_invalid() {
        let toml = with("mass = 4.0 ", "mass = -4.0 ");
        let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
        match &err {
            ConfigError::Invalid { field, .. } => assert_eq!(field, "decoy.mass"),
            other => panic!("wrong error {other:?}"),
        }
        assert!(
            err.to_string()
                .contains("decoy.mass must be positive, got -4"),
            "{err}"
        );
    }

    #[test]
    fn non_finite_and_unsupported_values_are_rejected() {
        let toml = with("length = 100.0 ", "length = nan ");
        let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
        assert!(
            matches!(&err, ConfigError::Invalid { field, .. } if field == "cable.length"),
            "{err:?}"
        );
        let toml = with("\"ISA-1976\"", "\"US-1962\"");
        let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
        assert!(
            matches!(&err, ConfigError::UnsupportedAtmosphere { name, .. } if name == "US-1962"),
            "{err:?}"
        );
        let toml = with("x_tow = 0.12", "x_tow = 1.5");
        let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
        assert!(
            matches!(&err, ConfigError::Invalid { field, .. } if field == "decoy.x_tow"),
            "{err:?}"
        );
    }

    #[test]
    fn bad_csv_row_names_its_line() {
        let csv = BUILTIN_AERO_CSV.replacen(
            "4,0.903119,0.513152,-0.185451",
            "4,0.903119,oops,-0.185451",
            1,
        );
        let line = csv.lines().position(|l| l.contains("oops")).unwrap() + 1;
        let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
        match &err {
            ConfigError::AeroCsv {
                line: Some(l),
                message,
                ..
            } => {
                assert_eq!(*l, line);
                assert!(message.contains("cd: `oops` is not a number"), "{message}");
            }
            other => panic!("wrong error {other:?}"),
        }
        assert!(
            err.to_string()
                .contains(&format!("decoy-aero.csv, line {line}")),
            "{err}"
        );

        let csv =
            BUILTIN_AERO_CSV.replacen("6,1.420349,0.599285,-0.276836", "6,1.420349,0.599285", 1);
        let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
        assert!(
            matches!(err, ConfigError::AeroCsv { line: Some(_), .. }),
            "{err:?}"
        );
    }

    #[test]
    fn non_increasing_alpha_names_its_line() {
        let csv = BUILTIN_AERO_CSV.replacen("\n12,", "\n9,", 1);
        let line = csv.lines().position(|l| l.starts_with("9,")).unwrap() + 1;
        let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
        match &err {
            ConfigError::AeroCsv {
                line: Some(l),
                message,
                ..
            } => {
                assert_eq!(*l, line);
                assert!(
                    message.contains("alpha_deg 9 does not increase"),
                    "{message}"
                );
            }
            other => panic!("wrong error {other:?}"),
        }
    }

    #[test]
    fn table_not_spanning_0_to_180_and_bad_header_are_rejected() {
        let csv = BUILTIN_AERO_CSV.replacen("\n180,0.000000,0.450000,0.000000", "", 1);
        let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
        assert!(
            matches!(err, ConfigError::AeroCsv { line: None, .. }),
            "{err:?}"
        );
        let csv = BUILTIN_AERO_CSV.replacen("alpha_deg,cl,cd,cm", "alpha,cl,cd,cm", 1);
        let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
        assert!(
            matches!(err, ConfigError::AeroCsv { line: Some(_), .. }),
            "{err:?}"
        );
    }

    #[test]
    fn missing_files_are_io_errors_naming_the_path() {
        let err = SystemConfig::from_file("/nonexistent/system.toml").unwrap_err();
        assert!(matches!(err, ConfigError::Io { .. }), "{err:?}");
        assert!(
            err.to_string().contains("/nonexistent/system.toml"),
            "{err}"
        );
    }

    #[test]
    fn mach_to_speed_uses_isa() {
        let config = SystemConfig::builtin().unwrap();
        let a0 = config.speed_of_sound(0.0).unwrap();
        assert!((a0 - 340.294).abs() < 0.01, "{a0}");
        let v = config.mach_to_speed(9000.0, 0.8).unwrap();
        let a9 = Atmosphere::<f64>::isa().at(9000.0).unwrap().speed_of_sound;
        assert_eq!(v, 0.8 * a9);
        assert!((a9 - 303.85).abs() < 0.05, "{a9}");
        assert!(matches!(
            config.mach_to_speed(25_000.0, 0.8),
            Err(ConfigError::Atmosphere(_))
        ));
    }
}
