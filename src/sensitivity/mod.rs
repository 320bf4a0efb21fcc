//! Forward sensitivities: how a run's motion depends on the model's parameters and on its
//! initial state, exactly (no finite differences), for a model stated on the expression graph.
//!
//! [`Variational`] compiles the variational equations of eq. 55 (derived on the graph by
//! `derived::variational`) into a model of n(1 + m) coordinates, x = (q, s₁, …, sₘ), that
//! every integrator runs as it runs any model. [`SensitivityProblem`] runs it in the model's
//! place from the model's initial state — a constrained model's state projected after each
//! step as its own run is, the sensitivities with it (`projected.rs`, `tangent.rs`) — and
//! splits the result into the model's own run, ∂(q, q̇)/∂θⱼ at each output and, for the events
//! whose conditions it is given ([`EventCondition`]), dt*/dθⱼ at each occurrence by the
//! implicit function theorem (`events.rs`) ([`SensitivitySolution`]).
//! [`solve_sensitivities`] is the short form for a model without constraints and without
//! event times. With [`Options::with_error_coordinates`] the step size is controlled on
//! (q, q̇) alone (CVODES's `errconS = false`); by default the sensitivities are
//! error-controlled too.
//!
//! [`Options::with_error_coordinates`]: crate::integrators::Options::with_error_coordinates
//!
//! ```
//! use lagrangian::sensitivity::{Direction, Variational, solve_sensitivities};
//! use lagrangian::tape::{Binary, Energies, Graph};
//! use lagrangian::{Method, Options};
//! # use approx::assert_relative_eq;
//! // x″ = −k x: T = ½ ẋ², U = ½ k x², parameter k.
//! let mut g = Graph::new();
//! let (k, x, v, half) = (g.param(0), g.coord(0), g.velocity(0), g.constant(0.5));
//! let v2 = g.binary(Binary::Mul, v, v)?;
//! let kinetic = g.binary(Binary::Mul, half, v2)?;
//! let x2 = g.binary(Binary::Mul, x, x)?;
//! let kx2 = g.binary(Binary::Mul, k, x2)?;
//! let potential = g.binary(Binary::Mul, half, kx2)?;
//! let parts = Energies { kinetic, potential: Some(potential), ..Energies::default() };
//! let wrt = [Direction::Parameter(0), Direction::Position(0)];
//! let variational = Variational::new(&g, 1, 1, &parts, None, &wrt)?;
//! let options = Options::adaptive(1e-12, 1e-12).with_output(lagrangian::Output::Final);
//! let sol = solve_sensitivities(&variational, &[4.0], &[1.0], &[0.0], (0.0, 1.0),
//!                               Method::Dop853, &options)?;
//! // x = cos(ω t), ω = √k: ∂x/∂k = −t sin(ω t)/(2ω), ∂x/∂x₀ = cos(ω t).
//! let (w, t) = (2.0_f64, 1.0);
//! assert_relative_eq!(sol.sensitivity(0, 0)[0], -t * (w * t).sin() / (2.0 * w), epsilon = 1e-10);
//! assert_relative_eq!(sol.sensitivity(0, 1)[0], (w * t).cos(), epsilon = 1e-10);
//! # Ok::<(), lagrangian::Error>(())
//! ```

mod events;
mod problem;
mod projected;
mod tangent;

pub use self::events::EventCondition;
pub use self::problem::{SensitivityProblem, check_no_resets, solve_sensitivities};
use self::tangent::TangentSpace;
use crate::derived::eom_program::{Energies, EomProgram};
pub use crate::derived::variational::{ConstraintNodes, Direction};
use crate::derived::variational::{
    projection_outputs, variational_energies, variational_initial_state,
};
use crate::error::{Error, Result};
use crate::expr::graph::Graph;
use crate::integrators::Solution;
use crate::program::{compile::Tape, eval::Function, inputs::Inputs};
use crate::routes::EnergyModel;
use std::sync::Arc;

