//! Frames and clearances, shared by the controller and the host's `decoy simulate`
//! (decoy-sim re-exports these types), so both compute clearances the same way.
//!
//! - [`FlightPathFrame`]: x along the aircraft's velocity, y horizontal and to the
//!   right, z = x cross y (down, perpendicular to the flight path).
//! - [`ExhaustPlume`]: the hot jet, a truncated cone in the aircraft body frame.
//! - [`Envelope`]: the aircraft's collision capsule in the body frame.
//!
//! Generic over the solver's scalar (`f32` on the Cortex-M4, `f64` on hosts).

use nalgebra::{Rotation3, UnitQuaternion};
use solver_core::scalar::norm;
use solver_core::{AircraftState, Mat3, Real, Vec3};

/// Speed below which the flight-path frame falls back to the aircraft's axes, m/s.
const MIN_SPEED_MPS: f64 = 1e-6;

/// The flight-path frame at one instant (axes in NED).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlightPathFrame<T: Real> {
    /// Unit x axis (along the velocity), NED.
    pub x: Vec3<T>,
    /// Unit y axis (horizontal, right), NED.
    pub y: Vec3<T>,
    /// Unit z axis (down, perpendicular to x and y), NED.
    pub z: Vec3<T>,
}

impl<T: Real> FlightPathFrame<T> {
    /// The frame of `aircraft`'s velocity; for a (near) zero or vertical velocity
    /// the aircraft's body axes stand in for the missing directions. Reduces to NED
    /// rotated to the heading in level flight.
    pub fn of(aircraft: &AircraftState<T>) -> Self {
        // The body axes only where the velocity leaves a direction undefined.
        let body_axis = |k: usize| -> Vec3<T> {
            solver_core::scalar::rotation_matrix(aircraft.attitude)
                .column(k)
                .into_owned()
        };
        let speed = norm(&aircraft.velocity);
        let x = if speed > T::lit(MIN_SPEED_MPS) {
            aircraft.velocity / speed
        } else {
            body_axis(0)
        };
        let right = Vec3::z().cross(&x);
        let right_norm = norm(&right);
        let y = if right_norm > T::lit(1e-6) {
            right / right_norm
        } else {
            let body_y = body_axis(1);
            let y = body_y - x * x.dot(&body_y);
            y / norm(&y)
        };
        FlightPathFrame {
            x,
            y,
            z: x.cross(&y),
        }
    }

    /// The components of the NED vector `r` along x, y, z.
    pub fn components(&self, r: &Vec3<T>) -> Vec3<T> {
        Vec3::new(self.x.dot(r), self.y.dot(r), self.z.dot(r))
    }

    /// The rotation taking flight-path-frame vectors to NED.
    pub fn rotation(&self) -> UnitQuaternion<T> {
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_basis_unchecked(&[
            self.x, self.y, self.z,
        ]))
    }

    /// Roll, pitch, yaw (ZYX), rad, of the body attitude `attitude` (body to NED)
    /// relative to this frame.
    ///
    /// From the rotation matrix Fᵀ R (F: this frame's axes as columns, R: the
    /// attitude's matrix) with [`solver_core::scalar::euler_zyx`].
    pub fn relative_euler(&self, attitude: &UnitQuaternion<T>) -> (T, T, T) {
        let q = attitude.quaternion();
        let r = solver_core::scalar::rotation_matrix([q.w, q.i, q.j, q.k]);
        let axes = [&self.x, &self.y, &self.z];
        let relative = Mat3::from_fn(|i, j| axes[i].dot(&r.column(j)));
        solver_core::scalar::euler_zyx(&relative)
    }
}

/// The hot exhaust plume: a truncated cone in the aircraft body frame starting at
/// the nozzle exit (radius `nozzle_radius`) and widening along `axis` with
/// half-angle `atan(tan_half_angle)` for `length` metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExhaustPlume<T: Real> {
    /// Nozzle exit centre, body frame, m.
    pub nozzle: Vec3<T>,
    /// Unit plume axis, body frame.
    pub axis: Vec3<T>,
    /// Nozzle exit radius, m.
    pub nozzle_radius: T,
    /// Tangent of the half angle.
    pub tan_half_angle: T,
    /// Length of the plume, m.
    pub length: T,
}

