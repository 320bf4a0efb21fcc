//! Newton's method globalised for a residual r(q) with an exact Jacobian K = ∂r/∂q: a
//! backtracking (Armijo) line search on ½|r|², Levenberg–Marquardt damping where K is singular
//! or a Newton step fails, and a last polishing step. The equilibria ([`crate::equilibrium`])
//! solve with it.

use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};

/// A residual r(q) with its Jacobian: what the Newton core solves.
pub(crate) trait Residual {
    /// r(q) and the load scale F at q. Fails (`NonFinite`) when r is not finite.
    fn residual(&mut self, q: &[f64]) -> Result<(DVector<f64>, f64)>;
    /// K = ∂r/∂q. Fails (`NonFinite`) when K is not finite.
    fn jacobian(&mut self, q: &[f64]) -> Result<DMatrix<f64>>;
}

/// The stopping rules of [`damped_newton`] (`StaticsOptions` states them for the equilibria).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Stopping {
    /// Absolute tolerance on |r|.
    pub(crate) abs_tolerance: f64,
    /// Tolerance on |r| relative to the load scale the residual reports.
    pub(crate) rel_tolerance: f64,
    /// Relative size of a Newton step below which the iteration has converged.
    pub(crate) step_tolerance: f64,
    /// Upper bound on iterations, failed line searches included.
    pub(crate) max_iterations: usize,
    /// Largest change of any coordinate in one iteration, |Δq|∞.
    pub(crate) max_step: f64,
}

/// A root of the residual, with the residual and K there.
#[derive(Debug)]
pub(crate) struct Root {
    pub(crate) q: DVector<f64>,
    pub(crate) r: DVector<f64>,
    pub(crate) k: DMatrix<f64>,
    pub(crate) iterations: usize,
}

/// Armijo constant: accept a step that achieves this fraction of the predicted decrease.
const ARMIJO: f64 = 1e-4;
/// Smallest line-search step fraction before the step counts as failed.
const MIN_STEP_FRACTION: f64 = 1e-10;
/// First Levenberg–Marquardt damping, relative to the largest diagonal entry of KᵀK.
const LM_INITIAL: f64 = 1e-3;
/// Damping below which the iteration returns to plain Newton steps.
const LM_OFF: f64 = 1e-7;
/// Damping above which no descent is possible: a minimum of |r| that is not a root.
const LM_MAX: f64 = 1e12;
/// A full-pivot LU pivot ratio below this makes K numerically singular.
const SINGULAR_PIVOT_RATIO: f64 = 1e-14;

/// Newton's method with an Armijo line search on ½|r|² and Levenberg–Marquardt fallback.
pub(crate) fn damped_newton<P: Residual>(
    problem: &mut P,
    q0: DVector<f64>,
    options: &Stopping,
) -> Result<Root> {
    let mut q = q0;
    let (mut r, mut scale) = problem.residual(q.as_slice())?;
    let mut k = problem.jacobian(q.as_slice())?;
    let mut lambda = 0.0;
    let mut iterations = 0;
    loop {
        let norm = r.norm();
        if norm <= options.abs_tolerance + options.rel_tolerance * scale {
            let converged = Root {
                q,
                r,
                k,
                iterations,
            };
            return Ok(if iterations < options.max_iterations {
                polish(problem, converged)
            } else {
                converged
            });
        }
        if iterations == options.max_iterations {
            return Err(no_convergence(iterations, norm, &q));
        }
        iterations += 1;

        let g = k.tr_mul(&r);
        let newton_step = if lambda == 0.0 {
            newton_direction(&k, &r)
        } else {
            None
        };
        let (mut d, is_newton) = match newton_step {
            Some(d) => {
                if d.amax() <= options.step_tolerance * q.amax() {
                    let q_new = &q + &d;
                    let (r_new, _) = problem.residual(q_new.as_slice())?;
                    let k_new = problem.jacobian(q_new.as_slice())?;
                    return Ok(Root {
                        q: q_new,
                        r: r_new,
                        k: k_new,
                        iterations,
                    });
                }
                (d, true)
            }
            None => {
                if g.iter().all(|&x| x == 0.0) {
                    // |r|² is stationary here but r ≠ 0: no descent direction exists.
                    return Err(no_convergence(iterations, norm, &q));
                }
                if lambda == 0.0 {
                    lambda = LM_INITIAL;
                }
                match lm_direction(&k, &g, lambda) {
                    Some(d) => (d, false),
                    None => {
                        lambda *= 10.0;
                        if lambda > LM_MAX {
                            return Err(no_convergence(iterations, norm, &q));
                        }
                        continue;
                    }
                }
            }
        };
        let longest = d.amax();
        if longest > options.max_step {
            d *= options.max_step / longest;
        }
        let slope = g.dot(&d);
        let searched = if slope < 0.0 {
            line_search(problem, &q, &d, 0.5 * norm * norm, slope)?
        } else {
            None
        };
        match searched {
            Some((q_new, r_new, scale_new)) => {
                k = problem.jacobian(q_new.as_slice())?;
                q = q_new;
                r = r_new;
                scale = scale.max(scale_new);
                if !is_newton {
                    lambda *= 0.1;
                    if lambda < LM_OFF {
                        lambda = 0.0;
                    }
                }
            }
            None => {
                lambda = if lambda == 0.0 {
                    LM_INITIAL
                } else {
                    lambda * 10.0
                };
                if lambda > LM_MAX {
                    return Err(no_convergence(iterations, norm, &q));
                }
            }
        }
    }
}

