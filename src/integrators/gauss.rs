//! Gauss–Legendre collocation on (q, p), p = ∂L/∂q̇: symplectic and symmetric for any
//! Lagrangian — q-dependent mass matrix, gyroscopic and velocity-dependent terms — where the
//! explicit splittings do not apply.
//!
//! The (q, p) form of Lagrange's equations (eq. 55) is q̇ = v, ṗ = G(t, q, v) with
//! p = ∂L/∂q̇(t, q, v) and G = ∂L/∂q + Q″ − ∂Φ/∂q̇. The s-stage Gauss method applied to it
//! (Hairer, Lubich & Wanner, *Geometric Numerical Integration*, §II.1.3, §VI.4, §VI.6.3) is,
//! with the stage velocities Vᵢ as unknowns,
//!
//! Qᵢ = q₀ + h Σⱼ aᵢⱼ Vⱼ,   ∂L/∂q̇(Qᵢ, Vᵢ) = p₀ + h Σⱼ aᵢⱼ G(Qⱼ, Vⱼ),
//! q₁ = q₀ + h Σⱼ bⱼ Vⱼ,    p₁ = p₀ + h Σⱼ bⱼ G(Qⱼ, Vⱼ),
//!
//! so no inverse Legendre map is needed inside the iteration; q̇₁ is recovered from p₁ once per
//! step. Without Q″ and Φ this is a symplectic Runge–Kutta method for the Hamiltonian system in
//! (q, p); with them it is the collocation form of the Lagrange–d'Alembert principle (eq. 35):
//! the non-conservative forces enter ṗ at the stages.
//!
//! The s·n equations are solved by simplified Newton with the AD Jacobian of (p, G) in (q, v)
//! at the start of a step,
//!
//! K = I ⊗ ∂p/∂v + h A ⊗ (∂p/∂q − ∂G/∂v) − h² A² ⊗ ∂G/∂q,
//!
//! factored once and kept over the following steps while the iteration converges fast; the
//! iteration runs to round-off, so the reuse changes the work, not the result. Starting values
//! come from the previous step's collocation polynomial.

use super::implicit::{FixedSteps, ImplicitStep, Legendre};
use super::run::{Integrator, Run, SegmentStepper, unconstrained_only};
use crate::dynamics::Dynamics;
use crate::dynamics::ForceParts;
use crate::dynamics::jacobian;
use crate::error::{Error, Result};
use crate::nonlinear::{Convergence, Lu, Verdict, max_norm, newton_update, same_step};
use nalgebra::DMatrix;
use num_dual::Dual64;

/// The coefficients of an s-stage Gauss–Legendre method: nodes at the zeros of the shifted
/// Legendre polynomial Pₛ(2c − 1), order 2s.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct GaussTableau {
    pub(crate) name: &'static str,
    pub(crate) order: usize,
    pub(crate) a: Vec<Vec<f64>>,
    pub(crate) b: Vec<f64>,
    pub(crate) c: Vec<f64>,
}

impl GaussTableau {
    /// Two stages, order 4 (Hammer & Hollingsworth 1955; Hairer, Nørsett & Wanner, *Solving ODEs
    /// I*, Table II.7.3).
    pub(crate) fn gauss4() -> Self {
        let r = 3f64.sqrt() / 6.0;
        Self {
            name: "gauss4",
            order: 4,
            a: vec![vec![0.25, 0.25 - r], vec![0.25 + r, 0.25]],
            b: vec![0.5, 0.5],
            c: vec![0.5 - r, 0.5 + r],
        }
    }

    /// Three stages, order 6 (Kuntzmann 1961, Butcher 1964; *Solving ODEs I*, Table II.7.4).
    pub(crate) fn gauss6() -> Self {
        let r = 15f64.sqrt();
        Self {
            name: "gauss6",
            order: 6,
            a: vec![
                vec![5.0 / 36.0, 2.0 / 9.0 - r / 15.0, 5.0 / 36.0 - r / 30.0],
                vec![5.0 / 36.0 + r / 24.0, 2.0 / 9.0, 5.0 / 36.0 - r / 24.0],
                vec![5.0 / 36.0 + r / 30.0, 2.0 / 9.0 + r / 15.0, 5.0 / 36.0],
            ],
            b: vec![5.0 / 18.0, 4.0 / 9.0, 5.0 / 18.0],
            c: vec![0.5 - r / 10.0, 0.5, 0.5 + r / 10.0],
        }
    }