impl<T: Real> ExhaustPlume<T> {
    /// A plume from configuration values: `axis` need not be unit (it is
    /// normalised), the half angle is in degrees.
    pub fn new(
        nozzle: [f64; 3],
        axis: [f64; 3],
        nozzle_radius: f64,
        half_angle_deg: f64,
        length: f64,
    ) -> Self {
        let axis = nalgebra::Vector3::from(axis).normalize();
        let tan_half_angle = libm::tan(half_angle_deg.to_radians());
        ExhaustPlume {
            nozzle: lit3(nozzle),
            axis: Vec3::new(T::lit(axis.x), T::lit(axis.y), T::lit(axis.z)),
            nozzle_radius: T::lit(nozzle_radius),
            tan_half_angle: T::lit(tan_half_angle),
            length: T::lit(length),
        }
    }

    /// Signed distance from the body-frame point `p` to the plume's surface
    /// (nozzle disc, conical side, end disc), m: positive outside, negative inside.
    ///
    /// Computed in the meridian half-plane: s along the axis from the nozzle, rho
    /// from the axis; the plume's section there is the trapezoid (0,0), (0,r0),
    /// (L, r0 + L tan a), (L,0), and the distance to the solid of revolution is
    /// the distance to the trapezoid's three edges off the axis.
    pub fn clearance(&self, p: &Vec3<T>) -> T {
        let d = p - self.nozzle;
        let s = d.dot(&self.axis);
        let rho = norm(&(d - self.axis * s));
        let zero = T::zero();
        let end_radius = self.nozzle_radius + self.length * self.tan_half_angle;
        let q = [s, rho];
        // The nearest edge by squared distance, one square root at the end (the
        // root is monotonic, so this is the root of the smallest distance).
        let distance2 = smaller(
            smaller(
                segment_distance2(q, [zero, zero], [zero, self.nozzle_radius]),
                segment_distance2(q, [zero, self.nozzle_radius], [self.length, end_radius]),
            ),
            segment_distance2(q, [self.length, end_radius], [self.length, zero]),
        );
        let distance = distance2.square_root();
        let inside =
            s >= zero && s <= self.length && rho <= self.nozzle_radius + s * self.tan_half_angle;
        if inside { -distance } else { distance }
    }
}

/// The aircraft's collision envelope: a capsule (a segment swept by a sphere) in
/// the body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Envelope<T: Real> {
    /// Fore end of the axis, body frame, m.
    pub fore: Vec3<T>,
    /// Aft end of the axis, body frame, m.
    pub aft: Vec3<T>,
    /// Radius, m.
    pub radius: T,
}

impl<T: Real> Envelope<T> {
    /// A capsule from configuration values.
    pub fn new(fore: [f64; 3], aft: [f64; 3], radius: f64) -> Self {
        Envelope {
            fore: lit3(fore),
            aft: lit3(aft),
            radius: T::lit(radius),
        }
    }

    /// Distance from the body-frame point `p` to the capsule's surface, m
    /// (negative inside).
    pub fn clearance(&self, p: &Vec3<T>) -> T {
        let axis = self.aft - self.fore;
        let length2 = axis.norm_squared();
        let t = if length2 > T::zero() {
            clamp01((p - self.fore).dot(&axis) / length2)
        } else {
            T::zero()
        };
        norm(&(p - (self.fore + axis * t))) - self.radius
    }
}

/// The fixed geometry of the aircraft the clearances need.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry<T: Real> {
    /// The exhaust plume.
    pub plume: ExhaustPlume<T>,
    /// The collision capsule.
    pub envelope: Envelope<T>,
}

impl<T: Real> Geometry<T> {
    /// Every value zero (a point plume and envelope at the aircraft's reference
    /// point): the geometry of [`Controller::UNCONFIGURED`](crate::Controller::UNCONFIGURED).
    pub(crate) const ZERO: Self = {
        let z = Vec3::new(T::ZERO, T::ZERO, T::ZERO);
        Geometry {
            plume: ExhaustPlume {
                nozzle: z,
                axis: z,
                nozzle_radius: T::ZERO,
                tan_half_angle: T::ZERO,
                length: T::ZERO,
            },
            envelope: Envelope {
                fore: z,
                aft: z,
                radius: T::ZERO,
            },
        }
    };
}

