//! What the HIL tests share: the boards come from `firmware/boards.toml`
//! (`decoy_hil::qemu::Board`), never a list of their own, so a board added to
//! the table is tested by every test of its role; the measured baselines
//! ([`baselines`]: `crates/hil-tests/baselines.toml`, read, compared, and
//! written by `cargo xtask bless`).

// Each test binary uses its own part of this module.
#![allow(dead_code)]

pub mod baselines;

use std::panic::{self, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use decoy_hil::qemu::{Board, Precision};
use decoy_hil::{defmt, firmware};

/// Time limit of a firmware build (a cold build takes a few minutes).
pub const BUILD_TIMEOUT: Duration = Duration::from_secs(900);

/// The firmware ELF of `board`, built once per test binary (after checking that
/// `defmt-print` is there).
pub fn elf(board: Board) -> &'static PathBuf {
    static ELFS: OnceLock<Vec<OnceLock<PathBuf>>> = OnceLock::new();
    let elfs = ELFS.get_or_init(|| Board::all().iter().map(|_| OnceLock::new()).collect());
    elfs[board.index()].get_or_init(|| {
        defmt::require().unwrap_or_else(|e| panic!("{e}"));
        let started = Instant::now();
        let elf = firmware::build_board(board, BUILD_TIMEOUT).unwrap_or_else(|e| panic!("{e}"));
        let memory = firmware::memory_usage(&elf).unwrap_or_else(|e| panic!("{e}"));
        // The build script names the board in the ELF (the cargo runner and
        // `decoy hil --firmware` read it).
        assert_eq!(
            Board::of_elf(&elf).unwrap_or_else(|e| panic!("{e}")),
            Some(board),
            "{}: the ELF's board symbol",
            elf.display()
        );
        println!(
            "{board} firmware built in {:.1} s: {}; {memory}",
            started.elapsed().as_secs_f64(),
            elf.display()
        );
        elf
    })
}

/// The boards of the table whose solver computes in `precision`; at least one
/// (a role no board has would leave its tests with nothing to check).
pub fn boards_in(precision: Precision) -> Vec<Board> {
    let boards = Board::with_precision(precision);
    assert!(
        !boards.is_empty(),
        "no {precision} board in firmware/boards.toml"
    );
    boards
}

/// Runs `check` on each of `boards` in turn, each to its end even when an
/// earlier one failed, then fails naming every board that failed (each
/// failure's own message is printed as it happens).
pub fn on_each(boards: &[Board], check: impl Fn(Board)) {
    assert!(!boards.is_empty(), "no board to check");
    let failed: Vec<String> = boards
        .iter()
        .filter_map(|&board| {
            panic::catch_unwind(AssertUnwindSafe(|| check(board)))
                .err()
                .map(|payload| {
                    let message = payload
                        .downcast_ref::<String>()
                        .map(String::as_str)
                        .or_else(|| payload.downcast_ref::<&str>().copied())
                        .unwrap_or("(a panic without a message)");
                    format!("{board}: {message}")
                })
        })
        .collect();
    assert!(
        failed.is_empty(),
        "failed on {} of {} boards:\n{}",
        failed.len(),
        boards.len(),
        failed.join("\n")
    );
}
