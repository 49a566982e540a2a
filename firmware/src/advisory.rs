//! The advisory line to the mission computer: one discrete output, asserted
//! (high) while any hazard flag (OVER_TENSION, CABLE_IN_PLUME,
//! DECOY_NEAR_AIRCRAFT) is set in the last Output the controller answered, and
//! deasserted (low) otherwise, from boot on.
//!
//! The line is any embedded-hal 1.0 `OutputPin`; the board says which (the
//! STM32F405's `Board::advisory`, PA5), and the application drives it after each
//! answer. Only an Output changes it: Rejected, Status and Pong answers carry no
//! new assessment, so the line keeps the last Output's. This is board and
//! application logic; the controller only reports the flags.

use decoy_link::StatusFlags;
use embedded_hal::digital::OutputPin;

/// The hazard flags that assert the line.
pub const HAZARDS: u16 =
    StatusFlags::OVER_TENSION | StatusFlags::CABLE_IN_PLUME | StatusFlags::DECOY_NEAR_AIRCRAFT;

/// The advisory line and its last driven level.
pub struct Advisory<P> {
    pin: P,
    asserted: bool,
}

impl<P: OutputPin> Advisory<P> {
    /// Takes the pin and drives it low (no hazard).
    pub fn new(mut pin: P) -> Result<Self, P::Error> {
        pin.set_low()?;
        Ok(Advisory {
            pin,
            asserted: false,
        })
    }

    /// Drives the line from an Output's `flags`; returns the new level if it
    /// changed (`Some(true)`: asserted), `None` if it stays as it was.
    pub fn update(&mut self, flags: u16) -> Result<Option<bool>, P::Error> {
        let asserted = flags & HAZARDS != 0;
        if asserted == self.asserted {
            return Ok(None);
        }
        if asserted {
            self.pin.set_high()?;
        } else {
            self.pin.set_low()?;
        }
        self.asserted = asserted;
        Ok(Some(asserted))
    }

    /// Whether the line is asserted.
    pub fn is_asserted(&self) -> bool {
        self.asserted
    }
}
