//! Equilibria on the constraint manifold: virtual work with workless reactions (seed §3.1–3.2).
//!
//! A [`Constrained`] system at rest stays at rest where the static residual r (see
//! [`crate::equilibrium`]) is balanced by the reactions of its holonomic constraints and the
//! configuration satisfies them:
//!
//! r(q) = Gᵀλ,    g(t, q) = 0,
//!
//! G = ∂g/∂q (k × n), with the sign convention of [`Constrained`] (M q̈ = −r + Gᵀλ, so at rest
//! r = Gᵀλ). This is the principle of virtual work of eq. 27–29 with the reactions kept: for
//! every virtual displacement δq with G δq = 0 the reactions do no work, so r·δq = 0.
//!
//! Velocity (nonholonomic) rows a(t, q)·q̇ + b(t, q) = 0 do not restrict the positions, and at
//! rest (q̇ = 0) they read b(t, q) = 0, which the usual scleronomic rows (rolling without
//! slipping, a knife edge) satisfy identically; their multipliers are not determined by the
//! balance at rest. They are ignored in the solve and in the verdict.

use super::residual::{STEADY_OFFSETS, STEADY_TOLERANCE, StaticProblem};
use super::stability::{Stability, classify};
use super::{StaticsOptions, equilibrium};
use crate::checks::check_state;
use crate::constrained::Constrained;
use crate::dynamics::Dynamics;
use crate::energies::Constraints;
use crate::error::{Error, Result};
use crate::nonlinear::{Residual, Stopping, damped_newton};
use nalgebra::{DMatrix, DVector};
use num_dual::{Dual64, HyperDual64};

/// A singular value of G below this fraction of the largest makes G rank-deficient.
const RANK_TOLERANCE: f64 = 1e-10;

/// An equilibrium on the constraint manifold, found by [`constrained_equilibrium`].
#[derive(Debug, Clone, PartialEq)]
pub struct ConstrainedEquilibrium {
    /// The equilibrium configuration q* (length n).
    pub q: DVector<f64>,
    /// λ, one per holonomic row (length k), with the sign convention of [`Constrained`]:
    /// r(q*) = Gᵀλ.
    pub multipliers: DVector<f64>,
    /// The generalized reaction forces Gᵀλ (length n), the seed's R.
    pub reaction_forces: DVector<f64>,
    /// |r(q*) − Gᵀλ|, the force balance left (Euclidean norm).
    pub residual: f64,
    /// g(t, q*), one per holonomic row.
    pub constraint_residuals: DVector<f64>,
    /// Newton/Levenberg–Marquardt iterations used.
    pub iterations: usize,
    /// Stable, unstable or neutral on the constraint manifold.
    pub stability: Stability,
    /// Why, in words.
    pub reason: String,
    /// Eigenvalues of the reduced Hessian Zᵀ H Z (symmetric part), ascending (length n − k).
    pub eigenvalues: DVector<f64>,
    /// The stiffness K = ∂r/∂q at q* (as [`crate::Equilibrium::stiffness`]).
    pub stiffness: DMatrix<f64>,
    /// The Hessian of the Lagrangian of the balance, H = K − Σ λᵢ ∂²gᵢ/∂q² (n × n).
    pub hessian: DMatrix<f64>,
    /// The constraint Jacobian G = ∂g/∂q at q* (k × n).
    pub constraint_jacobian: DMatrix<f64>,
}

