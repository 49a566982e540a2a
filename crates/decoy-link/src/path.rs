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

fn lerp3(a: &[f64; 3], b: &[f64; 3], s: f64) -> [f64; 3] {
    [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * s)
}

fn to_t<T: Real>(v: [f64; 3]) -> Vec3<T> {
    Vec3::new(T::lit(v[0]), T::lit(v[1]), T::lit(v[2]))
}

/// The flight path over [t0, t1] between the previous accepted State frame (t0)
/// and the current one (t1). Computed in f64 and rounded to the solver's scalar:
///
/// - position and velocity: the cubic Hermite through both frames' positions and
///   velocities (with s = (t - t0)/h, h = t1 - t0: p = h00 p0 + h10 h v0 + h01 p1 +
///   h11 h v1 and its derivative);
/// - acceleration, body rate and body angular acceleration: linear in s;
/// - attitude: normalised linear interpolation (nlerp) of the normalised
///   quaternions along the shorter arc.
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
        FramePath { from, to }
    }

    /// The constant path at one frame (its state at every time).
    pub fn single(frame: &AircraftStateFrame, origin: [f64; 3]) -> Self {
        let sample = Sample::of(frame, &origin);
        FramePath {
            from: sample,
            to: sample,
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
        let s = if h > 0.0 {
            ((t - a.time) / h).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let (position, velocity) = if h > 0.0 {
            // Hermite basis and derivatives (per unit s).
            let (s2, s3) = (s * s, s * s * s);
            let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
            let h10 = s3 - 2.0 * s2 + s;
            let h01 = -2.0 * s3 + 3.0 * s2;
            let h11 = s3 - s2;
            let d00 = 6.0 * s2 - 6.0 * s;
            let d10 = 3.0 * s2 - 4.0 * s + 1.0;
            let d01 = -6.0 * s2 + 6.0 * s;
            let d11 = 3.0 * s2 - 2.0 * s;
            let p = [0, 1, 2].map(|i| {
                h00 * a.position[i]
                    + h10 * h * a.velocity[i]
                    + h01 * b.position[i]
                    + h11 * h * b.velocity[i]
            });
            let v = [0, 1, 2].map(|i| {
                (d00 * a.position[i] + d01 * b.position[i]) / h
                    + d10 * a.velocity[i]
                    + d11 * b.velocity[i]
            });
            (p, v)
        } else {
            (b.position, b.velocity)
        };
        let q =
            normalised([0, 1, 2, 3].map(|i| a.attitude[i] + (b.attitude[i] - a.attitude[i]) * s));
        AircraftState {
            position: to_t(position),
            velocity: to_t(velocity),
            acceleration: to_t(lerp3(&a.acceleration, &b.acceleration, s)),
            attitude: q.map(T::lit),
            angular_rate: to_t(lerp3(&a.rate, &b.rate, s)),
            angular_acceleration: to_t(lerp3(&a.angular_acceleration, &b.angular_acceleration, s)),
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
}
