//! # solver-core: towed-decoy cable dynamics
//!
//! The cable is N rigid rods on spherical hinges, the decoy a rigid body hinged to
//! the last rod, the aircraft's motion prescribed (docs/design.md §1-2). The hinge
//! forces come from the tension recurrence solved as a stable block LDLᵀ two-sweep
//! elimination with 3x3 blocks (§3), the state advances by fixed-step RK4 with
//! renormalisation (§4), and simulations start from trim (§5).
//!
//! `no_std`, no heap, no `unsafe`, capacity `N` fixed at compile time, generic over
//! `f32` and `f64`. The `std` feature adds only host conveniences: the dense
//! mass-matrix reference solver ([`dense`]) used by tests and benchmarks.
//!
//! Frames, units and signs: SI units; world frame flat-earth NED (z down, altitude
//! = -z); body frames FRD; quaternions Hamilton, scalar first, body to NED. Joint 0
//! is the connection point on the aircraft, joint N the towing point on the decoy;
//! segment i runs from joint i-1 to joint i. T_j is the force the upstream body
//! exerts on the downstream one at joint j.
//!
//! ```
//! use solver_core::{reference_pendulum, AircraftState, Solver, Uniform, Vec3};
//! let model = reference_pendulum::<f64, 8>(8).unwrap();
//! let state = solver_core::pendulum_initial_state::<f64, 8>(8);
//! let mut solver = Solver::new(model, state).unwrap();
//! let anchor = Uniform { initial: AircraftState::fixed(Vec3::zeros()) };
//! for _ in 0..100 {
//!     solver.step(&anchor, 1e-3).unwrap();
//! }
//! let out = solver.outputs(&anchor).unwrap();
//! assert!(out.connection_tension() > 0.0);
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
// `!(x > 0)` is deliberate throughout: it is true for NaN, which must fail the check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Index loops over parallel per-segment arrays read like the recurrences they implement.
#![allow(clippy::needless_range_loop)]

pub mod aero;
pub mod atmosphere;
#[cfg(feature = "std")]
pub mod dense;
pub mod dynamics;
pub mod error;
pub mod model;
pub mod motion;
pub mod pendulum;
pub mod profiles;
pub mod rk4;
pub mod scalar;
pub mod solver;
pub mod state;
pub mod trim;

pub use aero::{AeroCoefficients, AeroTable};
pub use atmosphere::{AirColumn, AirProperties, Atmosphere, DensityLaw};
pub use dynamics::{TensionMethod, Workspace};
pub use error::{AeroTableError, AtmosphereError, ConfigError, InputError, SolveError, TrimError};
pub use model::{
    CableParams, DecoyParams, EndBody, Environment, Model, ModelParams, SegmentLayout,
};
pub use motion::{AircraftState, FlightPath, NodePath, PointKinematics, Uniform};
pub use pendulum::{pendulum_energy, pendulum_initial_state, reference_pendulum};
pub use rk4::{DerivativeSource, Rk4};
pub use scalar::{Mat3, Real, Vec3};
pub use solver::{CheckedStep, DecoyOutputs, Outputs, Solver, StepError, WAVE_STEP_FACTOR};
pub use state::{Derivative, State};
pub use trim::{TrimTask, trim};
