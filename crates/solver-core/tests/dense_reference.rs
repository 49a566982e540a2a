//! The O(N) two-sweep solver against the independent dense (Kane) formulation on
//! the same states: accelerations and joint forces agree to ~1e-9 relative in f64.

mod common;
use common::*;
use solver_core::dense::evaluate_dense;
use solver_core::solver::connection_and_air;
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
