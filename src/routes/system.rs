//! The energy route: a system composed of its kinetic energy, potential, dissipation and
//! generalized forces (seed eq. 55). Absent parts are `()` and cost nothing.

use crate::dynamics::{Dynamics, Structure};
use crate::energies::{Dissipation, GeneralizedForces, KineticEnergy, Potential};
use crate::eom::passes::{InertiaOut, Wrt, gradient, inertia};
use crate::eom::{Forces, by_dof, route_passes};
use crate::error::Result;
use crate::scalar::Scalar;
use std::sync::OnceLock;

/// A mechanical system stated by its energies: T, and optionally U, Φ and Q″.
///
/// ```
/// use lagrangian::{Dynamics, KineticEnergy, Potential, Scalar, System};
/// # use approx::assert_relative_eq;
/// struct Kinetic;
/// impl KineticEnergy for Kinetic {
///     fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
///         qd[0] * qd[0] * 0.5
///     }
///     fn depends_on_time(&self) -> bool { false }
///     fn depends_on_position(&self) -> bool { false }
///     fn constant_mass_matrix(&self) -> bool { true }
/// }
/// struct Spring(f64);
/// impl Potential for Spring {
///     fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
///         q[0] * q[0] * (0.5 * self.0)
///     }
///     fn depends_on_time(&self) -> bool { false }
/// }
/// let oscillator = System::new(1, Kinetic).with_potential(Spring(4.0));
/// let a = oscillator.accelerations(0.0, &[0.5], &[0.0]).unwrap();
/// assert_relative_eq!(a[0], -2.0, epsilon = 1e-15);
/// assert!(oscillator.structure().separable);
/// ```
#[derive(Debug)]
pub struct System<T, U = (), R = (), Q = ()> {
    dof: usize,
    /// Kinetic energy T(t, q, q̇).
    pub kinetic: T,
    /// Potential U(t, q); `()` when absent.
    pub potential: U,
    /// Rayleigh dissipation Φ(t, q, q̇); `()` when absent.
    pub dissipation: R,
    /// Generalized forces Q″(t, q, q̇); `()` when absent.
    pub forces: Q,
    /// LDLᵀ factor of a constant mass matrix, computed on first use.
    constant_factor: OnceLock<Result<Vec<f64>>>,
}

impl<T: Clone, U: Clone, R: Clone, Q: Clone> Clone for System<T, U, R, Q> {
    fn clone(&self) -> Self {
        Self {
            dof: self.dof,
            kinetic: self.kinetic.clone(),
            potential: self.potential.clone(),
            dissipation: self.dissipation.clone(),
            forces: self.forces.clone(),
            constant_factor: self.constant_factor.clone(),
        }
    }
}

impl<T: KineticEnergy> System<T> {
    /// A system of `dof` coordinates with kinetic energy `kinetic` and nothing else.
    ///
    /// # Panics
    /// If `dof` is zero.
    pub fn new(dof: usize, kinetic: T) -> Self {
        assert!(dof > 0, "a system needs at least one coordinate");
        Self {
            dof,
            kinetic,
            potential: (),
            dissipation: (),
            forces: (),
            constant_factor: OnceLock::new(),
        }
    }
}

impl<T, U, R, Q> System<T, U, R, Q> {
    /// Replace the potential.
    pub fn with_potential<U2: Potential>(self, potential: U2) -> System<T, U2, R, Q> {
        System {
            dof: self.dof,
            kinetic: self.kinetic,
            potential,
            dissipation: self.dissipation,
            forces: self.forces,
            constant_factor: self.constant_factor,
        }
    }

    /// Replace the Rayleigh dissipation function.
    pub fn with_dissipation<R2: Dissipation>(self, dissipation: R2) -> System<T, U, R2, Q> {
        System {
            dof: self.dof,
            kinetic: self.kinetic,
            potential: self.potential,
            dissipation,
            forces: self.forces,
            constant_factor: self.constant_factor,
        }
    }

    /// Replace the generalized forces.
    pub fn with_forces<Q2: GeneralizedForces>(self, forces: Q2) -> System<T, U, R, Q2> {
        System {
            dof: self.dof,
            kinetic: self.kinetic,
            potential: self.potential,
            dissipation: self.dissipation,
            forces,
            constant_factor: self.constant_factor,
        }
    }
}