/// The variational system of a model stated on the graph, compiled once: bind it to parameter
/// values ([`Variational::bind`]) and run it with any method ([`solve_sensitivities`]).
#[derive(Debug, Clone)]
pub struct Variational {
    dof: usize,
    directions: Vec<Direction>,
    kinetic: Arc<Tape>,
    forces: Arc<Tape>,
    program: EomProgram,
    /// For a constrained model: what the sensitivities are projected with, at the start and
    /// after each projected step.
    tangent: Option<TangentSpace>,
}

impl Variational {
    /// The variational equations of the model whose energies are `parts` (nodes of `graph`,
    /// `dof` coordinates, `params` parameters), under `constraints` if it has them, along
    /// `directions`. A constrained model's variational system runs its index-1 equations, its
    /// initial sensitivities projected onto the constraints' tangent space
    /// ([`Variational::initial_state`]), and its steps projected with the model's
    /// ([`SensitivityProblem`]).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a direction outside the model or none; as
    /// [`EomProgram::new`] for the model itself.
    pub fn new(
        graph: &Graph,
        dof: usize,
        params: usize,
        parts: &Energies,
        constraints: Option<ConstraintNodes<'_>>,
        directions: &[Direction],
    ) -> Result<Self> {
        let mut g = graph.clone();
        let system = variational_energies(&mut g, dof, params, parts, constraints, directions)?;
        let size = dof * (1 + directions.len());
        let inputs = Inputs::kinetic(size, params);
        let what = "the variational equations";
        let kinetic = Arc::new(Tape::new(&g, &[system.kinetic], inputs, what)?);
        let forces = system.forces.as_deref().unwrap_or_default();
        let forces = Arc::new(Tape::new(&g, forces, inputs, what)?);
        let tangent = match constraints {
            Some(c) => {
                let outputs = projection_outputs(&mut g, dof, parts, c, directions)?;
                let inputs = Inputs::kinetic(dof, params);
                let tape = Tape::new(&g, &outputs, inputs, "the initial sensitivities")?;
                Some(TangentSpace {
                    tape: Arc::new(tape),
                    holonomic: c.holonomic.len(),
                    rows: c.holonomic.len() + c.velocity.len(),
                })
            }
            None => None,
        };
        let program = EomProgram::new(&mut g, size, params, &system)?;
        Ok(Self {
            dof,
            directions: directions.to_vec(),
            kinetic,
            forces,
            program,
            tangent,
        })
    }

    /// The same system run by the interpreter (see [`EomProgram::interpreted`]).
    pub fn interpreted(self) -> Self {
        Self {
            program: self.program.interpreted(),
            ..self
        }
    }

    /// The model's number of coordinates n (the system has n(1 + m)).
    pub fn dof(&self) -> usize {
        self.dof
    }

    /// The directions, one column of sensitivities each.
    pub fn directions(&self) -> &[Direction] {
        &self.directions
    }

    /// The kinetic energy ½ |ẋ|² and the forces (q̈, s̈₁, …) of the system as tapes, and its
    /// eq. 55 program: what a binding holds to bind the system per run.
    #[cfg_attr(not(feature = "python"), allow(dead_code))]
    pub(crate) fn parts(&self) -> (&Arc<Tape>, &Arc<Tape>, &EomProgram) {
        (&self.kinetic, &self.forces, &self.program)
    }

    /// The variational system at these parameter values, a model of n(1 + m) coordinates.
    ///
    /// # Errors
    /// As [`Function::new`] and [`EomProgram::bind`].
    pub fn bind(&self, params: &[f64]) -> Result<EnergyModel> {
        let size = self.dof * (1 + self.directions.len());
        let kinetic = Function::new(self.kinetic.clone(), params)?;
        let forces = Function::new(self.forces.clone(), params)?;
        EnergyModel::new(size, kinetic, None, None, Some(forces))?
            .with_program(self.program.bind(params)?)
    }

