//! The consistent states: [`Constrained::project`] takes a state onto the constraints,
//! [`Constrained::check_consistent`] refuses one off them, both judging each row against its
//! own tolerance (the rule below), which is what a drift-free run holds its steps to.
//!
//! **The rule.** Row i is satisfied when its residual, as a distance — |rᵢ| / maxⱼ |Gᵢⱼ|, a
//! distance in q for g(t, q), in q̇ for the velocity level, to first order — is at most
//!
//! atol + rtol·ℓᵢ + 64 ε Σⱼ |Gᵢⱼ xⱼ| / maxⱼ |Gᵢⱼ|,
//!
//! with x = q (or q̇) and ℓᵢ the size of what the row reads: maxⱼ {|xⱼ| : Gᵢⱼ ≠ 0}, counted up
//! to 1 at the position level. That is the error control's own weight atol + rtol·|y| on the
//! row's coordinates, with two differences. Coordinates the row does not read (a free z beside a
//! pendulum's rod, moving fast) do not loosen it. And a coordinate's value is no physical scale
//! (it moves with the origin, and a crank's angle winds without bound), so at the position level
//! it loosens the row only up to 1: the residual stays bounded by the tolerance however far the
//! coordinates go, where a tolerance relative to maxⱼ |qⱼ| let it grow with them. Velocities are
//! the motion's own scale and count in full. The last term is the round-off of the row's own
//! evaluation (the coordinates it reads are known to ε|xⱼ|), so a state on the constraints in
//! floating point is never refused.

use super::{Constrained, PROJECTION_TOLERANCE};
use crate::checks::{check_state, finite};
use crate::dynamics::Dynamics;
use crate::energies::Constraints;
use crate::error::{Error, Result};
use crate::linalg::ldlt_solve;

/// Gauss–Newton iterations of [`Constrained::project`] before it gives up.
const PROJECTION_ITERATIONS: usize = 50;

/// Velocity corrections of [`Constrained::project`] (the rows are linear in q̇, so one is exact
/// up to round-off).
const VELOCITY_CORRECTIONS: usize = 3;

/// Multiples of ε in a row's round-off allowance (the module's rule).
const ROUND_OFF: f64 = 64.0 * f64::EPSILON;

impl<S: Dynamics, C: Constraints> Constrained<S, C> {
    /// The consistent state nearest (t, q, q̇) in the metric of M: positions onto g(t, q) = 0,
    /// then velocities onto the velocity-level constraints (holonomic rows ġ = G q̇ + ∂g/∂t = 0,
    /// velocity rows a·q̇ + b = 0). The repair of an inconsistent initial state
    /// ([`check_consistent`](Self::check_consistent)); [`project_within`](Self::project_within)
    /// with rtol = atol = `tol` ([`PROJECTION_TOLERANCE`], 10⁻¹², when `None`).
    ///
    /// # Errors
    /// As [`project_within`](Self::project_within).
    pub fn project(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        tol: Option<f64>,
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let tol = tolerance(tol)?;
        self.project_within(t, q, qd, tol, tol)
    }

