//! Explicit symplectic splitting methods for separable systems, L = ½ q̇ᵀMq̇ − U(t, q) with M
//! constant (plus forces Q″(t, q)): the flow splits into the drift q += h q̇ (t += h) and the kick
//! q̇ += h M⁻¹(Q″ − ∂U/∂q), each solved exactly, composed as
//!
//! K(b₀h) D(a₀h) K(b₁h) D(a₁h) … D(a_{s−1}h) K(b_s h).
//!
//! The last kick's force is the first kick's of the next step (FSAL): s force evaluations per
//! step. M is factored once (LDLᵀ).
//!
//! On a constrained system with holonomic rows g(t, q) = 0 (`rattle.rs`), Störmer–Verlet is
//! RATTLE (Hairer, Lubich & Wanner, *Geometric Numerical Integration*, §VII.1.4):
//!
//! v_{1/2} = v₀ + (h/2) a(q₀) − M⁻¹G(q₀)ᵀλ,  q₁ = q₀ + h v_{1/2},  g(t₁, q₁) = 0,
//! v₁ = v_{1/2} + (h/2) a(q₁) − M⁻¹G(q₁)ᵀμ,  G(q₁) v₁ + ∂g/∂t(t₁, q₁) = 0,
//!
//! λ by Newton to round-off, μ from a linear k × k system; it is symmetric and symplectic on
//! the constraint manifold, so the Yoshida compositions of RATTLE steps keep their order and
//! their symplecticity (HLW §V.3, §VII.1). Between the composed steps the velocity stage and
//! the next half kick merge as in the plain splitting (the next drift's multipliers absorb any
//! change along M⁻¹Gᵀ): one constrained drift per stage, one velocity stage per step. Moving
//! rows are served (∂g/∂t in the velocity stage). Blanes–Moan's splitting is not a composition
//! of Verlet steps: its drifts would need the exact free flow on the manifold, and it refuses
//! constrained models, as every splitting refuses velocity rows.

use super::dense::{Ends, Interpolant};
use super::rattle::{Manifold, holonomic_only};
use super::run::{Flow, Integrator, Run, SegmentStepper, axpy, copy};
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use num_dual::Dual64;

/// The coefficients of a kick–drift splitting: kicks `b` (one more than drifts) and drifts
/// `a`, each method's order declared once here.
#[derive(Debug, Clone, PartialEq)]
pub struct SymplecticTableau {
    /// Name in [`Method`](super::Method) spelling.
    pub name: &'static str,
    /// Order of convergence.
    pub order: usize,
    /// Drift coefficients a₀ … a_{s−1} (they sum to 1).
    pub a: Vec<f64>,
    /// Kick coefficients b₀ … b_s (they sum to 1).
    pub b: Vec<f64>,
}

impl SymplecticTableau {
    /// A splitting from its coefficients.
    ///
    /// # Panics
    /// If `b` does not have one more entry than `a`, or either does not sum to 1 (consistency).
    pub fn new(name: &'static str, order: usize, a: Vec<f64>, b: Vec<f64>) -> Self {
        assert!(!a.is_empty(), "a splitting needs at least one drift");
        assert_eq!(b.len(), a.len() + 1, "kick, drift, …, drift, kick");
        for (what, v) in [("a", &a), ("b", &b)] {
            let sum: f64 = v.iter().sum();
            assert!((sum - 1.0).abs() < 1e-13, "{what} sums to {sum}, not 1");
        }
        Self { name, order, a, b }
    }

    /// The composition S(w₁h) ∘ … ∘ S(w_m h) of Störmer–Verlet steps, merged into one
    /// kick–drift sequence: a = w, b = (w₁/2, (w₁+w₂)/2, …, w_m/2).
    pub fn composition(name: &'static str, order: usize, weights: &[f64]) -> Self {
        let m = weights.len();
        let mut b = Vec::with_capacity(m + 1);
        b.push(0.5 * weights[0]);
        for i in 1..m {
            b.push(0.5 * (weights[i - 1] + weights[i]));
        }
        b.push(0.5 * weights[m - 1]);
        Self::new(name, order, weights.to_vec(), b)
    }

