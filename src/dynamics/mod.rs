//! The equations of motion as one trait, shared by the energy route ([`System`](crate::System))
//! and the particle route ([`ParticleSystem`](crate::ParticleSystem)).
//!
//! Lagrange's equations with dissipation (seed eq. 55), solved for q̈:
//!
//! M q̈ = Q″ + ∂L/∂q − (∂²L/∂q̇∂q) q̇ − ∂²L/∂q̇∂t − ∂Φ/∂q̇,   M = ∂²T/∂q̇².
//!
//! The generic `*_into` methods run on any [`Scalar`], so integrators get exact Jacobians of the
//! accelerations by calling them with dual numbers. The `f64` methods check their inputs and
//! return owned vectors. `qp_form.rs` gives the implicit symplectic methods the (q, p) form of
//! any `Dynamics` (`ForceParts`).

mod forward;
mod jacobian;
mod qp_form;

pub(crate) use forward::forward_dynamics;
pub(crate) use jacobian::{acceleration_jacobian, jacobian};
pub(crate) use qp_form::ForceParts;

use crate::checks::{check_state, finite};
use crate::error::Result;
use crate::scalar::Scalar;
use nalgebra::{DMatrix, DVector};

/// What a system is made of, found from its parts (at compile time for Rust models).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Structure {
    /// Number of generalized coordinates.
    pub dof: usize,
    /// L depends on t explicitly (T or U): the energy function h is then not conserved.
    pub time_dependent: bool,
    /// M = ∂²T/∂q̇² is one constant matrix, factored once.
    pub constant_mass: bool,
    /// T depends on q̇ only with constant M and U on (t, q): explicit symplectic methods apply.
    pub separable: bool,
    /// A Rayleigh dissipation function is present.
    pub dissipative: bool,
    /// Generalized (non-potential) forces are present.
    pub forced: bool,
}

impl Structure {
    /// No dissipation, no forcing and no explicit time dependence: h = q̇·p − L is conserved.
    pub fn conservative(&self) -> bool {
        !self.dissipative && !self.forced && !self.time_dependent
    }
}

/// A mechanical system whose equations of motion can be evaluated.
pub trait Dynamics {
    /// Number of generalized coordinates.
    fn dof(&self) -> usize;

    /// The structure the integrators and the method choice rely on.
    fn structure(&self) -> Structure;

    /// Kinetic energy T(t, q, q̇).
    fn kinetic_energy<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D;

    /// Potential energy U(t, q) of every conservative force (gravity of particles included).
    fn potential_energy<D: Scalar>(&self, t: D, q: &[D]) -> D;

