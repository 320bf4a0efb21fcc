//! The particle route (seed §2, eq. 8–21): a system described by the positions r_j(t, q) of point
//! masses m_j instead of by T.
//!
//! With J_j = ∂r_j/∂q from one vector-dual pass and the acceleration at q̈ = 0,
//! a_j = d²r_j/dt² (the velocity-product terms of eq. 14–16 and the explicit-time terms) from one
//! second-order pass along (q̇, 1), Newton's law projected on the coordinates (eq. 20) reads
//!
//! (Σ m_j J_jᵀ J_j) q̈ = Σ J_jᵀ (F_j − m_j a_j) + Q″,
//!
//! with Cartesian forces F_j mapped by eq. 21/39. This is cheaper than differentiating T twice
//! and gives the same accelerations as the energy route (tests prove it).

use crate::dynamics::{Dynamics, Structure};
use crate::energies::{Dissipation, GeneralizedForces, KineticEnergy, Potential};
use crate::eom::{Forces, by_dof, route_passes};
use crate::error::Result;
use crate::routes::System;
use crate::scalar::Scalar;
use crate::scalar::{Grad, grad_const, grad_part, grad_seed, with_buf};
use num_dual::{Dual, Dual2};

/// Point masses whose positions are functions of the generalized coordinates (eq. 8–10).
pub trait Particles {
    /// Number of generalized coordinates.
    fn dof(&self) -> usize;

    /// Spatial dimension of each position: 2 or 3.
    fn dim(&self) -> usize;

    /// Number of particles.
    fn count(&self) -> usize;

    /// The mass m_j of particle `j` (zero for a massless point that only carries a load).
    fn mass(&self, j: usize) -> f64;

    /// Write the positions r_j(t, q), particle after particle (`dim` entries each), to `r`.
    fn positions<D: Scalar>(&self, t: D, q: &[D], r: &mut [D]);

    /// Whether the positions depend on t explicitly (moving constraints, a driven support).
    fn depends_on_time(&self) -> bool {
        true
    }

    /// Number of position entries: particles × dim.
    fn coordinates_len(&self) -> usize {
        self.count() * self.dim()
    }

    /// The number of coordinates when every value of the type has the same, as
    /// [`KineticEnergy::FIXED_DOF`]: compiles the derivative passes for that one size.
    const FIXED_DOF: Option<usize> = None;
}

impl<P: Particles + ?Sized> Particles for &P {
    const FIXED_DOF: Option<usize> = P::FIXED_DOF;
    fn dof(&self) -> usize {
        (**self).dof()
    }
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn count(&self) -> usize {
        (**self).count()
    }
    fn mass(&self, j: usize) -> f64 {
        (**self).mass(j)
    }
    #[inline]
    fn positions<D: Scalar>(&self, t: D, q: &[D], r: &mut [D]) {
        (**self).positions(t, q, r)
    }
    fn depends_on_time(&self) -> bool {
        (**self).depends_on_time()
    }
}

/// Forces F_j(t, r, ṙ) on the particles in Cartesian components (drag, a Lorentz force, a load).
///
/// `()` is the absent force.
pub trait CartesianForces {
    /// Add the forces, particle after particle, into `out` (same layout as the positions).
    fn forces<D: Scalar>(&self, t: D, r: &[D], v: &[D], out: &mut [D]);

    /// Whether the forces depend on t explicitly.
    fn depends_on_time(&self) -> bool {
        true
    }

    /// Whether this part exists; `false` only for the absent `()`.
    fn is_present(&self) -> bool {
        true
    }
}

impl CartesianForces for () {
    fn forces<D: Scalar>(&self, _t: D, _r: &[D], _v: &[D], _out: &mut [D]) {}
    fn depends_on_time(&self) -> bool {
        false
    }
    fn is_present(&self) -> bool {
        false
    }
}

impl<F: CartesianForces + ?Sized> CartesianForces for &F {
    fn forces<D: Scalar>(&self, t: D, r: &[D], v: &[D], out: &mut [D]) {
        (**self).forces(t, r, v, out)
    }
    fn depends_on_time(&self) -> bool {
        (**self).depends_on_time()
    }
    fn is_present(&self) -> bool {
        (**self).is_present()
    }
}

/// The kinetic energy T = ½ Σ m_j |ṙ_j|² of particles (eq. 22), for the energy route.
#[derive(Debug, Clone)]
pub struct ParticleKinetic<P>(pub P);