    fn stages(&self) -> usize {
        self.b.len()
    }
}

/// A Gauss–Legendre method run on a system.
pub(crate) struct Gauss {
    tableau: GaussTableau,
}

impl Gauss {
    pub(crate) fn new(tableau: GaussTableau) -> Self {
        Self { tableau }
    }
}

/// Newton iterations allowed per attempt.
const MAX_ITERATIONS: usize = 40;

/// A step that needed more iterations than this refreshes the Newton matrix for the next one.
const SLOW: usize = 8;

/// Starting values are extrapolated from the previous step only to a step at most this many
/// times longer.
const MAX_EXTRAPOLATION: f64 = 4.0;

/// The state and preallocated work space of a run.
struct Stepper {
    tab: GaussTableau,
    parts: ForceParts,
    n: usize,
    /// y = (q, q̇) at the current node; p alongside.
    y: Vec<f64>,
    p: Vec<f64>,
    /// A², for the Newton matrix.
    a2: Vec<Vec<f64>>,
    /// Stage velocities (unknowns), positions, momenta, forces: s rows of n.
    vs: Vec<f64>,
    qs: Vec<f64>,
    ps: Vec<f64>,
    gs: Vec<f64>,
    /// Residual, then Newton increment.
    r: Vec<f64>,
    /// The previous step's stage velocities, its start velocity and length (for starting
    /// values); `None` before the first step.
    prev: Option<f64>,
    prev_v0: Vec<f64>,
    prev_vs: Vec<f64>,
    /// New state under construction.
    y_new: Vec<f64>,
    p_new: Vec<f64>,
    tmp: Vec<f64>,
    /// Newton matrix: LU, the h it was built for (NaN: none), whether it was built at the
    /// current state, and whether the next step should rebuild it.
    lu: Lu<f64>,
    lu_h: f64,
    fresh: bool,
    refresh: bool,
    /// ∂(p, G)/∂(q, v), 2n × 2n, and its dual work space.
    jac: DMatrix<f64>,
    xd: Vec<Dual64>,
    fd: Vec<Dual64>,
    tmp_d: Vec<Dual64>,
    legendre: Legendre,
    /// Largest |q̇| seen: the floor of the scale of velocity increments.
    v_scale: f64,
}

impl Stepper {
    fn new<S: Dynamics + ?Sized>(tab: GaussTableau, run: &Run<'_, S>) -> Result<Self> {
        let n = run.n;
        let s = tab.stages();
        let y = run.y0.clone();
        let mut p = vec![0.0; n];
        run.system.momenta_into(run.t0, &y[..n], &y[n..], &mut p);
        crate::checks::finite(&p, "momenta", run.t0)?;
        let a2 = (0..s)
            .map(|i| {
                (0..s)
                    .map(|k| (0..s).map(|j| tab.a[i][j] * tab.a[j][k]).sum())
                    .collect()
            })
            .collect();
        let v_scale = max_norm(&y[n..]);
        Ok(Self {
            tab,
            parts: ForceParts::of(run.system),
            n,
            y,
            p,
            a2,
            vs: vec![0.0; s * n],
            qs: vec![0.0; s * n],
            ps: vec![0.0; s * n],
            gs: vec![0.0; s * n],
            r: vec![0.0; s * n],
            prev: None,
            prev_v0: vec![0.0; n],
            prev_vs: vec![0.0; s * n],
            y_new: vec![0.0; 2 * n],
            p_new: vec![0.0; n],
            tmp: vec![0.0; n],
            lu: Lu::new(s * n),
            lu_h: f64::NAN,
            fresh: false,
            refresh: false,
            jac: DMatrix::zeros(2 * n, 2 * n),
            xd: vec![Dual64::from_re(0.0); 2 * n],
            fd: vec![Dual64::from_re(0.0); 2 * n],
            tmp_d: vec![Dual64::from_re(0.0); n],
            legendre: Legendre::new(n),
            v_scale,
        })
    }

