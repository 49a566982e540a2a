//! The solver's work off the interpreter: [`solve`] runs it on a thread of its
//! own with the GIL released, so that other Python threads run meanwhile, and
//! turns Ctrl-C and panics into Python exceptions.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

use pyo3::prelude::*;

use crate::errors::DecoyError;

/// Stack of the worker thread, as the command line's (the fixed-capacity solver
/// types are large values; a Python thread's stack may be smaller).
const WORKER_STACK_BYTES: usize = 64 << 20;

/// How often the calling thread looks for a signal (Ctrl-C) while it waits.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// What a stop request says stopped the run: the only one is Ctrl-C's
/// KeyboardInterrupt (SIGINT), which [`solve`] raises itself.
const INTERRUPT: &str = "SIGINT";

/// Runs `work` on a worker thread while the calling thread waits without the
/// GIL. `work` gets the stop request it must poll (the run loop's `stop`): it
/// asks to stop once Python's signal handlers raised (Ctrl-C:
/// KeyboardInterrupt), which the calling thread checks every [`SIGNAL_POLL`]
/// (Python runs its handlers on the main thread only; elsewhere the check is a
/// no-op). Then the exception the handler raised is the result, whatever
/// `work` returned. A panic of `work` is a [`DecoyError`] naming it, not an
/// abort: the workspace's profiles unwind (`panic = "abort"` is the
/// firmware's alone).
pub fn solve<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&(dyn Fn() -> Option<&'static str> + Sync)) -> T + Send,
{
    let stop = AtomicBool::new(false);
    let mut interrupt: Option<PyErr> = None;
    let outcome = py.detach(|| {
        std::thread::scope(|scope| {
            let (done, finished) = mpsc::channel::<()>();
            let stop = &stop;
            let worker = std::thread::Builder::new()
                .name("decoy".into())
                .stack_size(WORKER_STACK_BYTES)
                .spawn_scoped(scope, move || {
                    // Dropped when the work ends or unwinds: the waiting thread wakes.
                    let _done = done;
                    work(&|| stop.load(Ordering::Relaxed).then_some(INTERRUPT))
                })
                .map_err(|e| format!("cannot start the solver's thread: {e}"))?;
            while let Err(RecvTimeoutError::Timeout) = finished.recv_timeout(SIGNAL_POLL) {
                if interrupt.is_none()
                    && let Err(e) = Python::attach(|py| py.check_signals())
                {
                    interrupt = Some(e);
                    stop.store(true, Ordering::Relaxed);
                }
            }
            worker.join().map_err(|payload| {
                let what = payload
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_owned())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "no message".to_owned());
                format!("internal error: the solver panicked: {what}")
            })
        })
    });
    if let Some(e) = interrupt {
        return Err(e);
    }
    outcome.map_err(DecoyError::new_err)
}
