//! What the implicit methods share: Jacobians by forward-mode AD (the system's generic
//! `*_into` methods evaluated on [`Dual64`], one direction per column — no finite differences),
//! an in-place LU factorization, the convergence test of a Newton iteration, and the inverse
//! Legendre map p ↦ q̇. The force G = ∂L/∂q + Q″ − ∂Φ/∂q̇ of the (q, p) form of eq. 55 is
//! [`crate::eom`]'s `ForceParts`.
//!
//! Every buffer is allocated once per run, so the step loops do not touch the allocator.

use super::dense::{Ends, Interpolant};
use super::{Flow, Run, SegmentStepper, Statistics};
use crate::dynamics::Dynamics;
use crate::eom;
use crate::error::{Error, Result};
use crate::linalg::ldlt_solve;
use nalgebra::{ComplexField, DMatrix};
use num_dual::Dual64;

/// The scalars the LU works on: `f64`, and `Complex<f64>` for Radau's complex system.
pub(crate) trait Field: ComplexField<RealField = f64> + Copy {}
impl<T: ComplexField<RealField = f64> + Copy> Field for T {}

/// An LU factorization with partial pivoting that overwrites a preallocated matrix, so that
/// refactoring allocates nothing (nalgebra's `LU::new` takes the matrix by value and allocates
/// its permutation on every call). The elimination is the one of nalgebra's `LU`.
pub(crate) struct Lu<T: Field> {
    /// The matrix to factor; after [`factor`](Self::factor), L (unit diagonal) and U packed.
    a: DMatrix<T>,
    /// Row exchanged with row k at step k.
    piv: Vec<usize>,
}

impl<T: Field> Lu<T> {
    /// Work space for an `n × n` matrix.
    pub(crate) fn new(n: usize) -> Self {
        Self {
            a: DMatrix::from_element(n, n, T::zero()),
            piv: vec![0; n],
        }
    }

    /// The matrix to fill before [`factor`](Self::factor).
    pub(crate) fn matrix(&mut self) -> &mut DMatrix<T> {
        &mut self.a
    }

    /// Factor in place; `false` when a pivot is zero or not finite (the matrix is singular).
    pub(crate) fn factor(&mut self) -> bool {
        let n = self.a.nrows();
        let a = self.a.as_mut_slice();
        for k in 0..n {
            let mut p = k;
            let mut best = -1.0;
            for i in k..n {
                let v = a[k * n + i].norm1();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best.is_finite() && best > 0.0) {
                return false;
            }
            self.piv[k] = p;
            if p != k {
                for j in 0..n {
                    a.swap(j * n + k, j * n + p);
                }
            }
            let inv = T::one() / a[k * n + k];
            for i in k + 1..n {
                a[k * n + i] *= inv;
            }
            for j in k + 1..n {
                let akj = a[j * n + k];
                if akj != T::zero() {
                    for i in k + 1..n {
                        let lik = a[k * n + i];
                        a[j * n + i] -= lik * akj;
                    }
                }
            }
        }
        true
    }

    /// Solve A x = b in place with the factored A.
    pub(crate) fn solve(&self, b: &mut [T]) {
        let n = self.a.nrows();
        let a = self.a.as_slice();
        for k in 0..n {
            b.swap(k, self.piv[k]);
        }
        for j in 0..n {
            let bj = b[j];
            if bj != T::zero() {
                for i in j + 1..n {
                    b[i] -= a[j * n + i] * bj;
                }
            }
        }
        for j in (0..n).rev() {
            b[j] /= a[j * n + j];
            let bj = b[j];
            for i in 0..j {
                b[i] -= a[j * n + i] * bj;
            }
        }
    }
}

/// `jac[(i, j)] = ∂fᵢ/∂xⱼ` at `x` by forward mode: column j from one evaluation of `f` on
/// [`Dual64`] seeded in xⱼ. `xd` (length of x) and `fd` (length of f) are work space.
pub(crate) fn jacobian(
    x: &[f64],
    xd: &mut [Dual64],
    fd: &mut [Dual64],
    jac: &mut DMatrix<f64>,
    mut f: impl FnMut(&[Dual64], &mut [Dual64]) -> Result<()>,
) -> Result<()> {
    for (d, &v) in xd.iter_mut().zip(x) {
        *d = Dual64::from_re(v);
    }
    for j in 0..x.len() {
        xd[j].eps = 1.0;
        let r = f(xd, fd);
        xd[j].eps = 0.0;
        r?;
        for (i, y) in fd.iter().enumerate() {
            jac[(i, j)] = y.eps;
        }
    }
    Ok(())
}

