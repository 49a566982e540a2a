//! # bridge-types: the host bridge's wire types
//!
//! The payloads of the iceoryx2 services of `decoy bridge` (docs/bridge.md, the
//! one description of the services). Every type is `#[repr(C)]`, plain numbers
//! with no pointers and **no implicit padding** (every gap is an explicit
//! `reserved` field, zero on send), `ZeroCopySend`, and carries a fixed iceoryx2
//! type name with the bridge protocol version in it (`decoy.bridge.v4.Answer`):
//! iceoryx2 refuses to connect a port whose type name, size or alignment differ.
//! Every sample starts with a [`Header`] (protocol version, kind, sequence number).
//!
//! This crate depends on nothing of the solver, so any language can mirror it:
//! [`layouts`] describes every type (name, size, alignment, each field's name,
//! offset, size and element type), and `decoy bridge-layout --json` prints that
//! description as JSON (the Python mirror is checked against it).
//!
//! Units SI. World frame flat-earth NED (x north, y east, z down, altitude = -z);
//! body frames FRD; quaternions Hamilton, scalar first, body to NED; body rates in
//! the body frame (as `docs/protocol.md` and `docs/outputs.md`).
//!
//! ## Versions
//!
//! [`PROTOCOL_VERSION`] is in every header and in every type name. Any change of a
//! field, its order or meaning increments it and renames every type (`v1` to
//! `v2`; `v3` added the answer kind [`kind::INITIALISING`], `v4` the envelope map's limits in [`Output`]), so an old client
//! cannot open a new bridge's services by accident. Fields
//! are only ever appended at the end of [`Output`] (and so of [`Answer`]) or
//! [`Status`]; a client built from the layout JSON picks them up.
#![deny(missing_docs)]

mod layout;
mod wire;

pub use layout::{FieldLayout, LayoutDescription, RequirementLayout, TypeLayout, layouts};
pub use wire::*;

/// The bridge protocol version: in every [`Header`] and every type name.
pub const PROTOCOL_VERSION: u16 = 4;

/// The prefix of every service name: `decoy/<instance>/<service>`.
pub const SERVICE_ROOT: &str = "decoy";

/// The services of one bridge instance (the last part of their names).
pub mod service {
    /// Request-response, [`crate::AircraftState`] -> [`crate::Answer`]: lockstep.
    pub const LOCKSTEP: &str = "lockstep";
    /// Publish-subscribe of [`crate::AircraftState`]: free-running input.
    pub const STATE: &str = "state";
    /// Publish-subscribe of [`crate::Answer`]: every answer, for any listener.
    pub const OUTPUTS: &str = "outputs";
    /// Publish-subscribe of [`crate::Status`]: counters, health, model.
    pub const STATUS: &str = "status";
    /// Request-response, [`crate::Command`] -> [`crate::CommandReply`].
    pub const COMMANDS: &str = "commands";
    /// Event: clients notify the bridge (a request, a state sample, a command).
    pub const TO_BRIDGE: &str = "to-bridge";
    /// Event: the bridge notifies clients (an answer, an output, a status).
    pub const FROM_BRIDGE: &str = "from-bridge";
    /// Every service, in the order of docs/bridge.md.
    pub const ALL: [&str; 7] = [
        LOCKSTEP,
        STATE,
        OUTPUTS,
        STATUS,
        COMMANDS,
        TO_BRIDGE,
        FROM_BRIDGE,
    ];
}

/// The full name of `service` of bridge `instance`: `decoy/<instance>/<service>`.
pub fn service_name(instance: &str, service: &str) -> String {
    format!("{SERVICE_ROOT}/{instance}/{service}")
}

/// Event ids on the event services.
pub mod event {
    /// To the bridge: a lockstep request was sent.
    pub const REQUEST: usize = 1;
    /// To the bridge: a free-running state sample was published.
    pub const STATE: usize = 2;
    /// To the bridge: a command was sent.
    pub const COMMAND: usize = 3;
    /// From the bridge: a lockstep answer was sent, and its copy published on
    /// the outputs service (one notification for both).
    pub const ANSWER: usize = 11;
    /// From the bridge: answers to free-running samples were published on the
    /// outputs service.
    pub const OUTPUT: usize = 12;
    /// From the bridge: a status was published.
    pub const STATUS: usize = 13;
    /// From the bridge: a command reply was sent.
    pub const COMMAND_REPLY: usize = 14;
}

/// Lowest valid instance name length.
pub const INSTANCE_MIN_LEN: usize = 1;
/// Longest instance name (it is part of service and node names).
pub const INSTANCE_MAX_LEN: usize = 32;

/// Whether `name` can name an instance: 1 to 32 of `[A-Za-z0-9_-]`, so that it
/// fits every service and node name and never adds a path level.
pub fn valid_instance(name: &str) -> bool {
    (INSTANCE_MIN_LEN..=INSTANCE_MAX_LEN).contains(&name.len())
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
}