    /// ∂U/∂q, written to `out`.
    fn potential_gradient_into<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]);

    /// Non-conservative, non-dissipative generalized forces Q″ (eq. 39, 55), written to `out`.
    fn generalized_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]);

    /// Viscous generalized forces −∂Φ/∂q̇ (eq. 55), written to `out`.
    fn dissipative_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]);

    /// Momenta p = ∂L/∂q̇, written to `out`.
    fn momenta_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]);

    /// Row-major mass matrix M = ∂²T/∂q̇², written to `out` (length dof²).
    fn mass_matrix_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]);

    /// Accelerations q̈ from eq. 55, written to `out`. Fails with a typed error when M cannot be
    /// factored or the result is not finite.
    fn accelerations_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()>;

    /// The eq. 55 program derived on the system's expression graph, when it has one
    /// ([`EnergyModel::with_program`](crate::tape::EnergyModel::with_program)): the integrators
    /// take the accelerations' Jacobian and the (q, p) form of the implicit symplectic methods
    /// from its machine code instead of from dual numbers. A wrapper that changes the equations
    /// must not pass it on.
    fn derived_program(&self) -> Option<&dyn DerivedProgram> {
        None
    }

    /// How a run of a ready-made scene computed its accelerations and why, which the solver
    /// puts in the run's statistics (`scene_path`): only a traced scene's run (`FastPath`, in
    /// `trace`) says; `None` for every other system.
    fn scene_path(&self) -> Option<String> {
        None
    }

    /// The eq. 55 program the Taylor method expands, or why there is none:
    /// [`derived_program`](Self::derived_program), unless the system makes one only when asked
    /// (a Rust scene traced into the graph, [`crate::trace::WithProgram`], whose trace and
    /// compilation would otherwise slow the first run of every other method). A wrapper that
    /// changes the equations must not pass it on.
    ///
    /// # Errors
    /// The reason, as the Taylor method reports it.
    fn taylor_program(&self) -> std::result::Result<&dyn DerivedProgram, String> {
        self.derived_program().ok_or_else(|| {
            "the Taylor method expands the model's expression graph: state the model as \
             expressions (lg.Model, tape::EomProgram) or trace a Rust system \
             (trace::WithProgram)"
                .into()
        })
    }

    /// The constraints the motion is held to, when there are any (a
    /// [`Constrained`](crate::Constrained) system): the integrators bring each accepted step back
    /// onto them and refuse the methods that cannot. A wrapper that keeps the equations passes
    /// it on.
    fn constraints(&self) -> Option<&dyn ConstraintAccess> {
        None
    }

    /// The Lagrangian L = T − U.
    fn lagrangian<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.kinetic_energy(t, q, qd) - self.potential_energy(t, q)
    }

    /// Accelerations q̈ at (t, q, q̇), with inputs checked.
    fn accelerations(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<DVector<f64>> {
        check_state(self.dof(), t, q, Some(qd))?;
        let mut out = DVector::zeros(self.dof());
        self.accelerations_into(t, q, qd, out.as_mut_slice())?;
        Ok(out)
    }

    /// The mass matrix M(t, q, q̇), with inputs checked.
    fn mass_matrix(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<DMatrix<f64>> {
        check_state(self.dof(), t, q, Some(qd))?;
        let n = self.dof();
        let mut m = vec![0.0; n * n];
        self.mass_matrix_into(t, q, qd, &mut m);
        finite(&m, "mass matrix", t)?;
        Ok(DMatrix::from_row_slice(n, n, &m))
    }

    /// Q″(t, q, q̇): the generalized forces that no potential or dissipation function describes.
    fn generalized_forces(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<DVector<f64>> {
        check_state(self.dof(), t, q, Some(qd))?;
        let mut out = DVector::zeros(self.dof());
        self.generalized_forces_into(t, q, qd, out.as_mut_slice());
        finite(out.as_slice(), "generalized forces", t)?;
        Ok(out)
    }

    /// Momenta p = ∂L/∂q̇.
    fn momenta(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<DVector<f64>> {
        check_state(self.dof(), t, q, Some(qd))?;
        let mut out = DVector::zeros(self.dof());
        self.momenta_into(t, q, qd, out.as_mut_slice());
        finite(out.as_slice(), "momenta", t)?;
        Ok(out)
    }

    /// The Lagrangian L = T − U at a checked state.
    fn lagrangian_at(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<f64> {
        check_state(self.dof(), t, q, Some(qd))?;
        let l = self.lagrangian(t, q, qd);
        finite(&[l], "Lagrangian", t)?;
        Ok(l)
    }

    /// The energy function (Jacobi integral) h = q̇·p − L: T + U for natural systems, conserved
    /// whenever L has no explicit t, also for velocity-dependent L.
    fn energy(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<f64> {
        energy_from_parts(self, t, q, qd)
    }
}

/// What the integrators take from the eq. 55 program derived on a model's expression graph
/// ([`Dynamics::derived_program`]): machine code at `f64` states. A capability, as
/// [`ConstraintAccess`] is, so that this trait names nothing of the code generation above it.
/// Sealed: the one implementation is the crate's own ([`EomFunction`](crate::tape::EomFunction)),
/// which the Taylor method reads whole through [`as_any`](Self::as_any).
pub trait DerivedProgram: sealed::Sealed + std::any::Any {
    /// Row-major M (n × n) and f of eq. 55 (M q̈ = f) at a state.
    fn mass_and_force(&self, t: f64, q: &[f64], qd: &[f64], m: &mut [f64], f: &mut [f64]);

    /// ∂q̈/∂(q, q̇) (row-major n × 2n) into `jac` when compiled for this model; `false` (and
    /// `jac` untouched) when the caller must take it from dual numbers.
    fn acceleration_jacobian(&self, t: f64, q: &[f64], qd: &[f64], jac: &mut [f64]) -> bool;

    /// The (q, p) form: momenta p and G = ∂L/∂q + Q″ − ∂Φ/∂q̇ at (t, q, q̇).
    fn qp_form(&self, t: f64, q: &[f64], qd: &[f64], p: &mut [f64], g: &mut [f64]);

    /// ∂(p, G)/∂(q, q̇) (row-major 2n × 2n) when compiled for this model, else `false`.
    fn qp_jacobian(&self, t: f64, q: &[f64], qd: &[f64], jac: &mut [f64]) -> bool;

    /// About the instructions of one evaluation of q̈ (the automatic method choice weighs a
    /// step's cost with it).
    fn acceleration_instructions(&self) -> usize;

    /// The program itself, for the Taylor method, which expands its graph.
    fn as_any(&self) -> &dyn std::any::Any;
}

/// Keeps [`DerivedProgram`] the crate's own.
pub(crate) mod sealed {
    /// Implemented only inside the crate.
    pub trait Sealed {}
}

/// The `f64` view of a constrained system's constraints that the integrators need
/// ([`Dynamics::constraints`]); [`Constrained`](crate::Constrained) implements it, and its
/// documentation says what each part means.
pub trait ConstraintAccess {
    /// Number of holonomic rows g(t, q) = 0.
    fn holonomic_rows(&self) -> usize;

    /// Number of velocity rows a(t, q)·q̇ + b(t, q) = 0.
    fn velocity_rows(&self) -> usize;

    /// The name of row `row` (holonomic rows first), for messages.
    fn row_name(&self, row: usize) -> String;

    /// Whether any row reads t explicitly (a moving constraint).
    fn moving(&self) -> bool;

    /// Refuse a state off the constraints (or with a velocity row not linear in q̇), judged
    /// with `tol` = (rtol, atol): each row's residual as a distance within atol + rtol·ℓᵢ
    /// ([`Constrained::check_consistent_within`](crate::Constrained::check_consistent_within)).
    ///
    /// # Errors
    /// [`Error::InconsistentState`](crate::Error::InconsistentState) naming the row, and the
    /// errors of evaluating the constraints.
    fn check_state(&self, t: f64, q: &[f64], qd: &[f64], tol: (f64, f64)) -> Result<()>;

    /// Move (q, q̇) onto the constraints in place when a row is outside `tol` = (rtol, atol),
    /// judged as [`check_state`](Self::check_state) judges; whether it moved.
    ///
    /// # Errors
    /// Those of [`Constrained::project_within`](crate::Constrained::project_within).
    fn project_in_place(
        &self,
        t: f64,
        q: &mut [f64],
        qd: &mut [f64],
        tol: (f64, f64),
    ) -> Result<bool>;

    /// The largest absolute residual of the rows, positions and velocities.
    ///
    /// # Errors
    /// As [`Constrained::residuals`](crate::Constrained::residuals).
    fn worst_residual(&self, t: f64, q: &[f64], qd: &[f64]) -> Result<f64>;

    /// g(t, q) into `out` (length [`holonomic_rows`](Self::holonomic_rows)).
    fn holonomic_into(&self, t: f64, q: &[f64], out: &mut [f64]);

    /// G (row-major, rows × n: holonomic rows ∂g/∂q, then velocity rows) into `out`.
    ///
    /// # Errors
    /// [`Error::NonFinite`](crate::Error::NonFinite) when G is not finite.
    fn jacobian_into(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) -> Result<()>;

    /// λ (length rows) and the generalized reactions Gᵀλ (length n) at a state.
    ///
    /// # Errors
    /// As [`Constrained::evaluate_into`](crate::Constrained::evaluate_into).
    fn multipliers_into(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        multipliers: &mut [f64],
        reactions: &mut [f64],
    ) -> Result<()>;

    /// ∂g/∂t(t, q) into `out` (length [`holonomic_rows`](Self::holonomic_rows)): zero unless a
    /// row moves; the velocity-level condition of RATTLE's last stage is G q̇ + ∂g/∂t = 0.
    fn holonomic_rates_into(&self, t: f64, q: &[f64], out: &mut [f64]);
}

/// h = q̇·p − L from the momenta and the Lagrangian: [`Dynamics::energy`] of a system with no
/// faster way.
pub(crate) fn energy_from_parts<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    q: &[f64],
    qd: &[f64],
) -> Result<f64> {
    let p = system.momenta(t, q, qd)?;
    let l = system.lagrangian_at(t, q, qd)?;
    let h = p.iter().zip(qd).map(|(p, v)| p * v).sum::<f64>() - l;
    finite(&[h], "energy", t).map(|()| h)
}
