//! Quick wall-clock sanity check of one RK4 step (the criterion benches are authoritative).
use solver_core::*;
use std::time::Instant;

fn main() {
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(|| {
            let model = reference_pendulum::<f64, 300>(300).unwrap();
            let mut solver = Box::new(Solver::new(model, pendulum_initial_state(300)).unwrap());
            let anchor = Uniform {
                initial: AircraftState::fixed(Vec3::zeros()),
            };
            for _ in 0..2000 {
                solver.step(&anchor, 1e-4).unwrap();
            }
            let n = 20_000;
            let t = Instant::now();
            for _ in 0..n {
                solver.step(&anchor, 1e-4).unwrap();
            }
            println!(
                "pendulum f64 N=300: {:.2} us/step",
                t.elapsed().as_secs_f64() * 1e6 / n as f64
            );
        })
        .unwrap()
        .join()
        .unwrap();
}
