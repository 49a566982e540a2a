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

use std::collections::BTreeSet;
use std::fmt;
use std::ops::Deref;
use std::sync::LazyLock;

use serde::Deserialize;

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

/// The solver's scalar on a board.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Precision {
    /// f32: the Cortex-M4F's single-precision FPU.
    F32,
    /// f64: feature `f64` (in hardware on the Cortex-M7's FPv5-D16).
    F64,
}

impl Precision {
    /// Bits of the scalar.
    pub fn bits(self) -> u8 {
        match self {
            Precision::F32 => 32,
            Precision::F64 => 64,
        }
    }
}

impl fmt::Display for Precision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "f{}", self.bits())
    }
}

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
    name: String,
    info: decoy_link::BoardInfo,
    label: String,
    summary: String,
    default: bool,
    module: String,
    advisory_line: bool,
    qemu: Vec<String>,
    feature: String,
    features: Vec<String>,
    hardware_features: Option<Vec<String>>,
    precision: Precision,
    target_cpu: Option<String>,
    ram_budget: u64,
    memory: MemoryMap,
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
    /// its CPU); [`QEMU_COMMON_ARGS`] follow them.
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

/// What is wrong with one row of the table.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Problem {
    /// The name is not lower-case letters, digits and `_` starting with a letter.
    #[error("the name must be lower-case letters, digits and `_`, starting with a letter")]
    Name,
    /// The Hello name breaks decoy_link::BoardName's rule.
    #[error(
        "`hello = \"{0}\"`: a Hello name is 1 to {max} printable ASCII bytes",
        max = decoy_link::BOARD_NAME_CAPACITY
    )]
    Hello(String),
    /// A text field is empty.
    #[error("`{0}` is empty")]
    Empty(&'static str),
    /// The module name is not a Rust module's.
    #[error("`module = \"{0}\"` is not a module name (lower-case letters, digits, `_`)")]
    Module(String),
    /// The core clock is zero.
    #[error("`core_clock_hz` is 0")]
    CoreClock,
    /// QEMU's arguments do not start with `-M MACHINE`.
    #[error("`qemu` must start with \"-M\" and the machine")]
    QemuMachine,
    /// A build does not have exactly one `board-*` feature.
    #[error("the {build} build's features have {count} `{FEATURE_PREFIX}*` features; exactly one")]
    BoardFeatures {
        /// Which build.
        build: Build,
        /// How many it has.
        count: usize,
    },
    /// The hardware build's board feature or precision differs from the QEMU
    /// build's.
    #[error(
        "the hardware build must have the QEMU build's `{FEATURE_PREFIX}*` feature and precision"
    )]
    HardwareDiffers,
    /// A feature name that cannot be passed to `--features`.
    #[error("feature `{0}`: not a Cargo feature name")]
    Feature(String),
    /// A feature listed twice.
    #[error("feature `{0}` is listed twice")]
    DuplicateFeature(String),
    /// The target CPU is not a plain name.
    #[error("`target_cpu = \"{0}\"` is not a CPU name")]
    TargetCpu(String),
    /// A size that is neither bytes nor "NK" / "NM".
    #[error("`{field}`: `{text}` is not a size (bytes, or \"NK\" or \"NM\")")]
    Size {
        /// The field.
        field: &'static str,
        /// What it says.
        text: String,
    },
    /// A memory region that is empty or ends beyond 4 GiB.
    #[error("`memory.{0}` is empty or ends beyond the 32-bit address space")]
    Region(&'static str),
    /// The RAM budget is zero or more than the RAM linked.
    #[error(
        "`ram_budget` ({budget} B) must be more than 0 and at most `memory.ram`'s length ({ram} B)"
    )]
    RamBudget {
        /// The budget.
        budget: u64,
        /// The RAM linked.
        ram: u64,
    },
}

