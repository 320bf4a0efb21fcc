//! The convergence test of a Newton iteration run to round-off, and the update step of a
//! simplified Newton iteration.

use super::lu::Lu;
use crate::error::Error;

/// Increments below this (relative) size are round-off.
const ROUND_OFF: f64 = 4.0 * f64::EPSILON;

/// Increments that stop shrinking below this size have reached the round-off floor of the
/// residual (cancellation in it can keep them above [`ROUND_OFF`]).
const PLATEAU: f64 = 1e-12;

/// What one Newton increment says about the iteration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Keep iterating.
    Continue,
    /// Converged to round-off.
    Converged,
    /// Diverging, stalled above round-off, or out of iterations.
    Failed,
}

/// The convergence test of a Newton iteration run to round-off, as the symmetric methods need
/// to be time-reversible: stop when the scaled increment itself is at round-off — not merely
/// the remaining error predicted from the contraction θ, because the quantities evaluated
/// before the last increment (the stage forces) must agree with the final iterate to
/// round-off too — or when increments below [`PLATEAU`] stop shrinking (the residual's
/// round-off floor); fail when θ ≥ 1 above that, or after `max_iterations`.
///
/// An iteration ended by a NaN or an infinity remembers which quantity it was and when, so
/// that its failure is [`Error::NonFinite`], as in the explicit methods, not a residual of NaN.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Convergence {
    previous: f64,
    /// Iterations so far.
    pub(crate) iterations: usize,
    /// Scaled norm of the last increment.
    pub(crate) last: f64,
    /// The last contraction factor θ (0 until two increments are known).
    pub(crate) rate: f64,
    max_iterations: usize,
    /// The quantity that was not finite, and the time it was evaluated at.
    non_finite: Option<(&'static str, f64)>,
}

impl Convergence {
    pub(crate) fn new(max_iterations: usize) -> Self {
        Self {
            previous: f64::INFINITY,
            iterations: 0,
            last: f64::INFINITY,
            rate: 0.0,
            max_iterations,
            non_finite: None,
        }
    }

