//! # decoy-studies: the studies and the paper reproduction report
//!
//! What the project computes about the towed-decoy system beyond one run of a
//! scenario (that is `decoy-sim`, whose runs, trims, traces and formats these
//! studies are made of):
//!
//! - [`sweep`]: the paper's steady-flight sweeps (speed, altitude; Figs. 15-22),
//!   the towing-point and CG settling sweeps (Figs. 23-24), the pull-up rate
//!   limit for the exhaust plume and the towing-point limit against the decoy's
//!   static margin (`decoy sweep`).
//! - [`study`]: the discretisation study (Figs. 13-14) and the choice of the
//!   embedded model (`decoy study discretisation`).
//! - [`envelope`]: the manoeuvre envelope map over altitude x Mach (`decoy
//!   envelope`).
//! - [`onboard`]: the envelope map on board, the file the controller carries,
//!   written from maps (`decoy limits-table`).
//! - [`report`]: `docs/paper-reproduction.md`, every claim of the paper against
//!   what the project computes (`decoy report`; outputs in `docs/sweeps.md`).
//!
//! ## Layering
//!
//! Each module uses only modules on the lines above its own, so the module graph
//! has no cycle: `envelope` (on decoy-sim alone), `onboard` (on `envelope`), `sweep` (`mod.rs`: ranges and table/plot helpers; then
//! `steady`, `settling`, `pull_up`, `static_margin`), then `study`, then
//! `report` (`spec.rs`: what it flies, its options, claims and verdicts; `data`, `claims`,
//! `figures`, `render`; `mod.rs`: the entry point). Errors are decoy-sim's
//! [`decoy_sim::SimError`] (a failed point of a sweep is its
//! [`decoy_sim::SimError::AtPoint`]).
#![deny(missing_docs)]

pub mod envelope;
pub mod onboard;
pub mod report;
pub mod study;
pub mod sweep;