/// The NED point `p` in the aircraft body frame (relative to its reference point).
pub fn to_body<T: Real>(aircraft: &AircraftState<T>, p: &Vec3<T>) -> Vec3<T> {
    solver_core::scalar::rotation_matrix(aircraft.attitude).tr_mul(&(p - aircraft.position))
}

/// The plume placed at the aircraft's state: nozzle and axis in NED, and its
/// meridian section's constants, for the clearance of many points at one
/// instant ([`PlacedPlume::clearance`], [`cable_plume_clearance`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacedPlume<T: Real> {
    nozzle: Vec3<T>,
    axis: Vec3<T>,
    nozzle_radius: T,
    length: T,
    end_radius: T,
    tan_half_angle: T,
    /// The conical side's meridian, (L, r_L - r_0), and 1 / its squared length.
    side: [T; 2],
    inverse_side2: T,
}

impl<T: Real> PlacedPlume<T> {
    /// `plume` (aircraft body frame) at `aircraft`'s position and attitude.
    pub fn new(plume: &ExhaustPlume<T>, aircraft: &AircraftState<T>) -> Self {
        let rotation = solver_core::scalar::rotation_matrix(aircraft.attitude);
        let end_radius = plume.nozzle_radius + plume.length * plume.tan_half_angle;
        let side = [plume.length, end_radius - plume.nozzle_radius];
        let side2 = side[0] * side[0] + side[1] * side[1];
        PlacedPlume {
            nozzle: aircraft.position + rotation * plume.nozzle,
            axis: rotation * plume.axis,
            nozzle_radius: plume.nozzle_radius,
            length: plume.length,
            end_radius,
            tan_half_angle: plume.tan_half_angle,
            side,
            inverse_side2: if side2 > T::zero() {
                T::one() / side2
            } else {
                T::zero()
            },
        }
    }

    /// Signed distance from the NED point `p` to the plume's surface, m
    /// ([`ExhaustPlume::clearance`] of the point in the body frame, to rounding):
    /// in the meridian half-plane (s along the axis from the nozzle, rho from the
    /// axis), the distance to the nozzle disc (s = 0, rho <= r0), the conical
    /// side and the end disc (s = L, rho <= rL), negative inside. No division, no
    /// branch but the comparisons of the three distances: the same work for
    /// every point.
    #[inline(always)]
    pub fn clearance(&self, p: &Vec3<T>) -> T {
        let d = p - self.nozzle;
        let s = d.dot(&self.axis);
        let rho = norm(&(d - self.axis * s));
        let (r0, rl, length) = (self.nozzle_radius, self.end_radius, self.length);
        // The discs: the radial excess beyond their rims.
        let beyond = |rho: T, r: T| if rho > r { rho - r } else { T::zero() };
        let (a, c) = (beyond(rho, r0), beyond(rho, rl));
        let nozzle2 = s * s + a * a;
        let end = s - length;
        let end2 = end * end + c * c;
        // The side, from (0, r0) to (L, rL): the nearest point's parameter in [0, 1].
        let (qs, qr) = (s, rho - r0);
        let t = (qs * self.side[0] + qr * self.side[1]) * self.inverse_side2;
        let t = clamp01(t);
        let (ds, dr) = (qs - t * self.side[0], qr - t * self.side[1]);
        let side2 = ds * ds + dr * dr;
        let distance2 = smaller(smaller(nozzle2, side2), end2);
        let distance = distance2.square_root();
        let inside = s >= T::zero() && s <= length && rho <= r0 + s * self.tan_half_angle;
        if inside { -distance } else { distance }
    }
}

