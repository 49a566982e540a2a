//! [`Board`]: a copyable handle on a row of the compiled-in table, with the
//! lookups the tools need.

use std::fmt;
use std::ops::Deref;
use std::sync::LazyLock;

use crate::{BoardSpec, Precision, Table, UnknownBoard};

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

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;
    use std::path::{Path, PathBuf};

    use super::*;
    use crate::{Build, FEATURE_PREFIX, TABLE_PATH, TARGET};

    /// The repository's root.
    fn root() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    #[test]
    fn the_compiled_in_table_is_valid() {
        let table = Table::builtin().unwrap_or_else(|e| panic!("{e}"));
        assert!(!table.boards().is_empty());
        assert_eq!(Board::all().len(), table.boards().len());
        assert!(Board::default().is_default());
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
}
