//! The built-in profiles the controller flies by itself ([`decoy_link::Profile`]
//! other than `Streamed`): `decoy_schema`'s manoeuvres, each flown as the aircraft
//! state frames a host would send.
//!
//! The controller turns each State frame of a built-in run (its clock only) into
//! the manoeuvre's state at that frame's profile time ([`frame`]), then integrates
//! between frames along the same [`crate::FramePath`] as a streamed run. The
//! profile is evaluated once per frame, at the frame's time, in the solver's
//! precision `T` (`solver_core::profiles`' split states: f32 on the Cortex-M4F,
//! positions as an f64 base plus the arc in `T`), then narrowed to the wire's
//! f32. The states follow the f64 profiles of the host's `decoy simulate` to
//! within f32 rounding (tested in solver-core).

use solver_core::Real;
use solver_core::profiles::{ManoeuvrePath, SplitState};

use decoy_link::AircraftStateFrame;

/// The State frame numbered `seq` at `time_s` of a run of `path` whose profile
/// time is `tau` (s since the run began): the path's state at `tau`, velocities
/// and the rest in `T`, then narrowed to the wire's f32.
pub(crate) fn frame<T: Real>(
    path: &ManoeuvrePath,
    seq: u32,
    time_s: f64,
    tau: f64,
) -> AircraftStateFrame {
    narrow(&path.split_state::<T>(tau), seq, time_s)
}

/// `state` as the State frame numbered `seq` at `time_s`: the position's base
/// plus its offset in f64, the rest narrowed to f32, no angular acceleration.
fn narrow<T: Real>(state: &SplitState<T>, seq: u32, time_s: f64) -> AircraftStateFrame {
    let f = |v: T| v.to_f64() as f32;
    let v3 = |v: &solver_core::Vec3<T>| [f(v.x), f(v.y), f(v.z)];
    AircraftStateFrame {
        seq,
        time_s,
        position_ned_m: [
            state.base[0] + state.offset.x.to_f64(),
            state.base[1] + state.offset.y.to_f64(),
            state.base[2] + state.offset.z.to_f64(),
        ],
        velocity_ned_mps: v3(&state.velocity),
        acceleration_ned_mps2: v3(&state.acceleration),
        attitude_wxyz: state.attitude.map(f),
        body_rate_radps: v3(&state.rate),
        body_angular_acceleration_radps2: [0.0; 3],
    }
}
