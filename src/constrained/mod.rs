//! Constrained systems: Lagrange's equations of the first kind, evaluated at a state.
//!
//! The seed's §2 starts from N particles under f constraints and §3.1–3.2 rest on constraint
//! forces R that do no work in a virtual displacement; §3.6 eliminates the rolling constraints
//! (eq. 45, 49) by hand. [`Constrained`] keeps the constraints as equations instead
//! ([`Constraints`]: holonomic rows g(t, q) = 0 and velocity rows a(t, q)·q̇ + b(t, q) = 0) and
//! adds their reactions to eq. 55 through Lagrange multipliers λ:
//!
//! M q̈ = f + Gᵀλ,    G q̈ = −γ,
//!
//! where f is everything of eq. 55 but M q̈ (Q″ + ∂L/∂q − (∂²L/∂q̇∂q) q̇ − ∂²L/∂q̇∂t − ∂Φ/∂q̇),
//! G stacks ∂g/∂q and the velocity rows' A = ∂(a·q̇ + b)/∂q̇, and γ is what the constraints'
//! time derivative along the motion holds besides G q̈:
//!
//! - holonomic rows: γ = d²/ds² g(t + s, q + s q̇) at s = 0 (the second derivative of g along
//!   the motion with q̈ = 0: (∂(G q̇)/∂q) q̇ + 2 (∂G/∂t) q̇ + ∂²g/∂t²), one pass of num-dual's
//!   second-order [`Dual2`];
//! - velocity rows: γ = d/ds (a·q̇ + b)(t + s, q + s q̇, q̇) at s = 0, one first-order pass.
//!
//! G comes from forward-mode vector duals over chunks of the coordinates, as eq. 55's passes; no
//! finite differences anywhere. q̈ and λ follow from M's LDLᵀ and the k × k Schur complement
//! S = G M⁻¹ Gᵀ (LDLᵀ again): with q̈₀ the unconstrained accelerations (M q̈₀ = f, from the
//! wrapped system's [`Dynamics::accelerations_into`]), S λ = −γ − G q̈₀ and
//! q̈ = q̈₀ + M⁻¹Gᵀλ. Gᵀλ is the generalized reaction force, the seed's R: G δq = 0 for every
//! virtual displacement, so its virtual work λ·G δq vanishes, which is why it drops out of
//! minimal coordinates.
//!
//! Sign convention: the reaction is +Gᵀλ on the right-hand side, so λ has the sign of the force
//! along ∂g/∂q (a rod x² + y² − l² = 0 in tension pulls towards the pivot: λ < 0).
//!
//! A rank-deficient G (a constraint stated twice, or a mechanism at a dead point) is
//! [`Error::DependentConstraints`] naming the rows; a velocity row not linear in q̇ is
//! [`Error::NonlinearVelocityConstraint`]. A system without constraints is not wrapped and pays
//! nothing. This is the evaluation at a state, and the consistent states: [`Constrained::project`]
//! takes a state onto the constraints (positions by Gauss–Newton in the M metric, velocities by
//! the M-orthogonal projection), the routine a drift-free integration calls after each step;
//! [`Constrained::check_consistent`] refuses an inconsistent one
//! ([`Error::InconsistentState`]). As a [`Dynamics`] of its own it integrates with the
//! Runge–Kutta methods and radau5, each accepted step projected back onto the constraints, and
//! with holonomic rows only with RATTLE and the constrained midpoint step (`integrators/`).

use crate::checks::{check_state, finite};
use crate::dynamics::Dynamics;
use crate::energies::Constraints;
use crate::error::{Error, Result};
use crate::linalg::factor_mass;
use crate::linalg::{ldlt_in_place, ldlt_solve};
use crate::scalar::{
    CHUNK, Grad, Hyper, Scalar, grad_const, grad_part, grad_seed, hyper, hyper_mixed, with_f64_buf,
};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use num_dual::{Dual, Dual2, Dual64};
use std::sync::OnceLock;

mod projection;

/// Entries of ∂²(a·q̇ + b)/∂q̇² above this fraction of the row's largest |∂(a·q̇ + b)/∂q̇| (or
/// of 1) make the row nonlinear in q̇ (dual numbers give exact zeros for a linear row).
const LINEARITY_TOLERANCE: f64 = 1e-12;

/// The default tolerance of [`Constrained::project`] and [`Constrained::check_consistent`]
/// (their rtol and atol alike), and the one a run of fixed steps holds its steps to: each row's
/// residual as a distance in q (or q̇) within 10⁻¹² (1 + ℓᵢ), ℓᵢ the size of the coordinates
/// the row reads up to 1 (the rule in `constrained/projection.rs`).
pub const PROJECTION_TOLERANCE: f64 = 1e-12;

/// A Schur pivot dⱼ of G M⁻¹ Gᵀ below this fraction of its largest diagonal entry is a rank
/// loss of G ([`Error::DependentConstraints`]), far above LDLᵀ's own floor (10⁻¹³): near a
/// mechanism's change point (a parallelogram four-bar with its links collinear) the multipliers
/// divide the state's residual inconsistency by dⱼ, and a Runge–Kutta stage landing there
/// (dⱼ ~ 10⁻¹³, σ_min(G) ~ 3·10⁻⁷ of its largest) gets a kick large enough to throw the run
/// onto the other branch. At 10⁻¹⁰ (σ_min ~ 10⁻⁵ of the largest) the kick stays below the
/// tolerance's own size; rows of scales apart by up to 10⁵ still pass.
const RANK_LOSS: f64 = 1e-10;

