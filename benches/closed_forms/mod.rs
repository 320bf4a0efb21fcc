//! Hand-written closed forms of the whole [`Dynamics`] interface for the benchmark scenes: the
//! limit a model derived from its energies is measured against (`integrators.rs`,
//! `compiled.rs`). Explicit formulas, no AD on `f64`; generic over the scalar only because the
//! trait is, so the implicit methods can differentiate them like any other system.
//!
//! [`check`] compares one with the library's own model of the same system: a wrong comparator
//! would make every ratio measured against it meaningless.

use lagrangian::scenes::{BallInSphere, DoublePendulum, ElasticPendulum, ForcedTwoMass, NPendulum};
use lagrangian::{Dynamics, Result, Scalar, Structure};

/// Fail unless `closed` and `model` have the same structure, accelerations, mass matrix and
/// energy to `1e-12` relative at `states` (t, q, q̇).
pub fn check<A: Dynamics, B: Dynamics>(
    what: &str,
    closed: &A,
    model: &B,
    states: &[(f64, Vec<f64>, Vec<f64>)],
) {
    assert_eq!(closed.structure(), model.structure(), "{what}: structure");
    let close = |a: &[f64], b: &[f64], quantity: &str| {
        let scale = b.iter().fold(1e-300_f64, |m, x| m.max(x.abs()));
        for (x, y) in a.iter().zip(b) {
            assert!(
                (x - y).abs() <= 1e-12 * scale,
                "{what}: {quantity} {a:?} (closed form) against {b:?} (library)"
            );
        }
    };
    for (t, q, qd) in states {
        let a = closed.accelerations(*t, q, qd).unwrap();
        let b = model.accelerations(*t, q, qd).unwrap();
        close(a.as_slice(), b.as_slice(), "accelerations");
        let a = closed.mass_matrix(*t, q, qd).unwrap();
        let b = model.mass_matrix(*t, q, qd).unwrap();
        close(a.as_slice(), b.as_slice(), "mass matrix");
        let a = closed.energy(*t, q, qd).unwrap();
        let b = model.energy(*t, q, qd).unwrap();
        close(&[a], &[b], "energy");
    }
}

/// A few states of `n` coordinates (t, q, q̇) away from equilibrium, `r` added to the first
/// coordinate (a radius).
pub fn states(n: usize, r: f64) -> Vec<(f64, Vec<f64>, Vec<f64>)> {
    (0..4)
        .map(|k| {
            let k = k as f64;
            let mut q: Vec<f64> = (0..n).map(|i| (0.9 * k + 0.7 * i as f64).sin()).collect();
            q[0] += r;
            let qd = (0..n)
                .map(|i| 1.3 * (1.1 * k - 0.4 * i as f64).cos())
                .collect();
            (0.37 * k, q, qd)
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------

/// The double pendulum written out by hand: T, U, ∂U/∂q, p = M q̇, M and q̈ (Cramer's rule),
/// generic over the scalar so the implicit methods can differentiate it too.
pub struct ClosedDoublePendulum(pub DoublePendulum);

impl ClosedDoublePendulum {
    fn mass<D: Scalar>(&self, q: &[D]) -> (D, D, D) {
        let DoublePendulum { m1, m2, l1, l2, .. } = self.0;
        let c = (q[0] - q[1]).cos();
        (
            D::from((m1 + m2) * l1 * l1),
            c * (m2 * l1 * l2),
            D::from(m2 * l2 * l2),
        )
    }
}

impl Dynamics for ClosedDoublePendulum {
    fn dof(&self) -> usize {
        2
    }
    fn structure(&self) -> Structure {
        Structure {
            dof: 2,
            time_dependent: false,
            constant_mass: false,
            separable: false,
            dissipative: false,
            forced: false,
        }
    }
    fn kinetic_energy<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let (a, b, d) = self.mass(q);
        (a * qd[0] * qd[0] + d * qd[1] * qd[1]) * 0.5 + b * qd[0] * qd[1]
    }
    fn potential_energy<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let DoublePendulum { m1, m2, l1, l2, g } = self.0;
        -(q[0].cos() * ((m1 + m2) * g * l1) + q[1].cos() * (m2 * g * l2))
    }
    fn potential_gradient_into<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        let DoublePendulum { m1, m2, l1, l2, g } = self.0;
        out[0] = q[0].sin() * ((m1 + m2) * g * l1);
        out[1] = q[1].sin() * (m2 * g * l2);
    }
    fn generalized_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn dissipative_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn momenta_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) {
        let (a, b, d) = self.mass(q);
        out[0] = a * qd[0] + b * qd[1];
        out[1] = b * qd[0] + d * qd[1];
    }
    fn mass_matrix_into<D: Scalar>(&self, _t: D, q: &[D], _qd: &[D], out: &mut [D]) {
        let (a, b, d) = self.mass(q);
        out.copy_from_slice(&[a, b, b, d]);
    }
    fn accelerations_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        let DoublePendulum { m1, m2, l1, l2, g } = self.0;
        let (s, c) = (q[0] - q[1]).sin_cos();
        let (a, b, d) = (
            D::from((m1 + m2) * l1 * l1),
            c * (m2 * l1 * l2),
            D::from(m2 * l2 * l2),
        );
        let e = -s * qd[1] * qd[1] * (m2 * l1 * l2) - q[0].sin() * ((m1 + m2) * g * l1);
        let f = s * qd[0] * qd[0] * (m2 * l1 * l2) - q[1].sin() * (m2 * g * l2);
        let det = a * d - b * b;
        out[0] = (e * d - b * f) / det;
        out[1] = (a * f - b * e) / det;
        Ok(())
    }
}

