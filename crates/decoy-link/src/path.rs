//! [`FramePath`]: the aircraft's flight path between two State frames, the one
//! path the controller and the host reference both integrate along.

use solver_core::{AircraftState, FlightPath, Real, Vec3};

use crate::messages::AircraftStateFrame;

/// One frame's kinematics in f64, position relative to the run's origin.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sample {
    time: f64,
    position: [f64; 3],
    velocity: [f64; 3],
    acceleration: [f64; 3],
    attitude: [f64; 4],
    rate: [f64; 3],
    angular_acceleration: [f64; 3],
}

impl Sample {
    fn of(frame: &AircraftStateFrame, origin: &[f64; 3]) -> Self {
        let widen3 = |v: [f32; 3]| v.map(f64::from);
        let p = frame.position_ned_m;
        let q = frame.attitude_wxyz.map(f64::from);
        Sample {
            time: frame.time_s,
            position: [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]],
            velocity: widen3(frame.velocity_ned_mps),
            acceleration: widen3(frame.acceleration_ned_mps2),
            attitude: normalised(q),
            rate: widen3(frame.body_rate_radps),
            angular_acceleration: widen3(frame.body_angular_acceleration_radps2),
        }
    }
}

fn normalised(q: [f64; 4]) -> [f64; 4] {
    let norm = libm::sqrt(q.iter().map(|c| c * c).sum::<f64>());
    if norm > 0.0 {
        q.map(|c| c / norm)
    } else {
        [1.0, 0.0, 0.0, 0.0]
    }
}

fn to_t<T: Real>(v: [f64; 3]) -> Vec3<T> {
    Vec3::new(T::lit(v[0]), T::lit(v[1]), T::lit(v[2]))
}

/// The flight path over [t0, t1] between the previous accepted State frame (t0)
/// and the current one (t1). The frames are normalised and the displacement
/// p1 - p0 taken in f64 once; every sample is then computed in the solver's
/// precision (f32 on the Cortex-M4F, where f64 is software-emulated), with
/// s = (t - t0)/h, h = t1 - t0:
///
/// - position and velocity: the cubic Hermite through both frames' positions and
///   velocities, written about p0: p = p0 + h01 (p1 - p0) + h h10 v0 + h h11 v1,
///   v = (p1 - p0) h01'/h + h10' v0 + h11' v1 (so the small displacement keeps
///   full relative precision even in f32);
/// - acceleration, body rate and body angular acceleration: linear in s;
/// - attitude: normalised linear interpolation (nlerp) of the normalised
///   quaternions along the shorter arc.
///
/// At t1 the position is p0 + (p1 - p0) rounded to the solver's precision (the
/// controller evaluates its outputs on the constant path of the frame itself).
///
/// Positions are relative to `origin` (NED, m), which the controller sets to the
/// horizontal position of the frame it trimmed at, so that an f32 solver keeps
/// centimetre resolution however far the aircraft flies (the air depends only on
/// the altitude, so the shift changes nothing else). Outside [t0, t1] the path is
/// clamped to the nearer frame. A single frame (or t1 <= t0) gives a constant state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePath {
    from: Sample,
    to: Sample,
    /// `to.position - from.position`, m, in f64.
    displacement: [f64; 3],
}

impl FramePath {
    /// The path from `previous` to `current`, positions relative to `origin`.
    pub fn new(
        previous: &AircraftStateFrame,
        current: &AircraftStateFrame,
        origin: [f64; 3],
    ) -> Self {
        let from = Sample::of(previous, &origin);
        let mut to = Sample::of(current, &origin);
        // Shortest arc: q and -q are the same attitude.
        let dot: f64 = (0..4).map(|i| from.attitude[i] * to.attitude[i]).sum();
        if dot < 0.0 {
            to.attitude = to.attitude.map(|c| -c);
        }
        let displacement = [0, 1, 2].map(|i| to.position[i] - from.position[i]);
        FramePath {
            from,
            to,
            displacement,
        }
    }

