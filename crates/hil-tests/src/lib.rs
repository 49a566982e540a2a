//! # hil-tests: the firmware in the loop
//!
//! Host-side helpers that build the firmware (`firmware/`, a workspace of its own),
//! boot it on QEMU's Cortex-M4F board with deterministic instruction counting, and
//! read what it prints; the integration tests in `tests/` compare that with the
//! host solver.
//!
//! - [`qemu`]: run a program with a time limit, killed on timeout and on drop;
//!   the QEMU command line of the board.
//! - [`firmware`]: build the firmware (also with another segment count, for the
//!   benchmark report), locate its ELF, read its memory use.
//! - [`report`]: parse the firmware's semihosting output.
//! - [`scenario`]: the scenario the firmware runs (the same source file).
#![deny(missing_docs)]

pub mod defmt;
pub mod firmware;
pub mod flight;
pub mod hil_run;
pub mod host;
pub mod link;
pub mod qemu;
pub mod reference;
pub mod report;
pub mod serial;

// The firmware's own scenario module, compiled here unchanged, so that the host
// replays exactly the flight path and step sequence the target runs.
#[path = "../../../firmware/src/scenario.rs"]
pub mod scenario;
