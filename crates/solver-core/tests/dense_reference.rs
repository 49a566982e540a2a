//! The O(N) two-sweep solver against the independent dense (Kane) formulation on
//! the same states: accelerations and joint forces agree to ~1e-9 relative in f64.

mod common;
use common::*;
use solver_core::dense::evaluate_dense;
use solver_core::motion::connection_and_air;
use solver_core::*;

fn relative_difference(a: &[Vec3<f64>], b: &[Vec3<f64>]) -> f64 {
    let scale = a.iter().map(|v| v.norm()).fold(0.0, f64::max).max(1e-300);
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
        / scale
}

fn compare<const N: usize>(
    model: Model<f64, N>,
    state: State<f64, N>,
    aircraft: AircraftState<f64>,
) -> (f64, f64, f64) {
    let n = model.segment_count();
    let path = Uniform { initial: aircraft };
    let (connection, air) = connection_and_air(&model, &aircraft).unwrap();
    let dense = evaluate_dense(&model, &state, &connection, &air).unwrap();
    let mut solver = Box::new(Solver::new(model, state).unwrap());
    let out = solver.outputs(&path).unwrap();
    let fast_rates: Vec<Vec3<f64>> = out.derivative().rates[..n].to_vec();
    let fast_forces: Vec<Vec3<f64>> = (0..=n).map(|j| out.joint_force(j)).collect();
    let rate_error = relative_difference(&dense.derivative.rates[..n], &fast_rates);
    let force_error = relative_difference(&dense.joint_forces, &fast_forces);
    let decoy_error = if out.decoy().is_some() {
        (dense.derivative.decoy_rate - out.derivative().decoy_rate).norm()
            / dense.derivative.decoy_rate.norm().max(1e-12)
    } else {
        0.0
    };
    (rate_error, force_error, decoy_error)
}

#[test]
fn pendulum_two_sweep_matches_dense() {
    let mut rng = Rng(7);
    for &count in &[2usize, 10, 50] {
        for trial in 0..3 {
            let model = reference_pendulum::<f64, 64>(count).unwrap();
            let state = if trial == 0 {
                pendulum_initial_state(count)
            } else {
                random_state(&mut rng, count, 3.0)
            };
            let (rates, forces, _) = compare(model, state, AircraftState::fixed(Vec3::zeros()));
            assert!(
                rates < 1e-9 && forces < 1e-9,
                "N={count} trial {trial}: rates {rates:e} forces {forces:e}"
            );
        }
    }
}

#[test]
fn towed_system_two_sweep_matches_dense() {
    let mut rng = Rng(11);
    for &count in &[2usize, 10, 50] {
        for &(uniform, rate_scale) in &[(true, 0.5), (false, 2.0)] {
            let layout = if uniform {
                SegmentLayout::Uniform { count }
            } else {
                SegmentLayout::Graded { count, ratio: 1.1 }
            };
            let model = Model::<f64, 64>::new(reference_params(layout)).unwrap();
            let state = random_state(&mut rng, count, rate_scale);
            // A manoeuvring aircraft: accelerating, rolling and pitching, so every term is exercised.
            let mut aircraft = AircraftState::level(9000.0, 0.8 * speed_of_sound(9000.0));
            aircraft.acceleration = Vec3::new(10.0, 1.0, -3.0);
            aircraft.angular_rate = Vec3::new(0.3, 0.1, 0.2);
            aircraft.angular_acceleration = Vec3::new(0.5, -0.2, 0.1);
            let (rates, forces, decoy) = compare(model, state, aircraft);
            assert!(
                rates < 1e-9 && forces < 1e-9 && decoy < 1e-9,
                "N={count} uniform={uniform}: rates {rates:e} forces {forces:e} decoy {decoy:e}"
            );
        }
    }
}

