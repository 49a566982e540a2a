//! Trim: the steady equilibrium of the towed system in steady straight flight
//! (DESIGN §5).
//!
//! In steady flight every body moves with the connection point's velocity v and
//! none rotates, so all bodies see the same relative air velocity u = wind - v.
//!
//! 1. Decoy: the attitude in the plane of the airflow and gravity whose moment
//!    about the towing point vanishes, with a restoring slope (nose-up
//!    perturbation gives a nose-down moment); then T_N = -(F_aero + m_d g).
//! 2. Segments, from the decoy up: segment i carries T_{i-1} = T_i - F_i(e_i) and its
//!    hinge torques vanish when e_i is parallel to T_{i-1} + T_i = 2T_i - F_i(e_i).
//!    Normal drag is k_n |u_n| u_n with u_n = u - (u.e)e and tangential drag lies
//!    along e, so with W = 2T_i - m_i g and sigma = k_n |u_n| the condition reads
//!    e = -normalize(W - sigma u), with sigma = k_n |u x e(sigma)|: a scalar root on
//!    [0, k_n |u|], found by bisection.
//! 3. Densities depend on the chain's altitudes, which depend on the shape: repeat
//!    1-2 with the altitudes of the previous pass until they settle.
//!
//! Densities come from the same air column as the dynamics, so the trim is an
//! equilibrium of the discrete dynamics to round-off.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion};

use crate::atmosphere::AirColumn;
use crate::dynamics::{cable_drag, decoy_aero};
use crate::error::TrimError;
use crate::model::Model;
use crate::motion::AircraftState;
use crate::scalar::{Real, Vec3};
use crate::solver::connection_and_air;
use crate::state::State;

const MAX_COLUMN_PASSES: usize = 60;
const MAX_BISECTIONS: usize = 200;
/// Decoy pitch search range about the airflow, degrees.
const PITCH_LIMIT_DEG: f64 = 80.0;
const PITCH_SCAN_STEPS: usize = 160;

/// The trim state for steady straight flight with the aircraft in `aircraft`
/// (its acceleration and rates must be zero). The returned state has time 0.
pub fn trim<T: Real, const N: usize>(
    model: &Model<T, N>,
    aircraft: &AircraftState<T>,
) -> Result<State<T, N>, TrimError> {
    let mut state = State::<T, N>::default();
    trim_into(model, aircraft, &mut state)?;
    Ok(state)
}

/// [`trim`] written into `state` (for a caller that must not hold a state on
/// its stack: [`crate::Solver::trim`]). On error `state` holds what the search
/// had reached: the caller restores its own copy.
pub fn trim_into<T: Real, const N: usize>(
    model: &Model<T, N>,
    aircraft: &AircraftState<T>,
    state: &mut State<T, N>,
) -> Result<(), TrimError> {
    let (connection, air) = connection_and_air(model, aircraft)?;
    let steady_tolerance = T::lit(1e-9);
    if aircraft.acceleration.norm() > steady_tolerance
        || aircraft.angular_rate.norm() > steady_tolerance
        || aircraft.angular_acceleration.norm() > steady_tolerance
    {
        return Err(TrimError::NotSteady);
    }
    let n = model.segment_count();
    let params = model.params();
    let env = &params.environment;
    let relative_air = env.wind - connection.velocity;
    let gravity = Vec3::new(T::zero(), T::zero(), env.gravity);
    let lengths = model.lengths();
    let masses = model.masses();

    *state = State::<T, N>::default();
    let mut centre_altitude = [-connection.position.z; N];
    let mut decoy_altitude = -connection.position.z;
    let tolerance = T::lit(16.0) * T::eps() * (connection.position.z.abs() + T::one());
    for _pass in 0..MAX_COLUMN_PASSES {
        // 1. Decoy.
        let mut tension = Vec3::zeros();
        if let Some((decoy, derived)) = model.decoy() {
            let density = air.density(decoy_altitude);
            let rotation = decoy_trim(model, &air, &relative_air, density)?;
            let (aero_force, ..) = decoy_aero(
                decoy,
                derived,
                rotation.to_rotation_matrix().matrix(),
                &Vec3::zeros(),
                &(-relative_air),
                &Vec3::zeros(),
                density,
            );
            tension = -(aero_force + gravity * decoy.mass);
            state.decoy_attitude = [rotation.w, rotation.i, rotation.j, rotation.k];
        }
        // 2. Segments from the decoy up.
        for i in (0..n).rev() {
            let density = air.density(centre_altitude[i]);
            let k_normal =
                T::lit(0.5) * density * params.cable.diameter * lengths[i] * params.cable.cd_normal;
            let w = tension * T::lit(2.0) - gravity * masses[i];
            let e = segment_direction(&w, &relative_air, k_normal)
                .ok_or(TrimError::SegmentDidNotConverge { segment: i + 1 })?;
            let force = gravity * masses[i]
                + cable_drag(&params.cable, density, lengths[i], &e, &relative_air);
            state.directions[i] = e;
            tension -= force;
        }
        // 3. Altitudes of this shape.
        let mut change = T::zero();
        let mut p = connection.position;
        for i in 0..n {
            let e = state.directions[i];
            let centre = -(p.z + e.z * (T::lit(0.5) * lengths[i]));
            change = change.max((centre - centre_altitude[i]).abs());
            centre_altitude[i] = centre;
            p += e * lengths[i];
        }
        if let Some((_, derived)) = model.decoy() {
            let cg = p - state.decoy_rotation() * derived.tow_from_cg;
            change = change.max((-cg.z - decoy_altitude).abs());
            decoy_altitude = -cg.z;
        }
        if change <= tolerance {
            return Ok(());
        }
    }
    Err(TrimError::ColumnDidNotConverge)
}

