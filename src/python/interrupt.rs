//! Ctrl-C during a run with the GIL released: [`ctrl_c`] is the run's interrupt, polling
//! Python's signal handlers, and [`interrupted`] the `KeyboardInterrupt` it leaves behind.
//! `simulate` and `Integrator.propagate_until` share them; an ensemble polls from its calling
//! thread instead (see `ensemble.rs`).

use crate::error::Error;
use pyo3::prelude::*;
use std::cell::Cell;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The interrupt of a run with the GIL released: it polls Python's signal handlers (Ctrl-C)
/// every 20 ms, looking at the clock only every 16 evaluations, and leaves the
/// `KeyboardInterrupt` in `pending`.
pub(super) fn ctrl_c(pending: &Mutex<Option<PyErr>>) -> impl Fn(f64) -> bool + '_ {
    let calls = Cell::new(0u32);
    let last = Cell::new(Instant::now());
    let stopped = Cell::new(false);
    move |_t: f64| -> bool {
        if stopped.get() {
            return true;
        }
        let k = calls.get().wrapping_add(1);
        calls.set(k);
        if !k.is_multiple_of(16) || last.get().elapsed() < Duration::from_millis(20) {
            return false;
        }
        last.set(Instant::now());
        if let Err(e) = Python::attach(|py| py.check_signals()) {
            *pending.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
            stopped.set(true);
        }
        stopped.get()
    }
}

/// The error of a run stopped by [`ctrl_c`]: the `KeyboardInterrupt` it left in `pending`.
pub(super) fn interrupted(pending: &Mutex<Option<PyErr>>, t: f64) -> PyErr {
    let e = pending.lock().unwrap_or_else(|p| p.into_inner()).take();
    e.unwrap_or_else(|| Error::Interrupted { t }.into())
}
