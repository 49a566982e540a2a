//! The paper's prescribed flight profiles (docs/design.md §8) as [`FlightPath`]s, and
//! [`ManoeuvrePath`], the flight path of any of `decoy_schema`'s
//! [`Manoeuvre`]s built from its parameters ([`ManoeuvreParams`]).
//!
//! All start at the origin of the horizontal plane heading north (+x) at altitude
//! `altitude`. Attitude follows the flight path: body x along the velocity, wings
//! level except in the turn, where the bank is the coordinated one,
//! tan(phi) = V w / g. Every profile gives position, velocity and acceleration that
//! are mutually consistent (each the derivative of the previous) and body rates and
//! angular accelerations consistent with the attitude.
//!
//! Each profile is evaluated in two ways: as a [`FlightPath`], computed in f64 and
//! rounded to `T` (the host's `decoy simulate`), and as a [`SplitState`] in the
//! solver's precision `T` (`split_state`: the decoy controller's built-in
//! profiles, one evaluation per frame). The second is for the Cortex-M4F, where
//! f64 is software-emulated and an f64 state with its trigonometry costs about
//! 38,000 instructions: positions are an f64 base (the straight legs) plus the arc
//! in `T`, and the trigonometry takes the angle reduced to a turn's period in f64
//! first, so that an f32 state keeps 1e-7 rad of heading however long a turn
//! lasts. The two agree to within `T`'s rounding (tested).
//!
//! A manoeuvre's physics is here: its profile type with both evaluations, and
//! its arm in [`ManoeuvrePath`].

use decoy_schema::Manoeuvre;
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

/// A profile's state in the solver's precision `T` ([`LevelAcceleration::split_state`]
/// and the others): the position as an f64 base plus an offset in `T`, the rest
/// in `T` (body angular acceleration zero).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitState<T: Real> {
    /// The position's f64 part, NED, m: the straight legs (they grow without bound).
    pub base: [f64; 3],
    /// The position's part in `T`, NED, m: the arc.
    pub offset: Vec3<T>,
    /// Velocity, NED, m/s.
    pub velocity: Vec3<T>,
    /// Acceleration, NED, m/s^2.
    pub acceleration: Vec3<T>,
    /// Attitude, body to NED, `[w, x, y, z]`.
    pub attitude: [T; 4],
    /// Body rates, rad/s.
    pub rate: Vec3<T>,
}

/// 2 pi, for the reduction of a turn's heading.
const TWO_PI: f64 = core::f64::consts::TAU;

/// Wings level, heading north: the identity quaternion.
fn level_attitude<T: Real>() -> [T; 4] {
    [T::one(), T::zero(), T::zero(), T::zero()]
}

