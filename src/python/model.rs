//! The systems behind a Python `Model`: one enum over the tape models and every Rust scene, so
//! that each integrator is compiled once for all of them (the variant is one predictable branch
//! per evaluation).

use crate::constrained::Constrained;
use crate::derived::constraint_program::ConstraintProgram;
use crate::derived::eom_program::{Energies, EomFunction, EomProgram, particle_kinetic};
use crate::dynamics::{Dynamics, Structure};
use crate::energies::{Dissipation, GeneralizedForces, KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::expr::derive::{Wrt, gradient, reads};
use crate::expr::graph::{Binary, Graph, Node, Unary};
use crate::program::{compile::Tape, eval::Function, inputs::Inputs};
use crate::routes::{BodySystem, CartesianForces, ParticleSystem, Particles, RigidBodies, System};
use crate::routes::{EnergyModel, ExprConstraints, TapeParticles};
use crate::scalar::Scalar;
use crate::scenes::registry::{Arguments, Drawn, Positions, Scene, positions_of, scenes};
use crate::scenes::*;
use crate::sensitivity::{ConstraintNodes, Direction, Variational};
use crate::trace::{TraceEnergies, WithProgram};
use std::sync::{Arc, Mutex};

/// The enum over the tape models and every scene of the registry, its dispatch macro `each!`,
/// and the scenes' construction and positions, all from the one list in
/// [`crate::scenes::registry`].
macro_rules! any_model {
    ($($scene:ident,)*) => {
        /// Every system a Python `Model` can stand for.
        #[derive(Debug)]
        pub(crate) enum AnyModel {
            Energy(EnergyModel),
            /// Stated by particles: the energy model of T = ½ Σ m |ṙ|² derived from the
            /// positions, and the particles for drawing.
            Particles(EnergyModel, TapeParticles),
            /// A model stated in Python under constraints (`constraints=`,
            /// `velocity_constraints=`): Lagrange's equations of the first kind over the
            /// unconstrained model inside. A model without constraints is never wrapped.
            Constrained(Box<Constrained<AnyModel, ExprConstraints>>),
            $($scene(WithProgram<<$scene as Scene>::System>),)*
        }

        /// `$body` with `$s` bound to the system inside whichever variant `$model` is.
        macro_rules! each {
            ($model:expr, $s:ident => $body:expr) => {
                match $model {
                    AnyModel::Energy($s) => $body,
                    AnyModel::Particles($s, _) => $body,
                    AnyModel::Constrained(c) => {
                        let $s: &Constrained<AnyModel, ExprConstraints> = c;
                        $body
                    }
                    $(AnyModel::$scene($s) => $body,)*
                }
            };
        }

        impl AnyModel {
            /// The scene of these checked arguments.
            pub(crate) fn scene(args: &Arguments) -> Result<Self> {
                let name = args.info().name;
                $(
                    if name == <$scene as Scene>::INFO.name {
                        let system = <$scene as Scene>::build(args)?;
                        return Ok(AnyModel::$scene(WithProgram::new(system, name)));
                    }
                )*
                Err(bad(format!("the scene {name} has no variant")))
            }

            /// Whether the equations of motion of a scene read t explicitly (see [`Driven`]);
            /// `None` for a model stated in Python, whose tapes say it ([`CompiledModel::driven`]).
            pub(crate) fn scene_driven(&self) -> Option<bool> {
                match self {
                    AnyModel::Energy(_) | AnyModel::Particles(..) => None,
                    AnyModel::Constrained(c) => c.system().scene_driven(),
                    $(AnyModel::$scene(s) => Some(s.system().driven()),)*
                }
            }

            /// Whether the model is a ready-made scene (a Rust system with its traced program).
            pub(crate) fn is_scene(&self) -> bool {
                !matches!(
                    self,
                    AnyModel::Energy(_) | AnyModel::Particles(..) | AnyModel::Constrained(_)
                )
            }

            /// The eq. 55 program on the model's expression graph (a scene's traced on first
            /// use), or why there is none.
            pub(crate) fn program(&self) -> Result<&EomFunction> {
                match self {
                    AnyModel::Energy(m) | AnyModel::Particles(m, _) => m
                        .program()
                        .ok_or_else(|| bad("the model has no equations of motion".into())),
                    AnyModel::Constrained(_) => Err(bad(
                        "a constrained model has no single program of eq. 55 to expand (its \
                         accelerations come from the multipliers at each state)"
                            .into(),
                    )),
                    $(AnyModel::$scene(s) => s.program(),)*
                }
            }

            /// The energies of a scene traced onto the expression graph (its parameters are
            /// numbers there), for what is derived on request: the variational equations.
            pub(crate) fn scene_graph(&self) -> Result<(Graph, Energies)> {
                match self {
                    AnyModel::Energy(_) | AnyModel::Particles(..) | AnyModel::Constrained(_) => {
                        Err(bad("not a scene".into()))
                    }
                    $(AnyModel::$scene(s) => s.system().trace_energies().map_err(|why| {
                        Error::NotTraceable { what: <$scene as Scene>::INFO.name.into(), why }
                    }),)*
                }
            }

            /// The particles' positions at the states (t_i, q_i) (`q` row after row) as
            /// (count, dim, values), or `None` for a system stated by its energies only.
            pub(crate) fn positions(&self, t: &[f64], q: &[f64]) -> Option<Positions> {
                match self {
                    AnyModel::Energy(_) => None,
                    AnyModel::Particles(_, p) => Some(positions_of(p, t, q)),
                    AnyModel::Constrained(c) => c.system().positions(t, q),
                    $(AnyModel::$scene(s) => s.system().positions(t, q),)*
                }
            }
        }
    };
}
scenes!(any_model);

/// Whether a Rust system's equations of motion read t explicitly: L does (the structure's
/// `time_dependent`), or the generalized forces do (a drive such as F cos ωt). Such a system is
/// not autonomous even when its L is.
pub(crate) trait Driven {
    fn driven(&self) -> bool;
}

impl<T, U, R, Q> Driven for System<T, U, R, Q>
where
    T: KineticEnergy,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
{
    fn driven(&self) -> bool {
        self.structure().time_dependent || self.forces.depends_on_time()
    }
}

impl<P, U, R, Q, F> Driven for ParticleSystem<P, U, R, Q, F>
where
    P: Particles,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
    F: CartesianForces,
{
    fn driven(&self) -> bool {
        self.structure().time_dependent
            || self.forces.depends_on_time()
            || self.cartesian.depends_on_time()
    }
}

impl<B, U, R, Q> Driven for BodySystem<B, U, R, Q>
where
    B: RigidBodies,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
{
    fn driven(&self) -> bool {
        self.structure().time_dependent || self.forces.depends_on_time()
    }
}

impl Dynamics for AnyModel {
    crate::dynamics::forward_dynamics!(each!: dof, structure, kinetic_energy, potential_energy,
        potential_gradient_into, generalized_forces_into, dissipative_forces_into, momenta_into,
        mass_matrix_into, accelerations_into, lagrangian, derived_program, taylor_program, energy,
        constraints);
}

impl AnyModel {
    /// Whether [`positions`](Self::positions) has anything to report.
    pub(crate) fn has_positions(&self) -> bool {
        self.positions(&[], &[]).is_some()
    }

    /// What computes the accelerations at `f64` states: `"native"` (eq. 55 derived on the
    /// expression graph, compiled by Cranelift), `"interpreter"` (the same program, or the tapes'
    /// derivative passes, interpreted) or `"rust"` (a scene written in Rust).
    pub(crate) fn backend(&self) -> &'static str {
        match self {
            AnyModel::Energy(m) | AnyModel::Particles(m, _) => {
                m.program().map_or("interpreter", |p| p.program().backend())
            }
            AnyModel::Constrained(c) => c.system().backend(),
            _ => "rust",
        }
    }

    /// The size of the compiled program of M and f, in instructions (`None` for a scene).
    pub(crate) fn instructions(&self) -> Option<usize> {
        match self {
            AnyModel::Energy(m) | AnyModel::Particles(m, _) => {
                m.program().map(|p| p.program().instructions())
            }
            AnyModel::Constrained(c) => c.system().instructions(),
            _ => None,
        }
    }

    /// The constrained system, when the model has constraints.
    pub(crate) fn constrained(&self) -> Option<&Constrained<AnyModel, ExprConstraints>> {
        match self {
            AnyModel::Constrained(c) => Some(c),
            _ => None,
        }
    }

    /// The model without its constraints (itself when it has none).
    pub(crate) fn unconstrained(&self) -> &AnyModel {
        match self {
            AnyModel::Constrained(c) => c.system(),
            other => other,
        }
    }

    /// The particle map of the particle route (inside the constraints, if any).
    pub(crate) fn tape_particles(&self) -> Option<&TapeParticles> {
        match self.unconstrained() {
            AnyModel::Particles(_, p) => Some(p),
            _ => None,
        }
    }
}

