//! The rigid-body route: a system described by the poses of rigid bodies — centre of mass r(t, q)
//! and orientation R(t, q) ([`Pose`]) — with their masses and inertia tensors, instead of by T.
//!
//! T = Σ ½ m ‖ṙ‖² + ½ Ωᵀ I Ω, Ω = vee(RᵀṘ) in body axes, I about the centre of mass in body axes
//! (as `lg.Body`). As on the particle route, nothing is differentiated twice: from one
//! vector-dual pass per chunk of coordinates, J_v = ∂r/∂q and J_ω, whose column i is
//! vee(Rᵀ ∂R/∂q_i), and from one second-order pass along (q̇, 1) the velocities and the
//! accelerations at q̈ = 0, a₀ = r̈ and α₀ = vee(ṘᵀṘ + RᵀR̈) (the derivative of the skew RᵀṘ). Newton
//! and Euler projected on the coordinates (Kane's form of Lagrange's equations) read
//!
//! (Σ m J_vᵀJ_v + J_ωᵀ I J_ω) q̈ = Σ J_vᵀ(m g − m a₀) − J_ωᵀ(I α₀ + Ω × IΩ) + Q″ − ∂U/∂q − ∂Φ/∂q̇.
//!
//! A body posed by a quaternion ([`Pose::from_quaternion`]) adds ½ c ṡ², s = ½‖q‖², c = 4 tr(I)/3
//! — a point of mass c at s — so that M stays regular along q.

use crate::dynamics::{Dynamics, Structure};
use crate::energies::{Dissipation, GeneralizedForces, KineticEnergy, Potential};
use crate::eom::{Forces, route_passes};
use crate::error::{Error, Result};
use crate::rigid::{ORTHONORMAL_TOLERANCE, Pose, Rotation, Vector3, cross};
use crate::routes::system::System;
use crate::scalar::{Grad, Scalar, grad_const, grad_part, grad_seed, is, with_buf};
use num_dual::{Dual, Dual2};

/// Rigid bodies whose poses are functions of the generalized coordinates.
///
/// ```
/// use lagrangian::rigid::{Pose, Rotation};
/// use lagrangian::{BodySystem, Dynamics, RigidBodies, Scalar};
/// /// A uniform rod of mass m and length l hinged at one end about the world x axis.
/// struct Rod { m: f64, l: f64 }
/// impl RigidBodies for Rod {
///     fn dof(&self) -> usize { 1 }
///     fn count(&self) -> usize { 1 }
///     fn mass(&self, _j: usize) -> f64 { self.m }
///     fn inertia(&self, _j: usize) -> [[f64; 3]; 3] {
///         let i = self.m * self.l * self.l / 12.0;
///         [[i, 0.0, 0.0], [0.0, i, 0.0], [0.0, 0.0, 0.0]]
///     }
///     fn poses<D: Scalar>(&self, _t: D, q: &[D], out: &mut [Pose<D>]) {
///         let r = Rotation::about_x(q[0]);
///         let c = r.apply([D::zero(), D::zero(), D::from(-0.5 * self.l)]);
///         out[0] = Pose::new(c, r);
///     }
///     fn depends_on_time(&self) -> bool { false }
/// }
/// let rod = BodySystem::new(Rod { m: 2.0, l: 1.5 }).with_gravity([0.0, 0.0, -9.81]);
/// let a = rod.accelerations(0.0, &[0.3], &[0.0]).unwrap();
/// // The compound pendulum: θ̈ = −(3 g / 2 l) sin θ.
/// assert!((a[0] + 1.5 * 9.81 / 1.5 * 0.3_f64.sin()).abs() < 1e-13);
/// ```
pub trait RigidBodies {
    /// Number of generalized coordinates.
    fn dof(&self) -> usize;

    /// Number of bodies.
    fn count(&self) -> usize;

    /// The mass of body `j`.
    fn mass(&self, j: usize) -> f64;

    /// The inertia tensor of body `j` about its centre of mass, in body axes (symmetric).
    fn inertia(&self, j: usize) -> [[f64; 3]; 3];

    /// Write the poses of the bodies at (t, q) to `out` (one per body).
    fn poses<D: Scalar>(&self, t: D, q: &[D], out: &mut [Pose<D>]);

    /// Whether the poses depend on t explicitly (a driven joint).
    fn depends_on_time(&self) -> bool {
        true
    }

