//! The reference towed-decoy system, the project's built-in configuration.
//!
//! `build.rs` reads `config/reference-system.toml` and the aerodynamic table it
//! names with `decoy-config` (the host's reader and validation) and embeds the
//! resulting [`SystemParams`] as postcard bytes; the firmware decodes them at boot
//! and builds everything from them with the host's own conversion.

use decoy_controller::SystemParams;

/// `SystemParams` of `config/`, postcard-encoded by `build.rs`.
static SYSTEM_POSTCARD: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/system.postcard"));

/// The reference system's parameters.
pub fn system() -> Result<SystemParams, postcard::Error> {
    postcard::from_bytes(SYSTEM_POSTCARD)
}
