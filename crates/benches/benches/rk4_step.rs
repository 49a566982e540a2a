//! Criterion wall-clock benchmarks of one RK4 step and of one tension solve.
//!
//! Groups (names are stable, they are quoted in the docs):
//!
//! - `pendulum_rk4_step/{f64,f32}/{N}`: one `Solver::step(&fixed_anchor, 1e-4)` on the
//!   compound pendulum with N rods (capacity N), N = 16, 64, 300, 1024, 2048, 4096 (f64) and
//!   16, 64, 300 (f32).
//! - `towed_rk4_step/{f32,f64}/graded16`, `towed_rk4_step/f64/uniform300`: one
//!   `Solver::step(&cruise, 1e-3)` on the reference towed system trimmed at 9 km,
//!   Mach 0.8, in steady level flight.
//! - `tension_solve/{two_sweep,shooting,dense}/{N}`: one derivative evaluation of the
//!   pendulum in its initial state, N = 16, 64, 300.
//!
//! State handling in the step benchmarks: the solver steps continuously (no copy of
//! the state inside the timed region), and every [`RESTART_STEPS`] steps the initial
//! state is restored outside the timed region ([`Bencher::iter_custom`]). Every
//! sample therefore covers the same stretch of trajectory (the first 0.1 s of the
//! pendulum's fall, the first second of trimmed flight), the per-step work does not
//! depend on the state anyway (no data-dependent branches but the error checks), and
//! a long-running pendulum cannot drift into a regime where a step fails.

use std::hint::black_box;
use std::time::{Duration, Instant};

use benches::{
    GRADED_COUNT, PENDULUM_DT, TOWED_DT, cruise_path, fixed_anchor, graded_layout, pendulum_solver,
    towed_solver,
};
use criterion::{
    BenchmarkGroup, BenchmarkId, Criterion, SamplingMode, criterion_group, criterion_main,
    measurement::WallTime,
};
use solver_core::dense::evaluate_dense;
use solver_core::solver::connection_and_air;
use solver_core::{AircraftState, FlightPath, Real, SegmentLayout, Solver, TensionMethod, Vec3};

/// Steps between restorations of the initial state (outside the timed region).
const RESTART_STEPS: u64 = 1000;

/// Times `iters` consecutive steps of `solver` along `path`, restoring the initial
/// state (untimed) every [`RESTART_STEPS`] steps. Panics if a step fails.
fn time_steps<T: Real, const N: usize, P: FlightPath<T>>(
    solver: &mut Solver<T, N>,
    path: &P,
    dt: f64,
    iters: u64,
) -> Duration {
    let initial = *solver.state();
    let mut total = Duration::ZERO;
    let mut left = iters;
    while left > 0 {
        let chunk = left.min(RESTART_STEPS);
        solver.set_state(initial).expect("finite initial state");
        let start = Instant::now();
        for _ in 0..chunk {
            solver
                .step(black_box(path), black_box(dt))
                .expect("RK4 step");
        }
        total += start.elapsed();
        black_box(solver.state());
        left -= chunk;
    }
    solver.set_state(initial).expect("finite initial state");
    total
}

/// Registers `pendulum_rk4_step/{precision}/{count}` with capacity = count.
macro_rules! pendulum_step {
    ($group:expr, $t:ty, $precision:literal, $($n:literal),+) => {$({
        let mut solver = pendulum_solver::<$t, $n>($n);
        let anchor = fixed_anchor::<$t>();
        $group.bench_function(BenchmarkId::new($precision, $n), |b| {
            b.iter_custom(|iters| time_steps(&mut *solver, &anchor, PENDULUM_DT, iters))
        });
    })+};
}

/// `pendulum_rk4_step/{f64,f32}/{N}`.
fn pendulum_rk4_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("pendulum_rk4_step");
    pendulum_step!(group, f64, "f64", 16, 64, 300, 1024, 2048, 4096);
    pendulum_step!(group, f32, "f32", 16, 64, 300);
    group.finish();
}

/// Registers one towed-system step benchmark `towed_rk4_step/{precision}/{name}`.
fn towed_step<T: Real, const N: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    precision: &str,
    name: &str,
    layout: SegmentLayout<T>,
) {
    let mut solver = towed_solver::<T, N>(layout);
    let path = cruise_path::<T>();
    group.bench_function(BenchmarkId::new(precision, name), |b| {
        b.iter_custom(|iters| time_steps(&mut *solver, &path, TOWED_DT, iters))
    });
}

/// `towed_rk4_step/{f32,f64}/graded16` and `towed_rk4_step/f64/uniform300`.
fn towed_rk4_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("towed_rk4_step");
    towed_step::<f32, GRADED_COUNT>(&mut group, "f32", "graded16", graded_layout());
    towed_step::<f64, GRADED_COUNT>(&mut group, "f64", "graded16", graded_layout());
    towed_step::<f64, 300>(
        &mut group,
        "f64",
        "uniform300",
        SegmentLayout::Uniform { count: 300 },
    );
    group.finish();
}

/// Registers `tension_solve/{two_sweep,shooting,dense}/{N}` (f64, capacity N) on the
/// pendulum in its initial state. The O(N) forms go through `Solver::derivative`
/// (which includes passes 1 and 3 and a copy of the derivative); the shooting form's
/// result is garbage or an error beyond a few tens of rods (round-off grows ~3.7^N),
/// which does not change the work done, so its result is only black-boxed.
macro_rules! tension_solve {
    ($group:expr, $($n:literal),+) => {$({
        let anchor = fixed_anchor::<f64>();
        let mut solver = pendulum_solver::<f64, $n>($n);
        for (name, method) in [("two_sweep", TensionMethod::TwoSweep), ("shooting", TensionMethod::Shooting)] {
            solver.set_method(method);
            $group.bench_function(BenchmarkId::new(name, $n), |b| b.iter(|| black_box(solver.derivative(black_box(&anchor)))));
        }
        let (connection, air) =
            connection_and_air(solver.model(), &AircraftState::fixed(Vec3::zeros())).expect("valid fixed anchor");
        let (model, state) = (solver.model(), solver.state());
        $group.bench_function(BenchmarkId::new("dense", $n), |b| {
            b.iter(|| black_box(evaluate_dense(black_box(model), black_box(state), &connection, &air)))
        });
    })+};
}

/// `tension_solve/{two_sweep,shooting,dense}/{16,64,300}`.
fn tension_solve(c: &mut Criterion) {
    let mut group = c.benchmark_group("tension_solve");
    // The dense O(N^3) solve takes milliseconds at N = 300: flat sampling keeps the
    // run within the measurement time; it changes nothing for the fast cases.
    group.sampling_mode(SamplingMode::Flat);
    tension_solve!(group, 16, 64, 300);
    group.finish();
}

criterion_group! {
    name = benches;
    // Text reports only (TOOLCHAIN.md: no plotters in this crate).
    config = Criterion::default().without_plots();
    targets = pendulum_rk4_step, towed_rk4_step, tension_solve
}
criterion_main!(benches);
