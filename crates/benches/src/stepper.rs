//! RK4 steps with the reference derivatives (shooting form, dense Kane solution):
//! `solver_core::rk4::Rk4`, the solver's own RK4, with a [`DerivativeSource`] that
//! evaluates the derivative of choice.
//!
//! [`ReferenceStepper::step`] is therefore the scheme of `Solver::step`, operation
//! for operation: stages at y, y + dt/2 k1, y + dt/2 k2 and y + dt k3 (flight path
//! sampled at t, t + dt/2 and t + dt), then y + dt/6 (k1 + 2 k2 + 2 k3 + k4),
//! renormalised, the state and stage buffers swapped. With [`Derivatives::TwoSweep`]
//! it gives bit-identical states to `Solver::step` (a test in this file checks it),
//! so the cost of the other two variants differs from the solver's only by their
//! derivative evaluation.
//!
//! Differences from `Solver::step`, all for the benchmarks:
//!
//! - The flight path is sampled without the solver's air column cache and the first
//!   stage never reuses an earlier evaluation (`connection_and_air` per distinct
//!   time: three times per step).
//! - The shooting form's round-off grows about 3.7x per segment: beyond a few tens of
//!   segments its tensions are garbage or not finite. `Solver::step` stops at the first
//!   evaluation that fails, so it would time one or two evaluations instead of four.
//!   Here a failed evaluation is recorded, a failed shooting evaluation still runs
//!   pass 3 (the accelerations), and the step carries on through all four stages; the
//!   step then reports the first error and leaves the state unchanged, as
//!   `Solver::step` does. The work per step is therefore the same whatever the
//!   numbers are.
//! - The dense derivatives come from `solver_core::dense::evaluate_dense`, which
//!   allocates its matrices on every call (it is a host-only reference).

use crate::on_large_stack;
use solver_core::dense::evaluate_dense;
use solver_core::dynamics::{self, accelerations, prepare};
use solver_core::motion::connection_and_air;
use solver_core::{
    AirColumn, Derivative, DerivativeSource, FlightPath, Model, PointKinematics, Real, Rk4,
    SolveError, Solver, State, Workspace,
};

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
    derivatives: Derivatives,
    ws: Workspace<T, N>,
    rk4: Rk4<T, N>,
}

impl<T: Real, const N: usize> ReferenceStepper<T, N> {
    /// A stepper with the solver's model and current state, boxed (large capacities
    /// are large).
    pub fn from_solver(solver: &Solver<T, N>, derivatives: Derivatives) -> Box<Self> {
        on_large_stack(|| {
            Box::new(ReferenceStepper {
                model: *solver.model(),
                derivatives,
                ws: Workspace::default(),
                rk4: Rk4::new(*solver.state()),
            })
        })
    }

    /// The current state.
    pub fn state(&self) -> &State<T, N> {
        self.rk4.state()
    }

    /// Replaces the state (the caller keeps it finite: it is a copy of an earlier one).
    pub fn set_state(&mut self, state: State<T, N>) {
        self.rk4.set_state(state);
    }

    /// One RK4 step of `dt` seconds along `path`; on error the state is unchanged and
    /// the first error is returned, after all four stages were evaluated anyway.
    pub fn step<P: FlightPath<T> + ?Sized>(&mut self, path: &P, dt: f64) -> Result<(), SolveError> {
        let mut source = Reference {
            model: &self.model,
            path,
            derivatives: self.derivatives,
            ws: &mut self.ws,
            first_error: None,
        };
        self.rk4.step(&mut source, dt, |_, _, _| {})
    }
}

/// The derivative of [`Derivatives`] along `path`, recording the first failed
/// evaluation instead of stopping at it (see the module documentation).
struct Reference<'a, T: Real, const N: usize, P: ?Sized> {
    model: &'a Model<T, N>,
    path: &'a P,
    derivatives: Derivatives,
    ws: &'a mut Workspace<T, N>,
    first_error: Option<SolveError>,
}

impl<T: Real, const N: usize, P: FlightPath<T> + ?Sized> DerivativeSource<T, N>
    for Reference<'_, T, N, P>
{
    type Inputs = (PointKinematics<T>, AirColumn<T>);

    fn segment_count(&self) -> usize {
        self.model.segment_count()
    }

    fn inputs_at(&mut self, time: f64) -> Result<Self::Inputs, SolveError> {
        Ok(connection_and_air(self.model, &self.path.state_at(time))?)
    }

    /// Always `Ok`: a failure is kept for [`DerivativeSource::finish`].
    fn evaluate(
        &mut self,
        state: &State<T, N>,
        (connection, air): &Self::Inputs,
        out: &mut Derivative<T, N>,
    ) -> Result<(), SolveError> {
        let result = match self.derivatives {
            Derivatives::TwoSweep => dynamics::evaluate(
                self.model,
                state,
                connection,
                air,
                solver_core::TensionMethod::TwoSweep,
                self.ws,
                out,
            ),
            Derivatives::Shooting => {
                prepare(self.model, state, connection, air, self.ws);
                let solved = dynamics::solve_tensions_shooting(self.model, state, self.ws);
                // Pass 3 runs on failure too: the same work whatever the round-off did.
                accelerations(self.model, state, self.ws, out);
                solved
            }
            Derivatives::Dense => evaluate_dense(self.model, state, connection, air)
                .map(|solution| *out = solution.derivative),
        };
        if let Err(e) = result {
            self.first_error.get_or_insert(e);
        }
        Ok(())
    }

    /// The first failed evaluation rejects the step.
    fn finish(&mut self) -> Result<(), SolveError> {
        self.first_error.map_or(Ok(()), Err)
    }
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
