//! Instruction counts (gungraun 0.20, callgrind under valgrind) of one RK4 step and
//! of one tension solve: deterministic, unlike the wall-clock criterion benchmarks.
//!
//! Run with `cargo bench -p benches --bench instructions` (needs valgrind and
//! `gungraun-runner` 0.20.0 on `PATH`; `cargo xtask bench-report` installs the
//! runner). Setup (building, trimming and boxing the solver) happens in gungraun's
//! setup functions, outside the counted region; the counted region is exactly one
//! call.
//!
//! Benchmarks (`<group>::<function> <id>`, parsed by the report):
//!
//! - `steps::pendulum_f64 n{8,64,300,1024,4096}`: one `Solver::step(&fixed_anchor,
//!   1e-4)` on the compound pendulum with N rods (capacity N), from its initial state.
//! - `steps::towed_f32 graded16`, `steps::towed_f64 graded16`: one
//!   `Solver::step(&cruise, 1e-3)` on the reference towed system with 16 graded
//!   segments, trimmed at 9 km, Mach 0.8.
//! - `tension::{two_sweep,shooting,dense} n{16,64,300}`: one derivative evaluation
//!   of the pendulum (f64) in its initial state, as in the criterion group
//!   `tension_solve` (the O(N) forms through `Solver::derivative`, the dense one
//!   through `evaluate_dense`, which allocates its matrix).

// gungraun's macros generate public modules without documentation.
#![allow(missing_docs)]

use std::hint::black_box;

use benches::{
    GRADED_COUNT, PENDULUM_DT, TOWED_DT, cruise_path, fixed_anchor, graded_layout, pendulum_solver,
    towed_solver,
};
use gungraun::{library_benchmark, library_benchmark_group, main};
use solver_core::dense::{DenseSolution, evaluate_dense};
use solver_core::solver::connection_and_air;
use solver_core::{
    AirColumn, AircraftState, Derivative, PointKinematics, Real, SolveError, Solver, TensionMethod,
    Uniform, Vec3,
};

/// One benchmarked operation on a case prepared in setup.
///
/// The capacity `N` is a const generic of the solver, and gungraun's `consts`
/// parameter does not combine with a setup whose type depends on it, so every case
/// is boxed behind this trait: one virtual call (a few instructions) per count.
trait Operation {
    /// Runs the operation once (the counted region).
    fn run(&mut self);
}

/// A solver ready to step, its flight path and its time step.
struct StepCase<T: Real, const N: usize> {
    solver: Box<Solver<T, N>>,
    path: Uniform<T>,
    dt: f64,
}

impl<T: Real, const N: usize> Operation for StepCase<T, N> {
    /// One RK4 step.
    fn run(&mut self) {
        self.solver
            .step(black_box(&self.path), black_box(self.dt))
            .expect("RK4 step");
    }
}

/// The pendulum with N rods, hinged to a fixed anchor.
fn pendulum_case<const N: usize>() -> Box<dyn Operation> {
    Box::new(StepCase {
        solver: pendulum_solver::<f64, N>(N),
        path: fixed_anchor(),
        dt: PENDULUM_DT,
    })
}

/// The trimmed 16-segment graded towed system in cruise.
fn towed_case<T: Real>() -> Box<dyn Operation> {
    Box::new(StepCase {
        solver: towed_solver::<T, GRADED_COUNT>(graded_layout()),
        path: cruise_path::<T>(),
        dt: TOWED_DT,
    })
}

/// Runs `case` once; the case is returned so that dropping it is not counted.
fn run_once(mut case: Box<dyn Operation>) -> Box<dyn Operation> {
    case.run();
    case
}

#[library_benchmark]
#[bench::n8(setup = pendulum_case::<8>)]
#[bench::n64(setup = pendulum_case::<64>)]
#[bench::n300(setup = pendulum_case::<300>)]
#[bench::n1024(setup = pendulum_case::<1024>)]
#[bench::n4096(setup = pendulum_case::<4096>)]
fn pendulum_f64(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::graded16(setup = towed_case::<f32>)]
fn towed_f32(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::graded16(setup = towed_case::<f64>)]
fn towed_f64(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

library_benchmark_group!(
    name = steps,
    benchmarks = [pendulum_f64, towed_f32, towed_f64]
);

/// The pendulum (f64, N rods) in its initial state and the result of the last
/// evaluation (kept so that it is not optimised away, dropped outside the count).
struct TensionCase<const N: usize> {
    solver: Box<Solver<f64, N>>,
    anchor: Uniform<f64>,
    connection: PointKinematics<f64>,
    air: AirColumn<f64>,
    dense: bool,
    derivative: Option<Result<Derivative<f64, N>, SolveError>>,
    dense_solution: Option<Result<DenseSolution<f64, N>, SolveError>>,
}

impl<const N: usize> Operation for TensionCase<N> {
    /// One derivative evaluation: the O(N) forms through `Solver::derivative`
    /// (passes 1-3 and the copy of the derivative), the dense one through
    /// `evaluate_dense`. The shooting form's result is garbage or an error beyond a
    /// few tens of rods (round-off grows ~3.7^N); the work is the same.
    fn run(&mut self) {
        if self.dense {
            self.dense_solution = Some(evaluate_dense(
                black_box(self.solver.model()),
                black_box(self.solver.state()),
                &self.connection,
                &self.air,
            ));
        } else {
            self.derivative = Some(self.solver.derivative(black_box(&self.anchor)));
        }
    }
}

/// The pendulum with N rods in its initial state, solved by `method` (`None`: dense).
fn tension_case<const N: usize>(method: Option<TensionMethod>) -> Box<dyn Operation> {
    let mut solver = pendulum_solver::<f64, N>(N);
    if let Some(method) = method {
        solver.set_method(method);
    }
    let (connection, air) =
        connection_and_air(solver.model(), &AircraftState::fixed(Vec3::zeros()))
            .expect("valid fixed anchor");
    Box::new(TensionCase {
        solver,
        anchor: fixed_anchor(),
        connection,
        air,
        dense: method.is_none(),
        derivative: None,
        dense_solution: None,
    })
}

#[library_benchmark]
#[bench::n16(args = (Some(TensionMethod::TwoSweep)), setup = tension_case::<16>)]
#[bench::n64(args = (Some(TensionMethod::TwoSweep)), setup = tension_case::<64>)]
#[bench::n300(args = (Some(TensionMethod::TwoSweep)), setup = tension_case::<300>)]
fn two_sweep(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::n16(args = (Some(TensionMethod::Shooting)), setup = tension_case::<16>)]
#[bench::n64(args = (Some(TensionMethod::Shooting)), setup = tension_case::<64>)]
#[bench::n300(args = (Some(TensionMethod::Shooting)), setup = tension_case::<300>)]
fn shooting(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::n16(args = (None), setup = tension_case::<16>)]
#[bench::n64(args = (None), setup = tension_case::<64>)]
#[bench::n300(args = (None), setup = tension_case::<300>)]
fn dense(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

library_benchmark_group!(name = tension, benchmarks = [two_sweep, shooting, dense]);

main!(library_benchmark_groups = steps, tension);