/// The smallest plume clearance of a cable given by its joint positions (NED,
/// joint 0 first), checked at every joint and every segment midpoint, and where it
/// is: the index into that sequence of points (0 = joint 0, 2j - 1 = midpoint of
/// segment j, 2j = joint j). Infinity and 0 for no joints.
///
/// Every point is evaluated: the cost depends only on the number of joints, not
/// on where the cable is (a search that skipped the points far from the plume
/// would be cheapest in cruise and dearest when the cable closes on the plume,
/// the moment that matters).
pub fn cable_plume_clearance<T: Real>(
    plume: &ExhaustPlume<T>,
    aircraft: &AircraftState<T>,
    joints: impl IntoIterator<Item = Vec3<T>>,
) -> (T, usize) {
    let placed = PlacedPlume::new(plume, aircraft);
    let half = T::lit(0.5);
    let (mut best, mut best_index) = (T::lit(f64::INFINITY), 0);
    let mut previous: Option<Vec3<T>> = None;
    for (j, p) in joints.into_iter().enumerate() {
        if let Some(q) = previous {
            let c = placed.clearance(&((q + p) * half));
            if c < best {
                (best, best_index) = (c, 2 * j - 1);
            }
        }
        let c = placed.clearance(&p);
        if c < best {
            (best, best_index) = (c, 2 * j);
        }
        previous = Some(p);
    }
    (best, best_index)
}

/// [`cable_plume_clearance`] in f64 with the same result, bit for bit, for the
/// host's runs, which measure every RK4 step: a point is evaluated only when it
/// can be nearer than the smallest clearance found so far. The clearance changes
/// by at most the distance moved (it is a distance to a fixed surface), and two
/// points k places apart along the cable are at most k `spacing` apart
/// (`spacing`: an upper bound of the distance from a joint to the next segment
/// midpoint and from a midpoint to the next joint, half the longest segment). So
/// after a point of clearance c, the next floor((c - best - margin) / spacing)
/// points, with best the smallest clearance so far and margin
/// [`PRUNE_MARGIN_M`] (far above the rounding of either computation), cannot
/// replace it and are skipped. Its cost therefore depends on where the cable is:
/// not for the controller's frame, whose cost must not ([`cable_plume_clearance`]).
pub fn cable_plume_clearance_pruned(
    plume: &ExhaustPlume<f64>,
    aircraft: &AircraftState<f64>,
    joints: impl IntoIterator<Item = Vec3<f64>>,
    spacing: f64,
) -> (f64, usize) {
    cable_plume_clearance_below(plume, aircraft, joints, spacing, f64::INFINITY)
        .unwrap_or((f64::INFINITY, 0))
}

/// [`cable_plume_clearance_pruned`] when only a clearance below `bound` matters
/// (the host's steps between output rows, whose clearance only lowers the
/// smallest of the run): `Some` of the same result, bit for bit, if it is
/// below `bound`, else `None`. The search starts from `bound` as the smallest
/// clearance so far, so far more points are skipped.
pub fn cable_plume_clearance_below(
    plume: &ExhaustPlume<f64>,
    aircraft: &AircraftState<f64>,
    joints: impl IntoIterator<Item = Vec3<f64>>,
    spacing: f64,
    bound: f64,
) -> Option<(f64, usize)> {
    let placed = PlacedPlume::new(plume, aircraft);
    let (mut best, mut best_index) = (bound, None);
    // The index of the next point to evaluate.
    let mut next = 0usize;
    let mut consider =
        |p: &Vec3<f64>, index: usize, best: &mut f64, best_index: &mut Option<usize>| {
            if index < next {
                return;
            }
            let c = placed.clearance(p);
            if c < *best {
                (*best, *best_index) = (c, Some(index));
            }
            let room = (c - *best - PRUNE_MARGIN_M) / spacing;
            // Not a number (an infinite clearance, a zero spacing): no skip.
            next = if (1.0..1e9).contains(&room) {
                index + 1 + room as usize
            } else {
                index + 1
            };
        };
    let mut previous: Option<Vec3<f64>> = None;
    for (j, p) in joints.into_iter().enumerate() {
        if let Some(q) = previous {
            consider(&((q + p) * 0.5), 2 * j - 1, &mut best, &mut best_index);
        }
        consider(&p, 2 * j, &mut best, &mut best_index);
        previous = Some(p);
    }
    best_index.map(|index| (best, index))
}