/// ∂a/∂(q, q̇) at (t, q, q̇), the lower half of the Jacobian of the first-order system
/// y = (q, q̇), ẏ = (q̇, a): `jac` is n × 2n. `xd` has length 2n, `fd` length n. From the
/// machine code of the system's derived program when it has one, otherwise (and when that
/// code's checks fail, so that the error is the accelerations' own) by dual numbers.
pub(crate) fn acceleration_jacobian<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    y: &[f64],
    xd: &mut [Dual64],
    fd: &mut [Dual64],
    jac: &mut DMatrix<f64>,
) -> Result<()> {
    let n = y.len() / 2;
    if let Some(program) = system.derived_program()
        && program.acceleration_jacobian(t, &y[..n], &y[n..], jac.as_mut_slice())
    {
        return Ok(());
    }
    let td = Dual64::from_re(t);
    jacobian(y, xd, fd, jac, |x, out| {
        system.accelerations_into(td, &x[..n], &x[n..], out)
    })
}

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

/// Work space of [`Legendre::velocity`].
pub(crate) struct Legendre {
    mass: Vec<f64>,
    residual: Vec<f64>,
}

/// Newton iterations allowed for p ↦ q̇ (for T quadratic in q̇ the first one is exact).
const LEGENDRE_ITERATIONS: usize = 30;

impl Legendre {
    pub(crate) fn new(n: usize) -> Self {
        Self {
            mass: vec![0.0; n * n],
            residual: vec![0.0; n],
        }
    }

    /// Solve ∂L/∂q̇(t, q, v) = p for the velocity v, by Newton from the guess in `v`, with
    /// M = ∂²T/∂q̇² (LDLᵀ) at the guess. `floor` is the smallest velocity scale that the
    /// convergence test measures increments against.
    ///
    /// # Errors
    /// [`Error::SingularMassMatrix`] when M cannot be factored (the Legendre map is not
    /// invertible there), [`Error::NonFinite`] when the momenta or the velocity are not
    /// finite, [`Error::NewtonFailure`] when the iteration does not converge.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn velocity<S: Dynamics + ?Sized>(
        &mut self,
        system: &S,
        t: f64,
        q: &[f64],
        p: &[f64],
        v: &mut [f64],
        floor: f64,
        stats: &mut Statistics,
    ) -> Result<()> {
        let n = q.len();
        system.mass_matrix_into(t, q, v, &mut self.mass);
        eom::factor(&mut self.mass, n, t, q)?;
        stats.factorizations += 1;
        let mut conv = Convergence::new(LEGENDRE_ITERATIONS);
        loop {
            system.momenta_into(t, q, v, &mut self.residual);
            for (r, pi) in self.residual.iter_mut().zip(p) {
                *r -= pi;
            }
            if !self.residual.iter().all(|x| x.is_finite()) {
                conv.not_finite("momenta", t);
                return Err(conv.failure(t));
            }
            ldlt_solve(&self.mass, n, &mut self.residual);
            for (vi, d) in v.iter_mut().zip(&self.residual) {
                *vi -= d;
            }
            let scale = max_norm(v).max(floor).max(f64::MIN_POSITIVE);
            match conv.judge(max_norm(&self.residual) / scale) {
                Verdict::Continue => {}
                Verdict::Converged => return Ok(()),
                Verdict::Failed => return Err(conv.failure(t)),
            }
        }
    }
}

