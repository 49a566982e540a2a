//! [`Table`]: the table read from its TOML form and validated, with typed
//! errors ([`TableError`], [`Problem`]), and the build script's choice of row
//! ([`Table::select`]).

use std::collections::BTreeSet;
use std::sync::LazyLock;

use serde::Deserialize;

use crate::feature_env;
use crate::spec::{MemoryMap, Region};
use crate::{BoardSpec, Build, F64_FEATURE, FEATURE_PREFIX, Precision, TABLE_PATH, TABLE_TEXT};

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
    fn sizes() {
        assert_eq!(Size::Text("4M".into()).bytes("x"), Ok(4 << 20));
        assert_eq!(Size::Text("12".into()).bytes("x"), Ok(12));
        assert!(Size::Text("K".into()).bytes("x").is_err());
        assert!(Size::Text("-1K".into()).bytes("x").is_err());
        assert!(Size::Text("99999999999999999M".into()).bytes("x").is_err());
    }
}