    /// The record of an iteration that failed after `iterations` with a last scaled increment
    /// (or residual) `last`, judged elsewhere; `non_finite` as in
    /// [`not_finite`](Self::not_finite) when a NaN or an infinity ended it.
    pub(crate) fn failed(
        iterations: usize,
        last: f64,
        non_finite: Option<(&'static str, f64)>,
    ) -> Self {
        Self {
            previous: f64::INFINITY,
            iterations,
            last,
            rate: f64::NAN,
            max_iterations: iterations,
            non_finite,
        }
    }

    /// The Newton matrix could not be factored (it is singular, or not finite): the attempt
    /// fails before its first iteration. `jacobian` is the Jacobian it was built from, and the
    /// time of its evaluation.
    pub(crate) fn unfactored(jacobian: &[f64], t: f64) -> Self {
        let finite = jacobian.iter().all(|x| x.is_finite());
        Self::failed(0, f64::INFINITY, (!finite).then_some(("Jacobian", t)))
    }

    /// End the iteration because `what`, evaluated at time `t`, is not finite.
    pub(crate) fn not_finite(&mut self, what: &'static str, t: f64) -> Verdict {
        self.iterations += 1;
        self.last = f64::NAN;
        self.non_finite = Some((what, t));
        Verdict::Failed
    }

    /// Judge the scaled norm `d` of the increment just applied.
    pub(crate) fn judge(&mut self, d: f64) -> Verdict {
        self.iterations += 1;
        self.last = d;
        if !d.is_finite() {
            return Verdict::Failed;
        }
        if d <= ROUND_OFF {
            return Verdict::Converged;
        }
        if self.iterations > 1 {
            let theta = d / self.previous;
            self.rate = theta;
            if theta >= 1.0 {
                return if d <= PLATEAU {
                    Verdict::Converged
                } else {
                    Verdict::Failed
                };
            }
        }
        self.previous = d;
        if self.iterations >= self.max_iterations {
            Verdict::Failed
        } else {
            Verdict::Continue
        }
    }

    /// The typed error for a failed iteration of the step starting at `t`: [`Error::NonFinite`]
    /// when a value was not finite (a non-finite increment from finite residuals is the Newton
    /// increment's), [`Error::NewtonFailure`] otherwise.
    pub(crate) fn failure(&self, t: f64) -> Error {
        match self.non_finite {
            Some((what, at)) => Error::NonFinite { what, t: at },
            None if self.iterations > 0 && !self.last.is_finite() => Error::NonFinite {
                what: "Newton increment",
                t,
            },
            None => Error::NewtonFailure {
                t,
                iterations: self.iterations,
                residual: self.last,
            },
        }
    }
}

/// Whether a Newton matrix built for step length `built` serves a step of length `h`: the
/// equal steps of a fixed-step run differ in the last bits, and a simplified Newton iteration
/// does not need K exactly. `built` is NaN when there is no factorization.
pub(crate) fn same_step(built: f64, h: f64) -> bool {
    (h / built - 1.0).abs() <= 1e-6
}

/// ‖x‖∞.
pub(crate) fn max_norm(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// One simplified-Newton update with a factored matrix: solve J d = r in place (`r` becomes
/// d), x −= d, and judge ‖d‖∞ scaled by max(‖x‖∞, `floor`) — the tail that the Gauss–Legendre
/// and variational iterations share.
#[inline]
pub(crate) fn newton_update(
    lu: &Lu<f64>,
    r: &mut [f64],
    x: &mut [f64],
    floor: f64,
    conv: &mut Convergence,
) -> Verdict {
    lu.solve(r);
    for (v, d) in x.iter_mut().zip(r.iter()) {
        *v -= d;
    }
    let scale = max_norm(x).max(floor).max(f64::MIN_POSITIVE);
    conv.judge(max_norm(r) / scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn convergence_verdicts() {
        let mut c = Convergence::new(10);
        assert_eq!(c.judge(1e-2), Verdict::Continue);
        assert_eq!(c.judge(1e-5), Verdict::Continue);
        assert_eq!(c.judge(1e-11), Verdict::Continue);
        assert_eq!(c.judge(1e-14), Verdict::Continue);
        assert_eq!(c.judge(1e-16), Verdict::Converged);
        // Stagnation at the residual's round-off floor.
        let mut c = Convergence::new(10);
        assert_eq!(c.judge(1e-8), Verdict::Continue);
        assert_eq!(c.judge(3e-15), Verdict::Continue);
        assert_eq!(c.judge(4e-15), Verdict::Converged);
        let mut c = Convergence::new(10);
        assert_eq!(c.judge(1e-2), Verdict::Continue);
        assert_eq!(c.judge(2e-2), Verdict::Failed);
        let mut c = Convergence::new(2);
        assert_eq!(c.judge(1e-2), Verdict::Continue);
        assert_eq!(c.judge(0.9e-2), Verdict::Failed);
        assert_eq!(Convergence::new(5).judge(f64::NAN), Verdict::Failed);
    }

    #[test]
    fn failures_name_what_was_not_finite() {
        // A quantity that went non-finite is named, with the time it was evaluated at.
        let mut c = Convergence::new(10);
        c.judge(1e-3);
        assert_eq!(c.not_finite("forces", 0.25), Verdict::Failed);
        assert_eq!(
            c.failure(0.2),
            Error::NonFinite {
                what: "forces",
                t: 0.25
            }
        );
        // A non-finite increment from finite residuals is the increment's.
        let mut c = Convergence::new(10);
        c.judge(f64::INFINITY);
        assert_eq!(
            c.failure(0.5),
            Error::NonFinite {
                what: "Newton increment",
                t: 0.5
            }
        );
        // A non-finite Jacobian is named; a finite but singular one is a Newton failure.
        let c = Convergence::unfactored(&[1.0, f64::NAN], 1.5);
        assert_eq!(
            c.failure(1.0),
            Error::NonFinite {
                what: "Jacobian",
                t: 1.5
            }
        );
        assert!(matches!(
            Convergence::unfactored(&[0.0, 0.0], 1.5).failure(1.0),
            Error::NewtonFailure {
                t: 1.0,
                iterations: 0,
                ..
            }
        ));
        // Divergence with finite increments stays a Newton failure.
        let mut c = Convergence::new(10);
        c.judge(1e-2);
        c.judge(2e-2);
        assert_eq!(
            c.failure(3.0),
            Error::NewtonFailure {
                t: 3.0,
                iterations: 2,
                residual: 2e-2
            }
        );
    }
}
