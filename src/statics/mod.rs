//! Equilibria of the equations of motion, and statics by the principle of virtual work (seed
//! §3.1–3.2).
//!
//! A system at rest stays at rest where the accelerations vanish at q̇ = 0, that is where the
//! force side of eq. 55 vanishes:
//!
//! r(q) = −[∂L/∂q + Q″ − ∂Φ/∂q̇ − ∂²L/∂q̇∂t](t, q, q̇ = 0)
//!      = ∂U/∂q − Q″ − ∂T/∂q + ∂Φ/∂q̇ + ∂²T/∂q̇∂t   (all at q̇ = 0).
//!
//! When T is a quadratic form in q̇ (the seed's statics) only ∂U/∂q − Q″ is left: the forces do no
//! virtual work in any virtual displacement (eq. 27–29). When T has a part T₀ that does not vanish
//! at q̇ = 0 (a bead on a spinning hoop, coordinates in a rotating frame), −∂T₀/∂q is the
//! centrifugal force and the roots are the relative equilibria, the stationary points of the
//! effective potential U − T₀. Neither needs M: a system built only for statics may have massless
//! points (its accelerations then fail with
//! [`Error::SingularMassMatrix`](crate::Error::SingularMassMatrix), as they should).
//!
//! The solver is Newton's method with the exact stiffness K = ∂r/∂q from dual numbers (one
//! `Dual64` pass per coordinate through the model's own generic code, no finite differences),
//! globalised by a backtracking (Armijo) line search on ½|r|² and by Levenberg–Marquardt damping
//! when K is singular or a Newton step fails. The equilibrium is classified from the eigenvalues
//! of the linearized equations of motion there ([`crate::modes`]), which see damping, gyroscopic
//! and centrifugal terms; only where M is singular does K alone decide (the energy criterion).
//!
//! A system whose equations depend on t explicitly has no static equilibrium in general: a
//! configuration balanced at one instant is not at the next. Unless the caller asks for the balance
//! at a frozen time ([`StaticsOptions::frozen_time`](crate::StaticsOptions::frozen_time)),
//! [`equilibrium()`](crate::equilibrium()) checks that r does not change with t at the root it
//! finds and fails with [`Error::NoStaticEquilibrium`](crate::Error::NoStaticEquilibrium) when it
//! does. A root that stays one (a driven pendulum hanging straight) is returned, but when its
//! linearization changes with t (parametric excitation) it is classified neutral: the eigenvalues
//! of one instant do not decide its stability. The structure hints decide whether to look: a system
//! that is neither time dependent, forced nor dissipative ([`crate::Structure::conservative`])
//! cannot depend on t; any other is checked numerically, which lets a steady rotation written with
//! t in it (a hoop turning at a constant rate, stated by particle positions r(t, q)) through.
//!
//! The files, one way: `residual` (r and K at rest) and `stability` (the verdict, and the
//! energy criterion) sit below the modes (`linearize.rs`), which use both; the
//! `equilibrium` solver sits above them and solves with `crate::nonlinear`. `input_matrix.rs`
//! adds to a linearization the input matrix B of a model stated at run time. `constrained.rs`
//! sits above `equilibrium` and [`crate::Constrained`]: equilibria on the manifold g(t, q) = 0 of
//! the holonomic rows, r(q) = Gᵀλ, classified by the Hessian reduced to null(G)
//! ([`constrained_equilibrium`](crate::constrained_equilibrium)). Velocity (nonholonomic) rows
//! do not restrict positions and hold at rest (b = 0 for the usual rolling and knife-edge rows):
//! the solve and the verdict ignore them. `constrained_modes.rs` sits above `constrained.rs` and
//! `linearize.rs`: the modes of such an equilibrium, Zᵀ H Z v = ω² Zᵀ M Z v on an orthonormal
//! basis Z of null(G) ([`constrained_modes`](crate::constrained_modes)).

mod constrained;
mod constrained_modes;
mod equilibrium;
mod input_matrix;
mod linearize;
mod residual;
mod stability;

pub use constrained::{ConstrainedEquilibrium, constrained_equilibrium};
pub use constrained_modes::constrained_modes;
pub use equilibrium::{Equilibrium, StaticsOptions, equilibrium};
pub use input_matrix::input_matrix;
pub use linearize::{Linearization, ModeProblem, Modes, linearize, modes};
pub use residual::static_stiffness;
pub(crate) use residual::{static_residual, static_stiffness_of};
pub use stability::Stability;
pub(crate) use stability::classify;
