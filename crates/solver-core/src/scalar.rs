//! The scalar type the solver is generic over (f32 on the microcontroller, f64 on hosts).

use nalgebra::{Matrix3, Quaternion, RealField, UnitQuaternion, Vector3};

/// A real scalar the solver runs on: `f32` or `f64`.
///
/// `RealField` comes from nalgebra/simba; in `no_std` builds its transcendental
/// functions come from `libm`.
pub trait Real: RealField + Copy + Default + core::fmt::Debug + core::fmt::Display {
    /// Zero, as a constant (usable in `const` items, where `T::zero()` is not).
    const ZERO: Self;
    /// One, as a constant.
    const ONE: Self;
    /// Converts an `f64` literal or parameter to this type (rounding for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both `f32` and `f64`).
    fn to_f64(self) -> f64;
    /// True when the value is neither NaN nor infinite.
    fn finite(self) -> bool;
    /// Machine epsilon of the type.
    fn eps() -> Self;
    /// Square root, correctly rounded: f64 the library root; f32 [`fpu_sqrt::sqrt`],
    /// the Cortex-M4F's VSQRT (seven instructions with its register moves, where
    /// libm's bitwise `sqrtf` takes about 60) and libm's `sqrtf` on hosts: both
    /// correctly rounded, so host and firmware f32 runs stay bit-identical.
    fn square_root(self) -> Self;
    /// The angle atan2(self, x) in [0, pi] of a point (x, self) with self >= 0
    /// (the upper half-plane): f64 libm's `atan2`; f32 [`upper_atan2_f32`], within
    /// 3e-7 rad of it, about 25 instructions on the Cortex-M4F where libm's
    /// `atan2f` takes about 60, the same bits on every platform.
    fn upper_atan2(self, x: Self) -> Self;
    /// The integer `n` in this type, correctly rounded (for f32 on the Cortex-M4F
    /// one library conversion, where `lit(n as f64)` would take two).
    fn from_count(n: u64) -> Self;
    /// Truncated toward zero to a `usize`, saturating (NaN and negatives give 0): one
    /// instruction for f32 on the Cortex-M4F (a conversion through f64 would be two
    /// software calls).
    fn truncated_index(self) -> usize;
    /// True when both values have the same bit pattern (unlike `==`, +0 and -0
    /// differ and a NaN equals itself): "the same input" for a cached result.
    fn same_bits(self, other: Self) -> bool;
    /// (sin x, cos x) for |x| <= 4 (a small angle: a profile's heading reduced to
    /// a turn, a climb angle): f64 libm's; f32 [`sin_cos_f32`], within 2 ulp of the
    /// exact values there, about 40 instructions on the Cortex-M4F where libm's
    /// `sinf` and `cosf` (working in f64, in software) take about 1,000 each; the
    /// same bits on every platform.
    fn sin_cos_small(self) -> (Self, Self);
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
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
    #[inline(always)]
    fn square_root(self) -> Self {
        fpu_sqrt::sqrt(self)
    }
    #[inline(always)]
    fn upper_atan2(self, x: Self) -> Self {
        upper_atan2_f32(self, x)
    }
    #[inline(always)]
    fn from_count(n: u64) -> Self {
        n as f32
    }
    #[inline(always)]
    fn truncated_index(self) -> usize {
        self as usize
    }
    #[inline(always)]
    fn same_bits(self, other: Self) -> bool {
        self.to_bits() == other.to_bits()
    }
    #[inline]
    fn sin_cos_small(self) -> (Self, Self) {
        sin_cos_f32(self)
    }
}

