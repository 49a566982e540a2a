//! The integrated state: a plain value that can be copied, saved and restored.

use nalgebra::UnitQuaternion;

use crate::scalar::{Real, Vec3};

/// State of the cable and decoy (2N + 3 degrees of freedom).
///
/// Invariants after every step: each `directions[i]` is a unit vector, each
/// `rates[i]` is perpendicular to `directions[i]`, `decoy_attitude` is a unit
/// quaternion. Entries beyond the model's segment count are unused and zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State<T: Real, const N: usize> {
    /// Simulation time, s. Always f64: an f32 clock accumulating 1 ms steps drifts by
    /// about 1e-4 s per 1000 steps and would shift manoeuvre events.
    pub time: f64,
    /// Unit direction of segment i+1, from joint i toward joint i+1 (toward the decoy), NED.
    pub directions: [Vec3<T>; N],
    /// Angular velocity of segment i+1, NED, rad/s (perpendicular to its direction).
    pub rates: [Vec3<T>; N],
    /// Decoy attitude, body (FRD) to NED, `[w, x, y, z]` (unused for a free end).
    pub decoy_attitude: [T; 4],
    /// Decoy angular velocity, decoy body frame, rad/s (unused for a free end).
    pub decoy_rate: Vec3<T>,
}

/// Time derivative of a [`State`] (same layout).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Derivative<T: Real, const N: usize> {
    /// d(direction)/dt = w x e.
    pub directions: [Vec3<T>; N],
    /// Angular acceleration of each segment, NED.
    pub rates: [Vec3<T>; N],
    /// dq/dt = q (x) (0, w_body) / 2.
    pub decoy_attitude: [T; 4],
    /// Decoy angular acceleration, body frame.
    pub decoy_rate: Vec3<T>,
}

impl<T: Real, const N: usize> Default for State<T, N> {
    fn default() -> Self {
        State {
            time: 0.0,
            directions: [Vec3::zeros(); N],
            rates: [Vec3::zeros(); N],
            decoy_attitude: [T::one(), T::zero(), T::zero(), T::zero()],
            decoy_rate: Vec3::zeros(),
        }
    }
}

impl<T: Real, const N: usize> Default for Derivative<T, N> {
    fn default() -> Self {
        Derivative {
            directions: [Vec3::zeros(); N],
            rates: [Vec3::zeros(); N],
            decoy_attitude: [T::zero(); 4],
            decoy_rate: Vec3::zeros(),
        }
    }
}

impl<T: Real, const N: usize> State<T, N> {
    /// The decoy attitude as a unit quaternion.
    pub fn decoy_rotation(&self) -> UnitQuaternion<T> {
        crate::scalar::unit_quaternion(self.decoy_attitude)
    }

    /// `self = base + h * d` over the first `count` segments (RK4 stage).
    pub(crate) fn set_stage(&mut self, base: &Self, d: &Derivative<T, N>, h: T, count: usize) {
        axpy(
            &mut self.directions[..count],
            &base.directions[..count],
            &d.directions[..count],
            h,
        );
        axpy(
            &mut self.rates[..count],
            &base.rates[..count],
            &d.rates[..count],
            h,
        );
        for ((q, b), dq) in self
            .decoy_attitude
            .iter_mut()
            .zip(&base.decoy_attitude)
            .zip(&d.decoy_attitude)
        {
            *q = *b + *dq * h;
        }
        self.decoy_rate = base.decoy_rate + d.decoy_rate * h;
    }

    /// `self = other` over the first `count` segments (entries beyond stay as they are).
    pub(crate) fn copy_used(&mut self, other: &Self, count: usize) {
        self.time = other.time;
        self.directions[..count].copy_from_slice(&other.directions[..count]);
        self.rates[..count].copy_from_slice(&other.rates[..count]);
        self.decoy_attitude = other.decoy_attitude;
        self.decoy_rate = other.decoy_rate;
    }

    /// Restores the invariants: unit directions, rates perpendicular to them, unit quaternion.
    pub(crate) fn renormalise(&mut self, count: usize) {
        for (e, w) in self.directions[..count]
            .iter_mut()
            .zip(self.rates[..count].iter_mut())
        {
            *e /= crate::scalar::norm(e);
            *w -= *e * w.dot(e);
        }
        let n = self
            .decoy_attitude
            .iter()
            .fold(T::zero(), |a, q| a + *q * *q)
            .square_root();
        for q in &mut self.decoy_attitude {
            *q /= n;
        }
    }

    /// True when every used value is finite.
    pub fn is_finite(&self, count: usize) -> bool {
        self.time.is_finite()
            && self.directions[..count]
                .iter()
                .chain(self.rates[..count].iter())
                .all(crate::scalar::vec_finite)
            && self.decoy_attitude.iter().all(|q| q.finite())
            && crate::scalar::vec_finite(&self.decoy_rate)
    }
}

impl<T: Real, const N: usize> Derivative<T, N> {
    /// `self = d` (first RK4 stage of the weighted sum).
    pub(crate) fn assign(&mut self, d: &Self, count: usize) {
        self.directions[..count].copy_from_slice(&d.directions[..count]);
        self.rates[..count].copy_from_slice(&d.rates[..count]);
        self.decoy_attitude = d.decoy_attitude;
        self.decoy_rate = d.decoy_rate;
    }

    /// `self += w * d` (RK4 weighted sum).
    pub(crate) fn add_scaled(&mut self, d: &Self, w: T, count: usize) {
        for (a, b) in self.directions[..count]
            .iter_mut()
            .zip(&d.directions[..count])
        {
            *a += b * w;
        }
        for (a, b) in self.rates[..count].iter_mut().zip(&d.rates[..count]) {
            *a += b * w;
        }
        for (a, b) in self.decoy_attitude.iter_mut().zip(&d.decoy_attitude) {
            *a += *b * w;
        }
        self.decoy_rate += d.decoy_rate * w;
    }
}

/// `out[i] = base[i] + h d[i]` over equal-length slices.
#[inline(always)]
fn axpy<T: Real>(out: &mut [Vec3<T>], base: &[Vec3<T>], d: &[Vec3<T>], h: T) {
    for ((o, b), v) in out.iter_mut().zip(base).zip(d) {
        *o = b + v * h;
    }
}