/// Why the table cannot be used.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TableError {
    /// Not TOML, or not the table's fields.
    #[error("{TABLE_PATH}: {0}")]
    Syntax(String),
    /// No row.
    #[error("{TABLE_PATH}: no `[[board]]`")]
    Empty,
    /// A row is wrong.
    #[error("{TABLE_PATH}: board `{board}`: {problem}")]
    Board {
        /// The row's name.
        board: String,
        /// What is wrong.
        problem: Problem,
    },
    /// Two rows share a value that must tell them apart.
    #[error("{TABLE_PATH}: boards `{first}` and `{second}` have the same {what} `{value}`")]
    Duplicate {
        /// The first row.
        first: String,
        /// The second row.
        second: String,
        /// Which field.
        what: &'static str,
        /// The value.
        value: String,
    },
    /// Not exactly one row is the default.
    #[error("{TABLE_PATH}: {0} boards have `default = true`; exactly one must")]
    Defaults(usize),
}

/// A board name that is not in the table.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("no board `{name}` in {TABLE_PATH}; the boards: {}", .known.join(", "))]
pub struct UnknownBoard {
    /// The name asked for.
    pub name: String,
    /// The table's names.
    pub known: Vec<String>,
}

/// Why the firmware's build script cannot tell which board it builds.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SelectError {
    /// No board feature is on.
    #[error(
        "a board feature is needed: one of {} (the boards of {TABLE_PATH})",
        .0.join(", ")
    )]
    None(Vec<String>),
    /// Several are.
    #[error("choose one board feature, not {}", .0.join(" and "))]
    Several(Vec<String>),
    /// A `board-*` feature is on that no row names.
    #[error(
        "{0} is set but no board of {TABLE_PATH} has that feature: add its row (or remove the feature)"
    )]
    Unknown(String),
}

/// The table: every board, in its order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Table {
    boards: Vec<BoardSpec>,
}

/// The compiled-in table, parsed and validated once.
static BUILTIN: LazyLock<Result<Table, TableError>> = LazyLock::new(|| Table::parse(TABLE_TEXT));

