//! Frames and clearances: the flight-path frame the outputs are expressed in, the
//! exhaust plume and the aircraft's collision envelope.
//!
//! The maths lives in `decoy_link::geometry` (no_std, generic over the scalar), so
//! that `decoy simulate` and the onboard controller compute the flight-path frame
//! and the clearances with the same code; this module fixes it to f64 and builds
//! it from the system configuration.

use decoy_config::{ConfigError, SystemConfig};
use decoy_link::ControllerConfig;
use nalgebra::Vector3;
use solver_core::{Real, SegmentLayout};

pub use decoy_link::geometry::cable_plume_clearance;

/// The flight-path frame at one instant: x along the aircraft's velocity, y
/// horizontal and to the right of it, z = x cross y (downward, perpendicular to
/// the flight path in its vertical plane); see [`decoy_link::FlightPathFrame`].
pub type FlightPathFrame = decoy_link::FlightPathFrame<f64>;

/// The hot exhaust plume, a truncated cone in the aircraft body frame; see
/// [`decoy_link::ExhaustPlume`].
pub type ExhaustPlume = decoy_link::ExhaustPlume<f64>;

/// The aircraft's collision capsule in the body frame; see [`decoy_link::Envelope`].
pub type Envelope = decoy_link::Envelope<f64>;

/// The plume of an aircraft configuration, in precision `T`.
pub fn plume_from_config<T: Real>(
    aircraft: &decoy_config::AircraftConfig,
) -> decoy_link::ExhaustPlume<T> {
    let axis = Vector3::from(aircraft.exhaust_axis).normalize();
    let t = T::lit;
    decoy_link::ExhaustPlume {
        nozzle: decoy_config::vec3(aircraft.exhaust_nozzle),
        axis: solver_core::Vec3::new(t(axis.x), t(axis.y), t(axis.z)),
        nozzle_radius: t(aircraft.exhaust_nozzle_radius),
        tan_half_angle: t(aircraft.exhaust_half_angle_deg.to_radians().tan()),
        length: t(aircraft.exhaust_length),
    }
}

/// The collision capsule of an aircraft configuration, in precision `T`.
pub fn envelope_from_config<T: Real>(
    aircraft: &decoy_config::AircraftConfig,
) -> decoy_link::Envelope<T> {
    decoy_link::Envelope {
        fore: decoy_config::vec3(aircraft.envelope_fore),
        aft: decoy_config::vec3(aircraft.envelope_aft),
        radius: T::lit(aircraft.envelope_radius),
    }
}

/// The onboard controller's configuration for `config` with `layout`: the model,
/// the plume and capsule, the allowable tension (what the firmware's build script
/// generates from the same files).
pub fn controller_config<T: Real>(
    config: &SystemConfig,
    layout: SegmentLayout<T>,
) -> Result<ControllerConfig<T>, ConfigError> {
    Ok(ControllerConfig {
        params: config.model_params(layout)?,
        geometry: decoy_link::Geometry {
            plume: plume_from_config(&config.aircraft),
            envelope: envelope_from_config(&config.aircraft),
        },
        allowable_tension_n: T::lit(config.cable.allowable_tension),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use solver_core::AircraftState;

    fn plume() -> ExhaustPlume {
        ExhaustPlume {
            nozzle: Vector3::new(-7.5, 0.0, 0.0),
            axis: Vector3::new(-1.0, 0.0, 0.0),
            nozzle_radius: 0.5,
            tan_half_angle: 0.1,
            length: 50.0,
        }
    }

    #[test]
    fn plume_clearance_signs_and_values() {
        let p = plume();
        // 10 m behind the nozzle the plume radius is 1.5 m.
        let behind = |s: f64, rho: f64| Vector3::new(-7.5 - s, 0.0, rho);
        let side = |s: f64, rho: f64| p.clearance(&behind(s, rho));
        // Outside, perpendicular distance to the cone's side.
        let c = side(10.0, 3.5);
        // (rho - r(s)) times the cosine of the half angle.
        let expected = 2.0 * 0.1f64.atan().cos();
        assert!((c - expected).abs() < 1e-12, "{c} vs {expected}");
        assert!(c > 0.0);
        // On the axis, inside: distance to the side (or the nozzle disc).
        assert!(side(10.0, 0.0) < 0.0);
        assert!((side(0.1, 0.0) + 0.1).abs() < 1e-12);
        // In front of the nozzle: distance to the disc.
        assert!((side(-2.0, 0.2) - 2.0).abs() < 1e-12);
        // Beyond the end: distance to the end disc.
        assert!((side(53.0, 0.0) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn capsule_clearance() {
        let e = Envelope {
            fore: Vector3::new(7.0, 0.0, 0.0),
            aft: Vector3::new(-7.5, 0.0, 0.0),
            radius: 1.6,
        };
        assert!((e.clearance(&Vector3::new(0.0, 0.0, 5.0)) - 3.4).abs() < 1e-12);
        assert!((e.clearance(&Vector3::new(-10.5, 0.0, 4.0)) - 3.4).abs() < 1e-12);
        assert!(e.clearance(&Vector3::zeros()) < 0.0);
    }

    #[test]
    fn flight_path_frame_in_a_climb() {
        let mut a = AircraftState::<f64>::level(9000.0, 100.0);
        a.velocity = Vector3::new(100.0 * 0.5f64.cos(), 0.0, -100.0 * 0.5f64.sin());
        let f = FlightPathFrame::of(&a);
        assert!((f.y - Vector3::y()).norm() < 1e-12);
        // z is "down" perpendicular to the climbing path: it leans forward.
        assert!(f.z.z > 0.0 && f.z.x > 0.0);
        let c = f.components(&Vector3::new(-1.0, 0.0, 0.0));
        assert!(c.x < 0.0);
    }
}
