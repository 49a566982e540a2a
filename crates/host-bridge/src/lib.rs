//! # host-bridge: the solver's wire types on the host
//!
//! Avionics simulations feed aircraft state to the solver and read its outputs
//! over shared memory (iceoryx2, added by the host-bridge issue). This crate owns
//! the wire types: plain `#[repr(C)]` values with no pointers, fixed layout and
//! explicit units, so any language can produce them. Conversion into the solver's
//! types validates every field; a bad message is a typed error and never reaches
//! the solver.
//!
//! Frames and units: SI, world NED (z down), body FRD, quaternion Hamilton scalar
//! first body to NED, body rates in the body frame.

use solver_core::{AircraftState, InputError, Outputs, Real, Vec3};

/// Aircraft state message (what an avionics simulation publishes each frame).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct AircraftStateMsg {
    /// Simulation time, s.
    pub time_s: f64,
    /// Reference-point position, NED, m.
    pub position_ned_m: [f64; 3],
    /// Velocity over the ground, NED, m/s.
    pub velocity_ned_mps: [f64; 3],
    /// Acceleration, NED, m/s^2.
    pub acceleration_ned_mps2: [f64; 3],
    /// Attitude quaternion body (FRD) to NED, `[w, x, y, z]`.
    pub attitude_wxyz: [f64; 4],
    /// Body angular rate, rad/s.
    pub body_rate_radps: [f64; 3],
    /// Body angular acceleration, rad/s^2.
    pub body_angular_acceleration_radps2: [f64; 3],
}

/// Solver output message (what the bridge publishes each frame).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct SolverOutputMsg {
    /// Simulation time, s.
    pub time_s: f64,
    /// Cable tension at the connection point (joint 0), N.
    pub connection_tension_n: f64,
    /// Cable tension at the decoy's towing point (joint N), N.
    pub tow_tension_n: f64,
    /// Decoy CG position relative to the connection point, NED, m.
    pub decoy_cg_from_connection_ned_m: [f64; 3],
    /// Decoy attitude quaternion body to NED, `[w, x, y, z]`.
    pub decoy_attitude_wxyz: [f64; 4],
    /// Decoy total angle of attack, rad.
    pub decoy_angle_of_attack_rad: f64,
}

impl AircraftStateMsg {
    /// Validates and converts to the solver's aircraft state (precision `T`).
    ///
    /// Returns the message time separately (the solver's time is f64 in every precision).
    pub fn to_state<T: Real>(&self) -> Result<(f64, AircraftState<T>), InputError> {
        if !self.time_s.is_finite() {
            return Err(InputError::NonFinite { field: "time" });
        }
        let v = |a: [f64; 3]| Vec3::new(T::lit(a[0]), T::lit(a[1]), T::lit(a[2]));
        let state = AircraftState {
            position: v(self.position_ned_m),
            velocity: v(self.velocity_ned_mps),
            acceleration: v(self.acceleration_ned_mps2),
            attitude: self.attitude_wxyz.map(T::lit),
            angular_rate: v(self.body_rate_radps),
            angular_acceleration: v(self.body_angular_acceleration_radps2),
        };
        state.validate()?;
        Ok((self.time_s, state))
    }
}

impl SolverOutputMsg {
    /// Builds the message from a solver evaluation.
    pub fn from_outputs<T: Real, const N: usize>(out: &Outputs<'_, T, N>) -> Self {
        let mut msg = SolverOutputMsg {
            time_s: out.time(),
            connection_tension_n: out.connection_tension().to_f64(),
            tow_tension_n: out.tow_tension().to_f64(),
            ..Default::default()
        };
        if let Some(decoy) = out.decoy() {
            let rel = decoy.cg_position - out.joint_position(0);
            msg.decoy_cg_from_connection_ned_m = [rel.x.to_f64(), rel.y.to_f64(), rel.z.to_f64()];
            let q = decoy.attitude;
            msg.decoy_attitude_wxyz = [q.w.to_f64(), q.i.to_f64(), q.j.to_f64(), q.k.to_f64()];
            msg.decoy_angle_of_attack_rad = decoy.angle_of_attack.to_f64();
        }
        msg
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level() -> AircraftStateMsg {
        AircraftStateMsg {
            time_s: 1.5,
            position_ned_m: [0.0, 0.0, -9000.0],
            velocity_ned_mps: [240.0, 0.0, 0.0],
            attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
            ..Default::default()
        }
    }

    #[test]
    fn valid_message_converts() {
        let (t, s) = level().to_state::<f32>().unwrap();
        assert_eq!(t, 1.5);
        assert_eq!(s.velocity.x, 240.0f32);
        assert_eq!(s.altitude(), 9000.0f32);
    }

    #[test]
    fn bad_messages_are_typed_errors() {
        let mut m = level();
        m.velocity_ned_mps[1] = f64::NAN;
        assert_eq!(
            m.to_state::<f64>().unwrap_err(),
            InputError::NonFinite { field: "velocity" }
        );
        let mut m = level();
        m.attitude_wxyz = [0.0; 4];
        assert_eq!(
            m.to_state::<f64>().unwrap_err(),
            InputError::DegenerateAttitude
        );
        let mut m = level();
        m.time_s = f64::INFINITY;
        assert_eq!(
            m.to_state::<f64>().unwrap_err(),
            InputError::NonFinite { field: "time" }
        );
    }

    #[test]
    fn layout_is_fixed() {
        // 1 + 3*5 + 4 = 20 f64 fields, no padding.
        assert_eq!(core::mem::size_of::<AircraftStateMsg>(), 20 * 8);
        assert_eq!(core::mem::size_of::<SolverOutputMsg>(), 11 * 8);
    }
}
