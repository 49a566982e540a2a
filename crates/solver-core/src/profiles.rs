//! The paper's prescribed flight profiles (docs/design.md §8) as [`FlightPath`]s.
//!
//! All start at the origin of the horizontal plane heading north (+x) at altitude
//! `altitude`. Attitude follows the flight path: body x along the velocity, wings
//! level except in the turn, where the bank is the coordinated one,
//! tan(phi) = V w / g. Every profile gives position, velocity and acceleration that
//! are mutually consistent (each the derivative of the previous) and body rates and
//! angular accelerations consistent with the attitude. Computed in f64 and rounded
//! to `T`.

use nalgebra::{ComplexField, UnitQuaternion, Vector3};

use crate::motion::{AircraftState, FlightPath};
use crate::scalar::{Real, Vec3};

// f64 maths through nalgebra's ComplexField (libm without std), not the std-only inherent methods.
fn sin(x: f64) -> f64 {
    ComplexField::sin(x)
}
fn cos(x: f64) -> f64 {
    ComplexField::cos(x)
}
fn atan(x: f64) -> f64 {
    ComplexField::atan(x)
}

fn to_t<T: Real>(v: Vector3<f64>) -> Vec3<T> {
    Vec3::new(T::lit(v.x), T::lit(v.y), T::lit(v.z))
}

fn state<T: Real>(
    position: Vector3<f64>,
    velocity: Vector3<f64>,
    acceleration: Vector3<f64>,
    attitude: UnitQuaternion<f64>,
    body_rate: Vector3<f64>,
) -> AircraftState<T> {
    AircraftState {
        position: to_t(position),
        velocity: to_t(velocity),
        acceleration: to_t(acceleration),
        attitude: [
            T::lit(attitude.w),
            T::lit(attitude.i),
            T::lit(attitude.j),
            T::lit(attitude.k),
        ],
        angular_rate: to_t(body_rate),
        angular_acceleration: Vec3::zeros(),
    }
}

/// Level flight at `initial_speed` until `start`, then a constant along-track
/// `acceleration` (m/s^2, may be negative) until `final_speed`, then constant speed.
/// With `start` = infinity (or equal speeds) it is steady level flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelAcceleration {
    /// Altitude, m.
    pub altitude: f64,
    /// Speed before `start`, m/s.
    pub initial_speed: f64,
    /// Speed after the acceleration, m/s.
    pub final_speed: f64,
    /// Time the acceleration starts, s.
    pub start: f64,
    /// Magnitude of the along-track acceleration, m/s^2 (sign taken from the speeds).
    pub acceleration: f64,
}

impl LevelAcceleration {
    /// Steady level flight at `speed`.
    pub fn steady(altitude: f64, speed: f64) -> Self {
        LevelAcceleration {
            altitude,
            initial_speed: speed,
            final_speed: speed,
            start: 0.0,
            acceleration: 0.0,
        }
    }

    /// Along-track distance, speed and acceleration at `t`.
    fn along(&self, t: f64) -> (f64, f64, f64) {
        let (v0, v1) = (self.initial_speed, self.final_speed);
        let a = if v1 >= v0 {
            self.acceleration.abs()
        } else {
            -self.acceleration.abs()
        };
        if t <= self.start || a == 0.0 || v0 == v1 {
            return (v0 * t, v0, 0.0);
        }
        let end = self.start + (v1 - v0) / a;
        if t < end {
            let s = t - self.start;
            (v0 * t + 0.5 * a * s * s, v0 + a * s, a)
        } else {
            let s = end - self.start;
            (v0 * t + 0.5 * a * s * s + (v1 - v0) * (t - end), v1, 0.0)
        }
    }
}

impl<T: Real> FlightPath<T> for LevelAcceleration {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let (x, v, a) = self.along(t);
        state(
            Vector3::new(x, 0.0, -self.altitude),
            Vector3::new(v, 0.0, 0.0),
            Vector3::new(a, 0.0, 0.0),
            UnitQuaternion::identity(),
            Vector3::zeros(),
        )
    }
}

/// Level flight at `speed` until `start`, then the flight path rotates upward at a
/// constant `rate` (rad/s) for `duration`, then holds the climb angle
/// `rate * duration` in a straight line. Speed stays constant; pitch equals the
/// flight-path angle; the body pitch rate is `rate` during the pull-up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PullUp {
    /// Altitude at the start, m.
    pub altitude: f64,
    /// Speed, m/s.
    pub speed: f64,
    /// Time the pull-up starts, s.
    pub start: f64,
    /// Flight-path rotation rate, rad/s (positive up).
    pub rate: f64,
    /// Duration of the rotation, s.
    pub duration: f64,
}

