//! Eq. 55 as one compiled program: the entries of M and the force vector f derived on the
//! expression graph ([`derive`](crate::expr::derive)) and compiled into one [`Tape`], so that the
//! accelerations at an `f64` state are one plain-`f64` run of that tape and an LDLᵀ solve — no
//! dual numbers, no pass of T per direction.
//!
//! With L = T − U,
//! M_ij = ∂²T/∂q̇ᵢ∂q̇ⱼ and fᵢ = Q″ᵢ + ∂L/∂qᵢ − (∂²L/∂q̇ᵢ∂q) q̇ − ∂²L/∂q̇ᵢ∂t − ∂Φ/∂q̇ᵢ,
//! where ∂T/∂q̇, ∂L/∂q and ∂Φ/∂q̇ are one reverse sweep each ([`gradient`](crate::expr::derive::gradient)), M's
//! columns one tangent sweep each, and the two mixed terms one tangent sweep of pᵢ = ∂T/∂q̇ᵢ along (q, t) ↦ (q̇, 1). Only
//! what the model has is built: no Φ, no Q″, no t — nothing for them. The tape's outputs are M's
//! upper triangle row by row, then f; the tape is what a native-code backend compiles, with the
//! constants of [`EomFunction::constants`].

use crate::checks::check_lengths;
use crate::dynamics::DerivedProgram;
use crate::error::{Error, Result};
use crate::expr::derive::{
    POSITION, Seeds, Simplify, TIME, VELOCITY, Wrt, gradient, reads, tangents,
};
use crate::expr::graph::Graph;
#[cfg(feature = "jit")]
use crate::linalg::pivots_hold;
use crate::linalg::{FactorFailure, ldlt_in_place};
use crate::program::compile::{Input, Tape};
use crate::program::eval::Function;
use crate::program::inputs::Inputs;
use crate::program::jet::Num;
use crate::scalar::{Scalar, with_buf};
use crate::taylor::TaylorProgram;
use std::sync::Arc;

/// The energies of a model as nodes of one [`Graph`]: T, and optionally U, Rayleigh's Φ and Q″
/// (one node per coordinate).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Energies {
    /// The kinetic energy T(t, q, q̇).
    pub kinetic: usize,
    /// The potential U(t, q).
    pub potential: Option<usize>,
    /// Rayleigh's dissipation function Φ(t, q, q̇).
    pub dissipation: Option<usize>,
    /// The generalized forces Q″(t, q, q̇), one per coordinate.
    pub forces: Option<Vec<usize>>,
}

/// The kinetic energy of particles as a node: T = ½ Σⱼ mⱼ |ṙⱼ|² (seed eq. 22–25), with ṙⱼ the
/// tangent of the positions rⱼ(t, q) along (t, q) ↦ (1, q̇), so that a model stated by its
/// particles gets eq. 55 derived and compiled like one stated by its energies. `positions`
/// holds `dim` nodes per particle, `masses` one node per particle.
///
/// # Errors
/// [`Error::InvalidInput`] when the counts do not match or a node is not in `graph`.
pub fn particle_kinetic(
    graph: &mut Graph,
    dof: usize,
    positions: &[usize],
    masses: &[usize],
    dim: usize,
) -> Result<usize> {
    if masses.is_empty() || positions.len() != dim * masses.len() {
        return Err(Error::InvalidInput {
            what: "particles",
            why: format!(
                "{} position components for {} masses",
                positions.len(),
                masses.len()
            ),
        });
    }
    let one = graph.constant(1.0);
    let mut seeds = Seeds::new().time(one);
    for i in 0..dof {
        let v = graph.velocity(i);
        seeds = seeds.coord(i, v);
    }
    let velocities = tangents(graph, positions, &seeds)?;
    let half = graph.constant(0.5);
    let mut s = Simplify(graph);
    let mut kinetic = None;
    for (&m, v) in masses.iter().zip(velocities.chunks_exact(dim)) {
        let mut speed2 = None;
        for &vk in v.iter().flatten() {
            let v2 = s.mul(vk, vk)?;
            speed2 = Some(match speed2 {
                Some(sum) => s.add(sum, v2)?,
                None => v2,
            });
        }
        if let Some(speed2) = speed2 {
            let hm = s.mul(half, m)?;
            let term = s.mul(hm, speed2)?;
            kinetic = Some(match kinetic {
                Some(sum) => s.add(sum, term)?,
                None => term,
            });
        }
    }
    Ok(kinetic.unwrap_or_else(|| s.0.constant(0.0)))
}

/// The pieces of eq. 55 as nodes of the graph they were derived in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EomGraph {
    /// Number of coordinates.
    pub dof: usize,
    /// M's upper triangle row by row: (0,0), (0,1), …, (0,n−1), (1,1), …
    pub mass: Vec<usize>,
    /// f, one node per coordinate.
    pub force: Vec<usize>,
    /// G = Q″ + ∂L/∂q − ∂Φ/∂q̇, the force of the (q, p) form ṗ = G that the implicit symplectic
    /// methods integrate (f without the mixed terms, which they take from p itself).
    pub qp_force: Vec<usize>,
    /// The momenta p = ∂L/∂q̇ = ∂T/∂q̇ (not compiled into the accelerations' tape; for a tape of
    /// their own).
    pub momenta: Vec<usize>,
    /// The energy function h = q̇·p − L (likewise).
    pub energy: usize,
    /// Whether every entry of M is free of t, q and q̇ (then M is computed and factored once).
    pub constant_mass: bool,
    /// Whether some entry of M or f reads t.
    pub time: bool,
}