/// The margin, m, by which [`cable_plume_clearance_pruned`]'s bound must exceed
/// the smallest clearance so far for a point to be skipped.
pub const PRUNE_MARGIN_M: f64 = 1e-6;

fn lit3<T: Real>(v: [f64; 3]) -> Vec3<T> {
    Vec3::new(T::lit(v[0]), T::lit(v[1]), T::lit(v[2]))
}

/// `t` clamped to [0, 1] by comparisons (no library call; NaN gives 1).
fn clamp01<T: Real>(t: T) -> T {
    if t > T::zero() {
        if t < T::one() { t } else { T::one() }
    } else if t <= T::zero() {
        T::zero()
    } else {
        T::one()
    }
}

/// The smaller of `a` and `b` by comparison (`b` when `a` is NaN).
fn smaller<T: Real>(a: T, b: T) -> T {
    if a <= b { a } else { b }
}

/// Squared distance from `q` to the segment a-b in the plane.
fn segment_distance2<T: Real>(q: [T; 2], a: [T; 2], b: [T; 2]) -> T {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let aq = [q[0] - a[0], q[1] - a[1]];
    let length2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if length2 > T::zero() {
        clamp01((aq[0] * ab[0] + aq[1] * ab[1]) / length2)
    } else {
        T::zero()
    };
    let dx = aq[0] - t * ab[0];
    let dy = aq[1] - t * ab[1];
    dx * dx + dy * dy
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plume<T: Real>() -> ExhaustPlume<T> {
        ExhaustPlume {
            nozzle: lit3([-7.5, 0.0, 0.0]),
            axis: lit3([-1.0, 0.0, 0.0]),
            nozzle_radius: T::lit(0.5),
            tan_half_angle: T::lit(0.1),
            length: T::lit(50.0),
        }
    }

    macro_rules! for_both {
        ($name:ident, $body:ident) => {
            mod $name {
                #[test]
                fn f32() {
                    super::$body::<f32>(1e-5);
                }
                #[test]
                fn f64() {
                    super::$body::<f64>(1e-12);
                }
            }
        };
    }

    fn plume_clearance_signs_and_values<T: Real>(tol: f64) {
        let p = plume::<T>();
        let side = |s: f64, rho: f64| p.clearance(&lit3([-7.5 - s, 0.0, rho])).to_f64();
        // Outside: (rho - r(s)) times the cosine of the half angle.
        let expected = 2.0 * libm::cos(libm::atan(0.1));
        assert!((side(10.0, 3.5) - expected).abs() < tol * 10.0);
        assert!(side(10.0, 0.0) < 0.0);
        assert!((side(0.1, 0.0) + 0.1).abs() < tol * 10.0);
        assert!((side(-2.0, 0.2) - 2.0).abs() < tol * 10.0);
        assert!((side(53.0, 0.0) - 3.0).abs() < tol * 100.0);
    }
    for_both!(plume_clearance, plume_clearance_signs_and_values);

    /// The pruned search gives the full search's clearance and index, bit for
    /// bit, on cables near, through and far from the plume of a manoeuvring
    /// aircraft, and so does the search below a bound when the clearance is
    /// below it (else it finds none).
    #[test]
    fn pruned_plume_clearance_is_the_full_one() {
        let plume = plume::<f64>();
        let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut uniform = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut skipped_some = false;
        for case in 0..400 {
            let mut aircraft = AircraftState::<f64>::level(9000.0 + 100.0 * uniform(), 200.0);
            aircraft.position = lit3([4000.0 * uniform(), 50.0 * uniform(), -9000.0]);
            // A unit quaternion of a random attitude (up to about 60 degrees).
            let q = [1.0, uniform() - 0.5, uniform() - 0.5, uniform() - 0.5];
            let norm = libm::sqrt(q.iter().map(|x| x * x).sum::<f64>());
            aircraft.attitude = q.map(|x| x / norm);
            // A cable leaving a point near the nozzle, bending down and back, with
            // a random offset so that some cases cross the plume.
            let rotation = solver_core::scalar::rotation_matrix(aircraft.attitude);
            let start = aircraft.position + rotation * lit3([-8.0, 0.0, 1.7 * uniform()]);
            let droop = 0.3 * (uniform() - 0.2);
            let side = 0.1 * (uniform() - 0.5);
            let joints: Vec<Vec3<f64>> = (0..=300)
                .map(|j| {
                    let a = j as f64 / 3.0;
                    start + rotation * lit3([-a, side * a, droop * a + 1e-3 * a * a])
                })
                .collect();
            let full = cable_plume_clearance(&plume, &aircraft, joints.iter().copied());
            // Half the longest segment bounds the distance between consecutive
            // points (joints and midpoints).
            let longest = joints
                .windows(2)
                .map(|w| (w[1] - w[0]).norm())
                .fold(0.0, f64::max);
            let spacing = 0.5 * longest * (1.0 + 1e-9);
            let pruned =
                cable_plume_clearance_pruned(&plume, &aircraft, joints.iter().copied(), spacing);
            assert_eq!(full.0.to_bits(), pruned.0.to_bits(), "case {case}");
            assert_eq!(full.1, pruned.1, "case {case}");
            skipped_some |= full.0 > 1.0;
            // Below a bound: the same result when it is below, else None, for
            // bounds above, below and at the clearance.
            for bound in [
                full.0 + 2.0 * uniform(),
                full.0 - 0.5 * uniform(),
                full.0,
                f64::INFINITY,
            ] {
                let below = cable_plume_clearance_below(
                    &plume,
                    &aircraft,
                    joints.iter().copied(),
                    spacing,
                    bound,
                );
                if full.0 < bound {
                    let (c, index) = below.expect("a clearance below the bound");
                    assert_eq!(
                        (c.to_bits(), index),
                        (full.0.to_bits(), full.1),
                        "case {case}"
                    );
                } else {
                    assert_eq!(below, None, "case {case}, bound {bound}");
                }
            }
        }
        assert!(
            skipped_some,
            "no case left the plume: the test would not exercise the pruning"
        );
    }

    fn capsule_clearance<T: Real>(tol: f64) {
        let e = Envelope::<T>::new([7.0, 0.0, 0.0], [-7.5, 0.0, 0.0], 1.6);
        assert!((e.clearance(&lit3([0.0, 0.0, 5.0])).to_f64() - 3.4).abs() < tol * 10.0);
        assert!((e.clearance(&lit3([-10.5, 0.0, 4.0])).to_f64() - 3.4).abs() < tol * 10.0);
        assert!(e.clearance(&Vec3::zeros()) < T::zero());
    }
    for_both!(capsule, capsule_clearance);

    fn frame_in_a_climb<T: Real>(tol: f64) {
        let mut a = AircraftState::<T>::level(T::lit(9000.0), T::lit(100.0));
        a.velocity = lit3([100.0 * libm::cos(0.5), 0.0, -100.0 * libm::sin(0.5)]);
        let f = FlightPathFrame::of(&a);
        assert!((f.y - Vec3::y()).norm().to_f64() < tol);
        assert!(f.z.z > T::zero() && f.z.x > T::zero());
        // The frame's own attitude has zero relative angles.
        let (r, p, y) = f.relative_euler(&f.rotation());
        assert!(r.abs().to_f64() < tol * 10.0 && p.abs().to_f64() < tol * 10.0);
        assert!(y.abs().to_f64() < tol * 10.0);
    }
    for_both!(climb_frame, frame_in_a_climb);

    #[test]
    fn f32_and_f64_clearances_agree() {
        let (p32, p64) = (plume::<f32>(), plume::<f64>());
        for i in 0..200 {
            let s = -10.0 + 0.37 * i as f64;
            let rho = 0.05 * (i % 60) as f64;
            let c32 = p32.clearance(&lit3([-7.5 - s, rho * 0.6, rho * 0.8]));
            let c64 = p64.clearance(&lit3([-7.5 - s, rho * 0.6, rho * 0.8]));
            assert!((c32 as f64 - c64).abs() < 1e-4, "{s} {rho}: {c32} {c64}");
        }
    }

    #[test]
    fn cable_clearance_checks_midpoints() {
        let p = plume::<f64>();
        let aircraft = AircraftState::<f64>::fixed(Vec3::zeros());
        // Two joints either side of the plume: only the midpoint is inside.
        let joints = [lit3([-20.0, 0.0, 3.0]), lit3([-20.0, 0.0, -3.0])];
        let (c, at) = cable_plume_clearance(&p, &aircraft, joints);
        assert!(c < 0.0);
        assert_eq!(at, 1);
    }
    /// Every point checked in the body frame, for comparison with the search in NED.
    fn brute_force<T: Real>(
        plume: &ExhaustPlume<T>,
        aircraft: &AircraftState<T>,
        joints: &[Vec3<T>],
    ) -> (T, usize) {
        // The same NED-to-body transform as `cable_plume_clearance`.
        let to_body = solver_core::scalar::rotation_matrix(aircraft.attitude).transpose();
        let mut best = (T::lit(f64::INFINITY), 0);
        let mut consider = |p: Vec3<T>, k: usize| {
            let c = plume.clearance(&(to_body * (p - aircraft.position)));
            if c < best.0 {
                best = (c, k);
            }
        };
        for (j, p) in joints.iter().enumerate() {
            if j > 0 {
                consider((joints[j - 1] + p) * T::lit(0.5), 2 * j - 1);
            }
            consider(*p, 2 * j);
        }
        best
    }

    /// The search over the placed plume (NED) finds the body-frame brute force's
    /// smallest clearance, to rounding (`tol`, m), at a point whose own body-frame
    /// clearance is that smallest one.
    fn the_placed_search_is_the_brute_force<T: Real>(tol: f64) {
        let plume = plume::<T>();
        let mut seed = 12345u64;
        let mut random = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..300 {
            let mut aircraft = AircraftState::<T>::level(T::lit(9000.0), T::lit(240.0));
            aircraft.position = lit3([1000.0 * random(), 50.0 * random(), -9000.0]);
            let (yaw, pitch) = (random() - 0.5, 0.3 * (random() - 0.5));
            let (cy, sy, cp, sp) = (
                (yaw / 2.0).cos(),
                (yaw / 2.0).sin(),
                (pitch / 2.0).cos(),
                (pitch / 2.0).sin(),
            );
            aircraft.attitude = [cy * cp, -sy * sp, cy * sp, sy * cp].map(T::lit);
            // A cable trailing behind, below and to the side, some points near
            // or inside the plume.
            let mut joints = [aircraft.position + lit3::<T>([-4.0, 0.0, 1.0]); 17];
            let (dz, dy) = (0.2 * (random() - 0.3), 0.1 * (random() - 0.5));
            for j in 1..joints.len() {
                let step = 2.0 + 10.0 * random();
                joints[j] = joints[j - 1] + lit3::<T>([-step, step * dy, step * dz]);
            }
            let placed = cable_plume_clearance(&plume, &aircraft, joints.iter().copied());
            let all = brute_force(&plume, &aircraft, &joints);
            let point = |k: usize| {
                if k.is_multiple_of(2) {
                    joints[k / 2]
                } else {
                    (joints[k / 2] + joints[k / 2 + 1]) * T::lit(0.5)
                }
            };
            let to_body = solver_core::scalar::rotation_matrix(aircraft.attitude).transpose();
            let at_index = plume.clearance(&(to_body * (point(placed.1) - aircraft.position)));
            assert!(
                (placed.0.to_f64() - all.0.to_f64()).abs() < tol
                    && (at_index.to_f64() - all.0.to_f64()).abs() < 2.0 * tol,
                "case {case}: {:?} against {:?}",
                (placed.0.to_f64(), placed.1),
                (all.0.to_f64(), all.1)
            );
        }
    }

    #[test]
    fn the_placed_search_is_the_brute_force_f32() {
        the_placed_search_is_the_brute_force::<f32>(2e-3);
    }

    #[test]
    fn the_placed_search_is_the_brute_force_f64() {
        the_placed_search_is_the_brute_force::<f64>(1e-9);
    }
}