impl<P: Particles> KineticEnergy for ParticleKinetic<P> {
    const FIXED_DOF: Option<usize> = P::FIXED_DOF;
    fn kinetic<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        let p = &self.0;
        let dim = p.dim();
        let along = |x: D, v: D| Dual::new(x, v);
        let zero = Dual::from_re(D::zero());
        with_buf::<_, 8, _>(q.len(), zero, |qs| {
            for ((l, &x), &v) in qs.iter_mut().zip(q).zip(qd) {
                *l = along(x, v);
            }
            with_buf::<_, 12, _>(p.coordinates_len(), zero, |r| {
                p.positions(along(t, D::one()), qs, r);
                let mut twice_t = D::zero();
                for (a, x) in r.iter().enumerate() {
                    twice_t += x.eps * x.eps * p.mass(a / dim);
                }
                twice_t * 0.5
            })
        })
    }
    fn depends_on_time(&self) -> bool {
        self.0.depends_on_time()
    }
}

/// The potential −Σ m_j g·r_j of a uniform gravity field g acting on particles.
#[derive(Debug, Clone)]
pub struct ParticleGravity<P> {
    /// The particles.
    pub particles: P,
    /// The field g (its first `dim` components are used).
    pub g: [f64; 3],
}

impl<P: Particles> Potential for ParticleGravity<P> {
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D {
        let p = &self.particles;
        let dim = p.dim();
        with_buf::<D, 12, _>(p.coordinates_len(), D::zero(), |r| {
            p.positions(t, q, r);
            let mut u = D::zero();
            for (a, &x) in r.iter().enumerate() {
                u -= x * (p.mass(a / dim) * self.g[a % dim]);
            }
            u
        })
    }
    fn depends_on_time(&self) -> bool {
        self.particles.depends_on_time()
    }
    fn is_present(&self) -> bool {
        self.g.iter().any(|&g| g != 0.0)
    }
}

/// Cartesian forces on particles as generalized forces Q_i = Σ F_j·∂r_j/∂q_i (eq. 21, 39).
#[derive(Debug, Clone)]
pub struct MappedForces<P, F> {
    /// The particles the forces act on.
    pub particles: P,
    /// The Cartesian forces.
    pub forces: F,
}

impl<P: Particles, F: CartesianForces> GeneralizedForces for MappedForces<P, F> {
    fn forces<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        let p = &self.particles;
        let (n, na) = (q.len(), p.coordinates_len());
        with_buf::<D, 12, _>(na, D::zero(), |r| {
            with_buf::<D, 12, _>(na, D::zero(), |v| {
                with_buf::<D, 12, _>(na, D::zero(), |f| {
                    with_buf::<D, 36, _>(na * n, D::zero(), |jac| {
                        by_dof!(
                            P::FIXED_DOF,
                            n,
                            self.jacobian_and_velocity(t, q, qd, jac, r, v)
                        );
                        self.forces.forces(t, r, v, f);
                        project(jac, n, f, out);
                    })
                })
            })
        })
    }
    fn depends_on_time(&self) -> bool {
        self.particles.depends_on_time() || self.forces.depends_on_time()
    }
    fn is_present(&self) -> bool {
        self.forces.is_present()
    }
}

impl<P: Particles, F> MappedForces<P, F> {
    fn jacobian_and_velocity<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        jac: &mut [D],
        r: &mut [D],
        v: &mut [D],
    ) {
        jacobian::<C, D, P>(&self.particles, t, q, jac);
        velocity(&self.particles, t, q, qd, r, v);
    }
}

/// `out_i += Σ_a J[a, i] f_a`.
#[inline]
fn project<D: Scalar>(jac: &[D], n: usize, f: &[D], out: &mut [D]) {
    for (a, &fa) in f.iter().enumerate() {
        for i in 0..n {
            out[i] += jac[a * n + i] * fa;
        }
    }
}