/// A one-step method whose implicit equations may fail to converge; the state y = (q, q̇) is
/// kept by the method (methods on (q, p) keep p alongside).
pub(crate) trait ImplicitStep<S: Dynamics + ?Sized> {
    /// Advance the state from `t` by `h`: `Ok(None)` when the step was taken, `Ok(Some(c))`
    /// when its Newton iteration `c` failed (the state is then unchanged).
    fn attempt(&mut self, run: &mut Run<'_, S>, t: f64, h: f64) -> Result<Option<Convergence>>;

    /// The current state y = (q, q̇).
    fn state(&self) -> &[f64];
}

/// How often a fixed step may be halved after Newton failures before
/// [`Error::NewtonFailure`]: down to dt / 2¹⁰.
pub(crate) const MAX_HALVINGS: usize = 10;

/// The fixed steps of an implicit method: equal steps of about `dt`; a step whose Newton
/// iteration fails is retried as two half steps, recursively up to [`MAX_HALVINGS`] times (each
/// failure counts as a rejected step and a Newton failure, each step taken as an accepted one).
/// Interpolant: quintic Hermite through (q, q̇, q̈) at both ends of the step.
pub(crate) struct FixedSteps<M> {
    method: M,
    /// Step `i` of `steps` is next.
    i: usize,
    steps: usize,
    y_old: Vec<f64>,
    f_old: Vec<f64>,
    f_new: Vec<f64>,
    /// Whether `f_old` is ẏ at the current state (the previous step's end).
    have_f_old: bool,
}

impl<M> FixedSteps<M> {
    pub(crate) fn new<S: Dynamics + ?Sized>(run: &Run<'_, S>, method: M, dt: f64) -> Result<Self> {
        let n = run.n;
        Ok(Self {
            method,
            i: 0,
            steps: run.fixed_steps(dt)?,
            y_old: vec![0.0; 2 * n],
            f_old: vec![0.0; 2 * n],
            f_new: vec![0.0; 2 * n],
            have_f_old: false,
        })
    }
}

impl<S: Dynamics + ?Sized, M: ImplicitStep<S>> SegmentStepper<S> for FixedSteps<M> {
    fn step(&mut self, run: &mut Run<'_, S>) -> Result<Flow> {
        let n = run.n;
        let (i, steps) = (self.i, self.steps);
        self.i += 1;
        let t = run.grid_time(i, steps);
        let t_new = run.grid_time(i + 1, steps);
        let dense = run.needs_interpolant(t_new);
        if dense {
            self.y_old.copy_from_slice(self.method.state());
            if !self.have_f_old {
                run.rhs(t, &self.y_old, &mut self.f_old)?;
            }
        }
        advance(run, &mut self.method, t, t_new, 0)?;
        let y = self.method.state();
        if !dense {
            self.have_f_old = false;
            return run.accept(t, t_new, y, i + 1 == steps, None);
        }
        run.rhs(t_new, y, &mut self.f_new)?;
        let step = Interpolant::Hermite {
            t,
            h: t_new - t,
            ends: Ends {
                q0: &self.y_old[..n],
                v0: &self.y_old[n..],
                a0: &self.f_old[n..],
                q1: &y[..n],
                v1: &y[n..],
                a1: &self.f_new[n..],
            },
        };
        let flow = run.accept(t, t_new, y, i + 1 == steps, Some(&step))?;
        std::mem::swap(&mut self.f_old, &mut self.f_new);
        self.have_f_old = true;
        Ok(flow)
    }
}

/// One step from `t` to `t_end`, halved on Newton failure.
fn advance<S: Dynamics + ?Sized, M: ImplicitStep<S>>(
    run: &mut Run<'_, S>,
    method: &mut M,
    t: f64,
    t_end: f64,
    depth: usize,
) -> Result<()> {
    match method.attempt(run, t, t_end - t)? {
        None => {
            run.stats.accepted_steps += 1;
            Ok(())
        }
        Some(conv) => {
            run.stats.newton_failures += 1;
            run.stats.rejected_steps += 1;
            if depth >= MAX_HALVINGS {
                return Err(conv.failure(t));
            }
            let mid = t + 0.5 * (t_end - t);
            advance(run, method, t, mid, depth + 1)?;
            advance(run, method, mid, t_end, depth + 1)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::Complex;

    #[test]
    fn lu_solves_real_and_complex_systems() {
        // A matrix that needs pivoting (zero in the first diagonal entry).
        let rows = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, -1.0, 4.0]];
        let x = [1.0, -2.0, 0.5];
        let mut lu = Lu::<f64>::new(3);
        let mut b = [0.0; 3];
        for i in 0..3 {
            for j in 0..3 {
                lu.matrix()[(i, j)] = rows[i][j];
                b[i] += rows[i][j] * x[j];
            }
        }
        assert!(lu.factor());
        lu.solve(&mut b);
        for i in 0..3 {
            assert_relative_eq!(b[i], x[i], epsilon = 1e-14);
        }
        // (μ I − J) with complex μ, as in Radau.
        let mu = Complex::new(2.0, -1.5);
        let mut lu = Lu::<Complex<f64>>::new(3);
        let z = [
            Complex::new(1.0, 1.0),
            Complex::new(0.0, -2.0),
            Complex::new(0.5, 0.0),
        ];
        let mut b = [Complex::new(0.0, 0.0); 3];
        for i in 0..3 {
            for j in 0..3 {
                let e = if i == j { mu } else { Complex::new(0.0, 0.0) } - rows[i][j];
                lu.matrix()[(i, j)] = e;
                b[i] += e * z[j];
            }
        }
        assert!(lu.factor());
        lu.solve(&mut b);
        for i in 0..3 {
            assert!((b[i] - z[i]).norm() < 1e-14);
        }
        let mut singular = Lu::<f64>::new(2);
        singular.matrix().fill(1.0);
        assert!(!singular.factor());
    }

    #[test]
    fn jacobian_matches_hand_derivative() {
        // f(x, y) = (x² y, sin x + y³).
        let x = [0.7, -1.3];
        let mut xd = [Dual64::from_re(0.0); 2];
        let mut fd = [Dual64::from_re(0.0); 2];
        let mut jac = DMatrix::zeros(2, 2);
        jacobian(&x, &mut xd, &mut fd, &mut jac, |x, f| {
            f[0] = x[0] * x[0] * x[1];
            f[1] = x[0].sin() + x[1].powi(3);
            Ok(())
        })
        .unwrap();
        assert_relative_eq!(jac[(0, 0)], 2.0 * x[0] * x[1], epsilon = 1e-15);
        assert_relative_eq!(jac[(0, 1)], x[0] * x[0], epsilon = 1e-15);
        assert_relative_eq!(jac[(1, 0)], x[0].cos(), epsilon = 1e-15);
        assert_relative_eq!(jac[(1, 1)], 3.0 * x[1] * x[1], epsilon = 1e-15);
    }

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
