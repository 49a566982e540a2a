//! Criterion-free timing of RK4 steps: a quick sanity check for runs without the
//! benchmark harness.
//!
//! Usage: `cargo run --release -p benches --bin step_time [-- STEPS]` (default
//! 20000 steps per case). Prints the mean wall-clock time per step of the 300-rod
//! pendulum (f64, dt = 1e-4) and of the 16-segment graded towed model at 9 km,
//! Mach 0.8 (f32 and f64, dt = 1e-3), after a short untimed warm-up.

use std::hint::black_box;
use std::time::Instant;

use benches::{
    GRADED_COUNT, PENDULUM_DT, TOWED_DT, cruise_path, fixed_anchor, graded_layout, pendulum_solver,
    towed_solver,
};
use solver_core::{FlightPath, Real, Solver};

/// Default number of timed steps per case.
const DEFAULT_STEPS: u64 = 20_000;

/// Runs `steps` RK4 steps (after `steps / 10` untimed) and returns µs per step.
fn micros_per_step<T: Real, const N: usize, P: FlightPath<T>>(
    solver: &mut Solver<T, N>,
    path: &P,
    dt: f64,
    steps: u64,
) -> f64 {
    for _ in 0..steps / 10 {
        solver.step(path, dt).expect("RK4 step (warm-up)");
    }
    let start = Instant::now();
    for _ in 0..steps {
        solver
            .step(black_box(path), black_box(dt))
            .expect("RK4 step");
    }
    let elapsed = start.elapsed();
    black_box(solver.state());
    elapsed.as_secs_f64() * 1e6 / steps as f64
}

fn main() {
    let steps = match std::env::args().nth(1) {
        Some(arg) => arg.parse().unwrap_or_else(|_| {
            eprintln!("usage: step_time [STEPS]");
            std::process::exit(2)
        }),
        None => DEFAULT_STEPS,
    };
    println!("{steps} timed RK4 steps per case");

    let mut pendulum = pendulum_solver::<f64, 300>(300);
    let us = micros_per_step(&mut *pendulum, &fixed_anchor(), PENDULUM_DT, steps);
    println!("pendulum   f64  N=300       dt=1e-4  {us:9.3} µs/step");

    let mut towed32 = towed_solver::<f32, GRADED_COUNT>(graded_layout());
    let us = micros_per_step(&mut *towed32, &cruise_path(), TOWED_DT, steps);
    println!("towed      f32  graded16    dt=1e-3  {us:9.3} µs/step");

    let mut towed64 = towed_solver::<f64, GRADED_COUNT>(graded_layout());
    let us = micros_per_step(&mut *towed64, &cruise_path(), TOWED_DT, steps);
    println!("towed      f64  graded16    dt=1e-3  {us:9.3} µs/step");
}
