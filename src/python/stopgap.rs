//! TEMPORARY, removed when the coordinator's `impl Dynamics for Constrained` lands on main:
//! lets `AnyModel::Constrained` compile before that. Delegates to the unconstrained model.

use super::model::AnyModel;
use crate::{Constrained, Dynamics, Result, Scalar, Structure};
use crate::routes::ExprConstraints;

impl Dynamics for Constrained<AnyModel, ExprConstraints> {
    fn dof(&self) -> usize {
        self.system().dof()
    }
    fn structure(&self) -> Structure {
        self.system().structure()
    }
    fn kinetic_energy<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.system().kinetic_energy(t, q, qd)
    }
    fn potential_energy<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.system().potential_energy(t, q)
    }
    fn potential_gradient_into<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
        self.system().potential_gradient_into(t, q, out)
    }
    fn generalized_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.system().generalized_forces_into(t, q, qd, out)
    }
    fn dissipative_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.system().dissipative_forces_into(t, q, qd, out)
    }
    fn momenta_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.system().momenta_into(t, q, qd, out)
    }
    fn mass_matrix_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.system().mass_matrix_into(t, q, qd, out)
    }
    fn accelerations_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        self.system().accelerations_into(t, q, qd, out)
    }
    fn derived_program(&self) -> Option<&crate::derived::eom_program::EomFunction> {
        None
    }
}
