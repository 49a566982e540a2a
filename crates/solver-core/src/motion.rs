//! The aircraft's prescribed motion and the connection point it drives.

use nalgebra::UnitQuaternion;

use crate::atmosphere::AirColumn;
use crate::error::InputError;
use crate::model::Model;
use crate::scalar::{Real, Vec3, vec_finite};

/// The aircraft's state at one instant (the flight path prescribes it).
///
/// World frame NED (m, m/s, m/s^2); attitude is the Hamilton quaternion taking
/// aircraft body (FRD) vectors to NED, scalar first; rates are body-frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AircraftState<T: Real> {
    /// Position of the aircraft reference point, NED, m.
    pub position: Vec3<T>,
    /// Velocity over the ground, NED, m/s.
    pub velocity: Vec3<T>,
    /// Acceleration, NED, m/s^2.
    pub acceleration: Vec3<T>,
    /// Attitude, body (FRD) to NED, `[w, x, y, z]`.
    pub attitude: [T; 4],
    /// Angular velocity, body frame, rad/s.
    pub angular_rate: Vec3<T>,
    /// Angular acceleration, body frame, rad/s^2.
    pub angular_acceleration: Vec3<T>,
}

/// Position, velocity and acceleration of the connection point (joint 0), NED.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointKinematics<T: Real> {
    /// Position, m.
    pub position: Vec3<T>,
    /// Velocity, m/s.
    pub velocity: Vec3<T>,
    /// Acceleration, m/s^2.
    pub acceleration: Vec3<T>,
}

impl<T: Real> AircraftState<T> {
    /// An aircraft at rest at `position`, level, heading north (the pendulum's fixed anchor).
    pub fn fixed(position: Vec3<T>) -> Self {
        let z = Vec3::zeros();
        AircraftState {
            position,
            velocity: z,
            acceleration: z,
            attitude: [T::one(), T::zero(), T::zero(), T::zero()],
            angular_rate: z,
            angular_acceleration: z,
        }
    }

    /// Steady level flight heading north at `speed` m/s at `altitude` m.
    pub fn level(altitude: T, speed: T) -> Self {
        let mut s = Self::fixed(Vec3::new(T::zero(), T::zero(), -altitude));
        s.velocity = Vec3::new(speed, T::zero(), T::zero());
        s
    }

    /// Checks every field is finite and the attitude is usable.
    pub fn validate(&self) -> Result<(), InputError> {
        // Cheap probe first: a sum of the 19 values is finite only if they all are
        // (when it is not, the field-by-field check names the culprit).
        let sum3 = |v: &Vec3<T>| v.x + v.y + v.z;
        let [w, x, y, z] = self.attitude;
        let probe = sum3(&self.position)
            + sum3(&self.velocity)
            + sum3(&self.acceleration)
            + sum3(&self.angular_rate)
            + sum3(&self.angular_acceleration)
            + ((w + x) + (y + z));
        let n2 = (w * w + x * x) + (y * y + z * z);
        if probe.finite() && n2 >= T::lit(1e-6) {
            return Ok(());
        }
        for (field, v) in [
            ("position", &self.position),
            ("velocity", &self.velocity),
            ("acceleration", &self.acceleration),
            ("angular_rate", &self.angular_rate),
            ("angular_acceleration", &self.angular_acceleration),
        ] {
            if !vec_finite(v) {
                return Err(InputError::NonFinite { field });
            }
        }
        if self.attitude.iter().any(|q| !q.finite()) {
            return Err(InputError::NonFinite { field: "attitude" });
        }
        if n2 < T::lit(1e-6) {
            return Err(InputError::DegenerateAttitude);
        }
        Ok(())
    }

    /// The attitude as a unit quaternion (normalised).
    pub fn rotation(&self) -> UnitQuaternion<T> {
        crate::scalar::unit_quaternion(self.attitude)
    }

    /// Kinematics of a point fixed in the aircraft body at `r` (FRD, m):
    /// p = p_a + R r, v = v_a + R (w x r), a = a_a + R (dw x r + w x (w x r)).
    pub fn point(&self, r: &Vec3<T>) -> PointKinematics<T> {
        let rot = crate::scalar::rotation_matrix(self.attitude);
        let w = self.angular_rate;
        PointKinematics {
            position: self.position + rot * r,
            velocity: self.velocity + rot * w.cross(r),
            acceleration: self.acceleration
                + rot * (self.angular_acceleration.cross(r) + w.cross(&w.cross(r))),
        }
    }

