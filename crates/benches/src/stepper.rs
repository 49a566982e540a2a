//! RK4 steps with the reference derivatives (shooting form, dense Kane solution),
//! written here because `solver-core` steps only with its own O(N) passes.
//!
//! [`ReferenceStepper::step`] is the same scheme as `Solver::step`, operation for
//! operation: stages at y, y + dt/2 k1, y + dt/2 k2 and y + dt k3 (flight path sampled
//! at t, t + dt/2, t + dt/2, t + dt), then y + dt/6 (k1 + 2 k2 + 2 k3 + k4),
//! renormalised. With [`Derivatives::TwoSweep`] it gives bit-identical states to
//! `Solver::step` (a test in this file checks it), so the cost of the other two
//! variants differs from the solver's only by their derivative evaluation.
//!
//! Differences from `Solver::step`, all for the benchmarks:
//!
//! - The shooting form's round-off grows about 3.7x per segment: beyond a few tens of
//!   segments its tensions are garbage or not finite. `Solver::step` stops at the first
//!   evaluation that fails, so it would time one or two evaluations instead of four.
//!   Here a failed shooting evaluation still runs pass 3 (the accelerations) and the
//!   step carries on through all four stages; the step then reports the first error
//!   and leaves the state unchanged, as `Solver::step` does. The work per step is
//!   therefore the same whatever the numbers are.
//! - The dense derivatives come from `solver_core::dense::evaluate_dense`, which
//!   allocates its matrices on every call (it is a host-only reference).

use crate::on_large_stack;
use solver_core::dense::evaluate_dense;
use solver_core::dynamics::{self, accelerations, prepare};
use solver_core::solver::connection_and_air;
use solver_core::{Derivative, FlightPath, Model, Real, SolveError, Solver, State, Workspace};

/// Where [`ReferenceStepper`] takes the state derivative from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Derivatives {
    /// The product's passes (two-sweep recurrence): the same as `Solver::step`.
    TwoSweep,
    /// The paper's single-sweep shooting form (`dynamics::solve_tensions_shooting`).
    Shooting,
    /// The dense Kane reference (`dense::evaluate_dense`, O(N³), allocates).
    Dense,
}

/// A model and state stepped by RK4 with [`Derivatives`] of choice.
#[derive(Clone, Debug)]
pub struct ReferenceStepper<T: Real, const N: usize> {
    model: Model<T, N>,
    state: State<T, N>,
    derivatives: Derivatives,
    ws: Workspace<T, N>,
    stage: State<T, N>,
    slope: Derivative<T, N>,
    sum: Derivative<T, N>,
}

impl<T: Real, const N: usize> ReferenceStepper<T, N> {
    /// A stepper with the solver's model and current state, boxed (large capacities
    /// are large).
    pub fn from_solver(solver: &Solver<T, N>, derivatives: Derivatives) -> Box<Self> {
        on_large_stack(|| {
            Box::new(ReferenceStepper {
                model: *solver.model(),
                state: *solver.state(),
                derivatives,
                ws: Workspace::default(),
                stage: State::default(),
                slope: Derivative::default(),
                sum: Derivative::default(),
            })
        })
    }

    /// The current state.
    pub fn state(&self) -> &State<T, N> {
        &self.state
    }

    /// Replaces the state (the caller keeps it finite: it is a copy of an earlier one).
    pub fn set_state(&mut self, state: State<T, N>) {
        self.state = state;
    }

