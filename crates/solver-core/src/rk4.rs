//! The one fixed-step RK4 of the workspace (docs/design.md §4), generic over where the
//! state's time derivative comes from.
//!
//! [`Rk4::step`] advances y(t) by dt:
//!
//! ```text
//!   k1 = f(y, t)                 k2 = f(y + dt/2 k1, t + dt/2)
//!   k3 = f(y + dt/2 k2, t + dt/2)  k4 = f(y + dt k3, t + dt)
//!   y(t + dt) = y + dt/6 (k1 + 2 k2 + 2 k3 + k4), renormalised
//! ```
//!
//! where f is a [`DerivativeSource`]: the product's O(N) passes ([`crate::Solver`]),
//! the dense Kane reference (`dense::DenseDerivative`, `std` only) or the
//! benchmarks' reference derivatives. The renormalisation restores the state's
//! invariants: unit directions, rates perpendicular to them, a unit quaternion.
//!
//! Invariants of the arithmetic, which every source shares, so that two sources
//! giving the same derivatives give the same states bit for bit:
//!
//! - the stage factors come from dt rounded to `T` once: `h = T(dt)`, `h/2 = h 0.5`,
//!   `h/6 = h (1/6)` (on the Cortex-M4F every f64 operation is a library call);
//! - the source's inputs are sampled once per distinct time (k2 and k3 share
//!   t + dt/2);
//! - the weighted sum is formed in the stage passes (`sum = k1`, `sum += 2 k2`,
//!   `sum += 2 k3`) and the result as `y + dt/6 (sum + k4)`, renormalised in the same
//!   pass (`State::set_final`);
//! - the state and the stage buffer are swapped after a successful step rather than
//!   copied; on any error the state is left exactly as it was.
//!
//! No heap, no dynamic dispatch: the step is generic over the source and inlined
//! into its caller.

use crate::error::{InputError, SolveError};
use crate::scalar::{Real, vec_finite};
use crate::state::{Derivative, State};

/// Where the state's time derivative comes from: f(y, t) for [`Rk4::step`].
///
/// A source holds whatever the derivative needs besides the state (a model, a
/// flight path, scratch space). It is asked for its time-dependent inputs once per
/// distinct time of a step and evaluates the derivative at a state with them.
pub trait DerivativeSource<T: Real, const N: usize> {
    /// The inputs of an evaluation at one time (for the towed system: the
    /// connection-point kinematics and the air column).
    type Inputs;

    /// Number of used segments of the states this source evaluates.
    fn segment_count(&self) -> usize;

    /// The inputs at `time`, s; an error rejects the step.
    fn inputs_at(&mut self, time: f64) -> Result<Self::Inputs, SolveError>;

    /// Writes dy/dt at `state` with `inputs` into `out` (its first
    /// [`DerivativeSource::segment_count`] segments and the decoy entries).
    fn evaluate(
        &mut self,
        state: &State<T, N>,
        inputs: &Self::Inputs,
        out: &mut Derivative<T, N>,
    ) -> Result<(), SolveError>;

    /// True when [`Rk4::last_derivative`] already holds the derivative at the current
    /// state with `inputs`, bit for bit: the first stage then copies it instead of
    /// evaluating again. Called once per step, with the inputs at the step's start.
    /// The default never reuses.
    #[inline(always)]
    fn holds_first_stage(&mut self, inputs: &Self::Inputs) -> bool {
        let _ = inputs;
        false
    }

    /// Evaluates dy/dt at `stage` with `inputs`, then replaces `stage` by the next
    /// stage and updates the sum as `next` says, with the bits of
    /// [`DerivativeSource::evaluate`] followed by those updates (the default does
    /// exactly that, with `out` as the derivative). A source may form the stage as
    /// it finds the derivative, without storing it: `out` is then scratch whose
    /// contents are unspecified afterwards.
    #[inline(always)]
    fn evaluate_to_stage(
        &mut self,
        stage: &mut State<T, N>,
        inputs: &Self::Inputs,
        out: &mut Derivative<T, N>,
        next: StageUpdate<'_, T, N>,
    ) -> Result<(), SolveError> {
        self.evaluate(stage, inputs, out)?;
        let n = self.segment_count();
        stage.set_stage_accumulating(next.base, out, next.h, next.sum, next.weight, n);
        Ok(())
    }

