//! SIGINT and SIGTERM for the commands that stop cleanly on them (`decoy
//! simulate`, `decoy hil`; `decoy feed` has host-bridge's, which must come after
//! its iceoryx2 node's own handler).
//!
//! The first of either sets a flag that the run reads at its step (or frame)
//! boundaries: it stops there, writes what it flew (a summary whose `stopped`
//! names the signal, the plots) and the command exits with 130 (SIGINT) or 143
//! (SIGTERM), the codes a shell gives a process that signal ended. A second
//! signal of either kind ends the process at once, as without the handlers (the
//! signal's default action): the files being written are then left under their
//! `.partial` names, none half-written under its own, and the next run into the
//! directory removes them.
//!
//! decoy-sim and decoy-hil install no handler; they take a stop request
//! ([`Interrupts::received`]) from here.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use signal_hook::consts::{SIGINT, SIGTERM};

use crate::Failure;

/// The signals that stop a run: number, name and the command's exit code.
const SIGNALS: [(i32, &str, u8); 2] = [(SIGINT, "SIGINT", 130), (SIGTERM, "SIGTERM", 143)];

/// The handlers of SIGINT and SIGTERM, installed for the rest of the process
/// (the command ends with its run).
pub struct Interrupts {
    /// The number of the signal received (0: none yet).
    received: Arc<AtomicUsize>,
}

impl Interrupts {
    /// Installs the handlers (see the module docs).
    pub fn install() -> Result<Self, Failure> {
        let armed = Arc::new(AtomicBool::new(false));
        let received = Arc::new(AtomicUsize::new(0));
        let fail = |e: std::io::Error| {
            Failure::Solver(format!("cannot install the SIGINT/SIGTERM handlers: {e}"))
        };
        for (signal, _, _) in SIGNALS {
            // Registered first, so that it runs before `armed` is set: nothing on
            // the first signal, the default action (the end) on the second.
            signal_hook::flag::register_conditional_default(signal, Arc::clone(&armed))
                .map_err(fail)?;
            signal_hook::flag::register_usize(signal, Arc::clone(&received), signal as usize)
                .map_err(fail)?;
            signal_hook::flag::register(signal, Arc::clone(&armed)).map_err(fail)?;
        }
        Ok(Interrupts { received })
    }

    /// The name of the signal received (`SIGINT`, `SIGTERM`), if one came: the
    /// run's stop request. One atomic load.
    pub fn received(&self) -> Option<&'static str> {
        let number = self.received.load(Ordering::Relaxed);
        SIGNALS
            .iter()
            .find(|(signal, _, _)| *signal as usize == number)
            .map(|(_, name, _)| *name)
    }
}

/// The exit code of a command that the signal `name` (as
/// [`Interrupts::received`] names it) stopped: 130 for SIGINT, 143 for SIGTERM.
pub fn exit_code(name: &str) -> u8 {
    SIGNALS
        .iter()
        .find(|(_, n, _)| *n == name)
        .map_or(130, |(_, _, code)| *code)
}