/// A [`Dynamics`] system under [`Constraints`]: Lagrange's equations of the first kind at a
/// state, seed eq. 55 with the reactions of the constraints (seed §2, §3.1: forces R that do no
/// work in a virtual displacement),
///
/// M q̈ = f + Gᵀλ,    G q̈ = −γ,
///
/// with f everything of eq. 55 but M q̈, G the constraints' Jacobian
/// ([`constraint_jacobian`](Self::constraint_jacobian), holonomic rows ∂g/∂q, velocity rows
/// ∂(a·q̇ + b)/∂q̇) and γ ([`gamma`](Self::gamma)) the rest of the constraints' derivative along
/// the motion: d²/ds² g(t + s, q + s q̇) and d/ds (a·q̇ + b)(t + s, q + s q̇, q̇) at s = 0, by
/// dual numbers. q̈ and λ come from M's LDLᵀ and the Schur complement G M⁻¹ Gᵀ; Gᵀλ is the
/// generalized reaction force. Sign convention: +Gᵀλ on the right-hand side, so λ has the sign
/// of the reaction along ∂g/∂q.
///
/// ```
/// use lagrangian::{Constrained, Constraints, KineticEnergy, Potential, Scalar, System};
///
/// /// A unit point mass in the plane under gravity g = 9.81 (y up).
/// struct Point;
/// impl KineticEnergy for Point {
///     fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
///         (qd[0] * qd[0] + qd[1] * qd[1]) * 0.5
///     }
/// }
/// struct Gravity;
/// impl Potential for Gravity {
///     fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
///         q[1] * 9.81
///     }
/// }
/// /// A rod of length 1 from the origin.
/// struct Rod;
/// impl Constraints for Rod {
///     fn holonomic_count(&self) -> usize {
///         1
///     }
///     fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
///         out[0] = q[0] * q[0] + q[1] * q[1] - 1.0;
///     }
/// }
///
/// let pendulum = Constrained::new(System::new(2, Point).with_potential(Gravity), Rod);
/// // Hanging at rest: no acceleration, and the rod carries the weight.
/// let at_rest = pendulum.evaluate(0.0, &[0.0, -1.0], &[0.0, 0.0])?;
/// assert!(at_rest.accelerations.norm() < 1e-14);
/// assert!((at_rest.reaction_forces[1] - 9.81).abs() < 1e-12);
///
/// // A state off the circle, moving radially, is refused; `project` repairs it.
/// let (q0, qd0) = ([0.0, -1.1], [0.3, -0.2]);
/// assert!(pendulum.check_consistent(0.0, &q0, &qd0, None).is_err());
/// let (q, qd) = pendulum.project(0.0, &q0, &qd0, None)?;
/// assert!((q[0].hypot(q[1]) - 1.0).abs() < 1e-14);
/// assert!((q[0] * qd[0] + q[1] * qd[1]).abs() < 1e-14);
/// pendulum.check_consistent(0.0, &q, &qd, None)?;
/// # Ok::<(), lagrangian::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Constrained<S, C> {
    system: S,
    constraints: C,
    /// M's LDLᵀ factor when the wrapped system's M is constant ([`crate::Structure`]): made
    /// once at the first state seen, not at every evaluation of the Schur complement.
    mass_factor: OnceLock<Result<Vec<f64>>>,
}

/// q̈, λ and the reactions Gᵀλ at one state ([`Constrained::evaluate`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ConstrainedAccelerations {
    /// q̈ (length n).
    pub accelerations: DVector<f64>,
    /// λ, one per row, holonomic rows first (length k).
    pub multipliers: DVector<f64>,
    /// The generalized reaction forces Gᵀλ (length n), the seed's R in generalized
    /// coordinates.
    pub reaction_forces: DVector<f64>,
}

/// How far a state is from satisfying the constraints ([`Constrained::residuals`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ConstraintResiduals {
    /// g(t, q), one per holonomic row.
    pub position: DVector<f64>,
    /// One per row, holonomic rows first: ġ = G q̇ + ∂g/∂t, then a·q̇ + b.
    pub velocity: DVector<f64>,
}

impl ConstraintResiduals {
    /// The largest absolute residual, positions and velocities together (0 without rows).
    pub fn max_abs(&self) -> f64 {
        self.position
            .iter()
            .chain(self.velocity.iter())
            .fold(0.0, |m, r| m.max(r.abs()))
    }
}

impl<S: Dynamics, C: Constraints> Constrained<S, C> {
    /// `system` under `constraints`.
    pub fn new(system: S, constraints: C) -> Self {
        Self {
            system,
            constraints,
            mass_factor: OnceLock::new(),
        }
    }

    /// The wrapped system.
    pub fn system(&self) -> &S {
        &self.system
    }

