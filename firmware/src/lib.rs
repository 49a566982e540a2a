//! # decoy-firmware: the decoy controller on a Cortex-M
//!
//! The library the firmware's binaries share: the board ([`board`], chosen by
//! feature), the advisory line's logic ([`advisory`]), the reference system embedded at build time ([`reference`]), the
//! solver's precision ([`Scalar`], feature `f64`) and capacity. The application
//! itself is `decoy_controller` (the controller and its serve loop); the binaries
//! (`src/main.rs`, `examples/step_cost.rs`) are thin.
#![no_std]
#![deny(missing_docs)]

pub mod advisory;
pub mod board;
pub mod reference;

/// The solver's scalar: f32 (the Cortex-M4F's FPU), the default.
#[cfg(not(feature = "f64"))]
pub type Scalar = f32;
/// The solver's scalar: f64 (feature `f64`, for the Cortex-M7's FPv5-D16).
#[cfg(feature = "f64")]
pub type Scalar = f64;

include!(concat!(env!("OUT_DIR"), "/capacity.rs"));
