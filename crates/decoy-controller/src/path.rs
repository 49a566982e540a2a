//! [`FramePath`]: the aircraft's flight path between two State frames, the one
//! path the controller and the host reference both integrate along.

use solver_core::{AircraftState, FlightPath, Real, Vec3};

use decoy_link::AircraftStateFrame;

/// One frame's kinematics in the solver's precision, position relative to the
/// run's origin: what the path returns at that frame's time.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sample<T: Real> {
    position: Vec3<T>,
    velocity: Vec3<T>,
    acceleration: Vec3<T>,
    /// Normalised in `T`.
    attitude: [T; 4],
    rate: Vec3<T>,
    angular_acceleration: Vec3<T>,
}

impl<T: Real> Sample<T> {
    /// The frame's kinematics; the position is taken relative to `origin` in f64
    /// (the one quantity the wire carries in f64), the rest converted from the
    /// wire's f32 (exact for both precisions).
    fn of(frame: &AircraftStateFrame, origin: &[f64; 3]) -> Self {
        let p = frame.position_ned_m;
        let attitude = normalised(frame.attitude_wxyz.map(wide::<T>));
        Sample {
            position: Vec3::new(
                T::lit(p[0] - origin[0]),
                T::lit(p[1] - origin[1]),
                T::lit(p[2] - origin[2]),
            ),
            velocity: wide3(frame.velocity_ned_mps),
            acceleration: wide3(frame.acceleration_ned_mps2),
            attitude,
            rate: wide3(frame.body_rate_radps),
            angular_acceleration: wide3(frame.body_angular_acceleration_radps2),
        }
    }

    fn state(&self) -> AircraftState<T> {
        AircraftState {
            position: self.position,
            velocity: self.velocity,
            acceleration: self.acceleration,
            attitude: self.attitude,
            angular_rate: self.rate,
            angular_acceleration: self.angular_acceleration,
        }
    }
}

/// q / |q| (the identity for a zero quaternion).
#[inline(always)]
fn normalised<T: Real>(q: [T; 4]) -> [T; 4] {
    let norm = q
        .iter()
        .fold(T::zero(), |sum, c| sum + *c * *c)
        .square_root();
    if norm > T::zero() {
        q.map(|c| c / norm)
    } else {
        [T::one(), T::zero(), T::zero(), T::zero()]
    }
}

/// A wire f32 in the solver's precision (exact).
#[inline(always)]
fn wide<T: Real>(v: f32) -> T {
    T::lit(f64::from(v))
}

fn wide3<T: Real>(v: [f32; 3]) -> Vec3<T> {
    Vec3::new(wide(v[0]), wide(v[1]), wide(v[2]))
}

/// The flight path over [t0, t1] between the previous accepted State frame (t0)
/// and the current one (t1), in the solver's precision `T` (f32 on the
/// Cortex-M4F, where f64 is software-emulated). Built once per frame: positions
/// relative to the origin and the displacement p1 - p0 are taken in f64, every
/// other value comes from the wire's f32; quaternions are normalised in `T`.
/// With s = (t - t0)/h, h = t1 - t0:
///
/// - position and velocity: the cubic Hermite through both frames' positions and
///   velocities, written about p0: p = p0 + h01 (p1 - p0) + h h10 v0 + h h11 v1,
///   v = (p1 - p0) h01'/h + h10' v0 + h11' v1 (so the small displacement keeps
///   full relative precision even in f32);
/// - acceleration, body rate and body angular acceleration: linear in s;
/// - attitude: normalised linear interpolation (nlerp) of the normalised
///   quaternions along the shorter arc.
///
/// At t <= t0 (s = 0) the path is exactly the previous frame's sample and at
/// t >= t1 exactly the current frame's (its position, velocity and the quaternion
/// as sent, normalised): so the path of the next frame starts with the bits this
/// one ends with, and the solver evaluates the end of one frame and the start of
/// the next with the same inputs (and reuses that evaluation, `Solver::step`).
///
/// Positions are relative to `origin` (NED, m), which the controller sets to the
/// horizontal position of the frame it trimmed at, so that an f32 solver keeps
/// centimetre resolution however far the aircraft flies (the air depends only on
/// the altitude, so the shift changes nothing else). A single frame (or t1 <= t0)
/// gives a constant state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePath<T: Real> {
    /// Time of the previous frame, s.
    t0: f64,
    /// Bits of t1 - t0 (s, f64) as an integer, where t1 is the current frame's
    /// time; 0 when t1 is not after t0 (a constant path at `to`).
    span_bits: i64,
    /// 1 / (t1 - t0), 1/s (zero for a constant path).
    inverse_span: T,
    /// t1 - t0, s.
    span: T,
    from: Sample<T>,
    to: Sample<T>,
    /// `to.attitude`, negated if that is the shorter arc from `from.attitude`.
    to_attitude_near: [T; 4],
    /// p1 - p0 taken in f64, then rounded once.
    delta: Vec3<T>,
}