/// (sin x, cos x) in f32 for |x| <= 4, within 2 ulp: x reduced to r in
/// [-pi/4, pi/4] by the nearest multiple k of pi/2 (Cody-Waite, pi/2 in two parts,
/// exact for |k| <= 3), the Taylor polynomials of sin and cos on r (their
/// truncation error below 3e-9 there), then the quadrant's signs and swap. NaN
/// for NaN; beyond 4 the reduction loses accuracy gradually.
#[inline]
pub fn sin_cos_f32(x: f32) -> (f32, f32) {
    use core::f32::consts::FRAC_2_PI;
    // pi/2 = PIO2_HI + PIO2_LO, PIO2_HI with 11 trailing zero bits, so k PIO2_HI
    // is exact for |k| < 2^11.
    const PIO2_HI: f32 = 1.570_312_5;
    const PIO2_LO: f32 = 4.838_268e-4;
    let q = x * FRAC_2_PI;
    let k = (if q >= 0.0 { q + 0.5 } else { q - 0.5 }) as i32;
    let kf = k as f32;
    let r = (x - kf * PIO2_HI) - kf * PIO2_LO;
    let r2 = r * r;
    // sin r = r (1 - r²/6 + r⁴/120 - r⁶/5040 + r⁸/362880),
    // cos r = 1 - r²/2 + r⁴/24 - r⁶/720 + r⁸/40320.
    let sin = r
        * (1.0
            + r2 * (-1.0 / 6.0
                + r2 * (1.0 / 120.0 + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362_880.0)))));
    let cos = 1.0 + r2 * (-0.5 + r2 * (1.0 / 24.0 + r2 * (-1.0 / 720.0 + r2 * (1.0 / 40_320.0))));
    match k & 3 {
        0 => (sin, cos),
        1 => (cos, -sin),
        2 => (-sin, -cos),
        _ => (-cos, sin),
    }
}

/// atan2(y, x) for y >= 0 in f32, in [0, pi], within 3e-7 rad: the smaller of
/// |x| and y over the larger, t in [0, 1], then atan t by the polynomial of
/// Abramowitz and Stegun 4.4.49 (|error| <= 2e-8 before rounding), reflected
/// about pi/4 and pi/2. Zero for (0, 0); NaN for a NaN argument.
#[inline(always)]
pub fn upper_atan2_f32(y: f32, x: f32) -> f32 {
    use core::f32::consts::{FRAC_PI_2, PI};
    let ax = x.abs();
    let (num, den, swap) = if ax >= y {
        (y, ax, false)
    } else {
        (ax, y, true)
    };
    if den == 0.0 {
        return 0.0;
    }
    let t = num / den;
    let t2 = t * t;
    // Horner, written out (a loop over the coefficients is not unrolled).
    let p = 0.002_866_225_7f32;
    let p = p * t2 - 0.016_165_737;
    let p = p * t2 + 0.042_909_614;
    let p = p * t2 - 0.075_289_64;
    let p = p * t2 + 0.106_562_64;
    let p = p * t2 - 0.142_089;
    let p = p * t2 + 0.199_935_51;
    let p = p * t2 - 0.333_331_45;
    let p = p * t2 + 1.0;
    let a = t * p;
    let a = if swap { FRAC_PI_2 - a } else { a };
    if x < 0.0 { PI - a } else { a }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
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
    #[inline(always)]
    fn square_root(self) -> Self {
        <f64 as nalgebra::ComplexField>::sqrt(self)
    }
    #[inline(always)]
    fn upper_atan2(self, x: Self) -> Self {
        <f64 as nalgebra::RealField>::atan2(self, x)
    }
    #[inline(always)]
    fn from_count(n: u64) -> Self {
        n as f64
    }
    #[inline(always)]
    fn truncated_index(self) -> usize {
        self as usize
    }
    #[inline(always)]
    fn same_bits(self, other: Self) -> bool {
        self.to_bits() == other.to_bits()
    }
    #[inline]
    fn sin_cos_small(self) -> (Self, Self) {
        (
            <f64 as nalgebra::ComplexField>::sin(self),
            <f64 as nalgebra::ComplexField>::cos(self),
        )
    }
}

/// The unit quaternion q/|q| from `[w, x, y, z]` (as nalgebra's
/// `UnitQuaternion::from_quaternion`, with [`Real::square_root`]).
#[inline(always)]
pub fn unit_quaternion<T: Real>(q: [T; 4]) -> UnitQuaternion<T> {
    let [w, x, y, z] = q;
    let inv = T::one() / (w * w + x * x + y * y + z * z).square_root();
    UnitQuaternion::new_unchecked(Quaternion::new(w * inv, x * inv, y * inv, z * inv))
}

