//! Compound multi-pendulum (docs/design.md §7.1): energy conservation of the O(N) solver.

mod common;
use solver_core::*;

#[test]
fn energy_drift_at_300_rods_over_one_second_is_below_1e_minus_8() {
    // Run in a thread with a large stack: the solver for 300 rods is ~150 KB.
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(|| {
            let count = 300;
            let model = reference_pendulum::<f64, 300>(count).unwrap();
            let mut solver = Box::new(Solver::new(model, pendulum_initial_state(count)).unwrap());
            let anchor = Uniform {
                initial: AircraftState::fixed(Vec3::zeros()),
            };
            let e0 = pendulum_energy(solver.model(), solver.state());
            let mut worst: f64 = 0.0;
            for step in 0..10_000 {
                solver.step(&anchor, 1e-4).unwrap();
                if step % 100 == 99 {
                    let e = pendulum_energy(solver.model(), solver.state());
                    worst = worst.max((e - e0).abs() / e0.abs());
                }
            }
            // The chain has really moved: the tip has fallen and swung.
            let out = solver.outputs(&anchor).unwrap();
            let tip = out.joint_position(count);
            assert!(tip.x > -25.0, "tip x {}", tip.x);
            assert!(worst < 1e-8, "relative energy drift {worst:e}");
            println!("N=300, 1 s, dt=1e-4: relative energy drift {worst:e}");
        })
        .unwrap()
        .join()
        .unwrap();
}

#[test]
fn two_rod_pendulum_support_force_balances_at_rest_hanging_down() {
    // Hanging straight down at rest: hinge force = total weight, no accelerations.
    let model = reference_pendulum::<f64, 4>(2).unwrap();
    let mut state = State::<f64, 4>::default();
    state.directions[0] = Vec3::z();
    state.directions[1] = Vec3::z();
    let mut solver = Solver::new(model, state).unwrap();
    let anchor = Uniform {
        initial: AircraftState::fixed(Vec3::zeros()),
    };
    let out = solver.outputs(&anchor).unwrap();
    assert!((out.joint_force(0) - Vec3::new(0.0, 0.0, -9.81)).norm() < 1e-12);
    assert!((out.joint_force(1) - Vec3::new(0.0, 0.0, -4.905)).norm() < 1e-12);
    assert!(out.derivative().rates[..2].iter().all(|w| w.norm() < 1e-12));
}