/// The N-pendulum by hand: M_ik = μ_ik l_i l_k cos(θ_i − θ_k), μ_ik = Σ_{j ≥ max(i,k)} m_j, the
/// velocity terms and gravity written out, M q̈ = rhs by a Cholesky factorization: N libm calls,
/// M's lower triangle in O(N²), the velocity terms in O(N) by running sums and the O(N³) solve,
/// as careful hand-written generic code does it.
pub struct ClosedNPendulum {
    chain: NPendulum,
    /// μ_i = Σ_{j ≥ i} m_j.
    tail: Vec<f64>,
}

impl ClosedNPendulum {
    pub fn new(chain: NPendulum) -> Self {
        let n = chain.links();
        let mut tail = vec![0.0; n + 1];
        for j in (0..n).rev() {
            tail[j] = tail[j + 1] + chain.masses[j];
        }
        Self { chain, tail }
    }

    fn mass<D: Scalar>(&self, q: &[D], m: &mut [D]) {
        let n = q.len();
        let l = &self.chain.lengths;
        for i in 0..n {
            for k in 0..n {
                m[i * n + k] = (q[i] - q[k]).cos() * (self.tail[i.max(k)] * l[i] * l[k]);
            }
        }
    }
}

impl Dynamics for ClosedNPendulum {
    fn dof(&self) -> usize {
        self.chain.links()
    }
    fn structure(&self) -> Structure {
        Structure {
            dof: self.chain.links(),
            time_dependent: false,
            constant_mass: false,
            separable: false,
            dissipative: false,
            forced: false,
        }
    }
    fn kinetic_energy<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let (mut vx, mut vy, mut twice_t) = (D::zero(), D::zero(), D::zero());
        for (k, (&th, &w)) in q.iter().zip(qd).enumerate() {
            let (s, c) = th.sin_cos();
            vx += c * w * self.chain.lengths[k];
            vy += s * w * self.chain.lengths[k];
            twice_t += (vx * vx + vy * vy) * self.chain.masses[k];
        }
        twice_t * 0.5
    }
    fn potential_energy<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let (mut y, mut u) = (D::zero(), D::zero());
        for (k, &th) in q.iter().enumerate() {
            y -= th.cos() * self.chain.lengths[k];
            u += y * (self.chain.masses[k] * self.chain.g);
        }
        u
    }
    fn potential_gradient_into<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        for (k, o) in out.iter_mut().enumerate() {
            *o = q[k].sin() * (self.tail[k] * self.chain.g * self.chain.lengths[k]);
        }
    }
    fn generalized_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn dissipative_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn momenta_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) {
        let n = q.len();
        let l = &self.chain.lengths;
        for i in 0..n {
            out[i] = D::zero();
            for k in 0..n {
                out[i] += (q[i] - q[k]).cos() * qd[k] * (self.tail[i.max(k)] * l[i] * l[k]);
            }
        }
    }
    fn mass_matrix_into<D: Scalar>(&self, _t: D, q: &[D], _qd: &[D], out: &mut [D]) {
        self.mass(q, out);
    }
    fn accelerations_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        let n = q.len();
        let (l, tail) = (&self.chain.lengths, &self.tail);
        // One allocation: M, sin θ, cos θ, and the running sums A, B below.
        let mut buf = vec![D::zero(); n * n + 4 * n + 2];
        let (m, rest) = buf.split_at_mut(n * n);
        let (s, rest) = rest.split_at_mut(n);
        let (c, rest) = rest.split_at_mut(n);
        let (a_hi, b_hi) = rest.split_at_mut(n + 1);
        for k in 0..n {
            (s[k], c[k]) = q[k].sin_cos();
        }
        // cos(θᵢ − θₖ) from the addition theorem, and only the lower triangle of M (the
        // Cholesky factorization reads no more).
        for i in 0..n {
            for k in 0..=i {
                m[i * n + k] = (c[i] * c[k] + s[i] * s[k]) * (tail[i] * l[i] * l[k]);
            }
        }
        // The velocity terms Σₖ μ_ik lᵢ lₖ sin(θᵢ − θₖ) θ̇ₖ² = lᵢ (sᵢ Aᵢ − cᵢ Bᵢ) with
        // Aᵢ = Σₖ μ_max(i,k) lₖ cₖ θ̇ₖ² = μᵢ Σ_{k≤i} (…) + Σ_{k>i} μₖ (…) (Bᵢ with sₖ): running
        // sums from both ends, O(N).
        for k in (0..n).rev() {
            let v = qd[k] * qd[k] * (tail[k] * l[k]);
            a_hi[k] = a_hi[k + 1] + c[k] * v;
            b_hi[k] = b_hi[k + 1] + s[k] * v;
        }
        let (mut a_lo, mut b_lo) = (D::zero(), D::zero());
        for i in 0..n {
            let v = qd[i] * qd[i] * l[i];
            a_lo += c[i] * v;
            b_lo += s[i] * v;
            let a = a_lo * tail[i] + a_hi[i + 1];
            let b = b_lo * tail[i] + b_hi[i + 1];
            out[i] = -(s[i] * (tail[i] * self.chain.g) + (s[i] * a - c[i] * b)) * l[i];
        }
        // Cholesky M = L Lᵀ in place (row-major lower triangle), then L y = rhs by rows and
        // Lᵀ x = y by columns, so that every inner loop runs along a row.
        for j in 0..n {
            let row = &m[j * n..j * n + j];
            let ljj = (m[j * n + j] - dot(row, row)).sqrt();
            m[j * n + j] = ljj;
            let inv = ljj.recip();
            for i in j + 1..n {
                let x = m[i * n + j] - dot(&m[i * n..i * n + j], &m[j * n..j * n + j]);
                m[i * n + j] = x * inv;
            }
        }
        for i in 0..n {
            out[i] = (out[i] - dot(&m[i * n..i * n + i], &out[..i])) / m[i * n + i];
        }
        for i in (0..n).rev() {
            out[i] /= m[i * n + i];
            let x = out[i];
            for (o, l) in out[..i].iter_mut().zip(&m[i * n..i * n + i]) {
                *o -= *l * x;
            }
        }
        Ok(())
    }
}