    /// `[w_m … w₁, w₀, w₁ … w_m]` with w₀ = 1 − 2 Σ wᵢ (Yoshida's symmetric compositions).
    fn yoshida(name: &'static str, order: usize, w: &[f64]) -> Self {
        let w0 = 1.0 - 2.0 * w.iter().sum::<f64>();
        let mut weights: Vec<f64> = w.iter().rev().copied().collect();
        weights.push(w0);
        weights.extend_from_slice(w);
        Self::composition(name, order, &weights)
    }

    /// Whether the method is symmetric (a and b palindromic), hence time-reversible.
    pub fn is_symmetric(&self) -> bool {
        let pal = |v: &[f64]| {
            v.iter()
                .zip(v.iter().rev())
                .all(|(x, y)| (x - y).abs() <= 1e-15 * (1.0 + x.abs()))
        };
        pal(&self.a) && pal(&self.b)
    }

    /// Whether the splitting is a composition of Störmer–Verlet steps S(w₁h) ∘ … ∘ S(w_m h)
    /// ([`composition`](Self::composition): b₀ = a₀/2, bⱼ = (aⱼ₋₁ + aⱼ)/2, b_s = a_{s−1}/2), so
    /// that on a constrained system it is the same composition of RATTLE steps.
    pub fn is_composition(&self) -> bool {
        let s = self.a.len();
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-14 * (1.0 + y.abs());
        close(self.b[0], 0.5 * self.a[0])
            && close(self.b[s], 0.5 * self.a[s - 1])
            && (1..s).all(|j| close(self.b[j], 0.5 * (self.a[j - 1] + self.a[j])))
    }

    /// Number of force evaluations per step.
    pub fn stages(&self) -> usize {
        self.a.len()
    }

    /// Störmer–Verlet in velocity form (kick–drift–kick), order 2 (Verlet, *Phys. Rev.* 159
    /// (1967) 98; Hairer, Lubich & Wanner, *Geometric Numerical Integration*, §I.3).
    pub fn stormer_verlet() -> Self {
        Self::new("stormer_verlet", 2, vec![1.0], vec![0.5, 0.5])
    }

    /// Yoshida's triple jump, order 4: weights w₁ = 1/(2 − 2^⅓), w₀ = −2^⅓/(2 − 2^⅓)
    /// (H. Yoshida, "Construction of higher order symplectic integrators", *Phys. Lett. A* 150
    /// (1990) 262–268, eq. 4.4).
    pub fn yoshida4() -> Self {
        let cbrt2 = 2.0_f64.cbrt();
        Self::yoshida("yoshida4", 4, &[1.0 / (2.0 - cbrt2)])
    }

    /// Yoshida's 7-stage composition of order 6, solution A of Table 1 (Yoshida 1990).
    pub fn yoshida6() -> Self {
        Self::yoshida(
            "yoshida6",
            6,
            &[
                -1.177_679_984_178_87,
                0.235_573_213_359_357,
                0.784_513_610_477_560,
            ],
        )
    }

    /// Yoshida's 15-stage composition of order 8, solution D of Table 2 (Yoshida 1990).
    pub fn yoshida8() -> Self {
        Self::yoshida(
            "yoshida8",
            8,
            &[
                0.102_799_849_391_985,
                -1.960_610_232_975_49,
                1.938_139_137_622_76,
                -0.158_240_635_368_243,
                -1.444_852_236_860_48,
                0.253_693_336_566_229,
                0.914_844_246_229_740,
            ],
        )
    }

    /// Blanes & Moan's SRKN₆ᵇ of order 4: 6 force evaluations per step, error constants far
    /// below Yoshida's (S. Blanes & P. C. Moan, "Practical symplectic partitioned Runge–Kutta
    /// and Runge–Kutta–Nyström methods", *J. Comput. Appl. Math.* 142 (2002) 313–330, Table 3).
    pub fn blanes_moan4() -> Self {
        let (b1, b2, b3) = (
            0.082_984_406_417_405_2,
            0.396_309_801_498_368,
            -0.039_056_304_922_348_6,
        );
        let b4 = 1.0 - 2.0 * (b1 + b2 + b3);
        let (a1, a2) = (0.245_298_957_184_271, 0.604_872_665_711_080);
        let a3 = 0.5 - (a1 + a2);
        Self::new(
            "blanes_moan4",
            4,
            vec![a1, a2, a3, a3, a2, a1],
            vec![b1, b2, b3, b4, b3, b2, b1],
        )
    }
}