    /// The number of coordinates when every value of the type has the same, as
    /// [`KineticEnergy::FIXED_DOF`]: compiles the derivative passes for that one size.
    const FIXED_DOF: Option<usize> = None;
}

impl<B: RigidBodies + ?Sized> RigidBodies for &B {
    const FIXED_DOF: Option<usize> = B::FIXED_DOF;
    fn dof(&self) -> usize {
        (**self).dof()
    }
    fn count(&self) -> usize {
        (**self).count()
    }
    fn mass(&self, j: usize) -> f64 {
        (**self).mass(j)
    }
    fn inertia(&self, j: usize) -> [[f64; 3]; 3] {
        (**self).inertia(j)
    }
    #[inline]
    fn poses<D: Scalar>(&self, t: D, q: &[D], out: &mut [Pose<D>]) {
        (**self).poses(t, q, out)
    }
    fn depends_on_time(&self) -> bool {
        (**self).depends_on_time()
    }
}

/// The weight c = 4 tr(I)/3 of the quaternion's regularizing term ½ c (q·q̇)².
fn quaternion_weight(inertia: &[[f64; 3]; 3]) -> f64 {
    4.0 * (inertia[0][0] + inertia[1][1] + inertia[2][2]) / 3.0
}

/// I v for an `f64` tensor.
#[inline]
fn times<D: Scalar>(i: &[[f64; 3]; 3], v: Vector3<D>) -> Vector3<D> {
    i.map(|row| v[0] * row[0] + v[1] * row[1] + v[2] * row[2])
}

/// vee(Aᵀ B) for 3×3 matrices.
#[inline]
fn vee_of_product<D: Scalar>(a: &[[D; 3]; 3], b: &[[D; 3]; 3]) -> Vector3<D> {
    let at_b = |r: usize, c: usize| a[0][r] * b[0][c] + a[1][r] * b[1][c] + a[2][r] * b[2][c];
    [at_b(2, 1), at_b(0, 2), at_b(1, 0)]
}

/// The kinetic energy of rigid bodies, ½ m ‖ṙ‖² + ½ ΩᵀIΩ (+ ½ c ṡ² for quaternions), for the
/// energy route (one dual pass along (q̇, 1)).
#[derive(Debug, Clone)]
pub struct BodyKinetic<B>(pub B);

impl<B: RigidBodies> KineticEnergy for BodyKinetic<B> {
    const FIXED_DOF: Option<usize> = B::FIXED_DOF;
    fn kinetic<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        let b = &self.0;
        let zero = Dual::from_re(D::zero());
        with_buf::<_, 8, _>(q.len(), zero, |qs| {
            for ((l, &x), &v) in qs.iter_mut().zip(q).zip(qd) {
                *l = Dual::new(x, v);
            }
            with_buf::<_, 4, _>(b.count(), Pose::identity(), |ps| {
                b.poses(Dual::new(t, D::one()), qs, ps);
                let mut twice_t = D::zero();
                for (j, p) in ps.iter().enumerate() {
                    let inertia = b.inertia(j);
                    let v = p.centre.map(|x| x.eps);
                    twice_t += (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) * b.mass(j);
                    let r = p.rotation.m.map(|row| row.map(|x| x.re));
                    let rd = p.rotation.m.map(|row| row.map(|x| x.eps));
                    let w = vee_of_product(&r, &rd);
                    let iw = times(&inertia, w);
                    twice_t += w[0] * iw[0] + w[1] * iw[1] + w[2] * iw[2];
                    if let Some(quat) = p.quaternion {
                        let sd = (quat.norm_squared() * 0.5).eps;
                        twice_t += sd * sd * quaternion_weight(&inertia);
                    }
                }
                twice_t * 0.5
            })
        })
    }
    fn depends_on_time(&self) -> bool {
        self.0.depends_on_time()
    }
}

/// The potential −Σ m g·r of a uniform gravity field g acting on the bodies.
#[derive(Debug, Clone)]
pub struct BodyGravity<B> {
    /// The bodies.
    pub bodies: B,
    /// The field g.
    pub g: [f64; 3],
}