/// Find an equilibrium of a constrained system near `q_guess`: q* and λ with
///
/// r(q*) = Gᵀλ,    g(t, q*) = 0,
///
/// r the static residual ∂U/∂q − Q″ − ∂T/∂q + ∂Φ/∂q̇ + ∂²T/∂q̇∂t at q̇ = 0 of the wrapped system
/// (see [`crate::equilibrium`]), g its holonomic rows and G = ∂g/∂q, sign convention of
/// [`Constrained`] (the reaction is +Gᵀλ). Velocity rows are ignored: they do not restrict the
/// positions, and at rest they read b(t, q) = 0, which the usual rolling and knife-edge rows
/// satisfy identically; their multipliers are not determined by the balance at rest.
///
/// The (n + k) system F(q, λ) = [r − Gᵀλ; g] = 0 is solved by Newton's method on its exact
/// Jacobian
///
/// J = [[H, −Gᵀ], [G, 0]],    H = K − Σᵢ λᵢ ∂²gᵢ/∂q²,
///
/// K = ∂r/∂q and the constraints' curvature from dual numbers (G by `Dual64`, ∂²gᵢ/∂q² by
/// hyper-duals; no finite differences), so convergence is quadratic; it is globalised as
/// [`crate::equilibrium`] is (Armijo line search on ½|F|², Levenberg–Marquardt damping), with the
/// same [`StaticsOptions`]. The guess needs only q: λ starts from the least-squares fit
/// G Gᵀλ = G r. The stopping tolerance is relative to the largest of the loads, |Gᵀλ| and
/// |G|·|q| (the size of the terms of g, in g's units).
///
/// The verdict is the energy criterion on the manifold (seed §3.2 (3)): with Z a basis of the
/// null space of G (the virtual displacements), the eigenvalues of Zᵀ H Z decide: all positive
/// stable (a strict minimum of U − λ·g on g = 0), one negative unstable, else neutral. A
/// configuration the constraints fix (n = k) is stable. The inertia and damping are not
/// consulted.
///
/// # Errors
/// [`Error::DependentConstraints`] when G is rank-deficient at the guess or at the root (naming
/// the row and the earlier rows it combines); [`Error::NoConvergence`] when no root is reached
/// within the options' bounds (its `q` is the last configuration; try another guess, or check
/// that the loads can be balanced on the manifold); [`Error::NoStaticEquilibrium`] when the
/// forces or the constraints change with t at the root and `options.frozen_time` is not set;
/// [`Error::DimensionMismatch`] or [`Error::NonFinite`] for a bad guess or a non-finite model;
/// [`Error::InvalidInput`] for bad options. Without holonomic rows this is [`equilibrium`]
/// (λ empty).
///
/// ```
/// use lagrangian::{Constrained, Constraints, KineticEnergy, Potential, Scalar, Stability};
/// use lagrangian::{StaticsOptions, System, constrained_equilibrium};
///
/// /// A unit point mass in the plane under gravity 9.81 (y up).
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
///     fn depends_on_time(&self) -> bool {
///         false
///     }
/// }
///
/// let pendulum = Constrained::new(System::new(2, Point).with_potential(Gravity), Rod);
/// let e = constrained_equilibrium(&pendulum, 0.0, &[0.3, -0.8], &StaticsOptions::default())?;
/// assert!((e.q[1] + 1.0).abs() < 1e-14 && e.q[0].abs() < 1e-14);
/// // The rod pulls up: r = (0, 9.81) = Gᵀλ with G = (0, −2), so λ = −9.81 / 2.
/// assert!((e.multipliers[0] + 4.905).abs() < 1e-12);
/// assert_eq!(e.stability, Stability::Stable);
/// # Ok::<(), lagrangian::Error>(())
/// ```
pub fn constrained_equilibrium<S: Dynamics, C: Constraints>(
    system: &Constrained<S, C>,
    t: f64,
    q_guess: &[f64],
    options: &StaticsOptions,
) -> Result<ConstrainedEquilibrium> {
    let inner = system.system();
    let constraints = system.constraints();
    let n = inner.dof();
    let k = if constraints.is_present() {
        constraints.holonomic_count()
    } else {
        0
    };
    if k == 0 {
        let e = equilibrium(inner, t, q_guess, options)?;
        return Ok(ConstrainedEquilibrium {
            constraint_residuals: DVector::zeros(0),
            multipliers: DVector::zeros(0),
            reaction_forces: DVector::zeros(n),
            residual: e.residual,
            iterations: e.iterations,
            stability: e.stability,
            reason: e.reason,
            eigenvalues: e.eigenvalues,
            hessian: e.stiffness.clone(),
            stiffness: e.stiffness,
            constraint_jacobian: DMatrix::zeros(0, n),
            q: e.q,
        });
    }
    options.validate()?;
    check_state(n, t, q_guess, None)?;
    let mut problem = Augmented {
        statics: StaticProblem::new(inner, t),
        constraints,
        t,
        n,
        k,
    };
    let g0 = problem.jacobian_g(q_guess)?;
    check_rank(&g0, constraints, t, q_guess)?;
    // λ₀ from the least-squares balance G Gᵀ λ = G r.
    let (r0, _) = problem.statics.residual(q_guess)?;
    let lambda0 = (&g0 * g0.transpose())
        .lu()
        .solve(&(&g0 * &r0))
        .filter(|l| l.iter().all(|v| v.is_finite()))
        .unwrap_or_else(|| DVector::zeros(k));
    let mut z0 = DVector::zeros(n + k);
    z0.rows_mut(0, n)
        .copy_from(&DVector::from_column_slice(q_guess));
    z0.rows_mut(n, k).copy_from(&lambda0);
    let stopping = Stopping {
        abs_tolerance: options.abs_tolerance,
        rel_tolerance: options.rel_tolerance,
        step_tolerance: options.step_tolerance,
        max_iterations: options.max_iterations,
        max_step: options.max_step,
    };
    let root = damped_newton(&mut problem, z0, &stopping).map_err(|e| match e {
        Error::NoConvergence {
            iterations,
            residual,
            mut q,
        } => {
            q.truncate(n);
            Error::NoConvergence {
                iterations,
                residual,
                q,
            }
        }
        e => e,
    })?;
    let q = root.q.rows(0, n).into_owned();
    let lambda = root.q.rows(n, k).into_owned();
    let qs = q.as_slice();
    let g = problem.jacobian_g(qs)?;
    check_rank(&g, constraints, t, qs)?;
    if !options.frozen_time {
        if !inner.structure().conservative() {
            problem.statics.check_steady(qs)?;
        }
        if constraints.depends_on_time() {
            check_steady_constraints(constraints, t, qs, k, &g)?;
        }
    }
    let stiffness = problem.statics.jacobian(qs)?;
    let hessian = root.k.view((0, 0), (n, n)).into_owned();
    let reaction_forces = g.transpose() * &lambda;
    let (r, _) = problem.statics.residual(qs)?;
    let mut constraint_residuals = vec![0.0; k];
    constraints.holonomic(t, qs, &mut constraint_residuals);
    let (eigenvalues, stability, reason) = verdict(&hessian, &g, options.stability_tolerance);
    Ok(ConstrainedEquilibrium {
        residual: (&r - &reaction_forces).norm(),
        q,
        multipliers: lambda,
        reaction_forces,
        constraint_residuals: DVector::from_vec(constraint_residuals),
        iterations: root.iterations,
        stability,
        reason,
        eigenvalues,
        stiffness,
        hessian,
        constraint_jacobian: g,
    })
}