/// The rotation matrix of the quaternion `[w, x, y, z]` after normalising it, from
/// the quaternion as it is: with s = 2/|q|²,
/// `R = I - s [[y²+z², -(xy-wz), -(xz+wy)], [-(xy+wz), x²+z², -(yz-wx)], [-(xz-wy), -(yz+wx), x²+y²]]`
/// (one division, no square root).
#[inline(always)]
pub fn rotation_matrix<T: Real>(q: [T; 4]) -> Mat3<T> {
    let [w, x, y, z] = q;
    let s = T::lit(2.0) / ((w * w + x * x) + (y * y + z * z));
    let (xs, ys, zs) = (x * s, y * s, z * s);
    let (wx, wy, wz) = (w * xs, w * ys, w * zs);
    let (xx, xy, xz) = (x * xs, x * ys, x * zs);
    let (yy, yz, zz) = (y * ys, y * zs, z * zs);
    let one = T::one();
    Mat3::new(
        one - (yy + zz),
        xy - wz,
        xz + wy,
        xy + wz,
        one - (xx + zz),
        yz - wx,
        xz - wy,
        yz + wx,
        one - (xx + yy),
    )
}

/// Roll, pitch, yaw (ZYX convention), rad, of the rotation matrix `r` (body to
/// reference frame): `r = Rz(yaw) Ry(pitch) Rx(roll)`.
///
/// The angles of nalgebra's `Rotation3::euler_angles`, computed with three
/// `atan2` and one square root: pitch = atan2(-r20, sqrt(r21² + r22²)),
/// roll = atan2(r21, r22), yaw = atan2(r10, r00) (the same angles as dividing both
/// arguments by cos(pitch) > 0, without `asin`, whose f32 library form works in
/// f64, all in software on a Cortex-M4). At the poles (|r20| >= 1) yaw is 0 and the
/// whole heading goes to roll, as nalgebra does.
#[inline]
pub fn euler_zyx<T: Real>(r: &Mat3<T>) -> (T, T, T) {
    let (r20, r21, r22) = (r[(2, 0)], r[(2, 1)], r[(2, 2)]);
    let one = T::one();
    if r20.abs() < one {
        let pitch = (-r20).atan2((r21 * r21 + r22 * r22).square_root());
        (r21.atan2(r22), pitch, r[(1, 0)].atan2(r[(0, 0)]))
    } else if r20 <= -one {
        (r[(0, 1)].atan2(r[(0, 2)]), T::frac_pi_2(), T::zero())
    } else {
        (-r[(0, 1)].atan2(-r[(0, 2)]), -T::frac_pi_2(), T::zero())
    }
}

/// Euclidean norm |v| with [`Real::square_root`].
#[inline(always)]
pub fn norm<T: Real>(v: &Vec3<T>) -> T {
    v.norm_squared().square_root()
}

/// 1/|v| (a direction after an RK4 step): the correctly rounded root of |v|² and
/// one division, whatever |v| (no Newton step for the nearly unit ones: its
/// branch made the cost depend on how far the step took |v| from 1).
#[inline(always)]
pub fn inverse_norm<T: Real>(v: &Vec3<T>) -> T {
    T::one() / v.norm_squared().square_root()
}

/// A 3-vector.
pub type Vec3<T> = Vector3<T>;
/// A 3x3 matrix.
pub type Mat3<T> = Matrix3<T>;

/// The zero vector, in a `const` context (where `Vec3::zeros()` cannot be called).
pub(crate) const fn zero3<T: Real>() -> Vec3<T> {
    Vec3::new(T::ZERO, T::ZERO, T::ZERO)
}

/// The zero matrix, in a `const` context.
pub(crate) const fn zero33<T: Real>() -> Mat3<T> {
    let z = T::ZERO;
    Mat3::new(z, z, z, z, z, z, z, z, z)
}

/// Returns `r` unchanged, with its address hidden from the optimiser
/// ([`core::hint::black_box`]); no effect on any value.
///
/// The firmware keeps its solver in a `static`. With LTO every field address of the
/// hot loops then folds to a link-time constant, and Thumb-2 reaches a constant
/// address beyond the load's offset range (1 KiB for VLDR) only with a MOVW and an
/// ADD per access: about twice the instructions of a loop that walks the arrays
/// through base registers. The passes take their references through this, once per
/// call.
#[inline(always)]
pub fn opaque<R>(r: R) -> R {
    core::hint::black_box(r)
}

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

