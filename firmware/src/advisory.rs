//! The advisory line to the mission computer: one discrete output, asserted
//! (high) while the last Output the controller answered has a decoy-management
//! monitor at warning or worse, or a look-ahead advisory (continuing the
//! manoeuvre violates a requirement within the horizon):
//! `decoy_link::Management::advisory_line`, the rule docs/protocol.md states; low
//! otherwise, from boot on.
//!
//! The line is any embedded-hal 1.0 `OutputPin`; the board says which (the
//! STM32F405's `Board::advisory`, PA5), and the application drives it after each
//! answer. Only an Output changes it: Rejected, Status and Pong answers carry no
//! new assessment, so the line keeps the last Output's. This is board and
//! application logic; the controller only reports the monitors.

use decoy_link::Management;
use embedded_hal::digital::OutputPin;

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

    /// Drives the line from an Output's management report; returns the new level
    /// if it changed (`Some(true)`: asserted), `None` if it stays as it was.
    pub fn update(&mut self, management: &Management) -> Result<Option<bool>, P::Error> {
        let asserted = management.advisory_line();
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