    /// One RK4 step of `dt` seconds along `path`; on error the state is unchanged and
    /// the first error is returned, after all four stages were evaluated anyway.
    pub fn step<P: FlightPath<T> + ?Sized>(&mut self, path: &P, dt: f64) -> Result<(), SolveError> {
        let n = self.model.segment_count();
        let t0 = self.state.time;
        let (t_half, t_end) = (t0 + 0.5 * dt, t0 + dt);
        // The stage factors as `Solver::step` forms them.
        let full = T::lit(dt);
        let half = full * T::lit(0.5);
        let sixth = full * T::lit(1.0 / 6.0);
        let two = T::lit(2.0);
        let mut first_error = None;
        let mut note = |result: Result<(), SolveError>| {
            if let Err(e) = result {
                first_error.get_or_insert(e);
            }
        };

        // k1 at y.
        self.stage = self.state;
        note(self.evaluate(path, t0));
        assign(&mut self.sum, &self.slope, n);
        // k2 at y + dt/2 k1.
        set_stage(&mut self.stage, &self.state, &self.slope, half, n);
        note(self.evaluate(path, t_half));
        add_scaled(&mut self.sum, &self.slope, two, n);
        // k3 at y + dt/2 k2.
        set_stage(&mut self.stage, &self.state, &self.slope, half, n);
        note(self.evaluate(path, t_half));
        add_scaled(&mut self.sum, &self.slope, two, n);
        // k4 at y + dt k3.
        set_stage(&mut self.stage, &self.state, &self.slope, full, n);
        note(self.evaluate(path, t_end));
        add_scaled(&mut self.sum, &self.slope, T::one(), n);
        // y + dt/6 (k1 + 2 k2 + 2 k3 + k4).
        set_stage(&mut self.stage, &self.state, &self.sum, sixth, n);
        self.stage.time = t_end;
        renormalise(&mut self.stage, n);
        if !self.stage.is_finite(n) {
            note(Err(SolveError::NonFinite { joint: n }));
        }
        match first_error {
            Some(e) => Err(e),
            None => {
                self.state = self.stage;
                Ok(())
            }
        }
    }

    /// The derivative at `self.stage` and time `t` into `self.slope`.
    fn evaluate<P: FlightPath<T> + ?Sized>(&mut self, path: &P, t: f64) -> Result<(), SolveError> {
        let (connection, air) = connection_and_air(&self.model, &path.state_at(t))?;
        match self.derivatives {
            Derivatives::TwoSweep => dynamics::evaluate(
                &self.model,
                &self.stage,
                &connection,
                &air,
                solver_core::TensionMethod::TwoSweep,
                &mut self.ws,
                &mut self.slope,
            ),
            Derivatives::Shooting => {
                prepare(&self.model, &self.stage, &connection, &air, &mut self.ws);
                let solved =
                    dynamics::solve_tensions_shooting(&self.model, &self.stage, &mut self.ws);
                // Pass 3 runs on failure too: the same work whatever the round-off did.
                accelerations(&self.model, &self.stage, &self.ws, &mut self.slope);
                solved
            }
            Derivatives::Dense => {
                let solution = evaluate_dense(&self.model, &self.stage, &connection, &air)?;
                self.slope = solution.derivative;
                Ok(())
            }
        }
    }
}

// The RK4 helpers of `solver-core`'s `State`/`Derivative` are crate-private; these
// are the same loops, in the same order (bit-identical results).

/// `stage = base + h d` over the first `count` segments.
fn set_stage<T: Real, const N: usize>(
    stage: &mut State<T, N>,
    base: &State<T, N>,
    d: &Derivative<T, N>,
    h: T,
    count: usize,
) {
    for i in 0..count {
        stage.directions[i] = base.directions[i] + d.directions[i] * h;
        stage.rates[i] = base.rates[i] + d.rates[i] * h;
    }
    for k in 0..4 {
        stage.decoy_attitude[k] = base.decoy_attitude[k] + d.decoy_attitude[k] * h;
    }
    stage.decoy_rate = base.decoy_rate + d.decoy_rate * h;
}

/// Unit directions, rates perpendicular to them, unit quaternion.
fn renormalise<T: Real, const N: usize>(state: &mut State<T, N>, count: usize) {
    for i in 0..count {
        let e = state.directions[i] / state.directions[i].norm();
        state.directions[i] = e;
        let w = state.rates[i];
        state.rates[i] = w - e * w.dot(&e);
    }
    let n = state
        .decoy_attitude
        .iter()
        .fold(T::zero(), |a, q| a + *q * *q)
        .sqrt();
    for q in &mut state.decoy_attitude {
        *q /= n;
    }
}