    /// The constraints.
    pub fn constraints(&self) -> &C {
        &self.constraints
    }

    /// Number of generalized coordinates n.
    pub fn dof(&self) -> usize {
        self.system.dof()
    }

    /// Number of constraint rows k (holonomic and velocity).
    pub fn rows(&self) -> usize {
        self.holonomic_rows() + self.velocity_rows()
    }

    fn holonomic_rows(&self) -> usize {
        if self.constraints.is_present() {
            self.constraints.holonomic_count()
        } else {
            0
        }
    }

    fn velocity_rows(&self) -> usize {
        if self.constraints.is_present() {
            self.constraints.velocity_count()
        } else {
            0
        }
    }

    /// The time seeded for a derivative along the motion: dt/ds = 1 when the constraints depend
    /// on t, else a constant.
    fn time_rate(&self) -> f64 {
        if self.constraints.depends_on_time() {
            1.0
        } else {
            0.0
        }
    }

    /// G (k × n): ∂g/∂q for the holonomic rows, then ∂(a·q̇ + b)/∂q̇ for the velocity rows.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] or [`Error::NonFinite`] for a bad state,
    /// [`Error::NonlinearVelocityConstraint`] for a velocity row not linear in q̇,
    /// [`Error::NonFinite`] when G is not finite.
    pub fn constraint_jacobian(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<DMatrix<f64>> {
        check_state(self.dof(), t, q, Some(qd))?;
        let (k, n) = (self.rows(), self.dof());
        let mut g = vec![0.0; k * n];
        self.jacobian_into(t, q, qd, &mut g);
        finite(&g, "constraint Jacobian", t)?;
        self.check_linear(t, q, qd, &g)?;
        Ok(DMatrix::from_row_slice(k, n, &g))
    }

    /// γ (length k): G q̈ + γ is the constraints' second time derivative (holonomic rows) or
    /// first (velocity rows) along the motion, so that the constrained accelerations satisfy
    /// G q̈ = −γ.
    ///
    /// # Errors
    /// As [`constraint_jacobian`](Self::constraint_jacobian), and [`Error::NonFinite`] when γ is
    /// not finite.
    pub fn gamma(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<DVector<f64>> {
        check_state(self.dof(), t, q, Some(qd))?;
        let mut gamma = vec![0.0; self.rows()];
        self.gamma_into(t, q, qd, &mut gamma);
        finite(&gamma, "constraint bias γ", t)?;
        Ok(DVector::from_vec(gamma))
    }

    /// The residuals at (t, q, q̇): g, and ġ = G q̇ + ∂g/∂t with a·q̇ + b (a consistent state has
    /// both zero).
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] or [`Error::NonFinite`] for a bad state or a residual that
    /// is not finite.
    pub fn residuals(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<ConstraintResiduals> {
        check_state(self.dof(), t, q, Some(qd))?;
        let (kh, kv) = (self.holonomic_rows(), self.velocity_rows());
        let mut position = vec![0.0; kh];
        let mut velocity = vec![0.0; kh + kv];
        if kh > 0 {
            self.constraints.holonomic(t, q, &mut position);
        }
        // ġ = G q̇ from compiled rows when the constraints have them and hold still (∂g/∂t = 0);
        // otherwise one dual pass along the motion.
        let n = self.dof();
        let compiled = kh > 0
            && !self.constraints.depends_on_time()
            && with_f64_buf::<256, _>((kh + kv) * (n + 1), |buf| {
                let (g, gamma) = buf.split_at_mut((kh + kv) * n);
                let done = self.constraints.compiled_rows(t, q, qd, g, gamma);
                if done {
                    for (i, r) in velocity[..kh].iter_mut().enumerate() {
                        *r = dot(&g[i * n..(i + 1) * n], qd);
                    }
                }
                done
            });
        if kh > 0 && !compiled {
            let td = Dual64::new(t, self.time_rate());
            let qq: Vec<Dual64> = q.iter().zip(qd).map(|(&x, &v)| Dual64::new(x, v)).collect();
            let mut out = vec![Dual64::from(0.0); kh];
            self.constraints.holonomic(td, &qq, &mut out);
            for (r, o) in velocity.iter_mut().zip(&out) {
                *r = o.eps;
            }
        }
        if kv > 0 {
            self.constraints.velocity(t, q, qd, &mut velocity[kh..]);
        }
        finite(&position, "constraint residual", t)?;
        finite(&velocity, "constraint velocity residual", t)?;
        Ok(ConstraintResiduals {
            position: DVector::from_vec(position),
            velocity: DVector::from_vec(velocity),
        })
    }

    /// X = M⁻¹Gᵀ (row i = M⁻¹ Gᵢᵀ) and the LDLᵀ factor of S = G M⁻¹ Gᵀ, for the k = `g.len()` / n
    /// rows of G in `g` (row-major), with M at (t, q, q̇): the one factorization behind the
    /// multipliers and the projections, over any scalar (dual numbers for the integrators'
    /// Jacobians).
    ///
    /// # Errors
    /// [`Error::SingularMassMatrix`] when M cannot be factored, [`Error::DependentConstraints`]
    /// when S cannot (G rank-deficient).
    fn schur<D: Scalar>(&self, t: D, q: &[D], qd: &[D], g: &[D]) -> Result<(Vec<D>, Vec<D>)> {
        let n = self.dof();
        if self.system.structure().constant_mass {
            let m = self.constant_mass_factor(t.re(), q, qd)?;
            return self.schur_factored(m, t, q, g);
        }
        let mut m = vec![D::zero(); n * n];
        self.system.mass_matrix_into(t, q, qd, &mut m);
        mass_factor_in_place(&mut m, n, t, q)?;
        self.schur_factored(&m, t, q, g)
    }

    /// [`schur`](Self::schur) with M's LDLᵀ factor `m` given (over the scalar, or in `f64` for
    /// a constant M).
    fn schur_factored<F: Copy, D: Scalar + std::ops::Mul<F, Output = D>>(
        &self,
        m: &[F],
        t: D,
        q: &[D],
        g: &[D],
    ) -> Result<(Vec<D>, Vec<D>)> {
        let n = self.dof();
        let k = g.len() / n;
        let mut x = vec![D::zero(); k * n];
        let mut s = vec![D::zero(); k * k];
        self.schur_into(m, t, q, g, &mut x, &mut s)?;
        Ok((x, s))
    }

    /// [`schur_factored`](Self::schur_factored) into caller-owned `x` (k × n) and `s` (k × k).
    fn schur_into<F: Copy, D: Scalar + std::ops::Mul<F, Output = D>>(
        &self,
        m: &[F],
        t: D,
        q: &[D],
        g: &[D],
        x: &mut [D],
        s: &mut [D],
    ) -> Result<()> {
        let n = self.dof();
        let k = g.len() / n;
        x.copy_from_slice(g);
        for row in x.chunks_exact_mut(n) {
            ldlt_solve(m, n, row);
        }
        // S is symmetric: one dot product per pair, factored in place (no copy kept for the
        // error path, which forms S again).
        let entry = |i: usize, j: usize| dot(&g[i * n..(i + 1) * n], &x[j * n..(j + 1) * n]);
        for i in 0..k {
            for j in i..k {
                s[i * k + j] = entry(i, j);
                s[j * k + i] = s[i * k + j];
            }
        }
        let big = (0..k).fold(0.0_f64, |m, i| m.max(s[i * k + i].re().abs()));
        // After the factorization the diagonal holds 1/dⱼ: a pivot below RANK_LOSS of the
        // largest diagonal entry is a rank loss too (see RANK_LOSS).
        if ldlt_in_place(s, k).is_err()
            || (0..k).any(|j| s[j * k + j].re() * (RANK_LOSS * big) >= 1.0)
        {
            let s: Vec<f64> = (0..k * k).map(|ij| entry(ij / k, ij % k).re()).collect();
            let q: Vec<f64> = q.iter().map(|x| x.re()).collect();
            return Err(self.dependent(&s, k, t.re(), &q));
        }
        Ok(())
    }

    /// The LDLᵀ factor of a constant M, made at the first state seen and kept.
    fn constant_mass_factor<D: Scalar>(&self, t: f64, q: &[D], qd: &[D]) -> Result<&[f64]> {
        let n = self.dof();
        let factor = self.mass_factor.get_or_init(|| {
            let q: Vec<f64> = q.iter().map(|x| x.re()).collect();
            let qd: Vec<f64> = qd.iter().map(|x| x.re()).collect();
            let mut m = vec![0.0; n * n];
            self.system.mass_matrix_into(t, &q, &qd, &mut m);
            mass_factor_in_place(&mut m, n, t, &q)?;
            Ok(m)
        });
        factor.as_deref().map_err(Clone::clone)
    }

    /// q̈, λ and the reactions Gᵀλ at (t, q, q̇) (module docs).
    ///
    /// # Errors
    /// As [`evaluate_into`](Self::evaluate_into).
    pub fn evaluate(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<ConstrainedAccelerations> {
        let (n, k) = (self.dof(), self.rows());
        let mut qdd = DVector::zeros(n);
        let mut lambda = DVector::zeros(k);
        let mut reactions = DVector::zeros(n);
        self.evaluate_into(
            t,
            q,
            qd,
            qdd.as_mut_slice(),
            lambda.as_mut_slice(),
            reactions.as_mut_slice(),
        )?;
        Ok(ConstrainedAccelerations {
            accelerations: qdd,
            multipliers: lambda,
            reaction_forces: reactions,
        })
    }

    /// The power of the reactions, Gᵀλ·q̇: zero for constraints that do not move (the seed's R
    /// does no work), otherwise the rate at which a moving constraint (a driven wire, a moving
    /// support) or a velocity row's b(t, q) feeds energy in, −λ·∂g/∂t − λ·b. Along a run the
    /// energy function h = q̇·p − L then changes as dh/dt = Gᵀλ·q̇ + Q″·q̇ − q̇·∂Φ/∂q̇ − ∂L/∂t,
    /// so that h − ∫ Gᵀλ·q̇ dt balances as in an unconstrained system.
    ///
    /// # Errors
    /// As [`evaluate_into`](Self::evaluate_into).
    pub fn constraint_power(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<f64> {
        let e = self.evaluate(t, q, qd)?;
        Ok(e.reaction_forces.iter().zip(qd).map(|(r, v)| r * v).sum())
    }

    /// The constrained accelerations q̈ alone.
    ///
    /// # Errors
    /// As [`evaluate_into`](Self::evaluate_into).
    pub fn accelerations(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<DVector<f64>> {
        self.evaluate(t, q, qd).map(|e| e.accelerations)
    }

    /// [`evaluate`](Self::evaluate) into caller-owned slices: `qdd` and `reactions` of length n,
    /// `multipliers` of length k.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] for a slice of the wrong length; [`Error::NonFinite`] for a
    /// non-finite state, G, γ or result; [`Error::NonlinearVelocityConstraint`];
    /// [`Error::SingularMassMatrix`] when M cannot be factored; [`Error::DependentConstraints`]
    /// when G M⁻¹ Gᵀ cannot (G rank-deficient).
    pub fn evaluate_into(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        qdd: &mut [f64],
        multipliers: &mut [f64],
        reactions: &mut [f64],
    ) -> Result<()> {
        let (n, k) = (self.dof(), self.rows());
        check_state(n, t, q, Some(qd))?;
        for (what, expected, got) in [
            ("accelerations", n, qdd.len()),
            ("multipliers", k, multipliers.len()),
            ("reaction forces", n, reactions.len()),
        ] {
            if got != expected {
                return Err(Error::DimensionMismatch {
                    what,
                    expected,
                    got,
                });
            }
        }
        // Velocity rows are checked linear in q̇ at the state (G for their scale); holonomic
        // rows need no check, and the solve checks G itself.
        if self.velocity_rows() > 0 {
            let mut g = vec![0.0; k * n];
            self.jacobian_f64(t, q, qd, &mut g);
            finite(&g, "constraint Jacobian", t)?;
            self.check_linear(t, q, qd, &g)?;
        }
        self.solve_first_kind_f64(t, q, qd, qdd, multipliers, reactions)?;
        finite(multipliers, "constraint multipliers", t)?;
        finite(reactions, "reaction forces", t)?;
        finite(qdd, "accelerations", t)
    }

    /// [`solve_first_kind`](Self::solve_first_kind) at an `f64` state from the pieces compiled
    /// ahead of time where the parts have them: M and f from one run of the wrapped system's
    /// eq. 55 program ([`Dynamics::derived_program`]), so M is factored once, and G with γ from
    /// [`Constraints::compiled_rows`]; each from the generic passes otherwise.
    ///
    /// # Errors
    /// As [`solve_first_kind`](Self::solve_first_kind).
    fn solve_first_kind_f64(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        qdd: &mut [f64],
        multipliers: &mut [f64],
        reactions: &mut [f64],
    ) -> Result<()> {
        let Some(program) = self.system.derived_program() else {
            return self.solve_first_kind(t, q, qd, qdd, multipliers, reactions);
        };
        let (n, k) = (self.dof(), self.rows());
        let constant = self.system.structure().constant_mass;
        // One work buffer (on the stack for small systems): M, G, M⁻¹Gᵀ, γ and S.
        with_f64_buf::<512, _>(n * n + 2 * k * n + k + k * k, |buf| {
            let (m, rest) = buf.split_at_mut(n * n);
            let (g, rest) = rest.split_at_mut(k * n);
            let (x, rest) = rest.split_at_mut(k * n);
            let (gamma, s) = rest.split_at_mut(k);
            program.mass_and_force(t, q, qd, m, qdd);
            // A constant M's factor is kept from the first evaluation.
            let m: &[f64] = if constant {
                self.constant_mass_factor(t, q, qd)?
            } else {
                finite(m, "mass matrix", t)?;
                factor_mass(m, n, t, q)?;
                m
            };
            crate::linalg::solve_mass(m, n, t, qdd)?;
            reactions.fill(0.0);
            if k == 0 {
                return Ok(());
            }
            if !self.constraints.compiled_rows(t, q, qd, g, gamma) {
                self.jacobian_into(t, q, qd, g);
                self.gamma_into(t, q, qd, gamma);
            }
            finite(g, "constraint Jacobian", t)?;
            finite(gamma, "constraint bias γ", t)?;
            self.schur_into(m, t, q, g, x, s)?;
            self.apply_multipliers(g, gamma, x, s, qdd, multipliers, reactions);
            Ok(())
        })
    }

    /// Lagrange's equations of the first kind at (t, q, q̇) over any scalar, unchecked: q̈₀ from
    /// the wrapped system (M q̈₀ = f), S λ = −γ − G q̈₀, q̈ = q̈₀ + M⁻¹Gᵀλ, reactions Gᵀλ.
    ///
    /// # Errors
    /// Those of the wrapped system's accelerations, [`Error::NonFinite`] for G or γ,
    /// [`Error::SingularMassMatrix`], [`Error::DependentConstraints`].
    fn solve_first_kind<D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        qdd: &mut [D],
        multipliers: &mut [D],
        reactions: &mut [D],
    ) -> Result<()> {
        let (n, k) = (self.dof(), self.rows());
        // The unconstrained accelerations q̈₀ (M q̈₀ = f, eq. 55).
        self.system.accelerations_into(t, q, qd, qdd)?;
        reactions.fill(D::zero());
        if k == 0 {
            return Ok(());
        }
        // G and γ in one buffer: one allocation fewer per evaluation.
        let mut buffer = vec![D::zero(); k * n + k];
        let (g, gamma) = buffer.split_at_mut(k * n);
        self.jacobian_into(t, q, qd, g);
        self.gamma_into(t, q, qd, gamma);
        for (what, x) in [("constraint Jacobian", &*g), ("constraint bias γ", &*gamma)] {
            if !x.iter().all(|v| v.re().is_finite()) {
                return Err(Error::NonFinite { what, t: t.re() });
            }
        }
        let (x, sf) = self.schur(t, q, qd, g)?;
        self.apply_multipliers(g, gamma, &x, &sf, qdd, multipliers, reactions);
        Ok(())
    }

    /// From q̈₀ in `qdd`: λ from S λ = −γ − G q̈₀ (`sf` S's factor), then q̈ = q̈₀ + M⁻¹Gᵀλ
    /// (`x` = M⁻¹Gᵀ by rows) and the reactions Gᵀλ added to `reactions` (zeroed).
    #[allow(clippy::too_many_arguments)]
    fn apply_multipliers<D: Scalar>(
        &self,
        g: &[D],
        gamma: &[D],
        x: &[D],
        sf: &[D],
        qdd: &mut [D],
        multipliers: &mut [D],
        reactions: &mut [D],
    ) {
        let (n, k) = (self.dof(), self.rows());
        for i in 0..k {
            multipliers[i] = -gamma[i] - dot(&g[i * n..(i + 1) * n], qdd);
        }
        ldlt_solve(sf, k, multipliers);
        for (i, &l) in multipliers.iter().enumerate() {
            for j in 0..n {
                reactions[j] += g[i * n + j] * l;
                qdd[j] += x[i * n + j] * l;
            }
        }
    }

    /// G into `g` (row-major k × n) at an `f64` state, unchecked: from the constraints'
    /// compiled rows when they have them, otherwise by [`jacobian_into`](Self::jacobian_into).
    fn jacobian_f64(&self, t: f64, q: &[f64], qd: &[f64], g: &mut [f64]) {
        let done = with_f64_buf::<64, _>(self.rows(), |gamma| {
            self.constraints.compiled_rows(t, q, qd, g, gamma)
        });
        if !done {
            self.jacobian_into(t, q, qd, g);
        }
    }

    /// G into `g` (row-major k × n), unchecked: forward-mode duals over chunks of q (holonomic
    /// rows) and of q̇ (velocity rows), over any scalar.
    fn jacobian_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], g: &mut [D]) {
        let (kh, kv, n) = (self.holonomic_rows(), self.velocity_rows(), self.dof());
        let tc = grad_const::<D, CHUNK>(t);
        for start in (0..n).step_by(CHUNK) {
            let seeded = |x: &[D]| -> Vec<Grad<D, CHUNK>> {
                x.iter()
                    .enumerate()
                    .map(|(j, &v)| {
                        if (start..start + CHUNK).contains(&j) {
                            grad_seed(v, j - start)
                        } else {
                            grad_const(v)
                        }
                    })
                    .collect()
            };
            let width = CHUNK.min(n - start);
            if kh > 0 {
                let qq = seeded(q);
                let mut out = vec![tc; kh];
                self.constraints.holonomic(tc, &qq, &mut out);
                for (i, o) in out.iter().enumerate() {
                    for c in 0..width {
                        g[i * n + start + c] = grad_part(o, c);
                    }
                }
            }
            if kv > 0 {
                let qq: Vec<_> = q.iter().map(|&v| grad_const(v)).collect();
                let vv = seeded(qd);
                let mut out = vec![tc; kv];
                self.constraints.velocity(tc, &qq, &vv, &mut out);
                for (i, o) in out.iter().enumerate() {
                    for c in 0..width {
                        g[(kh + i) * n + start + c] = grad_part(o, c);
                    }
                }
            }
        }
    }

    /// γ into `gamma` (length k), unchecked, over any scalar: one second-order pass along
    /// (t + s, q + s q̇) for the holonomic rows, one first-order pass for the velocity rows.
    fn gamma_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], gamma: &mut [D]) {
        let (kh, kv) = (self.holonomic_rows(), self.velocity_rows());
        let rate = D::from(self.time_rate());
        if kh > 0 {
            let td = Dual2::new(t, rate, D::zero());
            let qq: Vec<Dual2<D>> = q
                .iter()
                .zip(qd)
                .map(|(&x, &v)| Dual2::new(x, v, D::zero()))
                .collect();
            let mut out = vec![Dual2::from_re(D::zero()); kh];
            self.constraints.holonomic(td, &qq, &mut out);
            for (y, o) in gamma.iter_mut().zip(&out) {
                *y = o.v2;
            }
        }
        if kv > 0 {
            let td = Dual::new(t, rate);
            let qq: Vec<Dual<D>> = q.iter().zip(qd).map(|(&x, &v)| Dual::new(x, v)).collect();
            let vv: Vec<Dual<D>> = qd.iter().map(|&v| Dual::from_re(v)).collect();
            let mut out = vec![Dual::from_re(D::zero()); kv];
            self.constraints.velocity(td, &qq, &vv, &mut out);
            for (y, o) in gamma[kh..].iter_mut().zip(&out) {
                *y = o.eps;
            }
        }
    }

