//! # decoy-controller: the onboard decoy controller
//!
//! The program the decoy controller runs, as a library with no hardware in it: the
//! firmware wraps it with a board (UART, clock), and the host runs the very same
//! code as its bit-exact reference (`decoy hil`, the HIL tests, the host bridge).
//!
//! - [`params`]: [`SystemParams`], the reference system as plain `Copy` numbers,
//!   and the one conversion from it to the solver's model, the geometry and the
//!   [`ControllerConfig`]. The host fills it from `decoy-config`; the firmware's
//!   build script does the same at build time and writes it as a constant.
//! - [`validate`]: the checks a State frame passes before it reaches the solver,
//!   including the physical bounds of every input.
//! - [`envelope`]: the operating envelope the controller guarantees (frames
//!   outside it are answered and flagged).
//! - [`limits`]: the manoeuvre envelope map on board ([`LimitMap`]): the
//!   limits each Output reports at the aircraft's flight condition.
//! - [`path`]: [`FramePath`], the flight path between two State frames.
//! - [`geometry`]: the flight-path frame and the clearances to the exhaust plume
//!   and the aircraft (the host's `decoy simulate` uses the same code).
//! - [`monitor`]: the decoy-management monitors (posture, collision, tension,
//!   exhaust): margins, levels with hysteresis, worst margins and counts.
//! - [`wave`]: the wave-speed step limit (the stepping rule's input), which the
//!   controller and the look-ahead share.
//! - [`lookahead`]: the prediction flown forward with the aircraft holding its
//!   manoeuvre, in fixed slices per frame.
//! - [`controller`]: [`Controller`], the pure state machine.
//! - [`serve`]: the controller's main loop over any byte link (`embedded-io`
//!   `Read + ReadReady + Write`) and [`serve::Clock`]: the firmware's loop, which a
//!   host test also runs against a loopback.
//!
//! The wire protocol is `decoy-link` (docs/protocol.md). `no_std`, no heap, no
//! `unsafe`; every transcendental function goes to `libm` (solver-core's maths), so
//! the host and the target compute the same bits in the same precision.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
// `!(x > 0)` is deliberate: it is true for NaN, which must fail the check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod builtin;
pub mod controller;
pub mod envelope;
pub mod geometry;
pub mod limits;
pub mod lookahead;
pub mod monitor;
pub mod params;
pub mod path;
pub mod serve;
pub mod validate;
pub mod wave;

pub use controller::{
    CONTROL_PERIOD_US, Controller, ControllerConfig, ControllerError, ControllerSnapshot,
    DECOY_NEAR_AIRCRAFT_M, HOST_MAX_STEPS_PER_FRAME, InstructionCounter,
    MAX_PROFILE_RATE_MILLI_RADPS, MAX_STEP_S, MAX_TIME_JUMP_S, NoCounter, PREDICTION_CAPACITY,
    SILENCE_MS, TIME_TOLERANCE_S, TRIM_SLICE_UNITS, TRIM_SLICE_UNITS_F64, trim_slice_units,
};
/// The requirements' list and container (`ManagementParams::thresholds` is a
/// [`PerRequirement`]; the firmware's generated `SYSTEM` names it).
pub use decoy_schema::{PerRequirement, Requirement};
pub use envelope::{EnvelopeParams, OperatingEnvelope};
pub use geometry::{Envelope, ExhaustPlume, FlightPathFrame, Geometry};
pub use limits::{
    LIMIT_AXIS_CAPACITY, LIMIT_CELL_CAPACITY, LimitGrid, LimitGridError, LimitMap, Limiting,
};
pub use lookahead::{HeldManoeuvre, Lookahead, Prediction};
pub use monitor::{ManagementConfig, ManagementParams, Measures, Monitors, Thresholds};
pub use params::{AeroRows, SystemParams};
pub use path::FramePath;
