//! The scalar type the solver is generic over (f32 on the microcontroller, f64 on hosts).

use nalgebra::{Matrix3, RealField, Vector3};

/// A real scalar the solver runs on: `f32` or `f64`.
///
/// `RealField` comes from nalgebra/simba; in `no_std` builds its transcendental
/// functions come from `libm`.
pub trait Real: RealField + Copy + Default + core::fmt::Debug + core::fmt::Display {
    /// Converts an `f64` literal or parameter to this type (rounding for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both `f32` and `f64`).
    fn to_f64(self) -> f64;
    /// True when the value is neither NaN nor infinite.
    fn finite(self) -> bool;
    /// Machine epsilon of the type.
    fn eps() -> Self;
}

impl Real for f32 {
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline(always)]
    fn eps() -> Self {
        f32::EPSILON
    }
}

impl Real for f64 {
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline(always)]
    fn eps() -> Self {
        f64::EPSILON
    }
}

/// A 3-vector.
pub type Vec3<T> = Vector3<T>;
/// A 3x3 matrix.
pub type Mat3<T> = Matrix3<T>;

/// True when every component is finite.
#[inline]
pub fn vec_finite<T: Real>(v: &Vec3<T>) -> bool {
    v.x.finite() && v.y.finite() && v.z.finite()
}

/// The cross-product matrix `[r]x` with `[r]x v = r x v`.
#[inline]
pub fn skew<T: Real>(r: &Vec3<T>) -> Mat3<T> {
    let z = T::zero();
    Mat3::new(z, -r.z, r.y, r.z, z, -r.x, -r.y, r.x, z)
}