/// A model with extra generalized loads Q (one per coordinate) for statics: r = ∂U/∂q − Q″ − Q.
pub(crate) struct WithLoads<'a> {
    pub(crate) model: &'a AnyModel,
    pub(crate) loads: &'a Function,
}

impl Dynamics for WithLoads<'_> {
    crate::dynamics::forward_dynamics!(model: dof, kinetic_energy, potential_energy,
        potential_gradient_into, dissipative_forces_into, momenta_into, mass_matrix_into);
    fn structure(&self) -> Structure {
        Structure {
            forced: true,
            ..self.model.structure()
        }
    }
    fn generalized_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.model.generalized_forces_into(t, q, qd, out);
        crate::energies::GeneralizedForces::forces(self.loads, t, q, qd, out);
    }
    /// The model's q̈ plus M⁻¹ times the loads, so that an equilibrium's linearization (its
    /// stability) sees the loads too.
    fn accelerations_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        self.model.accelerations_into(t, q, qd, out)?;
        let n = self.dof();
        let mut loads = vec![D::zero(); n];
        crate::energies::GeneralizedForces::forces(self.loads, t, q, qd, &mut loads);
        let mut m = vec![D::zero(); n * n];
        self.model.mass_matrix_into(t, q, qd, &mut m);
        crate::linalg::factor_mass(&mut m, n, t, q)?;
        crate::linalg::solve_mass(&m, n, t, &mut loads)?;
        for (a, l) in out.iter_mut().zip(&loads) {
            *a += *l;
        }
        Ok(())
    }
}