/// The energy criterion on null(G): eigenvalues of Zᵀ H Z and the verdict with its reason.
fn verdict(h: &DMatrix<f64>, g: &DMatrix<f64>, tol: f64) -> (DVector<f64>, Stability, String) {
    let (k, n) = g.shape();
    if k >= n {
        return (
            DVector::zeros(0),
            Stability::Stable,
            "the constraints fix the configuration (G has full rank n: no virtual displacement)"
                .to_string(),
        );
    }
    let z = null_basis(g);
    let reduced = z.transpose() * h * &z;
    let (values, (stability, why)) = classify(&reduced, tol);
    let why = why
        .replace(
            "K has",
            "the Hessian H = K − Σλᵢ∂²gᵢ/∂q² reduced to null(G) has",
        )
        .replace(
            "K is",
            "the Hessian H = K − Σλᵢ∂²gᵢ/∂q² reduced to null(G) is",
        );
    let reason = format!("{why} (energy criterion on the constraint manifold)");
    (values, stability, reason)
}

/// Z (n × (n − k)): an orthonormal basis of null(G) for G (k × n) of full rank k, the last n − k
/// right singular vectors of G.
pub(super) fn null_basis(g: &DMatrix<f64>) -> DMatrix<f64> {
    let (k, n) = g.shape();
    // Pad G to n × n so that the SVD yields a full Vᵀ.
    let mut padded = DMatrix::zeros(n, n);
    padded.rows_mut(0, k).copy_from(g);
    let svd = padded.svd(false, true);
    let vt = svd.v_t.expect("requested Vᵀ");
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    DMatrix::from_fn(n, n - k, |i, j| vt[(order[k + j], i)])
}