    /// Evaluates dy/dt at `state` with `inputs` into `out` (RK4's first stage, k1)
    /// and forms the second stage's state `stage = state + h k1` (its first
    /// segments and the decoy), with the bits of [`DerivativeSource::evaluate`]
    /// followed by `State::set_stage` (the default does exactly that). A source
    /// may form the stage as it finds the derivative.
    #[inline(always)]
    fn evaluate_first_stage(
        &mut self,
        state: &State<T, N>,
        inputs: &Self::Inputs,
        stage: &mut State<T, N>,
        out: &mut Derivative<T, N>,
        h: T,
    ) -> Result<(), SolveError> {
        self.evaluate(state, inputs, out)?;
        let n = self.segment_count();
        stage.set_stage(state, out, h, n);
        Ok(())
    }

    /// Called after the four stages, before the new state is accepted: an error
    /// rejects the step and leaves the state as it was. For a source that records a
    /// failed evaluation and carries on (so that every step does the same work).
    /// The default accepts.
    #[inline(always)]
    fn finish(&mut self) -> Result<(), SolveError> {
        Ok(())
    }
}

/// The next RK4 stage formed from a derivative as it is found, without keeping it:
/// `stage = base + h k` and `sum = sum + weight k` (`State::set_stage_accumulating`'s
/// arithmetic, so the same bits).
pub struct StageUpdate<'a, T: Real, const N: usize> {
    /// The state the stage starts from (y).
    pub base: &'a State<T, N>,
    /// The stage factor.
    pub h: T,
    /// The weighted sum of the stages' derivatives.
    pub sum: &'a mut Derivative<T, N>,
    /// The derivative's weight in the sum.
    pub weight: T,
}

/// The integrated state and RK4's buffers: the state (`states[current]`), the stage
/// buffer (the other one), the last stage's derivative and the weighted sum.
///
/// A step writes its result into the stage buffer and swaps the two, rather than
/// copying it. Their unused entries (beyond the source's segments) are always
/// equal, so the swap changes none of them.
#[derive(Clone, Debug)]
pub struct Rk4<T: Real, const N: usize> {
    states: [State<T, N>; 2],
    /// 0 or 1 (read as `current & 1`: the optimiser then knows the index is in
    /// range, and no bounds check remains on the frame path).
    current: usize,
    /// The last stage's derivative (`derivatives[slope]`) and the weighted sum
    /// (the other one): a first stage reused from the last derivative swaps their
    /// roles rather than copying it.
    derivatives: [Derivative<T, N>; 2],
    /// 0 or 1 (read as `slope & 1`, as `current`).
    slope: usize,
}

impl<T: Real, const N: usize> Rk4<T, N> {
    /// Every buffer zero, all zero bits: an integrator that has no state yet (give it
    /// one with [`Rk4::set_state`]), as a constant, so that a `static` holding it
    /// lies in `.bss` ([`Solver::UNCONFIGURED`](crate::Solver::UNCONFIGURED)).
    pub const ZERO: Self = Rk4 {
        states: [State::ZERO; 2],
        current: 0,
        derivatives: [Derivative::ZERO; 2],
        slope: 0,
    };

    /// An integrator starting from `state` (the caller checks it is finite).
    pub fn new(state: State<T, N>) -> Self {
        Rk4 {
            states: [state; 2],
            current: 0,
            derivatives: [Derivative::default(), Derivative::default()],
            slope: 0,
        }
    }

    /// The current state.
    #[inline(always)]
    pub fn state(&self) -> &State<T, N> {
        &self.states[self.current & 1]
    }

    /// The current state, to write in place (the caller keeps it finite, its
    /// directions unit and perpendicular to its rates).
    pub fn state_mut(&mut self) -> &mut State<T, N> {
        &mut self.states[self.current & 1]
    }

