//! The operating envelope the controller guarantees: the flight conditions and
//! manoeuvres over which every 10 ms frame stays within its instruction budget
//! and the solution within its accuracy (docs/protocol.md §4, firmware/README.md
//! "Real time over the operating envelope"). A frame outside it is answered as any other, with
//! [`decoy_link::StatusFlags::OUTSIDE_ENVELOPE`] set; only the physical input
//! bounds of [`crate::validate`] reject a frame.

use solver_core::Real;

use decoy_link::AircraftStateFrame;

/// The envelope as plain numbers (`[envelope]` of the configuration): closed
/// ranges `[low, high]` and upper bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvelopeParams {
    /// Altitude of the aircraft reference point, m (geometric, -z).
    pub altitude_m: [f64; 2],
    /// Mach number of the aircraft's velocity through the air.
    pub mach: [f64; 2],
    /// Normal load factor, g: minus the specific force (acceleration less
    /// gravity) along the body z axis, over standard gravity (1 in level flight,
    /// 1/cos(bank) in a coordinated turn, about 1 + V w / g in a pull-up, cos of
    /// the climb angle in a straight climb).
    pub load_factor: [f64; 2],
    /// Largest |body rate|, rad/s.
    pub max_body_rate_radps: f64,
    /// Largest |acceleration along the velocity|, m/s².
    pub max_along_path_acceleration_mps2: f64,
}

impl EnvelopeParams {
    /// The reference system's envelope (`config/reference-system.toml`
    /// `[envelope]`, whose comments justify it).
    pub const REFERENCE: Self = EnvelopeParams {
        altitude_m: [0.0, 15_000.0],
        mach: [0.3, 0.95],
        load_factor: [0.0, 4.0],
        max_body_rate_radps: 0.35,
        max_along_path_acceleration_mps2: 10.0,
    };
}

/// Relative widening of the envelope's bounds in [`OperatingEnvelope::new`]
/// (1e-5: a hundred times f32's rounding, 0.15 m at 15 km, Mach 1e-5).
pub const BOUND_TOLERANCE: f64 = 1e-5;

/// The envelope in the controller's precision, its bounds squared where the
/// check compares squares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperatingEnvelope<T: Real> {
    altitude: [T; 2],
    mach: [T; 2],
    /// The load factor's bounds times standard gravity, m/s².
    specific_force: [T; 2],
    body_rate2: T,
    along2: T,
}

impl<T: Real> OperatingEnvelope<T> {
    /// Every bound zero (all zero bits): nothing is inside.
    pub const ZERO: Self = OperatingEnvelope {
        altitude: [T::ZERO; 2],
        mach: [T::ZERO; 2],
        specific_force: [T::ZERO; 2],
        body_rate2: T::ZERO,
        along2: T::ZERO,
    };

    /// `params` in `T`, with gravity `g0` (m/s²) for the load factor. Each bound
    /// is widened by [`BOUND_TOLERANCE`] of its magnitude (at least of its unit),
    /// so that a frame exactly at a bound, in the wire's f32 and the check's
    /// rounding, counts as inside.
    pub fn new(params: &EnvelopeParams, g0: f64) -> Self {
        let lit = T::lit;
        let widen = |[low, high]: [f64; 2], unit: f64| {
            [
                lit(low - BOUND_TOLERANCE * low.abs().max(unit)),
                lit(high + BOUND_TOLERANCE * high.abs().max(unit)),
            ]
        };
        let square = |v: f64| lit(v * v * (1.0 + 2.0 * BOUND_TOLERANCE));
        OperatingEnvelope {
            altitude: widen(params.altitude_m, 1.0),
            mach: widen(params.mach, 1.0),
            specific_force: widen(params.load_factor.map(|n| n * g0), g0),
            body_rate2: square(params.max_body_rate_radps),
            along2: square(params.max_along_path_acceleration_mps2),
        }
    }

