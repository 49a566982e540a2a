//! # decoy-config: the towed decoy system's configuration
//!
//! A system is described by a TOML file (environment, aircraft, cable, decoy,
//! solver, and optionally the decoy management and the operating envelope) plus
//! a CSV table of the decoy's aerodynamic coefficients that the TOML names in
//! `decoy.aero_table`. The project's reference system
//! (`config/reference-system.toml` + `config/decoy-aero.csv`) is embedded in the
//! crate, so [`SystemConfig::builtin`] works from any directory; so is the
//! weak-stability decoy ([`SystemConfig::weak_stability`],
//! `config/weak-stability-decoy.toml`), an overlay on it.
//!
//! ## Overlays
//!
//! A configuration file may be an **overlay**: a top-level `base = "FILE"` names
//! the file it is based on (relative to the overlay's directory; a built-in
//! overlay names a built-in file by its name in `config/`), and the overlay
//! writes only what differs. The base is loaded first (it may itself be an
//! overlay; a chain that comes back to a file already in it is a
//! [`ConfigError::BaseCycle`]), then the overlay's tables are merged onto it
//! table by table: a key the overlay writes replaces the base's value, a table
//! it writes is merged key by key into the base's table of the same name
//! (arrays are values, replaced whole), everything else is the base's. Only the
//! merged system is deserialised and validated, so a base need not be complete
//! on its own; every error names the file that wrote the field in question (and
//! its line, for malformed, unknown or mistyped fields). `decoy.aero_table` is
//! resolved against the directory of the file that names it.
//!
//! Loading validates everything once and reports the first problem as a typed
//! [`ConfigError`] whose message names the file, the field or the CSV line.
//! [`SystemConfig::model_params`] then turns the configuration into the solver's
//! [`solver_core::ModelParams`] for any scalar type and segment layout.
//!
//! The modules, each depending only on those before it: `error`
//! ([`ConfigError`]), `schema` (the serde types), `validation` (the ranges),
//! `tables` (the aerodynamic CSV), `conversion` (to
//! [`decoy_controller::SystemParams`] and the solver's types), `limits` (the
//! envelope map on board and the configuration's hash), `load` (files,
//! built-ins and overlays).
//!
//! Units SI; world frame NED (z down, altitude = -z); aircraft points in the
//! aircraft body frame (FRD); decoy stations are distances behind the decoy nose.
//!
//! ```
//! use decoy_config::SystemConfig;
//! use solver_core::Model;
//! let config = SystemConfig::builtin().unwrap();
//! let model: Model<f32, 16> = config.model(config.embedded_layout()).unwrap();
//! assert_eq!(model.segment_count(), config.solver.segments_embedded);
//! let speed = config.mach_to_speed(9000.0, 0.8).unwrap();
//! assert!((speed - 243.0).abs() < 1.0);
//! ```

mod conversion;
mod error;
mod limits;
mod load;
mod schema;
mod tables;
mod validation;

#[cfg(test)]
mod tests;

pub use conversion::vec3;
pub use decoy_controller::{
    AeroRows, ControllerConfig, ManagementParams, PerRequirement, SystemParams, Thresholds,
};
pub use error::{ConfigError, StaleLimits};
pub use limits::{BOUND_NAMES, HASH_PREFIX, LimitsFile, LimitsGrid, config_hash};
pub use load::{
    BASE_KEY, BUILTIN_AERO_CSV, BUILTIN_AERO_NAME, BUILTIN_LIMITS_TOML, BUILTIN_TOML,
    BUILTIN_TOML_NAME, WEAK_STABILITY_NAME, WEAK_STABILITY_TOML,
};
pub use schema::{
    AeroRow, AircraftConfig, CableConfig, CollisionSection, DecoyConfig, EnvelopeSection,
    EnvironmentConfig, ExhaustSection, ManagementSection, PostureSection, SolverConfig,
    SystemConfig, TensionSection,
};
pub use tables::{AERO_CSV_HEADER, MAX_AERO_COEFFICIENT, parse_aero_csv};
pub use validation::{
    MAX_BODY_OFFSET_M, MAX_VERTICAL_WIND_MPS, MAX_WIND_MPS, SUPPORTED_ATMOSPHERE,
};
