//! Plane pendulums: simple, double, and the N-link chain, all hanging in gravity g along −y.
//! Angles are measured from the downward vertical.

use super::registry::{Arguments, Coordinates, Drawing, Parameter, Route, Scene, SceneInfo};
use crate::energies::{KineticEnergy, Potential};
use crate::error::{Error, Result};
use crate::routes::{ParticleSystem, Particles, System};
use crate::scalar::Scalar;

/// A point mass m on a massless rod of length l: T = ½ m l² θ̇², U = −m g l cos θ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimplePendulum {
    /// Bob mass.
    pub m: f64,
    /// Rod length.
    pub l: f64,
    /// Gravitational acceleration.
    pub g: f64,
}

impl SimplePendulum {
    /// A pendulum of mass `m`, length `l` in gravity `g`.
    pub fn new(m: f64, l: f64, g: f64) -> Self {
        Self { m, l, g }
    }

    /// The energy-route system.
    pub fn system(self) -> System<Self, Self> {
        System::new(1, self).with_potential(self)
    }

    /// The particle-route system: one bob at (l sin θ, −l cos θ) in gravity.
    pub fn particles(self) -> ParticleSystem<Self> {
        ParticleSystem::new(self).with_gravity([0.0, -self.g, 0.0])
    }

    /// Closed form: θ̈ = −(g/l) sin θ.
    pub fn closed_form_accelerations(&self, q: &[f64], _qd: &[f64]) -> [f64; 1] {
        [-self.g / self.l * q[0].sin()]
    }
}

impl KineticEnergy for SimplePendulum {
    const FIXED_DOF: Option<usize> = Some(1);
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.m * self.l * self.l)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn depends_on_position(&self) -> bool {
        false
    }
    fn constant_mass_matrix(&self) -> bool {
        true
    }
}

impl Potential for SimplePendulum {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].cos() * (self.m * self.g * self.l)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Particles for SimplePendulum {
    const FIXED_DOF: Option<usize> = Some(1);
    fn dof(&self) -> usize {
        1
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        self.m
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        let (s, c) = q[0].sin_cos();
        r[0] = s * self.l;
        r[1] = -c * self.l;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Two point masses on massless rods, coordinates (θ₁, θ₂).
///
/// T = ½(m₁+m₂) l₁² θ̇₁² + ½ m₂ l₂² θ̇₂² + m₂ l₁ l₂ θ̇₁ θ̇₂ cos(θ₁−θ₂),
/// U = −(m₁+m₂) g l₁ cos θ₁ − m₂ g l₂ cos θ₂.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoublePendulum {
    /// Upper mass.
    pub m1: f64,
    /// Lower mass.
    pub m2: f64,
    /// Upper rod length.
    pub l1: f64,
    /// Lower rod length.
    pub l2: f64,
    /// Gravitational acceleration.
    pub g: f64,
}

impl DoublePendulum {
    /// A double pendulum with the given masses, lengths and gravity.
    pub fn new(m1: f64, m2: f64, l1: f64, l2: f64, g: f64) -> Self {
        Self { m1, m2, l1, l2, g }
    }

    /// The energy-route system.
    pub fn system(self) -> System<Self, Self> {
        System::new(2, self).with_potential(self)
    }

    /// The particle-route system: two bobs in gravity.
    pub fn particles(self) -> ParticleSystem<Self> {
        ParticleSystem::new(self).with_gravity([0.0, -self.g, 0.0])
    }

