//! RATTLE's constrained stages, shared by the explicit splittings (`symplectic.rs`) and the
//! midpoint variational integrator (`variational.rs`) on a constrained system with holonomic
//! rows g(t, q) = 0 (H. C. Andersen, "Rattle: a 'velocity' version of the Shake algorithm",
//! *J. Comput. Phys.* 52 (1983) 24–34; Hairer, Lubich & Wanner, *Geometric Numerical
//! Integration*, §VII.1.4):
//!
//! - the constrained drift: after a kick to v, q₁ = q₀ + h (v − M⁻¹G(q₀)ᵀΛ) with Λ such that
//!   g(t₁, q₁) = 0, by Newton on Λ with the k × k matrix G(q₁) M⁻¹ G(q₀)ᵀ, to round-off;
//! - the velocity stage: v₁ ← v₁ − M⁻¹G(q₁)ᵀμ with G(q₁) v₁ + ∂g/∂t(t₁, q₁) = 0 (linear in μ,
//!   the symmetric positive definite G M⁻¹ Gᵀ).
//!
//! Both correct along M⁻¹Gᵀ, the direction of the constraint forces, so the map stays
//! symplectic on the constraint manifold T*𝓜 (HLW Theorem VII.1.4). Velocity (nonholonomic)
//! rows have no position-level equation for the drift to solve: they are refused.

use crate::dynamics::{ConstraintAccess, Dynamics};
use crate::error::{Error, Result};
use crate::linalg::{ldlt_in_place, ldlt_solve};
use crate::nonlinear::{Convergence, Lu, Verdict, max_norm};

/// Newton iterations allowed for the drift's multipliers (quadratic convergence from the
/// unconstrained drift, O(h²) off the manifold, takes three or four).
const MAX_ITERATIONS: usize = 30;

/// `Err(why)` when the system's constraints are not RATTLE's: velocity rows.
pub(crate) fn holonomic_only<S: Dynamics + ?Sized>(
    system: &S,
    method: &str,
) -> std::result::Result<(), String> {
    match system.constraints() {
        Some(c) if c.velocity_rows() > 0 => Err(format!(
            "the model is constrained with {} velocity (nonholonomic) rows, and {method}'s \
             constrained (RATTLE) step holds holonomic rows g(t, q) = 0 only: a velocity row \
             has no position-level equation for the drift to solve; the Runge–Kutta methods \
             and radau5 project each step back onto every row",
            c.velocity_rows()
        )),
        _ => Ok(()),
    }
}

/// The constraint manifold at the current point: G, W = M⁻¹Gᵀ, and the work space of the
/// two constrained stages. Allocated once per run.
pub(crate) struct Manifold {
    n: usize,
    k: usize,
    /// G(t, q), k × n row-major, at the current point.
    g: Vec<f64>,
    /// W = M⁻¹Gᵀ at the current point, stored as its k columns of length n.
    w: Vec<f64>,
    /// G at a Newton iterate.
    g_trial: Vec<f64>,
    trial: Vec<f64>,
    r: Vec<f64>,
    rates: Vec<f64>,
    lambda: Vec<f64>,
    s: Vec<f64>,
    lu: Lu<f64>,
    /// A zero velocity: holonomic rows of G do not read it.
    zero: Vec<f64>,
}

impl Manifold {
    pub(crate) fn new(n: usize, k: usize) -> Self {
        Self {
            n,
            k,
            g: vec![0.0; k * n],
            w: vec![0.0; k * n],
            g_trial: vec![0.0; k * n],
            trial: vec![0.0; n],
            r: vec![0.0; k],
            rates: vec![0.0; k],
            lambda: vec![0.0; k],
            s: vec![0.0; k * k],
            lu: Lu::new(k),
            zero: vec![0.0; n],
        }
    }

    /// G and W = M⁻¹Gᵀ at (t, q); `mass` is M's LDLᵀ factor there.
    pub(crate) fn tangent(
        &mut self,
        c: &dyn ConstraintAccess,
        mass: &[f64],
        t: f64,
        q: &[f64],
    ) -> Result<()> {
        c.jacobian_into(t, q, &self.zero, &mut self.g)?;
        self.solve_w(mass, t)
    }

    /// W = M⁻¹Gᵀ from the current G.
    fn solve_w(&mut self, mass: &[f64], t: f64) -> Result<()> {
        let n = self.n;
        self.w.copy_from_slice(&self.g);
        for col in self.w.chunks_exact_mut(n) {
            ldlt_solve(mass, n, col);
        }
        crate::checks::finite(&self.w, "M⁻¹Gᵀ", t)
    }