    /// [`project`](Self::project) with each row held to atol + rtol·ℓᵢ as a distance (the rule
    /// in `constrained/projection.rs`, and the constraints page): the routine a drift-free run
    /// calls after each step with its own `rtol` and `atol`.
    ///
    /// Positions, by Gauss–Newton in the M metric, with the holonomic rows' G = ∂g/∂q, M and
    /// the Schur complement S = G M⁻¹ Gᵀ factored (LDLᵀ) at every iterate:
    ///
    /// Δq = −M⁻¹Gᵀ (G M⁻¹ Gᵀ)⁻¹ g(t, q),
    ///
    /// iterated until every row is within its tolerance, for at most 50 iterations; once within
    /// it, one more step takes the residual to round-off (and is kept only if the residual does
    /// not grow). Each step is the smallest correction in ‖Δq‖_M that zeroes the linearized
    /// constraints, so the whole correction is M-orthogonal to the constraint manifold up to
    /// O(|Δq|²) (exactly, when M⁻¹Gᵀ keeps its direction, as for a point on a circle with equal
    /// masses: the correction is radial).
    ///
    /// Velocities, by the M-orthogonal projection with every row's G at the projected q and the
    /// velocity residual r (`residuals(t, q, q̇).velocity`, linear in q̇):
    ///
    /// q̇ ← q̇ − M⁻¹Gᵀ (G M⁻¹ Gᵀ)⁻¹ r,
    ///
    /// to the same rule with q̇ for q. A state already within the tolerance is returned
    /// unchanged, bit for bit. M is evaluated at (t, q, q̇) with the q̇ given.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] or [`Error::NonFinite`] for a bad state or a non-finite g, G
    /// or iterate; [`Error::InvalidInput`] for a tolerance not positive and finite;
    /// [`Error::SingularMassMatrix`]; [`Error::DependentConstraints`] when G M⁻¹ Gᵀ cannot be
    /// factored at an iterate (redundant rows, a dead point); [`Error::ProjectionFailed`],
    /// naming the worst row, when the iterations run out (a start far from the manifold, or
    /// constraints without a real solution); [`Error::NonlinearVelocityConstraint`].
    pub fn project_within(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        rtol: f64,
        atol: f64,
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let (n, kh, k) = (self.dof(), self.holonomic_rows(), self.rows());
        check_state(n, t, q, Some(qd))?;
        let tol = Tolerance::new(rtol, atol)?;
        let mut q = q.to_vec();
        let mut qd = qd.to_vec();
        if k == 0 {
            return Ok((q, qd));
        }
        let mut g = vec![0.0; k * n];
        if kh > 0 {
            let mut r = vec![0.0; kh];
            let mut iterations = 0;
            // The iterate and its scaled residual before the polishing step.
            let mut polished: Option<(Vec<f64>, f64)> = None;
            loop {
                self.constraints.holonomic(t, &q, &mut r);
                finite(&r, "constraint residual", t)?;
                self.jacobian_f64(t, &q, &qd, &mut g);
                finite(&g[..kh * n], "constraint Jacobian", t)?;
                let (worst, scaled) = tol.worst_row(&r, &g, n, &q, true);
                if let Some((before, was)) = polished.take() {
                    if scaled > was {
                        q = before;
                    }
                    break;
                }
                if scaled <= 1.0 {
                    if iterations == 0 {
                        break;
                    }
                    // One more step once within the tolerance: Newton's quadratic convergence
                    // takes the residual to round-off (kept only if it does not grow).
                    polished = Some((q.clone(), scaled));
                } else if iterations == PROJECTION_ITERATIONS {
                    return Err(Error::ProjectionFailed {
                        t,
                        constraint: self.constraints.name(worst),
                        residual: r[worst],
                        iterations,
                    });
                }
                self.correct(t, &q, &qd, &g[..kh * n], &mut r)?;
                // r is now M⁻¹Gᵀ S⁻¹ g, laid out as n entries.
                for (x, d) in q.iter_mut().zip(&r) {
                    *x -= d;
                }
                finite(&q, "projected coordinates", t)?;
                r.resize(kh, 0.0);
                iterations += 1;
            }
        }
        self.jacobian_f64(t, &q, &qd, &mut g);
        finite(&g, "constraint Jacobian", t)?;
        self.check_linear(t, &q, &qd, &g)?;
        for correction in 0..=VELOCITY_CORRECTIONS {
            let mut r = self.residuals(t, &q, &qd)?.velocity.as_slice().to_vec();
            let (worst, scaled) = tol.worst_row(&r, &g, n, &qd, false);
            if scaled <= 1.0 {
                break;
            }
            if correction == VELOCITY_CORRECTIONS {
                return Err(Error::ProjectionFailed {
                    t,
                    constraint: self.constraints.name(worst),
                    residual: r[worst],
                    iterations: correction,
                });
            }
            self.correct(t, &q, &qd, &g, &mut r)?;
            for (v, d) in qd.iter_mut().zip(&r) {
                *v -= d;
            }
            finite(&qd, "projected velocities", t)?;
        }
        Ok((q, qd))
    }

    /// Refuse a state that does not satisfy the constraints: [`Error::InconsistentState`]
    /// naming the worst row, the level ("position": g(t, q); "velocity": ġ = G q̇ + ∂g/∂t or
    /// a·q̇ + b) and its residual; [`check_consistent_within`](Self::check_consistent_within)
    /// with rtol = atol = `tol` ([`PROJECTION_TOLERANCE`] when `None`). A state returned by
    /// `project` with the same tolerance passes.
    ///
    /// # Errors
    /// As [`check_consistent_within`](Self::check_consistent_within).
    pub fn check_consistent(&self, t: f64, q: &[f64], qd: &[f64], tol: Option<f64>) -> Result<()> {
        let tol = tolerance(tol)?;
        self.check_consistent_within(t, q, qd, tol, tol)
    }