    /// Hand-derived accelerations (the textbook closed form, solved by Cramer's rule).
    pub fn closed_form_accelerations(&self, q: &[f64], qd: &[f64]) -> [f64; 2] {
        let Self { m1, m2, l1, l2, g } = *self;
        let (s1, s2) = (q[0].sin(), q[1].sin());
        let (s, c) = (q[0] - q[1]).sin_cos();
        let (w1, w2) = (qd[0], qd[1]);
        // M = [[a, b], [b, d]], rhs = [e, f]
        let a = (m1 + m2) * l1 * l1;
        let b = m2 * l1 * l2 * c;
        let d = m2 * l2 * l2;
        let e = -m2 * l1 * l2 * s * w2 * w2 - (m1 + m2) * g * l1 * s1;
        let f = m2 * l1 * l2 * s * w1 * w1 - m2 * g * l2 * s2;
        let det = a * d - b * b;
        [(e * d - b * f) / det, (a * f - b * e) / det]
    }
}

impl KineticEnergy for DoublePendulum {
    const FIXED_DOF: Option<usize> = Some(2);
    #[inline]
    fn kinetic<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let Self { m1, m2, l1, l2, .. } = *self;
        qd[0] * qd[0] * (0.5 * (m1 + m2) * l1 * l1)
            + qd[1] * qd[1] * (0.5 * m2 * l2 * l2)
            + qd[0] * qd[1] * (q[0] - q[1]).cos() * (m2 * l1 * l2)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Potential for DoublePendulum {
    #[inline]
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let Self { m1, m2, l1, l2, g } = *self;
        -(q[0].cos() * ((m1 + m2) * g * l1) + q[1].cos() * (m2 * g * l2))
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Particles for DoublePendulum {
    const FIXED_DOF: Option<usize> = Some(2);
    fn dof(&self) -> usize {
        2
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        2
    }
    fn mass(&self, j: usize) -> f64 {
        [self.m1, self.m2][j]
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        let (s1, c1) = q[0].sin_cos();
        let (s2, c2) = q[1].sin_cos();
        r[0] = s1 * self.l1;
        r[1] = -c1 * self.l1;
        r[2] = r[0] + s2 * self.l2;
        r[3] = r[1] - c2 * self.l2;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// A chain of N point masses m_j on massless rods of lengths l_j, coordinates θ_1 … θ_N.
///
/// The kinetic energy is written the way a user would: the bob velocities as running sums
/// ṙ_j = Σ_{k≤j} l_k θ̇_k (cos θ_k, sin θ_k), then T = ½ Σ m_j |ṙ_j|² — O(N) work per evaluation.
#[derive(Debug, Clone, PartialEq)]
pub struct NPendulum {
    /// Bob masses, top to bottom.
    pub masses: Vec<f64>,
    /// Rod lengths, top to bottom.
    pub lengths: Vec<f64>,
    /// Gravitational acceleration.
    pub g: f64,
}

impl NPendulum {
    /// A chain with the given masses and lengths (equal lengths) in gravity `g`.
    ///
    /// # Panics
    /// If the lists are empty or of different lengths.
    pub fn new(masses: Vec<f64>, lengths: Vec<f64>, g: f64) -> Self {
        assert!(!masses.is_empty(), "an N-pendulum needs at least one link");
        assert_eq!(masses.len(), lengths.len(), "one length per mass");
        Self { masses, lengths, g }
    }

    /// `n` equal links of mass `m` and length `l`.
    pub fn uniform(n: usize, m: f64, l: f64, g: f64) -> Self {
        Self::new(vec![m; n], vec![l; n], g)
    }

    /// Number of links.
    pub fn links(&self) -> usize {
        self.masses.len()
    }

    /// The energy-route system.
    pub fn system(self) -> System<Self, Self> {
        let n = self.links();
        System::new(n, self.clone()).with_potential(self)
    }

    /// The particle-route system.
    pub fn particles(self) -> ParticleSystem<Self> {
        let g = self.g;
        ParticleSystem::new(self).with_gravity([0.0, -g, 0.0])
    }

    /// Hand-derived accelerations: M_ik = μ_ik l_i l_k cos(θ_i − θ_k) with μ_ik = Σ_{j ≥ max(i,k)}
    /// m_j, rhs_i = −Σ_k μ_ik l_i l_k sin(θ_i − θ_k) θ̇_k² − μ_ii g l_i sin θ_i, solved by Cholesky.
    pub fn closed_form_accelerations(&self, q: &[f64], qd: &[f64]) -> Vec<f64> {
        let n = self.links();
        let mut tail = vec![0.0; n + 1];
        for j in (0..n).rev() {
            tail[j] = tail[j + 1] + self.masses[j];
        }
        let l = &self.lengths;
        let mut m = nalgebra::DMatrix::zeros(n, n);
        let mut rhs = nalgebra::DVector::zeros(n);
        for i in 0..n {
            rhs[i] = -tail[i] * self.g * l[i] * q[i].sin();
            for k in 0..n {
                let mu = tail[i.max(k)];
                let (s, c) = (q[i] - q[k]).sin_cos();
                m[(i, k)] = mu * l[i] * l[k] * c;
                rhs[i] -= mu * l[i] * l[k] * s * qd[k] * qd[k];
            }
        }
        let chol =
            nalgebra::Cholesky::new(m).expect("the chain's mass matrix is positive definite");
        chol.solve(&rhs).iter().copied().collect()
    }
}

impl KineticEnergy for NPendulum {
    fn kinetic<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let (mut vx, mut vy, mut twice_t) = (D::zero(), D::zero(), D::zero());
        for (k, (&th, &w)) in q.iter().zip(qd).enumerate() {
            let (s, c) = th.sin_cos();
            vx += c * w * self.lengths[k];
            vy += s * w * self.lengths[k];
            twice_t += (vx * vx + vy * vy) * self.masses[k];
        }
        twice_t * 0.5
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Potential for NPendulum {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let (mut y, mut u) = (D::zero(), D::zero());
        for (k, &th) in q.iter().enumerate() {
            y -= th.cos() * self.lengths[k];
            u += y * (self.masses[k] * self.g);
        }
        u
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Particles for NPendulum {
    fn dof(&self) -> usize {
        self.links()
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        self.links()
    }
    fn mass(&self, j: usize) -> f64 {
        self.masses[j]
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        let (mut x, mut y) = (D::zero(), D::zero());
        for (k, &th) in q.iter().enumerate() {
            let (s, c) = th.sin_cos();
            x += s * self.lengths[k];
            y -= c * self.lengths[k];
            r[2 * k] = x;
            r[2 * k + 1] = y;
        }
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Scene for SimplePendulum {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "simple_pendulum",
        doc: "A point mass ``m`` on a rod of length ``l`` in gravity ``g``; coordinate θ \
              (``theta``) from the downward vertical. T = ½ m l² θ̇², U = −m g l cos θ.",
        parameters: &[
            Parameter::number("m", 1.0, "bob mass"),
            Parameter::number("l", 1.0, "rod length"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
        ],
        coordinates: Coordinates::Fixed(&["theta"]),
        route: Route::Energy,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        Ok(Self::new(a.number("m"), a.number("l"), a.number("g")).system())
    }
    fn drawing(_: &Arguments) -> Option<Drawing> {
        Some(Drawing::chain(1, false))
    }
}

impl Scene for DoublePendulum {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "double_pendulum",
        doc: "Two point masses on massless rods, coordinates (θ₁, θ₂) = (``th1``, ``th2``) \
              from the downward vertical.",
        parameters: &[
            Parameter::number("m1", 1.0, "upper bob mass"),
            Parameter::number("m2", 1.0, "lower bob mass"),
            Parameter::number("l1", 1.0, "upper rod length"),
            Parameter::number("l2", 1.0, "lower rod length"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
        ],
        coordinates: Coordinates::Fixed(&["th1", "th2"]),
        route: Route::Energy,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let n = |k| a.number(k);
        Ok(Self::new(n("m1"), n("m2"), n("l1"), n("l2"), n("g")).system())
    }
    fn drawing(_: &Arguments) -> Option<Drawing> {
        Some(Drawing::chain(2, false))
    }
}

impl Scene for NPendulum {
    type System = System<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "n_pendulum",
        doc: "A chain of N point masses on rods, coordinates ``th1`` … ``thN`` from the \
              vertical; N is the number of ``masses`` (one length per mass).",
        parameters: &[
            Parameter::list("masses", &[1.0, 1.0, 1.0], "bob masses, top to bottom"),
            Parameter::list("lengths", &[1.0, 1.0, 1.0], "rod lengths, top to bottom"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
        ],
        coordinates: Coordinates::Numbered {
            prefix: "th",
            per: "masses",
        },
        route: Route::Energy,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let (masses, lengths) = (a.list("masses"), a.list("lengths"));
        if masses.is_empty() || masses.len() != lengths.len() {
            return Err(Error::SceneArgument {
                scene: Self::INFO.name,
                parameter: "lengths".into(),
                why: format!(
                    "one length per mass (at least one): got {} masses and {} lengths",
                    masses.len(),
                    lengths.len()
                ),
            });
        }
        Ok(Self::new(masses.to_vec(), lengths.to_vec(), a.number("g")).system())
    }
    fn drawing(a: &Arguments) -> Option<Drawing> {
        Some(Drawing::chain(a.list("masses").len(), false))
    }
}