/// The forced two-mass system (seed eq. 41–44) by hand: constant M = diag(m₁, m₂), eq. 43–44
/// solved for the accelerations.
pub struct ClosedForcedTwoMass(pub ForcedTwoMass);

impl Dynamics for ClosedForcedTwoMass {
    fn dof(&self) -> usize {
        2
    }
    fn structure(&self) -> Structure {
        Structure {
            dof: 2,
            time_dependent: false,
            constant_mass: true,
            separable: true,
            dissipative: false,
            forced: true,
        }
    }
    fn kinetic_energy<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] * self.0.m1 + qd[1] * qd[1] * self.0.m2) * 0.5
    }
    fn potential_energy<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let stretch = q[1] - q[0];
        (q[0] * q[0] * self.0.k1 + stretch * stretch * self.0.k2) * 0.5
    }
    fn potential_gradient_into<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        let stretch = q[1] - q[0];
        out[0] = q[0] * self.0.k1 - stretch * self.0.k2;
        out[1] = stretch * self.0.k2;
    }
    fn generalized_forces_into<D: Scalar>(&self, t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        let c = (t * self.0.omega).cos();
        out[0] = c * self.0.f1;
        out[1] = c * self.0.f2;
    }
    fn dissipative_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn momenta_into<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D], out: &mut [D]) {
        out[0] = qd[0] * self.0.m1;
        out[1] = qd[1] * self.0.m2;
    }
    fn mass_matrix_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        let z = D::zero();
        out.copy_from_slice(&[D::from(self.0.m1), z, z, D::from(self.0.m2)]);
    }
    fn accelerations_into<D: Scalar>(&self, t: D, q: &[D], _qd: &[D], out: &mut [D]) -> Result<()> {
        let ForcedTwoMass {
            m1,
            m2,
            k1,
            k2,
            f1,
            f2,
            omega,
        } = self.0;
        let c = (t * omega).cos();
        let stretch = q[1] - q[0];
        out[0] = (c * f1 - q[0] * k1 + stretch * k2) / m1;
        out[1] = (c * f2 - stretch * k2) / m2;
        Ok(())
    }
}