impl<B: RigidBodies> Potential for BodyGravity<B> {
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D {
        let b = &self.bodies;
        with_buf::<_, 4, _>(b.count(), Pose::identity(), |ps| {
            b.poses(t, q, ps);
            let mut u = D::zero();
            for (j, p) in ps.iter().enumerate() {
                let m = b.mass(j);
                for (x, g) in p.centre.iter().zip(self.g) {
                    u -= *x * (m * g);
                }
            }
            u
        })
    }
    fn depends_on_time(&self) -> bool {
        self.bodies.depends_on_time()
    }
    fn is_present(&self) -> bool {
        self.g.iter().any(|&g| g != 0.0)
    }
}

/// Rows per body of the stacked Jacobian: 3 of ṙ, 3 of Ω, 1 of ṡ = q·q̇ (zero without a
/// quaternion).
const ROWS: usize = 7;

/// One body's velocities and its accelerations at q̈ = 0, in the order of the Jacobian's rows.
#[derive(Debug, Clone, Copy)]
struct Motion<D> {
    /// (ṙ, Ω, ṡ).
    velocity: [D; ROWS],
    /// (r̈, Ω̇, s̈) at q̈ = 0.
    acceleration: [D; ROWS],
}

/// The stacked Jacobian J = ∂(ṙ, Ω, ṡ)/∂q̇ (row-major, bodies × [`ROWS`] × n) by vector-dual
/// passes in chunks of `C`; the first orthonormality failure (body, error) into `worst`.
#[inline]
fn jacobian<const C: usize, D: Scalar, B: RigidBodies>(
    b: &B,
    t: D,
    q: &[D],
    jac: &mut [D],
    worst: &mut Option<(usize, f64)>,
) {
    let n = q.len();
    let zero = grad_const::<D, C>(D::zero());
    let tt = grad_const::<D, C>(t);
    with_buf::<Grad<D, C>, C, _>(n, zero, |qs| {
        with_buf::<Pose<Grad<D, C>>, 4, _>(b.count(), Pose::identity(), |ps| {
            for start in (0..n).step_by(C) {
                let end = (start + C).min(n);
                for (i, (l, &x)) in qs.iter_mut().zip(q).enumerate() {
                    *l = if (start..end).contains(&i) {
                        grad_seed(x, i - start)
                    } else {
                        grad_const(x)
                    };
                }
                b.poses(tt, qs, ps);
                for (j, p) in ps.iter().enumerate() {
                    let r = p.rotation.m.map(|row| row.map(|x| x.re));
                    if start == 0 && worst.is_none() {
                        let e = Rotation::from_matrix(r).orthonormality_error();
                        if e.is_nan() || e > ORTHONORMAL_TOLERANCE {
                            *worst = Some((j, e));
                        }
                    }
                    let s = p.quaternion.map(|quat| quat.norm_squared() * 0.5);
                    let rows = &mut jac[j * ROWS * n..(j + 1) * ROWS * n];
                    for i in start..end {
                        let k = i - start;
                        let dr = p.rotation.m.map(|row| row.map(|x| grad_part(&x, k)));
                        let w = vee_of_product(&r, &dr);
                        for d in 0..3 {
                            rows[d * n + i] = grad_part(&p.centre[d], k);
                            rows[(3 + d) * n + i] = w[d];
                        }
                        rows[6 * n + i] = s.map_or(D::zero(), |s| grad_part(&s, k));
                    }
                }
            }
        })
    })
}

/// Each body's [`Motion`] by one second-order pass along (q̇, 1).
#[inline]
fn motion<D: Scalar, B: RigidBodies>(b: &B, t: D, q: &[D], qd: &[D], out: &mut [Motion<D>]) {
    let zero = Dual2::from_re(D::zero());
    with_buf::<_, 8, _>(q.len(), zero, |qs| {
        for ((l, &x), &w) in qs.iter_mut().zip(q).zip(qd) {
            *l = Dual2::new(x, w, D::zero());
        }
        with_buf::<_, 4, _>(b.count(), Pose::identity(), |ps| {
            b.poses(Dual2::new(t, D::one(), D::zero()), qs, ps);
            for (p, o) in ps.iter().zip(out.iter_mut()) {
                let r = p.rotation.m.map(|row| row.map(|x| x.re));
                let rd = p.rotation.m.map(|row| row.map(|x| x.v1));
                let rdd = p.rotation.m.map(|row| row.map(|x| x.v2));
                let w = vee_of_product(&r, &rd);
                let (a, c) = (vee_of_product(&rd, &rd), vee_of_product(&r, &rdd));
                let s = p.quaternion.map(|quat| quat.norm_squared() * 0.5);
                let (sd, sdd) = s.map_or((D::zero(), D::zero()), |s| (s.v1, s.v2));
                for d in 0..3 {
                    o.velocity[d] = p.centre[d].v1;
                    o.acceleration[d] = p.centre[d].v2;
                    o.velocity[3 + d] = w[d];
                    o.acceleration[3 + d] = a[d] + c[d];
                }
                o.velocity[6] = sd;
                o.acceleration[6] = sdd;
            }
        })
    })
}

