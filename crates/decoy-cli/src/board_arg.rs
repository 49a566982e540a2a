//! `--board NAME`, one parser for `decoy hil` and `decoy bridge`: a board of
//! `firmware/boards.toml` (`decoy_boards`, through `decoy_hil::qemu::Board`), its
//! names and summaries listed in `--help`, an unknown name a usage error that
//! lists them.

use std::ffi::OsStr;

use clap::builder::{PossibleValue, TypedValueParser};
use clap::error::{ContextKind, ContextValue, ErrorKind};
use decoy_hil::qemu::Board;

/// The value parser of `--board`.
#[derive(Clone, Copy, Debug, Default)]
pub struct BoardParser;

impl TypedValueParser for BoardParser {
    type Value = Board;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<Board, clap::Error> {
        let text = value.to_string_lossy();
        Board::by_name(&text).map_err(|unknown| {
            let mut error = clap::Error::new(ErrorKind::InvalidValue).with_cmd(cmd);
            if let Some(arg) = arg {
                error.insert(
                    ContextKind::InvalidArg,
                    ContextValue::String(arg.to_string()),
                );
            }
            error.insert(
                ContextKind::InvalidValue,
                ContextValue::String(text.into_owned()),
            );
            error.insert(
                ContextKind::ValidValue,
                ContextValue::Strings(unknown.known),
            );
            error
        })
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(Board::all().iter().map(|board| {
            PossibleValue::new(board.spec().name()).help(board.spec().summary())
        })))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use clap::Parser;

    #[derive(Parser, Debug)]
    struct Args {
        #[arg(long, value_name = "NAME", value_parser = BoardParser, default_value_t = Board::default())]
        board: Board,
    }

    #[test]
    fn every_board_of_the_table_parses_and_the_default_is_the_tables() {
        for &board in Board::all() {
            let args = Args::try_parse_from(["t", "--board", board.name()]).unwrap();
            assert_eq!(args.board, board);
        }
        let args = Args::try_parse_from(["t"]).unwrap();
        assert_eq!(args.board, Board::default());
    }

    #[test]
    fn an_unknown_board_is_a_usage_error_that_lists_the_boards() {
        let error = Args::try_parse_from(["t", "--board", "m9"]).unwrap_err();
        assert_eq!(error.kind(), ErrorKind::InvalidValue);
        let text = error.to_string();
        assert!(text.contains("m9"), "{text}");
        for board in Board::all() {
            assert!(text.contains(board.name()), "{text}");
        }
    }

    #[test]
    fn the_help_lists_every_board_with_its_summary() {
        use clap::CommandFactory;
        let help = Args::command().render_long_help().to_string();
        for board in Board::all() {
            assert!(help.contains(board.name()), "{help}");
            assert!(help.contains(board.summary()), "{help}");
        }
    }
}
