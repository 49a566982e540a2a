//! # decoy-schema: the shared vocabulary, each fact once
//!
//! What several layers of the product must agree on, written down in one place:
//! the crates below the solver (the protocol `decoy-link`, the bridge's wire types
//! `bridge-types`) and above it (the controller, the simulation, the command line,
//! the Python client through `decoy bridge-layout --json`) read it from here
//! instead of repeating it. `no_std`, no heap, no dependency but serde, nothing of
//! the solver, so that every layer may depend on it.
#![no_std]
#![deny(missing_docs)]

pub mod requirement;
pub use requirement::{PerRequirement, REQUIREMENT_COUNT, Requirement};

pub mod columns;
pub use columns::{CSV_FILES, Column, CsvFile, Quantity};

#[cfg(test)]
mod docs;
pub mod manoeuvre;
pub mod precision;
pub use manoeuvre::{
    BUILTIN_ALTITUDE_M, BuiltinFlight, Manoeuvre, ManoeuvreInfo, Need, Parameter,
    STREAMED_PROFILE_CODE,
};
pub use precision::Precision;
