//! The reference towed-decoy system, the project's built-in configuration.
//!
//! `build.rs` reads `config/reference-system.toml` and the aerodynamic table it
//! names with `decoy-config` (the host's reader and validation) and writes the
//! resulting `SystemParams` as the constant [`SYSTEM`] (with the envelope map
//! on board, `config/reference-system.limits.toml`, checked against the
//! configuration's hash); the firmware builds everything from it with the
//! host's own conversion.

// The generated constant names these types unqualified (their derived `Debug` form).
use decoy_controller::{
    EnvelopeParams, LimitGrid, LimitMap, ManagementParams, PerRequirement, Thresholds,
};

include!(concat!(env!("OUT_DIR"), "/system.rs"));