    /// [`check_consistent`](Self::check_consistent) judged as
    /// [`project_within`](Self::project_within) judges (each row within atol + rtol·ℓᵢ as a
    /// distance, ℓᵢ the size of the coordinates it reads up to 1): what a run with these
    /// tolerances asks of its initial state. Positions are checked first.
    ///
    /// # Errors
    /// [`Error::InconsistentState`]; otherwise as [`constraint_jacobian`](Self::constraint_jacobian)
    /// and [`residuals`](Self::residuals), and [`Error::InvalidInput`] for a tolerance not
    /// positive and finite.
    pub fn check_consistent_within(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        rtol: f64,
        atol: f64,
    ) -> Result<()> {
        let tol = Tolerance::new(rtol, atol)?;
        let n = self.dof();
        let residuals = self.residuals(t, q, qd)?;
        let g = self.constraint_jacobian(t, q, qd)?;
        // Row-major, as the private helpers take it.
        let g: Vec<f64> = g.transpose().as_slice().to_vec();
        for (level, r, x, capped) in [
            ("position", residuals.position.as_slice(), q, true),
            ("velocity", residuals.velocity.as_slice(), qd, false),
        ] {
            let (worst, scaled) = tol.worst_row(r, &g, n, x, capped);
            if scaled > 1.0 {
                return Err(Error::InconsistentState {
                    t,
                    constraint: self.constraints.name(worst),
                    level,
                    residual: r[worst],
                });
            }
        }
        Ok(())
    }

    /// Replace `r` (length k′ ≤ k, the first k′ rows of G in `g`, row-major k′ × n) by the
    /// M-orthogonal correction M⁻¹Gᵀ (G M⁻¹ Gᵀ)⁻¹ r (length n), with M at (t, q, q̇).
    fn correct(&self, t: f64, q: &[f64], qd: &[f64], g: &[f64], r: &mut Vec<f64>) -> Result<()> {
        let n = self.dof();
        let (x, sf) = self.schur(t, q, qd, g)?;
        ldlt_solve(&sf, r.len(), r.as_mut_slice());
        let mut d = vec![0.0; n];
        for (i, &mu) in r.iter().enumerate() {
            for j in 0..n {
                d[j] += x[i * n + j] * mu;
            }
        }
        finite(&d, "projection step", t)?;
        *r = d;
        Ok(())
    }
}

/// The single tolerance of [`Constrained::project`] and [`Constrained::check_consistent`].
fn tolerance(tol: Option<f64>) -> Result<f64> {
    let tol = tol.unwrap_or(PROJECTION_TOLERANCE);
    if tol.is_finite() && tol > 0.0 {
        Ok(tol)
    } else {
        Err(Error::InvalidInput {
            what: "projection tolerance",
            why: format!(
                "{tol} is not positive and finite; the default is {PROJECTION_TOLERANCE:e}"
            ),
        })
    }
}

/// The two numbers of the module's rule, checked.
#[derive(Debug, Clone, Copy)]
struct Tolerance {
    rtol: f64,
    atol: f64,
}

impl Tolerance {
    fn new(rtol: f64, atol: f64) -> Result<Self> {
        for (what, v) in [("projection rtol", rtol), ("projection atol", atol)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::InvalidInput {
                    what,
                    why: format!(
                        "{v} is not positive and finite; the default is {PROJECTION_TOLERANCE:e}"
                    ),
                });
            }
        }
        Ok(Self { rtol, atol })
    }

    /// The row of `r` farthest from its tolerance, and that distance over its tolerance (≤ 1:
    /// within it): the module's rule with row i of `g` (row-major, n columns) and the
    /// coordinates `x` (`capped`: their size counts up to 1) or velocities. A zero row of G
    /// counts as a distance |rᵢ|.
    fn worst_row(&self, r: &[f64], g: &[f64], n: usize, x: &[f64], capped: bool) -> (usize, f64) {
        let cap = if capped { 1.0 } else { f64::INFINITY };
        let mut worst = (0, 0.0);
        for (i, &ri) in r.iter().enumerate() {
            let row = &g[i * n..(i + 1) * n];
            let (mut big, mut size, mut reads) = (0.0_f64, 0.0_f64, 0.0_f64);
            for (&gij, &xj) in row.iter().zip(x) {
                big = big.max(gij.abs());
                reads += (gij * xj).abs();
                if gij != 0.0 {
                    size = size.max(xj.abs());
                }
            }
            let big = if big > 0.0 { big } else { 1.0 };
            let allowed = self.atol + self.rtol * size.min(cap) + ROUND_OFF * reads / big;
            let d = ri.abs() / big / allowed;
            // A NaN residual is the worst of all.
            if d.is_nan() || d > worst.1 {
                worst = (i, if d.is_nan() { f64::INFINITY } else { d });
            }
        }
        worst
    }
}
