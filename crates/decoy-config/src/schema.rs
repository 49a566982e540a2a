//! The configuration's schema: the serde types of the TOML tables, the reference
//! values of the optional tables, and one row of the aerodynamic table.
//! Validation, the aerodynamic CSV and the conversion to the controller's plain
//! numbers are their own modules (`validation`, `tables`, `conversion`).

use serde::{Deserialize, Serialize};

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
    /// The aerodynamic table file, relative to the directory of the TOML file
    /// that names it (for an overlay that does not, its base's).
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
    /// Largest dynamic pressure of the aircraft's airspeed, Pa (cuts the low,
    /// fast corner of the altitude and Mach ranges).
    pub max_dynamic_pressure_pa: f64,
    /// The manoeuvre envelope map on board: a file written by `decoy
    /// limits-table`, relative to the file that names it, checked against the
    /// configuration's hash. An overlay does not inherit its base's (it is
    /// another system): it names its own or has none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits_map: Option<String>,
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
            max_dynamic_pressure_pa: e.max_dynamic_pressure_pa,
            limits_map: None,
        }
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
                cable_exclusion_m: 15.0,
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
    /// `[alpha_deg, cl, cd, cm]`, the form [`solver_core::AeroTable::from_degrees`] takes.
    pub fn to_array(self) -> [f64; 4] {
        [self.alpha_deg, self.cl, self.cd, self.cm]
    }
}

/// A validated towed-decoy system: every table of the TOML file (for an overlay,
/// its tables merged onto its base's) plus the parsed aerodynamic table.
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
    /// The envelope map on board that `envelope.limits_map` names, read and
    /// checked against this configuration (None without one).
    #[serde(skip)]
    pub limits: Option<decoy_controller::LimitMap>,
    /// The text of the file `limits` was read from (None without it).
    #[serde(skip)]
    pub limits_text: Option<String>,
    /// The envelope map named, when it was made for another configuration
    /// (then `limits` is None: `SystemConfig::check_limits`).
    #[serde(skip)]
    pub stale_limits: Option<crate::error::StaleLimits>,
    /// Where the TOML came from (a path, or the built-in name; for an overlay, the
    /// overlay's own file), for messages.
    #[serde(skip)]
    pub source: String,
}