/// `Err(DependentConstraints)` when G (k × n) is rank-deficient: the first row whose addition
/// drops the rank, and the earlier rows of the least-squares combination.
pub(super) fn check_rank<C: Constraints>(
    g: &DMatrix<f64>,
    constraints: &C,
    t: f64,
    q: &[f64],
) -> Result<()> {
    let k = g.nrows();
    let top = g.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let deficient = |rows: usize| -> bool {
        if rows == 0 {
            return false;
        }
        let sv = g.rows(0, rows).into_owned().singular_values();
        let (big, small) = sv
            .iter()
            .fold((0.0_f64, f64::INFINITY), |(b, s), &v| (b.max(v), s.min(v)));
        big == 0.0 || small <= RANK_TOLERANCE * big.max(top)
    };
    let Some(rows) = (1..=k).find(|&j| deficient(j)) else {
        return Ok(());
    };
    let row = rows - 1;
    let others = if row == 0 {
        Vec::new()
    } else {
        let earlier = g.rows(0, row).into_owned();
        let target = g.row(row).transpose();
        let gram = &earlier * earlier.transpose();
        match gram.lu().solve(&(&earlier * target)) {
            Some(c) => {
                let big = c.amax();
                (0..row)
                    .filter(|&i| c[i].abs() > 1e-8 * big)
                    .map(|i| constraints.name(i))
                    .collect()
            }
            None => (0..row).map(|i| constraints.name(i)).collect(),
        }
    };
    Err(Error::DependentConstraints {
        t,
        q: q.to_vec(),
        row: constraints.name(row),
        others,
    })
}

/// `Err(NoStaticEquilibrium)` when g(t, q) changes with t beyond the steady tolerance, relative
/// to |G|·|q| (the size of g's terms).
fn check_steady_constraints<C: Constraints>(
    constraints: &C,
    t: f64,
    q: &[f64],
    k: usize,
    g: &DMatrix<f64>,
) -> Result<()> {
    let mut now = vec![0.0; k];
    constraints.holonomic(t, q, &mut now);
    let qmax = q.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let scale = (g.amax() * qmax).max(f64::MIN_POSITIVE);
    let mut later = vec![0.0; k];
    for dt in STEADY_OFFSETS {
        constraints.holonomic(t + dt, q, &mut later);
        let change = now
            .iter()
            .zip(&later)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        if change.is_nan() || change > STEADY_TOLERANCE * scale {
            return Err(Error::NoStaticEquilibrium {
                t,
                other: t + dt,
                q: q.to_vec(),
                change,
            });
        }
    }
    Ok(())
}

/// F(q, λ) = [r(q) − Gᵀλ; g(t, q)] and its Jacobian, for the Newton core.
pub(super) struct Augmented<'a, S: ?Sized, C> {
    pub(super) statics: StaticProblem<'a, S>,
    pub(super) constraints: &'a C,
    pub(super) t: f64,
    pub(super) n: usize,
    pub(super) k: usize,
}

