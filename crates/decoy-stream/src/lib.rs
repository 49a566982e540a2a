//! # decoy-stream: streamed runs
//!
//! One pipeline for every run that streams a scenario's 10 ms aircraft state
//! frames to a decoy controller and compares its answers with the host's: the
//! plan and the frames from the scenario (`decoy simulate`'s flight profiles),
//! the flight through a [`Transport`], the replay of the same frames on the
//! host controller, the summary, the files (`timeseries.csv`, `summary.json`,
//! plots; docs/outputs.md) and the signals that stop it. Two devices use it:
//!
//! - [`hil`]: `decoy hil`, the firmware under QEMU over its UART (the
//!   transport is `decoy_hil::link::Session`);
//! - [`feed`]: `decoy feed`, a running host bridge (the transport is
//!   `host_bridge::client::BridgeClient`, lockstep or free-running).
//!
//! The transports are implemented here, on the two crates' own types, so that
//! neither depends on the other or on this pipeline: a Rust client of a bridge
//! compiles host-bridge alone, not decoy-sim, decoy-hil or the plotting.
//! [`qemu_backend`] is the bridge's qemu backend (the firmware under QEMU
//! behind a bridge), built as `decoy hil` builds its firmware.
//!
//! ## Layering
//!
//! Each module uses only modules on the lines above its own, so the module
//! graph has no cycle:
//!
//! 1. `signals` ([`signals::Interrupts`]: SIGINT and SIGTERM, also `decoy
//!    simulate`'s), `transport` (the traits), `files` (`timeseries.csv`, the
//!    samples, the instruction plot), `firmware` (the build a run needs);
//! 2. `uart`, `bridge` (the transports), `fly` (lockstep and free-running
//!    flights);
//! 3. `run` (the pipeline and its [`run::Device`] trait);
//! 4. `hil`, `feed`, `qemu_backend`.
#![deny(missing_docs)]

mod bridge;
pub mod feed;
pub mod files;
pub mod firmware;
pub mod fly;
pub mod hil;
pub mod qemu_backend;
pub mod run;
pub mod signals;
pub mod transport;
mod uart;

pub use transport::{FrameAnswer, FreeRunning, Transport};
