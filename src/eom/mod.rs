//! Lagrange's equations with dissipation (seed eq. 55), assembled once for every route:
//!
//! M q̈ = Q″ + ∂L/∂q − (∂²L/∂q̇∂q) q̇ − ∂²L/∂q̇∂t − ∂Φ/∂q̇,   L = T − U,   M = ∂²T/∂q̇².
//!
//! - [`passes`]: the forward-mode derivative passes, each term of eq. 55 with only the pass it
//!   needs;
//! - [`Forces`]: the terms T does not give, Q″ − ∂U/∂q − ∂Φ/∂q̇, from the parts U, Φ and Q″;
//! - [`Forces::accelerations`] and [`Forces::accelerations_constant`]: the one right-hand side
//!   and its LDLᵀ tail ([`factor_mass`](crate::linalg::factor_mass), [`solve_mass`](crate::linalg::solve_mass)): M factored with typed errors naming t and q,
//!   solved, checked finite;
//!
//! A route supplies only M and the terms its kinetic energy gives (T's
//! ∂T/∂q − (∂²T/∂q̇∂q) q̇ − ∂²T/∂q̇∂t): [`System`](crate::System) by [`passes::inertia`],
//! [`EnergyModel`](crate::tape::EnergyModel) by one jet pass of its tape, and
//! [`ParticleSystem`](crate::ParticleSystem) as Σ m_j J_jᵀJ_j and Σ J_jᵀ(F_j − m_j a_j).

pub(crate) mod passes;

use crate::energies::{Dissipation, GeneralizedForces, Potential};
use crate::error::Result;
use crate::linalg::{factor_mass, solve_mass};
use crate::scalar::Scalar;
use crate::scalar::with_buf;
use passes::{Wrt, gradient};

/// Call a const-generic method with `C` = the number of coordinates (up to the chunk size
/// [`CHUNK`](crate::scalar::CHUNK)) and `C2 = 2 C`: `by_dof!(hint, n, self.method(args))` calls
/// `self.method::<C, C2, _>(args)` with `C` from [`pass_chunk`]. `hint` is the number of
/// coordinates when the type fixes it
/// ([`KineticEnergy::FIXED_DOF`](crate::KineticEnergy::FIXED_DOF)): `C` is then chosen at
/// compile time and only that one size is instantiated (rustc skips the
/// arms of a `match` on a constant), a quarter of the code of the runtime choice among four
/// (issue 19: build time).
macro_rules! by_dof {
    ($hint:expr, $n:expr, $this:ident . $f:ident ( $($arg:expr),* $(,)? )) => {
        match const { $crate::eom::pass_chunk($hint) } {
            0 => $crate::eom::by_dof!(@chunk $crate::eom::pass_chunk(Some($n)), $this.$f($($arg),*)),
            _ => $crate::eom::by_dof!(
                @chunk const { $crate::eom::pass_chunk($hint) },
                $this.$f($($arg),*)
            ),
        }
    };
    (@chunk $c:expr, $this:ident . $f:ident ( $($arg:expr),* )) => {
        match $c {
            1 => $this.$f::<1, 2, _>($($arg),*),
            2 => $this.$f::<2, 4, _>($($arg),*),
            3 => $this.$f::<3, 6, _>($($arg),*),
            _ => $this.$f::<
                { $crate::scalar::CHUNK },
                { 2 * $crate::scalar::CHUNK },
                _,
            >($($arg),*),
        }
    };
}
pub(crate) use by_dof;

/// The [`Dynamics`](crate::dynamics::Dynamics) methods a route computes with its own passes of
/// pass size `C` ([`by_dof!`], `hint` the route's `FIXED_DOF`): ∂U/∂q, p, M and q̈, each
/// `self.<name>_dof::<C, C2, _>(…)`, q̈ after the lengths are checked. Written once for the
/// energy, particle and rigid-body routes.
macro_rules! route_passes {
    ($hint:expr) => {
        fn potential_gradient_into<D: $crate::scalar::Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
            $crate::eom::by_dof!($hint, self.dof(), self.potential_gradient_dof(t, q, out))
        }

        fn momenta_into<D: $crate::scalar::Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
            $crate::eom::by_dof!($hint, self.dof(), self.momenta_dof(t, q, qd, out))
        }

        fn mass_matrix_into<D: $crate::scalar::Scalar>(
            &self,
            t: D,
            q: &[D],
            qd: &[D],
            out: &mut [D],
        ) {
            $crate::eom::by_dof!($hint, self.dof(), self.mass_matrix_dof(t, q, qd, out))
        }

        fn accelerations_into<D: $crate::scalar::Scalar>(
            &self,
            t: D,
            q: &[D],
            qd: &[D],
            out: &mut [D],
        ) -> $crate::error::Result<()> {
            $crate::checks::check_lengths(self.dof(), q, qd, out)?;
            $crate::eom::by_dof!($hint, self.dof(), self.accelerations_dof(t, q, qd, out))
        }
    };
}
pub(crate) use route_passes;