/// W u for body `j`'s weight W = diag(m, m, m, I, c) on the rows (ṙ, Ω, ṡ).
#[inline]
fn weigh<D: Scalar, B: RigidBodies>(b: &B, j: usize, u: &[D; ROWS]) -> [D; ROWS] {
    let (m, inertia) = (b.mass(j), b.inertia(j));
    let iw = times(&inertia, [u[3], u[4], u[5]]);
    [
        u[0] * m,
        u[1] * m,
        u[2] * m,
        iw[0],
        iw[1],
        iw[2],
        u[6] * quaternion_weight(&inertia),
    ]
}

/// The number of leading columns of one body's rows past which every entry is exactly zero (the
/// coordinates of the links below it in a chain): at `f64` only, where zero is zero; a dual
/// number's zero real part may carry derivatives, so the other scalars take every column. The
/// sums skip those columns' exact zeros, a third of M's assembly in a long chain.
#[inline]
fn columns<D: Scalar>(rows: &[D], n: usize) -> usize {
    if !is::<D, f64>() {
        return n;
    }
    (0..n)
        .rposition(|k| rows[k..].iter().step_by(n).any(|x| x.re() != 0.0))
        .map_or(0, |k| k + 1)
}

/// `out_i += Σ_rows J[row, i] f_row` for one body's rows, over its first `last` columns.
#[inline]
fn project<D: Scalar>(rows: &[D], n: usize, last: usize, f: &[D; ROWS], out: &mut [D]) {
    for (row, &fr) in rows.chunks_exact(n).zip(f) {
        for (o, &jr) in out[..last].iter_mut().zip(row) {
            *o += jr * fr;
        }
    }
}

/// M = Σ Jᵀ W J over the bodies.
fn body_mass_matrix<D: Scalar, B: RigidBodies>(b: &B, jac: &[D], n: usize, m: &mut [D]) {
    m.fill(D::zero());
    for (j, rows) in jac.chunks_exact(ROWS * n).enumerate() {
        let last = columns(rows, n);
        for k in 0..last {
            let col: [D; ROWS] = std::array::from_fn(|r| rows[r * n + k]);
            let wc = weigh(b, j, &col);
            // Row k of M (upper part): Σ_r (W J)[r, k] J[r, i] for i ≥ k.
            for (r, &w) in wc.iter().enumerate() {
                let row = &rows[r * n..r * n + last];
                for (mi, &ji) in m[k * n + k..k * n + last].iter_mut().zip(&row[k..]) {
                    *mi += w * ji;
                }
            }
        }
    }
    for i in 0..n {
        for k in 0..i {
            m[i * n + k] = m[k * n + i];
        }
    }
}

/// Rigid bodies with uniform gravity and the parts of the energy route (a potential in q,
/// Rayleigh dissipation in q̇, generalized forces).
#[derive(Debug, Clone)]
pub struct BodySystem<B, U = (), R = (), Q = ()> {
    /// The bodies and their poses.
    pub bodies: B,
    /// Uniform gravitational acceleration g.
    pub gravity: [f64; 3],
    /// An extra potential U(t, q); `()` when absent.
    pub potential: U,
    /// Rayleigh dissipation Φ(t, q, q̇); `()` when absent.
    pub dissipation: R,
    /// Generalized forces Q″(t, q, q̇); `()` when absent.
    pub forces: Q,
}

impl<B: RigidBodies> BodySystem<B> {
    /// Bodies with no forces at all.
    ///
    /// # Panics
    /// If the bodies have no coordinate.
    pub fn new(bodies: B) -> Self {
        assert!(bodies.dof() > 0, "a system needs at least one coordinate");
        Self {
            bodies,
            gravity: [0.0; 3],
            potential: (),
            dissipation: (),
            forces: (),
        }
    }
}