/// Index of M_ij (i ≤ j) in the upper triangle stored row by row.
pub(crate) fn upper(n: usize, i: usize, j: usize) -> usize {
    i * n - i * (i + 1) / 2 + j
}

/// Derive M and f of eq. 55 from `parts` as nodes of `graph` (see the module docs).
///
/// # Errors
/// [`Error::InvalidInput`] when `dof` is zero, a part is not a node of the graph, the forces are
/// not one per coordinate, or the potential reads velocities.
pub fn eom_graph(graph: &mut Graph, dof: usize, parts: &Energies) -> Result<EomGraph> {
    let bad = |why: String| Err(Error::InvalidInput { what: "model", why });
    if dof == 0 {
        return bad("a model needs at least one coordinate".into());
    }
    let mut all = vec![parts.kinetic];
    all.extend(parts.potential);
    all.extend(parts.dissipation);
    if let Some(q) = &parts.forces {
        if q.len() != dof {
            return bad(format!(
                "the generalized forces have {} outputs, expected {dof}",
                q.len()
            ));
        }
        all.extend(q);
    }
    if let Some(&o) = all.iter().find(|&&o| o >= graph.len()) {
        return bad(format!("node {o} is not a node of the graph"));
    }
    if let Some(u) = parts.potential
        && reads(graph)[u] & VELOCITY != 0
    {
        return bad("the potential may not depend on the velocities".into());
    }
    let one = graph.constant(1.0);
    let t = parts.kinetic;
    // p = ∂T/∂q̇, one reverse sweep.
    let p = gradient(graph, t, Wrt::Velocity, dof)?;
    // M by columns: column j is one sweep ∂/∂q̇_j of p_0 … p_j.
    let zero = graph.constant(0.0);
    let mut mass = vec![zero; dof * (dof + 1) / 2];
    for j in 0..dof {
        let roots: Vec<usize> = p[..=j].iter().map(|d| d.unwrap_or(zero)).collect();
        let col = tangents(graph, &roots, &Seeds::new().velocity(j, one))?;
        for (i, m) in col.into_iter().enumerate() {
            mass[upper(dof, i, j)] = m.unwrap_or(zero);
        }
    }
    // (∂²T/∂q̇∂q) q̇ + ∂²T/∂q̇∂t: one sweep of p along (q, t) ↦ (q̇, 1).
    let mut motion = Seeds::new();
    if reads(graph)[t] & TIME != 0 {
        motion = motion.time(one);
    }
    for j in 0..dof {
        let v = graph.velocity(j);
        motion = motion.coord(j, v);
    }
    let roots: Vec<usize> = p.iter().map(|d| d.unwrap_or(zero)).collect();
    let mixed = tangents(graph, &roots, &motion)?;
    // ∂L/∂q_i, L = T − U.
    let lagrangian = match parts.potential {
        Some(u) => Simplify(graph).sub(t, u)?,
        None => t,
    };
    let dl = gradient(graph, lagrangian, Wrt::Position, dof)?;
    let dphi = match parts.dissipation {
        Some(phi) => gradient(graph, phi, Wrt::Velocity, dof)?,
        None => vec![None; dof],
    };
    let (mut force, mut qp_force) = (Vec::with_capacity(dof), Vec::with_capacity(dof));
    for i in 0..dof {
        let (dl, dphi) = (dl[i], dphi[i]);
        let q = parts.forces.as_ref().map(|q| q[i]);
        let mut s = Simplify(graph);
        let g = s.sum(q, dl)?;
        let g = s.diff(g, dphi)?;
        let f = s.diff(g, mixed[i])?;
        qp_force.push(g.unwrap_or(zero));
        force.push(f.unwrap_or(zero));
    }
    let momenta: Vec<usize> = p.iter().map(|d| d.unwrap_or(zero)).collect();
    let mut s = Simplify(graph);
    let mut qp = None;
    for (i, &pi) in momenta.iter().enumerate() {
        let v = s.0.velocity(i);
        let term = s.mul(v, pi)?;
        qp = s.sum(qp, Some(term))?;
    }
    let energy = s.diff(qp, Some(lagrangian))?.unwrap_or(zero);
    let r = reads(graph);
    let constant_mass = mass
        .iter()
        .all(|&m| r[m] & (TIME | POSITION | VELOCITY) == 0);
    let time = mass.iter().chain(&force).any(|&x| r[x] & TIME != 0);
    Ok(EomGraph {
        dof,
        mass,
        force,
        qp_force,
        momenta,
        energy,
        constant_mass,
        time,
    })
}

/// Largest number of coordinates whose solve M q̈ = f is unrolled into machine code
/// ([`solved_graph`]); larger systems factor M at run time. Measured on the pendulum chain
/// (tests/integration/graph_derivatives.rs, `eom_program_speed`): unrolled, one call costs 0.55× (n = 8)
/// and 0.51× (n = 16) of the program plus the run-time LDLᵀ of the time; at n = 32 0.94×
/// (7.3 against 7.8 µs: a tape that large gets Cranelift's single-pass register allocator),
/// while the build grows from 76 to 105 ms.
#[cfg(feature = "jit")]
const SOLVED_MAX: usize = 16;