/// Straight level flight north at `speed` through the origin at `tau`.
fn straight<T: Real>(altitude: f64, speed: f64, tau: f64) -> SplitState<T> {
    SplitState {
        base: [speed * tau, 0.0, -altitude],
        offset: Vec3::zeros(),
        velocity: Vec3::new(T::lit(speed), T::zero(), T::zero()),
        acceleration: Vec3::zeros(),
        attitude: level_attitude(),
        rate: Vec3::zeros(),
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

impl LevelAcceleration {
    /// The state at `tau` in `T` ([`SplitState`]): the along-track distance,
    /// speed and acceleration are polynomials (f64, no trigonometry), `along`'s
    /// arithmetic written out as the controller's built-in frames had it (through
    /// `along` the firmware's code for them would change).
    pub fn split_state<T: Real>(&self, tau: f64) -> SplitState<T> {
        let (v0, v1) = (self.initial_speed, self.final_speed);
        let a = if v1 >= v0 {
            self.acceleration.abs()
        } else {
            -self.acceleration.abs()
        };
        if tau <= self.start || a == 0.0 || v0 == v1 {
            return straight(self.altitude, v0, tau);
        }
        let end = self.start + (v1 - v0) / a;
        let (x, v, acc) = if tau < end {
            let s = tau - self.start;
            (v0 * tau + 0.5 * a * s * s, v0 + a * s, a)
        } else {
            let s = end - self.start;
            (
                v0 * tau + 0.5 * a * s * s + (v1 - v0) * (tau - end),
                v1,
                0.0,
            )
        };
        SplitState {
            base: [x, 0.0, -self.altitude],
            offset: Vec3::zeros(),
            velocity: Vec3::new(T::lit(v), T::zero(), T::zero()),
            acceleration: Vec3::new(T::lit(acc), T::zero(), T::zero()),
            attitude: level_attitude(),
            rate: Vec3::zeros(),
        }
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

impl PullUp {
    /// The state at `tau` in `T` ([`SplitState`]): the arc of radius v/w about
    /// the point above the pull-up's start, its climb angle
    /// gamma = w min(tau - start, duration) (at most 4 rad: the profile's rate is
    /// at most 1 rad/s for 5 s, `Real::sin_cos_small`'s range with the half
    /// angle), then the straight climb.
    pub fn split_state<T: Real>(&self, tau: f64) -> SplitState<T> {
        let v = self.speed;
        if tau <= self.start || self.rate == 0.0 {
            return straight(self.altitude, v, tau);
        }
        let since = tau - self.start;
        let rotating = since < self.duration;
        let gamma = self.rate * if rotating { since } else { self.duration };
        let radius = T::lit(v / self.rate);
        // The half angle's sine and cosine (the attitude's), the angle's by the
        // double-angle formulas: one evaluation.
        let (sh, ch) = (T::lit(0.5 * gamma)).sin_cos_small();
        let (sin, cos) = (T::lit(2.0) * sh * ch, ch * ch - sh * sh);
        let speed = T::lit(v);
        let direction = Vec3::new(cos, T::zero(), -sin);
        // Arc in the vertical plane: x forward, altitude up (z = -altitude).
        let offset = Vec3::new(radius * sin, T::zero(), -(radius * (T::one() - cos)));
        let mut base = [v * self.start, 0.0, -self.altitude];
        let (acceleration, rate) = if rotating {
            (
                Vec3::new(-sin, T::zero(), -cos) * (speed * T::lit(self.rate)),
                Vec3::new(T::zero(), T::lit(self.rate), T::zero()),
            )
        } else {
            // The straight climb after the arc: its length in f64 (it grows without
            // bound), its direction in T.
            let length = v * (since - self.duration);
            base[0] += length * cos.to_f64();
            base[2] -= length * sin.to_f64();
            (Vec3::zeros(), Vec3::zeros())
        };
        // Pitch gamma about the body y axis: q = (cos g/2, 0, sin g/2, 0).
        SplitState {
            base,
            offset,
            velocity: direction * speed,
            acceleration,
            attitude: [ch, T::zero(), sh, T::zero()],
            rate,
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

impl LevelTurn {
    /// The state at `tau` in `T` ([`SplitState`]): the circle of radius v/w,
    /// heading w (tau - start) reduced to [0, 2 pi) in f64, the coordinated bank
    /// atan(v w / g).
    pub fn split_state<T: Real>(&self, tau: f64) -> SplitState<T> {
        let v = self.speed;
        if tau <= self.start || self.rate == 0.0 {
            return straight(self.altitude, v, tau);
        }
        let w = self.rate;
        let heading = w * (tau - self.start);
        // The position is periodic in the heading: reduce it (f64) before T.
        let turns = libm::floor(heading / TWO_PI);
        let half_heading = T::lit(0.5 * (heading - turns * TWO_PI));
        let (sh, ch) = half_heading.sin_cos_small();
        let (sin, cos) = (T::lit(2.0) * sh * ch, ch * ch - sh * sh);
        let radius = T::lit(v / w);
        let speed = T::lit(v);
        // The coordinated bank atan(v w / g), in T (an f64 atan is a library call of
        // about 1,500 instructions on the M4F); its half angle's sine and cosine.
        let bank = T::lit(v * w / self.gravity).atan();
        let (sb, cb) = (T::lit(0.5) * bank).sin_cos_small();
        SplitState {
            base: [v * self.start, 0.0, -self.altitude],
            offset: Vec3::new(radius * sin, radius * (T::one() - cos), T::zero()),
            velocity: Vec3::new(cos, sin, T::zero()) * speed,
            acceleration: Vec3::new(-sin, cos, T::zero()) * (speed * T::lit(w)),
            // Yaw(heading) then roll(bank): q = q_z(heading) q_x(bank).
            attitude: [ch * cb, ch * sb, sh * sb, sh * cb],
            rate: Vec3::new(
                T::zero(),
                T::lit(w) * (T::lit(2.0) * sb * cb),
                T::lit(w) * (cb * cb - sb * sb),
            ),
        }
    }
}

/// The parameters of any manoeuvre, SI (speeds in m/s): each manoeuvre reads
/// those it has (`decoy_schema::Parameter`), the others are ignored.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ManoeuvreParams {
    /// Altitude at the start, m.
    pub altitude: f64,
    /// Initial speed, m/s.
    pub speed: f64,
    /// Speed after the acceleration, m/s.
    pub final_speed: f64,
    /// When the manoeuvre starts (the acceleration or the rotation), s.
    pub start: f64,
    /// Magnitude of the along-track acceleration, m/s^2.
    pub acceleration: f64,
    /// Flight-path rotation rate, rad/s.
    pub rate: f64,
    /// Duration of the rotation, s.
    pub duration: f64,
    /// Gravity for a turn's coordinated bank, m/s^2.
    pub gravity: f64,
}

/// The flight path of a [`Manoeuvre`]: the profile that flies it.
///
/// `Level` comes first, so that a `Some` of a `Level` path of zero parameters is
/// all zero bits (the decoy controller's unconfigured constant lies in `.bss`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ManoeuvrePath {
    /// Steady level flight or a level acceleration.
    Level(LevelAcceleration),
    /// The pull-up.
    PullUp(PullUp),
    /// The level coordinated turn.
    Turn(LevelTurn),
}

impl ManoeuvrePath {
    /// The path of `manoeuvre` with `params` (each manoeuvre reads its own).
    pub fn new(manoeuvre: Manoeuvre, params: &ManoeuvreParams) -> Self {
        let p = params;
        match manoeuvre {
            Manoeuvre::Steady => {
                ManoeuvrePath::Level(LevelAcceleration::steady(p.altitude, p.speed))
            }
            Manoeuvre::Acceleration => ManoeuvrePath::Level(LevelAcceleration {
                altitude: p.altitude,
                initial_speed: p.speed,
                final_speed: p.final_speed,
                start: p.start,
                acceleration: p.acceleration,
            }),
            Manoeuvre::PullUp => ManoeuvrePath::PullUp(PullUp {
                altitude: p.altitude,
                speed: p.speed,
                start: p.start,
                rate: p.rate,
                duration: p.duration,
            }),
            Manoeuvre::Turn => ManoeuvrePath::Turn(LevelTurn {
                altitude: p.altitude,
                speed: p.speed,
                start: p.start,
                rate: p.rate,
                gravity: p.gravity,
            }),
        }
    }

    /// When the manoeuvre starts, s: the acceleration, pull-up or turn start (0
    /// for steady flight).
    pub fn manoeuvre_start(&self) -> f64 {
        match self {
            ManoeuvrePath::Level(p) => {
                if p.final_speed == p.initial_speed || p.acceleration == 0.0 {
                    0.0
                } else {
                    p.start
                }
            }
            ManoeuvrePath::PullUp(p) => p.start,
            ManoeuvrePath::Turn(p) => p.start,
        }
    }

    /// The times, s, at which the path's acceleration or rotation rate jumps (a
    /// manoeuvre's start and end; none for steady flight), in increasing order: an
    /// integrator whose steps end exactly there keeps RK4's order through them
    /// (a step that straddles a jump integrates a kink) and starts each manoeuvre
    /// at its time, not a stage early.
    pub fn breakpoints(&self) -> [Option<f64>; 2] {
        match self {
            ManoeuvrePath::Level(p) => {
                let (v0, v1) = (p.initial_speed, p.final_speed);
                let a = p.acceleration.abs();
                if a == 0.0 || v0 == v1 {
                    [None, None]
                } else {
                    // `along`'s end of the acceleration: start + (v1 - v0) / a.
                    let a = if v1 >= v0 { a } else { -a };
                    [Some(p.start), Some(p.start + (v1 - v0) / a)]
                }
            }
            ManoeuvrePath::PullUp(p) => [Some(p.start), Some(p.start + p.duration)],
            ManoeuvrePath::Turn(p) => [Some(p.start), None],
        }
    }

    /// The flight-path rotation rate, rad/s, of a path that rotates.
    pub fn rate(&self) -> Option<f64> {
        match self {
            ManoeuvrePath::Level(_) => None,
            ManoeuvrePath::PullUp(p) => Some(p.rate),
            ManoeuvrePath::Turn(p) => Some(p.rate),
        }
    }

    /// True for a path that turns left (heading decreasing), whose outside is on
    /// the right.
    pub fn turns_left(&self) -> bool {
        matches!(self, ManoeuvrePath::Turn(p) if p.rate < 0.0)
    }

    /// The state at `tau` in `T` ([`SplitState`]). Always inlined: the caller's
    /// code is then the same as with the match written there (the decoy
    /// controller's frame, on the firmware's frame path).
    #[inline(always)]
    pub fn split_state<T: Real>(&self, tau: f64) -> SplitState<T> {
        match self {
            ManoeuvrePath::Level(p) => p.split_state::<T>(tau),
            ManoeuvrePath::PullUp(p) => p.split_state::<T>(tau),
            ManoeuvrePath::Turn(p) => p.split_state::<T>(tau),
        }
    }
}

impl<T: Real> FlightPath<T> for ManoeuvrePath {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        match self {
            ManoeuvrePath::Level(p) => p.state_at(t),
            ManoeuvrePath::PullUp(p) => p.state_at(t),
            ManoeuvrePath::Turn(p) => p.state_at(t),
        }
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

    /// Within `relative` of the distance flown (the `T` direction of a straight
    /// leg), 1 mm on the arcs, and `T`'s rounding on the rest.
    fn close<T: Real>(split: &SplitState<T>, state: &AircraftState<f64>, relative: f64) {
        let distance = state.position.xy().norm();
        let position = [
            split.base[0] + split.offset.x.to_f64(),
            split.base[1] + split.offset.y.to_f64(),
            split.base[2] + split.offset.z.to_f64(),
        ];
        for i in 0..3 {
            assert!(
                (position[i] - state.position[i]).abs() < 1e-3 + relative * distance,
                "position {i}: {} against {}",
                position[i],
                state.position[i]
            );
            assert!((split.velocity[i].to_f64() - state.velocity[i]).abs() < 1e-3);
            assert!((split.acceleration[i].to_f64() - state.acceleration[i]).abs() < 1e-3);
            assert!((split.rate[i].to_f64() - state.angular_rate[i]).abs() < 1e-6);
        }
        // The same attitude (q and -q alike).
        let dot: f64 = (0..4)
            .map(|i| split.attitude[i].to_f64() * state.attitude[i])
            .sum();
        assert!((dot.abs() - 1.0).abs() < 1e-6, "attitude {dot}");
    }

    /// The split states follow the f64 profiles within `T`'s rounding, over long
    /// runs too (the turn's heading reduced before `T`).
    #[test]
    fn split_states_follow_the_profiles() {
        let level = LevelAcceleration {
            altitude: 9000.0,
            initial_speed: 182.0,
            final_speed: 243.0,
            start: 2.0,
            acceleration: 10.0,
        };
        let pull = PullUp {
            altitude: 9000.0,
            speed: 182.0,
            start: 2.0,
            rate: 0.2,
            duration: 5.0,
        };
        let turn = LevelTurn {
            altitude: 9000.0,
            speed: 243.0,
            start: 0.0,
            rate: 0.2,
            gravity: 9.80665,
        };
        for tau in [
            0.0, 0.01, 1.99, 2.0, 2.37, 6.99, 7.0, 7.01, 12.5, 25.0, 600.0,
        ] {
            for path in [
                ManoeuvrePath::Level(level),
                ManoeuvrePath::PullUp(pull),
                ManoeuvrePath::Turn(turn),
            ] {
                let exact: AircraftState<f64> = path.state_at(tau);
                // f32 trigonometry on a radius of up to 1.2 km and a straight
                // climb of up to 110 km.
                close(&path.split_state::<f32>(tau), &exact, 1e-7);
                close(&path.split_state::<f64>(tau), &exact, 1e-12);
            }
        }
    }

    /// Each manoeuvre's path reads its own parameters.
    #[test]
    fn manoeuvre_paths_from_parameters() {
        let p = ManoeuvreParams {
            altitude: 9000.0,
            speed: 182.0,
            final_speed: 243.0,
            start: 2.0,
            acceleration: 10.0,
            rate: -0.1,
            duration: 5.0,
            gravity: 9.80665,
        };
        let steady = ManoeuvrePath::new(Manoeuvre::Steady, &p);
        assert_eq!(
            steady,
            ManoeuvrePath::Level(LevelAcceleration::steady(9000.0, 182.0))
        );
        assert_eq!(steady.manoeuvre_start(), 0.0);
        let acceleration = ManoeuvrePath::new(Manoeuvre::Acceleration, &p);
        assert_eq!(acceleration.manoeuvre_start(), 2.0);
        assert_eq!(acceleration.rate(), None);
        let pull = ManoeuvrePath::new(Manoeuvre::PullUp, &p);
        assert_eq!(pull.rate(), Some(-0.1));
        assert!(!pull.turns_left());
        let turn = ManoeuvrePath::new(Manoeuvre::Turn, &p);
        assert!(turn.turns_left());
        assert_eq!(
            turn,
            ManoeuvrePath::Turn(LevelTurn {
                altitude: 9000.0,
                speed: 182.0,
                start: 2.0,
                rate: -0.1,
                gravity: 9.80665,
            })
        );
    }
}
