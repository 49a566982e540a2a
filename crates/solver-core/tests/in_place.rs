//! Building in place: [`Solver::UNCONFIGURED`] configured with
//! [`Solver::configure`] is the solver [`Solver::new`] builds (the same model to
//! the bit, the same steps), a solver reconfigured after use forgets everything,
//! and a rejected configuration changes nothing. The model's in-place
//! construction is checked against the direct formulas of its derived values.

mod common;
use common::*;
use solver_core::profiles::PullUp;
use solver_core::*;

const CAPACITY: usize = 24;

fn graded<T: Real>(count: usize, ratio: f64) -> ModelParams<T> {
    reference_params(SegmentLayout::Graded {
        count,
        ratio: T::lit(ratio),
    })
}

/// A pull-up at 0.2 rad/s from Mach 0.6 at 9 km, from t = 0.05 s.
fn pull_up() -> PullUp {
    PullUp {
        altitude: 9000.0,
        speed: 0.6 * speed_of_sound(9000.0),
        start: 0.05,
        rate: 0.2,
        duration: 5.0,
    }
}

/// The state's every value as bits.
fn bits<T: Real, const N: usize>(s: &State<T, N>) -> Vec<u64> {
    let mut v = vec![s.time.to_bits()];
    for x in s.directions.iter().chain(&s.rates) {
        v.extend(x.iter().map(|c| c.to_f64().to_bits()));
    }
    v.extend(s.decoy_attitude.iter().map(|c| c.to_f64().to_bits()));
    v.extend(s.decoy_rate.iter().map(|c| c.to_f64().to_bits()));
    v
}

/// Trims `solver` on the pull-up, steps it 30 times by 2 ms, and returns the
/// states and connection tensions, as bits.
fn fly<T: Real>(solver: &mut Solver<T, CAPACITY>) -> Vec<Vec<u64>> {
    let path = pull_up();
    let start = trim(solver.model(), &FlightPath::<T>::state_at(&path, 0.0)).unwrap();
    solver.set_state(start).unwrap();
    (0..30)
        .map(|_| {
            solver.step(&path, 0.002).unwrap();
            let tension = solver.outputs(&path).unwrap().connection_tension();
            let mut b = bits(solver.state());
            b.push(tension.to_f64().to_bits());
            b
        })
        .collect()
}

fn configured_in_place_steps_as_new<T: Real>() {
    let params = graded::<T>(16, 1.3);
    let mut direct =
        Solver::new(Model::<T, CAPACITY>::new(params).unwrap(), State::default()).unwrap();
    let mut in_place = Solver::<T, CAPACITY>::UNCONFIGURED;
    in_place.configure(&params).unwrap();
    assert_eq!(in_place.model(), direct.model());
    assert_eq!(in_place.state(), direct.state());
    assert_eq!(fly(&mut in_place), fly(&mut direct));
}

#[test]
fn a_solver_configured_in_place_steps_as_the_one_new_builds() {
    configured_in_place_steps_as_new::<f32>();
    configured_in_place_steps_as_new::<f64>();
}

#[test]
fn a_reconfigured_solver_keeps_nothing_of_its_past() {
    // A solver that flew another model (more segments, other grading), then was
    // switched to the shooting method, then reconfigured: as a new one.
    let mut used = Solver::new(
        Model::<f32, CAPACITY>::new(graded(20, 1.1)).unwrap(),
        State::default(),
    )
    .unwrap();
    fly(&mut used);
    used.set_method(TensionMethod::Shooting);
    let params = graded::<f32>(16, 1.3);
    used.configure(&params).unwrap();
    let mut fresh = Solver::new(
        Model::<f32, CAPACITY>::new(params).unwrap(),
        State::default(),
    )
    .unwrap();
    assert_eq!(used.model(), fresh.model());
    assert_eq!(used.state(), fresh.state());
    assert_eq!(fly(&mut used), fly(&mut fresh));
}