/// The Jacobians of the implicit methods ([`jacobian_graph`], [`columns`]) are compiled only
/// for small systems whose Jacobian tapes have at most [`JACOBIAN_INSTRUCTIONS_MAX`]
/// instructions: Cranelift's time grows faster than the tapes (measured on the pendulum chain,
/// both Jacobians: n = 2 1.0 ms, n = 4 11 ms, n = 8 80 ms, n = 16 270 ms), while a Jacobian
/// from dual numbers over the derived program saves little more than that over a run of a
/// thousand Jacobians (double pendulum: 680 ns on dual numbers, 93–146 ns compiled; n = 16:
/// 245 and 16 µs). Larger systems take their Jacobians from dual numbers.
#[cfg(feature = "jit")]
const JACOBIAN_DOF_MAX: usize = 8;

/// See [`JACOBIAN_DOF_MAX`]: about 4 ms of compilation at most.
#[cfg(feature = "jit")]
const JACOBIAN_INSTRUCTIONS_MAX: usize = 600;

/// The LDLᵀ factors of M written out on the graph, node by node as [`ldlt_in_place`] computes
/// them: L below the diagonal, the pivots d and their reciprocals.
pub(crate) struct Factors {
    l: Vec<Vec<usize>>,
    #[cfg_attr(not(feature = "jit"), allow(dead_code))]
    d: Vec<usize>,
    inv: Vec<usize>,
}

impl Factors {
    pub(crate) fn of(graph: &mut Graph, eom: &EomGraph) -> Result<Self> {
        let n = eom.dof;
        Self::of_matrix(graph, n, |i, j| eom.mass[upper(n, i.min(j), i.max(j))])
    }

    /// The factors of the symmetric n × n matrix whose entry (i, j) is the node `m(i, j)`.
    pub(crate) fn of_matrix(
        graph: &mut Graph,
        n: usize,
        m: impl Fn(usize, usize) -> usize,
    ) -> Result<Self> {
        let one = graph.constant(1.0);
        let mut s = Simplify(graph);
        // l[i][j] = L_ij and w[i][j] = L_ij d_j below the diagonal; d and 1/d on it.
        let (mut l, mut w) = (vec![vec![one; n]; n], vec![vec![one; n]; n]);
        let (mut d, mut inv) = (vec![one; n], vec![one; n]);
        for j in 0..n {
            let mut dj = m(j, j);
            for k in 0..j {
                let p = s.mul(l[j][k], w[j][k])?;
                dj = s.sub(dj, p)?;
            }
            d[j] = dj;
            inv[j] = s.div(one, dj)?;
            for i in j + 1..n {
                let mut wij = m(i, j);
                for k in 0..j {
                    let p = s.mul(l[i][k], w[j][k])?;
                    wij = s.sub(wij, p)?;
                }
                w[i][j] = wij;
                l[i][j] = s.mul(wij, inv[j])?;
            }
        }
        Ok(Self { l, d, inv })
    }

    /// M⁻¹ b: L y = b, then D z = y, then Lᵀ x = z.
    pub(crate) fn solve(&self, graph: &mut Graph, mut x: Vec<usize>) -> Result<Vec<usize>> {
        let (n, l) = (x.len(), &self.l);
        let mut s = Simplify(graph);
        for i in 0..n {
            for k in 0..i {
                let p = s.mul(l[i][k], x[k])?;
                x[i] = s.sub(x[i], p)?;
            }
        }
        for i in 0..n {
            x[i] = s.mul(x[i], self.inv[i])?;
        }
        for i in (0..n).rev() {
            for k in i + 1..n {
                let p = s.mul(l[k][i], x[k])?;
                x[i] = s.sub(x[i], p)?;
            }
        }
        Ok(x)
    }

    /// The pivots, then M's diagonal: the outputs [`pivots_hold`] checks.
    #[cfg(feature = "jit")]
    fn checks(&self, eom: &EomGraph) -> impl Iterator<Item = usize> {
        let n = eom.dof;
        let diagonal = (0..n).map(move |j| eom.mass[upper(n, j, j)]);
        self.d.clone().into_iter().chain(diagonal)
    }
}

/// What the derivative of q̈ = M⁻¹ f along a direction is taken from: eq. 55's M and f
/// (`roots`: M's upper triangle, then f), M's factors on the graph, q̈ itself and the node 0.
/// One place for the Jacobian of the implicit methods ([`jacobian_graph`]) and the
/// variational equations (`derived::variational`).
pub(crate) struct Along<'a> {
    pub(crate) eom: &'a EomGraph,
    pub(crate) factors: &'a Factors,
    pub(crate) accelerations: &'a [usize],
    pub(crate) roots: &'a [usize],
    pub(crate) zero: usize,
}

impl Along<'_> {
    /// ∂q̈ along `seeds`: M ∂q̈ = ∂f − (∂M) q̈, from one tangent sweep of M's entries and f,
    /// solved with the factors (which are not themselves differentiated).
    pub(crate) fn tangent(&self, graph: &mut Graph, seeds: &Seeds) -> Result<Vec<usize>> {
        let n = self.eom.dof;
        let d = tangents(graph, self.roots, seeds)?;
        let (dm, df) = d.split_at(self.eom.mass.len());
        let mut s = Simplify(graph);
        let mut rhs = Vec::with_capacity(n);
        for i in 0..n {
            let mut r = df[i];
            for (k, &a) in self.accelerations.iter().enumerate() {
                if let Some(dmik) = dm[upper(n, i.min(k), i.max(k))] {
                    let p = s.mul(dmik, a)?;
                    r = s.diff(r, Some(p))?;
                }
            }
            rhs.push(r.unwrap_or(self.zero));
        }
        self.factors.solve(graph, rhs)
    }
}

