//! Instruction counts (gungraun 0.20, callgrind under valgrind) of one RK4 step and
//! of one tension solve: deterministic, unlike the wall-clock criterion benchmarks.
//!
//! Run with `cargo bench -p benches --bench instructions` (needs valgrind and
//! `gungraun-runner` 0.20.0 on `PATH`; `cargo xtask bench-report` installs the
//! runner). Setup (building, trimming and boxing the solver) happens in gungraun's
//! setup functions, outside the counted region; the counted region is exactly one
//! call.
//!
//! Benchmarks (`<group>::<function> <id>`, read by the report). The names are Rust
//! identifiers, which cannot come from constants: a test in `benches::names` reads
//! this file and checks that it defines exactly the keys the report expects.
//!
//! - `steps::pendulum_f64 n{8,64,300,1024,4096}`: one `Solver::step(&fixed_anchor,
//!   1e-4)` on the compound pendulum with N rods (capacity N), from its initial state.
//! - `steps::pendulum_f32 n{8,64,300,1024,4096}`: the same in f32.
//! - `steps::pendulum_shooting n{8,64,300,1024,4096}`, `steps::pendulum_dense
//!   n{8,64,300}`: the same RK4 step (f64) with the shooting form's and the dense
//!   Kane derivatives (`benches::stepper`; the shooting step runs all four stages
//!   even where the diverging form fails, the dense one allocates inside the count).
//! - `steps::towed_f32 graded16`, `steps::towed_f64 graded16`: one
//!   `Solver::step(&cruise, 1e-3)` on the reference towed system with 16 graded
//!   segments, trimmed at 9 km, Mach 0.8.
//! - `steps::towed_{f64,f32,shooting} uniform{8,64,300,1024,4096}`,
//!   `steps::towed_dense uniform{8,64,300}`: the towed scaling series (N uniform
//!   segments, trimmed, dt = 1e-5 s), as for the pendulum.
//! - `tension::{two_sweep,shooting,dense} n{16,64,300}`: one derivative evaluation
//!   of the pendulum (f64) in its initial state, as in the criterion group
//!   `tension_solve` (the O(N) forms through `Solver::derivative`, the dense one
//!   through `evaluate_dense`, which allocates its matrix).
//! - `breakdown::{f64,f32}_{graded16,uniform300} {pass}`: one pass of one derivative
//!   evaluation of the trimmed towed system (`benches::passes`): `evaluate`,
//!   `prepare`, `cable_drag`, `decoy_aero`, `solve_tensions`, `accelerations`.

// gungraun's macros generate public modules without documentation.
#![allow(missing_docs)]

use std::hint::black_box;

use benches::passes::{Pass, Passes};
use benches::stepper::{Derivatives, ReferenceStepper};
use benches::{
    GRADED_COUNT, PENDULUM_DT, TOWED_DT, TOWED_SCALING_DT, cruise_path, fixed_anchor,
    graded_layout, pendulum_solver, towed_solver, towed_uniform_solver,
};
use gungraun::{library_benchmark, library_benchmark_group, main};
use solver_core::dense::{DenseSolution, evaluate_dense};
use solver_core::motion::connection_and_air;
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

/// A reference stepper (shooting or dense derivatives), its flight path and time step.
struct ReferenceCase<T: Real, const N: usize> {
    stepper: Box<ReferenceStepper<T, N>>,
    path: Uniform<T>,
    dt: f64,
}