/// `sum = d`.
fn assign<T: Real, const N: usize>(sum: &mut Derivative<T, N>, d: &Derivative<T, N>, count: usize) {
    sum.directions[..count].copy_from_slice(&d.directions[..count]);
    sum.rates[..count].copy_from_slice(&d.rates[..count]);
    sum.decoy_attitude = d.decoy_attitude;
    sum.decoy_rate = d.decoy_rate;
}

/// `sum += w d`.
fn add_scaled<T: Real, const N: usize>(
    sum: &mut Derivative<T, N>,
    d: &Derivative<T, N>,
    w: T,
    count: usize,
) {
    for i in 0..count {
        sum.directions[i] += d.directions[i] * w;
        sum.rates[i] += d.rates[i] * w;
    }
    for k in 0..4 {
        sum.decoy_attitude[k] += d.decoy_attitude[k] * w;
    }
    sum.decoy_rate += d.decoy_rate * w;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{
        PENDULUM_DT, TOWED_DT, cruise_path, fixed_anchor, graded_layout, pendulum_solver,
        towed_solver,
    };

    /// Largest |a - b| over the used directions and rates.
    fn max_difference<const N: usize>(a: &State<f64, N>, b: &State<f64, N>, n: usize) -> f64 {
        (0..n)
            .flat_map(|i| {
                [
                    (a.directions[i] - b.directions[i]).amax(),
                    (a.rates[i] - b.rates[i]).amax(),
                ]
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn two_sweep_steps_are_the_solvers_bit_for_bit() {
        let mut solver = pendulum_solver::<f64, 8>(8);
        let mut stepper = ReferenceStepper::from_solver(&solver, Derivatives::TwoSweep);
        for _ in 0..20 {
            solver.step(&fixed_anchor(), PENDULUM_DT).unwrap();
            stepper.step(&fixed_anchor(), PENDULUM_DT).unwrap();
        }
        assert_eq!(solver.state(), stepper.state());

        let mut solver = towed_solver::<f32, 16>(graded_layout());
        let mut stepper = ReferenceStepper::from_solver(&solver, Derivatives::TwoSweep);
        for _ in 0..20 {
            solver.step(&cruise_path(), TOWED_DT).unwrap();
            stepper.step(&cruise_path(), TOWED_DT).unwrap();
        }
        assert_eq!(solver.state(), stepper.state());
    }

    #[test]
    fn dense_and_shooting_steps_agree_with_the_solver_where_they_are_usable() {
        for derivatives in [Derivatives::Dense, Derivatives::Shooting] {
            let mut solver = pendulum_solver::<f64, 8>(8);
            let mut stepper = ReferenceStepper::from_solver(&solver, derivatives);
            for _ in 0..20 {
                solver.step(&fixed_anchor(), PENDULUM_DT).unwrap();
                stepper.step(&fixed_anchor(), PENDULUM_DT).unwrap();
            }
            let difference = max_difference(solver.state(), stepper.state(), 8);
            assert!(difference < 1e-9, "{derivatives:?}: {difference}");

            let mut solver = towed_solver::<f64, 16>(graded_layout());
            let mut stepper = ReferenceStepper::from_solver(&solver, derivatives);
            for _ in 0..20 {
                solver.step(&cruise_path(), TOWED_DT).unwrap();
                stepper.step(&cruise_path(), TOWED_DT).unwrap();
            }
            let difference = max_difference(solver.state(), stepper.state(), 16);
            // The shooting form amplifies round-off about 3.7x per segment
            // (3.7^16 ~ 1e9 times f64's 1e-16 per derivative): 1.5e-6 measured.
            assert!(difference < 1e-5, "{derivatives:?}: {difference}");
        }
    }

    #[test]
    fn a_failed_shooting_step_leaves_the_state_unchanged() {
        // 300 rods: the shooting form's round-off (~3.7^300) makes the step fail.
        let solver = pendulum_solver::<f64, 300>(300);
        let mut stepper = ReferenceStepper::from_solver(&solver, Derivatives::Shooting);
        let before = *stepper.state();
        assert!(stepper.step(&fixed_anchor(), PENDULUM_DT).is_err());
        assert_eq!(*stepper.state(), before);
    }
}