impl<S: Dynamics + ?Sized, C: Constraints> Augmented<'_, S, C> {
    /// G = ∂g/∂q by one `Dual64` pass per coordinate.
    pub(super) fn jacobian_g(&self, q: &[f64]) -> Result<DMatrix<f64>> {
        let (n, k) = (self.n, self.k);
        let mut g = DMatrix::zeros(k, n);
        let mut qs: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
        let mut out = vec![Dual64::from(0.0); k];
        for j in 0..n {
            qs[j].eps = 1.0;
            self.constraints
                .holonomic(Dual64::from(self.t), &qs, &mut out);
            qs[j].eps = 0.0;
            for i in 0..k {
                g[(i, j)] = out[i].eps;
            }
        }
        if g.iter().all(|v| v.is_finite()) {
            Ok(g)
        } else {
            Err(Error::NonFinite {
                what: "constraint Jacobian",
                t: self.t,
            })
        }
    }

    /// Σᵢ λᵢ ∂²gᵢ/∂q² by one hyper-dual pass per pair of coordinates.
    pub(super) fn curvature(&self, q: &[f64], lambda: &[f64]) -> DMatrix<f64> {
        let (n, k) = (self.n, self.k);
        let mut h = DMatrix::zeros(n, n);
        let mut out = vec![HyperDual64::from(0.0); k];
        for a in 0..n {
            for b in a..n {
                let qs: Vec<HyperDual64> = q
                    .iter()
                    .enumerate()
                    .map(|(j, &x)| {
                        let e1 = if j == a { 1.0 } else { 0.0 };
                        let e2 = if j == b { 1.0 } else { 0.0 };
                        HyperDual64::new(x, e1, e2, 0.0)
                    })
                    .collect();
                self.constraints
                    .holonomic(HyperDual64::from(self.t), &qs, &mut out);
                let v: f64 = out.iter().zip(lambda).map(|(o, l)| l * o.eps1eps2).sum();
                h[(a, b)] = v;
                h[(b, a)] = v;
            }
        }
        h
    }
}

impl<S: Dynamics + ?Sized, C: Constraints> Residual for Augmented<'_, S, C> {
    fn residual(&mut self, z: &[f64]) -> Result<(DVector<f64>, f64)> {
        let (n, k) = (self.n, self.k);
        let (q, lambda) = z.split_at(n);
        let (r, scale) = self.statics.residual(q)?;
        let g = self.jacobian_g(q)?;
        let reactions = g.transpose() * DVector::from_column_slice(lambda);
        let mut values = vec![0.0; k];
        self.constraints.holonomic(self.t, q, &mut values);
        let mut f = DVector::zeros(n + k);
        f.rows_mut(0, n).copy_from(&(&r - &reactions));
        f.rows_mut(n, k).copy_from_slice(&values);
        let qmax = q.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let scale = scale.max(reactions.norm()).max(g.norm() * qmax);
        if f.iter().all(|v| v.is_finite()) && scale.is_finite() {
            Ok((f, scale))
        } else {
            Err(Error::NonFinite {
                what: "constrained static residual [r − Gᵀλ; g]",
                t: self.t,
            })
        }
    }

    fn jacobian(&mut self, z: &[f64]) -> Result<DMatrix<f64>> {
        let (n, k) = (self.n, self.k);
        let (q, lambda) = z.split_at(n);
        let stiffness = self.statics.jacobian(q)?;
        let g = self.jacobian_g(q)?;
        let hessian = stiffness - self.curvature(q, lambda);
        let mut j = DMatrix::zeros(n + k, n + k);
        j.view_mut((0, 0), (n, n)).copy_from(&hessian);
        j.view_mut((0, n), (n, k)).copy_from(&(-g.transpose()));
        j.view_mut((n, 0), (k, n)).copy_from(&g);
        if j.iter().all(|v| v.is_finite()) {
            Ok(j)
        } else {
            Err(Error::NonFinite {
                what: "constrained static Jacobian [[K − Σλ∂²g, −Gᵀ], [G, 0]]",
                t: self.t,
            })
        }
    }
}