    /// Starting values of the stage velocities for a step of length `h`: the polynomial through
    /// the previous step's (0, q̇₀), (cⱼ, Vⱼ) extrapolated to 1 + cᵢ h/h_prev, or q̇ itself.
    fn guess(&mut self, h: f64) {
        let (n, s) = (self.n, self.tab.stages());
        let c = &self.tab.c;
        let ratio = self.prev.map(|hp| h / hp);
        match ratio {
            Some(ratio) if ratio > 0.0 && ratio <= MAX_EXTRAPOLATION => {
                for i in 0..s {
                    let theta = 1.0 + c[i] * ratio;
                    let row = &mut self.vs[i * n..(i + 1) * n];
                    row.fill(0.0);
                    // Nodes x₀ = 0, x_{j+1} = cⱼ.
                    for m in 0..=s {
                        let xm = if m == 0 { 0.0 } else { c[m - 1] };
                        let mut w = 1.0;
                        for l in 0..=s {
                            if l != m {
                                let xl = if l == 0 { 0.0 } else { c[l - 1] };
                                w *= (theta - xl) / (xm - xl);
                            }
                        }
                        let src = if m == 0 {
                            &self.prev_v0[..]
                        } else {
                            &self.prev_vs[(m - 1) * n..m * n]
                        };
                        for (r, v) in row.iter_mut().zip(src) {
                            *r += w * v;
                        }
                    }
                }
            }
            _ => {
                for i in 0..s {
                    self.vs[i * n..(i + 1) * n].copy_from_slice(&self.y[n..]);
                }
            }
        }
    }

    /// The Newton matrix K for step length `h` at the current state, factored.
    fn build<S: Dynamics + ?Sized>(&mut self, run: &mut Run<'_, S>, t: f64, h: f64) -> Result<()> {
        let (n, s) = (self.n, self.tab.stages());
        let system = run.system;
        let parts = self.parts;
        let td = Dual64::from_re(t);
        let tmp_d = &mut self.tmp_d;
        let (q, v) = self.y.split_at(n);
        let compiled = system
            .derived_program()
            .is_some_and(|program| program.qp_jacobian(t, q, v, self.jac.as_mut_slice()));
        if !compiled {
            jacobian(
                &self.y,
                &mut self.xd,
                &mut self.fd,
                &mut self.jac,
                |x, out| {
                    let (q, v) = x.split_at(n);
                    let (p, g) = out.split_at_mut(n);
                    system.momenta_into(td, q, v, p);
                    parts.force_into(system, td, q, v, g, tmp_d);
                    Ok(())
                },
            )?;
        }
        run.stats.jacobian_evaluations += 1;
        let jac = &self.jac;
        let k = self.lu.matrix();
        for bi in 0..s {
            for bk in 0..s {
                let (ha, h2a2) = (h * self.tab.a[bi][bk], h * h * self.a2[bi][bk]);
                let diag = if bi == bk { 1.0 } else { 0.0 };
                for i in 0..n {
                    for j in 0..n {
                        let (pq, pv) = (jac[(i, j)], jac[(i, n + j)]);
                        let (gq, gv) = (jac[(n + i, j)], jac[(n + i, n + j)]);
                        k[(bi * n + i, bk * n + j)] = diag * pv + ha * (pq - gv) - h2a2 * gq;
                    }
                }
            }
        }
        run.stats.factorizations += 1;
        if self.lu.factor() {
            self.lu_h = h;
        } else {
            // A singular K (M itself singular, or a resonant h) fails this attempt.
            self.lu_h = f64::NAN;
        }
        self.fresh = true;
        self.refresh = false;
        Ok(())
    }