    /// The constrained drift from the point of the last [`tangent`](Self::tangent): q ← q +
    /// ha (v − WΛ/ha) with g(t1, q) = 0, v ← v − WΛ/ha; then G and W at the new point.
    ///
    /// # Errors
    /// [`Error::NewtonFailure`] (or [`Error::NonFinite`]) when the multipliers' Newton iteration
    /// does not converge in [`MAX_ITERATIONS`]; [`Error::DependentConstraints`] naming the row
    /// when G M⁻¹ Gᵀ is singular (redundant rows, a dead point).
    pub(crate) fn drift(
        &mut self,
        c: &dyn ConstraintAccess,
        mass: &[f64],
        t1: f64,
        q: &mut [f64],
        v: &mut [f64],
        ha: f64,
    ) -> Result<()> {
        let (n, k) = (self.n, self.k);
        for ((x, &q), &v) in self.trial.iter_mut().zip(q.iter()).zip(v.iter()) {
            *x = q + ha * v;
        }
        self.lambda.fill(0.0);
        let mut conv = Convergence::new(MAX_ITERATIONS);
        loop {
            c.holonomic_into(t1, &self.trial, &mut self.r);
            if !self.r.iter().all(|x| x.is_finite()) {
                conv.not_finite("constraint residual", t1);
                return Err(conv.failure(t1));
            }
            c.jacobian_into(t1, &self.trial, &self.zero, &mut self.g_trial)?;
            // S = G(q₁) M⁻¹ G(q₀)ᵀ, column-major in the LU's matrix.
            let m = self.lu.matrix();
            for i in 0..k {
                for j in 0..k {
                    m[(i, j)] = dot(
                        &self.g_trial[i * n..(i + 1) * n],
                        &self.w[j * n..(j + 1) * n],
                    );
                }
            }
            if !self.lu.factor() {
                return Err(self.singular(c, t1, q, v));
            }
            self.lu.solve(&mut self.r);
            let mut step = 0.0_f64;
            for (x, i) in self.trial.iter_mut().zip(0..n) {
                let d: f64 = (0..k).map(|j| self.w[j * n + i] * self.r[j]).sum();
                *x -= d;
                step = step.max(d.abs());
            }
            for (l, d) in self.lambda.iter_mut().zip(&self.r) {
                *l += d;
            }
            let scale = max_norm(&self.trial).max(f64::MIN_POSITIVE);
            match conv.judge(step / scale) {
                Verdict::Continue => {}
                Verdict::Converged => break,
                Verdict::Failed => return Err(conv.failure(t1)),
            }
        }
        for (i, vi) in v.iter_mut().enumerate() {
            let d: f64 = (0..k).map(|j| self.w[j * n + i] * self.lambda[j]).sum();
            *vi -= d / ha;
        }
        q.copy_from_slice(&self.trial);
        // The tangent at the new point: G from the last iterate, which the last increment (at
        // round-off) moved by nothing that G could resolve.
        std::mem::swap(&mut self.g, &mut self.g_trial);
        self.solve_w(mass, t1)
    }

    /// RATTLE's velocity stage at the point of the last [`tangent`](Self::tangent): v ← v − Wμ
    /// with G v + ∂g/∂t = 0. Returns the largest residual left, |g(t, q)| and |G v + ∂g/∂t|.
    ///
    /// # Errors
    /// [`Error::DependentConstraints`] when G M⁻¹ Gᵀ is singular; [`Error::NonFinite`].
    pub(crate) fn project_velocity(
        &mut self,
        c: &dyn ConstraintAccess,
        t: f64,
        q: &[f64],
        v: &mut [f64],
    ) -> Result<f64> {
        let (n, k) = (self.n, self.k);
        c.holonomic_rates_into(t, q, &mut self.rates);
        for i in 0..k {
            self.r[i] = dot(&self.g[i * n..(i + 1) * n], v) + self.rates[i];
            for j in 0..k {
                self.s[i * k + j] = dot(&self.g[i * n..(i + 1) * n], &self.w[j * n..(j + 1) * n]);
            }
        }
        if ldlt_in_place(&mut self.s, k).is_err() {
            return Err(self.singular(c, t, q, v));
        }
        ldlt_solve(&self.s, k, &mut self.r);
        for (i, vi) in v.iter_mut().enumerate() {
            *vi -= (0..k).map(|j| self.w[j * n + i] * self.r[j]).sum::<f64>();
        }
        let mut worst = 0.0_f64;
        for i in 0..k {
            let r = dot(&self.g[i * n..(i + 1) * n], v) + self.rates[i];
            worst = worst.max(r.abs());
        }
        c.holonomic_into(t, q, &mut self.r);
        let worst = self.r.iter().fold(worst, |m, x| m.max(x.abs()));
        if worst.is_finite() {
            Ok(worst)
        } else {
            Err(Error::NonFinite {
                what: "constraint residual",
                t,
            })
        }
    }

    /// The error for a singular G M⁻¹ Gᵀ: the constrained system's own (naming the dependent
    /// row) at (t, q, v), else a Newton failure at t.
    fn singular(&self, c: &dyn ConstraintAccess, t: f64, q: &[f64], v: &[f64]) -> Error {
        let mut multipliers = vec![0.0; self.k];
        let mut reactions = vec![0.0; self.n];
        match c.multipliers_into(t, q, v, &mut multipliers, &mut reactions) {
            Err(e) => e,
            Ok(()) => Error::NewtonFailure {
                t,
                iterations: 0,
                residual: f64::INFINITY,
            },
        }
    }
}

fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}
