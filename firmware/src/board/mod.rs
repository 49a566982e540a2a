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
//! | `board-stm32f405` | STM32F405, Cortex-M4F 168 MHz (QEMU `netduinoplus2` with `qemu`), through `stm32f4xx-hal` | `stm32f4.rs` |
//!
//! A board may give the application more: the STM32F405 has the advisory line
//! (`Board::advisory`, an embedded-hal `OutputPin`; see `crate::advisory`).
//!
//! A new board is a module here, its memory map and a line in this table; what
//! every board shares (the failure path with its panic and HardFault handlers,
//! stack painting, the blocking `embedded-io` loops) is `common.rs`.

#[cfg(any(
    all(feature = "board-mps2-an386", feature = "board-mps2-an500"),
    all(feature = "board-mps2-an386", feature = "board-stm32f405"),
    all(feature = "board-mps2-an500", feature = "board-stm32f405"),
))]
compile_error!("choose one board feature");
#[cfg(not(any(
    feature = "board-mps2-an386",
    feature = "board-mps2-an500",
    feature = "board-stm32f405"
)))]
compile_error!(
    "a board feature is needed: `board-mps2-an386`, `board-mps2-an500` or `board-stm32f405`"
);

/// The failure path, stack painting and the UART loops every board shares.
mod common;
pub use common::{fail, paint_stack, stack_high_water, stack_size};

#[cfg(any(feature = "board-mps2-an386", feature = "board-mps2-an500"))]
mod mps2;
#[cfg(any(feature = "board-mps2-an386", feature = "board-mps2-an500"))]
pub use mps2::*;

#[cfg(feature = "board-stm32f405")]
mod stm32f4;
#[cfg(feature = "board-stm32f405")]
pub use stm32f4::*;