    /// Stage positions, momenta and forces for the current stage velocities; the residual
    /// Rᵢ = Pᵢ − p₀ − h Σⱼ aᵢⱼ Gⱼ into `r`. When a value is not finite, which one and the time
    /// of its stage.
    fn residual<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        h: f64,
    ) -> std::result::Result<(), (&'static str, f64)> {
        let (n, s) = (self.n, self.tab.stages());
        let (a, c) = (&self.tab.a, &self.tab.c);
        let q0 = &self.y[..n];
        for i in 0..s {
            let qi = &mut self.qs[i * n..(i + 1) * n];
            qi.copy_from_slice(q0);
            for j in 0..s {
                let haij = h * a[i][j];
                for (x, v) in qi.iter_mut().zip(&self.vs[j * n..(j + 1) * n]) {
                    *x += haij * v;
                }
            }
            let ti = t + c[i] * h;
            let (qi, vi) = (&self.qs[i * n..(i + 1) * n], &self.vs[i * n..(i + 1) * n]);
            self.parts.momenta_and_force(
                run.system,
                ti,
                qi,
                vi,
                &mut self.ps[i * n..(i + 1) * n],
                &mut self.gs[i * n..(i + 1) * n],
                &mut self.tmp,
            );
            run.stats.rhs_evaluations += 1;
            let finite = |x: &[f64]| x.iter().all(|v| v.is_finite());
            if !finite(&self.qs[i * n..(i + 1) * n]) {
                return Err(("stage positions", ti));
            }
            if !finite(&self.ps[i * n..(i + 1) * n]) {
                return Err(("momenta", ti));
            }
            if !finite(&self.gs[i * n..(i + 1) * n]) {
                return Err(("forces", ti));
            }
        }
        for i in 0..s {
            let ri = &mut self.r[i * n..(i + 1) * n];
            for (k, x) in ri.iter_mut().enumerate() {
                *x = self.ps[i * n + k] - self.p[k];
            }
            for j in 0..s {
                let haij = h * a[i][j];
                for (x, g) in ri.iter_mut().zip(&self.gs[j * n..(j + 1) * n]) {
                    *x -= haij * g;
                }
            }
        }
        if self.r.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(("Newton residual", t))
        }
    }

    /// Simplified Newton on the stage velocities with the current factorization: whether it
    /// converged, and how.
    fn iterate<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        h: f64,
    ) -> (bool, Convergence) {
        let mut conv = Convergence::new(MAX_ITERATIONS);
        if !same_step(self.lu_h, h) {
            // The factorization failed: nothing to iterate with.
            return (false, Convergence::unfactored(self.jac.as_slice(), t));
        }
        let floor = 1e-3 * self.v_scale;
        loop {
            if let Err((what, at)) = self.residual(run, t, h) {
                conv.not_finite(what, at);
                return (false, conv);
            }
            match newton_update(&self.lu, &mut self.r, &mut self.vs, floor, &mut conv) {
                Verdict::Continue => {}
                Verdict::Converged => return (true, conv),
                Verdict::Failed => return (false, conv),
            }
        }
    }
}

impl<S: Dynamics + ?Sized> ImplicitStep<S> for Stepper {
    fn attempt(&mut self, run: &mut Run<'_, S>, t: f64, h: f64) -> Result<Option<Convergence>> {
        run.poll(t)?;
        let (n, s) = (self.n, self.tab.stages());
        if !same_step(self.lu_h, h) || self.refresh {
            self.build(run, t, h)?;
        }
        self.guess(h);
        let (mut converged, mut conv) = self.iterate(run, t, h);
        if !converged {
            if self.fresh {
                return Ok(Some(conv));
            }
            // A Newton matrix from an earlier step: rebuild it here and try again.
            self.build(run, t, h)?;
            self.guess(h);
            (converged, conv) = self.iterate(run, t, h);
            if !converged {
                return Ok(Some(conv));
            }
        }
        if conv.iterations > SLOW {
            self.refresh = true;
        }
        // q₁ = q₀ + h Σ bⱼ Vⱼ, p₁ = p₀ + h Σ bⱼ Gⱼ.
        let b = &self.tab.b;
        let (q_new, v_new) = self.y_new.split_at_mut(n);
        q_new.copy_from_slice(&self.y[..n]);
        self.p_new.copy_from_slice(&self.p);
        for j in 0..s {
            let hb = h * b[j];
            for k in 0..n {
                q_new[k] += hb * self.vs[j * n + k];
                self.p_new[k] += hb * self.gs[j * n + k];
            }
        }
        // q̇₁ from p₁, starting from the collocation polynomial at θ = 1.
        v_new.fill(0.0);
        for m in 0..=s {
            let xm = if m == 0 { 0.0 } else { self.tab.c[m - 1] };
            let mut w = 1.0;
            for l in 0..=s {
                if l != m {
                    let xl = if l == 0 { 0.0 } else { self.tab.c[l - 1] };
                    w *= (1.0 - xl) / (xm - xl);
                }
            }
            let src = if m == 0 {
                &self.y[n..]
            } else {
                &self.vs[(m - 1) * n..m * n]
            };
            for (r, v) in v_new.iter_mut().zip(src) {
                *r += w * v;
            }
        }
        let t_new = t + h;
        if !(q_new.iter().chain(&self.p_new).all(|x| x.is_finite())) {
            return Err(Error::NonFinite {
                what: "state",
                t: t_new,
            });
        }
        self.legendre.velocity(
            run.system,
            t_new,
            q_new,
            &self.p_new,
            v_new,
            1e-3 * self.v_scale,
            &mut run.stats,
        )?;
        // Accept: the step's stages seed the next one.
        self.prev = Some(h);
        self.prev_v0.copy_from_slice(&self.y[n..]);
        self.prev_vs.copy_from_slice(&self.vs);
        std::mem::swap(&mut self.y, &mut self.y_new);
        std::mem::swap(&mut self.p, &mut self.p_new);
        self.v_scale = self.v_scale.max(max_norm(&self.y[n..]));
        self.fresh = false;
        Ok(None)
    }

