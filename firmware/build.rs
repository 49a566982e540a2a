//! Build script of the firmware.
//!
//! 1. Links the board's memory map: copies `memory-mps2.x` to `OUT_DIR` as
//!    `memory.x`, where cortex-m-rt's `link.x` finds it. (A `memory.x` in the crate
//!    root would silently win over `OUT_DIR`, so there is none.)
//! 2. Passes the linker scripts (`-Tlink.x`, and `-Tdefmt.x` for defmt) from here
//!    rather than from `rustflags`, so that a `RUSTFLAGS` in the environment (for
//!    example `-C target-cpu=cortex-m7`) cannot drop them.
//! 3. Reads the project's configuration `../config/reference-system.toml` (and the
//!    aerodynamic table it names) with `decoy-config`, the host's own reader and
//!    validation, and writes its [`decoy_controller::SystemParams`] to
//!    `OUT_DIR/system.postcard`, which the firmware embeds and decodes at boot.
//!    The firmware then builds its controller with the same conversion the host
//!    uses (`SystemParams::controller_config`), so host and target cannot drift.

use std::env;
use std::error::Error;
use std::fs;
use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;

/// The board's memory map (QEMU `mps2-an386`: 4 MiB flash at 0, 4 MiB RAM at 0x2000_0000).
const MEMORY_MAP: &str = "memory-mps2.x";
/// The reference system, relative to this crate.
const SYSTEM_TOML: &str = "../config/reference-system.toml";

type Result<T> = std::result::Result<T, Box<dyn Error>>;

fn main() -> Result<()> {
    let out = PathBuf::from(env::var_os("OUT_DIR").ok_or("OUT_DIR is not set")?);

    fs::copy(MEMORY_MAP, out.join("memory.x"))
        .map_err(|e| format!("cannot copy {MEMORY_MAP}: {e}"))?;
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={MEMORY_MAP}");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    // The same for the measurement examples (examples/step_cost.rs).
    println!("cargo:rustc-link-arg-examples=-Tlink.x");
    println!("cargo:rustc-link-arg-examples=-Tdefmt.x");
    // f64 runs in hardware only with the Cortex-M7's FPv5-D16.
    if env::var_os("CARGO_FEATURE_F64").is_some() {
        let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
        if !flags.contains("target-cpu=cortex-m7") {
            println!(
                "cargo:warning=feature `f64` without `-C target-cpu=cortex-m7`: f64 is software-emulated; build the M7 profile with `cargo build-m7`"
            );
        }
    }

    println!("cargo:rerun-if-changed={SYSTEM_TOML}");
    let system = SystemConfig::from_file(SYSTEM_TOML)?;
    let aero = Path::new(SYSTEM_TOML)
        .parent()
        .unwrap_or(Path::new("."))
        .join(&system.decoy.aero_table);
    println!("cargo:rerun-if-changed={}", aero.display());
    let params = system.params()?;
    let bytes = postcard::to_allocvec(&params)?;
    fs::write(out.join("system.postcard"), bytes)?;
    Ok(())
}
