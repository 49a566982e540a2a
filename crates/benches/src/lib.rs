//! # benches: wall-clock benchmarks of solver-core
//!
//! Shared fixtures for the criterion benchmarks (`benches/rk4_step.rs`) and the
//! criterion-free step timer (`src/bin/step_time.rs`):
//!
//! - the compound pendulum ([`pendulum_solver`]) hinged to a fixed anchor
//!   ([`fixed_anchor`]), stepped with [`PENDULUM_DT`];
//! - the reference towed system ([`reference_params`], the built-in
//!   configuration from `decoy-config`), trimmed in
//!   steady level flight at [`CRUISE_ALTITUDE`] and [`CRUISE_MACH`]
//!   ([`towed_solver`], [`cruise_path`]), stepped with [`TOWED_DT`]; and its
//!   scaling series with N uniform segments ([`towed_uniform_solver`]), stepped with
//!   [`TOWED_SCALING_DT`];
//! - RK4 steps with the reference derivatives, shooting and dense ([`stepper`]:
//!   solver-core's `Rk4` with another derivative source), and
//!   one derivative evaluation taken apart into its passes ([`passes`]).
//!
//! Run the benchmarks with
//! `cargo bench -p benches --bench rk4_step -- --warm-up-time 1 --measurement-time 3`
//! and the quick check with `cargo run --release -p benches --bin step_time`.
//!
//! [`report`] turns the results of one run into `docs/benchmarks.md` (the
//! `bench-report` binary, run by `cargo xtask bench-report`).
//!
//! Benchmark names (stable, quoted in the docs; defined once in [`names`], which
//! the benchmarks and the report share):
//! `pendulum_rk4_step/{f64,f32,shooting,dense}/{N}`,
//! `towed_rk4_step/{f32,f64}/graded16`,
//! `towed_rk4_step/{f64,f32,shooting,dense}/uniform{N}`,
//! `tension_solve/{two_sweep,shooting,dense}/{N}`,
//! `eval_breakdown/{f64,f32}_{graded16,uniform300}/{pass}` (criterion; the gungraun
//! names are listed in `benches/instructions.rs`).

pub mod names;
pub mod passes;
pub mod report;
pub mod stepper;

use solver_core::{
    AircraftState, Atmosphere, Model, ModelParams, Real, SegmentLayout, Solver, Uniform, Vec3,
    pendulum_initial_state, reference_pendulum, trim,
};

/// Time step of the pendulum benchmarks, s.
pub const PENDULUM_DT: f64 = 1e-4;
/// Time step of the towed-system benchmarks, s.
pub const TOWED_DT: f64 = 1e-3;
/// Time step of the towed scaling series (uniform segments, up to 4096), s: small
/// enough that [`RESTART_STEPS`] steps from the trim stay finite at every size and
/// precision (the cost of a step does not depend on it).
pub const TOWED_SCALING_DT: f64 = 1e-5;
/// Steps between restorations of the initial state in the stepping benchmarks.
pub const RESTART_STEPS: u64 = 1000;
/// Flight altitude of the towed-system benchmarks, m.
pub const CRUISE_ALTITUDE: f64 = 9000.0;
/// Flight Mach number of the towed-system benchmarks.
pub const CRUISE_MACH: f64 = 0.8;
/// Segment count of the graded towed model.
pub const GRADED_COUNT: usize = 16;
/// Length ratio between neighbouring segments of the graded towed model.
pub const GRADED_RATIO: f64 = 1.3;

/// The reference towed system (the built-in configuration, `config/`) with the given
/// segment layout.
pub fn reference_params<T: Real>(layout: SegmentLayout<T>) -> ModelParams<T> {
    decoy_config::SystemConfig::builtin()
        .and_then(|config| config.model_params(layout))
        .expect("the built-in configuration is valid")
}

/// The 16-segment graded layout (ratio 1.3) of the towed benchmarks.
pub fn graded_layout<T: Real>() -> SegmentLayout<T> {
    SegmentLayout::Graded {
        count: GRADED_COUNT,
        ratio: T::lit(GRADED_RATIO),
    }
}

/// ISA speed of sound at `altitude` m, m/s.
pub fn speed_of_sound(altitude: f64) -> f64 {
    Atmosphere::<f64>::isa()
        .at(altitude)
        .expect("altitude inside the ISA model")
        .speed_of_sound
}

/// Cruise airspeed: Mach 0.8 at 9 km (ISA), m/s.
pub fn cruise_speed() -> f64 {
    CRUISE_MACH * speed_of_sound(CRUISE_ALTITUDE)
}

/// Steady level flight heading north at 9 km, Mach 0.8.
pub fn cruise_path<T: Real>() -> Uniform<T> {
    Uniform {
        initial: AircraftState::level(T::lit(CRUISE_ALTITUDE), T::lit(cruise_speed())),
    }
}

/// The pendulum's fixed anchor: an aircraft at rest at the origin.
pub fn fixed_anchor<T: Real>() -> Uniform<T> {
    Uniform {
        initial: AircraftState::fixed(Vec3::zeros()),
    }
}

/// Stack size of the threads [`on_large_stack`] starts, bytes.
const LARGE_STACK: usize = 256 << 20;

/// Runs `build` on a thread with a large stack and returns its result: building a
/// solver with a capacity of thousands of segments (trim, model, state, workspace
/// passed by value before they are boxed) takes more than the 8 MiB of the main
/// thread.
pub fn on_large_stack<R: Send>(build: impl FnOnce() -> R + Send) -> R {
    std::thread::scope(|scope| {
        std::thread::Builder::new()
            .stack_size(LARGE_STACK)
            .spawn_scoped(scope, build)
            .expect("spawn a thread to build the case")
            .join()
            .expect("building the case panicked")
    })
}

/// The compound pendulum with `count` rods (capacity `N`) in its initial state
/// (all rods at -60 degrees, at rest), boxed because large capacities are large.
pub fn pendulum_solver<T: Real, const N: usize>(count: usize) -> Box<Solver<T, N>> {
    on_large_stack(|| {
        let model = reference_pendulum::<T, N>(count).expect("pendulum model");
        let state = pendulum_initial_state::<T, N>(count);
        Box::new(Solver::new(model, state).expect("finite initial state"))
    })
}

/// The reference towed system with `layout` (capacity `N`), trimmed in the
/// [`cruise_path`] flight, boxed.
pub fn towed_solver<T: Real, const N: usize>(layout: SegmentLayout<T>) -> Box<Solver<T, N>> {
    on_large_stack(|| {
        let model = Model::<T, N>::new(reference_params(layout)).expect("reference towed model");
        let state = trim(&model, &cruise_path::<T>().initial).expect("trim at 9 km, Mach 0.8");
        Box::new(Solver::new(model, state).expect("finite trim state"))
    })
}

/// The reference towed system with `count` segments of equal length (capacity `N`),
/// trimmed in the [`cruise_path`] flight, boxed: the towed scaling series.
pub fn towed_uniform_solver<T: Real, const N: usize>(count: usize) -> Box<Solver<T, N>> {
    towed_solver::<T, N>(SegmentLayout::Uniform { count })
}