impl<B, U, R, Q> BodySystem<B, U, R, Q> {
    /// Set the uniform gravitational acceleration g (e.g. `[0.0, 0.0, -9.81]`).
    pub fn with_gravity(mut self, g: [f64; 3]) -> Self {
        self.gravity = g;
        self
    }

    /// Replace the extra potential.
    pub fn with_potential<U2: Potential>(self, potential: U2) -> BodySystem<B, U2, R, Q> {
        let Self {
            bodies,
            gravity,
            dissipation,
            forces,
            ..
        } = self;
        BodySystem {
            bodies,
            gravity,
            potential,
            dissipation,
            forces,
        }
    }

    /// Replace the Rayleigh dissipation function.
    pub fn with_dissipation<R2: Dissipation>(self, dissipation: R2) -> BodySystem<B, U, R2, Q> {
        let Self {
            bodies,
            gravity,
            potential,
            forces,
            ..
        } = self;
        BodySystem {
            bodies,
            gravity,
            potential,
            dissipation,
            forces,
        }
    }

    /// Replace the generalized forces.
    pub fn with_forces<Q2: GeneralizedForces>(self, forces: Q2) -> BodySystem<B, U, R, Q2> {
        let Self {
            bodies,
            gravity,
            potential,
            dissipation,
            ..
        } = self;
        BodySystem {
            bodies,
            gravity,
            potential,
            dissipation,
            forces,
        }
    }
}

/// The energy-route [`System`] equivalent to a [`BodySystem`], borrowing its parts.
pub type BodyEnergyRoute<'a, B, U, R, Q> =
    System<BodyKinetic<&'a B>, (BodyGravity<&'a B>, &'a U), &'a R, &'a Q>;

impl<B, U, R, Q> BodySystem<B, U, R, Q>
where
    B: RigidBodies,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
{
    /// The same system through the energy route: T differentiated twice. Slower; it exists to
    /// check one route against the other, and to trace the system into an expression graph.
    pub fn energy_route(&self) -> BodyEnergyRoute<'_, B, U, R, Q> {
        System::new(self.bodies.dof(), BodyKinetic(&self.bodies))
            .with_potential((self.gravity_potential(), &self.potential))
            .with_dissipation(&self.dissipation)
            .with_forces(&self.forces)
    }

    fn gravity_potential(&self) -> BodyGravity<&B> {
        BodyGravity {
            bodies: &self.bodies,
            g: self.gravity,
        }
    }

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
        let b = &self.bodies;
        check_bodies(b)?;
        let (n, count) = (q.len(), b.count());
        let zero = D::zero();
        let idle = Motion {
            velocity: [zero; ROWS],
            acceleration: [zero; ROWS],
        };
        let mut worst = None;
        let solved = self.parts().accelerations::<C, D>(
            t,
            q,
            qd,
            out,
            #[inline(always)]
            |m, rhs| {
                with_buf::<D, 64, _>(count * ROWS * n, zero, |jac| {
                    with_buf::<Motion<D>, 4, _>(count, idle, |mo| {
                        jacobian::<C, D, B>(b, t, q, jac, &mut worst);
                        motion(b, t, q, qd, mo);
                        for (j, mj) in mo.iter().enumerate() {
                            let mass = b.mass(j);
                            // The inertial terms at q̈ = 0, with Euler's Ω × IΩ.
                            let mut f = weigh(b, j, &mj.acceleration);
                            let w = [mj.velocity[3], mj.velocity[4], mj.velocity[5]];
                            let gyro = cross(w, times(&b.inertia(j), w));
                            for d in 0..3 {
                                f[d] = D::from(mass * self.gravity[d]) - f[d];
                                f[3 + d] = -(f[3 + d] + gyro[d]);
                            }
                            f[6] = -f[6];
                            let rows = &jac[j * ROWS * n..(j + 1) * ROWS * n];
                            project(rows, n, columns(rows, n), &f, rhs);
                        }
                        body_mass_matrix(b, jac, n, m);
                    })
                });
                false
            },
        );
        match worst {
            Some((j, e)) => Err(not_a_rotation(j, e, t, q)),
            None => solved,
        }
    }

    fn mass_matrix_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        _qd: &[D],
        out: &mut [D],
    ) {
        let b = &self.bodies;
        let n = q.len();
        with_buf::<D, 64, _>(b.count() * ROWS * n, D::zero(), |jac| {
            jacobian::<C, D, B>(b, t, q, jac, &mut None);
            body_mass_matrix(b, jac, n, out);
        })
    }

    fn momenta_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        qd: &[D],
        out: &mut [D],
    ) {
        // p = Σ Jᵀ W (ṙ, Ω, ṡ).
        let b = &self.bodies;
        let (n, count) = (q.len(), b.count());
        let zero = D::zero();
        let idle = Motion {
            velocity: [zero; ROWS],
            acceleration: [zero; ROWS],
        };
        out.fill(zero);
        with_buf::<D, 64, _>(count * ROWS * n, zero, |jac| {
            with_buf::<Motion<D>, 4, _>(count, idle, |mo| {
                jacobian::<C, D, B>(b, t, q, jac, &mut None);
                motion(b, t, q, qd, mo);
                for (j, mj) in mo.iter().enumerate() {
                    let f = weigh(b, j, &mj.velocity);
                    let rows = &jac[j * ROWS * n..(j + 1) * ROWS * n];
                    project(rows, n, columns(rows, n), &f, out);
                }
            })
        })
    }

    fn potential_gradient_dof<const C: usize, const C2: usize, D: Scalar>(
        &self,
        t: D,
        q: &[D],
        out: &mut [D],
    ) {
        let u = (self.gravity_potential(), &self.potential);
        out.fill(D::zero());
        Forces::new(&u, &(), &()).add_potential_gradient::<C, D>(t, q, 1.0, out);
    }
}

