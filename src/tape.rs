//! Models stated at run time: an expression graph compiled to a flat tape that is evaluated over
//! the same generic [`Scalar`](crate::Scalar) as a hand-written Rust model, so the AD passes and
//! every integrator work unchanged.
//!
//! This is what the Python module compiles the user's energies to, and it is not behind the
//! `python` feature because it is useful on its own: a model read from a file or built by a
//! program (a chain of N links, a mesh of springs) without writing a Rust type for it, and the
//! same test suite checks it against the Rust scenes.
//!
//! A [`Graph`] holds nodes in topological order and shares equal subexpressions (hash-consing).
//! [`Tape::new`] compiles the part of the graph that some outputs need:
//! - subexpressions of numbers and parameters go to a small `f64` program, run once per parameter
//!   set ([`Function::with_parameters`] re-runs only that, no recompilation);
//! - the rest becomes a flat list of instructions over a few reused slots (dead values free their
//!   slot), with `x op constant` forms so that a parameter never becomes a dual number, `x**2` as a
//!   square, and `sin x`, `cos x` of the same `x` as one `sin_cos`;
//! - the structure flags the engine relies on are read off the graph: whether t, q or q̇ are read
//!   at all, and whether T is a polynomial of degree ≤ 2 in q̇ whose quadratic part has constant
//!   coefficients (then M = ∂²T/∂q̇² is constant and factored once). The analysis is
//!   conservative: m l² (cos²θ + sin²θ) θ̇² is reported as not constant.
//!
//! Evaluation. An interpreter cannot do what the compiler does for a Rust model — inline the
//! model into each derivative pass and drop the derivative parts num-dual stores as `None` — so
//! the dual numbers of the engine's passes on `f64` states are evaluated as plain-array jets
//! (`jet.rs`), each instruction's result stays in an accumulator for the next one, and
//! [`EnergyModel`] takes ∂T/∂q, M and the mixed terms from one pass of T instead of two. These
//! narrow the gap between a model stated at run time and one written in Rust through
//! [`System`](crate::System); they do not close it (an interpreter still pays per instruction).
//!
//! This module is the public face of those models: it re-exports what they are made of from
//! their homes, lowest first — the expression graph and its derivatives (`src/expr/`), the flat
//! program and its interpreter (`src/program/`), machine code by Cranelift with the `jit`
//! feature (`src/native/`: `NativeTape`, `NativeFunction`, `Function::compile_native`; the
//! interpreter stays the fallback and the reference it is tested against), the Taylor series
//! and step (`src/taylor/`: [`TaylorProgram`], [`Expansion`]), eq. 55 on the graph, compiled
//! (`src/derived/`: [`eom_graph`], [`EomProgram`], [`EomFunction`], [`models`]), and the run-time
//! routes ([`EnergyModel`], [`TapeParticles`]) with the input matrix of a linearization
//! ([`input_matrix`]).
//!
//! Derivatives as expressions: [`tangent`], [`tangents`], [`Seeds`] and [`gradient`]
//! differentiate on the graph itself (forward mode and reverse-mode gradients, simplified and
//! hash-consed as it builds), and [`eom_graph`] derives eq. 55 — M's entries and one force
//! vector — as nodes, which [`EomProgram`] compiles into one tape evaluated in plain `f64`.
//!
//! ```
//! use lagrangian::tape::{Binary, Function, Graph, Inputs, Tape, Unary};
//! use lagrangian::{Dynamics, System};
//! # use approx::assert_relative_eq;
//! // A pendulum: T = ½ m l² θ̇², U = −m g l cos θ, with parameters (m, l, g).
//! let mut g = Graph::new();
//! let (m, l, grav) = (g.param(0), g.param(1), g.param(2));
//! let (th, w) = (g.coord(0), g.velocity(0));
//! let half = g.constant(0.5);
//! let ml = g.binary(Binary::Mul, m, l)?;
//! let mll = g.binary(Binary::Mul, ml, l)?;
//! let w2 = g.powi(w, 2)?;
//! let k = g.binary(Binary::Mul, half, mll)?;
//! let kinetic = g.binary(Binary::Mul, k, w2)?;
//! let mgl = g.binary(Binary::Mul, ml, grav)?;
//! let c = g.unary(Unary::Cos, th)?;
//! let mglc = g.binary(Binary::Mul, mgl, c)?;
//! let potential = g.unary(Unary::Neg, mglc)?;
//!
//! let params = [1.0, 2.0, 9.81];
//! let t = Tape::new(&g, &[kinetic], Inputs::kinetic(1, 3), "kinetic energy")?;
//! let u = Tape::new(&g, &[potential], Inputs::potential(1, 3), "potential")?;
//! assert!(t.constant_mass_matrix() && !t.depends_on_position());
//! let system = System::new(1, Function::new(t.into(), &params)?)
//!     .with_potential(Some(Function::new(u.into(), &params)?));
//! let a = system.accelerations(0.0, &[0.3], &[0.0])?;
//! assert_relative_eq!(a[0], -9.81 / 2.0 * 0.3_f64.sin(), epsilon = 1e-14);
//! # Ok::<(), lagrangian::Error>(())
//! ```

pub use crate::derived::constraint_program::{ConstraintProgram, ConstraintRows};
pub use crate::derived::eom_program::{
    Energies, EomFunction, EomGraph, EomProgram, eom_graph, particle_kinetic,
};
pub use crate::derived::models;
pub use crate::expr::derive::{Seeds, Wrt, gradient, tangent, tangents};
pub use crate::expr::graph::{Binary, Graph, Node, Unary};
#[cfg(feature = "jit")]
pub use crate::native::tape::{NativeFunction, NativeTape};
pub use crate::program::compile::Tape;
pub use crate::program::eval::Function;
pub use crate::program::inputs::Inputs;
pub use crate::routes::{EnergyModel, ExprConstraints, TapeParticles, TapeSystem};
pub use crate::statics::input_matrix;
pub use crate::taylor::{Expansion, MAX_TAYLOR_ORDER, StepRule, TaylorProgram};