    /// True when the aircraft state `frame`, flying at Mach `mach`, is inside:
    /// every bound met (closed ranges). In `T` from the frame's f32 fields: a
    /// few dozen instructions, the same for every frame; the quaternion is taken
    /// as unit (validation holds it within 1e-3).
    pub fn contains(&self, frame: &AircraftStateFrame, mach: T, gravity: T) -> bool {
        let w = |v: f32| T::lit(f64::from(v));
        let altitude = T::lit(-frame.position_ned_m[2]);
        let [qw, qx, qy, qz] = frame.attitude_wxyz.map(w);
        let [ax, ay, az] = frame.acceleration_ned_mps2.map(w);
        let [vx, vy, vz] = frame.velocity_ned_mps.map(w);
        let [p, q, r] = frame.body_rate_radps.map(w);
        // The body z axis in NED: the rotation's third column.
        let two = T::lit(2.0);
        let zx = two * (qx * qz + qw * qy);
        let zy = two * (qy * qz - qw * qx);
        let zz = T::one() - two * (qx * qx + qy * qy);
        // n g = -(a - g e_z) . z_b.
        let normal = (gravity - az) * zz - ax * zx - ay * zy;
        let along = ax * vx + ay * vy + az * vz;
        let speed2 = vx * vx + vy * vy + vz * vz;
        let rate2 = p * p + q * q + r * r;
        let within = |v: T, range: &[T; 2]| v >= range[0] && v <= range[1];
        within(altitude, &self.altitude)
            & within(mach, &self.mach)
            & within(normal, &self.specific_force)
            & (rate2 <= self.body_rate2)
            & (along * along <= self.along2 * speed2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(altitude: f64, speed: f32) -> AircraftStateFrame {
        AircraftStateFrame {
            seq: 0,
            time_s: 0.0,
            position_ned_m: [0.0, 0.0, -altitude],
            velocity_ned_mps: [speed, 0.0, 0.0],
            acceleration_ned_mps2: [0.0; 3],
            attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
            body_rate_radps: [0.0; 3],
            body_angular_acceleration_radps2: [0.0; 3],
        }
    }

    #[test]
    fn the_reference_envelope_holds_level_flight_and_rejects_its_outside() {
        let e = OperatingEnvelope::<f32>::new(&EnvelopeParams::REFERENCE, 9.80665);
        let g = 9.80665f32;
        assert!(e.contains(&level(9000.0, 243.0), 0.8, g));
        assert!(e.contains(&level(0.0, 243.0), 0.3, g));
        assert!(e.contains(&level(15_000.0, 243.0), 0.95, g));
        assert!(!e.contains(&level(15_001.0, 243.0), 0.8, g));
        assert!(!e.contains(&level(-1.0, 243.0), 0.8, g));
        assert!(!e.contains(&level(9000.0, 243.0), 0.96, g));
        assert!(!e.contains(&level(9000.0, 243.0), 0.29, g));
        // A 4 g pull-up is inside, 4.1 g not; a 3.9 g turn (bank 75 deg) inside.
        let mut pull = level(9000.0, 180.0);
        pull.acceleration_ned_mps2 = [0.0, 0.0, -3.0 * g];
        assert!(e.contains(&pull, 0.6, g));
        pull.acceleration_ned_mps2 = [0.0, 0.0, -3.1 * g];
        assert!(!e.contains(&pull, 0.6, g));
        let bank = 75.0f32.to_radians();
        let mut turn = level(9000.0, 243.0);
        turn.attitude_wxyz = [(bank / 2.0).cos(), (bank / 2.0).sin(), 0.0, 0.0];
        turn.acceleration_ned_mps2 = [0.0, g * bank.tan(), 0.0];
        assert!(e.contains(&turn, 0.8, g));
        // Body rates and the along-path acceleration.
        let mut rolling = level(9000.0, 243.0);
        rolling.body_rate_radps = [0.36, 0.0, 0.0];
        assert!(!e.contains(&rolling, 0.8, g));
        let mut accelerating = level(9000.0, 243.0);
        accelerating.acceleration_ned_mps2 = [10.0, 0.0, 0.0];
        assert!(e.contains(&accelerating, 0.8, g));
        accelerating.acceleration_ned_mps2 = [10.5, 0.0, 0.0];
        assert!(!e.contains(&accelerating, 0.8, g));
        // A straight vertical climb: load factor 0.
        let mut climb = level(9000.0, 0.0);
        climb.velocity_ned_mps = [0.0, 0.0, -180.0];
        let pitch = 90.0f32.to_radians();
        climb.attitude_wxyz = [(pitch / 2.0).cos(), 0.0, (pitch / 2.0).sin(), 0.0];
        assert!(e.contains(&climb, 0.6, g));
    }
}