    /// Replaces the state (the caller checks it is finite).
    pub fn set_state(&mut self, state: State<T, N>) {
        self.states = [state; 2];
    }

    /// Sets the current state's time, s, and nothing else (the caller checks it is
    /// finite).
    pub fn set_time(&mut self, time: f64) {
        self.states[self.current & 1].time = time;
    }

    /// The derivative of the last evaluation: the last stage of a step (k4), or what
    /// the caller wrote through [`Rk4::state_and_last_derivative`].
    #[inline(always)]
    pub fn last_derivative(&self) -> &Derivative<T, N> {
        &self.derivatives[self.slope & 1]
    }

    /// The current state and the last derivative's buffer, for an evaluation at the
    /// current state that a later step's first stage may reuse
    /// ([`DerivativeSource::holds_first_stage`]).
    #[inline(always)]
    pub fn state_and_last_derivative(&mut self) -> (&State<T, N>, &mut Derivative<T, N>) {
        (
            &self.states[self.current & 1],
            &mut self.derivatives[self.slope & 1],
        )
    }

    /// After a step: the new state and the spare derivative buffer (the step's
    /// weighted sum, no longer needed) to evaluate the new state's derivative in,
    /// for an error estimate that costs no evaluation the next step would not
    /// make anyway ([`crate::Solver::step_to_checked`]); [`Rk4::keep_spare`] then
    /// makes the spare buffer the last derivative.
    pub fn state_and_spare(&mut self) -> (&State<T, N>, &mut Derivative<T, N>) {
        let [a, b] = &mut self.derivatives;
        let spare = if self.slope & 1 == 0 { b } else { a };
        (&self.states[self.current & 1], spare)
    }

    /// Makes the spare derivative buffer, just evaluated at the current state
    /// ([`Rk4::state_and_spare`]), the last derivative.
    pub fn keep_spare(&mut self) {
        self.slope = 1 - (self.slope & 1);
    }

    /// Goes back to the state before the last step: the state buffer the step
    /// read is left untouched by it (the step writes the other and swaps), so
    /// this is a swap back. Only right after a successful step is that buffer the
    /// state before it; [`crate::Solver::step_to_checked`] guarantees it by
    /// borrowing the solver until the step is accepted or undone.
    pub fn undo_step(&mut self) {
        self.current = 1 - (self.current & 1);
    }

    /// Advances the state by one RK4 step of `dt` seconds with the derivatives of
    /// `source`, then renormalises (unit directions, rates perpendicular to them,
    /// unit quaternion).
    ///
    /// `observe` is called with the source, the state before the step and k1 (the
    /// source's scratch then holds that evaluation), unless the first stage fails.
    ///
    /// On any error (a bad `dt`, the source's inputs or evaluation, a non-finite
    /// result) the state is left exactly as it was. A non-finite result names the
    /// first segment (1-based joint) holding a non-finite value, or the last joint.
    ///
    /// `dt` is f64 in every precision so that time advances identically for f32 and
    /// f64; the stage arithmetic uses `dt` rounded to `T`.
    #[inline(always)]
    pub fn step<S, F>(&mut self, source: &mut S, dt: f64, observe: F) -> Result<(), SolveError>
    where
        S: DerivativeSource<T, N> + ?Sized,
        F: FnOnce(&mut S, &State<T, N>, &Derivative<T, N>),
    {
        self.step_from(source, dt, None, observe).map(|_| ())
    }