/// J = ∂r/∂q (row-major, positions × coordinates) by vector-dual passes in chunks of `C`.
#[inline]
fn jacobian<const C: usize, D: Scalar, P: Particles>(p: &P, t: D, q: &[D], jac: &mut [D]) {
    let (n, na) = (q.len(), p.coordinates_len());
    let zero = grad_const::<D, C>(D::zero());
    let tt = grad_const::<D, C>(t);
    with_buf::<Grad<D, C>, C, _>(n, zero, |qs| {
        with_buf::<Grad<D, C>, 12, _>(na, zero, |rs| {
            for start in (0..n).step_by(C) {
                let end = (start + C).min(n);
                for (i, (l, &x)) in qs.iter_mut().zip(q).enumerate() {
                    *l = if (start..end).contains(&i) {
                        grad_seed(x, i - start)
                    } else {
                        grad_const(x)
                    };
                }
                p.positions(tt, qs, rs);
                for (a, ra) in rs.iter().enumerate() {
                    for i in start..end {
                        jac[a * n + i] = grad_part(ra, i - start);
                    }
                }
            }
        })
    })
}

/// Positions and velocities ṙ = J q̇ + ∂r/∂t by one dual pass along (q̇, 1).
fn velocity<D: Scalar, P: Particles>(p: &P, t: D, q: &[D], qd: &[D], r: &mut [D], v: &mut [D]) {
    let zero = Dual::from_re(D::zero());
    with_buf::<_, 8, _>(q.len(), zero, |qs| {
        for ((l, &x), &w) in qs.iter_mut().zip(q).zip(qd) {
            *l = Dual::new(x, w);
        }
        with_buf::<_, 12, _>(p.coordinates_len(), zero, |rs| {
            p.positions(Dual::new(t, D::one()), qs, rs);
            for (a, x) in rs.iter().enumerate() {
                r[a] = x.re;
                v[a] = x.eps;
            }
        })
    })
}

/// Positions, velocities and accelerations at q̈ = 0 by one second-order pass along (q̇, 1).
#[inline]
fn motion<D: Scalar, P: Particles>(
    p: &P,
    t: D,
    q: &[D],
    qd: &[D],
    r: &mut [D],
    v: &mut [D],
    a: &mut [D],
) {
    let zero = Dual2::from_re(D::zero());
    with_buf::<_, 8, _>(q.len(), zero, |qs| {
        for ((l, &x), &w) in qs.iter_mut().zip(q).zip(qd) {
            *l = Dual2::new(x, w, D::zero());
        }
        with_buf::<_, 12, _>(p.coordinates_len(), zero, |rs| {
            p.positions(Dual2::new(t, D::one(), D::zero()), qs, rs);
            for (k, x) in rs.iter().enumerate() {
                (r[k], v[k], a[k]) = (x.re, x.v1, x.v2);
            }
        })
    })
}

/// Particles with uniform gravity, optional Cartesian forces, and the parts of the energy route
/// (a potential in q, Rayleigh dissipation in q̇, generalized forces).
#[derive(Debug, Clone)]
pub struct ParticleSystem<P, U = (), R = (), Q = (), F = ()> {
    /// The point masses and their positions r_j(t, q).
    pub particles: P,
    /// Uniform gravitational acceleration g (components beyond `dim` are ignored).
    pub gravity: [f64; 3],
    /// An extra potential U(t, q) (springs, say); `()` when absent.
    pub potential: U,
    /// Rayleigh dissipation Φ(t, q, q̇); `()` when absent.
    pub dissipation: R,
    /// Generalized forces Q″(t, q, q̇); `()` when absent.
    pub forces: Q,
    /// Cartesian forces F_j(t, r, ṙ); `()` when absent.
    pub cartesian: F,
}

impl<P: Particles> ParticleSystem<P> {
    /// Particles with no forces at all.
    pub fn new(particles: P) -> Self {
        assert!(
            particles.dof() > 0,
            "a system needs at least one coordinate"
        );
        assert!(
            particles.dim() == 2 || particles.dim() == 3,
            "positions are 2-D or 3-D"
        );
        Self {
            particles,
            gravity: [0.0; 3],
            potential: (),
            dissipation: (),
            forces: (),
            cartesian: (),
        }
    }
}

impl<P, U, R, Q, F> ParticleSystem<P, U, R, Q, F> {
    /// Set the uniform gravitational acceleration g (e.g. `[0.0, -9.81, 0.0]`).
    pub fn with_gravity(mut self, g: [f64; 3]) -> Self {
        self.gravity = g;
        self
    }

    /// Replace the extra potential.
    pub fn with_potential<U2: Potential>(self, potential: U2) -> ParticleSystem<P, U2, R, Q, F> {
        let Self {
            particles,
            gravity,
            dissipation,
            forces,
            cartesian,
            ..
        } = self;
        ParticleSystem {
            particles,
            gravity,
            potential,
            dissipation,
            forces,
            cartesian,
        }
    }