/// q̈ = M⁻¹ f of a small system written out on the graph: the LDLᵀ factorization of
/// [`ldlt_in_place`] node by node, then the two triangular solves, so that the accelerations are
/// one call of machine code. Outputs q̈, the pivots d_j and M's diagonal; the caller checks the
/// pivots as the factorization does ([`pivots_hold`](crate::linalg::pivots_hold)) and takes the
/// general path, with its typed errors, when a check fails. A constant M folds to constants,
/// and its pivots are checked once, when the program is bound, so then only q̈ is output.
#[cfg(feature = "jit")]
fn solved_graph(graph: &mut Graph, eom: &EomGraph) -> Result<Vec<usize>> {
    let factors = Factors::of(graph, eom)?;
    let accelerations = factors.solve(graph, eom.force.clone())?;
    let checks = (!eom.constant_mass).then(|| factors.checks(eom));
    Ok(accelerations
        .into_iter()
        .chain(checks.into_iter().flatten())
        .collect())
}

/// The seeds of the state coordinate x_j of x = (q, q̇).
#[cfg(feature = "jit")]
fn state_seed(graph: &mut Graph, n: usize, j: usize) -> Seeds {
    let one = graph.constant(1.0);
    if j < n {
        Seeds::new().coord(j, one)
    } else {
        Seeds::new().velocity(j - n, one)
    }
}

/// ∂q̈/∂(q, q̇) of a small system on the graph, for Radau IIA's Newton iteration and
/// `model.jacobian`. Along a state coordinate x_j, M q̈ = f gives
/// M ∂q̈/∂x_j = ∂f/∂x_j − (∂M/∂x_j) q̈: one tangent sweep of M and f per coordinate, solved with
/// the factors of the unrolled solve (which are not themselves differentiated). Outputs the
/// n × 2n Jacobian column by column (nalgebra's order), then q̈, the pivots and M's diagonal,
/// checked as for q̈ alone, so that the Jacobian is given exactly where q̈ is.
#[cfg(feature = "jit")]
fn jacobian_graph(graph: &mut Graph, eom: &EomGraph) -> Result<Vec<usize>> {
    let n = eom.dof;
    let factors = Factors::of(graph, eom)?;
    let accelerations = factors.solve(graph, eom.force.clone())?;
    let roots: Vec<usize> = eom.mass.iter().chain(&eom.force).copied().collect();
    let zero = graph.constant(0.0);
    let mut outputs = Vec::with_capacity(2 * n * n + 3 * n);
    let along = Along {
        eom,
        factors: &factors,
        accelerations: &accelerations,
        roots: &roots,
        zero,
    };
    for j in 0..2 * n {
        let seeds = state_seed(graph, n, j);
        outputs.extend(along.tangent(graph, &seeds)?);
    }
    outputs.extend(accelerations);
    outputs.extend(factors.checks(eom));
    Ok(outputs)
}

/// The Jacobian of `roots` with respect to x = (q, q̇), column by column (nalgebra's order): one
/// tangent sweep per state coordinate.
#[cfg(feature = "jit")]
fn columns(graph: &mut Graph, n: usize, roots: &[usize]) -> Result<Vec<usize>> {
    let zero = graph.constant(0.0);
    let mut outputs = Vec::with_capacity(2 * n * roots.len());
    for j in 0..2 * n {
        let seeds = state_seed(graph, n, j);
        let d = tangents(graph, roots, &seeds)?;
        outputs.extend(d.into_iter().map(|x| x.unwrap_or(zero)));
    }
    Ok(outputs)
}

/// A tape and its machine code, where Cranelift compiled it (feature `jit`; otherwise the
/// interpreter runs the tape, with the same results bit for bit).
#[derive(Debug, Clone)]
struct Part {
    tape: Arc<Tape>,
    #[cfg(feature = "jit")]
    native: Option<Arc<crate::native::tape::NativeTape>>,
}

impl Part {
    fn new(
        graph: &Graph,
        outputs: &[usize],
        dof: usize,
        params: usize,
        what: &str,
    ) -> Result<Self> {
        let tape = Tape::new(graph, outputs, Inputs::kinetic(dof, params), what)?;
        Ok(Self::of(tape))
    }

    fn of(tape: Tape) -> Self {
        Self {
            // Any failure of Cranelift leaves the interpreter.
            #[cfg(feature = "jit")]
            native: crate::native::tape::NativeTape::compile(&tape)
                .ok()
                .map(Arc::new),
            tape: tape.into(),
        }
    }

    /// The part only where it compiled to machine code.
    #[cfg(feature = "jit")]
    fn native_only(self) -> Option<Self> {
        self.native.is_some().then_some(self)
    }

    fn interpreted(self) -> Self {
        Self {
            #[cfg(feature = "jit")]
            native: None,
            ..self
        }
    }

    fn bind(&self, params: &[f64]) -> Result<BoundPart> {
        Ok(BoundPart {
            function: Function::new(self.tape.clone(), params)?,
            #[cfg(feature = "jit")]
            native: self.native.clone(),
        })
    }
}

/// A [`Part`] bound to parameter values.
#[derive(Debug, Clone)]
struct BoundPart {
    function: Function,
    #[cfg(feature = "jit")]
    native: Option<Arc<crate::native::tape::NativeTape>>,
}

impl BoundPart {
    /// The outputs at (t, q, q̇) into `out`.
    #[inline]
    fn eval(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) {
        #[cfg(feature = "jit")]
        if let Some(native) = &self.native {
            return native.eval(&self.function.consts, t, q, qd, out);
        }
        self.function.eval_into(t, q, qd, out)
    }
}

