//! The midpoint variational integrator: Hamilton's principle (seed eq. 36) made discrete, and
//! with forces the Lagrange–d'Alembert principle (eq. 35), after Marsden & West, "Discrete
//! mechanics and variational integrators", *Acta Numerica* 10 (2001) 357–514, §1.2, §3.2.
//!
//! The action over one step is approximated by the discrete Lagrangian
//!
//! L_d(q_k, q_{k+1}) = h L((q_k + q_{k+1})/2, (q_{k+1} − q_k)/h, t_k + h/2),
//!
//! and making Σ L_d stationary under variations with fixed ends gives the discrete
//! Euler–Lagrange equations; in position–momentum form, with the non-conservative forces
//! F = Q″ − ∂Φ/∂q̇ at the midpoint entering as F_d^± = (h/2) F (discrete Lagrange–d'Alembert),
//!
//! p_k = −D₁L_d(q_k, q_{k+1}) − F_d⁻,   p_{k+1} = D₂L_d(q_k, q_{k+1}) + F_d⁺.
//!
//! By the chain rule D₁L_d = (h/2) ∂L/∂q − ∂L/∂q̇ and D₂L_d = (h/2) ∂L/∂q + ∂L/∂q̇ at the
//! midpoint. The first equation is solved for q_{k+1} = q_k + h V by Newton with the AD Jacobian
//! in V (kept over steps while it converges fast, as in the Gauss methods); the second is
//! explicit. The map (q_k, p_k) ↦ (q_{k+1}, p_{k+1}) is symplectic and symmetric, of order 2,
//! for any regular Lagrangian; with dissipation it reproduces the energy decay with no spurious
//! drift. (It coincides with the one-stage Gauss method on (q, p).)
//!
//! On a constrained system with holonomic rows g(t, q) = 0 the step is the discrete
//! Lagrange–d'Alembert principle with multipliers in RATTLE form (Marsden & West §3.5;
//! Leyendecker, Marsden & Ortiz, *ZAMM* 88 (2008) 677–708): the first equation gains
//! −G(q_k)ᵀΛ and is solved with g(t_{k+1}, q_{k+1}) = 0 for (V, Λ) by Newton on the (n + k)
//! system, p_{k+1} gains G(q_k)ᵀΛ, and the velocity stage of `rattle.rs` (M at q_{k+1}) puts
//! q̇_{k+1} on G q̇ + ∂g/∂t = 0, p_{k+1} then the momenta of that velocity. Symplectic and
//! symmetric on the constraint manifold, order 2; each step ends on the constraints to
//! round-off. Velocity rows are refused.

use super::implicit::{FixedSteps, ImplicitStep, Legendre};
use super::rattle::{Manifold, holonomic_only};
use super::run::{Integrator, Run, SegmentStepper};
use crate::dynamics::Dynamics;
use crate::dynamics::ForceParts;
use crate::dynamics::jacobian;
use crate::error::{Error, Result};
use crate::nonlinear::{Convergence, Lu, Verdict, max_norm, newton_update, same_step};
use crate::scalar::Scalar;
use nalgebra::DMatrix;
use num_dual::Dual64;

/// The midpoint variational integrator.
pub(crate) struct Variational;

/// Newton iterations allowed per attempt.
const MAX_ITERATIONS: usize = 40;

/// A step that needed more iterations than this refreshes the Jacobian for the next one.
const SLOW: usize = 8;

/// The discrete Euler–Lagrange residual R(V) = ∂L/∂q̇ − (h/2)(∂L/∂q + F) − p_k at the midpoint
/// (t_k + h/2, q_k + hV/2, V), i.e. −(p_k + D₁L_d + F_d⁻); `g` receives ∂L/∂q + F there.
#[allow(clippy::too_many_arguments)]
fn residual_into<S: Dynamics + ?Sized, D: Scalar>(
    system: &S,
    parts: ForceParts,
    t_mid: f64,
    h: f64,
    q0: &[f64],
    p0: &[f64],
    v: &[D],
    qm: &mut [D],
    out: &mut [D],
    g: &mut [D],
    tmp: &mut [D],
) {
    let tm = D::from(t_mid);
    for ((x, &q), &vi) in qm.iter_mut().zip(q0).zip(v) {
        *x = vi * (0.5 * h) + q;
    }
    system.momenta_into(tm, qm, v, out);
    parts.force_into(system, tm, qm, v, g, tmp);
    for ((o, &gi), &p) in out.iter_mut().zip(g.iter()).zip(p0) {
        *o = *o - gi * (0.5 * h) - p;
    }
}