impl<T: Real> FramePath<T> {
    /// The path from `previous` to `current`, positions relative to `origin`.
    pub fn new(
        previous: &AircraftStateFrame,
        current: &AircraftStateFrame,
        origin: [f64; 3],
    ) -> Self {
        let from = Sample::of(previous, &origin);
        let to = Sample::of(current, &origin);
        // Shortest arc: q and -q are the same attitude.
        let dot = (0..4).fold(T::zero(), |sum, i| sum + from.attitude[i] * to.attitude[i]);
        let to_attitude_near = if dot < T::zero() {
            to.attitude.map(|c: T| -c)
        } else {
            to.attitude
        };
        let (p0, p1) = (previous.position_ned_m, current.position_ned_m);
        let delta = Vec3::new(
            T::lit(p1[0] - p0[0]),
            T::lit(p1[1] - p0[1]),
            T::lit(p1[2] - p0[2]),
        );
        let span = current.time_s - previous.time_s;
        let (span_bits, inverse_span, span) = if span > 0.0 {
            (span.to_bits() as i64, T::lit(1.0 / span), T::lit(span))
        } else {
            (0, T::zero(), T::zero())
        };
        FramePath {
            t0: previous.time_s,
            span_bits,
            inverse_span,
            span,
            from,
            to,
            to_attitude_near,
            delta,
        }
    }

    /// The constant path at one frame (its state at every time).
    pub fn single(frame: &AircraftStateFrame, origin: [f64; 3]) -> Self {
        FramePath::new(frame, frame, origin)
    }

    /// The origin of a run that trims at `frame`: the frame's horizontal
    /// position (so that an f32 solver keeps centimetre resolution, above).
    pub fn run_origin(frame: &AircraftStateFrame) -> [f64; 3] {
        let p = frame.position_ned_m;
        [p[0], p[1], 0.0]
    }
}

/// `aircraft` in steady straight flight, the trim's condition: its position,
/// velocity and attitude, its acceleration and rotation set to zero.
pub fn steady_flight<T: Real>(aircraft: &AircraftState<T>) -> AircraftState<T> {
    AircraftState {
        acceleration: Vec3::zeros(),
        angular_rate: Vec3::zeros(),
        angular_acceleration: Vec3::zeros(),
        ..*aircraft
    }
}

impl<T: Real> FlightPath<T> for FramePath<T> {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        // t - t0 against 0 and against t1 - t0 (the same f64 difference at t = t1),
        // compared as bit patterns: for non-negative doubles their order is that of
        // the integers (on the M4F a soft-float compare costs about 30 instructions).
        let elapsed = t - self.t0;
        let bits = elapsed.to_bits() as i64;
        // A NaN takes one of the two branches: with its sign bit set it is negative as
        // an integer, without it it lies above every span (a positive double, at most
        // +inf, whose bits are below every NaN's).
        if bits >= self.span_bits {
            return self.to.state();
        }
        if bits <= 0 {
            return self.from.state();
        }
        let s = T::lit(elapsed) * self.inverse_span;
        let s = if s < T::one() { s } else { T::one() };
        let step = self.span;
        let lit = T::lit;
        // Hermite basis (h01 = 1 - h00, so p = p0 + h01 (p1 - p0) + ...) and its
        // derivatives per unit s (d00 = -d01).
        let (s2, s3) = (s * s, s * s * s);
        let h10 = s3 - lit(2.0) * s2 + s;
        let h01 = lit(3.0) * s2 - lit(2.0) * s3;
        let h11 = s3 - s2;
        let d10 = lit(3.0) * s2 - lit(4.0) * s + T::one();
        let d01 = lit(6.0) * (s - s2);
        let d11 = lit(3.0) * s2 - lit(2.0) * s;
        let (a, b) = (&self.from, &self.to);
        let (delta, v0, v1) = (self.delta, a.velocity, b.velocity);
        let position = a.position + delta * h01 + (v0 * h10 + v1 * h11) * step;
        let velocity = delta * (d01 * self.inverse_span) + v0 * d10 + v1 * d11;
        let lerp = |x: &Vec3<T>, y: &Vec3<T>| -> Vec3<T> { x + (y - x) * s };
        let attitude = normalised([0, 1, 2, 3].map(|i| {
            let qa = a.attitude[i];
            qa + (self.to_attitude_near[i] - qa) * s
        }));
        AircraftState {
            position,
            velocity,
            acceleration: lerp(&a.acceleration, &b.acceleration),
            attitude,
            angular_rate: lerp(&a.rate, &b.rate),
            angular_acceleration: lerp(&a.angular_acceleration, &b.angular_acceleration),
        }
    }
}

