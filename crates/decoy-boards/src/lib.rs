//! # decoy-boards: every board the firmware runs on, described once
//!
//! The table is `firmware/boards.toml` ([`TABLE_PATH`]), compiled into this crate
//! ([`TABLE_TEXT`]) and validated when it is first read ([`Table::builtin`]). A row
//! ([`BoardSpec`]) holds everything the rest of the project knows of a board: its
//! name on the command line, the name it gives itself in Hello and its core
//! clock, its label in reports, the firmware's board module, QEMU's machine
//! arguments, the Cargo features of its QEMU build and of its hardware build,
//! its `-C target-cpu`, its memory map and its RAM budget.
//!
//! Who reads it:
//!
//! - the firmware's build script (`firmware/build.rs`, a build-dependency): it
//!   selects the row whose Cargo feature is on ([`Table::select`], exactly one),
//!   writes its memory map as `memory.x` ([`BoardSpec::memory_x`]), its Hello name
//!   and clock as constants, chooses the board module and names the board in the
//!   ELF ([`BoardSpec::symbol`]);
//! - `decoy-hil`: QEMU's command line ([`BoardSpec::qemu_args`],
//!   [`QEMU_COMMON_ARGS`]), how to build each board's firmware
//!   ([`BoardSpec::cargo_args`], [`BoardSpec::target_subdir`]), Hello's expected
//!   name ([`BoardSpec::info`]), the RAM budget;
//! - the `decoy` CLI (`--board NAME`, validated against [`Board::all`]);
//! - xtask: the firmware's build and clippy stages, one per row and build,
//!   `cargo xtask firmware build|run|clippy --board NAME`, and the cargo runner,
//!   which finds the board of an ELF by its symbol (feature `elf`:
//!   [`Board::of_elf`]);
//! - the HIL tests, which take the boards of a role from here
//!   ([`Board::with_precision`], [`BoardSpec::advisory_line`]).
//!
//! [`Board`] is a copyable handle on a row of the compiled-in table, with the
//! lookups the tools need: [`Board::by_name`], [`Board::all`], [`Board::default`].

use std::fmt;

mod board;
#[cfg(feature = "elf")]
mod elf;
mod spec;
mod table;

pub use board::Board;
#[cfg(feature = "elf")]
pub use elf::ElfError;
pub use spec::{BoardSpec, MemoryMap, Region, feature_env};
pub use table::{Problem, SelectError, Table, TableError, UnknownBoard};

/// The firmware's bare-metal target, every board's (`firmware/.cargo/config.toml`
/// builds for it by default).
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// The table's path in the repository, for messages.
pub const TABLE_PATH: &str = "firmware/boards.toml";

/// The table's text, compiled in.
pub const TABLE_TEXT: &str = include_str!("../../../firmware/boards.toml");

/// QEMU's arguments every board boots with, after its machine arguments: no
/// display or monitor; semihosting on (the defmt logs and the exit code go to
/// the host); virtual time 1 ns per executed instruction, so SysTick counts
/// instructions deterministically.
pub const QEMU_COMMON_ARGS: &[&str] = &[
    "-display",
    "none",
    "-monitor",
    "none",
    "-semihosting-config",
    "enable=on,target=native",
    "-icount",
    "shift=0,align=off,sleep=off",
];

/// How a board's own Cargo feature begins (`board-mps2-an386`).
pub const FEATURE_PREFIX: &str = "board-";

/// The Cargo feature that makes the solver compute in f64.
pub const F64_FEATURE: &str = "f64";

/// How the symbol naming a firmware ELF's board begins: the firmware's build
/// script defines `_decoy_board_NAME` (an absolute symbol of value 0, nothing
/// in memory) for the board it builds.
pub const SYMBOL_PREFIX: &str = "_decoy_board_";

/// The firmware's binary name (`firmware/Cargo.toml`).
pub const BINARY: &str = "decoy-firmware";

/// The solver's scalar on a board (the schema's, as the bridge's backend has it).
pub use decoy_schema::Precision;

/// Which of a board's firmware builds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Build {
    /// The build that runs under QEMU (`features`): what the HIL library, the
    /// tests and `decoy hil` build and boot.
    Qemu,
    /// The real hardware's build (`hardware_features`), where the board has one:
    /// built and linted, not run here.
    Hardware,
}

impl fmt::Display for Build {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Build::Qemu => "QEMU",
            Build::Hardware => "hardware",
        })
    }
}