/// Eq. 55 compiled: one [`Tape`] whose outputs are M's upper triangle row by row, then f (see
/// [`EomGraph`]), not yet bound to parameter values; for up to 16 coordinates with machine
/// code, also q̈ itself with the solve unrolled and the Jacobians the implicit methods need.
#[derive(Debug, Clone)]
pub struct EomProgram {
    tape: Arc<Tape>,
    dof: usize,
    constant_mass: bool,
    /// The tape as machine code (feature `jit`); `None` where it could not be compiled, and
    /// then the interpreter runs it (same results, bit for bit).
    #[cfg(feature = "jit")]
    native: Option<Arc<crate::native::tape::NativeTape>>,
    /// The momenta p = ∂L/∂q̇.
    momenta: Part,
    /// The energy function h = q̇·p − L, which `simulate` reports at every output step.
    energy: Part,
    /// p, then G: the (q, p) form of the implicit symplectic methods.
    qp_form: Part,
    /// M and f as series recurrences: the Taylor method's expansions.
    taylor: Arc<TaylorProgram>,
    /// ∂(p, G)/∂(q, q̇), column by column (small systems, see [`JACOBIAN_DOF_MAX`]).
    #[cfg(feature = "jit")]
    qp_jacobian: Option<Part>,
    /// q̈ with the solve unrolled, as machine code (up to [`SOLVED_MAX`] coordinates).
    #[cfg(feature = "jit")]
    solved: Option<Part>,
    /// ∂q̈/∂(q, q̇) with the solves unrolled, as machine code ([`jacobian_graph`]; small
    /// systems, see [`JACOBIAN_DOF_MAX`]).
    #[cfg(feature = "jit")]
    jacobian: Option<Part>,
}

impl EomProgram {
    /// Derive eq. 55 from `parts` (adding the derivatives' nodes to `graph`) and compile it for
    /// `dof` coordinates and `params` parameters.
    ///
    /// # Errors
    /// As [`eom_graph`] and [`Tape::new`].
    pub fn new(graph: &mut Graph, dof: usize, params: usize, parts: &Energies) -> Result<Self> {
        let eom = eom_graph(graph, dof, parts)?;
        #[cfg_attr(not(feature = "jit"), allow(unused_mut))]
        let mut program = Self::compile(graph, &eom, params)?;
        #[cfg(feature = "jit")]
        if program.native.is_some() && dof <= SOLVED_MAX {
            let outputs = solved_graph(graph, &eom)?;
            program.solved =
                Part::new(graph, &outputs, dof, params, "equations of motion")?.native_only();
            if dof <= JACOBIAN_DOF_MAX {
                let small = |graph: &Graph, outputs: &[usize], what: &str| -> Result<_> {
                    let tape = Tape::new(graph, outputs, Inputs::kinetic(dof, params), what)?;
                    let small = tape.instructions() <= JACOBIAN_INSTRUCTIONS_MAX;
                    Ok(small.then(|| Part::of(tape)).and_then(Part::native_only))
                };
                let outputs = jacobian_graph(graph, &eom)?;
                program.jacobian = small(graph, &outputs, "Jacobian of the accelerations")?;
                let roots: Vec<usize> = eom.momenta.iter().chain(&eom.qp_force).copied().collect();
                let outputs = columns(graph, dof, &roots)?;
                program.qp_jacobian = small(graph, &outputs, "Jacobian of the (q, p) form")?;
            }
        }
        Ok(program)
    }

    /// Compile derived pieces `eom` of `graph` for `params` parameters.
    ///
    /// # Errors
    /// As [`Tape::new`].
    pub fn compile(graph: &Graph, eom: &EomGraph, params: usize) -> Result<Self> {
        let outputs: Vec<usize> = eom.mass.iter().chain(&eom.force).copied().collect();
        let main = Part::new(graph, &outputs, eom.dof, params, "equations of motion")?;
        let momenta = Part::new(graph, &eom.momenta, eom.dof, params, "momenta")?;
        let energy = Part::new(graph, &[eom.energy], eom.dof, params, "energy")?;
        let qp: Vec<usize> = eom.momenta.iter().chain(&eom.qp_force).copied().collect();
        let qp_form = Part::new(graph, &qp, eom.dof, params, "the (q, p) form")?;
        Ok(Self {
            tape: main.tape,
            #[cfg(feature = "jit")]
            native: main.native,
            dof: eom.dof,
            constant_mass: eom.constant_mass,
            momenta,
            energy,
            qp_form,
            taylor: Arc::new(TaylorProgram::new(graph, eom.dof, &eom.mass, &eom.force)),
            #[cfg(feature = "jit")]
            qp_jacobian: None,
            #[cfg(feature = "jit")]
            solved: None,
            #[cfg(feature = "jit")]
            jacobian: None,
        })
    }

    /// The same program, its Taylor expansions compiled unrolled from their first run where
    /// they are small ([`TaylorProgram::unroll_small_early`]): for a model run again and again.
    pub fn unroll_small_early(mut self) -> Self {
        if let Some(taylor) = Arc::get_mut(&mut self.taylor) {
            taylor.unroll_small_early();
        }
        self
    }

    /// The same program run by the interpreter: the reference the native code is tested
    /// against (without the `jit` feature, the program itself). The Jacobians stay the derived
    /// ones, interpreted: they differ from dual numbers over the program where a function is not
    /// differentiable (|x| and sign at 0, atan2 at the origin), where the derived ones take the
    /// symbolic rule.
    pub fn interpreted(self) -> Self {
        Self {
            momenta: self.momenta.interpreted(),
            energy: self.energy.interpreted(),
            qp_form: self.qp_form.interpreted(),
            taylor: Arc::new(self.taylor.interpreted()),
            #[cfg(feature = "jit")]
            native: None,
            #[cfg(feature = "jit")]
            qp_jacobian: self.qp_jacobian.map(Part::interpreted),
            #[cfg(feature = "jit")]
            solved: None,
            #[cfg(feature = "jit")]
            jacobian: self.jacobian.map(Part::interpreted),
            ..self
        }
    }