impl<T: Real> FlightPath<T> for PullUp {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let v = self.speed;
        let level = Vector3::new(v * t.min(self.start), 0.0, -self.altitude);
        if t <= self.start || self.rate == 0.0 {
            let p = Vector3::new(v * t, 0.0, -self.altitude);
            return state(
                p,
                Vector3::new(v, 0.0, 0.0),
                Vector3::zeros(),
                UnitQuaternion::identity(),
                Vector3::zeros(),
            );
        }
        let radius = v / self.rate;
        let tau = (t - self.start).min(self.duration);
        let gamma = self.rate * tau;
        // Arc in the vertical plane: x forward, altitude up (z = -altitude).
        let arc = Vector3::new(radius * sin(gamma), 0.0, -radius * (1.0 - cos(gamma)));
        let direction = Vector3::new(cos(gamma), 0.0, -sin(gamma));
        let attitude = UnitQuaternion::from_euler_angles(0.0, gamma, 0.0);
        if t - self.start < self.duration {
            let accel = Vector3::new(-sin(gamma), 0.0, -cos(gamma)) * (v * self.rate);
            state(
                level + arc,
                direction * v,
                accel,
                attitude,
                Vector3::new(0.0, self.rate, 0.0),
            )
        } else {
            let straight = direction * (v * (t - self.start - self.duration));
            state(
                level + arc + straight,
                direction * v,
                Vector3::zeros(),
                attitude,
                Vector3::zeros(),
            )
        }
    }
}

/// A level coordinated turn at constant `speed` and turn `rate` (rad/s, positive to
/// the right, i.e. heading increasing) from `start`; straight level flight before.
/// Bank phi = atan(V w / g); body rates (0, w sin phi, w cos phi).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelTurn {
    /// Altitude, m.
    pub altitude: f64,
    /// Speed, m/s.
    pub speed: f64,
    /// Time the turn starts, s.
    pub start: f64,
    /// Turn rate, rad/s (positive: right turn).
    pub rate: f64,
    /// Gravity for the coordinated bank, m/s^2.
    pub gravity: f64,
}

impl LevelTurn {
    /// Coordinated bank angle, rad.
    pub fn bank(&self) -> f64 {
        atan(self.speed * self.rate / self.gravity)
    }
}

impl<T: Real> FlightPath<T> for LevelTurn {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let v = self.speed;
        if t <= self.start || self.rate == 0.0 {
            let p = Vector3::new(v * t, 0.0, -self.altitude);
            return state(
                p,
                Vector3::new(v, 0.0, 0.0),
                Vector3::zeros(),
                UnitQuaternion::identity(),
                Vector3::zeros(),
            );
        }
        let w = self.rate;
        let tau = t - self.start;
        let heading = w * tau;
        let radius = v / w;
        let p = Vector3::new(
            v * self.start + radius * sin(heading),
            radius * (1.0 - cos(heading)),
            -self.altitude,
        );
        let velocity = Vector3::new(cos(heading), sin(heading), 0.0) * v;
        let accel = Vector3::new(-sin(heading), cos(heading), 0.0) * (v * w);
        let bank = self.bank();
        let attitude = UnitQuaternion::from_euler_angles(bank, 0.0, heading);
        let body_rate = Vector3::new(0.0, w * sin(bank), w * cos(bank));
        state(p, velocity, accel, attitude, body_rate)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of position and velocity match velocity and acceleration,
    /// and the attitude's rate matches the body rate.
    fn consistent<P: FlightPath<f64>>(path: &P, times: &[f64]) {
        let h = 1e-4;
        for &t in times {
            let s = path.state_at(t);
            let (a, b) = (path.state_at(t - h), path.state_at(t + h));
            let v = (b.position - a.position) / (2.0 * h);
            let acc = (b.velocity - a.velocity) / (2.0 * h);
            assert!(
                (v - s.velocity).norm() < 1e-5 * (1.0 + s.velocity.norm()),
                "velocity at {t}"
            );
            assert!(
                (acc - s.acceleration).norm() < 1e-4 * (1.0 + s.acceleration.norm()),
                "acceleration at {t}"
            );
            // Body x along the velocity.
            let x = s.rotation() * Vector3::x();
            assert!(
                (x - s.velocity.normalize()).norm() < 1e-12,
                "attitude at {t}"
            );
            // q(t+h) = q(t) exp(w h) to first order.
            let dq = a.rotation().inverse() * b.rotation();
            let w = dq.scaled_axis() / (2.0 * h);
            assert!(
                (w - s.angular_rate).norm() < 1e-6,
                "body rate at {t}: {w} vs {}",
                s.angular_rate
            );
        }
    }

    #[test]
    fn profiles_are_kinematically_consistent() {
        let a = LevelAcceleration {
            altitude: 9000.0,
            initial_speed: 180.0,
            final_speed: 240.0,
            start: 2.0,
            acceleration: 10.0,
        };
        consistent(&a, &[1.0, 3.0, 7.0, 9.0]);
        assert_eq!(FlightPath::<f64>::state_at(&a, 20.0).velocity.x, 240.0);
        let p = PullUp {
            altitude: 9000.0,
            speed: 180.0,
            start: 2.0,
            rate: 0.1,
            duration: 5.0,
        };
        consistent(&p, &[1.0, 3.0, 6.5, 9.0]);
        let climb = FlightPath::<f64>::state_at(&p, 10.0);
        assert!((climb.velocity.z / 180.0 + 0.5f64.sin()).abs() < 1e-12);
        let turn = LevelTurn {
            altitude: 9000.0,
            speed: 240.0,
            start: 0.0,
            rate: 0.2,
            gravity: 9.80665,
        };
        consistent(&turn, &[0.5, 5.0, 20.0]);
        assert!((turn.bank().to_degrees() - 78.45).abs() < 0.05);
    }
}