/// One more Newton step from a converged point, kept when it does not increase |r|: near a
/// regular root it squares the error, so q is accurate far beyond the residual tolerance.
fn polish<P: Residual>(problem: &mut P, s: Root) -> Root {
    let Some(d) = newton_direction(&s.k, &s.r) else {
        return s;
    };
    let q = &s.q + &d;
    if q == s.q {
        return s;
    }
    match (
        problem.residual(q.as_slice()),
        problem.jacobian(q.as_slice()),
    ) {
        (Ok((r, _)), Ok(k)) if r.norm() <= s.r.norm() => Root {
            q,
            r,
            k,
            iterations: s.iterations + 1,
        },
        _ => s,
    }
}

/// The Newton step −K⁻¹r, or `None` when K is numerically singular.
fn newton_direction(k: &DMatrix<f64>, r: &DVector<f64>) -> Option<DVector<f64>> {
    let lu = k.clone().full_piv_lu();
    let u = lu.u();
    let n = u.nrows();
    let (first, last) = (u[(0, 0)].abs(), u[(n - 1, n - 1)].abs());
    if !first.is_finite() || first == 0.0 || last <= SINGULAR_PIVOT_RATIO * first {
        return None;
    }
    let d = -lu.solve(r)?;
    d.iter().all(|v| v.is_finite()).then_some(d)
}

/// The damped step −(KᵀK + λ μ I)⁻¹ Kᵀr, μ the largest diagonal entry of KᵀK.
fn lm_direction(k: &DMatrix<f64>, g: &DVector<f64>, lambda: f64) -> Option<DVector<f64>> {
    let mut a = k.tr_mul(k);
    let mu = a.diagonal().amax();
    if !mu.is_finite() || mu == 0.0 {
        return None;
    }
    for i in 0..a.nrows() {
        a[(i, i)] += lambda * mu;
    }
    let d = -a.cholesky()?.solve(g);
    d.iter().all(|v| v.is_finite()).then_some(d)
}

/// Backtracking from the full step until ½|r|² drops by the Armijo fraction of the predicted
/// decrease. Trial points where the model is not finite are stepped back from; if no finite
/// point was met at all, that error is returned. `None` when no step fraction is accepted.
#[allow(clippy::type_complexity)]
fn line_search<P: Residual>(
    problem: &mut P,
    q: &DVector<f64>,
    d: &DVector<f64>,
    merit: f64,
    slope: f64,
) -> Result<Option<(DVector<f64>, DVector<f64>, f64)>> {
    let mut alpha = 1.0;
    let mut last_error = None;
    let mut met_finite = false;
    while alpha >= MIN_STEP_FRACTION {
        let q_new = q + d * alpha;
        if q_new == *q {
            break;
        }
        match problem.residual(q_new.as_slice()) {
            Ok((r_new, scale)) => {
                met_finite = true;
                let merit_new = 0.5 * r_new.norm_squared();
                if merit_new <= merit + ARMIJO * alpha * slope {
                    return Ok(Some((q_new, r_new, scale)));
                }
            }
            Err(e @ Error::NonFinite { .. }) => last_error = Some(e),
            Err(e) => return Err(e),
        }
        alpha *= 0.5;
    }
    match last_error {
        Some(e) if !met_finite => Err(e),
        _ => Ok(None),
    }
}

