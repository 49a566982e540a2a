//! Scratch (deleted after use): time the passes of one evaluation separately.
use std::hint::black_box;
use std::time::Instant;
use solver_core::dynamics::{accelerations, prepare, solve_tensions};
use solver_core::solver::connection_and_air;
use solver_core::{AircraftState, Derivative, Vec3, Workspace};
fn main() {
    let mut solver = benches::pendulum_solver::<f64, 300>(300);
    let anchor = benches::fixed_anchor::<f64>();
    for _ in 0..2000 { solver.step(&anchor, 1e-4).unwrap(); }
    let model = *solver.model();
    let state = *solver.state();
    let (c, air) = connection_and_air(&model, &AircraftState::fixed(Vec3::zeros())).unwrap();
    let mut ws = Box::new(Workspace::<f64, 300>::default());
    let mut out = Box::new(Derivative::<f64, 300>::default());
    let n = 200_000;
    for round in 0..3 {
        let t = Instant::now();
        for _ in 0..n { prepare(black_box(&model), black_box(&state), &c, &air, &mut ws); }
        let a = t.elapsed().as_secs_f64() * 1e9 / n as f64;
        let t = Instant::now();
        for _ in 0..n { solve_tensions(black_box(&model), black_box(&state), &mut ws).unwrap(); }
        let b = t.elapsed().as_secs_f64() * 1e9 / n as f64;
        let t = Instant::now();
        for _ in 0..n { accelerations(black_box(&model), black_box(&state), &ws, &mut out); black_box(&out); }
        let d = t.elapsed().as_secs_f64() * 1e9 / n as f64;
        println!("round {round}: prepare {a:.0} ns, solve_tensions {b:.0} ns, accelerations {d:.0} ns");
    }
}