/// A node as the Python side serializes it: `(op, number, i, j)`.
pub(crate) type RawNode = (String, f64, i64, i64);

fn bad(why: String) -> Error {
    Error::InvalidInput { what: "model", why }
}

/// The parts of a model stated in Python, compiled once; binding to parameter values is cheap.
#[derive(Debug, Clone)]
pub(crate) struct CompiledModel {
    pub(crate) dof: usize,
    pub(crate) params: usize,
    pub(crate) kinetic: Option<Arc<Tape>>,
    pub(crate) potential: Option<Arc<Tape>>,
    pub(crate) dissipation: Option<Arc<Tape>>,
    pub(crate) forces: Option<Arc<Tape>>,
    /// Position tape, dimension and mass tape of the particle route.
    pub(crate) particles: Option<(Arc<Tape>, usize, Arc<Tape>)>,
    /// Eq. 55 derived on the expression graph (M and the force vector as one tape), for a model
    /// stated by its kinetic energy: the accelerations at `f64` states with no dual numbers.
    pub(crate) eom: Option<EomProgram>,
    /// The expression graph and the energies' nodes in it, kept for what is derived on request:
    /// the input matrix B of a linearization ([`crate::tape::input_matrix`]).
    pub(crate) energies: Option<(Arc<Graph>, Energies)>,
    /// The constraints' tapes (holonomic over (t, q), velocity over (t, q, q̇)) and row names.
    pub(crate) constraints: Option<ConstraintTapes>,
    /// The variational systems compiled so far, by their directions: shared by every binding
    /// of the model (`with_parameters`, a fit's iterations), compiled once each.
    pub(crate) variational: VariationalCache,
}