fn no_convergence(iterations: usize, residual: f64, q: &DVector<f64>) -> Error {
    Error::NoConvergence {
        iterations,
        residual,
        q: q.iter().copied().collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The stopping rules of the equilibria's defaults.
    fn defaults() -> Stopping {
        Stopping {
            abs_tolerance: 0.0,
            rel_tolerance: 1e-12,
            step_tolerance: 1e-12,
            max_iterations: 100,
            max_step: f64::INFINITY,
        }
    }

    /// A residual given by closures, for testing the Newton core on its own.
    struct Fun<R, J>(R, J);

    impl<R, J> Residual for Fun<R, J>
    where
        R: FnMut(&[f64]) -> Vec<f64>,
        J: FnMut(&[f64]) -> Vec<f64>,
    {
        fn residual(&mut self, q: &[f64]) -> Result<(DVector<f64>, f64)> {
            let r = DVector::from_vec((self.0)(q));
            if r.iter().all(|v| v.is_finite()) {
                let scale = r.norm();
                Ok((r, scale))
            } else {
                Err(Error::NonFinite {
                    what: "test residual",
                    t: 0.0,
                })
            }
        }
        fn jacobian(&mut self, q: &[f64]) -> Result<DMatrix<f64>> {
            let n = q.len();
            Ok(DMatrix::from_row_slice(n, n, &(self.1)(q)))
        }
    }

    #[test]
    fn newton_circle_and_hyperbola() {
        // x² + y² = 5, x y = 2: roots (1, 2), (2, 1) and their negatives.
        let mut f = Fun(
            |q: &[f64]| vec![q[0] * q[0] + q[1] * q[1] - 5.0, q[0] * q[1] - 2.0],
            |q: &[f64]| vec![2.0 * q[0], 2.0 * q[1], q[1], q[0]],
        );
        let opts = defaults();
        let s = damped_newton(&mut f, DVector::from_vec(vec![0.7, 2.9]), &opts).unwrap();
        assert_relative_eq!(s.q[0], 1.0, epsilon = 1e-14);
        assert_relative_eq!(s.q[1], 2.0, epsilon = 1e-14);
        assert!(s.iterations <= 10, "{} iterations", s.iterations);
        let s = damped_newton(&mut f, DVector::from_vec(vec![-3.0, -0.5]), &opts).unwrap();
        assert_relative_eq!(s.q[0], -2.0, epsilon = 1e-14);
        assert_relative_eq!(s.q[1], -1.0, epsilon = 1e-14);
    }

    #[test]
    fn newton_atan_needs_line_search() {
        // Plain Newton on atan diverges from |x₀| > 1.39; the line search brings it home.
        let mut f = Fun(
            |q: &[f64]| vec![q[0].atan()],
            |q: &[f64]| vec![1.0 / (1.0 + q[0] * q[0])],
        );
        let s = damped_newton(&mut f, DVector::from_vec(vec![10.0]), &defaults()).unwrap();
        assert!(s.q[0].abs() < 1e-12, "q = {}", s.q[0]);
        assert!(s.iterations <= 30, "{} iterations", s.iterations);
    }

    #[test]
    fn newton_steps_back_from_non_finite() {
        // r = √q − 1: the first full step from q = 9 lands at q = −3 where √q is NaN.
        let mut f = Fun(
            |q: &[f64]| vec![q[0].sqrt() - 1.0],
            |q: &[f64]| vec![0.5 / q[0].sqrt()],
        );
        let s = damped_newton(&mut f, DVector::from_vec(vec![9.0]), &defaults()).unwrap();
        assert_relative_eq!(s.q[0], 1.0, epsilon = 1e-14);
    }

    #[test]
    fn newton_singular_jacobian_uses_damping() {
        // r = (x² + y − 1, x − y): roots x = y = (−1 ± √5)/2; K is singular on x = −½, where
        // the guess starts.
        let mut f = Fun(
            |q: &[f64]| vec![q[0] * q[0] + q[1] - 1.0, q[0] - q[1]],
            |q: &[f64]| vec![2.0 * q[0], 1.0, 1.0, -1.0],
        );
        let guess = DVector::from_vec(vec![-0.5, 0.0]);
        let s = damped_newton(&mut f, guess, &defaults()).unwrap();
        let root = if s.q[0] > 0.0 {
            0.5 * (5.0_f64.sqrt() - 1.0)
        } else {
            -0.5 * (5.0_f64.sqrt() + 1.0)
        };
        assert_relative_eq!(s.q[0], root, epsilon = 1e-14);
        assert_relative_eq!(s.q[1], root, epsilon = 1e-14);
    }

    #[test]
    fn newton_no_root_fails() {
        // r = q² + 1 ≥ 1 has no root; |r| has a minimum at q = 0 where K = 0.
        let mut f = Fun(
            |q: &[f64]| vec![q[0] * q[0] + 1.0],
            |q: &[f64]| vec![2.0 * q[0]],
        );
        for q0 in [1.0, 0.7, -2.3] {
            let e = damped_newton(&mut f, DVector::from_vec(vec![q0]), &defaults()).unwrap_err();
            match e {
                Error::NoConvergence {
                    iterations,
                    residual,
                    ..
                } => {
                    assert!(iterations <= 100);
                    assert!(residual >= 1.0);
                }
                other => panic!("expected NoConvergence, got {other:?}"),
            }
        }
    }

    #[test]
    fn newton_iteration_bound_is_kept() {
        let mut f = Fun(
            |q: &[f64]| vec![q[0].atan()],
            |q: &[f64]| vec![1.0 / (1.0 + q[0] * q[0])],
        );
        let opts = Stopping {
            max_iterations: 2,
            ..defaults()
        };
        let e = damped_newton(&mut f, DVector::from_vec(vec![10.0]), &opts).unwrap_err();
        assert!(matches!(e, Error::NoConvergence { iterations: 2, .. }));
    }
}