    /// What runs the tape: `"native"` (machine code from Cranelift, feature `jit`) or
    /// `"interpreter"`.
    pub fn backend(&self) -> &'static str {
        #[cfg(feature = "jit")]
        if self.native.is_some() {
            return "native";
        }
        "interpreter"
    }

    /// The compiled tape: outputs M's upper triangle row by row, then f.
    pub fn tape(&self) -> &Arc<Tape> {
        &self.tape
    }

    /// The size of the program of M and f, in instructions: what one evaluation costs.
    pub fn instructions(&self) -> usize {
        self.tape.instructions()
    }

    /// Number of coordinates.
    pub fn dof(&self) -> usize {
        self.dof
    }

    /// Whether M is free of t, q and q̇ (computed and factored once per parameter set).
    pub fn constant_mass_matrix(&self) -> bool {
        self.constant_mass
    }

    /// Bind to parameter values.
    ///
    /// # Errors
    /// As [`Function::new`].
    pub fn bind(&self, params: &[f64]) -> Result<EomFunction> {
        let function = Function::new(self.tape.clone(), params)?;
        let n = self.dof;
        let mass_factor = self.constant_mass.then(|| {
            // Every entry of M is an output read from the constants.
            let mut m = vec![0.0; n * n];
            let zeros = vec![0.0; n];
            let mut out = vec![0.0; self.tape.outputs()];
            function.eval_into(0.0, &zeros, &zeros, &mut out);
            for i in 0..n {
                for j in i..n {
                    m[j * n + i] = out[upper(n, i, j)];
                }
            }
            ldlt_in_place(&mut m, n).map(|()| m.into())
        });
        // A constant singular M folds a pivot's reciprocal to a non-finite constant, which
        // does not bind (and the unrolled solve of a constant M, which checks no pivots, is
        // bound only where M factors): then the general path reports it, at the first
        // evaluation.
        #[cfg(feature = "jit")]
        let unrolled = |part: &Option<Part>| part.as_ref().and_then(|p| p.bind(params).ok());
        #[cfg(feature = "jit")]
        let factored = !matches!(mass_factor, Some(Err(_)));
        Ok(EomFunction {
            program: self.clone(),
            params: params.into(),
            function,
            momenta: self.momenta.bind(params)?,
            energy: self.energy.bind(params)?,
            qp_form: self.qp_form.bind(params)?,
            mass_factor,
            #[cfg(feature = "jit")]
            qp_jacobian: unrolled(&self.qp_jacobian),
            #[cfg(feature = "jit")]
            solved: unrolled(&self.solved).filter(|_| factored),
            #[cfg(feature = "jit")]
            jacobian: unrolled(&self.jacobian),
        })
    }
}

/// An [`EomProgram`] bound to parameter values: the accelerations at `f64` states.
#[derive(Debug, Clone)]
pub struct EomFunction {
    program: EomProgram,
    /// The parameter values it is bound to.
    params: Arc<[f64]>,
    function: Function,
    momenta: BoundPart,
    energy: BoundPart,
    qp_form: BoundPart,
    /// The LDLᵀ factor of a constant M (or why it has none).
    mass_factor: Option<std::result::Result<Arc<[f64]>, FactorFailure>>,
    #[cfg(feature = "jit")]
    qp_jacobian: Option<BoundPart>,
    /// The unrolled solve for these parameter values.
    #[cfg(feature = "jit")]
    solved: Option<BoundPart>,
    #[cfg(feature = "jit")]
    jacobian: Option<BoundPart>,
}

impl EomFunction {
    /// The program.
    pub fn program(&self) -> &EomProgram {
        &self.program
    }

    /// The series recurrences of M and f and the parameter values: what the Taylor method
    /// expands.
    pub fn taylor(&self) -> (&Arc<TaylorProgram>, &[f64]) {
        (&self.program.taylor, &self.params)
    }

    /// About the instructions of one evaluation of the accelerations: those of the program
    /// with the solve unrolled, where it has one; else those of M and f and of the LDLᵀ
    /// factorization and solve (n³/3 + 2n², the solve alone when a constant M was factored
    /// once). `Method::Auto` weighs a Runge–Kutta step's cost with it.
    pub fn acceleration_instructions(&self) -> usize {
        #[cfg(feature = "jit")]
        if let Some(solved) = &self.solved {
            return solved.function.tape().instructions();
        }
        let n = self.program.dof;
        let factor = if self.mass_factor.is_some() {
            0
        } else {
            n * n * n / 3
        };
        self.program.tape.instructions() + factor + 2 * n * n
    }

    /// The tape's constants for these parameter values (what the tape reads besides t, q, q̇).
    pub fn constants(&self) -> &[f64] {
        &self.function.consts
    }

    /// The same program with other parameter values.
    ///
    /// # Errors
    /// As [`Function::new`].
    pub fn with_parameters(&self, params: &[f64]) -> Result<Self> {
        self.program.bind(params)
    }

    /// The momenta p = ∂L/∂q̇ at (t, q, q̇), written to `out`.
    ///
    /// # Panics
    /// If a slice has the wrong length.
    pub fn momenta(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) {
        let n = self.program.dof;
        assert!(
            q.len() == n && qd.len() == n && out.len() == n,
            "wrong lengths"
        );
        self.momenta.eval(t, q, qd, out)
    }