    /// The constant path at one frame (its state at every time).
    pub fn single(frame: &AircraftStateFrame, origin: [f64; 3]) -> Self {
        let sample = Sample::of(frame, &origin);
        FramePath {
            from: sample,
            to: sample,
            displacement: [0.0; 3],
        }
    }

    /// The aircraft state at `t` in f64 (the trait gives any precision).
    pub fn state_f64(&self, t: f64) -> AircraftState<f64> {
        FlightPath::<f64>::state_at(self, t)
    }
}

impl<T: Real> FlightPath<T> for FramePath {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let (a, b) = (&self.from, &self.to);
        let h = b.time - a.time;
        if !(h > 0.0) {
            return AircraftState {
                position: to_t(b.position),
                velocity: to_t(b.velocity),
                acceleration: to_t(b.acceleration),
                attitude: b.attitude.map(T::lit),
                angular_rate: to_t(b.rate),
                angular_acceleration: to_t(b.angular_acceleration),
            };
        }
        let s = T::lit(((t - a.time) / h).clamp(0.0, 1.0));
        let step = T::lit(h);
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
        let delta: Vec3<T> = to_t(self.displacement);
        let (v0, v1): (Vec3<T>, Vec3<T>) = (to_t(a.velocity), to_t(b.velocity));
        let position = to_t::<T>(a.position) + delta * h01 + (v0 * h10 + v1 * h11) * step;
        let velocity = delta * (d01 / step) + v0 * d10 + v1 * d11;
        let lerp = |x: &[f64; 3], y: &[f64; 3]| -> Vec3<T> {
            let x: Vec3<T> = to_t(*x);
            x + (to_t::<T>(*y) - x) * s
        };
        let q = [0, 1, 2, 3].map(|i| {
            let qa = T::lit(a.attitude[i]);
            qa + (T::lit(b.attitude[i]) - qa) * s
        });
        let norm = q.iter().fold(T::zero(), |sum, c| sum + *c * *c).sqrt();
        let attitude = if norm > T::zero() {
            q.map(|c| c / norm)
        } else {
            [T::one(), T::zero(), T::zero(), T::zero()]
        };
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
        let path = FramePath::new(&f0, &f1, [0.0, 10.0, 0.0]);
        for k in 0..=10 {
            let t = 1.0 + 0.001 * k as f64;
            let s = path.state_f64(t);
            assert!((s.position.x - x(t)).abs() < 1e-7, "{t}");
            assert!((s.velocity.x - (100.0 + t)).abs() < 1e-4, "{t}");
            assert_eq!(s.position.y, 0.0);
            assert_eq!(s.position.z, -9000.0);
        }
        assert_eq!(path.state_f64(1.01).position.x, x(1.01));
    }

    #[test]
    fn nlerp_takes_the_shorter_arc() {
        let mut f0 = frame(0.0, 0.0, 100.0);
        let mut f1 = frame(0.01, 1.0, 100.0);
        f0.attitude_wxyz = [1.0, 0.0, 0.0, 0.0];
        f1.attitude_wxyz = [-1.0, 0.0, 0.0, 0.0];
        let s = FramePath::new(&f0, &f1, [0.0; 3]).state_f64(0.005);
        assert!((s.attitude[0].abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn f32_samples_keep_the_velocity_far_from_the_origin() {
        // 50 km from the origin an f32 position has a 4 mm resolution; the
        // velocity must still come out right, from the f64 displacement.
        let (f0, f1) = (frame(10.0, 50_000.0, 240.0), frame(10.01, 50_002.4, 240.0));
        let path = FramePath::new(&f0, &f1, [0.0; 3]);
        for k in 0..=4 {
            let s: AircraftState<f32> = path.state_at(10.0 + 0.0025 * k as f64);
            assert!((s.velocity.x - 240.0).abs() < 1e-3, "{}", s.velocity.x);
            let expected = 50_000.0 + 240.0 * 0.0025 * k as f64;
            assert!((f64::from(s.position.x) - expected).abs() < 5e-3);
        }
    }
}