/// A splitting method run on a separable system.
pub(crate) struct Splitting {
    tableau: SymplecticTableau,
    /// Times of the drifts' ends within the step, as fractions of h.
    nodes: Vec<f64>,
}

impl Splitting {
    pub(crate) fn new(tableau: SymplecticTableau) -> Self {
        let mut acc = 0.0;
        let nodes = tableau
            .a
            .iter()
            .map(|a| {
                acc += a;
                acc
            })
            .collect();
        Self { tableau, nodes }
    }
}

/// Whether Q″ depends on q̇ near the initial state: ∂Q″/∂q̇ₖ by dual numbers at q̇₀ and at a
/// shifted velocity (a force like −c q̇³ has zero derivative at q̇ = 0).
fn forces_depend_on_velocity<S: Dynamics + ?Sized>(
    system: &S,
    t0: f64,
    q0: &[f64],
    qd0: &[f64],
) -> bool {
    let n = q0.len();
    let t = Dual64::from_re(t0);
    let q: Vec<Dual64> = q0.iter().map(|&x| Dual64::from_re(x)).collect();
    let mut out = vec![Dual64::from_re(0.0); n];
    for shift in [0.0, 1.0] {
        for k in 0..n {
            let qd: Vec<Dual64> = qd0
                .iter()
                .enumerate()
                .map(|(i, &v)| {
                    let v = v + shift * (1.0 + v.abs());
                    Dual64::new(v, if i == k { 1.0 } else { 0.0 })
                })
                .collect();
            system.generalized_forces_into(t, &q, &qd, &mut out);
            if out.iter().any(|o| o.eps != 0.0) {
                return true;
            }
        }
    }
    false
}

/// The kick's acceleration M⁻¹(Q″ − ∂U/∂q) with M factored once.
struct Kick {
    factor: Vec<f64>,
    /// Whether M is diagonal (its factor's L the identity): the solve is then one product per
    /// coordinate, with the bits of the full solve (whose terms with L's zeros add nothing).
    diagonal: bool,
    forced: bool,
    buf: Vec<f64>,
}

impl Kick {
    /// Inline: a small system's force is then compiled into the step, as in a hand-written loop.
    #[inline]
    fn accelerations<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        t: f64,
        q: &[f64],
        v: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        run.stats.rhs_evaluations += 1;
        run.poll(t)?;
        run.system.potential_gradient_into(t, q, out);
        for o in out.iter_mut() {
            *o = -*o;
        }
        if self.forced {
            run.system.generalized_forces_into(t, q, v, &mut self.buf);
            for (o, f) in out.iter_mut().zip(&self.buf) {
                *o += f;
            }
        }
        if self.diagonal {
            let n = run.n;
            for (i, o) in out.iter_mut().enumerate() {
                *o *= self.factor[i * n + i];
            }
            if out.iter().all(|v| v.is_finite()) {
                return Ok(());
            }
            return Err(Error::NonFinite {
                what: "accelerations",
                t,
            });
        }
        crate::linalg::solve_mass(&self.factor, run.n, t, out)
    }
}

impl Integrator for Splitting {
    fn order(&self) -> usize {
        self.tableau.order
    }

    fn adaptive(&self) -> bool {
        false
    }

    fn explicit(&self) -> bool {
        true
    }