    /// Refuse a velocity row whose Hessian in q̇ is not zero at the state: hyper-dual passes over
    /// pairs of chunks of q̇ (the upper block triangle). `g` is G, for the rows' scales.
    fn check_linear(&self, t: f64, q: &[f64], qd: &[f64], g: &[f64]) -> Result<()> {
        let (kh, kv, n) = (self.holonomic_rows(), self.velocity_rows(), self.dof());
        if kv == 0 {
            return Ok(());
        }
        type H = Hyper<f64, CHUNK, CHUNK>;
        let tc: H = hyper(t, None, None);
        let qq: Vec<H> = q.iter().map(|&v| hyper(v, None, None)).collect();
        let mut worst = vec![0.0_f64; kv];
        for a in (0..n).step_by(CHUNK) {
            for b in (a..n).step_by(CHUNK) {
                let vv: Vec<H> = qd
                    .iter()
                    .enumerate()
                    .map(|(j, &v)| {
                        let e1 = (a..a + CHUNK).contains(&j).then(|| {
                            let mut e = SVector::<f64, CHUNK>::zeros();
                            e[j - a] = 1.0;
                            e
                        });
                        let e2 = (b..b + CHUNK).contains(&j).then(|| {
                            let mut e = SMatrix::<f64, 1, CHUNK>::zeros();
                            e[j - b] = 1.0;
                            e
                        });
                        hyper(v, e1, e2)
                    })
                    .collect();
                let mut out = vec![tc; kv];
                self.constraints.velocity(tc, &qq, &vv, &mut out);
                for (w, o) in worst.iter_mut().zip(&out) {
                    for i in 0..CHUNK.min(n - a) {
                        for j in 0..CHUNK.min(n - b) {
                            let h = hyper_mixed(o, i, j);
                            // A NaN is kept as the worst, so it is refused too.
                            if h.is_nan() || h.abs() > *w {
                                *w = if h.is_nan() { f64::NAN } else { h.abs() };
                            }
                        }
                    }
                }
            }
        }
        for (r, &w) in worst.iter().enumerate() {
            let row = kh + r;
            let scale = g[row * n..(row + 1) * n]
                .iter()
                .fold(1.0_f64, |m, x| m.max(x.abs()));
            if w.is_nan() || w > LINEARITY_TOLERANCE * scale {
                return Err(Error::NonlinearVelocityConstraint {
                    t,
                    row: self.constraints.name(row),
                    second_derivative: w,
                });
            }
        }
        Ok(())
    }