impl Table {
    /// The compiled-in table ([`TABLE_TEXT`]), validated.
    pub fn builtin() -> Result<&'static Table, TableError> {
        BUILTIN.as_ref().map_err(Clone::clone)
    }

    /// Reads and validates a table.
    pub fn parse(text: &str) -> Result<Table, TableError> {
        let raw: RawTable = toml::from_str(text).map_err(|e| TableError::Syntax(e.to_string()))?;
        if raw.board.is_empty() {
            return Err(TableError::Empty);
        }
        let boards = raw
            .board
            .into_iter()
            .map(|row| {
                let name = row.name.clone();
                row.validate().map_err(|problem| TableError::Board {
                    board: name,
                    problem,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        for (i, a) in boards.iter().enumerate() {
            for b in &boards[i + 1..] {
                let shared: [(&'static str, &str, &str); 4] = [
                    ("name", &a.name, &b.name),
                    ("Hello name", a.hello(), b.hello()),
                    ("label", &a.label, &b.label),
                    ("board feature", &a.feature, &b.feature),
                ];
                for (what, x, y) in shared {
                    if x == y {
                        return Err(TableError::Duplicate {
                            first: a.name.clone(),
                            second: b.name.clone(),
                            what,
                            value: x.to_owned(),
                        });
                    }
                }
            }
        }
        let defaults = boards.iter().filter(|b| b.default).count();
        if defaults != 1 {
            return Err(TableError::Defaults(defaults));
        }
        Ok(Table { boards })
    }

    /// Every board, in the table's order.
    pub fn boards(&self) -> &[BoardSpec] {
        &self.boards
    }

    /// The board named `name`.
    pub fn get(&self, name: &str) -> Result<&BoardSpec, UnknownBoard> {
        self.boards
            .iter()
            .find(|b| b.name == name)
            .ok_or_else(|| UnknownBoard {
                name: name.to_owned(),
                known: self.boards.iter().map(|b| b.name.clone()).collect(),
            })
    }

    /// The default board (exactly one, checked by [`Table::parse`]).
    pub fn default_board(&self) -> &BoardSpec {
        self.boards
            .iter()
            .find(|b| b.default)
            .unwrap_or(&self.boards[0])
    }

    /// The board a firmware build is for, from the names of the `CARGO_FEATURE_*`
    /// environment variables Cargo set for its build script: exactly one board's
    /// feature must be on, and no `board-*` feature that no row names.
    pub fn select<S: AsRef<str>>(&self, feature_vars: &[S]) -> Result<&BoardSpec, SelectError> {
        let board_vars = feature_env(FEATURE_PREFIX);
        if let Some(unknown) = feature_vars
            .iter()
            .map(AsRef::as_ref)
            .filter(|v| v.starts_with(&board_vars))
            .find(|v| self.boards.iter().all(|b| b.feature_env() != *v))
        {
            return Err(SelectError::Unknown(unknown.to_owned()));
        }
        let on: Vec<&BoardSpec> = self
            .boards
            .iter()
            .filter(|b| {
                let var = b.feature_env();
                feature_vars.iter().any(|v| v.as_ref() == var)
            })
            .collect();
        match on[..] {
            [board] => Ok(board),
            [] => Err(SelectError::None(
                self.boards.iter().map(|b| b.feature.clone()).collect(),
            )),
            _ => Err(SelectError::Several(
                on.iter().map(|b| b.feature.clone()).collect(),
            )),
        }
    }
}

/// A board of the compiled-in table: a copyable handle on its row
/// ([`BoardSpec`], which it dereferences to). Equal boards have equal names.
#[derive(Clone, Copy)]
pub struct Board(&'static BoardSpec);

/// The handles on the compiled-in table's rows.
static BOARDS: LazyLock<Vec<Board>> = LazyLock::new(|| match Table::builtin() {
    Ok(table) => table.boards().iter().map(Board).collect(),
    // The table is compiled in and checked by this crate's tests and by every
    // firmware build: an invalid one cannot be shipped unnoticed.
    Err(e) => panic!("the compiled-in board table is invalid: {e}"),
});

impl Board {
    /// Every board, in the table's order.
    ///
    /// # Panics
    ///
    /// If the compiled-in table is invalid ([`Table::builtin`] says why), which
    /// this crate's tests and every firmware build rule out.
    pub fn all() -> &'static [Board] {
        &BOARDS
    }

    /// The board named `name` on the command line.
    pub fn by_name(name: &str) -> Result<Board, UnknownBoard> {
        Board::all()
            .iter()
            .copied()
            .find(|b| b.name() == name)
            .ok_or_else(|| UnknownBoard {
                name: name.to_owned(),
                known: Board::names(),
            })
    }

    /// Every board's name, in the table's order.
    pub fn names() -> Vec<String> {
        Board::all().iter().map(|b| b.name().to_owned()).collect()
    }

    /// The boards whose solver computes in `precision`, in the table's order.
    pub fn with_precision(precision: Precision) -> Vec<Board> {
        Board::all()
            .iter()
            .copied()
            .filter(|b| b.precision() == precision)
            .collect()
    }

    /// The board's position in the table (for per-board arrays).
    pub fn index(self) -> usize {
        Board::all()
            .iter()
            .position(|b| *b == self)
            .unwrap_or_default()
    }

    /// The board's row.
    pub fn spec(self) -> &'static BoardSpec {
        self.0
    }

    /// The board a firmware ELF was built for, from its `_decoy_board_NAME`
    /// symbol ([`BoardSpec::symbol`]): `Ok(None)` if it has none (built before
    /// boards were named, or not the firmware).
    #[cfg(feature = "elf")]
    pub fn of_elf(path: &std::path::Path) -> Result<Option<Board>, ElfError> {
        use object::{Object, ObjectSymbol};
        let bytes = std::fs::read(path).map_err(|e| ElfError::Read {
            path: path.to_owned(),
            error: e.to_string(),
        })?;
        let file = object::File::parse(&*bytes).map_err(|e| ElfError::Read {
            path: path.to_owned(),
            error: e.to_string(),
        })?;
        let names: BTreeSet<&str> = file
            .symbols()
            .filter_map(|s| s.name().ok())
            .filter_map(|n| n.strip_prefix(SYMBOL_PREFIX))
            .collect();
        match names.into_iter().collect::<Vec<_>>()[..] {
            [] => Ok(None),
            [name] => Board::by_name(name)
                .map(Some)
                .map_err(|unknown| ElfError::Unknown {
                    path: path.to_owned(),
                    unknown,
                }),
            _ => Err(ElfError::Several(path.to_owned())),
        }
    }
}

/// Why the board of a firmware ELF cannot be read.
#[cfg(feature = "elf")]
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ElfError {
    /// The file cannot be read or is not an ELF.
    #[error("{}: {error}", .path.display())]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        error: String,
    },
    /// It names several boards.
    #[error("{}: the ELF names several boards (`{SYMBOL_PREFIX}*` symbols)", .0.display())]
    Several(std::path::PathBuf),
    /// It names a board the table does not have.
    #[error("{}: {unknown}", .path.display())]
    Unknown {
        /// The file.
        path: std::path::PathBuf,
        /// The name it gives.
        unknown: UnknownBoard,
    },
}

impl Deref for Board {
    type Target = BoardSpec;

    fn deref(&self) -> &BoardSpec {
        self.0
    }
}

impl Default for Board {
    /// The default board (`default = true`).
    fn default() -> Self {
        Board::all()
            .iter()
            .copied()
            .find(|b| b.is_default())
            .unwrap_or(Board::all()[0])
    }
}

impl PartialEq for Board {
    fn eq(&self, other: &Self) -> bool {
        self.0.name == other.0.name
    }
}

impl Eq for Board {}

impl std::hash::Hash for Board {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.name.hash(state);
    }
}

impl fmt::Debug for Board {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Board({})", self.0.name)
    }
}

