//! The paper's single-sweep shooting form diverges with N; the two-sweep
//! elimination stays at round-off (docs/design.md §3). Both against the dense reference.

mod common;
use common::*;
use solver_core::dense::evaluate_dense;
use solver_core::motion::connection_and_air;
use solver_core::*;

/// Relative error of the joint forces of `method` against the dense f64 reference.
fn error<T: Real, const N: usize>(count: usize, method: TensionMethod, seed: u64) -> f64 {
    let mut rng = Rng(seed);
    let state64: State<f64, N> = random_state(&mut rng, count, 2.0);
    let model64 = reference_pendulum::<f64, N>(count).unwrap();
    let anchor = AircraftState::fixed(Vec3::zeros());
    let (connection, air) = connection_and_air(&model64, &anchor).unwrap();
    let dense = evaluate_dense(&model64, &state64, &connection, &air).unwrap();

    let mut state = State::<T, N>::default();
    for i in 0..count {
        state.directions[i] = state64.directions[i].map(T::lit);
        state.rates[i] = state64.rates[i].map(T::lit);
    }
    let model = reference_pendulum::<T, N>(count).unwrap();
    let mut solver = Box::new(Solver::new(model, state).unwrap());
    solver.set_method(method);
    let path = Uniform {
        initial: AircraftState::<T>::fixed(Vec3::zeros()),
    };
    let scale = dense
        .joint_forces
        .iter()
        .map(|f| f.norm())
        .fold(0.0, f64::max);
    match solver.outputs(&path) {
        Ok(out) => {
            let mut worst: f64 = 0.0;
            for j in 0..=count {
                let f = out.joint_force(j).map(|x| x.to_f64());
                worst = worst.max((f - dense.joint_forces[j]).norm() / scale);
            }
            if worst.is_finite() {
                worst
            } else {
                f64::INFINITY
            }
        }
        Err(_) => f64::INFINITY,
    }
}

macro_rules! shooting_vs_two_sweep {
    ($name:ident, $t:ty, $small:expr, $large:expr, $stable_tol:expr) => {
        #[test]
        fn $name() {
            let small_shoot = error::<$t, 64>($small, TensionMethod::Shooting, 3);
            let large_shoot = error::<$t, 64>($large, TensionMethod::Shooting, 3);
            let small_sweep = error::<$t, 64>($small, TensionMethod::TwoSweep, 3);
            let large_sweep = error::<$t, 64>($large, TensionMethod::TwoSweep, 3);
            println!(
                "{}: shooting N={} {:e}, N={} {:e}; two-sweep {:e}, {:e}",
                stringify!($t),
                $small,
                small_shoot,
                $large,
                large_shoot,
                small_sweep,
                large_sweep
            );
            // The shooting error grows by orders of magnitude with N ...
            assert!(
                large_shoot > 1e3 * small_shoot.max(1e-300),
                "shooting did not diverge"
            );
            assert!(
                large_shoot > 1e-2,
                "shooting at N={} should be useless, error {large_shoot:e}",
                $large
            );
            // ... while the two-sweep elimination stays at round-off.
            assert!(small_sweep < $stable_tol && large_sweep < $stable_tol);
        }
    };
}

shooting_vs_two_sweep!(shooting_diverges_f64_two_sweep_does_not, f64, 5, 40, 1e-11);
shooting_vs_two_sweep!(shooting_diverges_f32_two_sweep_does_not, f32, 2, 16, 1e-4);

#[test]
fn shooting_agrees_for_small_chains() {
    // The reference form is right, only unstable: at N = 4 in f64 it matches the dense solution.
    assert!(error::<f64, 8>(4, TensionMethod::Shooting, 5) < 1e-9);
}