    /// The typed error for a Schur complement `s` (k × k, the first k rows) that LDLᵀ refused: the first row whose
    /// leading block fails is dependent on earlier ones, with the coefficients of the
    /// combination from the block before it.
    fn dependent(&self, s: &[f64], k: usize, t: f64, q: &[f64]) -> Error {
        let name = |i: usize| self.constraints.name(i);
        let lead = |j: usize| -> Vec<f64> {
            (0..j)
                .flat_map(|r| s[r * k..r * k + j].iter().copied())
                .collect()
        };
        let failing = (1..=k).find(|&j| ldlt_in_place(&mut lead(j), j).is_err());
        let (row, others) = match failing {
            Some(j) => {
                let row = j - 1;
                let mut f = lead(row);
                let others = if row == 0 || ldlt_in_place(&mut f, row).is_err() {
                    Vec::new()
                } else {
                    // S₀ c = S[0..row, row]: Gᵣ ≈ Σ cᵢ Gᵢ in the M⁻¹ metric.
                    let mut c: Vec<f64> = (0..row).map(|i| s[i * k + row]).collect();
                    ldlt_solve(&f, row, &mut c);
                    let big = c.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
                    (0..row)
                        .filter(|&i| c[i].abs() > 1e-8 * big)
                        .map(name)
                        .collect()
                };
                (row, others)
            }
            None => (k - 1, (0..k - 1).map(name).collect()),
        };
        Error::DependentConstraints {
            t,
            q: q.to_vec(),
            row: name(row),
            others,
        }
    }
}

