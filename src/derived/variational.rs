//! The variational equations of eq. 55 on the expression graph: how the motion moves when a
//! parameter or the initial state does (forward sensitivities).
//!
//! Along a direction — a parameter pⱼ, or the initial state — the sensitivity sⱼ = ∂q/∂θⱼ
//! obeys the derivative of M q̈ = f along (q, q̇, p) ↦ (sⱼ, ṡⱼ, eⱼ):
//!
//! ```text
//! M s̈ⱼ = ∂f/∂q sⱼ + ∂f/∂q̇ ṡⱼ + ∂f/∂pⱼ − (∂M/∂q sⱼ + ∂M/∂q̇ ṡⱼ + ∂M/∂pⱼ) q̈
//! ```
//!
//! — one tangent sweep of M's entries and f per direction (seeds qᵢ ↦ sⱼᵢ, q̇ᵢ ↦ ṡⱼᵢ and, for a
//! parameter, pⱼ ↦ 1), solved with the factors of M written out on the graph (which are not
//! themselves differentiated), as the Jacobian of the implicit methods is. The state and its m
//! sensitivities together are a second-order system of n(1 + m) coordinates, stated here as a
//! model the whole engine already runs: T = ½ |ẋ|² (M = 1, constant, factored once) and the
//! generalized forces (q̈, s̈₁, …, s̈ₘ). Every integrator then carries the sensitivities with the
//! state — the Runge–Kutta stages, Radau's Newton iteration on the exact (block-triangular)
//! Jacobian, Gauss–Legendre's collocation, the Taylor method's jets — and a parameter or an
//! initial state differ only in the seeds and the initial values (`s(t₀) = 0`, or a unit
//! vector in q₀ or q̇₀).

use super::eom_program::{Energies, Factors, eom_graph, upper};
use crate::error::{Error, Result};
use crate::expr::derive::{Seeds, Simplify, tangents};
use crate::expr::graph::Graph;

/// One column of the sensitivities: what the motion is differentiated with respect to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// A parameter of the model, by index.
    Parameter(usize),
    /// The initial coordinate q₀ᵢ.
    Position(usize),
    /// The initial velocity q̇₀ᵢ.
    Velocity(usize),
}

/// The energies of the variational system of the model `parts` (n = `dof` coordinates, as
/// nodes of `graph`) along `directions`: T = ½ Σ ẋₖ² over the n(1 + m) coordinates
/// x = (q, s₁, …, sₘ), and the generalized forces (q̈, s̈₁, …, s̈ₘ) (see the module docs). The
/// coordinate n + j n + i of the new system is sⱼᵢ, its velocity ṡⱼᵢ.
///
/// # Errors
/// As [`eom_graph`]; [`Error::InvalidInput`] for a direction outside the model (a parameter
/// index ≥ `params`, a coordinate ≥ `dof`) or no direction at all.
pub fn variational_energies(
    graph: &mut Graph,
    dof: usize,
    params: usize,
    parts: &Energies,
    directions: &[Direction],
) -> Result<Energies> {
    let n = dof;
    let bad = |why: String| Error::InvalidInput {
        what: "sensitivities",
        why,
    };
    if directions.is_empty() {
        return Err(bad("no direction to differentiate along".into()));
    }
    for d in directions {
        match *d {
            Direction::Parameter(p) if p >= params => {
                return Err(bad(format!(
                    "parameter {p} is not a parameter: the model has {params}"
                )));
            }
            Direction::Position(i) | Direction::Velocity(i) if i >= n => {
                return Err(bad(format!(
                    "coordinate {i} is not a coordinate: the model has {n}"
                )));
            }
            _ => {}
        }
    }
    let eom = eom_graph(graph, n, parts)?;
    let factors = Factors::of(graph, &eom)?;
    let accelerations = factors.solve(graph, eom.force.clone())?;
    let roots: Vec<usize> = eom.mass.iter().chain(&eom.force).copied().collect();
    let (zero, one) = (graph.constant(0.0), graph.constant(1.0));
    let mut forces = accelerations.clone();
    for (j, d) in directions.iter().enumerate() {
        let mut seeds = Seeds::new();
        for i in 0..n {
            let (s, sd) = (graph.coord(n + j * n + i), graph.velocity(n + j * n + i));
            seeds = seeds.coord(i, s).velocity(i, sd);
        }
        if let Direction::Parameter(p) = *d {
            seeds = seeds.param(p, one);
        }
        let tangent = tangents(graph, &roots, &seeds)?;
        let (dm, df) = tangent.split_at(eom.mass.len());
        let mut s = Simplify(graph);
        let mut rhs = Vec::with_capacity(n);
        for i in 0..n {
            let mut r = df[i];
            for (k, &a) in accelerations.iter().enumerate() {
                if let Some(dmik) = dm[upper(n, i.min(k), i.max(k))] {
                    let p = s.mul(dmik, a)?;
                    r = s.diff(r, Some(p))?;
                }
            }
            rhs.push(r.unwrap_or(zero));
        }
        forces.extend(factors.solve(graph, rhs)?);
    }
    let size = n * (1 + directions.len());
    let mut s = Simplify(graph);
    let mut twice = None;
    for k in 0..size {
        let v = s.0.velocity(k);
        let v2 = s.mul(v, v)?;
        twice = s.sum(twice, Some(v2))?;
    }
    let half = s.0.constant(0.5);
    let kinetic = s.mul(half, twice.unwrap_or(zero))?;
    Ok(Energies {
        kinetic,
        potential: None,
        dissipation: None,
        forces: Some(forces),
    })
}

/// The initial state of the variational system: (q₀, s₁(t₀), …) and (q̇₀, ṡ₁(t₀), …), with
/// sⱼ(t₀) = 0 for a parameter and a unit vector in q₀ or q̇₀ for an initial state.
pub fn variational_initial_state(
    q0: &[f64],
    qd0: &[f64],
    directions: &[Direction],
) -> (Vec<f64>, Vec<f64>) {
    let n = q0.len();
    let size = n * (1 + directions.len());
    let (mut q, mut qd) = (vec![0.0; size], vec![0.0; size]);
    q[..n].copy_from_slice(q0);
    qd[..n].copy_from_slice(qd0);
    for (j, d) in directions.iter().enumerate() {
        match *d {
            Direction::Parameter(_) => {}
            Direction::Position(i) => q[n + j * n + i] = 1.0,
            Direction::Velocity(i) => qd[n + j * n + i] = 1.0,
        }
    }
    (q, qd)
}
