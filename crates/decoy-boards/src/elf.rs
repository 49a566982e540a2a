//! An ELF's board (feature `elf`): the `_decoy_board_NAME` symbol the firmware's
//! build script defines, read with `object`.

use std::collections::BTreeSet;

use crate::{Board, SYMBOL_PREFIX, UnknownBoard};

impl Board {
    /// The board a firmware ELF was built for, from its `_decoy_board_NAME`
    /// symbol ([`crate::BoardSpec::symbol`]): `Ok(None)` if it has none (built before
    /// boards were named, or not the firmware).
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

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    /// An ELF whose symbol table holds absolute symbols named `names`.
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
}