    /// [`Rk4::step`] with the source's inputs at the step's start given (`start`,
    /// when the caller has them: the inputs at the end of the step before, on the
    /// same source, are those of this step's start, bit for bit); returns the
    /// inputs at the step's end for the next. With `start` the inputs the source
    /// gives at the current time, the same bits as [`Rk4::step`].
    #[inline(always)]
    pub fn step_from<S, F>(
        &mut self,
        source: &mut S,
        dt: f64,
        start: Option<S::Inputs>,
        observe: F,
    ) -> Result<S::Inputs, SolveError>
    where
        S: DerivativeSource<T, N> + ?Sized,
        F: FnOnce(&mut S, &State<T, N>, &Derivative<T, N>),
    {
        // dt finite and positive, tested on its bits (positive doubles order as
        // their bit patterns; a soft-float compare on the M4F costs about 30
        // instructions): above +0 and below +inf, NaN and negatives excluded.
        let bits = dt.to_bits();
        if !(bits > 0 && bits < f64::INFINITY.to_bits()) {
            return Err(InputError::BadTimeStep.into());
        }
        let t0 = self.state().time;
        let (t_half, t_end) = (t0 + half_of(dt), t0 + dt);
        let start = match start {
            Some(inputs) => inputs,
            None => source.inputs_at(t0)?,
        };
        self.step_sampled(
            source,
            T::lit(dt),
            start,
            |source| source.inputs_at(t_half),
            |source| source.inputs_at(t_end),
            t_end,
            observe,
        )
    }

    /// One RK4 step from the state's time t0 to `t_end` exactly: the step dt =
    /// `t_end` - t0 (in f64, then rounded to `T` for the stages), the inputs sampled
    /// at t0 (or `start`, as in [`Rk4::step_from`]), t0 + dt/2 and `t_end`, and the
    /// new state's time `t_end` itself, not t0 + dt: a caller that steps to times it
    /// computes on a grid (k / 100 s) never sees its clock drift, whatever the steps.
    /// Returns the inputs at `t_end` for the next step. [`InputError::BadTimeStep`]
    /// when `t_end` is not finite or not after t0; on any error the state is left
    /// exactly as it was.
    #[inline(always)]
    pub fn step_to<S, F>(
        &mut self,
        source: &mut S,
        t_end: f64,
        start: Option<S::Inputs>,
        observe: F,
    ) -> Result<S::Inputs, SolveError>
    where
        S: DerivativeSource<T, N> + ?Sized,
        F: FnOnce(&mut S, &State<T, N>, &Derivative<T, N>),
    {
        let t0 = self.state().time;
        let dt = t_end - t0;
        let bits = dt.to_bits();
        if !(bits > 0 && bits < f64::INFINITY.to_bits() && t_end.is_finite()) {
            return Err(InputError::BadTimeStep.into());
        }
        let t_half = t0 + half_of(dt);
        let start = match start {
            Some(inputs) => inputs,
            None => source.inputs_at(t0)?,
        };
        self.step_sampled(
            source,
            T::lit(dt),
            start,
            |source| source.inputs_at(t_half),
            |source| source.inputs_at(t_end),
            t_end,
            observe,
        )
    }

