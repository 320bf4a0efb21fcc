//! The residual at rest r(q) = −[∂L/∂q + Q″ − ∂Φ/∂q̇ − ∂²L/∂q̇∂t](t, q, q̇ = 0) and its
//! stiffness K = ∂r/∂q by dual numbers (see [`crate::equilibrium`]).

use crate::checks::check_state;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use crate::nonlinear::Residual;
use crate::scalar::Scalar;
use nalgebra::{DMatrix, DVector};
use num_dual::{Dual, Dual64};

/// The stiffness K = ∂r/∂q at (t, q, q̇ = 0), r as in the module documentation, by one dual pass
/// per coordinate.
///
/// At an equilibrium this is the K of the linearised equations M δq̈ + C δq̇ + K δq = 0,
/// centrifugal stiffness included.
pub fn static_stiffness<S: Dynamics>(system: &S, t: f64, q: &[f64]) -> Result<DMatrix<f64>> {
    check_state(system.dof(), t, q, None)?;
    StaticProblem::new(system, t).jacobian(q)
}

/// [`static_stiffness`] for any system, inputs unchecked.
pub(crate) fn static_stiffness_of<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    q: &[f64],
) -> Result<DMatrix<f64>> {
    StaticProblem::new(system, t).jacobian(q)
}

/// r(q) at (t, q, q̇ = 0) and the load scale F it balances (see
/// [`StaticsOptions`](crate::StaticsOptions)).
pub(crate) fn static_residual<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    q: &[f64],
) -> Result<(DVector<f64>, f64)> {
    StaticProblem::new(system, t).residual(q)
}

/// r(q) of a system at time t, q̇ = 0.
pub(super) struct StaticProblem<'a, S: ?Sized> {
    system: &'a S,
    t: f64,
    forced: bool,
    dissipative: bool,
    time_dependent: bool,
}

/// Times after t at which r is compared with r(t) to see whether it depends on t: irrational
/// offsets, so that no periodic forcing is caught at the same phase.
pub(super) const STEADY_OFFSETS: [f64; 3] = [
    0.618_033_988_749_894_9,
    std::f64::consts::SQRT_2,
    7.389_056_098_930_65,
];
/// A change of r with t beyond this fraction of the load scale is a time-dependent balance.
pub(super) const STEADY_TOLERANCE: f64 = 1e-9;

impl<'a, S: Dynamics + ?Sized> StaticProblem<'a, S> {
    pub(super) fn new(system: &'a S, t: f64) -> Self {
        let s = system.structure();
        Self {
            system,
            t,
            forced: s.forced,
            dissipative: s.dissipative,
            time_dependent: s.time_dependent,
        }
    }

    /// ∂U/∂q into `grad` and the other forces at rest, Q″ + ∂T/∂q − ∂Φ/∂q̇ − ∂²T/∂q̇∂t at
    /// (t, q, 0), into `load`, on any scalar (r = grad − load).
    fn terms<D: Scalar>(&self, t: f64, q: &[D], grad: &mut [D], load: &mut [D]) {
        let n = q.len();
        let t = D::from(t);
        self.system.potential_gradient_into(t, q, grad);
        load.fill(D::zero());
        let at_rest = vec![D::zero(); n];
        let mut work = vec![D::zero(); n];
        if self.forced {
            self.system
                .generalized_forces_into(t, q, &at_rest, &mut work);
            add(load, &work, 1.0);
        }
        if self.dissipative {
            self.system
                .dissipative_forces_into(t, q, &at_rest, &mut work);
            add(load, &work, 1.0);
        }
        // ∂T/∂q at q̇ = 0: the centrifugal force of T₀, one dual pass per coordinate.
        let tt = Dual::from_re(t);
        let rest = vec![Dual::from_re(D::zero()); n];
        let mut qs: Vec<Dual<D>> = q.iter().map(|&x| Dual::from_re(x)).collect();
        for i in 0..n {
            qs[i].eps = D::one();
            load[i] += self.system.kinetic_energy(tt, &qs, &rest).eps;
            qs[i].eps = D::zero();
        }
        if self.time_dependent {
            // −∂²T/∂q̇∂t at q̇ = 0: p = ∂T/∂q̇ seeded in t.
            let qs: Vec<Dual<D>> = q.iter().map(|&x| Dual::from_re(x)).collect();
            let mut p = vec![Dual::from_re(D::zero()); n];
            self.system
                .momenta_into(Dual::new(t, D::one()), &qs, &rest, &mut p);
            for (l, p) in load.iter_mut().zip(&p) {
                *l -= p.eps;
            }
        }
    }

    fn residual_at(&self, t: f64, q: &[f64]) -> Result<(DVector<f64>, f64)> {
        let n = q.len();
        let (mut grad, mut load) = (vec![0.0; n], vec![0.0; n]);
        self.terms(t, q, &mut grad, &mut load);
        let r = DVector::from_iterator(n, grad.iter().zip(&load).map(|(g, f)| g - f));
        let scale = norm(&grad).max(norm(&load));
        if r.iter().all(|v| v.is_finite()) && scale.is_finite() {
            Ok((r, scale))
        } else {
            Err(Error::NonFinite {
                what: "static residual ∂U/∂q − Q″ − ∂T/∂q + ∂Φ/∂q̇ (at q̇ = 0)",
                t,
            })
        }
    }

    /// `Err(NoStaticEquilibrium)` when r(q) changes with t.
    pub(super) fn check_steady(&self, q: &[f64]) -> Result<()> {
        let (r, scale) = self.residual_at(self.t, q)?;
        for dt in STEADY_OFFSETS {
            let other = self.t + dt;
            let (r2, scale2) = self.residual_at(other, q)?;
            let change = (&r2 - &r).norm();
            if change > STEADY_TOLERANCE * scale.max(scale2) {
                return Err(Error::NoStaticEquilibrium {
                    t: self.t,
                    other,
                    q: q.to_vec(),
                    change,
                });
            }
        }
        Ok(())
    }
}

/// `acc += s · x`.
fn add<D: Scalar>(acc: &mut [D], x: &[D], s: f64) {
    for (a, &x) in acc.iter_mut().zip(x) {
        *a += x * s;
    }
}

impl<S: Dynamics + ?Sized> Residual for StaticProblem<'_, S> {
    fn residual(&mut self, q: &[f64]) -> Result<(DVector<f64>, f64)> {
        self.residual_at(self.t, q)
    }

    fn jacobian(&mut self, q: &[f64]) -> Result<DMatrix<f64>> {
        let n = q.len();
        let zero = Dual64::from_re(0.0);
        let (mut qs, mut grad, mut load) = (vec![zero; n], vec![zero; n], vec![zero; n]);
        let mut k = DMatrix::zeros(n, n);
        for j in 0..n {
            for (i, (s, &x)) in qs.iter_mut().zip(q).enumerate() {
                *s = Dual64::new(x, if i == j { 1.0 } else { 0.0 });
            }
            self.terms(self.t, &qs, &mut grad, &mut load);
            for i in 0..n {
                k[(i, j)] = grad[i].eps - load[i].eps;
            }
        }
        if k.iter().all(|v| v.is_finite()) {
            Ok(k)
        } else {
            Err(Error::NonFinite {
                what: "static stiffness ∂r/∂q",
                t: self.t,
            })
        }
    }
}

/// |v|, the Euclidean norm.
fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
