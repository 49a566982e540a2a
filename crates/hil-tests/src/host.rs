//! The host's copy of the firmware's controller configuration, from the same
//! configuration files the firmware's `build.rs` reads (`config/`).

use decoy_config::{ConfigError, SystemConfig};
use decoy_link::{ControllerConfig, Envelope, ExhaustPlume, Geometry};
use solver_core::Real;

/// The controller configuration of `config`'s embedded model
/// (`solver.segments_embedded` segments graded `solver.grading_ratio_embedded`) in
/// precision `T`: the model, the exhaust plume and collision capsule, and the
/// allowable tension, each value converted from the configuration's f64 to `T`
/// once, as the firmware's generated constants are.
pub fn controller_config<T: Real>(
    config: &SystemConfig,
) -> Result<ControllerConfig<T>, ConfigError> {
    let a = &config.aircraft;
    Ok(ControllerConfig {
        params: config.model_params(config.embedded_layout())?,
        geometry: Geometry {
            plume: ExhaustPlume::new(
                a.exhaust_nozzle,
                a.exhaust_axis,
                a.exhaust_nozzle_radius,
                a.exhaust_half_angle_deg,
                a.exhaust_length,
            ),
            envelope: Envelope::new(a.envelope_fore, a.envelope_aft, a.envelope_radius),
        },
        allowable_tension_n: T::lit(config.cable.allowable_tension),
    })
}