impl fmt::Display for Board {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0.name)
    }
}

// ------------------------------------------------------------- the file's form

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTable {
    #[serde(default)]
    board: Vec<RawBoard>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoard {
    name: String,
    hello: String,
    label: String,
    summary: String,
    #[serde(default)]
    default: bool,
    module: String,
    core_clock_hz: u32,
    advisory_line: bool,
    qemu: Vec<String>,
    features: Vec<String>,
    hardware_features: Option<Vec<String>>,
    target_cpu: Option<String>,
    ram_budget: Size,
    memory: RawMemory,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMemory {
    flash: RawRegion,
    ram: RawRegion,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRegion {
    origin: u64,
    length: Size,
}

/// A size: bytes, or a linker script's "NK" / "NM".
#[derive(Deserialize)]
#[serde(untagged)]
enum Size {
    Bytes(u64),
    Text(String),
}

impl Size {
    fn bytes(&self, field: &'static str) -> Result<u64, Problem> {
        let text = match self {
            Size::Bytes(n) => return Ok(*n),
            Size::Text(text) => text,
        };
        let bad = || Problem::Size {
            field,
            text: text.clone(),
        };
        let (digits, unit) = match text.strip_suffix('K') {
            Some(d) => (d, 1024),
            None => match text.strip_suffix('M') {
                Some(d) => (d, 1024 * 1024),
                None => (text.as_str(), 1),
            },
        };
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad());
        }
        digits
            .parse::<u64>()
            .ok()
            .and_then(|n| n.checked_mul(unit))
            .ok_or_else(bad)
    }
}

/// Lower-case letters, digits and `_`, starting with a letter.
fn is_identifier(text: &str) -> bool {
    text.starts_with(|c: char| c.is_ascii_lowercase())
        && text
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

impl RawBoard {
    fn validate(self) -> Result<BoardSpec, Problem> {
        if !is_identifier(&self.name) {
            return Err(Problem::Name);
        }
        let name = decoy_link::BoardName::new(&self.hello).ok_or(Problem::Hello(self.hello))?;
        for (field, text) in [("label", &self.label), ("summary", &self.summary)] {
            if text.trim().is_empty() {
                return Err(Problem::Empty(field));
            }
        }
        if !is_identifier(&self.module) {
            return Err(Problem::Module(self.module));
        }
        if self.core_clock_hz == 0 {
            return Err(Problem::CoreClock);
        }
        if self.qemu.len() < 2 || self.qemu[0] != "-M" || self.qemu[1].is_empty() {
            return Err(Problem::QemuMachine);
        }
        let feature = board_feature(&self.features, Build::Qemu)?;
        let precision = precision_of(&self.features);
        if let Some(hardware) = &self.hardware_features
            && (board_feature(hardware, Build::Hardware)? != feature
                || precision_of(hardware) != precision)
        {
            return Err(Problem::HardwareDiffers);
        }
        if let Some(cpu) = &self.target_cpu
            && (cpu.is_empty()
                || !cpu
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.'))
        {
            return Err(Problem::TargetCpu(cpu.clone()));
        }
        let region = |which: &'static str, r: &RawRegion| -> Result<Region, Problem> {
            let length = r.length.bytes(which)?;
            if length == 0 || r.origin.saturating_add(length) > 1 << 32 {
                return Err(Problem::Region(which));
            }
            Ok(Region {
                origin: r.origin,
                length,
            })
        };
        let memory = MemoryMap {
            flash: region("flash", &self.memory.flash)?,
            ram: region("ram", &self.memory.ram)?,
        };
        let ram_budget = self.ram_budget.bytes("ram_budget")?;
        if ram_budget == 0 || ram_budget > memory.ram.length {
            return Err(Problem::RamBudget {
                budget: ram_budget,
                ram: memory.ram.length,
            });
        }
        Ok(BoardSpec {
            name: self.name,
            info: decoy_link::BoardInfo {
                name,
                core_clock_hz: self.core_clock_hz,
            },
            label: self.label,
            summary: self.summary,
            default: self.default,
            module: self.module,
            advisory_line: self.advisory_line,
            qemu: self.qemu,
            feature,
            features: self.features,
            hardware_features: self.hardware_features,
            precision,
            target_cpu: self.target_cpu,
            ram_budget,
            memory,
        })
    }
}

/// The one `board-*` feature of `features`, which must all be feature names
/// without repetition.
fn board_feature(features: &[String], build: Build) -> Result<String, Problem> {
    let mut seen = BTreeSet::new();
    for f in features {
        let valid = !f.is_empty()
            && f.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
        if !valid {
            return Err(Problem::Feature(f.clone()));
        }
        if !seen.insert(f.as_str()) {
            return Err(Problem::DuplicateFeature(f.clone()));
        }
    }
    let boards: Vec<&String> = features
        .iter()
        .filter(|f| f.starts_with(FEATURE_PREFIX))
        .collect();
    match boards[..] {
        [feature] => Ok(feature.clone()),
        _ => Err(Problem::BoardFeatures {
            build,
            count: boards.len(),
        }),
    }
}

fn precision_of(features: &[String]) -> Precision {
    if features.iter().any(|f| f == F64_FEATURE) {
        Precision::F64
    } else {
        Precision::F32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use std::path::{Path, PathBuf};

    /// The repository's root.
    fn root() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    /// A valid one-board table, to break one field at a time.
    const ONE: &str = r#"
        [[board]]
        name = "x1"
        hello = "board-x1"
        label = "X1"
        summary = "a board"
        default = true
        module = "xmod"
        core_clock_hz = 48_000_000
        advisory_line = false
        qemu = ["-M", "xmachine"]
        features = ["qemu", "board-x1"]
        ram_budget = "32K"
        memory.flash = { origin = 0x0800_0000, length = "256K" }
        memory.ram = { origin = 0x2000_0000, length = 65536 }
    "#;

    fn with(line: &str, replacement: &str) -> String {
        assert!(ONE.contains(line), "{line}");
        ONE.replace(line, replacement)
    }

    fn problem(text: &str) -> Problem {
        match Table::parse(text) {
            Err(TableError::Board { problem, .. }) => problem,
            other => panic!("expected a row's problem, got {other:?}"),
        }
    }

    #[test]
    fn the_compiled_in_table_is_valid() {
        let table = Table::builtin().unwrap_or_else(|e| panic!("{e}"));
        assert!(!table.boards().is_empty());
        assert_eq!(Board::all().len(), table.boards().len());
        assert!(Board::default().is_default());
    }

    #[test]
    fn a_valid_row_reads_back() {
        let table = Table::parse(ONE).unwrap();
        let b = &table.boards()[0];
        assert_eq!(b.name(), "x1");
        assert_eq!(b.hello(), "board-x1");
        assert_eq!(b.info().core_clock_hz, 48_000_000);
        assert_eq!(b.feature(), "board-x1");
        assert_eq!(b.feature_env(), "CARGO_FEATURE_BOARD_X1");
        assert_eq!(b.precision(), Precision::F32);
        assert_eq!(b.ram_budget(), 32 * 1024);
        assert_eq!(
            b.memory(),
            MemoryMap {
                flash: Region {
                    origin: 0x0800_0000,
                    length: 256 * 1024
                },
                ram: Region {
                    origin: 0x2000_0000,
                    length: 65536
                },
            }
        );
        assert_eq!(b.builds().collect::<Vec<_>>(), [Build::Qemu]);
        assert_eq!(b.features(Build::Hardware), None);
        assert_eq!(b.cargo_args(Build::Hardware), None);
        assert_eq!(
            b.cargo_args(Build::Qemu).unwrap(),
            ["--no-default-features", "--features", "qemu,board-x1"]
        );
        assert_eq!(b.target_subdir(Build::Qemu), None);
        assert_eq!(b.symbol(), "_decoy_board_x1");
        assert_eq!(
            b.memory_x(),
            "/* @generated by firmware/build.rs from firmware/boards.toml (board `x1`); do not edit. */\n\
             MEMORY\n{\n  FLASH : ORIGIN = 0x08000000, LENGTH = 256K\n  RAM   : ORIGIN = 0x20000000, LENGTH = 64K\n}\n"
        );
        assert_eq!(table.default_board().name(), "x1");
    }

    #[test]
    fn every_field_is_checked() {
        assert_eq!(problem(&with("\"x1\"", "\"X-1\"")), Problem::Name);
        assert_eq!(
            problem(&with("\"board-x1\"\n", "\"two words\"\n")),
            Problem::Hello("two words".into())
        );
        assert_eq!(problem(&with("\"X1\"", "\" \"")), Problem::Empty("label"));
        assert_eq!(
            problem(&with("\"xmod\"", "\"x-mod\"")),
            Problem::Module("x-mod".into())
        );
        assert_eq!(problem(&with("48_000_000", "0")), Problem::CoreClock);
        assert_eq!(
            problem(&with("[\"-M\", \"xmachine\"]", "[\"-cpu\", \"x\"]")),
            Problem::QemuMachine
        );
        assert_eq!(
            problem(&with("[\"qemu\", \"board-x1\"]", "[\"qemu\"]")),
            Problem::BoardFeatures {
                build: Build::Qemu,
                count: 0
            }
        );
        assert_eq!(
            problem(&with(
                "[\"qemu\", \"board-x1\"]",
                "[\"board-x1\", \"board-x2\"]"
            )),
            Problem::BoardFeatures {
                build: Build::Qemu,
                count: 2
            }
        );
        assert_eq!(
            problem(&with(
                "[\"qemu\", \"board-x1\"]",
                "[\"qemu,x\", \"board-x1\"]"
            )),
            Problem::Feature("qemu,x".into())
        );
        assert_eq!(
            problem(&with(
                "[\"qemu\", \"board-x1\"]",
                "[\"qemu\", \"qemu\", \"board-x1\"]"
            )),
            Problem::DuplicateFeature("qemu".into())
        );
        assert_eq!(
            problem(&with(
                "features = [\"qemu\", \"board-x1\"]",
                "features = [\"qemu\", \"board-x1\"]\nhardware_features = [\"rtt\", \"board-x2\"]"
            )),
            Problem::HardwareDiffers
        );
        assert_eq!(
            problem(&with(
                "features = [\"qemu\", \"board-x1\"]",
                "features = [\"qemu\", \"board-x1\"]\nhardware_features = [\"rtt\", \"board-x1\", \"f64\"]"
            )),
            Problem::HardwareDiffers
        );
        assert_eq!(
            problem(&with(
                "ram_budget = \"32K\"",
                "ram_budget = \"32K\"\ntarget_cpu = \"cortex m7\""
            )),
            Problem::TargetCpu("cortex m7".into())
        );
        assert_eq!(
            problem(&with("\"32K\"", "\"32 KiB\"")),
            Problem::Size {
                field: "ram_budget",
                text: "32 KiB".into()
            }
        );
        assert_eq!(
            problem(&with("\"32K\"", "\"128K\"")),
            Problem::RamBudget {
                budget: 128 * 1024,
                ram: 65536
            }
        );
        assert_eq!(problem(&with("\"256K\"", "0")), Problem::Region("flash"));
        assert_eq!(
            problem(&with("origin = 0x2000_0000", "origin = 0xFFFF_8000")),
            Problem::Region("ram")
        );
        assert!(matches!(
            Table::parse(&with("module", "modul")),
            Err(TableError::Syntax(_))
        ));
        assert_eq!(Table::parse(""), Err(TableError::Empty));
    }

    #[test]
    fn rows_must_be_told_apart_and_one_is_the_default() {
        let second = ONE.replace("default = true", "");
        let two = format!(
            "{ONE}\n{}",
            second
                .replace("\"x1\"", "\"x2\"")
                .replace("\"X1\"", "\"X2\"")
        );
        // Same Hello name and board feature: the Hello name is reported first.
        assert_eq!(
            Table::parse(&two),
            Err(TableError::Duplicate {
                first: "x1".into(),
                second: "x2".into(),
                what: "Hello name",
                value: "board-x1".into()
            })
        );
        let two = two
            .replacen("hello = \"board-x1\"", "hello = \"board-x2\"", 2)
            .replacen("hello = \"board-x2\"", "hello = \"board-x1\"", 1);
        assert_eq!(
            Table::parse(&two),
            Err(TableError::Duplicate {
                first: "x1".into(),
                second: "x2".into(),
                what: "board feature",
                value: "board-x1".into()
            })
        );
        let none = ONE.replace("default = true", "");
        assert_eq!(Table::parse(&none), Err(TableError::Defaults(0)));
    }

    #[test]
    fn the_build_script_selects_exactly_one_board() {
        let table = Table::parse(ONE).unwrap();
        let vars = |v: &[&str]| v.iter().map(|s| (*s).to_owned()).collect::<Vec<_>>();
        let on = table
            .select(&vars(&["CARGO_FEATURE_QEMU", "CARGO_FEATURE_BOARD_X1"]))
            .unwrap();
        assert_eq!(on.name(), "x1");
        assert_eq!(
            table.select(&vars(&["CARGO_FEATURE_QEMU"])),
            Err(SelectError::None(vec!["board-x1".into()]))
        );
        assert_eq!(
            table.select(&vars(&["CARGO_FEATURE_BOARD_X1", "CARGO_FEATURE_BOARD_X9"])),
            Err(SelectError::Unknown("CARGO_FEATURE_BOARD_X9".into()))
        );
        let builtin = Table::builtin().unwrap();
        let all: Vec<String> = builtin.boards().iter().map(|b| b.feature_env()).collect();
        assert!(matches!(
            builtin.select(&all),
            Err(SelectError::Several(features)) if features.len() == all.len()
        ));
    }

    #[test]
    fn lookups_by_name_and_role() {
        for &board in Board::all() {
            assert_eq!(Board::by_name(board.name()), Ok(board));
            assert_eq!(Board::all()[board.index()], board);
            assert!(Board::with_precision(board.precision()).contains(&board));
        }
        let unknown = Board::by_name("m9").unwrap_err();
        assert_eq!(unknown.known, Board::names());
        let message = unknown.to_string();
        assert!(message.contains("`m9`"), "{message}");
        assert!(message.contains(Board::default().name()), "{message}");
        let all = Board::with_precision(Precision::F32).len()
            + Board::with_precision(Precision::F64).len();
        assert_eq!(all, Board::all().len());
    }

    #[test]
    fn cargo_arguments_and_target_directories() {
        for &board in Board::all() {
            let args = board.cargo_args(Build::Qemu).unwrap();
            assert_eq!(args[..2], ["--no-default-features", "--features"]);
            assert!(args[2].split(',').any(|f| f == board.feature()), "{args:?}");
            match board.target_cpu() {
                Some(cpu) => assert_eq!(
                    args[3..],
                    [
                        "--config".to_owned(),
                        format!("target.{TARGET}.rustflags=[\"-C\", \"target-cpu={cpu}\"]")
                    ]
                ),
                None => assert_eq!(args.len(), 3),
            }
            assert_eq!(
                board.target_subdir(Build::Qemu).is_none(),
                board.is_default(),
                "{board}"
            );
            assert_eq!(
                board.target_subdir(Build::Hardware),
                Some(format!("target/{}-hw", board.name()))
            );
        }
    }

    /// The table against the firmware it describes: the features exist, the
    /// default board is what the default features build, the modules exist, the
    /// target is the one `.cargo/config.toml` builds for.
    #[test]
    fn the_table_matches_the_firmware() {
        let read = |path: &str| {
            let path = root().join(path);
            let text = std::fs::read_to_string(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            text.parse::<toml::Table>()
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        };
        let manifest = read("firmware/Cargo.toml");
        let features = manifest["features"].as_table().expect("[features]");
        let names = |v: &toml::Value| -> Vec<String> {
            v.as_array()
                .expect("a list")
                .iter()
                .map(|f| f.as_str().expect("a feature").to_owned())
                .collect()
        };
        let default: BTreeSet<String> = names(&features["default"]).into_iter().collect();
        let board = Board::default();
        let expected: BTreeSet<String> = board
            .features(Build::Qemu)
            .unwrap()
            .iter()
            .cloned()
            .collect();
        assert_eq!(
            default, expected,
            "firmware/Cargo.toml's default features must be the default board's ({board})"
        );
        for &board in Board::all() {
            for build in board.builds() {
                for f in board.features(build).unwrap() {
                    assert!(
                        features.contains_key(f),
                        "{board}: feature `{f}` is not in firmware/Cargo.toml"
                    );
                }
            }
            let module = root().join(format!("firmware/src/board/{}.rs", board.module()));
            assert!(module.is_file(), "{board}: no {}", module.display());
        }
        for name in features.keys().filter(|f| f.starts_with(FEATURE_PREFIX)) {
            assert!(
                Board::all().iter().any(|b| b.feature() == name),
                "firmware/Cargo.toml's feature `{name}` has no row in {TABLE_PATH}"
            );
        }
        let config = read("firmware/.cargo/config.toml");
        assert_eq!(config["build"]["target"].as_str(), Some(TARGET));
    }

    /// An ELF whose symbol table holds absolute symbols named `names`.
    #[cfg(feature = "elf")]
    fn elf_with(names: &[&str]) -> PathBuf {
        use object::write::{Object, Symbol, SymbolSection};
        use object::{
            Architecture, BinaryFormat, Endianness, SymbolFlags, SymbolKind, SymbolScope,
        };
        let mut elf = Object::new(BinaryFormat::Elf, Architecture::Arm, Endianness::Little);
        for name in names {
            elf.add_symbol(Symbol {
                name: name.as_bytes().to_vec(),
                value: 0,
                size: 0,
                kind: SymbolKind::Data,
                scope: SymbolScope::Linkage,
                weak: false,
                section: SymbolSection::Absolute,
                flags: SymbolFlags::None,
            });
        }
        let path = std::env::temp_dir().join(format!(
            "decoy-boards-{}-{}.elf",
            std::process::id(),
            names.join("+")
        ));
        std::fs::write(&path, elf.write().unwrap()).unwrap();
        path
    }

    #[cfg(feature = "elf")]
    #[test]
    fn an_elf_names_its_board() {
        let board = Board::all()[Board::all().len() - 1];
        let one = elf_with(&[&board.symbol(), "main"]);
        assert_eq!(Board::of_elf(&one), Ok(Some(board)));
        let none = elf_with(&["main"]);
        assert_eq!(Board::of_elf(&none), Ok(None));
        let two = elf_with(&["_decoy_board_m4", "_decoy_board_m7"]);
        assert_eq!(Board::of_elf(&two), Err(ElfError::Several(two.clone())));
        let unknown = elf_with(&["_decoy_board_m9"]);
        assert!(
            matches!(Board::of_elf(&unknown), Err(ElfError::Unknown { unknown: u, .. }) if u.name == "m9")
        );
        let missing = std::env::temp_dir().join("decoy-boards-no-such.elf");
        assert!(matches!(
            Board::of_elf(&missing),
            Err(ElfError::Read { .. })
        ));
        for path in [one, none, two, unknown] {
            std::fs::remove_file(path).unwrap();
        }
    }

    #[test]
    fn sizes() {
        assert_eq!(linker_size(4 * 1024 * 1024), "4M");
        assert_eq!(linker_size(128 * 1024), "128K");
        assert_eq!(linker_size(1000), "1000");
        assert_eq!(Size::Text("4M".into()).bytes("x"), Ok(4 << 20));
        assert_eq!(Size::Text("12".into()).bytes("x"), Ok(12));
        assert!(Size::Text("K".into()).bytes("x").is_err());
        assert!(Size::Text("-1K".into()).bytes("x").is_err());
        assert!(Size::Text("99999999999999999M".into()).bytes("x").is_err());
    }
}
