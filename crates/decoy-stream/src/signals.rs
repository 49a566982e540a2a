//! SIGINT and SIGTERM for the commands that stop cleanly on them: `decoy
//! simulate` (the command line installs these for its run) and the streamed
//! runs, `decoy hil` and `decoy feed` (the pipeline installs them once its
//! transport is open: a bridge client's iceoryx2 node installs a handler of
//! its own, which would replace any installed before it; these chain after it).
//!
//! The first of either sets a flag that the run reads at its step (or frame)
//! boundaries: it stops there, writes what it flew (a summary whose `stopped`
//! names the signal, the plots) and the command exits with 130 (SIGINT) or 143
//! (SIGTERM), the codes a shell gives a process that signal ended
//! ([`exit_code`]). A second signal of either kind ends the process at once, as
//! without the handlers (the signal's default action): the files being written
//! are then left under their `.partial` names, none half-written under its own,
//! and the next run into the directory removes them. The handlers are removed
//! when the [`Interrupts`] is dropped.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use signal_hook::consts::{SIGINT, SIGTERM};

/// The signals that stop a run: number, name and the command's exit code.
const SIGNALS: [(i32, &str, u8); 2] = [(SIGINT, "SIGINT", 130), (SIGTERM, "SIGTERM", 143)];

/// The handlers of SIGINT and SIGTERM, installed until dropped.
pub struct Interrupts {
    /// The number of the first signal received (0: none yet).
    received: Arc<AtomicUsize>,
    ids: Vec<signal_hook::SigId>,
}

impl Interrupts {
    /// Installs the handlers (see the module docs).
    pub fn install() -> Result<Self, std::io::Error> {
        let armed = Arc::new(AtomicBool::new(false));
        let mut interrupts = Interrupts {
            received: Arc::new(AtomicUsize::new(0)),
            ids: Vec::new(),
        };
        for (signal, _, _) in SIGNALS {
            // In this order: the default action only once `armed` is set, so on
            // the second signal; the first one's number kept.
            interrupts
                .ids
                .push(signal_hook::flag::register_conditional_default(
                    signal,
                    Arc::clone(&armed),
                )?);
            interrupts.ids.push(signal_hook::flag::register_usize(
                signal,
                Arc::clone(&interrupts.received),
                signal as usize,
            )?);
            interrupts
                .ids
                .push(signal_hook::flag::register(signal, Arc::clone(&armed))?);
        }
        Ok(interrupts)
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

impl Drop for Interrupts {
    fn drop(&mut self) {
        for id in self.ids.drain(..) {
            signal_hook::low_level::unregister(id);
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_are_the_shells() {
        assert_eq!(exit_code("SIGINT"), 130);
        assert_eq!(exit_code("SIGTERM"), 143);
    }

    /// A signal raised while the handlers are installed is recorded (and does
    /// not end the test process); the handlers are gone once dropped.
    #[test]
    fn the_first_signal_is_recorded() {
        let interrupts = Interrupts::install().unwrap();
        assert_eq!(interrupts.received(), None);
        signal_hook::low_level::raise(SIGTERM).unwrap();
        assert_eq!(interrupts.received(), Some("SIGTERM"));
        drop(interrupts);
    }
}
