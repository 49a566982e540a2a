//! Criterion wall-clock benchmarks of one RK4 step, of one tension solve and of the
//! passes of one derivative evaluation.
//!
//! Groups (names are stable, they are quoted in the docs and read by the report; the
//! names come from `benches::names`, which the report uses too):
//!
//! - `pendulum_rk4_step/{f64,f32}/{N}`: one `Solver::step(&fixed_anchor, 1e-4)` on the
//!   compound pendulum with N rods (capacity N), N = 16, 64, 300, 1024, 2048, 4096.
//! - `pendulum_rk4_step/shooting/{N}` (same N): the same RK4 step with the shooting
//!   form's derivatives (`benches::stepper`, which runs all four stages even when the
//!   diverging shooting form fails: beyond a few tens of rods it does, the work is
//!   the same).
//! - `pendulum_rk4_step/dense/{16,64,300}`: the same RK4 step with the dense Kane
//!   derivatives (`solver_core::dense::evaluate_dense`, O(N³)).
//! - `towed_rk4_step/{f32,f64}/graded16`: one `Solver::step(&cruise, 1e-3)` on the
//!   reference towed system with 16 graded segments, trimmed at 9 km, Mach 0.8.
//! - `towed_rk4_step/{f64,f32,shooting}/uniform{N}` (N as for the pendulum) and
//!   `towed_rk4_step/dense/uniform{16,64,300}`: the towed scaling series, N segments
//!   of equal length, trimmed, dt = 1e-5 s.
//! - `tension_solve/{two_sweep,shooting,dense}/{N}`: one derivative evaluation of the
//!   pendulum in its initial state, N = 16, 64, 300.
//! - `eval_breakdown/{f64,f32}_{graded16,uniform300}/{pass}`: one pass of one
//!   derivative evaluation of the trimmed towed system (`benches::passes`), pass =
//!   `evaluate` (the whole), `prepare`, `cable_drag`, `decoy_aero`, `solve_tensions`,
//!   `accelerations`.
//!
//! State handling in the step benchmarks: the solver steps continuously (no copy of
//! the state inside the timed region), and every [`RESTART_STEPS`] steps the initial
//! state is restored outside the timed region ([`Bencher::iter_custom`]); more often
//! where fewer consecutive steps stay finite (found in setup, printed as a note: the
//! f32 pendulum and towed system with thousands of segments). Every
//! sample therefore covers the same stretch of trajectory (the first 0.1 s of the
//! pendulum's fall, the first second of trimmed flight), the per-step work does not
//! depend on the state anyway (no data-dependent branches but the error checks), and
//! a long-running pendulum cannot drift into a regime where a step fails.

use std::hint::black_box;
use std::time::{Duration, Instant};

use benches::names::{self, System, Variant};
use benches::passes::{Pass, Passes};
use benches::stepper::{Derivatives, ReferenceStepper};
use benches::{
    GRADED_COUNT, PENDULUM_DT, RESTART_STEPS, TOWED_DT, TOWED_SCALING_DT, cruise_path,
    fixed_anchor, graded_layout, pendulum_solver, towed_solver, towed_uniform_solver,
};
use criterion::{
    BenchmarkGroup, BenchmarkId, Criterion, SamplingMode, criterion_group, criterion_main,
    measurement::WallTime,
};
use solver_core::dense::evaluate_dense;
use solver_core::motion::connection_and_air;
use solver_core::{
    AircraftState, Real, SegmentLayout, SolveError, Solver, State, TensionMethod, Uniform, Vec3,
};

/// Something that takes RK4 steps from a state that can be saved and restored.
trait Stepper<T: Real, const N: usize> {
    /// The current state.
    fn saved(&self) -> State<T, N>;
    /// Puts a saved state back.
    fn restore(&mut self, state: State<T, N>);
    /// One RK4 step.
    fn step_once(&mut self, path: &Uniform<T>, dt: f64) -> Result<(), SolveError>;
}

impl<T: Real, const N: usize> Stepper<T, N> for Solver<T, N> {
    fn saved(&self) -> State<T, N> {
        *self.state()
    }
    fn restore(&mut self, state: State<T, N>) {
        self.set_state(state).expect("finite initial state");
    }
    fn step_once(&mut self, path: &Uniform<T>, dt: f64) -> Result<(), SolveError> {
        self.step(path, dt)
    }
}