    /// One RK4 step of `full` (the step in `T`, positive and finite: the caller
    /// checks) with the source's inputs at the step's start (`start`), middle
    /// (`middle`, sampled once for k2 and k3) and end (`end`, returned for the
    /// next step's start); the new state's time is `time_after`. The core of
    /// [`Rk4::step_from`], for a caller that samples its inputs otherwise than by
    /// time (the controller's frames: at the nodes of the frame's steps,
    /// [`crate::Solver::steps_on`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn step_sampled<S, F, M, E>(
        &mut self,
        source: &mut S,
        full: T,
        start: S::Inputs,
        middle: M,
        end: E,
        time_after: f64,
        observe: F,
    ) -> Result<S::Inputs, SolveError>
    where
        S: DerivativeSource<T, N> + ?Sized,
        F: FnOnce(&mut S, &State<T, N>, &Derivative<T, N>),
        M: FnOnce(&mut S) -> Result<S::Inputs, SolveError>,
        E: FnOnce(&mut S) -> Result<S::Inputs, SolveError>,
    {
        let n = source.segment_count();
        let (state, stage) = halves(&mut self.states, self.current);
        // The stage factors from the step rounded to T once.
        let half = full * T::lit(0.5);
        let sixth = full * T::lit(1.0 / 6.0);
        let two = T::lit(2.0);

        // k1 at the current state, straight into the weighted sum (sum = k1); or, when
        // the source says the last evaluation was at this state with the same inputs,
        // that evaluation itself: the last derivative's buffer becomes the sum (the
        // other one the scratch), the same bits without evaluating or copying.
        // Either way the stage y + dt/2 k1 follows, formed as k1 is found when it
        // is evaluated.
        let reuse = source.holds_first_stage(&start);
        if reuse {
            self.slope = 1 - self.slope;
        }
        let [a, b] = &mut self.derivatives;
        let (slope, sum) = if self.slope == 0 { (a, b) } else { (b, a) };
        if reuse {
            stage.set_stage(state, sum, half, n);
        } else {
            source.evaluate_first_stage(state, &start, stage, sum, half)?;
        }
        observe(source, state, sum);
        // The inputs are sampled once per distinct time: k2 and k3 both evaluate at
        // the step's middle.
        let middle = middle(source)?;
        // k2 at y + dt/2 k1, turned into the stage y + dt/2 k2 (sum += 2 k2).
        let next = StageUpdate {
            base: state,
            h: half,
            sum: &mut *sum,
            weight: two,
        };
        source.evaluate_to_stage(stage, &middle, slope, next)?;
        // k3 at y + dt/2 k2, turned into the stage y + dt k3 (sum += 2 k3).
        let next = StageUpdate {
            base: state,
            h: full,
            sum: &mut *sum,
            weight: two,
        };
        source.evaluate_to_stage(stage, &middle, slope, next)?;
        // k4 at y + dt k3.
        let end = end(source)?;
        source.evaluate(stage, &end, slope)?;
        // y + dt/6 (k1 + 2 k2 + 2 k3 + k4).
        let probe = stage.set_final(state, sum, slope, sixth, n);
        stage.time = time_after;
        source.finish()?;
        // The probe is finite only if every value is; the full check runs only when it is not.
        let probe_finite = probe.finite() && time_after.is_finite();
        if !probe_finite && !stage.is_finite(n) {
            let joint = stage
                .directions
                .iter()
                .zip(&stage.rates)
                .take(n)
                .position(|(e, w)| !(vec_finite(e) && vec_finite(w)))
                .map_or(n, |i| i + 1);
            return Err(SolveError::NonFinite { joint });
        }
        // The stage buffer holds the new state: swap the roles.
        self.current = 1 - self.current;
        Ok(end)
    }
}

/// 0.5 x for a positive finite `x`, exactly: one off the exponent when the result
/// is normal (an integer subtraction where the soft-float multiply on the M4F
/// costs about 50 instructions), else the multiplication.
#[inline(always)]
fn half_of(x: f64) -> f64 {
    let bits = x.to_bits();
    // Biased exponent 2 or more: x/2 is normal, its exponent one less.
    if bits >= 2 << 52 && bits < f64::INFINITY.to_bits() {
        f64::from_bits(bits - (1 << 52))
    } else {
        0.5 * x
    }
}