struct Stepper {
    parts: ForceParts,
    n: usize,
    /// y = (q, q̇) at the current node; p alongside.
    y: Vec<f64>,
    p: Vec<f64>,
    /// Midpoint velocity V = (q_{k+1} − q_k)/h (the unknown), the previous one, and the
    /// previous step length (`None` before the first step).
    v: Vec<f64>,
    v_prev: Vec<f64>,
    prev: Option<f64>,
    qm: Vec<f64>,
    r: Vec<f64>,
    g: Vec<f64>,
    tmp: Vec<f64>,
    y_new: Vec<f64>,
    p_new: Vec<f64>,
    lu: Lu<f64>,
    lu_h: f64,
    fresh: bool,
    refresh: bool,
    jac: DMatrix<f64>,
    xd: Vec<Dual64>,
    fd: Vec<Dual64>,
    qm_d: Vec<Dual64>,
    g_d: Vec<Dual64>,
    tmp_d: Vec<Dual64>,
    legendre: Legendre,
    v_scale: f64,
    /// The constrained step's work space, on a constrained system.
    constrained: Option<Multipliers>,
}

/// The constrained midpoint step's unknowns beside V and its work space: the multipliers Λ of
/// G(q_k)ᵀ, G at both ends, the (n + k) Newton matrix, M at the new point for the velocity
/// stage.
struct Multipliers {
    k: usize,
    lambda: Vec<f64>,
    g0: Vec<f64>,
    g1: Vec<f64>,
    values: Vec<f64>,
    q1: Vec<f64>,
    rhs: Vec<f64>,
    zero: Vec<f64>,
    lu: Lu<f64>,
    mass: Vec<f64>,
    manifold: Manifold,
}

impl Multipliers {
    fn new(n: usize, k: usize) -> Self {
        Self {
            k,
            lambda: vec![0.0; k],
            g0: vec![0.0; k * n],
            g1: vec![0.0; k * n],
            values: vec![0.0; k],
            q1: vec![0.0; n],
            rhs: vec![0.0; n + k],
            zero: vec![0.0; n],
            lu: Lu::new(n + k),
            mass: vec![0.0; n * n],
            manifold: Manifold::new(n, k),
        }
    }
}

impl Stepper {
    fn new<S: Dynamics + ?Sized>(run: &Run<'_, S>) -> Result<Self> {
        let n = run.n;
        let y = run.y0.clone();
        let mut p = vec![0.0; n];
        run.system.momenta_into(run.t0, &y[..n], &y[n..], &mut p);
        crate::checks::finite(&p, "momenta", run.t0)?;
        let v_scale = max_norm(&y[n..]);
        let zero = Dual64::from_re(0.0);
        Ok(Self {
            parts: ForceParts::of(run.system),
            n,
            y,
            p,
            v: vec![0.0; n],
            v_prev: vec![0.0; n],
            prev: None,
            qm: vec![0.0; n],
            r: vec![0.0; n],
            g: vec![0.0; n],
            tmp: vec![0.0; n],
            y_new: vec![0.0; 2 * n],
            p_new: vec![0.0; n],
            lu: Lu::new(n),
            lu_h: f64::NAN,
            fresh: false,
            refresh: false,
            jac: DMatrix::zeros(n, n),
            xd: vec![zero; n],
            fd: vec![zero; n],
            qm_d: vec![zero; n],
            g_d: vec![zero; n],
            tmp_d: vec![zero; n],
            legendre: Legendre::new(n),
            v_scale,
            constrained: run
                .system
                .constraints()
                .map(|c| Multipliers::new(n, c.holonomic_rows())),
        })
    }