#[test]
fn a_rejected_configuration_leaves_the_solver_as_it_was() {
    let mut solver = Solver::new(
        Model::<f64, CAPACITY>::new(graded(16, 1.3)).unwrap(),
        State::default(),
    )
    .unwrap();
    fly(&mut solver);
    let (model, state) = (*solver.model(), *solver.state());
    let mut bad_density = graded::<f64>(12, 1.2);
    bad_density.cable.linear_density = -1.0;
    let mut bad_decoy = graded::<f64>(12, 1.2);
    if let EndBody::Decoy(d) = &mut bad_decoy.end {
        d.x_cg = 2.0;
    }
    // The masses of the short segments near the decoy (5.5 cm) underflow to zero
    // at f64's smallest subnormal density; the long ones do not.
    let mut massless = graded::<f64>(CAPACITY, 1.3);
    massless.cable.linear_density = f64::from_bits(1);
    let cases = [
        (graded(CAPACITY + 1, 1.3), "too many segments"),
        (graded(12, 0.5), "grading ratio"),
        (bad_density, "cable.linear_density"),
        (bad_decoy, "decoy.x_cg"),
        (massless, "segment mass"),
    ];
    for (params, what) in cases {
        let error = solver.configure(&params).unwrap_err();
        assert_eq!(
            Err(error),
            Model::<f64, CAPACITY>::new(params).map(|_| ()),
            "{what}"
        );
        assert_eq!(solver.model(), &model, "{what}: the model changed");
        assert_eq!(solver.state(), &state, "{what}: the state changed");
    }
}

/// The derived values by their definitions (what `Model::new` computed before it
/// was built on the in-place construction): lengths r^(N-i) scaled to the cable
/// length, from the decoy end; masses, inverses, rate gains and drag factors from
/// them.
fn check_derived<T: Real>(params: &ModelParams<T>) {
    let model = Model::<T, CAPACITY>::new(*params).unwrap();
    let count = params.layout.count();
    let cable = &params.cable;
    let mut lengths = vec![T::zero(); count];
    match params.layout {
        SegmentLayout::Uniform { .. } => lengths.fill(cable.length / T::lit(count as f64)),
        SegmentLayout::Graded { ratio, .. } => {
            let (mut weight, mut total) = (T::one(), T::zero());
            for l in lengths.iter_mut().rev() {
                *l = weight;
                total += weight;
                weight *= ratio;
            }
            let scale = cable.length / total;
            for l in &mut lengths {
                *l *= scale;
            }
        }
    }
    let masses: Vec<T> = lengths.iter().map(|l| cable.linear_density * *l).collect();
    let inverse: Vec<T> = masses.iter().map(|m| T::one() / *m).collect();
    let gains: Vec<T> = (0..count)
        .map(|i| T::lit(6.0) / (masses[i] * lengths[i]))
        .collect();
    let area: Vec<T> = (0..count)
        .map(|i| T::lit(0.5) * cable.diameter * lengths[i] * inverse[i])
        .collect();
    let normal: Vec<T> = area.iter().map(|a| *a * cable.cd_normal).collect();
    let tangential: Vec<T> = area
        .iter()
        .map(|a| *a * T::pi() * cable.cf_tangential)
        .collect();
    let same =
        |a: &[T], b: &[T]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.same_bits(*y));
    assert!(same(model.lengths(), &lengths), "{:?}", params.layout);
    assert!(same(model.masses(), &masses));
    assert!(same(model.inverse_masses(), &inverse));
    assert!(same(model.rate_gains(), &gains));
    let (n, t) = model.drag_factors();
    assert!(same(n, &normal));
    assert!(same(t, &tangential));
}