#[cfg(test)]
mod tests {
    #[test]
    fn the_f32_upper_atan2_is_within_3e7_of_the_library() {
        let mut worst = 0.0f64;
        for i in 0..=4000 {
            let angle = core::f64::consts::PI * i as f64 / 4000.0;
            for r in [1.0f64, 1e-3, 37.5, 1e6] {
                let (x, y) = ((r * angle.cos()) as f32, (r * angle.sin()).abs() as f32);
                let got = super::upper_atan2_f32(y, x) as f64;
                let expected = (y as f64).atan2(x as f64);
                worst = worst.max((got - expected).abs());
            }
        }
        assert!(worst < 3e-7, "worst {worst:e}");
        assert_eq!(super::upper_atan2_f32(0.0, 0.0), 0.0);
        assert_eq!(super::upper_atan2_f32(0.0, 2.0), 0.0);
        assert_eq!(super::upper_atan2_f32(0.0, -2.0), core::f32::consts::PI);
        assert_eq!(
            super::upper_atan2_f32(3.0, 0.0),
            core::f32::consts::FRAC_PI_2
        );
        assert!(super::upper_atan2_f32(f32::NAN, 1.0).is_nan());
        assert!(super::upper_atan2_f32(1.0, f32::NAN).is_nan());
    }

    #[test]
    fn euler_zyx_matches_nalgebra() {
        use nalgebra::UnitQuaternion;
        let cases: [(f64, f64, f64); 5] = [
            (0.3, -0.4, 2.0),
            (-2.9, 1.2, -0.7),
            (0.0, 0.0, 0.0),
            (3.1, -1.5, 3.0),
            (0.2, 1.5, -3.1),
        ];
        for (roll, pitch, yaw) in cases {
            let q = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
            let m = *q.to_rotation_matrix().matrix();
            let (r, p, y) = super::euler_zyx(&m);
            let (er, ep, ey) = q.euler_angles();
            assert!(
                (r - er).abs() < 1e-9 && (p - ep).abs() < 1e-9 && (y - ey).abs() < 1e-9,
                "{:?} vs {:?}",
                (r, p, y),
                (er, ep, ey)
            );
        }
        // The poles: nalgebra's convention (yaw 0, the heading in roll).
        for pitch in [core::f64::consts::FRAC_PI_2, -core::f64::consts::FRAC_PI_2] {
            let m = *UnitQuaternion::from_euler_angles(0.0, pitch, 0.7)
                .to_rotation_matrix()
                .matrix();
            let mut pole = m;
            pole[(2, 0)] = -pitch.signum();
            let (r, p, y) = super::euler_zyx(&pole);
            let rotation = nalgebra::Rotation3::from_matrix_unchecked(pole);
            let (er, ep, ey) = rotation.euler_angles();
            assert_eq!((r, p, y), (er, ep, ey));
        }
    }

    #[test]
    fn sin_cos_f32_is_within_two_ulp() {
        let ulp = |v: f64| (v.abs() as f32).max(f32::MIN_POSITIVE).to_bits();
        let mut worst = 0u32;
        for i in -40_000..=40_000 {
            let x = i as f32 * 1e-4;
            let (s, c) = super::sin_cos_f32(x);
            let (es, ec) = ((x as f64).sin(), (x as f64).cos());
            for (got, exact) in [(s, es), (c, ec)] {
                let near = exact as f32;
                let diff = (got.to_bits() as i64 - near.to_bits() as i64).unsigned_abs() as u32;
                // Near a zero of the function, absolute rather than relative.
                if exact.abs() > 1e-3 {
                    worst = worst.max(diff);
                } else {
                    assert!(
                        (got as f64 - exact).abs() < 1e-7,
                        "{x}: {got} against {exact}"
                    );
                }
                let _ = ulp;
            }
        }
        assert!(worst <= 2, "{worst} ulp");
    }

    #[test]
    fn rotation_matrix_matches_the_unit_quaternion() {
        let q = [0.9f64, -0.2, 0.35, 0.1];
        let unit = super::unit_quaternion(q);
        let expected = *unit.to_rotation_matrix().matrix();
        let got = super::rotation_matrix(q);
        assert!((got - expected).norm() < 1e-14, "{got} vs {expected}");
    }
}
