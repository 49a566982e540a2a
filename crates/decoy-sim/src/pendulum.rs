//! `decoy pendulum`: the compound multi-pendulum validation case (N rods of 0.5 kg
//! and 0.1 m hinged at a fixed point, released at rest 60° from the vertical),
//! integrated by the solver (the O(N) recurrence) or by the dense mass-matrix
//! reference, both stepped by solver-core's one RK4, and sampled at given times.
//!
//! Frame of the samples: hinge at the origin, x horizontal, z up (the solver's NED
//! z is down); energy = kinetic + potential, zero at hinge height.

use serde::Serialize;
use solver_core::dense::{DenseDerivative, evaluate_dense};
use solver_core::motion::connection_and_air;
use solver_core::{
    AircraftState, Model, Rk4, Solver, State, Uniform, Vec3, pendulum_energy,
    pendulum_initial_state, reference_pendulum,
};

/// Segment capacity of the pendulum solver.
pub const PENDULUM_CAPACITY: usize = 512;
/// Relative tolerance for a sample time to be a whole number of time steps.
const TIME_MULTIPLE_TOLERANCE: f64 = 1e-9;
/// Most time steps a pendulum run may take.
const MAX_STEPS: f64 = 1e12;

/// How the pendulum's hinge forces are found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PendulumMethod {
    /// The O(N) two-sweep tension recurrence (the solver).
    Recurrence,
    /// The dense mass-matrix (Kane) reference, O(N^3) per evaluation.
    Dense,
}

/// A pendulum run: rods, interval, step, sample times, method.
#[derive(Clone, Debug, PartialEq)]
pub struct PendulumRequest {
    /// Number of rods.
    pub segments: usize,
    /// End of the simulated interval, s.
    pub t_end: f64,
    /// RK4 time step, s.
    pub dt: f64,
    /// Sample times, s: each a whole number of time steps, at most `t_end`.
    pub times: Vec<f64>,
    /// The hinge-force method.
    pub method: PendulumMethod,
}

/// One sample, in the pendulum's frame (hinge at the origin, x horizontal, z up).
#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct PendulumSample {
    /// Time, s.
    pub t: f64,
    /// Position of the free end, `[x, z]`, m.
    pub tip: [f64; 2],
    /// Magnitude of the hinge force on rod 1, N.
    #[serde(rename = "support_tension_N")]
    pub support_tension_n: f64,
    /// Kinetic plus potential energy (zero at hinge height), J.
    #[serde(rename = "energy_J")]
    pub energy_j: f64,
}

/// The run's samples, in the order of the requested times.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct PendulumReport {
    /// Number of rods.
    pub segments: usize,
    /// RK4 time step, s.
    pub dt: f64,
    /// The samples.
    pub samples: Vec<PendulumSample>,
}

/// Why a pendulum run could not be made.
#[derive(Debug, Clone, PartialEq)]
pub enum PendulumError {
    /// A bad request (the message names the argument).
    Usage(String),
    /// The solver failed (the message says where).
    Solver(String),
}