/// Segment direction with hinge torques balanced: e = -normalize(W - sigma u) with
/// sigma = k_n |u x e(sigma)| (see the module docs). `None` if W - sigma u vanishes.
fn segment_direction<T: Real>(w: &Vec3<T>, u: &Vec3<T>, k_normal: T) -> Option<Vec3<T>> {
    let direction = |sigma: T| -> Option<Vec3<T>> {
        let v = w - u * sigma;
        let norm = v.norm();
        if norm > T::zero() && norm.finite() {
            Some(-v / norm)
        } else {
            None
        }
    };
    let residual =
        |sigma: T| -> Option<T> { Some(k_normal * u.cross(&direction(sigma)?).norm() - sigma) };
    let (mut lo, mut hi) = (T::zero(), k_normal * u.norm());
    if !(hi > T::zero()) {
        return direction(T::zero());
    }
    // residual(0) >= 0 and residual(hi) <= 0 by construction.
    for _ in 0..MAX_BISECTIONS {
        let mid = (lo + hi) * T::lit(0.5);
        if mid <= lo || mid >= hi {
            break;
        }
        if residual(mid)? > T::zero() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    direction((lo + hi) * T::lit(0.5))
}

/// Decoy attitude with zero moment about the towing point in the plane of the airflow and gravity.
fn decoy_trim<T: Real, const N: usize>(
    model: &Model<T, N>,
    _air: &AirColumn<T>,
    relative_air: &Vec3<T>,
    density: T,
) -> Result<UnitQuaternion<T>, TrimError> {
    let Some((decoy, derived)) = model.decoy() else {
        return Err(TrimError::NoDecoyTrim);
    };
    let gravity = Vec3::new(T::zero(), T::zero(), model.params().environment.gravity);
    // The decoy moves through the air with velocity -relative_air.
    let speed = relative_air.norm();
    if !(speed > T::lit(1e-3)) {
        return Err(TrimError::NoDecoyTrim);
    }
    let flight = -relative_air / speed;
    let down = Vec3::z();
    let right = down.cross(&flight);
    let right_norm = right.norm();
    if !(right_norm > T::lit(1e-6)) {
        return Err(TrimError::NoDecoyTrim);
    }
    let right = right / right_norm;
    let up = right.cross(&flight); // perpendicular to the flight direction, upward (-z for level flight)
    let attitude = |theta: T| -> UnitQuaternion<T> {
        let x = flight * theta.cos() + up * theta.sin();
        let z = x.cross(&right);
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            Matrix3::from_columns(&[x, right, z]),
        ))
    };
    // Pitching moment about the towing point (about the body y axis).
    let moment = |theta: T| -> T {
        let rotation = attitude(theta);
        let (force, moment_cg_body, ..) = decoy_aero(
            decoy,
            derived,
            rotation.to_rotation_matrix().matrix(),
            &Vec3::zeros(),
            &(-relative_air),
            &Vec3::zeros(),
            density,
        );
        let cg_from_tow_body = -derived.tow_from_cg;
        let total_force_body = rotation.inverse_transform_vector(&(force + gravity * decoy.mass));
        (moment_cg_body + cg_from_tow_body.cross(&total_force_body)).y
    };
    // Scan for stable roots (moment crosses zero from positive to negative as pitch grows)
    // and take the one nearest the airflow.
    let limit = T::lit(PITCH_LIMIT_DEG.to_radians());
    let step = limit * T::lit(2.0) / T::lit(PITCH_SCAN_STEPS as f64);
    let mut best: Option<(T, T)> = None;
    let mut a = -limit;
    let mut ma = moment(a);
    for k in 1..=PITCH_SCAN_STEPS {
        let b = -limit + step * T::lit(k as f64);
        let mb = moment(b);
        if ma >= T::zero() && mb < T::zero() {
            let better = match best {
                None => true,
                Some((lo, hi)) => (a + b).abs() < (lo + hi).abs(),
            };
            if better {
                best = Some((a, b));
            }
        }
        a = b;
        ma = mb;
    }
    let (mut lo, mut hi) = best.ok_or(TrimError::NoDecoyTrim)?;
    for _ in 0..MAX_BISECTIONS {
        let mid = (lo + hi) * T::lit(0.5);
        if mid <= lo || mid >= hi {
            break;
        }
        if moment(mid) >= T::zero() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(attitude((lo + hi) * T::lit(0.5)))
}
