//! The firmware a run needs: the configured build for a board, or a variant
//! with another segment count (`decoy hil --segments`, the bridge's qemu
//! backend), after checking that the count fits the firmware's solver.

use std::path::PathBuf;

use decoy_hil::firmware::{self, BUILD_TIMEOUT, BuildError};
use decoy_hil::qemu::Board;

/// `--segments` must fit the firmware's solver: the usage message when it
/// does not.
pub fn check_segments(segments: usize) -> Result<(), String> {
    if (1..=firmware::MAX_SEGMENTS).contains(&segments) {
        Ok(())
    } else {
        Err(format!(
            "--segments must be between 1 and {} (the firmware's capacity), got {segments}",
            firmware::MAX_SEGMENTS
        ))
    }
}

/// Builds the firmware for `board` with `segments` segments (checked with
/// [`check_segments`] first): the configured build when that is the
/// configuration's count `configured`, else a variant; returns its ELF.
pub fn build_firmware(
    board: Board,
    segments: usize,
    configured: usize,
) -> Result<PathBuf, BuildError> {
    if segments == configured {
        firmware::build_board(board, BUILD_TIMEOUT)
    } else {
        firmware::build_board_with_segments(board, segments, BUILD_TIMEOUT)
    }
}
