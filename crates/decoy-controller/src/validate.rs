//! Validation of a State frame, before anything touches the solver.

use solver_core::{Atmosphere, Real, Vec3};

use decoy_link::{AircraftStateFrame, RejectReason};

/// Lowest accepted altitude of the aircraft reference point, m.
pub const MIN_ALTITUDE_M: f64 = solver_core::atmosphere::MIN_ALTITUDE_M;
/// Highest accepted altitude of the aircraft reference point, m.
pub const MAX_ALTITUDE_M: f64 = solver_core::atmosphere::MAX_ALTITUDE_M;
/// Highest accepted Mach number.
pub const MAX_MACH: f64 = 2.0;
/// Largest accepted deviation of |q| from 1.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;
/// Largest accepted |acceleration| of the aircraft reference point, m/s² (15 g:
/// beyond the structural limit of any towing aircraft; the paper's tightest turn
/// is about 5 g).
pub const MAX_ACCELERATION_MPS2: f32 = 150.0;
/// Largest accepted |body rate|, rad/s (about 400 °/s, above a fighter's peak
/// roll rate).
pub const MAX_BODY_RATE_RADPS: f32 = 7.0;
/// Largest accepted |body angular acceleration|, rad/s².
pub const MAX_ANGULAR_ACCELERATION_RADPS2: f32 = 50.0;

/// True when every field of the frame is finite.
pub fn is_finite(frame: &AircraftStateFrame) -> bool {
    let f32s = frame
        .velocity_ned_mps
        .iter()
        .chain(&frame.acceleration_ned_mps2)
        .chain(&frame.attitude_wxyz)
        .chain(&frame.body_rate_radps)
        .chain(&frame.body_angular_acceleration_radps2);
    frame.time_s.is_finite()
        && frame.position_ned_m.iter().all(|v| v.is_finite())
        && f32s.into_iter().all(|v| v.is_finite())
}

/// True when |v| <= `limit`, compared as |v|² <= limit² in f32 (the frame's own
/// precision; no root, no division): a square that overflows is infinite and fails.
fn within(v: &[f32; 3], limit: f32) -> bool {
    let [x, y, z] = *v;
    x * x + y * y + z * z <= limit * limit
}

/// Checks a frame whose kinematics drive the solver (streamed mode), in this
/// order: every field finite ([`RejectReason::NonFinite`]); |q| in [0.999, 1.001]
/// ([`RejectReason::BadQuaternion`]); the altitude -z within
/// [`MIN_ALTITUDE_M`]..=[`MAX_ALTITUDE_M`], the Mach number
/// |v - wind| / a(altitude) in (0, [`MAX_MACH`]], and the physical envelope
/// |acceleration| <= [`MAX_ACCELERATION_MPS2`], |body rate| <=
/// [`MAX_BODY_RATE_RADPS`], |angular acceleration| <=
/// [`MAX_ANGULAR_ACCELERATION_RADPS2`] ([`RejectReason::OutOfRange`]).
/// The speed of sound comes from `atmosphere` in the solver's precision.
/// Returns the Mach number.
pub fn validate_streamed<T: Real>(
    frame: &AircraftStateFrame,
    atmosphere: &Atmosphere<T>,
    wind: &Vec3<T>,
) -> Result<T, RejectReason> {
    if !is_finite(frame) {
        return Err(RejectReason::NonFinite);
    }
    // In f32, the frame's own precision: f64 is software-emulated on the
    // Cortex-M4F, and the tolerances are far above f32 rounding.
    let norm2: f32 = frame.attitude_wxyz.iter().map(|&c| c * c).sum();
    let norm = <f32 as Real>::square_root(norm2);
    let tolerance = QUATERNION_NORM_TOLERANCE as f32;
    if !((1.0 - tolerance)..=(1.0 + tolerance)).contains(&norm) {
        return Err(RejectReason::BadQuaternion);
    }
    let bounds = [
        (&frame.acceleration_ned_mps2, MAX_ACCELERATION_MPS2),
        (&frame.body_rate_radps, MAX_BODY_RATE_RADPS),
        (
            &frame.body_angular_acceleration_radps2,
            MAX_ANGULAR_ACCELERATION_RADPS2,
        ),
    ];
    if !bounds.iter().all(|(v, limit)| within(v, *limit)) {
        return Err(RejectReason::OutOfRange);
    }
    let altitude = -frame.position_ned_m[2];
    if !(MIN_ALTITUDE_M..=MAX_ALTITUDE_M).contains(&altitude) {
        return Err(RejectReason::OutOfRange);
    }
    let mach = mach_of(frame, atmosphere, wind).ok_or(RejectReason::OutOfRange)?;
    if !(mach > T::zero() && mach <= T::lit(MAX_MACH)) {
        return Err(RejectReason::OutOfRange);
    }
    Ok(mach)
}

/// The Mach number |v - wind| / a(altitude) of a finite frame whose altitude is
/// inside the atmosphere (`None` otherwise, or without a speed of sound). The
/// speed of sound alone: no `pow`, the same cost at every altitude.
pub fn mach_of<T: Real>(
    frame: &AircraftStateFrame,
    atmosphere: &Atmosphere<T>,
    wind: &Vec3<T>,
) -> Option<T> {
    let altitude = -frame.position_ned_m[2];
    let speed_of_sound = atmosphere.speed_of_sound(T::lit(altitude)).ok()?;
    let v = frame.velocity_ned_mps;
    let relative = [0, 1, 2].map(|i| T::lit(f64::from(v[i])) - wind[i]);
    let airspeed = relative
        .iter()
        .fold(T::zero(), |sum, c| sum + *c * *c)
        .square_root();
    if !(speed_of_sound > T::zero()) {
        return None;
    }
    Some(airspeed / speed_of_sound)
}