/// The constrained system as a system of its own: its accelerations are the constrained q̈
/// (index 1: M q̈ = f + Gᵀλ with G q̈ = −γ), over any scalar, so the integrators and their AD
/// Jacobians take it as they take any [`Dynamics`]; [`Dynamics::constraints`] tells them to
/// bring each accepted step back onto the constraints. The energies, M and the momenta are the
/// wrapped system's. It has no eq. 55 program (the Taylor method refuses it, naming the methods
/// that serve it), and a constraint that moves makes it time-dependent.
impl<S: Dynamics, C: Constraints> Dynamics for Constrained<S, C> {
    crate::dynamics::forward_dynamics!(system: dof, kinetic_energy, potential_energy,
        potential_gradient_into, generalized_forces_into, dissipative_forces_into, momenta_into,
        mass_matrix_into, energy);
    fn structure(&self) -> crate::dynamics::Structure {
        let s = self.system.structure();
        crate::dynamics::Structure {
            time_dependent: s.time_dependent
                || (self.rows() > 0 && self.constraints.depends_on_time()),
            ..s
        }
    }
    fn accelerations_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        let (n, k) = (self.dof(), self.rows());
        if crate::scalar::is::<D, f64>() {
            // SAFETY: D is f64 (same TypeId), so these are identity casts.
            let (tf, qf, qdf, outf) = unsafe {
                (
                    *crate::scalar::cast::<D, f64>(&t),
                    crate::scalar::cast_slice::<D, f64>(q),
                    crate::scalar::cast_slice::<D, f64>(qd),
                    &mut *(out as *mut [D] as *mut [f64]),
                )
            };
            with_f64_buf::<64, _>(k + n, |buf| {
                let (lf, rf) = buf.split_at_mut(k);
                self.solve_first_kind_f64(tf, qf, qdf, outf, lf, rf)
            })?;
        } else {
            let mut multipliers = vec![D::zero(); k];
            let mut reactions = vec![D::zero(); n];
            self.solve_first_kind(t, q, qd, out, &mut multipliers, &mut reactions)?;
        }
        if out.iter().all(|a| a.re().is_finite()) {
            Ok(())
        } else {
            Err(Error::NonFinite {
                what: "accelerations",
                t: t.re(),
            })
        }
    }
    fn taylor_program(&self) -> std::result::Result<&dyn crate::dynamics::DerivedProgram, String> {
        Err(
            "the Taylor method expands the unconstrained eq. 55 program, which has no \
             multipliers: a constrained model takes a Runge–Kutta method or radau5, each step \
             projected back onto the constraints, or with holonomic rows only RATTLE \
             (stormer_verlet, yoshida4/6/8) or midpoint"
                .into(),
        )
    }
    fn constraints(&self) -> Option<&dyn crate::dynamics::ConstraintAccess> {
        (self.rows() > 0).then_some(self as &dyn crate::dynamics::ConstraintAccess)
    }
}