impl<T: Real, const N: usize> Stepper<T, N> for ReferenceStepper<T, N> {
    fn saved(&self) -> State<T, N> {
        *self.state()
    }
    fn restore(&mut self, state: State<T, N>) {
        self.set_state(state);
    }
    fn step_once(&mut self, path: &Uniform<T>, dt: f64) -> Result<(), SolveError> {
        self.step(path, dt)
    }
}

/// How many consecutive steps (at most [`RESTART_STEPS`]) succeed from the current
/// state, which is restored afterwards; at least 1 (the first step must succeed).
/// In f32 the pendulum with 4096 rods and the towed system with thousands of uniform
/// segments do not stay finite for long; their benchmarks restart that much more often.
fn finite_steps<T: Real, const N: usize, S: Stepper<T, N> + ?Sized>(
    stepper: &mut S,
    path: &Uniform<T>,
    dt: f64,
    name: &str,
) -> u64 {
    let initial = stepper.saved();
    let mut steps = 0;
    while steps < RESTART_STEPS && stepper.step_once(path, dt).is_ok() {
        steps += 1;
    }
    stepper.restore(initial);
    assert!(steps > 0, "{name}: the first RK4 step fails");
    if steps < RESTART_STEPS {
        eprintln!("note: {name}: only {steps} steps stay finite; restarting every {steps} steps");
    }
    steps
}

/// Times `iters` consecutive steps of `stepper` along `path`, restoring the initial
/// state (untimed) every `restart` steps. A failing step panics, unless `may_fail`
/// (the shooting form, whose failed steps do the full work anyway).
fn time_steps<T: Real, const N: usize, S: Stepper<T, N> + ?Sized>(
    stepper: &mut S,
    path: &Uniform<T>,
    dt: f64,
    (restart, may_fail): (u64, bool),
    iters: u64,
) -> Duration {
    let initial = stepper.saved();
    let mut total = Duration::ZERO;
    let mut left = iters;
    while left > 0 {
        let chunk = left.min(restart);
        stepper.restore(initial);
        let start = Instant::now();
        for _ in 0..chunk {
            let result = stepper.step_once(black_box(path), black_box(dt));
            if !may_fail {
                result.expect("RK4 step");
            }
        }
        total += start.elapsed();
        black_box(stepper.saved().time);
        left -= chunk;
    }
    stepper.restore(initial);
    total
}

/// Registers `{group}/{f64,f32,shooting}/{size}` for the O(N) steps of `make(N)`
/// and `{group}/dense/{size}` for the dense ones, capacity N, `size` the system's
/// name of N (`names::System::wall_size`).
macro_rules! step_series {
    ($group:expr, $system:expr, $make:ident, $path:ident, $dt:expr; o_n: $($n:literal),+; dense: $($d:literal),+) => {
        $({
            let size = $system.wall_size($n);
            let mut solver = $make::<f64, $n>($n);
            let path = $path::<f64>();
            let restart = finite_steps(&mut *solver, &path, $dt, &format!("f64/{size}"));
            $group.bench_function(BenchmarkId::new(Variant::F64.name(), &size), |b| {
                b.iter_custom(|iters| time_steps(&mut *solver, &path, $dt, (restart, false), iters))
            });
            let mut shooting = ReferenceStepper::from_solver(&solver, Derivatives::Shooting);
            $group.bench_function(BenchmarkId::new(Variant::Shooting.name(), &size), |b| {
                b.iter_custom(|iters| time_steps(&mut *shooting, &path, $dt, (RESTART_STEPS, true), iters))
            });
            drop((solver, shooting));
            let mut solver = $make::<f32, $n>($n);
            let path = $path::<f32>();
            let restart = finite_steps(&mut *solver, &path, $dt, &format!("f32/{size}"));
            $group.bench_function(BenchmarkId::new(Variant::F32.name(), &size), |b| {
                b.iter_custom(|iters| time_steps(&mut *solver, &path, $dt, (restart, false), iters))
            });
        })+
        // The dense step takes milliseconds at N = 300: flat sampling and few samples.
        $group.sampling_mode(SamplingMode::Flat);
        $group.sample_size(10);
        $({
            let solver = $make::<f64, $d>($d);
            let path = $path::<f64>();
            let mut dense = ReferenceStepper::from_solver(&solver, Derivatives::Dense);
            $group.bench_function(BenchmarkId::new(Variant::Dense.name(), $system.wall_size($d)), |b| {
                b.iter_custom(|iters| time_steps(&mut *dense, &path, $dt, (RESTART_STEPS, false), iters))
            });
        })+
    };
}

