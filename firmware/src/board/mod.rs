//! The board the firmware runs on, chosen by feature. Each board module gives the
//! application the same roles: [`Board::take`] with a UART that is `embedded-io`
//! `Read + ReadReady + Write` and a [`Clock`] (instruction counter and millisecond
//! clock, `decoy_controller::serve::Clock`), the board's name and core clock for
//! Hello, failure handling ([`fail`]) and the stack high-water mark.
//!
//! | feature | board | module |
//! |---|---|---|
//! | `board-mps2-an386` (default) | QEMU MPS2 AN386, Cortex-M4F | `mps2.rs` |
//! | `board-mps2-an500` | QEMU MPS2 AN500, Cortex-M7 | `mps2.rs` |
//!
//! A new board is a module here, its memory map and a line in this table.

#[cfg(all(feature = "board-mps2-an386", feature = "board-mps2-an500"))]
compile_error!("choose one board feature");
#[cfg(not(any(feature = "board-mps2-an386", feature = "board-mps2-an500")))]
compile_error!("a board feature is needed: `board-mps2-an386` or `board-mps2-an500`");

#[cfg(any(feature = "board-mps2-an386", feature = "board-mps2-an500"))]
mod mps2;
#[cfg(any(feature = "board-mps2-an386", feature = "board-mps2-an500"))]
pub use mps2::*;