    fn fits<S: Dynamics + ?Sized>(
        &self,
        system: &S,
        t0: f64,
        q0: &[f64],
        qd0: &[f64],
    ) -> std::result::Result<(), String> {
        if system.constraints().is_some() {
            holonomic_only(system, self.tableau.name)?;
            if !self.tableau.is_composition() {
                return Err(format!(
                    "the model is constrained, and {} is not a composition of Störmer–Verlet \
                     steps: its drifts would need the exact free flow on the constraint \
                     manifold (a geodesic), which RATTLE approximates to order 2 only; \
                     stormer_verlet and yoshida4/6/8 are compositions of RATTLE steps",
                    self.tableau.name
                ));
            }
        }
        let s = system.structure();
        if !s.separable {
            return Err(
                "the system is not separable: T must be ½ q̇ᵀMq̇ with a constant mass matrix \
                 (no dependence on q or t) for an explicit kick–drift splitting"
                    .into(),
            );
        }
        if s.dissipative {
            return Err(
                "Rayleigh dissipation makes the kick depend on q̇, so the kick is no longer \
                 an exact flow"
                    .into(),
            );
        }
        if s.forced && forces_depend_on_velocity(system, t0, q0, qd0) {
            return Err(
                "the generalized forces Q″ depend on q̇, so the kick is no longer an exact flow"
                    .into(),
            );
        }
        Ok(())
    }

    fn start<S: Dynamics + ?Sized>(
        self,
        run: &mut Run<'_, S>,
    ) -> Result<Box<dyn SegmentStepper<S>>> {
        let n = run.n;
        let dt = run.options.dt.ok_or_else(|| Error::InvalidInput {
            what: "dt",
            why: format!("{} is a fixed-step method", self.tableau.name),
        })?;
        let steps = run.fixed_steps(dt)?;
        let (t0, q0, qd0) = (run.t0, &run.y0[..n], &run.y0[n..]);
        let mut factor = vec![0.0; n * n];
        run.system.mass_matrix_into(t0, q0, qd0, &mut factor);
        crate::linalg::factor_mass(&mut factor, n, t0, q0)?;
        run.stats.factorizations += 1;
        // L is the factor's strict lower triangle (its upper one is the factorization's scratch).
        let diagonal = (0..n).all(|i| (0..i).all(|j| factor[i * n + j] == 0.0));
        let mut kick = Kick {
            factor,
            diagonal,
            forced: run.system.structure().forced,
            buf: vec![0.0; n],
        };
        let q = q0.to_vec();
        let v = qd0.to_vec();
        let manifold = match run.system.constraints() {
            Some(c) => {
                let mut m = Manifold::new(n, c.holonomic_rows());
                m.tangent(c, &kick.factor, t0, &q)?;
                Some(m)
            }
            None => None,
        };
        let mut acc = vec![0.0; n];
        kick.accelerations(run, t0, &q, &v, &mut acc)?;
        Ok(Box::new(SplittingStepper {
            old: (q.clone(), v.clone(), acc.clone()),
            manifold,
            a_end: vec![0.0; n],
            y: vec![0.0; 2 * n],
            split: self,
            kick,
            q,
            v,
            acc,
            i: 0,
            steps,
        }))
    }
}

/// The constrained q̈ at (t, q, v), counted as an evaluation of the right-hand side.
fn constrained_accelerations<S: Dynamics + ?Sized>(
    run: &mut Run<'_, S>,
    t: f64,
    q: &[f64],
    v: &[f64],
    out: &mut [f64],
) -> Result<()> {
    run.stats.rhs_evaluations += 1;
    run.system.accelerations_into(t, q, v, out)
}

/// Where a splitting run stands between its equal steps.
struct SplittingStepper {
    split: Splitting,
    /// RATTLE's constrained stages, on a constrained system.
    manifold: Option<Manifold>,
    /// The constrained q̈ at the step's end, for its interpolant (the kick's `acc` is not).
    a_end: Vec<f64>,
    kick: Kick,
    q: Vec<f64>,
    v: Vec<f64>,
    /// M⁻¹(Q″ − ∂U/∂q) at (q, v).
    acc: Vec<f64>,
    /// The previous step's end (q, q̇, q̈), for its interpolant.
    old: (Vec<f64>, Vec<f64>, Vec<f64>),
    /// The (q, q̇) record buffer.
    y: Vec<f64>,
    /// Step `i` of `steps` is next.
    i: usize,
    steps: usize,
}

