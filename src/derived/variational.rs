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

use super::constraint_program::constraint_graph;
use super::eom_program::{Along, Energies, Factors, eom_graph};
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

/// The constraint rows of a model as nodes of its graph: holonomic rows g(t, q), velocity rows
/// a(t, q)·q̇ + b(t, q), and whether a row reads t.
#[derive(Debug, Clone, Copy)]
pub struct ConstraintNodes<'a> {
    /// The holonomic rows.
    pub holonomic: &'a [usize],
    /// The velocity rows.
    pub velocity: &'a [usize],
    /// Whether a row reads t.
    pub moving: bool,
}

/// The energies of the variational system of the model `parts` (n = `dof` coordinates, as
/// nodes of `graph`) along `directions`: T = ½ Σ ẋₖ² over the n(1 + m) coordinates
/// x = (q, s₁, …, sₘ), and the generalized forces (q̈, s̈₁, …, s̈ₘ) (see the module docs). The
/// coordinate n + j n + i of the new system is sⱼᵢ, its velocity ṡⱼᵢ.
///
/// Under `constraints`, q̈ is the index-1 acceleration of Lagrange's equations of the first
/// kind written out on the graph — q̈ = q̈₀ + M⁻¹Gᵀλ with (G M⁻¹ Gᵀ) λ = −γ − G q̈₀ and
/// q̈₀ = M⁻¹ f, both factorizations unrolled — and s̈ⱼ its tangent along the direction.
///
/// # Errors
/// As [`eom_graph`]; [`Error::InvalidInput`] for a direction outside the model (a parameter
/// index ≥ `params`, a coordinate ≥ `dof`) or no direction at all.
pub fn variational_energies(
    graph: &mut Graph,
    dof: usize,
    params: usize,
    parts: &Energies,
    constraints: Option<ConstraintNodes<'_>>,
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
    let free = factors.solve(graph, eom.force.clone())?;
    let (zero, one) = (graph.constant(0.0), graph.constant(1.0));
    let seeds = |graph: &mut Graph, j: usize, d: Direction| {
        let mut seeds = Seeds::new();
        for i in 0..n {
            let (s, sd) = (graph.coord(n + j * n + i), graph.velocity(n + j * n + i));
            seeds = seeds.coord(i, s).velocity(i, sd);
        }
        if let Direction::Parameter(p) = d {
            seeds = seeds.param(p, one);
        }
        seeds
    };
    let mut forces;
    if let Some(c) = constraints {
        let accelerations = constrained_accelerations(graph, n, &factors, free, c)?;
        forces = accelerations.clone();
        for (j, &d) in directions.iter().enumerate() {
            let seeds = seeds(graph, j, d);
            let tangent = tangents(graph, &accelerations, &seeds)?;
            forces.extend(tangent.into_iter().map(|x| x.unwrap_or(zero)));
        }
        return kinetic_of(graph, n * (1 + directions.len()), forces);
    }
    let accelerations = free;
    let roots: Vec<usize> = eom.mass.iter().chain(&eom.force).copied().collect();
    forces = accelerations.clone();
    let along = Along {
        eom: &eom,
        factors: &factors,
        accelerations: &accelerations,
        roots: &roots,
        zero,
    };
    for (j, &d) in directions.iter().enumerate() {
        let seeds = seeds(graph, j, d);
        forces.extend(along.tangent(graph, &seeds)?);
    }
    kinetic_of(graph, n * (1 + directions.len()), forces)
}

