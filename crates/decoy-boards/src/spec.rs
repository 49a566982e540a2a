//! [`BoardSpec`]: one row of the table, validated, and what the tools derive
//! from it (cargo arguments, target directories, `memory.x`, the ELF symbol).

use std::fmt;

use crate::{Build, Precision, SYMBOL_PREFIX, TABLE_PATH, TARGET};

/// A region of a memory map, bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// Its first address.
    pub origin: u64,
    /// Its length.
    pub length: u64,
}

/// The memory the firmware is linked for (cortex-m-rt's `memory.x`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryMap {
    /// Code and constants.
    pub flash: Region,
    /// Static data and the stack.
    pub ram: Region,
}

/// One board: a row of the table, validated.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BoardSpec {
    pub(crate) name: String,
    pub(crate) info: decoy_link::BoardInfo,
    pub(crate) label: String,
    pub(crate) summary: String,
    pub(crate) default: bool,
    pub(crate) module: String,
    pub(crate) advisory_line: bool,
    pub(crate) qemu: Vec<String>,
    pub(crate) feature: String,
    pub(crate) features: Vec<String>,
    pub(crate) hardware_features: Option<Vec<String>>,
    pub(crate) precision: Precision,
    pub(crate) target_cpu: Option<String>,
    pub(crate) ram_budget: u64,
    pub(crate) memory: MemoryMap,
}

impl BoardSpec {
    /// The board's name on the command line (`m4`), also its target directory's
    /// and its ELF symbol's.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The name the firmware gives itself in Hello (`mps2-an386`).
    pub fn hello(&self) -> &str {
        self.info.name.as_str()
    }

    /// The board as its firmware describes itself in Hello: its name and core
    /// clock.
    pub fn info(&self) -> decoy_link::BoardInfo {
        self.info
    }

    /// The core clock (SysTick's source), Hz.
    pub fn core_clock_hz(&self) -> u32 {
        self.info.core_clock_hz
    }

    /// The board's short name in reports (`M4`).
    pub fn label(&self) -> &str {
        &self.label
    }

    /// One line for `--help`.
    pub fn summary(&self) -> &str {
        &self.summary
    }

    /// Whether this is the default board: the firmware's default features build
    /// it, into Cargo's own target directory, and it is the CLI's default.
    pub fn is_default(&self) -> bool {
        self.default
    }

    /// The firmware's board module (`firmware/src/board/MODULE.rs`).
    pub fn module(&self) -> &str {
        &self.module
    }

    /// Whether the board drives the advisory line to the mission computer.
    pub fn advisory_line(&self) -> bool {
        self.advisory_line
    }

    /// QEMU's machine arguments (`-M`, and `-cpu` where the machine does not fix
    /// its CPU); [`crate::QEMU_COMMON_ARGS`] follow them.
    pub fn qemu_args(&self) -> &[String] {
        &self.qemu
    }

    /// The board's own Cargo feature (`board-mps2-an386`).
    pub fn feature(&self) -> &str {
        &self.feature
    }

    /// The environment variable Cargo sets for a build script when the board's
    /// feature is on (`CARGO_FEATURE_BOARD_MPS2_AN386`).
    pub fn feature_env(&self) -> String {
        feature_env(&self.feature)
    }

    /// The Cargo features of `build` (with `--no-default-features`); `None` if
    /// the board has no such build.
    pub fn features(&self, build: Build) -> Option<&[String]> {
        match build {
            Build::Qemu => Some(&self.features),
            Build::Hardware => self.hardware_features.as_deref(),
        }
    }