    /// The energy function h = q̇·p − L at (t, q, q̇) (T + U for a natural system), one run of
    /// its own tape.
    ///
    /// # Panics
    /// If a slice has the wrong length.
    pub fn energy(&self, t: f64, q: &[f64], qd: &[f64]) -> f64 {
        let n = self.program.dof;
        assert!(q.len() == n && qd.len() == n, "wrong state lengths");
        let mut h = [0.0];
        self.energy.eval(t, q, qd, &mut h);
        h[0]
    }

    /// The (q, p) form of the implicit symplectic methods at (t, q, q̇): p = ∂L/∂q̇ into `p` and
    /// G = Q″ + ∂L/∂q − ∂Φ/∂q̇ into `g` (what `dynamics`'s `ForceParts` computes from the parts).
    ///
    /// # Panics
    /// If a slice has the wrong length.
    pub fn qp_form(&self, t: f64, q: &[f64], qd: &[f64], p: &mut [f64], g: &mut [f64]) {
        let n = self.program.dof;
        assert!(q.len() == n && qd.len() == n, "wrong state lengths");
        assert!(p.len() == n && g.len() == n, "wrong output lengths");
        with_buf::<f64, 64, _>(2 * n, 0.0, |out| {
            self.qp_form.eval(t, q, qd, out);
            p.copy_from_slice(&out[..n]);
            g.copy_from_slice(&out[n..]);
        })
    }

    /// ∂(p, G)/∂(q, q̇) of the (q, p) form at (t, q, q̇) into `jac` (2n × 2n, column by column
    /// as nalgebra stores it), derived on the graph and compiled: `false`, and `jac` untouched,
    /// when the program has none (without the `jit` feature, and for systems whose Jacobians
    /// are too large to compile quickly, see `JACOBIAN_DOF_MAX`) — then differentiate
    /// [`qp_form`](Self::qp_form)'s parts on dual numbers.
    ///
    /// # Panics
    /// If a slice has the wrong length.
    #[cfg_attr(not(feature = "jit"), allow(unused_variables))]
    pub fn qp_jacobian(&self, t: f64, q: &[f64], qd: &[f64], jac: &mut [f64]) -> bool {
        let n = self.program.dof;
        assert!(q.len() == n && qd.len() == n, "wrong state lengths");
        assert!(jac.len() == 4 * n * n, "wrong output length");
        #[cfg(feature = "jit")]
        if let Some(part) = &self.qp_jacobian {
            part.eval(t, q, qd, jac);
            return true;
        }
        false
    }

    /// ∂q̈/∂(q, q̇) at (t, q, q̇) into `jac` (n × 2n, column by column as nalgebra stores it),
    /// derived on the graph and compiled with the solves unrolled: `false`, and `jac`
    /// untouched, when the program has none (as for [`qp_jacobian`](Self::qp_jacobian)) or a
    /// pivot or finiteness check fails — then differentiate
    /// [`accelerations_dual`](Self::accelerations_dual), which also says what failed.
    ///
    /// # Panics
    /// If a slice has the wrong length.
    #[cfg_attr(not(feature = "jit"), allow(unused_variables))]
    pub fn acceleration_jacobian(&self, t: f64, q: &[f64], qd: &[f64], jac: &mut [f64]) -> bool {
        let n = self.program.dof;
        assert!(q.len() == n && qd.len() == n, "wrong state lengths");
        assert!(jac.len() == 2 * n * n, "wrong output length");
        #[cfg(feature = "jit")]
        if let Some(part) = &self.jacobian {
            const MAX: usize = (2 * JACOBIAN_DOF_MAX + 3) * JACOBIAN_DOF_MAX;
            return with_buf::<f64, MAX, _>(jac.len() + 3 * n, 0.0, |v| {
                part.eval(t, q, qd, v);
                let (values, checks) = v.split_at(jac.len() + n);
                let (pivots, diagonal) = checks.split_at(n);
                let fine = pivots_hold(pivots, diagonal) && values.iter().all(|x| x.is_finite());
                let j = &values[..jac.len()];
                if fine {
                    jac.copy_from_slice(j);
                }
                fine
            });
        }
        false
    }

    /// M (full, row-major n × n) and f at (t, q, q̇).
    ///
    /// # Panics
    /// If a slice has the wrong length.
    pub fn mass_and_force(&self, t: f64, q: &[f64], qd: &[f64], m: &mut [f64], f: &mut [f64]) {
        let n = self.program.dof;
        assert!(q.len() == n && qd.len() == n, "wrong state lengths");
        assert!(m.len() == n * n && f.len() == n, "wrong output lengths");
        self.run(
            t,
            q,
            qd,
            |i, j, x| {
                m[i * n + j] = x;
                m[j * n + i] = x;
            },
            f,
        );
    }

    /// Run the tape: M_ij (i ≤ j) to `mass`, f to `f`.
    #[inline(always)]
    fn run(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        mut mass: impl FnMut(usize, usize, f64),
        f: &mut [f64],
    ) {
        let n = self.program.dof;
        let nm = n * (n + 1) / 2;
        // Row and column of each upper-triangle output, in order.
        let (mut i, mut j) = (0, 0);
        let mut emit = |k: usize, v: f64| {
            if k < nm {
                mass(i, j, v);
                j += 1;
                if j == n {
                    i += 1;
                    j = i;
                }
            } else {
                f[k - nm] = v;
            }
        };
        #[cfg(feature = "jit")]
        if let Some(native) = &self.program.native {
            return with_buf::<f64, 64, _>(self.program.tape.outputs(), 0.0, |out| {
                native.eval(&self.function.consts, t, q, qd, out);
                for (k, &v) in out.iter().enumerate() {
                    emit(k, v);
                }
            });
        }
        let input = |x: Input| {
            Num(match x {
                Input::Time => t,
                Input::Coord(k) => q[k],
                Input::Velocity(k) => qd[k],
            })
        };
        self.function
            .tape
            .run(&self.function.consts, input, |k, v: Num<f64>| emit(k, v.0));
    }