/// The model of `size` coordinates with T = ½ |ẋ|² (M = 1) and the generalized forces `forces`.
fn kinetic_of(graph: &mut Graph, size: usize, forces: Vec<usize>) -> Result<Energies> {
    let zero = graph.constant(0.0);
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

/// The index-1 accelerations of Lagrange's equations of the first kind as nodes: `free` is
/// q̈₀ = M⁻¹ f (with M's `factors`), and q̈ = q̈₀ + A λ with A = M⁻¹ Gᵀ and
/// (G A) λ = −γ − G q̈₀, the k × k Schur complement G A factored on the graph too.
fn constrained_accelerations(
    graph: &mut Graph,
    n: usize,
    factors: &Factors,
    free: Vec<usize>,
    c: ConstraintNodes<'_>,
) -> Result<Vec<usize>> {
    let (g, gamma, _) = constraint_graph(graph, n, c.holonomic, c.velocity, c.moving)?;
    let k = gamma.len();
    let row = |r: usize| g[r * n..(r + 1) * n].to_vec();
    let a: Vec<Vec<usize>> = (0..k)
        .map(|r| factors.solve(graph, row(r)))
        .collect::<Result<_>>()?;
    let dot = |graph: &mut Graph, x: &[usize], y: &[usize]| -> Result<usize> {
        let mut s = Simplify(graph);
        let mut acc = None;
        for (&x, &y) in x.iter().zip(y) {
            let p = s.mul(x, y)?;
            acc = s.sum(acc, Some(p))?;
        }
        Ok(acc.unwrap_or_else(|| s.0.constant(0.0)))
    };
    let mut schur = vec![vec![0; k]; k];
    for r in 0..k {
        for q in r..k {
            let x = dot(graph, &g[r * n..(r + 1) * n], &a[q])?;
            schur[r][q] = x;
            schur[q][r] = x;
        }
    }
    let sf = Factors::of_matrix(graph, k, |i, j| schur[i][j])?;
    let mut rhs = Vec::with_capacity(k);
    for (r, &gr) in gamma.iter().enumerate() {
        let gq = dot(graph, &g[r * n..(r + 1) * n], &free)?;
        let mut s = Simplify(graph);
        let sum = s.add(gr, gq)?;
        rhs.push(s.neg(sum)?);
    }
    let lambda = sf.solve(graph, rhs)?;
    let mut out = free;
    for (i, o) in out.iter_mut().enumerate() {
        let mut s = Simplify(graph);
        let mut acc = Some(*o);
        for (ar, &l) in a.iter().zip(&lambda) {
            let p = s.mul(ar[i], l)?;
            acc = s.sum(acc, Some(p))?;
        }
        *o = acc.unwrap_or(*o);
    }
    Ok(out)
}

/// What the initial sensitivities of a constrained model are projected with, as nodes (outputs
/// of one tape over the model's (t, q, q̇)): M's upper triangle; G_h = ∂g/∂q of the holonomic
/// rows (row-major); V_q = ∂v/∂q and V_v = ∂v/∂q̇ of the rows at the velocity level v (ġ, then
/// the velocity rows); then per direction ∂g/∂p and ∂v/∂p (zero for an initial state).
///
/// # Errors
/// As [`eom_graph`] and [`tangents`].
pub fn projection_outputs(
    graph: &mut Graph,
    dof: usize,
    parts: &Energies,
    c: ConstraintNodes<'_>,
    directions: &[Direction],
) -> Result<Vec<usize>> {
    let n = dof;
    let eom = eom_graph(graph, n, parts)?;
    let (_, _, level1) = constraint_graph(graph, n, c.holonomic, c.velocity, c.moving)?;
    let (zero, one) = (graph.constant(0.0), graph.constant(1.0));
    let mut out = eom.mass.clone();
    let by_column = |graph: &mut Graph, roots: &[usize], velocity: bool| -> Result<Vec<usize>> {
        let mut m = vec![zero; roots.len() * n];
        for j in 0..n {
            let seeds = if velocity {
                Seeds::new().velocity(j, one)
            } else {
                Seeds::new().coord(j, one)
            };
            for (r, d) in tangents(graph, roots, &seeds)?.into_iter().enumerate() {
                m[r * n + j] = d.unwrap_or(zero);
            }
        }
        Ok(m)
    };
    out.extend(by_column(graph, c.holonomic, false)?);
    out.extend(by_column(graph, &level1, false)?);
    out.extend(by_column(graph, &level1, true)?);
    for d in directions {
        let along = match *d {
            Direction::Parameter(p) => Some(Seeds::new().param(p, one)),
            Direction::Position(_) | Direction::Velocity(_) => None,
        };
        for roots in [c.holonomic, &level1[..]] {
            match &along {
                Some(seeds) => out.extend(
                    tangents(graph, roots, seeds)?
                        .into_iter()
                        .map(|x| x.unwrap_or(zero)),
                ),
                None => out.extend(std::iter::repeat_n(zero, roots.len())),
            }
        }
    }
    Ok(out)
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
