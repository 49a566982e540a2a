//! The built-in profiles the controller flies by itself ([`Profile`] other than
//! `Streamed`): the paper's level acceleration, pull-up and level turn, as the
//! aircraft state frames a host would send.
//!
//! The controller turns each State frame of a built-in run (its clock only) into
//! the profile's state at that frame's profile time ([`BuiltinPath::frame`]), then
//! integrates between frames along the same [`crate::FramePath`] as a streamed
//! run. The profile is evaluated once per frame, at the frame's time: in the
//! solver's precision `T` (f32 on the Cortex-M4F, where f64 is software-emulated
//! and an f64 state with its trigonometry cost about 38,000 instructions),
//! positions as an f64 base (the straight legs) plus the arc in `T`. The
//! trigonometry takes the angle reduced to a turn's period in f64 first, so an f32
//! controller keeps 1e-7 rad of heading however long a turn lasts. The formulas
//! are `solver_core::profiles`' (the host's `decoy simulate`), whose f64 states
//! these frames follow to within f32 rounding (tested).

use solver_core::profiles::{LevelAcceleration, LevelTurn, PullUp};
use solver_core::{Real, Vec3};

use decoy_link::AircraftStateFrame;

/// A built-in profile's flight path: the profile's parameters in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum BuiltinPath {
    /// Steady level flight or a level acceleration.
    Level(LevelAcceleration),
    /// The pull-up.
    PullUp(PullUp),
    /// The level coordinated turn.
    Turn(LevelTurn),
}

/// 2 pi, for the reduction of a turn's heading.
const TWO_PI: f64 = core::f64::consts::TAU;

impl BuiltinPath {
    /// The State frame numbered `seq` at `time_s` of a run whose profile time is
    /// `tau` (s since the run began): the profile's state at `tau`, velocities and
    /// the rest in `T`, then narrowed to the wire's f32.
    pub(crate) fn frame<T: Real>(&self, seq: u32, time_s: f64, tau: f64) -> AircraftStateFrame {
        let state = match self {
            BuiltinPath::Level(p) => level::<T>(p, tau),
            BuiltinPath::PullUp(p) => pull_up::<T>(p, tau),
            BuiltinPath::Turn(p) => turn::<T>(p, tau),
        };
        state.frame(seq, time_s)
    }
}

/// A profile state: the position as an f64 base plus an offset in `T`, the rest
/// in `T`.
struct ProfileState<T: Real> {
    base: [f64; 3],
    offset: Vec3<T>,
    velocity: Vec3<T>,
    acceleration: Vec3<T>,
    attitude: [T; 4],
    rate: Vec3<T>,
}

impl<T: Real> ProfileState<T> {
    fn frame(&self, seq: u32, time_s: f64) -> AircraftStateFrame {
        let f = |v: T| v.to_f64() as f32;
        let v3 = |v: &Vec3<T>| [f(v.x), f(v.y), f(v.z)];
        AircraftStateFrame {
            seq,
            time_s,
            position_ned_m: [
                self.base[0] + self.offset.x.to_f64(),
                self.base[1] + self.offset.y.to_f64(),
                self.base[2] + self.offset.z.to_f64(),
            ],
            velocity_ned_mps: v3(&self.velocity),
            acceleration_ned_mps2: v3(&self.acceleration),
            attitude_wxyz: self.attitude.map(f),
            body_rate_radps: v3(&self.rate),
            body_angular_acceleration_radps2: [0.0; 3],
        }
    }
}

/// Wings level, heading north: the identity quaternion.
fn level_attitude<T: Real>() -> [T; 4] {
    [T::one(), T::zero(), T::zero(), T::zero()]
}

/// Straight level flight north at `speed` through the origin at `tau`.
fn straight<T: Real>(altitude: f64, speed: f64, tau: f64) -> ProfileState<T> {
    ProfileState {
        base: [speed * tau, 0.0, -altitude],
        offset: Vec3::zeros(),
        velocity: Vec3::new(T::lit(speed), T::zero(), T::zero()),
        acceleration: Vec3::zeros(),
        attitude: level_attitude(),
        rate: Vec3::zeros(),
    }
}

/// [`LevelAcceleration`] at `tau`: the along-track distance, speed and
/// acceleration are polynomials (f64, no trigonometry).
fn level<T: Real>(p: &LevelAcceleration, tau: f64) -> ProfileState<T> {
    let (v0, v1) = (p.initial_speed, p.final_speed);
    let a = if v1 >= v0 {
        p.acceleration.abs()
    } else {
        -p.acceleration.abs()
    };
    if tau <= p.start || a == 0.0 || v0 == v1 {
        return straight(p.altitude, v0, tau);
    }
    let end = p.start + (v1 - v0) / a;
    let (x, v, acc) = if tau < end {
        let s = tau - p.start;
        (v0 * tau + 0.5 * a * s * s, v0 + a * s, a)
    } else {
        let s = end - p.start;
        (
            v0 * tau + 0.5 * a * s * s + (v1 - v0) * (tau - end),
            v1,
            0.0,
        )
    };
    ProfileState {
        base: [x, 0.0, -p.altitude],
        offset: Vec3::zeros(),
        velocity: Vec3::new(T::lit(v), T::zero(), T::zero()),
        acceleration: Vec3::new(T::lit(acc), T::zero(), T::zero()),
        attitude: level_attitude(),
        rate: Vec3::zeros(),
    }
}