impl std::fmt::Display for PendulumError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PendulumError::Usage(m) | PendulumError::Solver(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for PendulumError {}

type PendulumState = State<f64, PENDULUM_CAPACITY>;
type PendulumModel = Model<f64, PENDULUM_CAPACITY>;

/// Tip, support tension, energy at a sample.
type SampleValues = ([f64; 2], f64, f64);

fn usage(message: impl Into<String>) -> PendulumError {
    PendulumError::Usage(message.into())
}

fn solver_failure(context: &str, e: impl std::fmt::Display) -> PendulumError {
    PendulumError::Solver(format!("{context}: {e}"))
}

fn step_failure(t: f64, e: impl std::fmt::Display) -> PendulumError {
    PendulumError::Solver(format!(
        "integration failed in the step from t = {t} s: {e} (is --dt too large?)"
    ))
}

/// Runs the request.
pub fn run_pendulum(request: &PendulumRequest) -> Result<PendulumReport, PendulumError> {
    let steps = pendulum_steps(request)?;
    let n = request.segments;
    let model: PendulumModel = reference_pendulum(n).map_err(|e| usage(e.to_string()))?;
    let initial: PendulumState = pendulum_initial_state(n);
    let values = match request.method {
        PendulumMethod::Recurrence => integrate_recurrence(model, initial, request.dt, &steps)?,
        PendulumMethod::Dense => integrate_dense(&model, initial, request.dt, &steps)?,
    };
    let samples = request
        .times
        .iter()
        .zip(values)
        .map(|(&t, (tip, support_tension_n, energy_j))| PendulumSample {
            t,
            tip,
            support_tension_n,
            energy_j,
        })
        .collect();
    Ok(PendulumReport {
        segments: n,
        dt: request.dt,
        samples,
    })
}

/// Checks the request and returns the step count of each requested time.
fn pendulum_steps(args: &PendulumRequest) -> Result<Vec<u64>, PendulumError> {
    let n = args.segments;
    if n == 0 {
        return Err(usage("--segments must be at least 1"));
    }
    if n > PENDULUM_CAPACITY {
        return Err(usage(format!(
            "--segments {n}: the pendulum solver holds at most {PENDULUM_CAPACITY} segments"
        )));
    }
    if !(args.dt.is_finite() && args.dt > 0.0) {
        return Err(usage(format!(
            "--dt must be a positive finite number of seconds, got {}",
            args.dt
        )));
    }
    if !(args.t_end.is_finite() && args.t_end > 0.0) {
        return Err(usage(format!(
            "--t-end must be a positive finite number of seconds, got {}",
            args.t_end
        )));
    }
    if args.t_end / args.dt > MAX_STEPS {
        return Err(usage(format!(
            "--t-end / --dt asks for more than {MAX_STEPS:e} steps"
        )));
    }
    args.times
        .iter()
        .map(|&t| {
            if !t.is_finite() {
                return Err(usage(format!("--times: {t} is not a finite time")));
            }
            if t < 0.0 {
                return Err(usage(format!("--times: {t} is negative")));
            }
            if t > args.t_end {
                return Err(usage(format!(
                    "--times: {t} is beyond --t-end {}",
                    args.t_end
                )));
            }
            let steps = (t / args.dt).round();
            if (steps * args.dt - t).abs() > TIME_MULTIPLE_TOLERANCE * t.max(args.dt) {
                return Err(usage(format!(
                    "--times: {t} is not a whole number of time steps of --dt {}",
                    args.dt
                )));
            }
            Ok(steps as u64)
        })
        .collect()
}

/// Distinct step counts in increasing order, and for each requested time its index among them.
fn schedule(steps: &[u64]) -> (Vec<u64>, Vec<usize>) {
    let mut distinct = steps.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    let index = steps
        .iter()
        .map(|s| distinct.binary_search(s).unwrap_or(0))
        .collect();
    (distinct, index)
}

/// Runs `step` up to each distinct sample step count and records `sample` there;
/// returns the samples in the order of `steps`.
fn sample_run(
    steps: &[u64],
    mut step: impl FnMut() -> Result<(), PendulumError>,
    mut sample: impl FnMut() -> Result<SampleValues, PendulumError>,
) -> Result<Vec<SampleValues>, PendulumError> {
    let (distinct, index) = schedule(steps);
    let mut recorded = Vec::with_capacity(distinct.len());
    let mut done = 0u64;
    for &target in &distinct {
        while done < target {
            step()?;
            done += 1;
        }
        recorded.push(sample()?);
    }
    Ok(index.iter().map(|&i| recorded[i]).collect())
}

fn fixed_anchor() -> Uniform<f64> {
    Uniform {
        initial: AircraftState::fixed(Vec3::zeros()),
    }
}

/// The pendulum frame: x horizontal, z up (the solver's NED z is down).
fn pendulum_point(p: &Vec3<f64>) -> [f64; 2] {
    [p.x, -p.z]
}

fn integrate_recurrence(
    model: PendulumModel,
    initial: PendulumState,
    dt: f64,
    steps: &[u64],
) -> Result<Vec<SampleValues>, PendulumError> {
    let n = model.segment_count();
    let anchor = fixed_anchor();
    let solver = std::cell::RefCell::new(Box::new(
        Solver::new(model, initial).map_err(|e| solver_failure("initial state rejected", e))?,
    ));
    sample_run(
        steps,
        || {
            let mut solver = solver.borrow_mut();
            let t = solver.state().time;
            solver.step(&anchor, dt).map_err(|e| step_failure(t, e))
        },
        || {
            let mut solver = solver.borrow_mut();
            let energy = pendulum_energy(solver.model(), solver.state());
            let out = solver
                .outputs(&anchor)
                .map_err(|e| solver_failure("evaluation failed", e))?;
            Ok((
                pendulum_point(&out.joint_position(n)),
                out.joint_force(0).norm(),
                energy,
            ))
        },
    )
}

/// The dense reference stepped by the solver's RK4 (`solver_core::rk4::Rk4` with
/// `dense::DenseDerivative`): the same stages, weights and renormalisation as the
/// recurrence's solver; only the derivative differs.
fn integrate_dense(
    model: &PendulumModel,
    initial: PendulumState,
    dt: f64,
    steps: &[u64],
) -> Result<Vec<SampleValues>, PendulumError> {
    let n = model.segment_count();
    let anchor = fixed_anchor();
    let (connection, air) = connection_and_air(model, &anchor.initial)
        .map_err(|e| solver_failure("anchor rejected", e))?;
    let rk4 = std::cell::RefCell::new(Box::new(Rk4::new(initial)));
    sample_run(
        steps,
        || {
            let mut rk4 = rk4.borrow_mut();
            let t = rk4.state().time;
            rk4.step(&mut DenseDerivative::new(model, &anchor), dt, |_, _, _| {})
                .map_err(|e| step_failure(t, e))
        },
        || {
            let rk4 = rk4.borrow();
            let y = rk4.state();
            let solution = evaluate_dense(model, y, &connection, &air)
                .map_err(|e| solver_failure("dense evaluation failed", e))?;
            let tip = (0..n).fold(connection.position, |p, i| {
                p + y.directions[i] * model.lengths()[i]
            });
            Ok((
                pendulum_point(&tip),
                solution.joint_forces[0].norm(),
                pendulum_energy(model, y),
            ))
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(method: PendulumMethod) -> PendulumRequest {
        PendulumRequest {
            segments: 5,
            t_end: 0.1,
            dt: 1e-3,
            times: vec![0.1, 0.0, 0.05],
            method,
        }
    }

    #[test]
    fn samples_come_in_the_order_asked_and_both_methods_agree() {
        let a = run_pendulum(&request(PendulumMethod::Recurrence)).unwrap();
        let b = run_pendulum(&request(PendulumMethod::Dense)).unwrap();
        assert_eq!(
            a.samples.iter().map(|s| s.t).collect::<Vec<_>>(),
            [0.1, 0.0, 0.05]
        );
        for (x, y) in a.samples.iter().zip(&b.samples) {
            assert!((x.tip[0] - y.tip[0]).abs() < 1e-9 && (x.tip[1] - y.tip[1]).abs() < 1e-9);
            assert!((x.support_tension_n - y.support_tension_n).abs() < 1e-7);
        }
    }

    #[test]
    fn bad_requests_name_the_argument() {
        let mut r = request(PendulumMethod::Recurrence);
        r.times = vec![0.0005];
        match run_pendulum(&r) {
            Err(PendulumError::Usage(m)) => assert!(m.contains("--times"), "{m}"),
            other => panic!("{other:?}"),
        }
        r.segments = 0;
        assert!(matches!(run_pendulum(&r), Err(PendulumError::Usage(_))));
    }
}
