//! The board the firmware runs on: the row of `firmware/boards.toml` whose Cargo
//! feature is on. `build.rs` selects it (exactly one board feature, through the
//! crate `decoy-boards`), links its memory map, sets `cfg(board_module = "...")`
//! to its module here and writes its Hello name, core clock and whether it has
//! the advisory line as constants ([`NAME`], [`CORE_CLOCK_HZ`],
//! [`ADVISORY_LINE`]; `row.rs`).
//!
//! Every board module implements the same interface, so that the application
//! has no board `cfg`:
//!
//! - `Uart`, the host link: `embedded-io` `Read + ReadReady + Write +
//!   WriteReady`, with its `UartError`;
//! - `Clock`, the instruction counter and millisecond clock
//!   (`decoy_controller::serve::Clock` and `decoy_controller::InstructionCounter`);
//! - `AdvisoryPin`, the advisory line to the mission computer
//!   ([`crate::advisory::LinePin`]: a pin, or [`crate::advisory::NoLine`] on a
//!   board without the line, whose updates compile to nothing);
//! - `take()`, which sets them up (`None` if it cannot: [`Board::take`]), and
//!   `uart_off()`, the failure path's safe state.
//!
//! | module | boards (`firmware/boards.toml`) |
//! |---|---|
//! | `mps2.rs` | QEMU MPS2 AN386 (Cortex-M4F) and AN500 (Cortex-M7), CMSDK UART0 |
//! | `stm32f4.rs` | STM32F405, Cortex-M4F 168 MHz (QEMU `netduinoplus2` with `qemu`), through `stm32f4xx-hal` |
//!
//! A new board is a row of `firmware/boards.toml` and its Cargo feature; a new
//! module is a file here and its two lines below. What every board shares is
//! `common.rs` (stack painting, the blocking `embedded-io` loops, the defmt
//! transport) and `failure.rs` (the failure path with its panic and HardFault
//! handlers).

use crate::advisory::LinePin;

/// The board's row of `firmware/boards.toml`.
mod row;
pub use row::{ADVISORY_LINE, CORE_CLOCK_HZ, NAME};

/// Stack painting and the UART loops every board shares.
mod common;
pub use common::{paint_stack, stack_high_water, stack_size};

/// The failure path every board shares.
mod failure;
pub use failure::fail;

#[cfg(board_module = "mps2")]
mod mps2;
#[cfg(board_module = "mps2")]
use mps2 as module;

#[cfg(board_module = "stm32f4")]
mod stm32f4;
#[cfg(board_module = "stm32f4")]
use stm32f4 as module;

use module::uart_off;
pub use module::{AdvisoryPin, Clock, Uart, UartError};

/// The board's peripherals, as the application uses them: the same on every
/// board.
pub struct Board {
    /// The host link.
    pub uart: Uart,
    /// Instruction counter and millisecond clock.
    pub clock: Clock,
    /// The advisory line to the mission computer, deasserted (low) at boot; a
    /// pin that does nothing on a board without the line.
    pub advisory: AdvisoryPin,
}

impl Board {
    /// Takes the peripherals and sets them up; `None` if already taken or if the
    /// board cannot be set up (the module says when).
    pub fn take() -> Option<Self> {
        let (uart, clock, advisory) = module::take()?;
        Some(Board {
            uart,
            clock,
            advisory,
        })
    }
}

/// The board as Hello describes it: its name and core clock
/// (`firmware/boards.toml`).
pub const INFO: decoy_link::BoardInfo = decoy_link::BoardInfo {
    name: match decoy_link::BoardName::new(NAME) {
        Some(name) => name,
        None => panic!("a board name is 1 to 24 printable ASCII bytes"),
    },
    core_clock_hz: CORE_CLOCK_HZ,
};

// The module's advisory pin is wired exactly when the table says the board has
// the line (the tests that check the line take the boards from the table).
const _: () = assert!(
    <AdvisoryPin as LinePin>::WIRED == ADVISORY_LINE,
    "the board module's AdvisoryPin disagrees with `advisory_line` in firmware/boards.toml"
);