/// [`PullUp`] at `tau`: the arc of radius v/w about the point above the pull-up's
/// start, its climb angle gamma = w min(tau - start, duration) (at most 4 rad:
/// the profile's rate is at most 1 rad/s for 5 s, `Real::sin_cos_small`'s range
/// with the half angle), then the straight climb.
fn pull_up<T: Real>(p: &PullUp, tau: f64) -> ProfileState<T> {
    let v = p.speed;
    if tau <= p.start || p.rate == 0.0 {
        return straight(p.altitude, v, tau);
    }
    let since = tau - p.start;
    let rotating = since < p.duration;
    let gamma = p.rate * if rotating { since } else { p.duration };
    let radius = T::lit(v / p.rate);
    // The half angle's sine and cosine (the attitude's), the angle's by the
    // double-angle formulas: one evaluation.
    let (sh, ch) = (T::lit(0.5 * gamma)).sin_cos_small();
    let (sin, cos) = (T::lit(2.0) * sh * ch, ch * ch - sh * sh);
    let speed = T::lit(v);
    let direction = Vec3::new(cos, T::zero(), -sin);
    // Arc in the vertical plane: x forward, altitude up (z = -altitude).
    let offset = Vec3::new(radius * sin, T::zero(), -(radius * (T::one() - cos)));
    let mut base = [v * p.start, 0.0, -p.altitude];
    let (acceleration, rate) = if rotating {
        (
            Vec3::new(-sin, T::zero(), -cos) * (speed * T::lit(p.rate)),
            Vec3::new(T::zero(), T::lit(p.rate), T::zero()),
        )
    } else {
        // The straight climb after the arc: its length in f64 (it grows without
        // bound), its direction in T.
        let length = v * (since - p.duration);
        base[0] += length * cos.to_f64();
        base[2] -= length * sin.to_f64();
        (Vec3::zeros(), Vec3::zeros())
    };
    // Pitch gamma about the body y axis: q = (cos g/2, 0, sin g/2, 0).
    ProfileState {
        base,
        offset,
        velocity: direction * speed,
        acceleration,
        attitude: [ch, T::zero(), sh, T::zero()],
        rate,
    }
}

/// [`LevelTurn`] at `tau`: the circle of radius v/w, heading w (tau - start)
/// reduced to [0, 2 pi) in f64, the coordinated bank atan(v w / g).
fn turn<T: Real>(p: &LevelTurn, tau: f64) -> ProfileState<T> {
    let v = p.speed;
    if tau <= p.start || p.rate == 0.0 {
        return straight(p.altitude, v, tau);
    }
    let w = p.rate;
    let heading = w * (tau - p.start);
    // The position is periodic in the heading: reduce it (f64) before T.
    let turns = libm::floor(heading / TWO_PI);
    let half_heading = T::lit(0.5 * (heading - turns * TWO_PI));
    let (sh, ch) = half_heading.sin_cos_small();
    let (sin, cos) = (T::lit(2.0) * sh * ch, ch * ch - sh * sh);
    let radius = T::lit(v / w);
    let speed = T::lit(v);
    // The coordinated bank atan(v w / g), in T (an f64 atan is a library call of
    // about 1,500 instructions on the M4F); its half angle's sine and cosine.
    let bank = T::lit(v * w / p.gravity).atan();
    let (sb, cb) = (T::lit(0.5) * bank).sin_cos_small();
    ProfileState {
        base: [v * p.start, 0.0, -p.altitude],
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

#[cfg(test)]
mod tests {
    use super::*;
    use solver_core::{AircraftState, FlightPath};

    /// Within `relative` of the distance flown (the f32 direction of a straight
    /// leg), 1 mm on the arcs, and f32 rounding on the rest.
    fn close(frame: &AircraftStateFrame, state: &AircraftState<f64>, relative: f64) {
        let distance = state.position.xy().norm();
        for i in 0..3 {
            assert!(
                (frame.position_ned_m[i] - state.position[i]).abs() < 1e-3 + relative * distance,
                "position {i}: {} against {}",
                frame.position_ned_m[i],
                state.position[i]
            );
            assert!((f64::from(frame.velocity_ned_mps[i]) - state.velocity[i]).abs() < 1e-3);
            assert!(
                (f64::from(frame.acceleration_ned_mps2[i]) - state.acceleration[i]).abs() < 1e-3
            );
            assert!((f64::from(frame.body_rate_radps[i]) - state.angular_rate[i]).abs() < 1e-6);
        }
        // The same attitude (q and -q alike).
        let dot: f64 = (0..4)
            .map(|i| f64::from(frame.attitude_wxyz[i]) * state.attitude[i])
            .sum();
        assert!((dot.abs() - 1.0).abs() < 1e-6, "attitude {dot}");
    }

    /// The frames follow `solver_core::profiles`' f64 states within f32 rounding,
    /// over long runs too (the turn's heading reduced before T).
    #[test]
    fn frames_follow_the_profiles() {
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
                BuiltinPath::Level(level),
                BuiltinPath::PullUp(pull),
                BuiltinPath::Turn(turn),
            ] {
                let exact: AircraftState<f64> = match path {
                    BuiltinPath::Level(p) => p.state_at(tau),
                    BuiltinPath::PullUp(p) => p.state_at(tau),
                    BuiltinPath::Turn(p) => p.state_at(tau),
                };
                // f32 trigonometry on a radius of up to 1.2 km and a straight
                // climb of up to 110 km.
                close(&path.frame::<f32>(7, 100.0 + tau, tau), &exact, 1e-7);
                close(&path.frame::<f64>(7, 100.0 + tau, tau), &exact, 1e-12);
            }
        }
    }
}