    /// Replace the Rayleigh dissipation function.
    pub fn with_dissipation<R2: Dissipation>(
        self,
        dissipation: R2,
    ) -> ParticleSystem<P, U, R2, Q, F> {
        let Self {
            particles,
            gravity,
            potential,
            forces,
            cartesian,
            ..
        } = self;
        ParticleSystem {
            particles,
            gravity,
            potential,
            dissipation,
            forces,
            cartesian,
        }
    }

    /// Replace the generalized forces.
    pub fn with_forces<Q2: GeneralizedForces>(self, forces: Q2) -> ParticleSystem<P, U, R, Q2, F> {
        let Self {
            particles,
            gravity,
            potential,
            dissipation,
            cartesian,
            ..
        } = self;
        ParticleSystem {
            particles,
            gravity,
            potential,
            dissipation,
            forces,
            cartesian,
        }
    }

    /// Replace the Cartesian forces.
    pub fn with_cartesian_forces<F2: CartesianForces>(
        self,
        cartesian: F2,
    ) -> ParticleSystem<P, U, R, Q, F2> {
        let Self {
            particles,
            gravity,
            potential,
            dissipation,
            forces,
            ..
        } = self;
        ParticleSystem {
            particles,
            gravity,
            potential,
            dissipation,
            forces,
            cartesian,
        }
    }
}

/// The energy-route [`System`] equivalent to a [`ParticleSystem`], borrowing its parts.
pub type EnergyRoute<'a, P, U, R, Q, F> = System<
    ParticleKinetic<&'a P>,
    (ParticleGravity<&'a P>, &'a U),
    &'a R,
    (&'a Q, MappedForces<&'a P, &'a F>),
>;

impl<P, U, R, Q, F> ParticleSystem<P, U, R, Q, F>
where
    P: Particles,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
    F: CartesianForces,
{
    /// The same system through the energy route: T = ½ Σ m_j |ṙ_j|² differentiated twice.
    /// Slower; it exists to check one route against the other.
    pub fn energy_route(&self) -> EnergyRoute<'_, P, U, R, Q, F> {
        let gravity = ParticleGravity {
            particles: &self.particles,
            g: self.gravity,
        };
        let mapped = MappedForces {
            particles: &self.particles,
            forces: &self.cartesian,
        };
        System::new(self.particles.dof(), ParticleKinetic(&self.particles))
            .with_potential((gravity, &self.potential))
            .with_dissipation(&self.dissipation)
            .with_forces((&self.forces, mapped))
    }

    /// U, Φ and Q″ (the parts given in generalized coordinates), for the shared assembly of
    /// eq. 55.
    #[inline(always)]
    fn parts(&self) -> Forces<'_, U, R, Q> {
        Forces::new(&self.potential, &self.dissipation, &self.forces)
    }

    fn accelerations_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) -> Result<()> {
        // A copy of the body with the size known at compile time for the common n == C case.
        if q.len() == C {
            self.accelerations_n::<C, D>(C, t, q, qd, out)
        } else {
            self.accelerations_n::<C, D>(q.len(), t, q, qd, out)
        }
    }

    /// Eq. 55 with M = Σ m_j J_jᵀJ_j and the particles' terms Σ J_jᵀ(F_j − m_j a_j): J from one
    /// vector-dual pass per chunk of C coordinates, and r, ṙ and the acceleration a_j at q̈ = 0
    /// from one second-order pass along (q̇, 1). (A single nested `Dual2<Grad>` pass measured 5×
    /// slower: num-dual's nested `sin_cos` dominates.) The rest from [`crate::eom`].
    #[inline(always)]
    fn accelerations_n<const C: usize, D: Scalar>(
        &self,
        n: usize,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) -> Result<()> {
        let (q, qd, out) = (&q[..n], &qd[..n], &mut out[..n]);
        let p = &self.particles;
        let (na, dim) = (p.coordinates_len(), p.dim());
        let zero = D::zero();
        self.parts().accelerations::<C, D>(
            t,
            q,
            qd,
            out,
            #[inline(always)]
            |m, rhs| {
                with_buf::<D, 36, _>(na * n, zero, |jac| {
                    with_buf::<D, 12, _>(na, zero, |r| {
                        with_buf::<D, 12, _>(na, zero, |v| {
                            with_buf::<D, 12, _>(na, zero, |f| {
                                jacobian::<C, D, P>(p, t, q, jac);
                                motion(p, t, q, qd, r, v, f);
                                // f holds the accelerations at q̈ = 0; turn it into F_j − m_j a_j.
                                for (j, fj) in f.chunks_exact_mut(dim).enumerate() {
                                    let m = p.mass(j);
                                    for (d, fk) in fj.iter_mut().enumerate() {
                                        *fk = D::from(m * self.gravity[d]) - *fk * m;
                                    }
                                }
                                if self.cartesian.is_present() {
                                    self.cartesian.forces(t, r, v, f);
                                }
                                project(jac, n, f, rhs);
                                particle_mass_matrix(p, jac, n, m);
                            })
                        })
                    })
                });
                false
            },
        )
    }

    fn mass_matrix_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        _qd: &[D],
        out: &mut [D],
    ) {
        let p = &self.particles;
        let (n, na) = (q.len(), p.coordinates_len());
        with_buf::<D, 36, _>(na * n, D::zero(), |jac| {
            jacobian::<C, D, P>(p, t, q, jac);
            particle_mass_matrix(p, jac, n, out);
        })
    }

    fn momenta_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) {
        // p = Σ m_j J_jᵀ ṙ_j
        let p = &self.particles;
        let (n, na, dim) = (q.len(), p.coordinates_len(), p.dim());
        out.fill(D::zero());
        with_buf::<D, 36, _>(na * n, D::zero(), |jac| {
            with_buf::<D, 12, _>(na, D::zero(), |r| {
                with_buf::<D, 12, _>(na, D::zero(), |v| {
                    jacobian::<C, D, P>(p, t, q, jac);
                    velocity(p, t, q, qd, r, v);
                    for (k, vk) in v.iter_mut().enumerate() {
                        *vk *= p.mass(k / dim);
                    }
                    project(jac, n, v, out);
                })
            })
        })
    }

    fn potential_gradient_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        out: &mut [D],
    ) {
        let gravity = ParticleGravity {
            particles: &self.particles,
            g: self.gravity,
        };
        let u = (gravity, &self.potential);
        out.fill(D::zero());
        Forces::new(&u, &(), &()).add_potential_gradient::<C, D>(t, q, 1.0, out);
    }
}