/// The variational systems of a model by their directions ([`CompiledModel::variational`]).
pub(crate) type VariationalCache = Arc<Mutex<Vec<(Vec<Direction>, Arc<Variational>)>>>;

/// The compiled rows of a constrained model, bound to parameters in [`CompiledModel::bind`].
#[derive(Debug, Clone)]
pub(crate) struct ConstraintTapes {
    holonomic: Option<Arc<Tape>>,
    velocity: Option<Arc<Tape>>,
    names: Vec<String>,
    /// G and γ derived on the graph and compiled, for `f64` states; `None` with the
    /// interpreter backend (G and γ then come from dual numbers, the reference).
    rows: Option<ConstraintProgram>,
    /// The rows as nodes of the model's graph (holonomic, velocity) and whether one reads t:
    /// what the variational equations derive from.
    nodes: (Vec<usize>, Vec<usize>, bool),
}

/// What runs a model's derived eq. 55 program at `f64` states, as Python names it
/// (`Model(..., backend=...)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Backend {
    /// Machine code from Cranelift where the platform has it, else the interpreter.
    Native,
    /// The same program interpreted: the reference the machine code is tested against.
    Interpreter,
}

impl Backend {
    /// The backend named `name`.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for any other name.
    pub(crate) fn named(name: &str) -> Result<Self> {
        match name {
            "native" => Ok(Self::Native),
            "interpreter" => Ok(Self::Interpreter),
            other => Err(Error::InvalidInput {
                what: "model",
                why: format!(
                    "unknown backend {other:?}: use \"native\" (compiled to machine code, the \
                     default) or \"interpreter\""
                ),
            }),
        }
    }
}

/// What the Python side sends for one model.
pub(crate) struct Spec<'a> {
    pub(crate) nodes: &'a [RawNode],
    pub(crate) dof: usize,
    pub(crate) params: usize,
    pub(crate) kinetic: Option<usize>,
    pub(crate) potential: Option<usize>,
    pub(crate) dissipation: Option<usize>,
    pub(crate) forces: Option<Vec<usize>>,
    pub(crate) positions: Option<Vec<usize>>,
    pub(crate) dim: usize,
    pub(crate) masses: Option<Vec<usize>>,
    /// Holonomic rows g(t, q) and velocity rows a·q̇ + b (node indices) with the rows' names
    /// (holonomic first; empty for the default names).
    pub(crate) constraints: Option<Vec<usize>>,
    pub(crate) velocity_constraints: Option<Vec<usize>>,
    pub(crate) constraint_names: Vec<String>,
    pub(crate) backend: Backend,
}

/// Graph node ids of the serialized outputs (serialized node k may have merged into an earlier
/// equal node).
pub(crate) fn node_ids(nodes: &[RawNode]) -> Result<(Graph, Vec<usize>)> {
    let mut g = Graph::new();
    let mut ids: Vec<usize> = Vec::with_capacity(nodes.len());
    for (k, raw) in nodes.iter().enumerate() {
        let one = graph_node(raw, k, &ids)?;
        ids.push(g.push(one)?);
    }
    Ok((g, ids))
}

