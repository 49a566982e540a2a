//! The integrated state: a plain value that can be copied, saved and restored.

use nalgebra::UnitQuaternion;

use crate::scalar::{Real, Vec3, zero3};

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

impl<T: Real, const N: usize> State<T, N> {
    /// Every value zero (the decoy quaternion too, so this is not an attitude): the
    /// contents of an integrator that has not been given a state yet, all zero
    /// bits, so that a `static` holding it lies in `.bss`.
    pub const ZERO: Self = State {
        time: 0.0,
        directions: [zero3(); N],
        rates: [zero3(); N],
        decoy_attitude: [T::ZERO; 4],
        decoy_rate: zero3(),
    };

    /// At rest: every direction, rate and time zero, the decoy level heading north
    /// (the identity quaternion): [`State::default`].
    pub const REST: Self = State {
        decoy_attitude: [T::ONE, T::ZERO, T::ZERO, T::ZERO],
        ..Self::ZERO
    };
}

/// [`State::REST`], built at run time (no constant image in the binary).
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

impl<T: Real, const N: usize> Derivative<T, N> {
    /// Every value zero ([`Derivative::default`]).
    pub const ZERO: Self = Derivative {
        directions: [zero3(); N],
        rates: [zero3(); N],
        decoy_attitude: [T::ZERO; 4],
        decoy_rate: zero3(),
    };
}