/// M = Σ m_j J_jᵀ J_j.
#[inline]
fn particle_mass_matrix<D: Scalar, P: Particles>(p: &P, jac: &[D], n: usize, m: &mut [D]) {
    m.fill(D::zero());
    let dim = p.dim();
    for (k, row) in jac.chunks_exact(n * dim).enumerate() {
        let mass = p.mass(k);
        if mass == 0.0 {
            continue;
        }
        for row in row.chunks_exact(n) {
            for i in 0..n {
                let wi = row[i] * mass;
                for j in i..n {
                    m[i * n + j] += wi * row[j];
                }
            }
        }
    }
    for i in 0..n {
        for j in 0..i {
            m[i * n + j] = m[j * n + i];
        }
    }
}

impl<P, U, R, Q, F> Dynamics for ParticleSystem<P, U, R, Q, F>
where
    P: Particles,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
    F: CartesianForces,
{
    route_passes!(P::FIXED_DOF);

    fn dof(&self) -> usize {
        self.particles.dof()
    }

    fn structure(&self) -> Structure {
        let moving = self.particles.depends_on_time();
        Structure {
            dof: self.dof(),
            time_dependent: moving || self.potential.depends_on_time(),
            constant_mass: false,
            separable: false,
            dissipative: self.dissipation.is_present(),
            forced: self.forces.is_present() || self.cartesian.is_present(),
        }
    }

    fn kinetic_energy<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        ParticleKinetic(&self.particles).kinetic(t, q, qd)
    }

    fn potential_energy<D: Scalar>(&self, t: D, q: &[D]) -> D {
        let gravity = ParticleGravity {
            particles: &self.particles,
            g: self.gravity,
        };
        gravity.potential(t, q) + self.potential.potential(t, q)
    }

    fn generalized_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
        self.forces.forces(t, q, qd, out);
        let mapped = MappedForces {
            particles: &self.particles,
            forces: &self.cartesian,
        };
        if mapped.is_present() {
            mapped.forces(t, q, qd, out);
        }
    }

    fn dissipative_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.energy_route().dissipative_forces_into(t, q, qd, out)
    }
}