fn graph_node(raw: &RawNode, k: usize, ids: &[usize]) -> Result<Node> {
    let (op, x, i, j) = raw;
    let index = |v: i64| -> Result<usize> {
        usize::try_from(v)
            .ok()
            .and_then(|v| ids.get(v).copied())
            .ok_or_else(|| bad(format!("node {k} ({op}) refers to node {v}")))
    };
    let leaf = |v: i64| -> Result<usize> {
        usize::try_from(v).map_err(|_| bad(format!("node {k} ({op}) has index {v}")))
    };
    let un = |f: Unary| -> Result<Node> { Ok(Node::Unary(f, index(*i)?)) };
    let bin = |f: Binary| -> Result<Node> { Ok(Node::Binary(f, index(*i)?, index(*j)?)) };
    // The functions of one argument by their names in the table (`expr/functions.rs`).
    if let Some(f) = Unary::from_name(op) {
        return un(f);
    }
    Ok(match op.as_str() {
        "const" => Node::Const(*x),
        "param" => Node::Param(leaf(*i)?),
        "t" => Node::Time,
        "q" => Node::Coord(leaf(*i)?),
        "qd" => Node::Velocity(leaf(*i)?),
        "add" => bin(Binary::Add)?,
        "sub" => bin(Binary::Sub)?,
        "mul" => bin(Binary::Mul)?,
        "div" => bin(Binary::Div)?,
        "pow" => bin(Binary::Pow)?,
        "atan2" => bin(Binary::Atan2)?,
        "powi" => Node::PowI(
            index(*i)?,
            i32::try_from(*j).map_err(|_| bad(format!("exponent {j} is too large")))?,
        ),
        other => return Err(bad(format!("unknown operation {other:?}"))),
    })
}

impl CompiledModel {
    /// Compile the parts of a model.
    pub(crate) fn new(spec: &Spec<'_>) -> Result<Self> {
        let Spec { dof, params, .. } = *spec;
        if dof == 0 {
            return Err(bad("a model needs at least one coordinate".into()));
        }
        let (mut g, ids) = node_ids(spec.nodes)?;
        let node = |o: usize, what: &str| -> Result<usize> {
            ids.get(o)
                .copied()
                .ok_or_else(|| bad(format!("{what}: output {o} is not a node")))
        };
        let tape = |g: &Graph, roots: &[usize], inputs: Inputs, what: &str| -> Result<Arc<Tape>> {
            let roots = roots
                .iter()
                .map(|&o| node(o, what))
                .collect::<Result<Vec<_>>>()?;
            Ok(Arc::new(Tape::new(g, &roots, inputs, what)?))
        };
        let all = Inputs::kinetic(dof, params);
        let no_velocity = Inputs::potential(dof, params);
        let constraints = constraint_tapes(&mut g, spec, &ids)?;
        let kinetic = spec
            .kinetic
            .map(|k| tape(&g, &[k], all, "kinetic energy"))
            .transpose()?;
        let potential = spec
            .potential
            .map(|u| tape(&g, &[u], no_velocity, "potential"))
            .transpose()?;
        let dissipation = spec
            .dissipation
            .map(|r| tape(&g, &[r], all, "dissipation function"))
            .transpose()?;
        let forces = match &spec.forces {
            Some(f) if f.len() != dof => {
                return Err(Error::DimensionMismatch {
                    what: "forces",
                    expected: dof,
                    got: f.len(),
                });
            }
            Some(f) => Some(tape(&g, f, all, "generalized forces")?),
            None => None,
        };
        let particles = match (&spec.positions, &spec.masses) {
            (Some(r), Some(m)) => {
                if spec.dim != 2 && spec.dim != 3 {
                    return Err(bad(format!("positions are 2-D or 3-D, not {}-D", spec.dim)));
                }
                if m.is_empty() || r.len() != spec.dim * m.len() {
                    return Err(bad(format!(
                        "{} position components for {} masses in {}-D",
                        r.len(),
                        m.len(),
                        spec.dim
                    )));
                }
                Some((
                    tape(&g, r, no_velocity, "positions")?,
                    spec.dim,
                    tape(&g, m, Inputs::constant(params), "masses")?,
                ))
            }
            (None, None) => None,
            _ => return Err(bad("positions and masses go together".into())),
        };
        if kinetic.is_some() == particles.is_some() {
            return Err(bad(
                "give either the kinetic energy or the particles' positions and masses".into(),
            ));
        }
        // Derived last: its nodes join the graph the tapes above were compiled from. A model
        // stated by its particles gets its T derived from the positions first.
        let (kinetic, kinetic_node) = match (kinetic, spec.kinetic, &spec.positions, &spec.masses) {
            (Some(tape), Some(k), _, _) => (Some(tape), Some(node(k, "kinetic energy")?)),
            (None, None, Some(r), Some(m)) => {
                let nodes = |o: &[usize], what: &str| -> Result<Vec<usize>> {
                    o.iter().map(|&o| node(o, what)).collect()
                };
                let (r, m) = (nodes(r, "positions")?, nodes(m, "masses")?);
                let k = particle_kinetic(&mut g, dof, &r, &m, spec.dim)?;
                let tape = Tape::new(&g, &[k], all, "kinetic energy")?;
                (Some(Arc::new(tape)), Some(k))
            }
            _ => (None, None),
        };
        let mut energies = None;
        let eom = match kinetic_node {
            Some(k) => {
                let parts = Energies {
                    kinetic: k,
                    potential: spec.potential.map(|u| node(u, "potential")).transpose()?,
                    dissipation: spec
                        .dissipation
                        .map(|r| node(r, "dissipation function"))
                        .transpose()?,
                    forces: spec
                        .forces
                        .as_ref()
                        .map(|f| f.iter().map(|&o| node(o, "generalized forces")).collect())
                        .transpose()?,
                };
                let program = EomProgram::new(&mut g, dof, params, &parts)?;
                energies = Some(parts);
                Some(match spec.backend {
                    // A Python model is run again and again: its first runs take the unrolled
                    // expansion where it is small.
                    Backend::Native => program.unroll_small_early(),
                    Backend::Interpreter => program.interpreted(),
                })
            }
            None => None,
        };
        Ok(Self {
            dof,
            params,
            kinetic,
            potential,
            dissipation,
            forces,
            particles,
            eom,
            energies: energies.map(|parts| (Arc::new(g), parts)),
            constraints,
            variational: Arc::default(),
        })
    }