    /// The variational system's initial state from the model's (q₀, q̇₀) at t₀ and the
    /// parameter values `params`: the sensitivities start at zero for a parameter and at a unit
    /// vector for an initial coordinate or velocity — for a constrained model projected onto the
    /// tangent space of the constraints as the parameter or the initial state moves (the
    /// derivative of [`Constrained::project`](crate::constrained::Constrained::project)'s projection in
    /// the M metric: G s + ∂g/∂p = 0, then the rows at the velocity level likewise).
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] when q₀ or q̇₀ has not n entries; [`Error::InvalidInput`]
    /// where M or the constraints' G M⁻¹ Gᵀ cannot be solved at t₀.
    pub fn initial_state(
        &self,
        t0: f64,
        q0: &[f64],
        qd0: &[f64],
        params: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        for (what, v) in [("q0", q0), ("qd0", qd0)] {
            if v.len() != self.dof {
                return Err(Error::DimensionMismatch {
                    what,
                    expected: self.dof,
                    got: v.len(),
                });
            }
        }
        let (mut q, mut qd) = variational_initial_state(q0, qd0, &self.directions);
        if let Some(tangent) = &self.tangent {
            let f = Function::new(tangent.tape.clone(), params)?;
            tangent.project(&f, t0, self.dof, &mut q, &mut qd, true)?;
        }
        Ok((q, qd))
    }

    /// Split a run of the variational system into the model's run (its n coordinates, events
    /// included) and the sensitivities at each output. The continuous solution, when kept,
    /// stays the variational system's (its first n coordinates are the model's).
    pub fn split(&self, sol: Solution) -> SensitivitySolution {
        let (n, m) = (self.dof, self.directions.len());
        let size = sol.dof;
        let mut values = Vec::with_capacity(sol.len() * m * 2 * n);
        let (mut q, mut qd) = (
            Vec::with_capacity(sol.len() * n),
            Vec::with_capacity(sol.len() * n),
        );
        for i in 0..sol.len() {
            let (qi, qdi) = (sol.q_at(i), sol.qd_at(i));
            q.extend_from_slice(&qi[..n]);
            qd.extend_from_slice(&qdi[..n]);
            for j in 0..m {
                let at = n + j * n..n + (j + 1) * n;
                values.extend_from_slice(&qi[at.clone()]);
                values.extend_from_slice(&qdi[at]);
            }
        }
        let events = sol
            .events
            .iter()
            .map(|o| {
                let leading = |v: &[f64]| -> Vec<f64> {
                    v.chunks_exact(size)
                        .flat_map(|r| &r[..n])
                        .copied()
                        .collect()
                };
                crate::integrators::Occurrences {
                    t: o.t.clone(),
                    q: leading(&o.q),
                    qd: leading(&o.qd),
                }
            })
            .collect();
        let event_states = sol.events;
        SensitivitySolution {
            solution: Solution {
                dof: n,
                q,
                qd,
                events,
                ..sol
            },
            directions: self.directions.clone(),
            sensitivities: values,
            event_states,
            event_times: Vec::new(),
        }
    }
}

/// A run with its sensitivities ([`solve_sensitivities`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SensitivitySolution {
    /// The model's own run: its n coordinates at each output, its events, its statistics (the
    /// work of the variational system's run).
    pub solution: Solution,
    /// The directions, in the order of the columns.
    pub directions: Vec<Direction>,
    /// ∂(q, q̇)/∂θⱼ at each output i: 2n numbers (∂q, then ∂q̇) from `(i m + j) 2n`.
    pub sensitivities: Vec<f64>,
    /// The variational system's state at each event occurrence (n(1 + m) coordinates per
    /// occurrence), for the sensitivities there.
    pub event_states: Vec<crate::integrators::Occurrences>,
    /// dt*/dθⱼ per event, m numbers per occurrence (`k m + j` for occurrence k), for a run
    /// given the events' conditions ([`SensitivityProblem::with_event_conditions`]); empty
    /// otherwise.
    pub event_times: Vec<Vec<f64>>,
}

impl SensitivitySolution {
    /// ∂(q, q̇)/∂θⱼ at output `i` (2n numbers: ∂q, then ∂q̇) for direction `j`.
    pub fn sensitivity(&self, i: usize, j: usize) -> &[f64] {
        let width = 2 * self.solution.dof;
        let at = (i * self.directions.len() + j) * width;
        &self.sensitivities[at..at + width]
    }
}