/// The aircraft state `state` at `time_s` as the State frame numbered `seq` a host
/// sends (velocities, accelerations, attitude and rates narrowed to f32).
pub fn state_frame(seq: u32, time_s: f64, state: &AircraftState<f64>) -> AircraftStateFrame {
    let f32s = |v: &Vec3<f64>| [v.x as f32, v.y as f32, v.z as f32];
    AircraftStateFrame {
        seq,
        time_s,
        position_ned_m: [state.position.x, state.position.y, state.position.z],
        velocity_ned_mps: f32s(&state.velocity),
        acceleration_ned_mps2: f32s(&state.acceleration),
        attitude_wxyz: state.attitude.map(|q| q as f32),
        body_rate_radps: f32s(&state.angular_rate),
        body_angular_acceleration_radps2: f32s(&state.angular_acceleration),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(t: f64, x: f64, v: f32) -> AircraftStateFrame {
        AircraftStateFrame {
            seq: 0,
            time_s: t,
            position_ned_m: [x, 10.0, -9000.0],
            velocity_ned_mps: [v, 0.0, 0.0],
            acceleration_ned_mps2: [1.0, 0.0, 0.0],
            attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
            body_rate_radps: [0.0; 3],
            body_angular_acceleration_radps2: [0.0; 3],
        }
    }

    #[test]
    fn hermite_reproduces_the_end_frames_and_a_quadratic() {
        // x = 100 t + t^2 / 2 is a cubic: the Hermite reproduces it (to the f32
        // rounding of the frames' velocities).
        let x = |t: f64| 100.0 * t + 0.5 * t * t;
        let (f0, f1) = (frame(1.0, x(1.0), 101.0), frame(1.01, x(1.01), 101.01));
        let path = FramePath::<f64>::new(&f0, &f1, [0.0, 10.0, 0.0]);
        for k in 0..=10 {
            let t = 1.0 + 0.001 * k as f64;
            let s = path.state_at(t);
            assert!((s.position.x - x(t)).abs() < 1e-7, "{t}");
            assert!((s.velocity.x - (100.0 + t)).abs() < 1e-4, "{t}");
            assert_eq!(s.position.y, 0.0);
            assert_eq!(s.position.z, -9000.0);
        }
        assert_eq!(path.state_at(1.01).position.x, x(1.01));
    }

    #[test]
    fn nlerp_takes_the_shorter_arc() {
        let mut f0 = frame(0.0, 0.0, 100.0);
        let mut f1 = frame(0.01, 1.0, 100.0);
        f0.attitude_wxyz = [1.0, 0.0, 0.0, 0.0];
        f1.attitude_wxyz = [-1.0, 0.0, 0.0, 0.0];
        let s = FramePath::<f64>::new(&f0, &f1, [0.0; 3]).state_at(0.005);
        assert!((s.attitude[0].abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn f32_samples_keep_the_velocity_far_from_the_origin() {
        // 50 km from the origin an f32 position has a 4 mm resolution; the
        // velocity must still come out right, from the f64 displacement.
        let (f0, f1) = (frame(10.0, 50_000.0, 240.0), frame(10.01, 50_002.4, 240.0));
        let path = FramePath::<f32>::new(&f0, &f1, [0.0; 3]);
        for k in 0..=4 {
            let s = path.state_at(10.0 + 0.0025 * k as f64);
            assert!((s.velocity.x - 240.0).abs() < 1e-3, "{}", s.velocity.x);
            let expected = 50_000.0 + 240.0 * 0.0025 * k as f64;
            assert!((f64::from(s.position.x) - expected).abs() < 5e-3);
        }
    }

    #[test]
    fn consecutive_paths_meet_with_the_same_bits() {
        // The end of one frame's path is the start of the next, bit for bit (so the
        // solver can reuse the evaluation there), in both precisions and with the
        // attitude flipped for the shorter arc.
        let mut f0 = frame(2.0, 480.123_456_7, 240.0);
        let mut f1 = frame(2.01, 482.523_456_7, 240.1);
        let mut f2 = frame(2.02, 484.924_456_7, 240.2);
        f0.attitude_wxyz = [0.999, 0.01, 0.02, 0.03];
        f1.attitude_wxyz = [-0.998, -0.011, -0.02, -0.031];
        f2.attitude_wxyz = [0.997, 0.012, 0.021, 0.032];
        let origin = [400.0, 10.0, 0.0];
        for_both(&f0, &f1, &f2, origin);
        fn for_both(
            f0: &AircraftStateFrame,
            f1: &AircraftStateFrame,
            f2: &AircraftStateFrame,
            origin: [f64; 3],
        ) {
            let (a, b) = (
                FramePath::<f32>::new(f0, f1, origin),
                FramePath::<f32>::new(f1, f2, origin),
            );
            assert_eq!(a.state_at(f1.time_s), b.state_at(f1.time_s));
            assert_eq!(
                a.state_at(f1.time_s),
                FramePath::<f32>::single(f1, origin).state_at(7.0)
            );
            let (a, b) = (
                FramePath::<f64>::new(f0, f1, origin),
                FramePath::<f64>::new(f1, f2, origin),
            );
            assert_eq!(a.state_at(f1.time_s), b.state_at(f1.time_s));
            assert_eq!(
                a.state_at(f1.time_s),
                FramePath::<f64>::single(f1, origin).state_at(-3.0)
            );
            // Inside the span the attitude follows the shorter arc (w stays positive).
            assert!(a.state_at(f1.time_s - 0.005).attitude[0] > 0.99);
        }
    }
}