    /// Whether the equations of motion read t explicitly: t appears in T, U, Φ or Q″.
    pub(crate) fn driven(&self) -> bool {
        [
            &self.kinetic,
            &self.potential,
            &self.dissipation,
            &self.forces,
        ]
        .into_iter()
        .flatten()
        .chain(self.particles.as_ref().map(|(r, _, _)| r))
        .chain(
            self.constraints
                .iter()
                .flat_map(|c| c.holonomic.iter().chain(&c.velocity)),
        )
        .any(|tape| tape.depends_on_time())
    }

    /// B = ∂ẋ/∂u at the operating point of `lin`, for the parameters `inputs` (indices) at the
    /// values `params` ([`crate::tape::input_matrix`]).
    pub(crate) fn input_matrix(
        &self,
        params: &[f64],
        inputs: &[usize],
        lin: &crate::statics::Linearization,
    ) -> Result<nalgebra::DMatrix<f64>> {
        let Some((graph, parts)) = &self.energies else {
            return Err(bad(
                "the model has no equations of motion to differentiate".into()
            ));
        };
        crate::statics::input_matrix(graph, parts, params, inputs, lin)
    }

    /// The variational system `v` as a compiled model of its own, to be bound per run as any
    /// compiled model is (an ensemble with sensitivities).
    pub(crate) fn of_variational(v: &Variational, params: usize) -> Self {
        let (kinetic, forces, eom) = v.parts();
        Self {
            dof: v.dof() * (1 + v.directions().len()),
            params,
            kinetic: Some(kinetic.clone()),
            potential: None,
            dissipation: None,
            forces: Some(forces.clone()),
            particles: None,
            eom: Some(eom.clone()),
            energies: None,
            constraints: None,
            variational: Arc::default(),
        }
    }

