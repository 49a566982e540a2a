//! # decoy-sim: towed-decoy flight simulations
//!
//! The main user job (`decoy simulate`): fly the aircraft through a scenario (the
//! paper's steady flight, acceleration, pull-up and turn, DESIGN.md §8, or a
//! recorded flight), integrate the towed system with the solver from the trim of
//! the initial flight condition, and report what onboard decoy management needs
//! (DESIGN.md §9): cable tensions, decoy attitude and position, the cable's
//! clearance to the exhaust plume and the decoy's to the aircraft.
//!
//! - [`Scenario`]: a scenario TOML file, or one of the shipped ones
//!   ([`BUILTIN_SCENARIOS`]); [`Scenario::plan`] checks it with the command line's
//!   overrides ([`RunOptions`]) into a [`RunPlan`].
//! - [`RecordedFlight`]: a recorded flight CSV, interpolated into a
//!   [`solver_core::FlightPath`].
//! - [`simulate`]: runs a plan and writes `timeseries.csv`, `cable.csv`,
//!   `summary.json` and the plots (columns and definitions in `docs/outputs.md`).
//! - [`trace()`]: the same run kept in memory (optionally from a perturbed trim),
//!   for the studies below.
//! - [`sweep`]: the paper's steady-flight sweeps (speed, altitude; Figs. 15-22)
//!   and the towing-point and CG settling sweeps (Figs. 23-24) (`decoy sweep`).
//! - [`study`]: the discretisation study (Figs. 13-14) and the choice of the
//!   embedded model (`decoy study discretisation`).
//! - [`report`]: `docs/paper-reproduction.md`, every claim of the paper against
//!   what the project computes (`decoy report`; outputs in `docs/sweeps.md`).
//!
//! Output frame: the *flight-path frame* ([`FlightPathFrame`]) at each instant,
//! origin at the aircraft reference point, x along the aircraft's velocity, y
//! horizontal to its right, z down perpendicular to both. Reported as *behind*
//! (= -x), *below* (= z) and *lateral*, positive to the left (= -y): the outside of
//! a right turn. In a left-turn scenario (negative `rate_radps`) lateral is
//! positive to the right, so that it is always positive toward the outside of the
//! scenario's turn.
//!
//! ```no_run
//! use decoy_config::SystemConfig;
//! use decoy_sim::{RunOptions, Scenario, simulate};
//! let config = SystemConfig::builtin()?;
//! let scenario = Scenario::load("acceleration")?;
//! let options = RunOptions { segments: Some(16), grading: Some(1.3), ..RunOptions::default() };
//! let run = simulate(&config, &scenario, &options, |_fraction| {})?;
//! println!("peak tension {} N", run.summary.max_tension_connection_n);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

pub mod error;
pub mod geometry;
mod plots;
pub mod profile;
pub mod recorded;
pub mod report;
pub mod run;
pub mod scenario;
pub mod study;
pub mod sweep;
pub mod trace;

pub use error::SimError;
pub use geometry::{Envelope, ExhaustPlume, FlightPathFrame};
pub use plots::{COMPARISON_PLOT_NAMES, PLOT_NAMES, write_comparison_plots};
pub use profile::FlightProfile;
pub use recorded::{RECORDED_COLUMNS, RecordedFlight, RecordedSample};
pub use run::{
    CABLE_HEADER, FinalValues, InitialState, RunOptions, RunOutput, Sample, Snapshot, StoppedAt,
    Summary, TIMESERIES_HEADER, describe_layout, format_time, format_value, simulate, summarize,
};
pub use scenario::{
    BUILTIN_SCENARIOS, RECORDED_EXAMPLE_CSV, RunPlan, Scenario, ScenarioKind, ScenarioOrigin,
};
pub use trace::{Start, Trace, TraceOptions, pitched_attitude, trace};