impl<T: Real, const N: usize> Operation for ReferenceCase<T, N> {
    /// One RK4 step; the shooting form's failure (beyond a few tens of segments) is
    /// ignored, its step does the full work anyway.
    fn run(&mut self) {
        let _ = black_box(self.stepper.step(black_box(&self.path), black_box(self.dt)));
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

/// The pendulum with N rods in f32.
fn pendulum_f32_case<const N: usize>() -> Box<dyn Operation> {
    Box::new(StepCase {
        solver: pendulum_solver::<f32, N>(N),
        path: fixed_anchor(),
        dt: PENDULUM_DT,
    })
}

/// The pendulum with N rods (f64) stepped with the reference `derivatives`.
fn pendulum_reference_case<const N: usize>(derivatives: Derivatives) -> Box<dyn Operation> {
    Box::new(ReferenceCase {
        stepper: ReferenceStepper::from_solver(&pendulum_solver::<f64, N>(N), derivatives),
        path: fixed_anchor(),
        dt: PENDULUM_DT,
    })
}

/// The trimmed towed system with N uniform segments in cruise.
fn towed_uniform_case<T: Real, const N: usize>() -> Box<dyn Operation> {
    Box::new(StepCase {
        solver: towed_uniform_solver::<T, N>(N),
        path: cruise_path::<T>(),
        dt: TOWED_SCALING_DT,
    })
}

/// The trimmed towed system with N uniform segments (f64), reference `derivatives`.
fn towed_reference_case<const N: usize>(derivatives: Derivatives) -> Box<dyn Operation> {
    Box::new(ReferenceCase {
        stepper: ReferenceStepper::from_solver(&towed_uniform_solver::<f64, N>(N), derivatives),
        path: cruise_path::<f64>(),
        dt: TOWED_SCALING_DT,
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
#[bench::n8(setup = pendulum_f32_case::<8>)]
#[bench::n64(setup = pendulum_f32_case::<64>)]
#[bench::n300(setup = pendulum_f32_case::<300>)]
#[bench::n1024(setup = pendulum_f32_case::<1024>)]
#[bench::n4096(setup = pendulum_f32_case::<4096>)]
fn pendulum_f32(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::n8(args = (Derivatives::Shooting), setup = pendulum_reference_case::<8>)]
#[bench::n64(args = (Derivatives::Shooting), setup = pendulum_reference_case::<64>)]
#[bench::n300(args = (Derivatives::Shooting), setup = pendulum_reference_case::<300>)]
#[bench::n1024(args = (Derivatives::Shooting), setup = pendulum_reference_case::<1024>)]
#[bench::n4096(args = (Derivatives::Shooting), setup = pendulum_reference_case::<4096>)]
fn pendulum_shooting(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::n8(args = (Derivatives::Dense), setup = pendulum_reference_case::<8>)]
#[bench::n64(args = (Derivatives::Dense), setup = pendulum_reference_case::<64>)]
#[bench::n300(args = (Derivatives::Dense), setup = pendulum_reference_case::<300>)]
fn pendulum_dense(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::graded16(setup = towed_case::<f32>)]
#[bench::uniform8(setup = towed_uniform_case::<f32, 8>)]
#[bench::uniform64(setup = towed_uniform_case::<f32, 64>)]
#[bench::uniform300(setup = towed_uniform_case::<f32, 300>)]
#[bench::uniform1024(setup = towed_uniform_case::<f32, 1024>)]
#[bench::uniform4096(setup = towed_uniform_case::<f32, 4096>)]
fn towed_f32(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::graded16(setup = towed_case::<f64>)]
#[bench::uniform8(setup = towed_uniform_case::<f64, 8>)]
#[bench::uniform64(setup = towed_uniform_case::<f64, 64>)]
#[bench::uniform300(setup = towed_uniform_case::<f64, 300>)]
#[bench::uniform1024(setup = towed_uniform_case::<f64, 1024>)]
#[bench::uniform4096(setup = towed_uniform_case::<f64, 4096>)]
fn towed_f64(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::uniform8(args = (Derivatives::Shooting), setup = towed_reference_case::<8>)]
#[bench::uniform64(args = (Derivatives::Shooting), setup = towed_reference_case::<64>)]
#[bench::uniform300(args = (Derivatives::Shooting), setup = towed_reference_case::<300>)]
#[bench::uniform1024(args = (Derivatives::Shooting), setup = towed_reference_case::<1024>)]
#[bench::uniform4096(args = (Derivatives::Shooting), setup = towed_reference_case::<4096>)]
fn towed_shooting(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::uniform8(args = (Derivatives::Dense), setup = towed_reference_case::<8>)]
#[bench::uniform64(args = (Derivatives::Dense), setup = towed_reference_case::<64>)]
#[bench::uniform300(args = (Derivatives::Dense), setup = towed_reference_case::<300>)]
fn towed_dense(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

library_benchmark_group!(
    name = steps,
    benchmarks = [
        pendulum_f64,
        pendulum_f32,
        pendulum_shooting,
        pendulum_dense,
        towed_f32,
        towed_f64,
        towed_shooting,
        towed_dense
    ]
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

/// One pass of one evaluation of a trimmed towed system, prepared in setup.
struct PassCase<T: Real, const N: usize> {
    passes: Box<Passes<T, N>>,
    pass: Pass,
}

impl<T: Real, const N: usize> Operation for PassCase<T, N> {
    /// The pass, once.
    fn run(&mut self) {
        self.passes.run(black_box(self.pass));
    }
}

/// `pass` on the 16-segment graded towed system (precision T).
fn graded_pass_case<T: Real>(pass: Pass) -> Box<dyn Operation> {
    let solver = towed_solver::<T, GRADED_COUNT>(graded_layout());
    Box::new(PassCase {
        passes: Passes::new(&*solver, &cruise_path::<T>()),
        pass,
    })
}

/// `pass` on the 300-segment uniform towed system (precision T).
fn uniform300_pass_case<T: Real>(pass: Pass) -> Box<dyn Operation> {
    let solver = towed_uniform_solver::<T, 300>(300);
    Box::new(PassCase {
        passes: Passes::new(&*solver, &cruise_path::<T>()),
        pass,
    })
}

#[library_benchmark]
#[bench::evaluate(args = (Pass::Evaluate), setup = graded_pass_case::<f64>)]
#[bench::prepare(args = (Pass::Prepare), setup = graded_pass_case::<f64>)]
#[bench::cable_drag(args = (Pass::CableDrag), setup = graded_pass_case::<f64>)]
#[bench::decoy_aero(args = (Pass::DecoyAero), setup = graded_pass_case::<f64>)]
#[bench::solve_tensions(args = (Pass::SolveTensions), setup = graded_pass_case::<f64>)]
#[bench::accelerations(args = (Pass::Accelerations), setup = graded_pass_case::<f64>)]
fn f64_graded16(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::evaluate(args = (Pass::Evaluate), setup = graded_pass_case::<f32>)]
#[bench::prepare(args = (Pass::Prepare), setup = graded_pass_case::<f32>)]
#[bench::cable_drag(args = (Pass::CableDrag), setup = graded_pass_case::<f32>)]
#[bench::decoy_aero(args = (Pass::DecoyAero), setup = graded_pass_case::<f32>)]
#[bench::solve_tensions(args = (Pass::SolveTensions), setup = graded_pass_case::<f32>)]
#[bench::accelerations(args = (Pass::Accelerations), setup = graded_pass_case::<f32>)]
fn f32_graded16(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::evaluate(args = (Pass::Evaluate), setup = uniform300_pass_case::<f64>)]
#[bench::prepare(args = (Pass::Prepare), setup = uniform300_pass_case::<f64>)]
#[bench::cable_drag(args = (Pass::CableDrag), setup = uniform300_pass_case::<f64>)]
#[bench::decoy_aero(args = (Pass::DecoyAero), setup = uniform300_pass_case::<f64>)]
#[bench::solve_tensions(args = (Pass::SolveTensions), setup = uniform300_pass_case::<f64>)]
#[bench::accelerations(args = (Pass::Accelerations), setup = uniform300_pass_case::<f64>)]
fn f64_uniform300(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

#[library_benchmark]
#[bench::evaluate(args = (Pass::Evaluate), setup = uniform300_pass_case::<f32>)]
#[bench::prepare(args = (Pass::Prepare), setup = uniform300_pass_case::<f32>)]
#[bench::cable_drag(args = (Pass::CableDrag), setup = uniform300_pass_case::<f32>)]
#[bench::decoy_aero(args = (Pass::DecoyAero), setup = uniform300_pass_case::<f32>)]
#[bench::solve_tensions(args = (Pass::SolveTensions), setup = uniform300_pass_case::<f32>)]
#[bench::accelerations(args = (Pass::Accelerations), setup = uniform300_pass_case::<f32>)]
fn f32_uniform300(case: Box<dyn Operation>) -> Box<dyn Operation> {
    run_once(case)
}

library_benchmark_group!(
    name = breakdown,
    benchmarks = [f64_graded16, f32_graded16, f64_uniform300, f32_uniform300]
);

main!(library_benchmark_groups = steps, tension, breakdown);
