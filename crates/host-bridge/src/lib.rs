//! # host-bridge: avionics simulations drive the decoy controller over iceoryx2
//!
//! The bridge's server and its client. `decoy bridge` serves one decoy
//! controller (a [`backend::Backend`]: the controller in this process, or the
//! firmware under QEMU over its UART, `decoy_stream::qemu_backend`) to any
//! number of clients over iceoryx2 shared memory; a client ([`client`]) drives
//! it (`decoy feed` is `decoy_stream::feed`, a client among others).
//! docs/bridge.md describes the services, the lockstep rule and the wire types
//! (crate `bridge-types`, which depends on nothing of the solver).
//!
//! A Rust program that only talks to a bridge depends on this crate alone: it
//! compiles nothing of the scenarios, the firmware's build, QEMU or the
//! plotting (`cargo xtask test`'s layering stage checks it). A bridge on a
//! thread for tests, benchmarks and examples is the crate `bridge-local`; the
//! CPU affinity (`--cpu`) the crate `cpu-affinity`.
//!
//! - [`services`]: the services of an instance, opened with the same settings by
//!   the bridge and its clients; the iceoryx2 configuration (prefix, root).
//! - [`convert`]: the one mapping between the wire types and the decoy link's
//!   messages (so validation is exactly the controller's).
//! - [`backend`]: the [`backend::Backend`] trait and the host backend.
//! - [`bridge`]: the bridge's event loop (a WaitSet: no busy loop), counters,
//!   health, status, summary.
//! - [`client`]: a client (lockstep with a deadline, free-running, commands,
//!   outputs, status).
//! - [`remote`]: the bridge across hosts over Zenoh: key expressions, tags,
//!   configuration rules, a client's transport.
//! - [`gateway`]: the bridge's end across hosts (a client of its own
//!   shared-memory services).
//! - [`timing`]: durations in a fixed histogram (the service times, the
//!   benchmark's round trips): bounded memory however long a bridge runs;
//!   their percentiles.
#![deny(missing_docs)]

pub mod backend;
pub mod bridge;
pub mod client;
pub mod convert;
pub mod gateway;
pub mod remote;
pub mod services;
pub mod timing;

use std::fmt;

/// Why the bridge or a client failed.
#[derive(Debug)]
pub enum BridgeError {
    /// Bad options or configuration (exit code 2).
    Usage(String),
    /// iceoryx2 failed.
    Ipc(String),
    /// No bridge with that instance name is running.
    NoBridge(String),
    /// The bridge did not answer in time.
    NoAnswer(String),
    /// The backend failed (QEMU, the firmware link).
    Backend(String),
    /// The other end speaks another protocol: a payload's type tag or size is
    /// not this build's (over Zenoh; over shared memory iceoryx2 refuses the
    /// port).
    Protocol(String),
}

impl BridgeError {
    /// Whether the input must change (exit code 2) rather than the run failing (1).
    pub fn is_usage(&self) -> bool {
        matches!(self, BridgeError::Usage(_))
    }
}

impl fmt::Display for BridgeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BridgeError::Usage(m)
            | BridgeError::Ipc(m)
            | BridgeError::NoBridge(m)
            | BridgeError::NoAnswer(m)
            | BridgeError::Backend(m)
            | BridgeError::Protocol(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for BridgeError {}