    /// Starting value of V: q̇_k + (q̇_k − V_prev) h/h_prev, the line through the previous
    /// midpoint velocity and the node velocity; q̇_k on the first step.
    fn guess(&mut self, h: f64) {
        let n = self.n;
        let vk = &self.y[n..];
        match self.prev.map(|hp| h / hp) {
            Some(ratio) if ratio > 0.0 && ratio <= 4.0 => {
                for ((v, &a), &b) in self.v.iter_mut().zip(vk).zip(&self.v_prev) {
                    *v = a + (a - b) * ratio;
                }
            }
            _ => self.v.copy_from_slice(vk),
        }
    }

    /// ∂R/∂V at the current guess, factored.
    fn build<S: Dynamics + ?Sized>(&mut self, run: &mut Run<'_, S>, t: f64, h: f64) -> Result<()> {
        self.residual_jacobian(run, t, h)?;
        self.lu.matrix().copy_from(&self.jac);
        run.stats.factorizations += 1;
        self.lu_h = if self.lu.factor() { h } else { f64::NAN };
        self.fresh = true;
        self.refresh = false;
        Ok(())
    }

    /// ∂R/∂V at the current guess into `jac`.
    fn residual_jacobian<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        h: f64,
    ) -> Result<()> {
        let (system, parts) = (run.system, self.parts);
        let (q0, p0) = (&self.y[..self.n], &self.p[..]);
        let (qm, g, tmp) = (&mut self.qm_d, &mut self.g_d, &mut self.tmp_d);
        let t_mid = t + 0.5 * h;
        jacobian(
            &self.v,
            &mut self.xd,
            &mut self.fd,
            &mut self.jac,
            |v, out| {
                residual_into(system, parts, t_mid, h, q0, p0, v, qm, out, g, tmp);
                Ok(())
            },
        )?;
        run.stats.jacobian_evaluations += 1;
        Ok(())
    }

    fn iterate<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        h: f64,
    ) -> (bool, Convergence) {
        let mut conv = Convergence::new(MAX_ITERATIONS);
        let t_mid = t + 0.5 * h;
        if !same_step(self.lu_h, h) {
            return (false, Convergence::unfactored(self.jac.as_slice(), t_mid));
        }
        let n = self.n;
        let floor = 1e-3 * self.v_scale;
        loop {
            residual_into(
                run.system,
                self.parts,
                t_mid,
                h,
                &self.y[..n],
                &self.p,
                &self.v,
                &mut self.qm,
                &mut self.r,
                &mut self.g,
                &mut self.tmp,
            );
            run.stats.rhs_evaluations += 1;
            if !self.r.iter().all(|x| x.is_finite()) {
                let finite = |x: &[f64]| x.iter().all(|v| v.is_finite());
                let what = if !finite(&self.qm) {
                    "stage positions"
                } else if !finite(&self.g) {
                    "forces"
                } else {
                    "momenta"
                };
                conv.not_finite(what, t_mid);
                return (false, conv);
            }
            match newton_update(&self.lu, &mut self.r, &mut self.v, floor, &mut conv) {
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
        if self.constrained.is_some() {
            return self.attempt_constrained(run, t, h);
        }
        let n = self.n;
        self.guess(h);
        if !same_step(self.lu_h, h) || self.refresh {
            self.build(run, t, h)?;
        }
        let (mut converged, mut conv) = self.iterate(run, t, h);
        if !converged {
            if self.fresh {
                return Ok(Some(conv));
            }
            self.guess(h);
            self.build(run, t, h)?;
            (converged, conv) = self.iterate(run, t, h);
            if !converged {
                return Ok(Some(conv));
            }
        }
        if conv.iterations > SLOW {
            self.refresh = true;
        }
        // q_{k+1} = q_k + h V. p_{k+1} = D₂L_d + F_d⁺; adding the first equation,
        // p_{k+1} − p_k = (D₁ + D₂)L_d + F_d⁻ + F_d⁺ = h (∂L/∂q + F) at the midpoint.
        let (q_new, v_new) = self.y_new.split_at_mut(n);
        for k in 0..n {
            q_new[k] = self.y[k] + h * self.v[k];
            self.p_new[k] = self.p[k] + h * self.g[k];
        }
        let t_new = t + h;
        if !(q_new.iter().chain(&self.p_new).all(|x| x.is_finite())) {
            return Err(Error::NonFinite {
                what: "state",
                t: t_new,
            });
        }
        // q̇_{k+1} from p_{k+1}, starting from 2V − q̇_k.
        for k in 0..n {
            v_new[k] = 2.0 * self.v[k] - self.y[n + k];
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
        self.prev = Some(h);
        self.v_prev.copy_from_slice(&self.v);
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

impl Stepper {
    /// The constrained step (discrete Lagrange–d'Alembert with multipliers, RATTLE form:
    /// Marsden & West 2001, §3.5; Leyendecker, Marsden & Ortiz, "Variational integrators for
    /// constrained dynamical systems", *ZAMM* 88 (2008) 677–708):
    ///
    /// p_k = −D₁L_d(q_k, q_{k+1}) − F_d⁻ − G(q_k)ᵀΛ,   g(t_{k+1}, q_{k+1}) = 0,
    /// p_{k+1} = D₂L_d(q_k, q_{k+1}) + F_d⁺ − G(q_{k+1})ᵀμ,   G(q_{k+1}) q̇_{k+1} + ∂g/∂t = 0.
    ///
    /// The first two are solved for (V, Λ), q_{k+1} = q_k + hV, by simplified Newton with the
    /// (n + k) matrix [[∂R/∂V, −G(q_k)ᵀ], [G(q_{k+1}), 0]] built at the guess (the row of g
    /// divided by h), to round-off; the last two by RATTLE's velocity stage, p_{k+1} then the
    /// momenta of the projected q̇_{k+1}. The map is symplectic and symmetric on the constraint
    /// manifold, of order 2, for any regular Lagrangian.
    fn attempt_constrained<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        h: f64,
    ) -> Result<Option<Convergence>> {
        let c = run
            .system
            .constraints()
            .expect("a constrained step on a constrained system");
        let n = self.n;
        let (t_mid, t_new) = (t + 0.5 * h, t + h);
        self.guess(h);
        self.residual_jacobian(run, t, h)?;
        let Some(cp) = self.constrained.as_mut() else {
            unreachable!("attempt_constrained is called with the work space set")
        };
        let k = cp.k;
        let q0 = &self.y[..n];
        c.jacobian_into(t, q0, &cp.zero, &mut cp.g0)?;
        for ((x, &q), &v) in cp.q1.iter_mut().zip(q0).zip(&self.v) {
            *x = q + h * v;
        }
        c.jacobian_into(t_new, &cp.q1, &cp.zero, &mut cp.g1)?;
        let m = cp.lu.matrix();
        m.fill(0.0);
        for i in 0..n {
            for j in 0..n {
                m[(i, j)] = self.jac[(i, j)];
            }
            for r in 0..k {
                m[(i, n + r)] = -cp.g0[r * n + i];
                m[(n + r, i)] = cp.g1[r * n + i];
            }
        }
        run.stats.factorizations += 1;
        if !cp.lu.factor() {
            return Ok(Some(Convergence::unfactored(self.jac.as_slice(), t_mid)));
        }
        cp.lambda.fill(0.0);
        // The rows g/h carry the round-off of g (ε |q|) over h into V: V is judged against
        // |q|/h too, i.e. the step's change of position against 10⁻³ of the positions.
        let floor = 1e-3 * self.v_scale.max(max_norm(q0) / h.abs());
        let mut conv = Convergence::new(MAX_ITERATIONS);
        loop {
            residual_into(
                run.system,
                self.parts,
                t_mid,
                h,
                q0,
                &self.p,
                &self.v,
                &mut self.qm,
                &mut self.r,
                &mut self.g,
                &mut self.tmp,
            );
            run.stats.rhs_evaluations += 1;
            for ((x, &q), &v) in cp.q1.iter_mut().zip(q0).zip(&self.v) {
                *x = q + h * v;
            }
            c.holonomic_into(t_new, &cp.q1, &mut cp.values);
            for i in 0..n {
                let reaction: f64 = (0..k).map(|r| cp.g0[r * n + i] * cp.lambda[r]).sum();
                cp.rhs[i] = self.r[i] - reaction;
            }
            for r in 0..k {
                cp.rhs[n + r] = cp.values[r] / h;
            }
            if !cp.rhs.iter().all(|x| x.is_finite()) {
                conv.not_finite("constrained step residual", t_mid);
                return Ok(Some(conv));
            }
            cp.lu.solve(&mut cp.rhs);
            for (v, d) in self.v.iter_mut().zip(&cp.rhs[..n]) {
                *v -= d;
            }
            for (l, d) in cp.lambda.iter_mut().zip(&cp.rhs[n..]) {
                *l -= d;
            }
            let scale = max_norm(&self.v).max(floor).max(f64::MIN_POSITIVE);
            match conv.judge(max_norm(&cp.rhs[..n]) / scale) {
                Verdict::Continue => {}
                Verdict::Converged => break,
                Verdict::Failed => return Ok(Some(conv)),
            }
        }
        // q_{k+1} = q_k + hV; p_{k+1} − p_k = h (∂L/∂q + F) at the midpoint + G(q_k)ᵀΛ.
        let (q_new, v_new) = self.y_new.split_at_mut(n);
        for i in 0..n {
            q_new[i] = self.y[i] + h * self.v[i];
            let reaction: f64 = (0..k).map(|r| cp.g0[r * n + i] * cp.lambda[r]).sum();
            self.p_new[i] = self.p[i] + h * self.g[i] + reaction;
        }
        if !(q_new.iter().chain(&self.p_new).all(|x| x.is_finite())) {
            return Err(Error::NonFinite {
                what: "state",
                t: t_new,
            });
        }
        for i in 0..n {
            v_new[i] = 2.0 * self.v[i] - self.y[n + i];
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
        // RATTLE's velocity stage in the metric of M at the new point, then the momenta of
        // the projected velocity (for T quadratic in q̇, p_{k+1} − G(q_{k+1})ᵀμ).
        run.system
            .mass_matrix_into(t_new, q_new, v_new, &mut cp.mass);
        crate::linalg::factor_mass(&mut cp.mass, n, t_new, q_new)?;
        run.stats.factorizations += 1;
        cp.manifold.tangent(c, &cp.mass, t_new, q_new)?;
        let residual = cp.manifold.project_velocity(c, t_new, q_new, v_new)?;
        run.stats.constraint_residual = run.stats.constraint_residual.max(residual);
        run.system
            .momenta_into(t_new, q_new, v_new, &mut self.p_new);
        crate::checks::finite(&self.p_new, "momenta", t_new)?;
        self.prev = Some(h);
        self.v_prev.copy_from_slice(&self.v);
        std::mem::swap(&mut self.y, &mut self.y_new);
        std::mem::swap(&mut self.p, &mut self.p_new);
        self.v_scale = self.v_scale.max(max_norm(&self.y[n..]));
        Ok(None)
    }
}

impl Integrator for Variational {
    fn order(&self) -> usize {
        2
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
        holonomic_only(system, "midpoint")
    }

    fn start<S: Dynamics + ?Sized>(
        self,
        run: &mut Run<'_, S>,
    ) -> Result<Box<dyn SegmentStepper<S>>> {
        let dt = run.options.dt.ok_or_else(|| Error::InvalidInput {
            what: "dt",
            why: "midpoint is a fixed-step method".into(),
        })?;
        let stepper = Stepper::new(run)?;
        Ok(Box::new(FixedSteps::new(run, stepper, dt)?))
    }
}