impl<T, U, R, Q> System<T, U, R, Q>
where
    T: KineticEnergy,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
{
    /// U, Φ and Q″, for the shared assembly of eq. 55.
    #[inline(always)]
    fn parts(&self) -> Forces<'_, U, R, Q> {
        Forces::new(&self.potential, &self.dissipation, &self.forces)
    }

    /// Whether T gives terms besides M q̈: ∂T/∂q − (∂²T/∂q̇∂q) q̇ − ∂²T/∂q̇∂t.
    fn has_kinetic_terms(&self) -> bool {
        self.kinetic.depends_on_position() || self.kinetic.depends_on_time()
    }

    fn accelerations_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) -> Result<()> {
        // A copy of the body with the size known at compile time for the common n == C case.
        if self.dof == C {
            self.accelerations_n::<C, C2, D>(C, t, q, qd, out)
        } else {
            self.accelerations_n::<C, C2, D>(self.dof, t, q, qd, out)
        }
    }

    /// Eq. 55 with M and T's terms from [`inertia`] (which folds −∂U/∂q into its one pass
    /// where that pays), the rest from [`crate::eom`].
    #[inline(always)]
    fn accelerations_n<const C: usize, const C2: usize, D: Scalar>(
        &self,
        n: usize,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) -> Result<()> {
        let (q, qd, out) = (&q[..n], &qd[..n], &mut out[..n]);
        let kinetic_terms = self.has_kinetic_terms();
        let (ke, pot) = (&self.kinetic, &self.potential);
        if ke.constant_mass_matrix() {
            let m = self.constant_factor::<C, C2, D>(t, q, qd)?;
            self.parts().accelerations_constant::<C, D>(
                m,
                t,
                q,
                qd,
                out,
                #[inline(always)]
                |rhs| {
                    kinetic_terms && {
                        let io = InertiaOut {
                            mass: None,
                            kinetic_terms: Some(rhs),
                        };
                        inertia::<C, C2, D, T, U>(ke, pot, t, q, qd, io)
                    }
                },
            )
        } else {
            self.parts().accelerations::<C, D>(
                t,
                q,
                qd,
                out,
                #[inline(always)]
                |m, rhs| {
                    let io = InertiaOut {
                        mass: Some(m),
                        kinetic_terms: kinetic_terms.then_some(rhs),
                    };
                    inertia::<C, C2, D, T, U>(ke, pot, t, q, qd, io)
                },
            )
        }
    }

    /// The LDLᵀ factor of a constant mass matrix, computed once at the first state seen.
    fn constant_factor<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
    ) -> Result<&[f64]> {
        let n = self.dof;
        let factor = self.constant_factor.get_or_init(|| {
            let tr = t.re();
            let qr: Vec<f64> = q.iter().map(|x| x.re()).collect();
            let qdr: Vec<f64> = qd.iter().map(|x| x.re()).collect();
            let mut m = vec![0.0; n * n];
            let io = InertiaOut {
                mass: Some(&mut m),
                kinetic_terms: None,
            };
            inertia::<C, C2, f64, T, ()>(&self.kinetic, &(), tr, &qr, &qdr, io);
            crate::linalg::factor_mass(&mut m, n, tr, &qr)?;
            Ok(m)
        });
        factor.as_deref().map_err(Clone::clone)
    }

    fn mass_matrix_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) {
        let io = InertiaOut {
            mass: Some(out),
            kinetic_terms: None,
        };
        inertia::<C, C2, D, T, ()>(&self.kinetic, &(), t, q, qd, io);
    }

    fn momenta_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) {
        out.fill(D::zero());
        let f = |t, q: &[_], qd: &[_]| self.kinetic.kinetic(t, q, qd);
        gradient::<C, D, _>(t, q, qd, Wrt::Velocity, 1.0, f, out);
    }

    fn potential_gradient_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        out: &mut [D],
    ) {
        out.fill(D::zero());
        self.parts().add_potential_gradient::<C, D>(t, q, 1.0, out);
    }

    fn dissipative_forces_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) {
        out.fill(D::zero());
        self.parts().add_dissipative_forces::<C, D>(t, q, qd, out);
    }
}

impl<T, U, R, Q> Dynamics for System<T, U, R, Q>
where
    T: KineticEnergy,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
{
    route_passes!(T::FIXED_DOF);

    fn dof(&self) -> usize {
        self.dof
    }

    fn structure(&self) -> Structure {
        let k = &self.kinetic;
        let constant_mass = k.constant_mass_matrix();
        Structure {
            dof: self.dof,
            time_dependent: k.depends_on_time() || self.potential.depends_on_time(),
            constant_mass,
            separable: constant_mass && !k.depends_on_position() && !k.depends_on_time(),
            dissipative: self.dissipation.is_present(),
            forced: self.forces.is_present(),
        }
    }

    fn kinetic_energy<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.kinetic.kinetic(t, q, qd)
    }

    fn potential_energy<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.potential.potential(t, q)
    }

    fn generalized_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
        self.forces.forces(t, q, qd, out);
    }

    fn dissipative_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        by_dof!(
            T::FIXED_DOF,
            self.dof,
            self.dissipative_forces_dof(t, q, qd, out)
        )
    }
}
