//! Checks of the values a caller hands in — lengths of state vectors, finiteness — shared by
//! every floor (the compiled models, the routes, `Dynamics`, the integrators), so they live at
//! the bottom and name nothing but the error type.

use crate::error::{Error, Result};

/// Check lengths and finiteness of a state.
pub(crate) fn check_state(n: usize, t: f64, q: &[f64], qd: Option<&[f64]>) -> Result<()> {
    if q.len() != n {
        return Err(Error::DimensionMismatch {
            what: "q",
            expected: n,
            got: q.len(),
        });
    }
    if let Some(qd) = qd {
        if qd.len() != n {
            return Err(Error::DimensionMismatch {
                what: "qd",
                expected: n,
                got: qd.len(),
            });
        }
        finite(qd, "velocity", t)?;
    }
    finite(&[t], "time", t)?;
    finite(q, "coordinate", t)
}

/// `Err(NonFinite)` unless every value is finite.
pub(crate) fn finite(values: &[f64], what: &'static str, t: f64) -> Result<()> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Error::NonFinite { what, t })
    }
}

/// Check the lengths the generic `*_into` methods are called with.
pub(crate) fn check_lengths<D>(n: usize, q: &[D], qd: &[D], out: &[D]) -> Result<()> {
    for (what, len) in [("q", q.len()), ("qd", qd.len()), ("output", out.len())] {
        if len != n {
            return Err(Error::DimensionMismatch {
                what,
                expected: n,
                got: len,
            });
        }
    }
    Ok(())
}
