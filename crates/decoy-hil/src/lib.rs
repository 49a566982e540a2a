//! # hil-tests: the firmware in the loop
//!
//! Host-side tools that build the decoy controller firmware (`firmware/`, a
//! workspace of its own), boot it under QEMU with deterministic instruction
//! counting (`-icount`), talk the decoy link (`decoy_link`) to it over its UART,
//! and compare its answers with the same controller run on the host. The
//! integration tests in `tests/` assert that; `decoy hil` ([`hil_run`]) is the
//! same run for people, with `decoy simulate`'s outputs.
//!
//! - [`qemu`]: run a program with a time limit, killed on timeout and on drop;
//!   the QEMU command line of the boards ([`qemu::Board`]: M4, M7).
//! - [`firmware`]: build the firmware (M4, M7, other segment counts), locate its
//!   ELF, read its memory use.
//! - [`serial`]: the UART's TCP listener (ephemeral port, accept with a deadline).
//! - [`link`]: [`link::Session`] (QEMU + link, killed on drop, defmt log shown
//!   when a test fails) and [`link::Link`] (frames with deadlines).
//! - [`defmt`]: decoding the firmware's defmt log with `defmt-print`.
//! - [`flight`]: scenario frames every 10 ms, lock-step flying, the host replay
//!   and the comparison.
//! - [`host`], [`reference`]: the host controller's configuration, and
//!   `hil-reference`, the host controller with the target's maths (bit for bit).
//! - [`hil_run`]: `decoy hil`.
//! - [`step_cost`]: the firmware's `examples/step_cost.rs`, the instructions of one
//!   RK4 step on the target.
#![deny(missing_docs)]

pub mod defmt;
pub mod firmware;
pub mod flight;
pub mod hil_run;
pub mod link;
pub mod qemu;
pub mod reference;
pub mod serial;
pub mod step_cost;