/// The state and the stage buffer of [`Rk4::states`], `current` first.
#[inline(always)]
fn halves<T: Real, const N: usize>(
    states: &mut [State<T, N>; 2],
    current: usize,
) -> (&State<T, N>, &mut State<T, N>) {
    let [a, b] = states;
    if current == 0 { (a, b) } else { (b, a) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_of_is_the_product() {
        for x in [
            1.0,
            0.0025,
            1.0e-300,
            f64::MIN_POSITIVE,
            f64::MIN_POSITIVE * 2.0,
            f64::MIN_POSITIVE * 3.5,
            5e-324,
            1e-310,
            f64::MAX,
            123.456,
        ] {
            assert_eq!(half_of(x).to_bits(), (0.5 * x).to_bits(), "{x:e}");
        }
    }
    use crate::scalar::Vec3;

    /// A rod spinning at a constant rate about z: dy/dt = (w x e, 0), recording the
    /// times it was asked for and how often it evaluated.
    struct Spin {
        times: [f64; 4],
        sampled: usize,
        evaluations: usize,
        reuse: bool,
        reject: bool,
    }

    impl Spin {
        fn new(reuse: bool, reject: bool) -> Self {
            Spin {
                times: [f64::NAN; 4],
                sampled: 0,
                evaluations: 0,
                reuse,
                reject,
            }
        }
    }

    impl DerivativeSource<f64, 1> for Spin {
        type Inputs = ();
        fn segment_count(&self) -> usize {
            1
        }
        fn inputs_at(&mut self, time: f64) -> Result<(), SolveError> {
            self.times[self.sampled] = time;
            self.sampled += 1;
            Ok(())
        }
        fn evaluate(
            &mut self,
            state: &State<f64, 1>,
            _: &(),
            out: &mut Derivative<f64, 1>,
        ) -> Result<(), SolveError> {
            self.evaluations += 1;
            out.directions[0] = state.rates[0].cross(&state.directions[0]);
            out.rates[0] = Vec3::zeros();
            Ok(())
        }
        fn holds_first_stage(&mut self, _: &()) -> bool {
            self.reuse
        }
        fn finish(&mut self) -> Result<(), SolveError> {
            if self.reject {
                Err(SolveError::NonFinite { joint: 1 })
            } else {
                Ok(())
            }
        }
    }

    fn spinning_rod() -> State<f64, 1> {
        let mut state = State::default();
        state.directions[0] = Vec3::x();
        state.rates[0] = Vec3::new(0.0, 0.0, 2.0);
        state
    }

    #[test]
    fn a_step_samples_three_times_and_follows_the_rotation() {
        let mut rk4 = Rk4::new(spinning_rod());
        let mut spin = Spin::new(false, false);
        let mut observed = None;
        rk4.step(&mut spin, 0.01, |_, state, k1| {
            observed = Some((state.time, k1.directions[0]));
        })
        .unwrap();
        assert_eq!(spin.times[..3], [0.0, 0.005, 0.01]);
        assert_eq!(spin.evaluations, 4);
        assert_eq!(observed, Some((0.0, Vec3::new(0.0, 2.0, 0.0))));
        let e = rk4.state().directions[0];
        // RK4's rotation by 0.02 rad, renormalised: within its local error of the exact one.
        let exact = Vec3::new(0.02f64.cos(), 0.02f64.sin(), 0.0);
        assert!((e - exact).amax() < 1e-10, "{e:?}");
        assert!((e.norm() - 1.0).abs() < 1e-15);
        assert_eq!(rk4.state().time, 0.01);
    }

    #[test]
    fn a_held_first_stage_is_copied_not_evaluated() {
        let mut rk4 = Rk4::new(spinning_rod());
        let mut spin = Spin::new(false, false);
        let (state, slope) = rk4.state_and_last_derivative();
        spin.evaluate(state, &(), slope).unwrap();
        let mut fresh = rk4.clone();
        let mut reusing = Spin::new(true, false);
        rk4.step(&mut reusing, 0.01, |_, _, _| {}).unwrap();
        assert_eq!(reusing.evaluations, 3);
        fresh.step(&mut spin, 0.01, |_, _, _| {}).unwrap();
        assert_eq!(rk4.state(), fresh.state());
    }

    #[test]
    fn a_rejected_step_or_time_step_leaves_the_state_as_it_was() {
        let mut rk4 = Rk4::new(spinning_rod());
        assert!(
            rk4.step(&mut Spin::new(false, true), 0.01, |_, _, _| {})
                .is_err()
        );
        assert_eq!(*rk4.state(), spinning_rod());
        let mut spin = Spin::new(false, false);
        for dt in [0.0, -0.01, f64::NAN, f64::INFINITY] {
            assert_eq!(
                rk4.step(&mut spin, dt, |_, _, _| {}),
                Err(SolveError::Input(InputError::BadTimeStep))
            );
        }
        assert_eq!(spin.sampled, 0);
        assert_eq!(*rk4.state(), spinning_rod());
    }
}