/// The masses and inertia tensors a [`RigidBodies`] gives: finite, m ≥ 0, I symmetric with
/// non-negative diagonal (M is built from I's upper triangle, so an asymmetric I would be read
/// wrong, not refused).
fn check_bodies<B: RigidBodies>(b: &B) -> Result<()> {
    for j in 0..b.count() {
        let (m, i) = (b.mass(j), b.inertia(j));
        let scale = i.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
        let asymmetric = (0..3).any(|r| (0..3).any(|c| (i[r][c] - i[c][r]).abs() > 1e-12 * scale));
        let finite = m.is_finite() && m >= 0.0 && i.iter().flatten().all(|x| x.is_finite());
        let bad = !finite || asymmetric || (0..3).any(|d| i[d][d] < 0.0);
        if bad {
            return Err(Error::InvalidInput {
                what: "rigid body",
                why: format!(
                    "body {j} has mass {m} and inertia {i:?}: give a finite mass ≥ 0 and a \
                     finite, symmetric inertia tensor about the centre of mass with \
                     non-negative diagonal"
                ),
            });
        }
    }
    Ok(())
}

/// The error of a body whose R is not a rotation (or not finite).
fn not_a_rotation<D: Scalar>(j: usize, e: f64, t: D, q: &[D]) -> Error {
    if !e.is_finite() {
        return Error::NonFinite {
            what: "rigid body orientation",
            t: t.re(),
        };
    }
    let q: Vec<f64> = q.iter().map(|x| x.re()).collect();
    Error::InvalidInput {
        what: "rigid body orientation",
        why: format!(
            "body {j}'s R at t = {}, q = {q:?} is not a rotation: the largest entry of RᵀR − I \
             is {e:.3e} (at most {ORTHONORMAL_TOLERANCE:e} allowed); build R from Rotation's \
             constructors, products of them, or a quaternion",
            t.re()
        ),
    }
}

impl<B, U, R, Q> Dynamics for BodySystem<B, U, R, Q>
where
    B: RigidBodies,
    U: Potential,
    R: Dissipation,
    Q: GeneralizedForces,
{
    route_passes!(B::FIXED_DOF);

    fn dof(&self) -> usize {
        self.bodies.dof()
    }

    fn structure(&self) -> Structure {
        Structure {
            dof: self.dof(),
            time_dependent: self.bodies.depends_on_time() || self.potential.depends_on_time(),
            constant_mass: false,
            separable: false,
            dissipative: self.dissipation.is_present(),
            forced: self.forces.is_present(),
        }
    }

    fn kinetic_energy<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        BodyKinetic(&self.bodies).kinetic(t, q, qd)
    }

    fn potential_energy<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.gravity_potential().potential(t, q) + self.potential.potential(t, q)
    }

    fn generalized_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
        self.forces.forces(t, q, qd, out);
    }

    fn dissipative_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.energy_route().dissipative_forces_into(t, q, qd, out)
    }
}