    /// The variational system along `directions` ([`Variational`]), compiled on the first
    /// request for these directions and kept.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a model without equations of motion on the graph; as
    /// [`Variational::new`].
    pub(crate) fn variational(&self, directions: &[Direction]) -> Result<Arc<Variational>> {
        let mut kept = self.variational.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((_, v)) = kept.iter().find(|(d, _)| d == directions) {
            return Ok(v.clone());
        }
        let (Some((graph, parts)), Some(eom)) = (&self.energies, &self.eom) else {
            return Err(bad(
                "the model has no equations of motion to differentiate".into()
            ));
        };
        let constraints = self.constraints.as_ref().map(|c| ConstraintNodes {
            holonomic: &c.nodes.0,
            velocity: &c.nodes.1,
            moving: c.nodes.2,
        });
        let v = Variational::new(graph, self.dof, self.params, parts, constraints, directions)?;
        let v = Arc::new(match eom.backend() {
            "native" => v,
            _ => v.interpreted(),
        });
        kept.push((directions.to_vec(), v.clone()));
        Ok(v)
    }

    /// The system at these parameter values.
    pub(crate) fn bind(&self, params: &[f64]) -> Result<AnyModel> {
        if params.len() != self.params {
            return Err(Error::DimensionMismatch {
                what: "parameters",
                expected: self.params,
                got: params.len(),
            });
        }
        let bind = |t: &Option<Arc<Tape>>| {
            t.as_ref()
                .map(|t| Function::new(t.clone(), params))
                .transpose()
        };
        let (u, r, q) = (
            bind(&self.potential)?,
            bind(&self.dissipation)?,
            bind(&self.forces)?,
        );
        let Some(k) = &self.kinetic else {
            return Err(bad("the model has no kinetic energy".into()));
        };
        let model = EnergyModel::new(self.dof, Function::new(k.clone(), params)?, u, r, q)?;
        let model = match &self.eom {
            Some(eom) => model.with_program(eom.bind(params)?)?,
            None => model,
        };
        let model = match &self.particles {
            None => AnyModel::Energy(model),
            Some((positions, dim, masses)) => {
                let m = Function::new(masses.clone(), params)?.constant_values();
                let p = TapeParticles::new(
                    self.dof,
                    *dim,
                    Function::new(positions.clone(), params)?,
                    m,
                )?;
                AnyModel::Particles(model, p)
            }
        };
        Ok(match &self.constraints {
            None => model,
            Some(c) => {
                let bind = |t: &Option<Arc<Tape>>| {
                    t.as_ref()
                        .map(|t| Function::new(t.clone(), params))
                        .transpose()
                };
                let rows = ExprConstraints::new(
                    self.dof,
                    bind(&c.holonomic)?,
                    bind(&c.velocity)?,
                    c.names.clone(),
                )?;
                let rows = match &c.rows {
                    Some(program) => rows.with_compiled_rows(program.bind(params)?),
                    None => rows,
                };
                AnyModel::Constrained(Box::new(Constrained::new(model, rows)))
            }
        })
    }
}