    fn state(&self) -> &[f64] {
        &self.y
    }
}

impl Integrator for Gauss {
    fn order(&self) -> usize {
        self.tableau.order
    }

    fn adaptive(&self) -> bool {
        false
    }

    fn explicit(&self) -> bool {
        false
    }

    fn fits<S: Dynamics + ?Sized>(
        &self,
        system: &S,
        _t0: f64,
        _q0: &[f64],
        _qd0: &[f64],
    ) -> std::result::Result<(), String> {
        unconstrained_only(
            system,
            "its collocation on (q, p) has no multipliers (a constrained Gauss–Legendre step, \
             Jay's SPARK, is not built; midpoint takes a constrained variational step, and \
             stormer_verlet and yoshida4/6/8 run as RATTLE on separable models)",
        )
    }

    fn start<S: Dynamics + ?Sized>(
        self,
        run: &mut Run<'_, S>,
    ) -> Result<Box<dyn SegmentStepper<S>>> {
        let dt = run.options.dt.ok_or_else(|| Error::InvalidInput {
            what: "dt",
            why: format!("{} is a fixed-step method", self.tableau.name),
        })?;
        let stepper = Stepper::new(self.tableau, run)?;
        Ok(Box::new(FixedSteps::new(run, stepper, dt)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The simplifying conditions B(2s) and C(s) (order 2s, stage order s) and the symplecticity
    /// condition bᵢaᵢⱼ + bⱼaⱼᵢ = bᵢbⱼ (Hairer, Lubich & Wanner, Theorem VI.4.3).
    #[test]
    fn gauss_tableaux_order_and_symplecticity() {
        for tab in [GaussTableau::gauss4(), GaussTableau::gauss6()] {
            let s = tab.stages();
            assert_eq!(tab.order, 2 * s);
            for k in 1..=2 * s {
                let sum: f64 = (0..s).map(|i| tab.b[i] * tab.c[i].powi(k as i32 - 1)).sum();
                assert_relative_eq!(sum, 1.0 / k as f64, epsilon = 1e-15);
            }
            // Not of order 2s + 1.
            let k = 2 * s + 1;
            let sum: f64 = (0..s).map(|i| tab.b[i] * tab.c[i].powi(k as i32 - 1)).sum();
            assert!((sum - 1.0 / k as f64).abs() > 1e-6);
            for i in 0..s {
                for k in 1..=s {
                    let sum: f64 = (0..s)
                        .map(|j| tab.a[i][j] * tab.c[j].powi(k as i32 - 1))
                        .sum();
                    assert_relative_eq!(sum, tab.c[i].powi(k as i32) / k as f64, epsilon = 1e-15);
                }
                for j in 0..s {
                    let m = tab.b[i] * tab.a[i][j] + tab.b[j] * tab.a[j][i] - tab.b[i] * tab.b[j];
                    assert!(m.abs() < 1e-15, "{} ({i}, {j}): {m:e}", tab.name);
                }
            }
        }
    }
}
