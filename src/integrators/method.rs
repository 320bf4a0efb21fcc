//! The integration methods by name: [`Method`], what [`str::parse`] reads and `Display` writes.
//! What each method is and can do is in the registry (`registry.rs`), above the methods' files.

use crate::error::{Error, Result};

/// Declares the methods once: each variant with its documentation and its name; gives
/// [`Method`], [`Method::ALL`] (registry order) and [`Method::name`]. What each method is
/// and can do is its arm in the registry (`registry.rs`).
macro_rules! methods {
    ($($(#[$doc:meta])* $variant:ident = $name:literal,)*) => {
        /// An integration method; [`Method::Auto`] chooses one from the system's structure.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[non_exhaustive]
        pub enum Method {
            /// Choose from the structure, the options and the initial state; the choice and its
            /// reason are in [`Statistics::choice`](super::Statistics::choice):
            ///
            /// 0. a constrained system's reason starts with "constrained": `yoshida4` (a
            ///    composition of RATTLE steps) when it is conservative and separable with
            ///    holonomic rows only and a fixed `dt`; otherwise the rules below among the
            ///    methods that project their steps onto the constraints (not the symplectic
            ///    ones, not `taylor`);
            /// 1. conservative (no Φ, no Q″, no explicit t) with a fixed `dt`: `blanes_moan4` when
            ///    separable (constant M, U(q)), otherwise `gauss4` (symplectic for any L);
            /// 2. otherwise (forced, dissipative, time-dependent, or tolerances only): `radau5`
            ///    when the system is stiff;
            /// 3. else, with tolerances only and where the stiffness test ran, `taylor` for a
            ///    model stated as an analytic expression graph where its cost, estimated from
            ///    the sizes of the model's programs and the tolerance, is below DOP853's: small
            ///    smooth systems from about 1e-9 down (the double pendulum from about 1e-12);
            ///    not the N-link chains, whose series of M cost too much per step;
            /// 4. else `dop853` (adaptive, or at the fixed `dt`).
            ///
            /// Stiff means: at the initial state, the Jacobian of (q̇, q̈) has a decaying
            /// (relaxation) mode at least 1000 times faster than every mode the solution must
            /// follow — the oscillatory and the growing ones, and 1/|span| — so an explicit
            /// method's step would be set by stability, not accuracy. The eigenvalues come from
            /// the AD Jacobian (2n dual evaluations, one Schur decomposition; up to 64
            /// coordinates). Symplectic methods need a fixed `dt`: a conservative system given
            /// tolerances only gets `dop853`, and the reason says to give `dt` for a symplectic
            /// method.
            Auto,
            $($(#[$doc])* $variant,)*
        }

        impl Method {
            /// Every concrete method, in registry order.
            pub const ALL: &'static [Method] = &[$(Method::$variant),*];

            /// The method's name, as [`str::parse`] accepts it.
            pub fn name(self) -> &'static str {
                match self {
                    Method::Auto => "auto",
                    $(Method::$variant => $name,)*
                }
            }
        }
    };
}

methods! {
    /// Classical Runge–Kutta of order 4, fixed step.
    Rk4 = "rk4",
    /// Dormand–Prince 5(4) with step control, dense output and stiffness test (Hairer's `dopri5`).
    Dopri5 = "dopri5",
    /// Dormand–Prince 8(5,3) with step control, dense output and stiffness test (Hairer's `dop853`).
    Dop853 = "dop853",
    /// Störmer–Verlet (velocity Verlet, kick–drift–kick), order 2, symplectic.
    StormerVerlet = "stormer_verlet",
    /// Yoshida's triple-jump composition of Störmer–Verlet, order 4, symplectic.
    Yoshida4 = "yoshida4",
    /// Yoshida's 7-stage composition (solution A), order 6, symplectic.
    Yoshida6 = "yoshida6",
    /// Yoshida's 15-stage composition (solution D), order 8, symplectic.
    Yoshida8 = "yoshida8",
    /// Blanes & Moan's 6-stage symplectic Runge–Kutta–Nyström method SRKN₆ᵇ, order 4.
    BlanesMoan4 = "blanes_moan4",
    /// The midpoint variational integrator (discrete Hamilton and Lagrange–d'Alembert
    /// principles), order 2: implicit, symplectic and symmetric for any Lagrangian.
    Midpoint = "midpoint",
    /// Gauss–Legendre collocation with 2 stages on (q, p), order 4: implicit, symplectic and
    /// symmetric for any Lagrangian.
    Gauss4 = "gauss4",
    /// Gauss–Legendre collocation with 3 stages on (q, p), order 6: implicit, symplectic and
    /// symmetric for any Lagrangian.
    Gauss6 = "gauss6",
    /// Radau IIA of order 5 (Hairer & Wanner's RADAU5): implicit, L-stable, adaptive, with the
    /// AD Jacobian; for stiff problems.
    Radau5 = "radau5",
    /// The Taylor method (Jorba & Zou) on the model's expression graph: order and step from the
    /// tolerance and the series' radius of convergence; models stated as expressions only, with
    /// no |x| or sign(x) of the state. `Auto` chooses it where its cost, estimated from the
    /// sizes of the model's programs and the tolerance, is below DOP853's (`auto.rs`): small
    /// smooth models from about 1e-9 down, not the N-link chains, where a step's p²/2 graph
    /// evaluations make it 1.9–11× slower than DOP853.
    Taylor = "taylor",
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = Error;

    /// Parse a method name (`"auto"`, `"dop853"`, `"yoshida6"`, …), ignoring case.
    fn from_str(s: &str) -> Result<Self> {
        let lower = s.to_ascii_lowercase();
        let lower = if lower == "verlet" {
            "stormer_verlet".into()
        } else {
            lower
        };
        if lower == "auto" {
            return Ok(Method::Auto);
        }
        Method::ALL
            .iter()
            .copied()
            .find(|m| m.name() == lower)
            .ok_or_else(|| Error::InvalidInput {
                what: "method",
                why: format!(
                    "unknown method {s:?}; known: auto, {}",
                    Method::ALL
                        .iter()
                        .map(|m| m.name())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            })
    }
}
