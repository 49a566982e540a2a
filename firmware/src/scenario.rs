//! The scenario the firmware runs, shared with the host: the paper's acceleration
//! case, shortened for test time.
//!
//! The aircraft flies level at 9 km at Mach 0.6 until t = 1 s, then accelerates at
//! +10 m/s^2 until Mach 0.8 (not reached in the 3 s run), then flies on at Mach 0.8.
//!
//! This file is compiled into the firmware (`mod scenario`) and, unchanged, into the
//! host crate `hil-tests` (`#[path]`), which replays it with the host solver and
//! compares. It depends only on `solver_core` and `core`.

use solver_core::{AircraftState, Atmosphere, AtmosphereError, FlightPath, Real};

/// Flight altitude, m.
pub const ALTITUDE_M: f64 = 9000.0;
/// Mach number of the level flight before the acceleration.
pub const START_MACH: f64 = 0.6;
/// Mach number at which the acceleration ends.
pub const END_MACH: f64 = 0.8;
/// Start of the acceleration, s (2 s in the paper; shortened).
pub const ACCELERATION_START_S: f64 = 1.0;
/// Longitudinal acceleration, m/s^2.
pub const ACCELERATION: f64 = 10.0;

/// Segment capacity of the embedded solver (the model uses
/// `solver.segments_embedded` of them).
pub const SEGMENT_CAPACITY: usize = 64;
/// Control period: the solver advances by this much per control step, s.
pub const CONTROL_PERIOD_S: f64 = 0.01;
/// RK4 steps per control period. One step of 10 ms diverges about 0.17 s after
/// the acceleration starts (the last hinge loses its tension pivot); two steps of
/// 5 ms track a 1 ms reference to about 0.05 % in the peak tension.
pub const SUBSTEPS: usize = 2;
/// Control steps in the run (3.0 s).
pub const CONTROL_STEPS: usize = 300;
/// The firmware reports one line every this many control steps (0.1 s).
pub const REPORT_EVERY: usize = 10;

/// The RK4 step, s.
pub const fn substep_s() -> f64 {
    CONTROL_PERIOD_S / SUBSTEPS as f64
}

/// The acceleration flight path, heading north.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Acceleration {
    /// Speed of the level flight before the acceleration, m/s.
    pub start_speed: f64,
    /// Speed at which the acceleration ends, m/s.
    pub end_speed: f64,
}

impl Acceleration {
    /// The scenario's speeds from the speed of sound at [`ALTITUDE_M`], computed in
    /// f32 by `atmosphere` (as on the target, so host and target fly the same path).
    pub fn new(atmosphere: &Atmosphere<f32>) -> Result<Self, AtmosphereError> {
        let speed_of_sound = f64::from(atmosphere.at(ALTITUDE_M as f32)?.speed_of_sound);
        Ok(Acceleration {
            start_speed: START_MACH * speed_of_sound,
            end_speed: END_MACH * speed_of_sound,
        })
    }
}

impl<T: Real> FlightPath<T> for Acceleration {
    /// Position, velocity and acceleration along x: v0 t before the start; plus
    /// a s^2 / 2 (s = t - t_start) while accelerating; plus (v1 - v0)(t - t_end)
    /// after. Computed in f64 and rounded to `T` once.
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let (v0, v1, a) = (self.start_speed, self.end_speed, ACCELERATION);
        let t_start = ACCELERATION_START_S;
        let t_end = t_start + (v1 - v0) / a;
        let (x, v, acceleration) = if t < t_start {
            (v0 * t, v0, 0.0)
        } else if t < t_end {
            let s = t - t_start;
            (v0 * t + 0.5 * a * s * s, v0 + a * s, a)
        } else {
            let s = t_end - t_start;
            (v0 * t + 0.5 * a * s * s + (v1 - v0) * (t - t_end), v1, 0.0)
        };
        let mut state = AircraftState::level(T::lit(ALTITUDE_M), T::lit(v));
        state.position.x = T::lit(x);
        state.acceleration.x = T::lit(acceleration);
        state
    }
}
