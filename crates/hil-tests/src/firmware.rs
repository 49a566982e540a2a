//! Building the firmware and reading its ELF.
//!
//! The firmware is a Cargo workspace of its own (`firmware/`, target
//! `thumbv7em-none-eabihf`, set in `firmware/.cargo/config.toml`). It is built with
//! the toolchain `cargo xtask setup` chose: the rustup toolchain, or, when
//! `target/xtask-toolchain` says `debian`, Debian's compiler with `core` built from
//! source (see `/work/shared/TOOLCHAIN.md`).

use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use object::{Object, ObjectSection, SectionFlags, SectionKind};

use crate::qemu::{Captured, RunError, run_with_timeout};

/// The bare-metal target of the firmware.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The firmware's binary name.
pub const BINARY: &str = "decoy-firmware";

/// The repository root (the root workspace's directory).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// The firmware workspace.
pub fn firmware_dir() -> PathBuf {
    workspace_root().join("firmware")
}

/// The release ELF that [`build_release`] produces.
pub fn release_elf() -> PathBuf {
    firmware_dir()
        .join("target")
        .join(TARGET)
        .join("release")
        .join(BINARY)
}

/// Why the firmware could not be built.
#[derive(Debug)]
pub enum BuildError {
    /// Cargo could not be run, or ran out of time.
    Run(RunError),
    /// Cargo ran and failed.
    Failed(Captured),
    /// Cargo succeeded but the ELF is not where expected.
    MissingElf(PathBuf),
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::Run(e) => write!(f, "building the firmware: {e}"),
            BuildError::Failed(out) => write!(
                f,
                "the firmware build failed (run `cargo xtask setup` if the target is missing)\n{}",
                out.describe()
            ),
            BuildError::MissingElf(path) => {
                write!(
                    f,
                    "the firmware build succeeded but {} does not exist",
                    path.display()
                )
            }
        }
    }
}

impl std::error::Error for BuildError {}

/// How `cargo xtask setup` said target code must be built.
fn debian_toolchain() -> bool {
    fs::read_to_string(workspace_root().join("target").join("xtask-toolchain"))
        .is_ok_and(|mode| mode.trim() == "debian")
}

/// The `cargo build --release` command of the firmware.
///
/// It runs in `firmware/` so that `firmware/.cargo/config.toml` (target, linker
/// script, runner) applies, with `--manifest-path` for clarity. Variables that
/// would override that configuration when inherited from an outer `cargo test`
/// (`RUSTFLAGS`, a shared target directory, a build target) are removed.
pub fn build_command() -> Command {
    let dir = firmware_dir();
    let manifest = dir.join("Cargo.toml");
    let mut cmd = if debian_toolchain() {
        let mut cmd = Command::new("rustup");
        cmd.args(["run", "debian", "cargo", "build", "--release"])
            .args([
                "-Z",
                "build-std=core,compiler_builtins",
                "-Z",
                "build-std-features=compiler-builtins-mem",
            ])
            .env("RUSTC_BOOTSTRAP", "1");
        cmd
    } else {
        let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
        cmd.args(["build", "--release"]);
        cmd
    };
    cmd.arg("--manifest-path").arg(manifest).current_dir(&dir);
    for var in [
        "RUSTFLAGS",
        "CARGO_ENCODED_RUSTFLAGS",
        "CARGO_BUILD_RUSTFLAGS",
        "CARGO_BUILD_TARGET",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET_DIR",
    ] {
        cmd.env_remove(var);
    }
    cmd
}

/// Builds the firmware in release mode within `timeout` and returns its ELF.
pub fn build_release(timeout: Duration) -> Result<PathBuf, BuildError> {
    let out = run_with_timeout(
        &mut build_command(),
        timeout,
        "cargo is not on PATH; install Rust with rustup",
    )
    .map_err(BuildError::Run)?;
    if !out.status.success() {
        return Err(BuildError::Failed(out));
    }
    let elf = release_elf();
    if elf.is_file() {
        Ok(elf)
    } else {
        Err(BuildError::MissingElf(elf))
    }
}

/// Static memory of an ELF, as `size` (Berkeley format) counts it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryUsage {
    /// Read-only allocated sections: code, constants, vector table (flash), bytes.
    pub text: u64,
    /// Initialised writable sections (flash image, copied to RAM), bytes.
    pub data: u64,
    /// Zero-initialised and uninitialised writable sections (RAM), bytes.
    pub bss: u64,
}

impl MemoryUsage {
    /// Flash used: `.text` + `.data`'s load image.
    pub fn flash(&self) -> u64 {
        self.text + self.data
    }

    /// Static RAM used: `.data` + `.bss` (the stack comes on top).
    pub fn ram(&self) -> u64 {
        self.data + self.bss
    }
}

impl fmt::Display for MemoryUsage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "text {} B, data {} B, bss {} B (flash {} B, static RAM {} B)",
            self.text,
            self.data,
            self.bss,
            self.flash(),
            self.ram()
        )
    }
}

/// Reads the allocated sections of the ELF at `path`.
pub fn memory_usage(path: &Path) -> Result<MemoryUsage, String> {
    let bytes = fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut usage = MemoryUsage::default();
    for section in file.sections() {
        let SectionFlags::Elf { sh_flags } = section.flags() else {
            continue;
        };
        let alloc = sh_flags & u64::from(object::elf::SHF_ALLOC) != 0;
        if !alloc {
            continue;
        }
        let write = sh_flags & u64::from(object::elf::SHF_WRITE) != 0;
        let zero_fill = matches!(
            section.kind(),
            SectionKind::UninitializedData | SectionKind::UninitializedTls
        );
        let size = section.size();
        match (write, zero_fill) {
            (_, true) => usage.bss += size,
            (true, false) => usage.data += size,
            (false, false) => usage.text += size,
        }
    }
    Ok(usage)
}