/// The constraints' tapes of `spec`, or `None` without rows: holonomic rows may not read q̇, and
/// each velocity row must be linear in q̇, which the graph says exactly: its gradient in q̇
/// (derived on the graph, simplified as built) reads no velocity.
fn constraint_tapes(
    g: &mut Graph,
    spec: &Spec<'_>,
    ids: &[usize],
) -> Result<Option<ConstraintTapes>> {
    let holonomic = spec.constraints.as_deref().unwrap_or(&[]);
    let velocity = spec.velocity_constraints.as_deref().unwrap_or(&[]);
    let (kh, kv) = (holonomic.len(), velocity.len());
    if kh + kv == 0 {
        return Ok(None);
    }
    let names = &spec.constraint_names;
    if !names.is_empty() && names.len() != kh + kv {
        return Err(bad(format!(
            "{} constraint names for {} rows",
            names.len(),
            kh + kv
        )));
    }
    let name = |row: usize| {
        names
            .get(row)
            .cloned()
            .unwrap_or_else(|| format!("constraint {row}"))
    };
    let nodes = |outputs: &[usize]| -> Result<Vec<usize>> {
        outputs
            .iter()
            .map(|&o| {
                ids.get(o)
                    .copied()
                    .ok_or_else(|| bad(format!("constraints: output {o} is not a node")))
            })
            .collect()
    };
    let (hn, vn) = (nodes(holonomic)?, nodes(velocity)?);
    let read = reads(g);
    if let Some(i) = hn
        .iter()
        .position(|&r| read[r] & crate::expr::derive::VELOCITY != 0)
    {
        return Err(bad(format!(
            "the holonomic constraint {:?} reads a velocity: g(t, q) = 0 is stated in t, the \
             coordinates and parameters; give a constraint on the velocities as a \
             velocity_constraint a(t, q)·q̇ + b(t, q) instead",
            name(i)
        )));
    }
    for (i, &row) in vn.iter().enumerate() {
        let grad = gradient(g, row, Wrt::Velocity, spec.dof)?;
        let read = reads(g);
        if let Some(j) = grad
            .iter()
            .position(|d| d.is_some_and(|d| read[d] & crate::expr::derive::VELOCITY != 0))
        {
            return Err(Error::InvalidInput {
                what: "velocity constraints",
                why: format!(
                    "the velocity constraint {:?} is not linear in the velocities: its \
                     derivative in velocity {j} still reads a velocity. A velocity constraint \
                     is a(t, q)·q̇ + b(t, q) = 0 (rolling without slipping, a knife edge)",
                    name(kh + i)
                ),
            });
        }
    }
    let (params, dof) = (spec.params, spec.dof);
    let tape = |roots: &[usize], inputs: Inputs, what: &str| -> Result<Option<Arc<Tape>>> {
        if roots.is_empty() {
            return Ok(None);
        }
        Ok(Some(Arc::new(Tape::new(g, roots, inputs, what)?)))
    };
    let holonomic = tape(&hn, Inputs::potential(dof, params), "constraints")?;
    let velocity = tape(&vn, Inputs::kinetic(dof, params), "velocity constraints")?;
    let moving = [&holonomic, &velocity]
        .into_iter()
        .flatten()
        .any(|t| t.depends_on_time());
    let rows = match spec.backend {
        Backend::Native => Some(ConstraintProgram::new(g, dof, params, &hn, &vn, moving)?),
        Backend::Interpreter => None,
    };
    Ok(Some(ConstraintTapes {
        holonomic,
        velocity,
        names: (0..kh + kv).map(name).collect(),
        rows,
        nodes: (hn, vn, moving),
    }))
}

/// Extra generalized loads for statics, compiled from serialized nodes with one output per
/// coordinate and bound to the parameter values.
pub(crate) fn loads(
    nodes: &[RawNode],
    outputs: &[usize],
    dof: usize,
    params: &[f64],
) -> Result<Function> {
    if outputs.len() != dof {
        return Err(Error::DimensionMismatch {
            what: "loads",
            expected: dof,
            got: outputs.len(),
        });
    }
    let (g, ids) = node_ids(nodes)?;
    let roots = outputs
        .iter()
        .map(|&o| {
            ids.get(o)
                .copied()
                .ok_or_else(|| bad(format!("loads: output {o} is not a node")))
        })
        .collect::<Result<Vec<_>>>()?;
    let tape = Tape::new(&g, &roots, Inputs::kinetic(dof, params.len()), "loads")?;
    Function::new(Arc::new(tape), params)
}
