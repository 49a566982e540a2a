//! Frames and clearances: the flight-path frame the outputs are expressed in, the
//! exhaust plume and the aircraft's collision envelope.
//!
//! The maths lives in `decoy_controller::geometry` (no_std, generic over the scalar), so
//! that `decoy simulate` and the onboard controller compute the flight-path frame
//! and the clearances with the same code; this module fixes it to f64 and builds
//! it from the system configuration.

use solver_core::Real;

pub use decoy_controller::geometry::{
    cable_plume_clearance, cable_plume_clearance_below, cable_plume_clearance_pruned,
};

/// The flight-path frame at one instant: x along the aircraft's velocity, y
/// horizontal and to the right of it, z = x cross y (downward, perpendicular to
/// the flight path in its vertical plane); see [`decoy_controller::FlightPathFrame`].
pub type FlightPathFrame = decoy_controller::FlightPathFrame<f64>;

/// The hot exhaust plume, a truncated cone in the aircraft body frame; see
/// [`decoy_controller::ExhaustPlume`].
pub type ExhaustPlume = decoy_controller::ExhaustPlume<f64>;

/// The aircraft's collision capsule in the body frame; see [`decoy_controller::Envelope`].
pub type Envelope = decoy_controller::Envelope<f64>;

/// The plume of an aircraft configuration, in precision `T` (the constructor the
/// controller's [`decoy_controller::SystemParams::plume`] uses: axis normalised,
/// half-angle tangent by libm).
pub fn plume_from_config<T: Real>(
    aircraft: &decoy_config::AircraftConfig,
) -> decoy_controller::ExhaustPlume<T> {
    decoy_controller::ExhaustPlume::new(
        aircraft.exhaust_nozzle,
        aircraft.exhaust_axis,
        aircraft.exhaust_nozzle_radius,
        aircraft.exhaust_half_angle_deg,
        aircraft.exhaust_length,
    )
}

/// The collision capsule of an aircraft configuration, in precision `T`.
pub fn envelope_from_config<T: Real>(
    aircraft: &decoy_config::AircraftConfig,
) -> decoy_controller::Envelope<T> {
    decoy_controller::Envelope::new(
        aircraft.envelope_fore,
        aircraft.envelope_aft,
        aircraft.envelope_radius,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
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
