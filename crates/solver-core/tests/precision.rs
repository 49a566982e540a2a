//! f32 against f64 on the 16-segment graded model through a 20 s run with an
//! acceleration (docs/design.md §7.4), determinism, and bad inputs.

mod common;
use common::*;
use solver_core::*;

/// Mach 0.6 level to t = 2 s, then +10 m/s^2 until Mach 0.8, then constant (the paper's case).
struct Acceleration {
    altitude: f64,
    v0: f64,
    v1: f64,
}

impl<T: Real> FlightPath<T> for Acceleration {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let (a, t0) = (10.0, 2.0);
        let t1 = t0 + (self.v1 - self.v0) / a;
        let (x, v, acc) = if t < t0 {
            (self.v0 * t, self.v0, 0.0)
        } else if t < t1 {
            let s = t - t0;
            (self.v0 * t + 0.5 * a * s * s, self.v0 + a * s, a)
        } else {
            let s = t1 - t0;
            (
                self.v0 * t + 0.5 * a * s * s + (self.v1 - self.v0) * (t - t1),
                self.v1,
                0.0,
            )
        };
        let mut s = AircraftState::<T>::level(T::lit(self.altitude), T::lit(v));
        s.position.x = T::lit(x);
        s.acceleration.x = T::lit(acc);
        s
    }
}

fn connection_tensions<T: Real>(dt: f64, seconds: f64) -> Vec<f64> {
    let model = Model::<T, 16>::new(reference_params(SegmentLayout::Graded {
        count: 16,
        ratio: T::lit(1.3),
    }))
    .unwrap();
    let a = speed_of_sound(9000.0);
    let path = Acceleration {
        altitude: 9000.0,
        v0: 0.6 * a,
        v1: 0.8 * a,
    };
    let start = trim(&model, &FlightPath::<T>::state_at(&path, 0.0)).unwrap();
    let mut solver = Solver::new(model, start).unwrap();
    let steps = (seconds / dt).round() as usize;
    let mut out = Vec::with_capacity(steps);
    for _ in 0..steps {
        solver.step(&path, dt).unwrap();
        out.push(solver.outputs(&path).unwrap().connection_tension().to_f64());
    }
    out
}

#[test]
fn f32_tracks_f64_within_half_a_percent_through_an_acceleration() {
    let dt = 1e-3;
    let t64 = connection_tensions::<f64>(dt, 20.0);
    let t32 = connection_tensions::<f32>(dt, 20.0);
    let peak = t64.iter().cloned().fold(0.0, f64::max);
    let worst = t64
        .iter()
        .zip(&t32)
        .map(|(a, b)| (a - b).abs() / a)
        .fold(0.0, f64::max);
    let first = t64[0];
    println!("f64 first {first:.2} N peak {peak:.2} N; worst f32 relative difference {worst:e}");
    assert!(peak > first * 1.2, "the acceleration must load the cable");
    assert!(worst < 5e-3, "f32 differs from f64 by {worst:e}");
}

#[test]
fn same_inputs_give_bit_identical_outputs() {
    let a = connection_tensions::<f64>(2e-3, 4.0);
    let b = connection_tensions::<f64>(2e-3, 4.0);
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
    let a = connection_tensions::<f32>(2e-3, 4.0);
    let b = connection_tensions::<f32>(2e-3, 4.0);
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
}

#[test]
fn observed_outputs_equal_a_separate_evaluation() {
    let model = Model::<f64, 16>::new(reference_params(SegmentLayout::Graded {
        count: 16,
        ratio: 1.3,
    }))
    .unwrap();
    let a = speed_of_sound(9000.0);
    let path = Acceleration {
        altitude: 9000.0,
        v0: 0.6 * a,
        v1: 0.8 * a,
    };
    let mut solver = Solver::new(model, trim(&model, &path.state_at(0.0)).unwrap()).unwrap();
    for _ in 0..2100 {
        solver.step(&path, 1e-3).unwrap();
    }
    let separate = solver.outputs(&path).unwrap().connection_tension();
    let mut observed = f64::NAN;
    solver
        .step_observed(&path, 1e-3, |out| observed = out.connection_tension())
        .unwrap();
    assert_eq!(separate.to_bits(), observed.to_bits());
}

