//! The variational system of a constrained model, held to the model's constraints as a plain
//! run of the model is: after each accepted step of a method that projects (the Runge–Kutta
//! methods and radau5), the state is projected by the model's own
//! [`ConstraintAccess::project_in_place`] — the same map, to the same tolerance, as the plain
//! run — and, where it moved, the sensitivities with it, onto the tangent space at the new state
//! ([`TangentSpace`]). The run's `constraint_residual` is then the model's, as in the plain run.

use super::tangent::TangentSpace;
use crate::dynamics::{ConstraintAccess, DerivedProgram, Dynamics};
use crate::error::Result;
use crate::program::eval::Function;
use crate::routes::EnergyModel;

/// The bound variational system of n(1 + m) coordinates whose constraints are the model's on
/// its first n (see the module docs).
pub(super) struct Projected<'a> {
    pub(super) system: &'a EnergyModel,
    /// The model's constraints.
    pub(super) state: &'a dyn ConstraintAccess,
    pub(super) tangent: &'a TangentSpace,
    /// The tangent space's tape bound to the run's parameter values.
    pub(super) bound: Function,
    /// The model's number of coordinates.
    pub(super) n: usize,
}

impl Dynamics for Projected<'_> {
    crate::dynamics::forward_dynamics!(system: dof, structure, kinetic_energy, potential_energy,
        potential_gradient_into, generalized_forces_into, dissipative_forces_into, momenta_into,
        mass_matrix_into, accelerations_into, lagrangian, derived_program, energy);
    fn taylor_program(&self) -> std::result::Result<&dyn DerivedProgram, String> {
        Err("the Taylor method does not project its steps onto the constraints".into())
    }
    fn constraints(&self) -> Option<&dyn ConstraintAccess> {
        Some(self)
    }
}

/// The model's constraints on the first n coordinates; the sensitivities follow a projection.
/// Only the projecting methods run this system, so the parts RATTLE and midpoint read (G, the
/// multipliers, ∂g/∂t) are the model's, padded with zeros for the sensitivities.
impl ConstraintAccess for Projected<'_> {
    fn holonomic_rows(&self) -> usize {
        self.state.holonomic_rows()
    }
    fn velocity_rows(&self) -> usize {
        self.state.velocity_rows()
    }
    fn row_name(&self, row: usize) -> String {
        self.state.row_name(row)
    }
    fn moving(&self) -> bool {
        self.state.moving()
    }
    fn check_state(&self, t: f64, q: &[f64], qd: &[f64], tol: (f64, f64)) -> Result<()> {
        let n = self.n;
        self.state.check_state(t, &q[..n], &qd[..n], tol)
    }
    fn project_in_place(
        &self,
        t: f64,
        q: &mut [f64],
        qd: &mut [f64],
        tol: (f64, f64),
    ) -> Result<bool> {
        let n = self.n;
        let moved = self
            .state
            .project_in_place(t, &mut q[..n], &mut qd[..n], tol)?;
        if moved {
            self.tangent.project(&self.bound, t, n, q, qd, false)?;
        }
        Ok(moved)
    }
    fn worst_residual(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<f64> {
        let n = self.n;
        self.state.worst_residual(t, &q[..n], &qd[..n])
    }
    fn holonomic_into(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.state.holonomic_into(t, &q[..self.n], out)
    }
    fn jacobian_into(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) -> Result<()> {
        let (n, size) = (self.n, q.len());
        let rows = self.holonomic_rows() + self.velocity_rows();
        let mut g = vec![0.0; rows * n];
        self.state.jacobian_into(t, &q[..n], &qd[..n], &mut g)?;
        out.fill(0.0);
        for r in 0..rows {
            out[r * size..r * size + n].copy_from_slice(&g[r * n..(r + 1) * n]);
        }
        Ok(())
    }
    fn multipliers_into(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        multipliers: &mut [f64],
        reactions: &mut [f64],
    ) -> Result<()> {
        let n = self.n;
        reactions.fill(0.0);
        self.state
            .multipliers_into(t, &q[..n], &qd[..n], multipliers, &mut reactions[..n])
    }
    fn holonomic_rates_into(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.state.holonomic_rates_into(t, &q[..self.n], out)
    }
}