/// [`Derivative::ZERO`], built at run time.
impl<T: Real, const N: usize> State<T, N> {
    /// Makes this the time, the first `count` segments and the decoy of `other`,
    /// in place, leaving the rest of the capacity as it is: on a state whose
    /// unused capacity is zero (as a solver's), the copy is the state itself, at
    /// the cost of the used part where a whole copy moves the whole capacity
    /// (about 1.6 KB at 64 segments in f32).
    pub fn copy_used(&mut self, other: &Self, count: usize) {
        self.time = other.time;
        // One pass over both arrays (two slice copies become two library calls).
        let rows = self.directions[..count]
            .iter_mut()
            .zip(&mut self.rates[..count])
            .zip(other.directions[..count].iter().zip(&other.rates[..count]));
        for ((d, r), (e, w)) in rows {
            *d = *e;
            *r = *w;
        }
        self.decoy_attitude = other.decoy_attitude;
        self.decoy_rate = other.decoy_rate;
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

    /// RK4 stage `self = base + h k` over the first `count` segments.
    #[inline(never)]
    pub(crate) fn set_stage(&mut self, base: &Self, k: &Derivative<T, N>, h: T, count: usize) {
        let (this, base, k) = crate::scalar::opaque((self, base, k));
        let rows = this.directions[..count]
            .iter_mut()
            .zip(this.rates[..count].iter_mut())
            .zip(base.directions[..count].iter().zip(&base.rates[..count]))
            .zip(k.directions[..count].iter().zip(&k.rates[..count]));
        for (((o_e, o_w), (b_e, b_w)), (k_e, k_w)) in rows {
            // Copies first: the stores may alias for all the optimiser knows.
            let (b_e, b_w, k_e, k_w) = (*b_e, *b_w, *k_e, *k_w);
            *o_e = b_e + k_e * h;
            *o_w = b_w + k_w * h;
        }
        for ((o, b), d) in this
            .decoy_attitude
            .iter_mut()
            .zip(&base.decoy_attitude)
            .zip(&k.decoy_attitude)
        {
            *o = *b + *d * h;
        }
        this.decoy_rate = base.decoy_rate + k.decoy_rate * h;
    }

    /// RK4 stage and weighted sum in one pass over the first `count` segments:
    /// `self = base + h k` and `sum += weight k`.
    #[inline(never)]
    pub(crate) fn set_stage_accumulating(
        &mut self,
        base: &Self,
        k: &Derivative<T, N>,
        h: T,
        sum: &mut Derivative<T, N>,
        weight: T,
        count: usize,
    ) {
        let (this, base, k, sum) = crate::scalar::opaque((self, base, k, sum));
        // The weight through `opaque`: a literal 2 would become k + k, and with it a
        // separate add where a multiply-accumulate does (the same bits either way).
        let weight = crate::scalar::opaque(weight);
        stage_pass(this, base, k, h, sum, count, |s, k| s + k * weight);
    }

    /// The RK4 result `self = base + h (sum + k)` over the first `count` segments
    /// (`sum` holds k1 + 2 k2 + 2 k3, `k` is k4, `h` = dt/6), renormalised in the same
    /// pass to restore the invariants: e / |e|, w - e (w.e), q / |q|.
    ///
    /// Returns the sum of every used direction, rate, quaternion and decoy-rate
    /// component: finite only if all of them are (a cheap probe; when it is not
    /// finite, [`State::is_finite`] decides).
    #[inline(never)]
    pub(crate) fn set_final(
        &mut self,
        base: &Self,
        sum: &Derivative<T, N>,
        k: &Derivative<T, N>,
        h: T,
        count: usize,
    ) -> T {
        let (this, base, sum, k) = crate::scalar::opaque((self, base, sum, k));
        let mut probe = T::zero();
        let rows = this.directions[..count]
            .iter_mut()
            .zip(this.rates[..count].iter_mut())
            .zip(base.directions[..count].iter().zip(&base.rates[..count]))
            .zip(
                (sum.directions[..count].iter().zip(&sum.rates[..count]))
                    .zip(k.directions[..count].iter().zip(&k.rates[..count])),
            );
        for (((e_out, w_out), (e0, w0)), ((se, sw), (ke, kw))) in rows {
            // Copies first: the stores may alias for all the optimiser knows.
            let (e0, w0, se, sw, ke, kw) = (*e0, *w0, *se, *sw, *ke, *kw);
            let e = e0 + (se + ke) * h;
            let e = e * crate::scalar::inverse_norm(&e);
            let w = w0 + (sw + kw) * h;
            let w = w - e * w.dot(&e);
            // w is finite only if e is (a non-finite e makes w - e (w.e) NaN).
            probe += w.x + w.y + w.z;
            *e_out = e;
            *w_out = w;
        }
        for (((o, b), s), d) in this
            .decoy_attitude
            .iter_mut()
            .zip(&base.decoy_attitude)
            .zip(&sum.decoy_attitude)
            .zip(&k.decoy_attitude)
        {
            *o = *b + (*s + *d) * h;
        }
        this.decoy_rate = base.decoy_rate + (sum.decoy_rate + k.decoy_rate) * h;
        probe + this.renormalise_decoy()
    }

    /// The decoy part of the renormalisation: q / |q|; returns the sum of the
    /// quaternion and decoy-rate components.
    fn renormalise_decoy(&mut self) -> T {
        let n = self
            .decoy_attitude
            .iter()
            .fold(T::zero(), |a, q| a + *q * *q)
            .square_root();
        let mut probe = T::zero();
        for q in &mut self.decoy_attitude {
            *q /= n;
            probe += *q;
        }
        probe + (self.decoy_rate.x + self.decoy_rate.y + self.decoy_rate.z)
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

/// One pass of [`State::set_stage_accumulating`]: `out = base + h k`, and every
/// component of `sum` becomes `acc(sum, k)`.
#[inline(always)]
fn stage_pass<T: Real, const N: usize>(
    out: &mut State<T, N>,
    base: &State<T, N>,
    k: &Derivative<T, N>,
    h: T,
    sum: &mut Derivative<T, N>,
    count: usize,
    acc: impl Fn(T, T) -> T,
) {
    let acc3 = |s: &Vec3<T>, d: &Vec3<T>| Vec3::new(acc(s.x, d.x), acc(s.y, d.y), acc(s.z, d.z));
    let rows = out.directions[..count]
        .iter_mut()
        .zip(out.rates[..count].iter_mut())
        .zip(base.directions[..count].iter().zip(&base.rates[..count]))
        .zip(k.directions[..count].iter().zip(&k.rates[..count]))
        .zip(
            sum.directions[..count]
                .iter_mut()
                .zip(sum.rates[..count].iter_mut()),
        );
    for ((((o_e, o_w), (b_e, b_w)), (k_e, k_w)), (s_e, s_w)) in rows {
        // Copies first: the stores may alias for all the optimiser knows.
        let (b_e, b_w, k_e, k_w, se, sw) = (*b_e, *b_w, *k_e, *k_w, *s_e, *s_w);
        *o_e = b_e + k_e * h;
        *o_w = b_w + k_w * h;
        *s_e = acc3(&se, &k_e);
        *s_w = acc3(&sw, &k_w);
    }
    let rows = out
        .decoy_attitude
        .iter_mut()
        .zip(&base.decoy_attitude)
        .zip(k.decoy_attitude.iter().zip(sum.decoy_attitude.iter_mut()));
    for ((o, b), (d, s)) in rows {
        *o = *b + *d * h;
        *s = acc(*s, *d);
    }
    out.decoy_rate = base.decoy_rate + k.decoy_rate * h;
    sum.decoy_rate = acc3(&sum.decoy_rate, &k.decoy_rate);
}
