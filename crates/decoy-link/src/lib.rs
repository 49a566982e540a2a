//! # decoy-link: the host <-> decoy-controller wire protocol
//!
//! The one crate both ends of the link use, so they cannot disagree. It is the
//! protocol only and depends on nothing of the solver (the controller that speaks
//! it is `decoy-controller`):
//!
//! - [`framing`]: `0x00, COBS(postcard(message) ++ crc32_le), 0x00` frames
//!   ([`encode`], [`Decoder`]), typed [`FrameError`]s, never a stall on garbage.
//! - [`messages`]: [`HostMessage`] (State frames, commands) and [`DeviceMessage`]
//!   (outputs, rejections, status, pong, hello), [`PROTOCOL_VERSION`].
//! - [`profile`]: [`Profile`], the streamed kinematics or a manoeuvre of
//!   `decoy_schema` flown built in.
//!
//! docs/protocol.md is the wire format's reference. `no_std`, no heap, no
//! `unsafe`; the `std` feature adds `framing::encode_vec` only.
//!
//! ```
//! use decoy_link::{encode, Command, FrameDecoder, HostMessage, MAX_WIRE_BYTES};
//! let mut wire = [0u8; MAX_WIRE_BYTES];
//! let n = encode(&HostMessage::Command(Command::Ping { nonce: 7 }), &mut wire).unwrap();
//! let mut decoder = FrameDecoder::new();
//! let mut got = None;
//! for &b in &wire[..n] {
//!     if let Some(frame) = decoder.push::<HostMessage>(b) {
//!         got = Some(frame.unwrap());
//!     }
//! }
//! assert_eq!(got, Some(HostMessage::Command(Command::Ping { nonce: 7 })));
//! ```
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
// `!(x > 0)` is deliberate: it is true for NaN, which must fail the check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod framing;
pub mod messages;
pub mod profile;

/// The requirements' list and container, from `decoy-schema` (the reports of
/// [`Management`] are a [`PerRequirement`]).
pub use decoy_schema::{PerRequirement, Requirement};
#[cfg(feature = "std")]
pub use framing::encode_vec;
pub use framing::{
    Decoder, EncodeError, FrameDecoder, FrameError, MAX_FRAME_BYTES, MAX_WIRE_BYTES, crc32, encode,
};
pub use messages::{
    Advisories, AircraftStateFrame, BOARD_NAME_CAPACITY, BoardInfo, BoardName, Command, Counters,
    DeviceMessage, Hello, HostMessage, Limits, Management, MonitorLevel, MonitorReport,
    OutputFrame, PROTOCOL_VERSION, Profile, RejectReason, Rejected, StatusFlags, StatusFrame,
    limited_by,
};
pub use profile::BuiltinProfile;