/// The product's fused pass (tensions and accelerations in one back sweep) gives
/// the bits of the separate passes, with a decoy and with a free end.
fn fused_matches_separate<T: Real, const N: usize>(model: Model<T, N>, state: State<T, N>) {
    use solver_core::dynamics::{
        accelerations, prepare, solve_tensions, solve_tensions_and_accelerations,
        solve_tensions_first_stage,
    };
    let aircraft = AircraftState::<T>::level(T::lit(9000.0), T::lit(180.0));
    let (connection, air) = connection_and_air(&model, &aircraft).unwrap();
    let mut separate_ws = Box::new(Workspace::<T, N>::default());
    let mut fused_ws = separate_ws.clone();
    let (mut separate, mut fused) = (Derivative::<T, N>::default(), Derivative::<T, N>::default());
    prepare(&model, &state, &connection, &air, &mut separate_ws);
    solve_tensions(&model, &state, &mut separate_ws).unwrap();
    accelerations(&model, &state, &separate_ws, &mut separate);
    prepare(&model, &state, &connection, &air, &mut fused_ws);
    solve_tensions_and_accelerations(&model, &state, &mut fused_ws, &mut fused).unwrap();
    assert_eq!(format!("{fused:?}"), format!("{separate:?}"));
    let forces = |ws: &Workspace<T, N>| format!("{ws:?}");
    assert_eq!(forces(&fused_ws), forces(&separate_ws));

    // RK4's first stage with the second stage's state formed in the back sweep:
    // the same derivative, and the stage y + h k1 as `State::set_stage` forms it.
    let h = T::lit(0.00125);
    let mut first_ws = Box::new(Workspace::<T, N>::default());
    let mut first = Derivative::<T, N>::default();
    let mut stage = Box::new(State::<T, N>::default());
    prepare(&model, &state, &connection, &air, &mut first_ws);
    solve_tensions_first_stage(&model, &state, &mut first_ws, &mut first, &mut stage, h).unwrap();
    let n = model.segment_count();
    assert_eq!(
        format!("{:?}", &first.directions[..n]),
        format!("{:?}", &separate.directions[..n])
    );
    assert_eq!(
        format!("{:?}", &first.rates[..n]),
        format!("{:?}", &separate.rates[..n])
    );
    assert_eq!(
        format!("{:?}", (first.decoy_attitude, first.decoy_rate)),
        format!("{:?}", (separate.decoy_attitude, separate.decoy_rate))
    );
    assert_eq!(forces(&first_ws), forces(&separate_ws));
    let mut expected = Box::new(State::<T, N>::default());
    for i in 0..n {
        expected.directions[i] = state.directions[i] + separate.directions[i] * h;
        expected.rates[i] = state.rates[i] + separate.rates[i] * h;
    }
    for k in 0..4 {
        expected.decoy_attitude[k] = state.decoy_attitude[k] + separate.decoy_attitude[k] * h;
    }
    expected.decoy_rate = state.decoy_rate + separate.decoy_rate * h;
    assert_eq!(
        format!("{:?}", &stage.directions[..n]),
        format!("{:?}", &expected.directions[..n])
    );
    assert_eq!(
        format!("{:?}", &stage.rates[..n]),
        format!("{:?}", &expected.rates[..n])
    );
    assert_eq!(
        format!("{:?}", (stage.decoy_attitude, stage.decoy_rate)),
        format!("{:?}", (expected.decoy_attitude, expected.decoy_rate))
    );
}

#[test]
fn the_fused_back_sweep_is_the_separate_passes() {
    let mut rng = Rng(7);
    for &count in &[1usize, 2, 5, 16] {
        let towed = Model::<f32, 16>::new(reference_params(SegmentLayout::Graded {
            count,
            ratio: 1.3,
        }))
        .unwrap();
        fused_matches_separate(towed, random_state(&mut rng, count, 0.5));
        let towed = Model::<f64, 16>::new(reference_params(SegmentLayout::Graded {
            count,
            ratio: 1.3,
        }))
        .unwrap();
        fused_matches_separate(towed, random_state(&mut rng, count, 0.5));
        let pendulum = reference_pendulum::<f64, 16>(count).unwrap();
        fused_matches_separate(pendulum, random_state(&mut rng, count, 0.5));
        let pendulum = reference_pendulum::<f32, 16>(count).unwrap();
        fused_matches_separate(pendulum, random_state(&mut rng, count, 0.5));
    }
}

#[test]
fn dense_steps_through_the_solvers_rk4_track_the_solver() {
    // The same RK4 on both derivatives: the states differ only by the derivatives'
    // round-off, not by the scheme (over 200 steps of 1 ms the folding chain
    // amplifies it to 7.8e-8; over these 5 ms it stays below 1e-9).
    let model = reference_pendulum::<f64, 16>(10).unwrap();
    let anchor = Uniform {
        initial: AircraftState::fixed(Vec3::zeros()),
    };
    let mut solver = Box::new(Solver::new(model, pendulum_initial_state(10)).unwrap());
    let mut dense = Box::new(Rk4::new(pendulum_initial_state::<f64, 16>(10)));
    for _ in 0..50 {
        solver.step(&anchor, 1e-4).unwrap();
        dense
            .step(
                &mut solver_core::dense::DenseDerivative::new(&model, &anchor),
                1e-4,
                |_, _, _| {},
            )
            .unwrap();
    }
    assert_eq!(dense.state().time, solver.state().time);
    let difference = (0..10)
        .map(|i| (dense.state().directions[i] - solver.state().directions[i]).amax())
        .fold(0.0, f64::max);
    assert!(difference < 1e-9, "{difference:e}");
}
