//! `centaur._native`: the Rust side of Centaur's Python package.
//!
//! Thin bindings, no logic of their own: each class holds the Rust object it names and
//! each method calls the Rust function of the same name, converting numpy arrays in and
//! out (observations and actions `float32`, dynamics `float64`, as in Rust). The Python
//! package (`python/centaur/`) builds the Gymnasium API on top: `centaur.make`, the
//! registered ids, the vector env, the Stable-Baselines3 adapter and the Ray helpers.
//!
//! Failures raise `centaur.CentaurError` (a `ValueError`) with the Rust error's message;
//! wrong array sizes raise it too, before any Rust call could assert. The GIL is released
//! while environments step, so the `VecEnv`'s threads run while Python waits.

mod control;
mod dynamics;
mod env;
mod policy;
mod sweep;

use std::sync::{Mutex, MutexGuard, TryLockError};

use pyo3::prelude::*;

pyo3::create_exception!(
    _native,
    CentaurError,
    pyo3::exceptions::PyValueError,
    "A Centaur call refused its input (bad options, sizes or values, a broken file)."
);

/// A `CentaurError` with `message`.
pub(crate) fn error(message: impl std::fmt::Display) -> PyErr {
    CentaurError::new_err(message.to_string())
}

/// Checks that an array argument has `expected` entries.
pub(crate) fn check_len(what: &str, got: usize, expected: usize) -> PyResult<()> {
    if got == expected {
        Ok(())
    } else {
        Err(error(format!("{what} has {got} entries, expected {expected}")))
    }
}

/// Locks an object's Rust state. An object serves one call at a time: a second thread
/// calling it meanwhile gets an error (waiting would deadlock on the GIL, which the first
/// call releases while it steps); a call that panicked half-way leaves it unusable.
pub(crate) fn lock<'a, T>(m: &'a Mutex<T>, what: &str) -> PyResult<MutexGuard<'a, T>> {
    m.try_lock().map_err(|e| match e {
        TryLockError::WouldBlock => error(format!("this {what} is in use by another thread")),
        TryLockError::Poisoned(_) => {
            error(format!("this {what} was left in an unknown state by a failed call; make a new one"))
        }
    })
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CentaurError", m.py().get_type::<CentaurError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    env::register(m)?;
    dynamics::register(m)?;
    control::register(m)?;
    policy::register(m)?;
    sweep::register(m)?;
    Ok(())
}