impl<S: Dynamics + ?Sized> SegmentStepper<S> for SplittingStepper {
    /// The steps that nothing watches go in a row inside one call, only counted, as in the
    /// Runge–Kutta stepper.
    fn step(&mut self, run: &mut Run<'_, S>) -> Result<Flow> {
        let mut quiet = run.quiet_steps();
        let mut stepped = false;
        loop {
            match self.step_once(run, quiet > 0) {
                Ok(Flow::Continue) if quiet > 0 => {
                    quiet -= 1;
                    stepped = true;
                }
                Err(e) if stepped => {
                    // The failure names the last accepted state, from which this step started
                    // (`y` holds it: the step may have moved q and v).
                    run.out
                        .reached(run.grid_time(self.i - 1, self.steps), &self.y);
                    return Err(e);
                }
                flow => return flow,
            }
        }
    }
}

impl SplittingStepper {
    /// Step `i` of `steps`; a `quiet` step that does not end the span is only counted
    /// ([`Run::quiet_steps`]).
    fn step_once<S: Dynamics + ?Sized>(
        &mut self,
        run: &mut Run<'_, S>,
        quiet: bool,
    ) -> Result<Flow> {
        let Self {
            split,
            manifold,
            a_end,
            kick,
            q,
            v,
            acc,
            old: (q_old, v_old, a_old),
            y,
            i,
            steps,
        } = self;
        let n = run.n;
        let (i, steps) = (*i, *steps);
        self.i += 1;
        let t = run.grid_time(i, steps);
        let t_new = run.grid_time(i + 1, steps);
        let h = t_new - t;
        let dense = run.needs_interpolant(t_new);
        let system = run.system;
        let mut constraints = system.constraints().zip(manifold.as_mut());
        if dense {
            q_old.copy_from_slice(q);
            v_old.copy_from_slice(v);
            match constraints {
                // The interpolant's ends carry the constrained q̈, not the kick's.
                Some(_) => constrained_accelerations(run, t, q, v, a_old)?,
                None => a_old.copy_from_slice(acc),
            }
        }
        let (a, b) = (&split.tableau.a, &split.tableau.b);
        let last_drift = a.len() - 1;
        for j in 0..a.len() {
            let hb = h * b[j];
            axpy(hb, acc, v);
            let ha = h * a[j];
            let tj = if j == last_drift {
                t_new
            } else {
                t + split.nodes[j] * h
            };
            // On a constrained system the adjacent half kicks of the composed RATTLE steps
            // merge as in the plain splitting: the velocity stage between them moves v along
            // W = M⁻¹Gᵀ at the same point, which the next drift's multipliers absorb.
            match constraints.as_mut() {
                Some((c, m)) => m
                    .drift(*c, &kick.factor, tj, q, v, ha)
                    .map_err(|e| match e {
                        // Dated, as every Newton failure, by the step's start.
                        Error::NewtonFailure {
                            iterations,
                            residual,
                            ..
                        } => Error::NewtonFailure {
                            t,
                            iterations,
                            residual,
                        },
                        e => e,
                    })?,
                None => axpy(ha, v, q),
            }
            kick.accelerations(run, tj, q, v, acc)?;
        }
        let hb = h * b[a.len()];
        axpy(hb, acc, v);
        if let Some((c, m)) = constraints {
            let residual = m.project_velocity(c, t_new, q, v)?;
            run.stats.constraint_residual = run.stats.constraint_residual.max(residual);
        }
        if !(q.iter().all(|x| x.is_finite()) && v.iter().all(|x| x.is_finite())) {
            return Err(Error::NonFinite {
                what: "state",
                t: t_new,
            });
        }
        run.stats.accepted_steps += 1;
        if dense && manifold.is_some() {
            constrained_accelerations(run, t_new, q, v, a_end)?;
        }
        copy(q, &mut y[..n]);
        copy(v, &mut y[n..]);
        if quiet && i + 1 < steps {
            run.out.skip(1);
            return Ok(Flow::Continue);
        }
        let step = dense.then(|| Interpolant::Hermite {
            t,
            h,
            ends: Ends {
                q0: q_old,
                v0: v_old,
                a0: a_old,
                q1: q,
                v1: v,
                a1: if manifold.is_some() { a_end } else { acc },
            },
        });
        run.accept(t, t_new, y, i + 1 == steps, step.as_ref())
    }
}
