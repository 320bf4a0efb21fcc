//! What the implicit integrators share: the inverse Legendre map p ↦ q̇, and the fixed steps
//! of an implicit method, halved where Newton fails. Their Newton iterations are
//! [`crate::nonlinear`]'s, their Jacobians [`crate::dynamics`]'s; the force G = ∂L/∂q + Q″ −
//! ∂Φ/∂q̇ of the (q, p) form of eq. 55 is [`crate::dynamics`]'s `ForceParts`.
//!
//! Every buffer is allocated once per run, so the step loops do not touch the allocator.

use super::dense::{Ends, Interpolant};
use super::run::{Flow, Run, SegmentStepper};
use super::solution::Statistics;
use crate::dynamics::Dynamics;
use crate::error::Result;
use crate::linalg::ldlt_solve;
use crate::nonlinear::{Convergence, Verdict, max_norm};

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
    ///
    /// [`Error::SingularMassMatrix`]: crate::Error::SingularMassMatrix
    /// [`Error::NonFinite`]: crate::Error::NonFinite
    /// [`Error::NewtonFailure`]: crate::Error::NewtonFailure
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
        crate::linalg::factor_mass(&mut self.mass, n, t, q)?;
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
/// [`Error::NewtonFailure`](crate::Error::NewtonFailure): down to dt / 2¹⁰.
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