    /// The board's builds: the QEMU build, then the hardware build if it has one.
    pub fn builds(&self) -> impl Iterator<Item = Build> + '_ {
        [Build::Qemu, Build::Hardware]
            .into_iter()
            .filter(|&b| self.features(b).is_some())
    }

    /// The solver's precision on this board (feature `f64` or not).
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// `-C target-cpu=...` of both builds, if any.
    pub fn target_cpu(&self) -> Option<&str> {
        self.target_cpu.as_deref()
    }

    /// The RAM the firmware may use at its peak (static RAM and the stack's
    /// deepest), bytes.
    pub fn ram_budget(&self) -> u64 {
        self.ram_budget
    }

    /// The memory map the firmware is linked for.
    pub fn memory(&self) -> MemoryMap {
        self.memory
    }

    /// The rustflags of the board's builds (`-C target-cpu=...`, or none).
    pub fn rustflags(&self) -> Vec<String> {
        match &self.target_cpu {
            Some(cpu) => vec!["-C".to_owned(), format!("target-cpu={cpu}")],
            None => Vec::new(),
        }
    }

    /// The cargo arguments that configure `build` of the firmware (after
    /// `cargo build --release` or `cargo clippy --release`, before any
    /// `--target-dir`): `--no-default-features --features ...` and, with a
    /// target CPU, the rustflags as `--config` (so that a `RUSTFLAGS` elsewhere
    /// does not replace them); `None` if the board has no such build.
    pub fn cargo_args(&self, build: Build) -> Option<Vec<String>> {
        let features = self.features(build)?;
        let mut args = vec![
            "--no-default-features".to_owned(),
            "--features".to_owned(),
            features.join(","),
        ];
        let flags = self.rustflags();
        if !flags.is_empty() {
            let quoted: Vec<String> = flags.iter().map(|f| format!("\"{f}\"")).collect();
            args.push("--config".to_owned());
            args.push(format!("target.{TARGET}.rustflags=[{}]", quoted.join(", ")));
        }
        Some(args)
    }

    /// The target directory of `build` under `firmware/`: `None` for Cargo's own
    /// `target/` (the default board's QEMU build, what a plain `cargo build
    /// --release` builds), `target/NAME` for another board's QEMU build,
    /// `target/NAME-hw` for a hardware build. Each build has its own, so that
    /// they do not rebuild each other.
    pub fn target_subdir(&self, build: Build) -> Option<String> {
        match build {
            Build::Qemu if self.default => None,
            Build::Qemu => Some(format!("target/{}", self.name)),
            Build::Hardware => Some(format!("target/{}-hw", self.name)),
        }
    }

    /// The name of the absolute symbol the firmware's build script defines in
    /// the board's ELF (`_decoy_board_m4`).
    pub fn symbol(&self) -> String {
        format!("{SYMBOL_PREFIX}{}", self.name)
    }

    /// The board's memory map as cortex-m-rt's `memory.x`.
    pub fn memory_x(&self) -> String {
        let region = |name: &str, r: Region| {
            format!(
                "  {name:<5} : ORIGIN = {:#010x}, LENGTH = {}\n",
                r.origin,
                linker_size(r.length)
            )
        };
        format!(
            "/* @generated by firmware/build.rs from {TABLE_PATH} (board `{}`); do not edit. */\n\
             MEMORY\n{{\n{}{}}}\n",
            self.name,
            region("FLASH", self.memory.flash),
            region("RAM", self.memory.ram)
        )
    }
}

impl fmt::Display for BoardSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name)
    }
}

/// The environment variable Cargo sets for a build script when `feature` is on.
pub fn feature_env(feature: &str) -> String {
    format!(
        "CARGO_FEATURE_{}",
        feature.to_ascii_uppercase().replace('-', "_")
    )
}

/// `bytes` as a linker script writes a length: `4M`, `128K`, or the number.
fn linker_size(bytes: u64) -> String {
    const KIB: u64 = 1024;
    const MIB: u64 = 1024 * 1024;
    if bytes > 0 && bytes.is_multiple_of(MIB) {
        format!("{}M", bytes / MIB)
    } else if bytes > 0 && bytes.is_multiple_of(KIB) {
        format!("{}K", bytes / KIB)
    } else {
        bytes.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_as_a_linker_script_writes_them() {
        assert_eq!(linker_size(4 * 1024 * 1024), "4M");
        assert_eq!(linker_size(128 * 1024), "128K");
        assert_eq!(linker_size(1000), "1000");
    }
}