#[test]
fn the_model_built_in_place_has_the_derived_values_of_their_definitions() {
    for count in [1, 2, 16, CAPACITY] {
        for layout in [
            SegmentLayout::Uniform { count },
            SegmentLayout::Graded { count, ratio: 1.3 },
            SegmentLayout::Graded { count, ratio: 1.0 },
        ] {
            let params64 = reference_params::<f64>(layout);
            check_derived(&params64);
            let layout32 = match layout {
                SegmentLayout::Uniform { count } => SegmentLayout::Uniform { count },
                SegmentLayout::Graded { count, ratio } => SegmentLayout::Graded {
                    count,
                    ratio: ratio as f32,
                },
            };
            check_derived(&reference_params::<f32>(layout32));
        }
    }
}

#[test]
fn a_smaller_model_in_place_of_a_larger_one_leaves_no_trace() {
    let mut solver = Solver::new(
        Model::<f64, CAPACITY>::new(graded(CAPACITY, 1.1)).unwrap(),
        State::default(),
    )
    .unwrap();
    let params = graded::<f64>(4, 1.3);
    solver.configure(&params).unwrap();
    // Equal as a whole (the unused entries beyond the 4 segments included).
    assert_eq!(solver.model(), &Model::new(params).unwrap());
}

/// `Solver::steps` carries each step's end inputs to the next step's start: the
/// same bits as the steps one by one, through the snatch of the pull-up, in both
/// precisions.
fn steps_in_a_row_as_one_by_one<T: Real>() {
    let path = pull_up();
    let params = graded::<T>(12, 1.26);
    let mut one_by_one =
        Solver::new(Model::<T, CAPACITY>::new(params).unwrap(), State::default()).unwrap();
    let start = trim(one_by_one.model(), &FlightPath::<T>::state_at(&path, 0.0)).unwrap();
    one_by_one.set_state(start).unwrap();
    let mut in_a_row = one_by_one.clone();
    for frame in 0..150 {
        let count = 1 + frame % 4;
        let dt = 0.01 / f64::from(count);
        for _ in 0..count {
            one_by_one.step(&path, dt).unwrap();
        }
        in_a_row.steps(&path, dt, count).unwrap();
        assert_eq!(
            bits(in_a_row.state()),
            bits(one_by_one.state()),
            "frame {frame}"
        );
        let tension = |s: &mut Solver<T, CAPACITY>| s.outputs(&path).unwrap().connection_tension();
        assert_eq!(
            tension(&mut in_a_row).to_f64().to_bits(),
            tension(&mut one_by_one).to_f64().to_bits()
        );
    }
    // A rejected step ends the run where the one-by-one steps end it.
    let rejected = in_a_row.steps(&path, f64::NAN, 3);
    assert!(rejected.is_err());
    assert_eq!(bits(in_a_row.state()), bits(one_by_one.state()));
}

#[test]
fn steps_in_a_row_are_the_steps_one_by_one() {
    steps_in_a_row_as_one_by_one::<f32>();
    steps_in_a_row_as_one_by_one::<f64>();
}

/// `State::copy_used` into a zero state keeps every used value and the time,
/// and is the state to the bit for the solver.
#[test]
fn a_used_copy_is_the_state_for_the_solver() {
    let path = pull_up();
    let mut solver = Solver::new(
        Model::<f32, CAPACITY>::new(graded(12, 1.26)).unwrap(),
        State::default(),
    )
    .unwrap();
    let start = trim(solver.model(), &FlightPath::<f32>::state_at(&path, 0.0)).unwrap();
    solver.set_state(start).unwrap();
    solver.steps(&path, 0.0025, 8).unwrap();
    let mut copy = State::ZERO;
    copy.copy_used(solver.state(), 12);
    assert_eq!(&copy, solver.state());
    let mut restored = solver.clone();
    solver.steps(&path, 0.0025, 4).unwrap();
    restored.set_state(copy).unwrap();
    restored.steps(&path, 0.0025, 4).unwrap();
    assert_eq!(bits(restored.state()), bits(solver.state()));
}
