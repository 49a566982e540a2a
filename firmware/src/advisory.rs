//! The advisory line to the mission computer: one discrete output, asserted
//! (high) while the last Output the controller answered has a decoy-management
//! monitor at warning or worse, or a look-ahead advisory (continuing the
//! manoeuvre violates a requirement within the horizon):
//! `decoy_link::Management::advisory_line`, the rule docs/protocol.md states; low
//! otherwise, from boot on.
//!
//! The line is any embedded-hal 1.0 `OutputPin` that says whether it is wired
//! ([`LinePin`]); every board gives one as `Board::advisory` (the STM32F405's is
//! PA5; a board without the line gives [`NoLine`], which is not wired, so that
//! [`Advisory::update`] compiles to nothing there), and the application drives
//! it after each answer. Only an Output changes it: Rejected, Status and Pong
//! answers carry no new assessment, so the line keeps the last Output's. This is
//! board and application logic; the controller only reports the monitors.

use core::convert::Infallible;

use decoy_link::Management;
use embedded_hal::digital::{ErrorType, OutputPin};

/// The pin of an advisory line: an embedded-hal `OutputPin` that says whether
/// the board has the line at all.
pub trait LinePin: OutputPin {
    /// Whether the pin drives a line. `false` ([`NoLine`]): [`Advisory::update`]
    /// never changes the level nor reports a change, and the optimiser removes it.
    const WIRED: bool;
}

/// The advisory pin of a board without the line: setting it does nothing.
pub struct NoLine;

impl ErrorType for NoLine {
    type Error = Infallible;
}

impl OutputPin for NoLine {
    fn set_low(&mut self) -> Result<(), Infallible> {
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl LinePin for NoLine {
    const WIRED: bool = false;
}

/// The advisory line and its last driven level.
pub struct Advisory<P> {
    pin: P,
    asserted: bool,
}

impl<P: LinePin> Advisory<P> {
    /// Takes the pin and drives it low (no hazard).
    pub fn new(mut pin: P) -> Result<Self, P::Error> {
        pin.set_low()?;
        Ok(Advisory {
            pin,
            asserted: false,
        })
    }

    /// Drives the line from an Output's management report; returns the new level
    /// if it changed (`Some(true)`: asserted), `None` if it stays as it was (and
    /// always on a board without the line).
    pub fn update(&mut self, management: &Management) -> Result<Option<bool>, P::Error> {
        if !P::WIRED {
            return Ok(None);
        }
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