impl<S: Dynamics, C: Constraints> crate::dynamics::ConstraintAccess for Constrained<S, C> {
    fn holonomic_rows(&self) -> usize {
        Constrained::holonomic_rows(self)
    }
    fn velocity_rows(&self) -> usize {
        Constrained::velocity_rows(self)
    }
    fn row_name(&self, row: usize) -> String {
        self.constraints.name(row)
    }
    fn moving(&self) -> bool {
        self.constraints.depends_on_time()
    }
    fn check_state(&self, t: f64, q: &[f64], qd: &[f64], tol: (f64, f64)) -> Result<()> {
        self.check_consistent_within(t, q, qd, tol.0, tol.1)
    }
    fn project_in_place(
        &self,
        t: f64,
        q: &mut [f64],
        qd: &mut [f64],
        tol: (f64, f64),
    ) -> Result<bool> {
        let (pq, pqd) = self.project_within(t, q, qd, tol.0, tol.1)?;
        let moved = pq != q || pqd != qd;
        q.copy_from_slice(&pq);
        qd.copy_from_slice(&pqd);
        Ok(moved)
    }
    fn worst_residual(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<f64> {
        self.residuals(t, q, qd).map(|r| r.max_abs())
    }
    fn holonomic_into(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.constraints.holonomic(t, q, out)
    }
    fn jacobian_into(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) -> Result<()> {
        Constrained::jacobian_into(self, t, q, qd, out);
        finite(out, "constraint Jacobian", t)
    }
    fn multipliers_into(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        multipliers: &mut [f64],
        reactions: &mut [f64],
    ) -> Result<()> {
        let mut qdd = vec![0.0; self.dof()];
        self.evaluate_into(t, q, qd, &mut qdd, multipliers, reactions)
    }
    fn holonomic_rates_into(&self, t: f64, q: &[f64], out: &mut [f64]) {
        if !self.constraints.depends_on_time() {
            out.fill(0.0);
            return;
        }
        let qq: Vec<Dual64> = q.iter().map(|&x| Dual64::from_re(x)).collect();
        let mut rates = vec![Dual64::from_re(0.0); out.len()];
        self.constraints
            .holonomic(Dual64::new(t, 1.0), &qq, &mut rates);
        for (o, r) in out.iter_mut().zip(&rates) {
            *o = r.eps;
        }
    }
}

/// M (n × n, at (t, q)) replaced by its LDLᵀ factor: [`Error::NonFinite`] for a non-finite M,
/// [`Error::SingularMassMatrix`] when it cannot be factored.
fn mass_factor_in_place<D: Scalar>(m: &mut [D], n: usize, t: D, q: &[D]) -> Result<()> {
    if !m.iter().all(|x| x.re().is_finite()) {
        return Err(Error::NonFinite {
            what: "mass matrix",
            t: t.re(),
        });
    }
    factor_mass(m, n, t, q)
}

fn dot<D: Scalar>(x: &[D], y: &[D]) -> D {
    x.iter().zip(y).fold(D::zero(), |s, (&a, &b)| s + a * b)
}