/// `pendulum_rk4_step/{f64,f32,shooting}/{N}` and `pendulum_rk4_step/dense/{N}`.
fn pendulum_rk4_step(c: &mut Criterion) {
    let mut group = c.benchmark_group(names::PENDULUM_RK4_STEP);
    step_series!(group, System::Pendulum, pendulum_solver, fixed_anchor, PENDULUM_DT;
        o_n: 16, 64, 300, 1024, 2048, 4096; dense: 16, 64, 300);
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
        b.iter_custom(|iters| {
            time_steps(&mut *solver, &path, TOWED_DT, (RESTART_STEPS, false), iters)
        })
    });
}

/// `towed_rk4_step/{f32,f64}/graded16` and the uniform scaling series
/// `towed_rk4_step/{f64,f32,shooting,dense}/uniform{N}`.
fn towed_rk4_step(c: &mut Criterion) {
    let mut group = c.benchmark_group(names::TOWED_RK4_STEP);
    let [f32_name, f64_name] = names::GRADED_PRECISIONS;
    towed_step::<f32, GRADED_COUNT>(&mut group, f32_name, names::GRADED16, graded_layout());
    towed_step::<f64, GRADED_COUNT>(&mut group, f64_name, names::GRADED16, graded_layout());
    step_series!(group, System::Towed, towed_uniform_solver, cruise_path, TOWED_SCALING_DT;
        o_n: 16, 64, 300, 1024, 2048, 4096; dense: 16, 64, 300);
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
        let [two_sweep, shooting, dense] = names::TENSION_METHODS;
        for (name, method) in [(two_sweep, TensionMethod::TwoSweep), (shooting, TensionMethod::Shooting)] {
            solver.set_method(method);
            $group.bench_function(BenchmarkId::new(name, $n), |b| b.iter(|| black_box(solver.derivative(black_box(&anchor)))));
        }
        let (connection, air) =
            connection_and_air(solver.model(), &AircraftState::fixed(Vec3::zeros())).expect("valid fixed anchor");
        let (model, state) = (solver.model(), solver.state());
        $group.bench_function(BenchmarkId::new(dense, $n), |b| {
            b.iter(|| black_box(evaluate_dense(black_box(model), black_box(state), &connection, &air)))
        });
    })+};
}

/// `tension_solve/{two_sweep,shooting,dense}/{16,64,300}`.
fn tension_solve(c: &mut Criterion) {
    let mut group = c.benchmark_group(names::TENSION_SOLVE);
    // The dense O(N^3) solve takes milliseconds at N = 300: flat sampling keeps the
    // run within the measurement time; it changes nothing for the fast cases.
    group.sampling_mode(SamplingMode::Flat);
    tension_solve!(group, 16, 64, 300);
    group.finish();
}

/// Registers `eval_breakdown/{name}/{pass}` for every pass on the trimmed `solver`.
fn breakdown<T: Real, const N: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    solver: &Solver<T, N>,
) {
    let mut passes = Passes::new(solver, &cruise_path::<T>());
    for pass in Pass::ALL {
        group.bench_function(BenchmarkId::new(name, pass.name()), |b| {
            b.iter(|| passes.run(black_box(pass)))
        });
    }
}

/// `eval_breakdown/{f64,f32}_{graded16,uniform300}/{pass}`.
fn eval_breakdown(c: &mut Criterion) {
    let mut group = c.benchmark_group(names::EVAL_BREAKDOWN);
    let [f64_graded16, f32_graded16, f64_uniform300, f32_uniform300] = names::BREAKDOWN_CASES;
    breakdown(
        &mut group,
        f64_graded16,
        &*towed_solver::<f64, GRADED_COUNT>(graded_layout()),
    );
    breakdown(
        &mut group,
        f32_graded16,
        &*towed_solver::<f32, GRADED_COUNT>(graded_layout()),
    );
    breakdown(
        &mut group,
        f64_uniform300,
        &*towed_uniform_solver::<f64, 300>(300),
    );
    breakdown(
        &mut group,
        f32_uniform300,
        &*towed_uniform_solver::<f32, 300>(300),
    );
    group.finish();
}

criterion_group! {
    name = benches;
    // Text reports only: criterion's own plots panic beside plotters' ab_glyph
    // feature in the same build (docs/toolchain.md §8).
    config = Criterion::default().without_plots();
    targets = pendulum_rk4_step, towed_rk4_step, tension_solve, eval_breakdown
}
criterion_main!(benches);