    /// Altitude of the reference point, m (= -z).
    pub fn altitude(&self) -> T {
        -self.position.z
    }
}

/// A prescribed aircraft trajectory: the aircraft state at any time.
///
/// The RK4 integrator samples it at the start, middle and end of every step, so
/// position, velocity and acceleration must be mutually consistent (acceleration the
/// derivative of velocity) for the solver's accelerations to be meaningful.
pub trait FlightPath<T: Real> {
    /// The aircraft state at time `t`, s (f64 in every precision, see [`crate::State::time`]).
    fn state_at(&self, t: f64) -> AircraftState<T>;

    /// The kinematics of the point fixed in the aircraft body at `r` (FRD, m) at
    /// time `t`, s: what the solver samples (the connection point). By default the
    /// aircraft state at `t`, checked ([`AircraftState::validate`]), then
    /// [`AircraftState::point`]. A path may give the point's kinematics another
    /// way (the controller's frame path interpolates them between its two frames);
    /// it must then agree with `state_at` at the times where the point is pinned
    /// (bit for bit where it says so) and check its own inputs.
    #[inline(always)]
    fn point_at(&self, t: f64, r: &Vec3<T>) -> Result<PointKinematics<T>, InputError> {
        let aircraft = self.state_at(t);
        aircraft.validate()?;
        Ok(aircraft.point(r))
    }
}

/// A flight path over one interval that can be sampled at the nodes of equal
/// RK4 steps: node k of `nodes` lies at the fraction k / nodes of the interval
/// (with n steps, nodes = 2n: each step's start, middle and end). The
/// controller's frame path ([`crate::Solver::steps_on`]): sampled by fractions
/// that are exact (k/8 for four steps), not by times taken in f64, which on the
/// Cortex-M4F are software-emulated.
pub trait NodePath<T: Real> {
    /// The interval's length, s.
    fn span(&self) -> T;
    /// The kinematics of the point fixed in the aircraft body at `r` (FRD, m) at
    /// node `k` of `nodes` (0 <= k <= nodes): at node 0 and node `nodes` the
    /// interval's ends, bit for bit as [`FlightPath::point_at`] gives them there.
    fn node_point(&self, k: u32, nodes: u32, r: &Vec3<T>)
    -> Result<PointKinematics<T>, InputError>;
}

/// A flight path that is one constant state moved along with its velocity and
/// acceleration (steady flight when the acceleration is zero; a fixed anchor when
/// the velocity is zero too). Attitude and rates stay as given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Uniform<T: Real> {
    /// The state at t = 0.
    pub initial: AircraftState<T>,
}

impl<T: Real> FlightPath<T> for Uniform<T> {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let t = T::lit(t);
        let mut s = self.initial;
        let half = T::lit(0.5);
        s.position = self.initial.position
            + self.initial.velocity * t
            + self.initial.acceleration * (half * t * t);
        s.velocity = self.initial.velocity + self.initial.acceleration * t;
        s
    }
}

/// Validates an aircraft state and derives the connection-point kinematics and the
/// air column the solver uses there ([`AirColumn::about`]).
pub fn connection_and_air<T: Real, const N: usize>(
    model: &Model<T, N>,
    aircraft: &AircraftState<T>,
) -> Result<(PointKinematics<T>, AirColumn<T>), InputError> {
    aircraft.validate()?;
    let connection = aircraft.point(&model.params().connection_point);
    let air = AirColumn::about(
        &model.params().environment.atmosphere,
        -connection.position.z,
    )?;
    Ok((connection, air))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotating_point_kinematics() {
        // Yawing at 0.2 rad/s: a point 4 m aft sees centripetal acceleration 0.16 m/s^2 toward the centre.
        let mut s = AircraftState::<f64>::fixed(Vec3::zeros());
        s.angular_rate = Vec3::new(0.0, 0.0, 0.2);
        let k = s.point(&Vec3::new(-4.0, 0.0, 0.0));
        assert!((k.velocity - Vec3::new(0.0, -0.8, 0.0)).norm() < 1e-12);
        assert!((k.acceleration - Vec3::new(0.16, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn validation_names_the_field() {
        let mut s = AircraftState::<f64>::level(9000.0, 240.0);
        assert!(s.validate().is_ok());
        s.velocity.y = f64::NAN;
        assert_eq!(
            s.validate(),
            Err(InputError::NonFinite { field: "velocity" })
        );
        let mut s = AircraftState::<f64>::level(9000.0, 240.0);
        s.attitude = [0.0; 4];
        assert_eq!(s.validate(), Err(InputError::DegenerateAttitude));
    }
}