/// The pass size `C` that [`by_dof!`] takes for `Some(n)` coordinates, at compile time for a
/// type's fixed number and at run time for the others, so both pick the same `C` for the same n;
/// 0 for `None` (no fixed number: choose at run time).
pub(crate) const fn pass_chunk(dof: Option<usize>) -> usize {
    match dof {
        Some(n @ 1..=3) => n,
        Some(_) => crate::scalar::CHUNK,
        None => 0,
    }
}

/// The parts of eq. 55 other than T: U, Φ and Q″. An absent part (`()`, `None`) reports
/// itself absent and costs no pass.
pub(crate) struct Forces<'a, U, R, Q> {
    /// U(t, q).
    potential: &'a U,
    /// Rayleigh's Φ(t, q, q̇).
    dissipation: &'a R,
    /// Q″(t, q, q̇).
    forces: &'a Q,
}

impl<'a, U: Potential, R: Dissipation, Q: GeneralizedForces> Forces<'a, U, R, Q> {
    /// The parts U, Φ and Q″.
    #[inline(always)]
    pub(crate) fn new(potential: &'a U, dissipation: &'a R, forces: &'a Q) -> Self {
        Self {
            potential,
            dissipation,
            forces,
        }
    }

    /// `out += sign · ∂U/∂q`, one gradient pass in chunks of `C` (nothing when U is absent).
    #[inline(always)]
    pub(crate) fn add_potential_gradient<const C: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        sign: f64,
        out: &mut [D],
    ) {
        if self.potential.is_present() {
            gradient::<C, D, _>(
                t,
                q,
                q,
                Wrt::Position,
                sign,
                #[inline(always)]
                |t, q, _qd| self.potential.potential(t, q),
                out,
            );
        }
    }

    /// `out −= ∂Φ/∂q̇`, one gradient pass in chunks of `C` (nothing when Φ is absent).
    #[inline(always)]
    pub(crate) fn add_dissipative_forces<const C: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) {
        if self.dissipation.is_present() {
            gradient::<C, D, _>(
                t,
                q,
                qd,
                Wrt::Velocity,
                -1.0,
                #[inline(always)]
                |t, q, qd| self.dissipation.dissipation(t, q, qd),
                out,
            );
        }
    }

    /// The terms of eq. 55's right-hand side that T does not give, added into `out`:
    /// Q″ − ∂U/∂q − ∂Φ/∂q̇. `folded` leaves out −∂U/∂q, which the kinetic pass has already
    /// added (the one-pass inertia scheme differentiates L = T − U for up to two coordinates,
    /// see [`passes::inertia`]).
    #[inline(always)]
    pub(crate) fn add_into<const C: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        folded: bool,
        out: &mut [D],
    ) {
        if self.forces.is_present() {
            self.forces.forces(t, q, qd, out);
        }
        if !folded {
            self.add_potential_gradient::<C, D>(t, q, -1.0, out);
        }
        self.add_dissipative_forces::<C, D>(t, q, qd, out);
    }

    /// Eq. 55 solved for q̈ into `out` (n = `q.len()` entries). `inertia(m, rhs)` is the route's
    /// part: it writes M (row-major, n × n) to `m`, adds the terms its kinetic energy gives into
    /// `rhs`, and returns whether those include −∂U/∂q. The rest of the right-hand side comes
    /// from [`add_into`](Self::add_into). M is factored before those force terms are computed:
    /// the factorization is a serial chain of divisions, which the processor then overlaps with
    /// them.
    ///
    /// # Errors
    /// As [`factor_mass`] and [`solve_mass`].
    #[inline(always)]
    pub(crate) fn accelerations<const C: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
        inertia: impl FnOnce(&mut [D], &mut [D]) -> bool,
    ) -> Result<()> {
        let n = q.len();
        out.fill(D::zero());
        with_buf::<D, 16, _>(
            n * n,
            D::zero(),
            #[inline(always)]
            |m| {
                let folded = inertia(m, out);
                factor_mass(m, n, t, q)?;
                self.add_into::<C, D>(t, q, qd, folded, out);
                solve_mass(&*m, n, t, out)
            },
        )
    }

    /// [`accelerations`](Self::accelerations) with a constant M whose factor (from [`factor_mass`],
    /// at `f64`) is `m`: `kinetic(rhs)` adds the terms the kinetic energy gives (if any) into
    /// `rhs` and returns whether those include −∂U/∂q.
    ///
    /// # Errors
    /// As [`solve`].
    #[inline(always)]
    pub(crate) fn accelerations_constant<const C: usize, D: Scalar>(
        &self,
        m: &[f64],
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
        kinetic: impl FnOnce(&mut [D]) -> bool,
    ) -> Result<()> {
        out.fill(D::zero());
        let folded = kinetic(out);
        self.add_into::<C, D>(t, q, qd, folded, out);
        solve_mass(m, q.len(), t, out)
    }
}