#[test]
fn saved_state_restores_bit_identically() {
    let model = Model::<f64, 16>::new(reference_params(SegmentLayout::Graded {
        count: 16,
        ratio: 1.3,
    }))
    .unwrap();
    let a = speed_of_sound(9000.0);
    let path = Acceleration {
        altitude: 9000.0,
        v0: 0.6 * a,
        v1: 0.8 * a,
    };
    let mut solver = Solver::new(model, trim(&model, &path.state_at(0.0)).unwrap()).unwrap();
    for _ in 0..2500 {
        solver.step(&path, 1e-3).unwrap();
    }
    let saved = *solver.state();
    for _ in 0..500 {
        solver.step(&path, 1e-3).unwrap();
    }
    let first = *solver.state();
    solver.set_state(saved).unwrap();
    for _ in 0..500 {
        solver.step(&path, 1e-3).unwrap();
    }
    assert_eq!(first, *solver.state());
}

struct Broken(AircraftState<f64>);
impl FlightPath<f64> for Broken {
    fn state_at(&self, _t: f64) -> AircraftState<f64> {
        self.0
    }
}

#[test]
fn bad_inputs_are_typed_errors_and_leave_the_state_unchanged() {
    let model = Model::<f64, 16>::new(reference_params(SegmentLayout::Graded {
        count: 16,
        ratio: 1.3,
    }))
    .unwrap();
    let good = AircraftState::level(9000.0, 200.0);
    let mut solver = Solver::new(model, trim(&model, &good).unwrap()).unwrap();
    let before = *solver.state();
    let cases: Vec<(AircraftState<f64>, SolveError)> = vec![
        (
            {
                let mut s = good;
                s.velocity.x = f64::NAN;
                s
            },
            SolveError::Input(InputError::NonFinite { field: "velocity" }),
        ),
        (
            {
                let mut s = good;
                s.position.y = f64::INFINITY;
                s
            },
            SolveError::Input(InputError::NonFinite { field: "position" }),
        ),
        (
            {
                let mut s = good;
                s.angular_acceleration.z = f64::NAN;
                s
            },
            SolveError::Input(InputError::NonFinite {
                field: "angular_acceleration",
            }),
        ),
        (
            {
                let mut s = good;
                s.attitude = [0.0; 4];
                s
            },
            SolveError::Input(InputError::DegenerateAttitude),
        ),
        (
            {
                let mut s = good;
                s.position.z = -30_000.0;
                s
            },
            SolveError::Input(InputError::Atmosphere(
                AtmosphereError::AltitudeOutOfRange {
                    altitude_m: 29_999.0,
                },
            )),
        ),
    ];
    for (aircraft, expected) in cases {
        assert_eq!(solver.step(&Broken(aircraft), 1e-3).unwrap_err(), expected);
        assert_eq!(*solver.state(), before, "state changed after {expected:?}");
    }
    assert_eq!(
        solver.step(&Broken(good), f64::NAN).unwrap_err(),
        SolveError::Input(InputError::BadTimeStep)
    );
    assert_eq!(
        solver.step(&Broken(good), -1e-3).unwrap_err(),
        SolveError::Input(InputError::BadTimeStep)
    );
    let mut nan_state = before;
    nan_state.rates[3].x = f64::NAN;
    assert!(solver.set_state(nan_state).is_err());
    assert_eq!(*solver.state(), before);
    // And a valid step still works afterwards.
    solver.step(&Broken(good), 1e-3).unwrap();
}

#[test]
fn degenerate_state_names_the_joint() {
    // Two coincident-direction rods with a zero-mass decoy is impossible to build; instead
    // a free chain whose state holds a zero direction vector gives a non-finite pivot at its joint.
    let model = reference_pendulum::<f64, 8>(6).unwrap();
    let mut state = pendulum_initial_state::<f64, 8>(6);
    state.directions[3] = Vec3::new(f64::NAN, 0.0, 0.0);
    let mut solver = Solver::new(model, pendulum_initial_state(6)).unwrap();
    assert!(solver.set_state(state).is_err());
    let anchor = Uniform {
        initial: AircraftState::fixed(Vec3::zeros()),
    };
    // Direct evaluation on the bad state reports the joint where elimination failed.
    let (connection, air) = solver_core::motion::connection_and_air(
        solver.model(),
        &AircraftState::fixed(Vec3::zeros()),
    )
    .unwrap();
    let mut ws = Box::new(Workspace::<f64, 8>::default());
    let mut d = Derivative::<f64, 8>::default();
    let err = solver_core::dynamics::evaluate(
        solver.model(),
        &state,
        &connection,
        &air,
        TensionMethod::TwoSweep,
        &mut ws,
        &mut d,
    )
    .unwrap_err();
    assert_eq!(err, SolveError::NonPositivePivot { joint: 3 });
    solver.step(&anchor, 1e-3).unwrap();
}