/// The ball rolling in a sphere (seed eq. 49–53) by hand: one coordinate, constant inertia
/// I = (m + J/r₂²)(r₁ − r₂)², eq. 53.
pub struct ClosedBallInSphere(pub BallInSphere);

impl ClosedBallInSphere {
    /// m g (r₁ − r₂), the amplitude of U.
    fn weight_arm(&self) -> f64 {
        let b = self.0;
        b.m * b.g * (b.r1 - b.r2)
    }
}

impl Dynamics for ClosedBallInSphere {
    fn dof(&self) -> usize {
        1
    }
    fn structure(&self) -> Structure {
        Structure {
            dof: 1,
            time_dependent: false,
            constant_mass: true,
            separable: true,
            dissipative: false,
            forced: false,
        }
    }
    fn kinetic_energy<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.0.inertia())
    }
    fn potential_energy<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].cos() * self.weight_arm()
    }
    fn potential_gradient_into<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        out[0] = q[0].sin() * self.weight_arm();
    }
    fn generalized_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn dissipative_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn momenta_into<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D], out: &mut [D]) {
        out[0] = qd[0] * self.0.inertia();
    }
    fn mass_matrix_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out[0] = D::from(self.0.inertia());
    }
    fn accelerations_into<D: Scalar>(
        &self,
        _t: D,
        q: &[D],
        _qd: &[D],
        out: &mut [D],
    ) -> Result<()> {
        out[0] = -q[0].sin() * (self.weight_arm() / self.0.inertia());
        Ok(())
    }
}

/// The spring pendulum with a radial dashpot (Φ = ½ c ṙ²) by hand, coordinates (r, θ):
/// M = diag(m, m r²), r̈ = r θ̇² − (k/m)(r − l₀) + g cos θ − (c/m) ṙ,
/// θ̈ = −(2 ṙ θ̇ + g sin θ) / r.
pub struct ClosedStiffSpring {
    /// Mass, stiffness, natural length, gravity.
    pub spring: ElasticPendulum,
    /// Radial damping coefficient c.
    pub c: f64,
}

impl Dynamics for ClosedStiffSpring {
    fn dof(&self) -> usize {
        2
    }
    fn structure(&self) -> Structure {
        Structure {
            dof: 2,
            time_dependent: false,
            constant_mass: false,
            separable: false,
            dissipative: self.c != 0.0,
            forced: false,
        }
    }
    fn kinetic_energy<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] + q[0] * q[0] * qd[1] * qd[1]) * (0.5 * self.spring.m)
    }
    fn potential_energy<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let ElasticPendulum { m, k, l0, g } = self.spring;
        let stretch = q[0] - l0;
        stretch * stretch * (0.5 * k) - q[0] * q[1].cos() * (m * g)
    }
    fn potential_gradient_into<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        let ElasticPendulum { m, k, l0, g } = self.spring;
        let (s, c) = q[1].sin_cos();
        out[0] = (q[0] - l0) * k - c * (m * g);
        out[1] = q[0] * s * (m * g);
    }
    fn generalized_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn dissipative_forces_into<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D], out: &mut [D]) {
        out[0] = -qd[0] * self.c;
        out[1] = D::zero();
    }
    fn momenta_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) {
        let m = self.spring.m;
        out[0] = qd[0] * m;
        out[1] = q[0] * q[0] * qd[1] * m;
    }
    fn mass_matrix_into<D: Scalar>(&self, _t: D, q: &[D], _qd: &[D], out: &mut [D]) {
        let m = self.spring.m;
        let z = D::zero();
        out.copy_from_slice(&[D::from(m), z, z, q[0] * q[0] * m]);
    }
    fn accelerations_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        let ElasticPendulum { m, k, l0, g } = self.spring;
        let (r, rd, thd) = (q[0], qd[0], qd[1]);
        let (s, c) = q[1].sin_cos();
        out[0] = r * thd * thd - (r - l0) * (k / m) + c * g - rd * (self.c / m);
        out[1] = -(rd * thd * 2.0 + s * g) / r;
        Ok(())
    }
}

/// Σ aₖ bₖ in four independent partial sums, so that the additions overlap instead of each
/// waiting for the one before.
fn dot<D: Scalar>(a: &[D], b: &[D]) -> D {
    let mut s = [D::zero(); 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .fold(D::zero(), |acc, (x, y)| acc + *x * *y);
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            s[k] += x[k] * y[k];
        }
    }
    (s[0] + s[1]) + (s[2] + s[3]) + tail
}