    /// The accelerations at a state of any scalar type (the dual numbers of the integrators'
    /// Jacobians and of linearization): the same program run by the interpreter over `D`, so
    /// its derivatives are those of the derived M and f — one run per dual evaluation instead of
    /// the hyper-dual derivative passes of T.
    ///
    /// # Errors
    /// As [`accelerations`](Self::accelerations).
    pub fn accelerations_dual<D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) -> Result<()> {
        let n = self.program.dof;
        check_lengths(n, q, qd, out)?;
        let nm = n * (n + 1) / 2;
        let input = |x: Input| {
            Num(match x {
                Input::Time => t,
                Input::Coord(k) => q[k],
                Input::Velocity(k) => qd[k],
            })
        };
        with_buf::<D, 64, _>(n * n, D::zero(), |m| {
            let (mut i, mut j) = (0, 0);
            self.function
                .tape
                .run(&self.function.consts, input, |k, v: Num<D>| {
                    if k < nm {
                        // The factorization reads the lower triangle.
                        m[j * n + i] = v.0;
                        j += 1;
                        if j == n {
                            i += 1;
                            j = i;
                        }
                    } else {
                        out[k - nm] = v.0;
                    }
                });
            match &self.mass_factor {
                Some(factor) => {
                    let factor = factor
                        .as_ref()
                        .map_err(|&f| crate::linalg::singular_mass(f, t, q))?;
                    crate::linalg::solve_mass(&factor[..], n, t, out)
                }
                None => {
                    crate::linalg::factor_mass(m, n, t, q)?;
                    crate::linalg::solve_mass(&*m, n, t, out)
                }
            }
        })
    }

    /// The accelerations q̈ = M⁻¹ f at (t, q, q̇), written to `out`.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] for slices of the wrong length,
    /// [`Error::SingularMassMatrix`] when M cannot be factored, [`Error::NonFinite`] when the
    /// accelerations are not finite — as the energy route.
    pub fn accelerations(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) -> Result<()> {
        let n = self.program.dof;
        check_lengths(n, q, qd, out)?;
        #[cfg(feature = "jit")]
        if let Some(solved) = &self.solved
            && self.program.constant_mass
        {
            // Only q̈: M's pivots were checked when the program was bound.
            solved.eval(t, q, qd, out);
            if out.iter().all(|x| x.is_finite()) {
                return Ok(());
            }
        } else if let Some(solved) = &self.solved {
            let done = with_buf::<f64, { 3 * SOLVED_MAX }, _>(3 * n, 0.0, |v| {
                solved.eval(t, q, qd, v);
                let (a, rest) = v.split_at(n);
                let (pivots, diagonal) = rest.split_at(n);
                let fine = pivots_hold(pivots, diagonal) && a.iter().all(|x| x.is_finite());
                if fine {
                    out.copy_from_slice(a);
                }
                fine
            });
            if done {
                return Ok(());
            }
            // A failed check: the general path below reports it as the factorization does.
        }
        match &self.mass_factor {
            Some(factor) => {
                let factor = factor
                    .as_ref()
                    .map_err(|&f| crate::linalg::singular_mass(f, t, q))?;
                self.run(t, q, qd, |_, _, _| {}, out);
                crate::linalg::solve_mass(&factor[..], n, t, out)
            }
            None => with_buf::<f64, 64, _>(n * n, 0.0, |m| {
                // The factorization reads the lower triangle.
                self.run(t, q, qd, |i, j, x| m[j * n + i] = x, out);
                crate::linalg::factor_mass(m, n, t, q)?;
                crate::linalg::solve_mass(&*m, n, t, out)
            }),
        }
    }
}

impl crate::dynamics::sealed::Sealed for EomFunction {}

impl DerivedProgram for EomFunction {
    fn mass_and_force(&self, t: f64, q: &[f64], qd: &[f64], m: &mut [f64], f: &mut [f64]) {
        EomFunction::mass_and_force(self, t, q, qd, m, f)
    }
    fn acceleration_jacobian(&self, t: f64, q: &[f64], qd: &[f64], jac: &mut [f64]) -> bool {
        EomFunction::acceleration_jacobian(self, t, q, qd, jac)
    }
    fn qp_form(&self, t: f64, q: &[f64], qd: &[f64], p: &mut [f64], g: &mut [f64]) {
        EomFunction::qp_form(self, t, q, qd, p, g)
    }
    fn qp_jacobian(&self, t: f64, q: &[f64], qd: &[f64], jac: &mut [f64]) -> bool {
        EomFunction::qp_jacobian(self, t, q, qd, jac)
    }
    fn acceleration_instructions(&self) -> usize {
        EomFunction::acceleration_instructions(self)
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

impl EomFunction {
    /// The program behind a system's [`DerivedProgram`] (sealed: this is its one
    /// implementation).
    pub fn of(program: &dyn DerivedProgram) -> &EomFunction {
        program
            .as_any()
            .downcast_ref()
            .expect("DerivedProgram is sealed: EomFunction is its one implementation")
    }
}
