//! # decoy-hil: the firmware in the loop
//!
//! The library that builds (or is given) the decoy controller firmware
//! (`firmware/`, a workspace of its own), boots it under QEMU with deterministic
//! instruction counting (`-icount`), talks the decoy link (`decoy_link`) to it over
//! its UART, and compares its answers with the same controller
//! (`decoy_controller`) run on the host. `decoy hil` (`decoy_stream::hil`), the
//! bridge's qemu backend (`decoy_stream::qemu_backend`), the benches' firmware
//! rows and the HIL tests (`crates/hil-tests`, which holds only tests) use it.
//!
//! - [`budgets`]: the requirements the firmware is held to (frame, RK4 step,
//!   management, RAM, accuracy), each with the issue it comes from.
//! - [`qemu`]: run a program with a time limit, killed on timeout and on drop;
//!   the QEMU command line of the boards ([`qemu::Board`], the boards of
//!   `firmware/boards.toml` through the crate `decoy-boards`).
//! - [`firmware`]: find the firmware's source (the checkout `decoy` was built
//!   from, or `$DECOY_SOURCE_DIR`), build it (each board's build as the table
//!   says, other segment counts), locate or check an ELF, read its memory use.
//! - [`serial`]: the UART's TCP listener (ephemeral port, accept with a deadline).
//! - [`link`]: [`link::Session`] (QEMU + link, killed on drop, defmt log shown
//!   when a test fails) and [`link::Link`] (frames with deadlines).
//! - [`defmt`]: decoding the firmware's defmt log with `defmt-print`.
//! - [`flight`]: scenario frames every 10 ms, lock-step flying, the host replay
//!   and the comparison.
//! - [`reference`]: the host reference, the firmware's controller in this process
//!   in the firmware's precision; every build computes the target's maths (libm),
//!   so its answers equal the firmware's bit for bit.
//! - [`step_cost`]: the firmware's `examples/step_cost.rs`, the instructions of one
//!   RK4 step on the target.
#![deny(missing_docs)]

pub mod budgets;
pub mod defmt;
pub mod firmware;
pub mod flight;
pub mod link;
pub mod panic_sites;
pub mod qemu;
pub mod reference;
pub mod serial;
pub mod step_cost;
pub mod sweep;
