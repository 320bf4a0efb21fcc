//! The (q, p) form of eq. 55 that the implicit symplectic methods integrate: with p = ∂L/∂q̇,
//! Lagrange's equations with dissipation read ṗ = G(t, q, q̇), G = ∂L/∂q + Q″ − ∂Φ/∂q̇ (the
//! Lagrange–d'Alembert principle, eq. 35, in its continuous form). No second derivative of L is
//! needed: M q̈ and the mixed terms of eq. 55 are the total derivative of p, which the
//! integrators take from p itself.

use super::Dynamics;
use crate::eom::by_dof;
use crate::eom::passes::{Wrt, gradient};
use crate::scalar::Scalar;

/// Which parts of the force G = ∂L/∂q + Q″ − ∂Φ/∂q̇ a system has.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ForceParts {
    /// T does not depend on q: ∂L/∂q = −∂U/∂q, one pass of U only.
    separable: bool,
    forced: bool,
    dissipative: bool,
}

impl ForceParts {
    pub(crate) fn of<S: Dynamics + ?Sized>(system: &S) -> Self {
        let s = system.structure();
        Self {
            separable: s.separable,
            forced: s.forced,
            dissipative: s.dissipative,
        }
    }

    /// p = ∂L/∂q̇ into `p` and G into `g` at an `f64` state: one run of the system's derived
    /// program when it has one, otherwise `momenta_into` and [`force_into`](Self::force_into).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn momenta_and_force<S: Dynamics + ?Sized>(
        self,
        system: &S,
        t: f64,
        q: &[f64],
        v: &[f64],
        p: &mut [f64],
        g: &mut [f64],
        tmp: &mut [f64],
    ) {
        if let Some(program) = system.derived_program() {
            return program.qp_form(t, q, v, p, g);
        }
        system.momenta_into(t, q, v, p);
        self.force_into(system, t, q, v, g, tmp);
    }

    /// G = ∂L/∂q + Q″ − ∂Φ/∂q̇ at (t, q, q̇) into `g`: the right-hand side of ṗ = G, the
    /// (q, p) form of eq. 55. `tmp` has the length of q.
    pub(crate) fn force_into<S: Dynamics + ?Sized, D: Scalar>(
        self,
        system: &S,
        t: D,
        q: &[D],
        v: &[D],
        g: &mut [D],
        tmp: &mut [D],
    ) {
        if self.separable {
            system.potential_gradient_into(t, q, g);
            for x in g.iter_mut() {
                *x = -*x;
            }
        } else {
            g.fill(D::zero());
            let lagrangian = Lagrangian(system);
            by_dof!(None, q.len(), lagrangian.add_position_gradient(t, q, v, g));
        }
        if self.forced {
            system.generalized_forces_into(t, q, v, tmp);
            for (x, f) in g.iter_mut().zip(tmp.iter()) {
                *x += *f;
            }
        }
        if self.dissipative {
            system.dissipative_forces_into(t, q, v, tmp);
            for (x, f) in g.iter_mut().zip(tmp.iter()) {
                *x += *f;
            }
        }
    }
}

/// The Lagrangian of a system, as a function to differentiate.
struct Lagrangian<'a, S: ?Sized>(&'a S);

impl<S: Dynamics + ?Sized> Lagrangian<'_, S> {
    /// `out += ∂L/∂q` by one gradient pass in chunks of `C` (`C2` is unused: the signature
    /// [`by_dof!`] calls).
    fn add_position_gradient<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        v: &[D],
        out: &mut [D],
    ) {
        let system = self.0;
        gradient::<C, D, _>(
            t,
            q,
            v,
            Wrt::Position,
            1.0,
            |t, q, v| system.lagrangian(t, q, v),
            out,
        );
    }
}