/// A straight climb at 30 m/s: the air column moves through its grid cells.
struct Climb {
    speed: f64,
}

impl<T: Real> FlightPath<T> for Climb {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let mut s = AircraftState::<T>::level(T::lit(9000.0 + 30.0 * t), T::lit(self.speed));
        s.position.x = T::lit(self.speed * t);
        s.velocity.z = T::lit(-30.0);
        s
    }
}

/// The first stage of a step reuses the evaluation that `outputs` left at the same
/// state with the same inputs; with other inputs it evaluates. Either way every
/// bit of every state is that of a solver that never asked for outputs.
fn reuse_changes_nothing<T: Real>() {
    let model = Model::<T, 16>::new(reference_params(SegmentLayout::Graded {
        count: 16,
        ratio: T::lit(1.3),
    }))
    .unwrap();
    let a = speed_of_sound(9000.0);
    let path = Climb { speed: 0.6 * a };
    let other = Climb {
        speed: 0.6 * a + 1.0,
    };
    let start = trim(
        &model,
        &FlightPath::<T>::state_at(&Climb { speed: 0.6 * a }, 0.0),
    )
    .unwrap();
    let mut plain = Solver::new(model, start).unwrap();
    let mut reusing = Solver::new(model, start).unwrap();
    let mut mismatched = Solver::new(model, start).unwrap();
    for k in 0..400 {
        plain.step(&path, 0.005).unwrap();
        reusing.step(&path, 0.005).unwrap();
        mismatched.step(&path, 0.005).unwrap();
        let tension = reusing.outputs(&path).unwrap().connection_tension();
        mismatched.outputs(&other).unwrap();
        assert_eq!(reusing.state(), plain.state(), "step {k}");
        assert_eq!(mismatched.state(), plain.state(), "step {k}");
        // The reused evaluation is the one a step would make.
        let fresh = plain.clone().outputs(&path).unwrap().connection_tension();
        assert_eq!(
            tension.to_f64().to_bits(),
            fresh.to_f64().to_bits(),
            "step {k}"
        );
    }
    // 2 s of climbing crossed 4 grid cells of the air column; the run stayed finite.
    assert!(plain.outputs(&path).unwrap().connection_tension() > T::zero());
}

#[test]
fn reusing_the_output_evaluation_changes_no_bit() {
    reuse_changes_nothing::<f32>();
    reuse_changes_nothing::<f64>();
}

#[test]
fn outputs_are_never_ok_with_a_non_finite_force() {
    // f32 overflows in the hinge forces for accelerations, body rates or angular
    // accelerations far beyond any aircraft's: a typed error naming a joint, never
    // Ok with an infinite tension.
    let model = Model::<f32, 16>::new(reference_params(SegmentLayout::Graded {
        count: 16,
        ratio: 1.3,
    }))
    .unwrap();
    let steady = AircraftState::level(9000.0, 200.0);
    let mut solver = Solver::new(model, trim(&model, &steady).unwrap()).unwrap();
    let mut errors = 0;
    for magnitude in [1e19f32, 1e20, 1e25, 1e30, f32::MAX] {
        for (kind, axis, sign) in (0..3).flat_map(|kind| {
            (0..3).flat_map(move |axis| [(kind, axis, 1.0f32), (kind, axis, -1.0)])
        }) {
            let mut violent = steady;
            let field = match kind {
                0 => &mut violent.acceleration,
                1 => &mut violent.angular_rate,
                _ => &mut violent.angular_acceleration,
            };
            field[axis] = sign * magnitude;
            let path = Uniform { initial: violent };
            match solver.outputs(&path) {
                Ok(out) => {
                    for j in 0..=16 {
                        let tension = out.joint_force(j).norm();
                        assert!(
                            tension.is_finite(),
                            "Ok with the tension {tension} at joint {j} ({kind}, {axis}, {})",
                            sign * magnitude
                        );
                    }
                }
                Err(SolveError::NonFinite { joint } | SolveError::NonPositivePivot { joint }) => {
                    assert!(joint <= 16);
                    errors += 1;
                }
                Err(other) => panic!("{other:?}"),
            }
        }
    }
    assert!(
        errors > 0,
        "no acceleration overflowed f32: the check is not exercised"
    );
    // The steady flight's outputs are still finite and Ok.
    let out = solver.outputs(&Uniform { initial: steady }).unwrap();
    assert!(out.connection_tension().is_finite());
}
