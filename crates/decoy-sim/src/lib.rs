//! # decoy-sim: towed-decoy flight simulations
//!
//! The main user job (`decoy simulate`): fly the aircraft through a scenario (the
//! paper's steady flight, acceleration, pull-up and turn, docs/design.md §8, or a
//! recorded flight), integrate the towed system with the solver from the trim of
//! the initial flight condition, and report what onboard decoy management needs
//! (docs/design.md §9): cable tensions, decoy attitude and position, the cable's
//! clearance to the exhaust plume and the decoy's to the aircraft.
//!
//! - [`Scenario`]: a scenario TOML file, or one of the shipped ones
//!   ([`BUILTIN_SCENARIOS`]); [`Scenario::plan`] checks it with the command line's
//!   overrides ([`RunOptions`]) into a [`RunPlan`].
//! - [`RecordedFlight`]: a recorded flight CSV, interpolated into a
//!   [`solver_core::FlightPath`].
//! - [`simulate`]: runs a plan and writes `timeseries.csv`, `cable.csv`,
//!   `summary.json` and the plots (columns and definitions in `docs/outputs.md`);
//!   [`simulate_until`] stops at the step a caller's stop request (the command
//!   line's SIGINT or SIGTERM) comes. [`clear_output_dir`] makes an output
//!   directory hold one run's files only (every command that writes one calls
//!   it), and every file is written whole (`decoy_plots::atomic`).
//!   [`simulate_recorded`] keeps the same run's rows and snapshots in memory
//!   and writes its files only to a directory it is given (the `decoy` Python
//!   package, `crates/decoy-py`).
//! - [`trace()`]: the same run kept in memory (optionally from a perturbed trim),
//!   for the studies (crate `decoy-studies`: the sweeps, the discretisation
//!   study and the paper reproduction report, built on these runs).
//!
//! Output frame: the *flight-path frame* ([`FlightPathFrame`]) at each instant,
//! origin at the aircraft reference point, x along the aircraft's velocity, y
//! horizontal to its right, z down perpendicular to both. Reported as *behind*
//! (= -x), *below* (= z) and *lateral*, positive to the left (= -y): the outside of
//! a right turn. In a left-turn scenario (negative `rate_radps`) lateral is
//! positive to the right, so that it is always positive toward the outside of the
//! scenario's turn.
//!
//! ## Layering
//!
//! Each module uses only modules on the lines above its own, so the module graph
//! has no cycle:
//!
//! 1. `error`, `format` (number and layout formats), `capacity` (the solver
//!    capacity chosen from the segment count), `geometry`, `options`
//!    ([`RunOptions`]), `flyable` (pull-ups and turns built over an onset,
//!    [`Flyable`]);
//! 2. `recorded` (recorded flights), `profile` ([`FlightProfile`]), `steps`
//!    (the step rule and the run's timeline, [`StepRule`], [`Timeline`]);
//! 3. `scenario` (scenario files and [`RunPlan`]), `trim` (the steady trim of
//!    one flight condition, `decoy trim`);
//! 4. `record` (the probe, running statistics and CSV rows of a run), then
//!    `summary` ([`Summary`], [`summarize`]);
//! 5. `plots`;
//! 6. `run` ([`simulate`]: the integration loop and the output directory);
//! 7. `trace` (a run in memory).
//!
//! ```no_run
//! use decoy_config::SystemConfig;
//! use decoy_sim::{RunOptions, Scenario, simulate};
//! let config = SystemConfig::builtin()?;
//! let scenario = Scenario::load("acceleration")?;
//! // The embedded model (the configuration's solver.segments_embedded, graded by
//! // solver.grading_ratio_embedded) instead of the host model's uniform segments.
//! let options = RunOptions {
//!     segments: Some(config.solver.segments_embedded),
//!     grading: Some(config.solver.grading_ratio_embedded),
//!     ..RunOptions::default()
//! };
//! let run = simulate(&config, &scenario, &options, |_fraction| {})?;
//! println!("peak tension {} N", run.summary.max_tension_connection_n);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

mod capacity;
pub mod error;
pub mod flyable;
pub mod format;
pub mod geometry;
pub mod management;
pub mod options;
pub mod pendulum;
mod plots;
pub mod profile;
pub mod record;
pub mod recorded;
pub mod run;
pub mod scenario;
pub mod steps;
pub mod summary;
pub mod trace;
pub mod trim;

/// Files written whole or not at all (`decoy-plots`' module, which every
/// output file of a run goes through).
pub use decoy_plots::atomic;
pub use error::SimError;
pub use flyable::{Flyable, FlyablePullUp, FlyableTurn};
pub use format::{Cell, csv_row, describe_layout, format_time, format_value, missing_cells};
pub use geometry::{Envelope, ExhaustPlume, FlightPathFrame};
pub use management::{ManagementSample, ManagementSummary, RequirementSummary};
pub use options::{InitialState, RunOptions};
pub use plots::{
    COMPARISON_PLOT_NAMES, PLOT_NAMES, management_panels, write_comparison_plots,
    write_management_plot,
};
pub use profile::FlightProfile;
pub use record::{Sample, Snapshot};
pub use recorded::{RECORDED_COLUMNS, RecordedFlight, RecordedSample};
pub use run::{
    FIRMWARE_LOG, INSTRUCTIONS_PLOT, Recording, RunOutput, clear_output_dir,
    known_output_file_names, output_file_names, simulate, simulate_recorded, simulate_until,
};
pub use scenario::{
    BUILTIN_SCENARIOS, RECORDED_EXAMPLE_CSV, RunPlan, Scenario, ScenarioKind, ScenarioOrigin,
};
pub use steps::{StepRule, Timeline};
pub use summary::{FinalValues, StepsTaken, StoppedAt, Summary, summarize};
pub use trace::{Start, Trace, TraceOptions, pitched_attitude, trace};
