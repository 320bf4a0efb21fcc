//! The seed's five statics examples (§3.2, Fig. 1–5), each with the seed's closed-form answer.
//!
//! Loads are Cartesian forces on points whose positions are functions of the coordinate, so the
//! generalized force comes from eq. 21/39, Qᵢ = Σ F_j·∂r_j/∂qᵢ, exactly as the seed computes the
//! virtual work δ*W = Σ F_j·δr_j (eq. 27). Where a figure has no inertia the load points are
//! massless: these scenes are for statics, and their accelerations fail with
//! [`SingularMassMatrix`](crate::Error::SingularMassMatrix), as they should.

use super::registry::{
    Arguments, Coordinates, Drawing, Drawn, Parameter, Positions, Route, Scene, SceneInfo,
};
use crate::energies::{GeneralizedForces, KineticEnergy, Potential};
use crate::error::Result;
use crate::routes::{CartesianForces, ParticleSystem, Particles, System};
use crate::scalar::Scalar;

/// Example 1, the lever (Fig. 1): arms l₁ and l₂ on either side of the pivot, a vertical force P
/// at the end of l₁ and a horizontal force Q at the end of l₂.
///
/// θ is the lever's angle below the horizontal on the l₁ side: the ends are at
/// A = l₁(cos θ, −sin θ) and B = l₂(−cos θ, sin θ). P pulls A down and Q pulls B outward (−x), so
/// δ*W = (P l₁ cos θ − Q l₂ sin θ) δθ and tan θ = P l₁ / (Q l₂).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lever {
    /// Arm of the vertical force.
    pub l1: f64,
    /// Arm of the horizontal force.
    pub l2: f64,
    /// Vertical force P.
    pub p: f64,
    /// Horizontal force Q.
    pub q: f64,
}

impl Lever {
    /// A lever with arms `l1`, `l2` carrying forces `p` (vertical) and `q` (horizontal).
    pub fn new(l1: f64, l2: f64, p: f64, q: f64) -> Self {
        Self { l1, l2, p, q }
    }

    /// Two massless load points; only statics applies.
    pub fn particles(self) -> ParticleSystem<Self, (), (), (), Self> {
        ParticleSystem::new(self).with_cartesian_forces(self)
    }

    /// The seed's virtual work per unit δθ: P l₁ cos θ − Q l₂ sin θ.
    pub fn virtual_work(&self, theta: f64) -> f64 {
        self.p * self.l1 * theta.cos() - self.q * self.l2 * theta.sin()
    }

    /// The seed's answer: tan θ = P l₁ / (Q l₂).
    pub fn closed_form_angle(&self) -> f64 {
        (self.p * self.l1).atan2(self.q * self.l2)
    }
}

impl Particles for Lever {
    const FIXED_DOF: Option<usize> = Some(1);
    fn dof(&self) -> usize {
        1
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        2
    }
    fn mass(&self, _j: usize) -> f64 {
        0.0
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        let (s, c) = q[0].sin_cos();
        r[0] = c * self.l1;
        r[1] = -s * self.l1;
        r[2] = -c * self.l2;
        r[3] = s * self.l2;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl CartesianForces for Lever {
    fn forces<D: Scalar>(&self, _t: D, _r: &[D], _v: &[D], out: &mut [D]) {
        out[1] -= D::from(self.p);
        out[2] -= D::from(self.q);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Example 2, the differential pulley (chain block, Fig. 2): sheaves of radii r₁ > r₂ on one
/// axle, the load Q on a movable pulley, the effort P on the hand chain.
///
/// θ is the axle's rotation, positive when the load rises: the hand chain moves down by r₁θ and
/// the load rises by (r₁ − r₂)θ/2, so the loads do δ*W = (P r₁ − Q (r₁ − r₂)/2) δθ and balance when
/// P = Q (r₁ − r₂)/(2 r₁).
///
/// That balance is neutral — at the balancing P every θ is an equilibrium — so a root finder has
/// nothing to find. To measure the effort the way one would on a bench, the hand chain is also
/// held by a spring balance of stiffness k (U = ½ k (r₁θ)²): the axle turns until the balance
/// supplies the part of the effort P does not, and its reading at equilibrium, −k r₁ θ, is
/// Q (r₁ − r₂)/(2 r₁) − P. With k = 0 there is no spring: the balance is neutral at the balancing P
/// and there is no equilibrium at any other P.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DifferentialPulley {
    /// Radius of the large sheave (the hand chain runs on it).
    pub r1: f64,
    /// Radius of the small sheave.
    pub r2: f64,
    /// Effort P on the hand chain (downward).
    pub p: f64,
    /// Load Q (weight hung on the movable pulley).
    pub q: f64,
    /// Stiffness of the spring balance on the hand chain (0: none).
    pub k: f64,
}

impl DifferentialPulley {
    /// A chain block with sheaves `r1` > `r2`, effort `p`, load `q` and spring balance `k`.
    pub fn new(r1: f64, r2: f64, p: f64, q: f64, k: f64) -> Self {
        Self { r1, r2, p, q, k }
    }

    /// Two massless load points (hand chain, load) and the spring balance.
    pub fn particles(self) -> ParticleSystem<Self, Self, (), (), Self> {
        ParticleSystem::new(self)
            .with_potential(self)
            .with_cartesian_forces(self)
    }

    /// The seed's virtual work of P and Q per unit δθ: P r₁ − Q (r₁ − r₂)/2.
    pub fn virtual_work(&self) -> f64 {
        self.p * self.r1 - self.q * (self.r1 - self.r2) * 0.5
    }

    /// The seed's answer: the effort that holds the load, P = Q (r₁ − r₂)/(2 r₁).
    pub fn balancing_pull(&self) -> f64 {
        self.q * (self.r1 - self.r2) / (2.0 * self.r1)
    }

    /// The spring balance's reading −k r₁ θ (the tension it adds to the hand chain).
    pub fn balance_reading(&self, theta: f64) -> f64 {
        -self.k * self.r1 * theta
    }

    /// The equilibrium rotation k r₁² θ = P r₁ − Q (r₁ − r₂)/2; `None` without a spring.
    pub fn closed_form_angle(&self) -> Option<f64> {
        (self.k > 0.0).then(|| self.virtual_work() / (self.k * self.r1 * self.r1))
    }
}

impl Particles for DifferentialPulley {
    const FIXED_DOF: Option<usize> = Some(1);
    fn dof(&self) -> usize {
        1
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        2
    }
    fn mass(&self, _j: usize) -> f64 {
        0.0
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        // Hand chain on the right of the large sheave, load below the axle.
        r[0] = D::from(self.r1);
        r[1] = -q[0] * self.r1;
        r[2] = D::zero();
        r[3] = q[0] * ((self.r1 - self.r2) * 0.5);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl CartesianForces for DifferentialPulley {
    fn forces<D: Scalar>(&self, _t: D, _r: &[D], _v: &[D], out: &mut [D]) {
        out[1] -= D::from(self.p);
        out[3] -= D::from(self.q);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Potential for DifferentialPulley {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let stretch = q[0] * self.r1;
        stretch * stretch * (0.5 * self.k)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn is_present(&self) -> bool {
        self.k != 0.0
    }
}

/// Example 3, the rhombus link (Fig. 3): four links of length l, ∠BCD = 2θ, vertical forces P at
/// A and C pulling them apart, horizontal forces Q at B and D pulling them apart.
///
/// With the centre O at the origin, A = (0, l cos θ), B = (l sin θ, 0), C = −A, D = −B, so
/// δ*W = 2{P δ(OA) + Q δ(OB)} = 2l(−P sin θ + Q cos θ) δθ and Q = P tan θ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RhombusLink {
    /// Link length.
    pub l: f64,
    /// Vertical force P at A and C.
    pub p: f64,
    /// Horizontal force Q at B and D.
    pub q: f64,
}

impl RhombusLink {
    /// A rhombus of links `l` with vertical forces `p` and horizontal forces `q`.
    pub fn new(l: f64, p: f64, q: f64) -> Self {
        Self { l, p, q }
    }

    /// Four massless load points; only statics applies.
    pub fn particles(self) -> ParticleSystem<Self, (), (), (), Self> {
        ParticleSystem::new(self).with_cartesian_forces(self)
    }

    /// The seed's virtual work per unit δθ: 2l(−P sin θ + Q cos θ).
    pub fn virtual_work(&self, theta: f64) -> f64 {
        2.0 * self.l * (-self.p * theta.sin() + self.q * theta.cos())
    }

    /// The seed's answer Q = P tan θ, solved for θ.
    pub fn closed_form_angle(&self) -> f64 {
        self.q.atan2(self.p)
    }
}

impl Particles for RhombusLink {
    const FIXED_DOF: Option<usize> = Some(1);
    fn dof(&self) -> usize {
        1
    }
    fn dim(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        4
    }
    fn mass(&self, _j: usize) -> f64 {
        0.0
    }
    fn positions<D: Scalar>(&self, _t: D, q: &[D], r: &mut [D]) {
        let (s, c) = q[0].sin_cos();
        let (oa, ob) = (c * self.l, s * self.l);
        // A, B, C, D
        let points = [
            (D::zero(), oa),
            (ob, D::zero()),
            (D::zero(), -oa),
            (-ob, D::zero()),
        ];
        for (j, (x, y)) in points.into_iter().enumerate() {
            r[2 * j] = x;
            r[2 * j + 1] = y;
        }
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl CartesianForces for RhombusLink {
    fn forces<D: Scalar>(&self, _t: D, _r: &[D], _v: &[D], out: &mut [D]) {
        out[1] += D::from(self.p); // A up
        out[2] += D::from(self.q); // B right
        out[5] -= D::from(self.p); // C down
        out[6] -= D::from(self.q); // D left
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Example 4, the spring-loaded rhombus (Fig. 4): links of length a hung from A, a spring of
/// stiffness k and natural length 2L₀ across BD, a mass M at the lower vertex C.
///
/// With ∠BCD = 2θ, BD = 2a sin θ and AC = 2a cos θ, so
/// U = 2k(L₀ − a sin θ)² − 2Mga cos θ and the equilibrium is Mg sin θ = 2k(L₀ − a sin θ) cos θ,
/// a quartic in sin θ with one root in 0 < sin θ < L₀/a. The mass is a real particle at
/// C = (0, −2a cos θ) in gravity g, so this scene also moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringRhombus {
    /// Link length a.
    pub a: f64,
    /// Spring stiffness k.
    pub k: f64,
    /// Half the spring's natural length, L₀.
    pub l0: f64,
    /// Hanging mass M.
    pub m: f64,
    /// Gravitational acceleration g.
    pub g: f64,
}

impl SpringRhombus {
    /// A rhombus of links `a`, spring `k` of natural length 2`l0`, mass `m` in gravity `g`.
    pub fn new(a: f64, k: f64, l0: f64, m: f64, g: f64) -> Self {
        Self { a, k, l0, m, g }
    }

    /// The mass at C in gravity with the spring as a potential.
    pub fn particles(self) -> ParticleSystem<Self, Self> {
        ParticleSystem::new(self)
            .with_gravity([0.0, -self.g, 0.0])
            .with_potential(self)
    }

    /// The virtual work per unit δθ, −∂U/∂θ = 2a{2k(L₀ − a sin θ) cos θ − Mg sin θ}: the spring
    /// pushes B and D apart (θ up), the weight pulls C down (θ down). The seed prints the
    /// opposite sign for δ*W = −δU (its expression is +δU); the equilibrium it derives from it,
    /// and that [`closed_form_angle`](Self::closed_form_angle) solves, is unaffected.
    pub fn virtual_work(&self, theta: f64) -> f64 {
        let (s, c) = theta.sin_cos();
        2.0 * self.a * (2.0 * self.k * (self.l0 - self.a * s) * c - self.m * self.g * s)
    }

    /// The seed's total potential U = 2k(L₀ − a sin θ)² − 2Mga cos θ.
    pub fn closed_form_potential(&self, theta: f64) -> f64 {
        let (s, c) = theta.sin_cos();
        let e = self.l0 - self.a * s;
        2.0 * self.k * e * e - 2.0 * self.m * self.g * self.a * c
    }

    /// The seed's answer: the root of Mg s = 2k(L₀ − a s)√(1 − s²), s = sin θ, in
    /// 0 < s < min(1, L₀/a). Squared, M²g²s² − 4k²(L₀ − a s)²(1 − s²) is strictly increasing on
    /// that interval, negative at 0 and positive at its end, so bisection in plain `f64` finds the
    /// one root to the last bit, independently of the AD solver.
    pub fn closed_form_angle(&self) -> f64 {
        let mg = self.m * self.g;
        let quartic = |s: f64| {
            let e = self.l0 - self.a * s;
            mg * mg * s * s - 4.0 * self.k * self.k * e * e * (1.0 - s * s)
        };
        let (mut lo, mut hi) = (0.0_f64, (self.l0 / self.a).min(1.0));
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if quartic(mid) < 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (0.5 * (lo + hi)).asin()
    }
}

impl Particles for SpringRhombus {
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
        r[0] = D::zero();
        r[1] = -q[0].cos() * (2.0 * self.a);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Potential for SpringRhombus {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        // ½ k (2L₀ − BD)², BD = 2a sin θ
        let e = -q[0].sin() * self.a + self.l0;
        e * e * (2.0 * self.k)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Example 5, two masses on two springs (Fig. 5): k₁ from the wall to m₁, k₂ from m₁ to m₂,
/// loads f₁ on m₁ and f₂ on m₂, displacements (x₁, x₂).
///
/// U = ½k₁x₁² + ½k₂(x₂ − x₁)², Q″ = (f₁, f₂), δ*W = −δU + f₁δx₁ + f₂δx₂ (eq. 29), so
/// x₁ = (f₁ + f₂)/k₁, x₂ = x₁ + f₂/k₂. T = ½m₁ẋ₁² + ½m₂ẋ₂², so the same scene also moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoSprings {
    /// First mass.
    pub m1: f64,
    /// Second mass.
    pub m2: f64,
    /// Wall spring.
    pub k1: f64,
    /// Coupling spring.
    pub k2: f64,
    /// Load on the first mass.
    pub f1: f64,
    /// Load on the second mass.
    pub f2: f64,
}

impl TwoSprings {
    /// Masses `m1`, `m2`, springs `k1`, `k2`, loads `f1`, `f2`.
    pub fn new(m1: f64, m2: f64, k1: f64, k2: f64, f1: f64, f2: f64) -> Self {
        Self {
            m1,
            m2,
            k1,
            k2,
            f1,
            f2,
        }
    }

    /// The energy-route system with the loads as generalized forces.
    pub fn system(self) -> System<Self, Self, (), Self> {
        System::new(2, self).with_potential(self).with_forces(self)
    }

    /// The seed's answer: x₁ = (f₁ + f₂)/k₁, x₂ = x₁ + f₂/k₂.
    pub fn closed_form_displacements(&self) -> [f64; 2] {
        let x1 = (self.f1 + self.f2) / self.k1;
        [x1, x1 + self.f2 / self.k2]
    }

    /// K = ∂²U/∂x² = [[k₁ + k₂, −k₂], [−k₂, k₂]].
    pub fn stiffness_matrix(&self) -> [[f64; 2]; 2] {
        [[self.k1 + self.k2, -self.k2], [-self.k2, self.k2]]
    }

    /// Eigenvalues of K, ascending: ((k₁ + 2k₂) ∓ √(k₁² + 4k₂²))/2 (the smaller one as
    /// det/λ₊ = k₁k₂/λ₊, free of cancellation).
    pub fn closed_form_eigenvalues(&self) -> [f64; 2] {
        let (k1, k2) = (self.k1, self.k2);
        let upper = 0.5 * (k1 + 2.0 * k2 + (k1 * k1 + 4.0 * k2 * k2).sqrt());
        [k1 * k2 / upper, upper]
    }
}

impl KineticEnergy for TwoSprings {
    const FIXED_DOF: Option<usize> = Some(2);
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.m1) + qd[1] * qd[1] * (0.5 * self.m2)
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

impl Potential for TwoSprings {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let stretch = q[1] - q[0];
        q[0] * q[0] * (0.5 * self.k1) + stretch * stretch * (0.5 * self.k2)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl GeneralizedForces for TwoSprings {
    fn forces<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out[0] += D::from(self.f1);
        out[1] += D::from(self.f2);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Scene for Lever {
    type System = ParticleSystem<Self, (), (), (), Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "lever",
        doc: "Seed §3.2 example 1: a lever with a vertical force ``p`` on arm ``l1`` and a \
              horizontal force ``q`` on arm ``l2``; coordinate ``theta``. Statics only \
              (massless).",
        parameters: &[
            Parameter::number("l1", 1.3, "arm carrying the vertical force"),
            Parameter::number("l2", 0.6, "arm carrying the horizontal force"),
            Parameter::number("p", 4.0, "vertical force"),
            Parameter::number("q", 9.0, "horizontal force"),
        ],
        coordinates: Coordinates::Fixed(&["theta"]),
        route: Route::Particle,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let n = |k| a.number(k);
        Ok(Self::new(n("l1"), n("l2"), n("p"), n("q")).particles())
    }
    fn drawing(_: &Arguments) -> Option<Drawing> {
        Some(Drawing {
            rods: vec![(-1, 0), (-1, 1)],
            marks: vec![[0.0, 0.0]],
            ..Drawing::default()
        })
    }
}

impl Scene for DifferentialPulley {
    type System = ParticleSystem<Self, Self, (), (), Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "differential_pulley",
        doc: "Seed §3.2 example 2: a chain block with sheaves ``r1`` > ``r2``, effort ``p``, \
              load ``q`` and a spring balance ``k``; coordinate ``theta``. Statics only.",
        parameters: &[
            Parameter::number("r1", 0.2, "radius of the larger sheave"),
            Parameter::number("r2", 0.17, "radius of the smaller sheave"),
            Parameter::number("p", 35.0, "effort on the hand chain"),
            Parameter::number("q", 800.0, "load"),
            Parameter::number("k", 0.0, "stiffness of the spring balance"),
        ],
        coordinates: Coordinates::Fixed(&["theta"]),
        route: Route::Particle,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let n = |k| a.number(k);
        Ok(Self::new(n("r1"), n("r2"), n("p"), n("q"), n("k")).particles())
    }
    fn drawing(a: &Arguments) -> Option<Drawing> {
        Some(Drawing {
            circles: vec![[0.0, 0.0, a.number("r1")], [0.0, 0.0, a.number("r2")]],
            marks: vec![[0.0, 0.0]],
            ..Drawing::default()
        })
    }
}

impl Scene for RhombusLink {
    type System = ParticleSystem<Self, (), (), (), Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "rhombus_link",
        doc: "Seed §3.2 example 3: four links ``l`` with forces ``p`` (vertical) and ``q`` \
              (horizontal); coordinate ``theta`` (half of ∠BCD). Statics only.",
        parameters: &[
            Parameter::number("l", 0.8, "link length"),
            Parameter::number("p", 3.0, "vertical force"),
            Parameter::number("q", 5.0, "horizontal force"),
        ],
        coordinates: Coordinates::Fixed(&["theta"]),
        route: Route::Particle,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        Ok(Self::new(a.number("l"), a.number("p"), a.number("q")).particles())
    }
    fn drawing(_: &Arguments) -> Option<Drawing> {
        Some(Drawing {
            rods: vec![(0, 1), (1, 2), (2, 3), (3, 0)],
            ..Drawing::default()
        })
    }
}

impl Scene for SpringRhombus {
    type System = ParticleSystem<Self, Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "spring_rhombus",
        doc: "Seed §3.2 example 4: a rhombus of links ``a`` with a spring ``k`` (natural \
              length 2 ``l0``) and a hanging mass ``m``; coordinate ``theta``.",
        parameters: &[
            Parameter::number("a", 0.7, "link length"),
            Parameter::number("k", 300.0, "spring stiffness"),
            Parameter::number("l0", 0.5, "half the natural length of the spring"),
            Parameter::number("m", 3.0, "hanging mass"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
        ],
        coordinates: Coordinates::Fixed(&["theta"]),
        route: Route::Particle,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let n = |k| a.number(k);
        Ok(Self::new(n("a"), n("k"), n("l0"), n("m"), n("g")).particles())
    }
}

impl Scene for TwoSprings {
    type System = System<Self, Self, (), Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "two_springs",
        doc: "Seed §3.2 example 5: two masses on two springs with loads ``f1``, ``f2``; \
              coordinates ``x1``, ``x2``.",
        parameters: &[
            Parameter::number("m1", 1.5, "first mass"),
            Parameter::number("m2", 0.5, "second mass"),
            Parameter::number("k1", 40.0, "stiffness of the spring from the ground to m₁"),
            Parameter::number("k2", 25.0, "stiffness of the spring from m₁ to m₂"),
            Parameter::number("f1", 2.0, "load on m₁"),
            Parameter::number("f2", -3.0, "load on m₂"),
        ],
        coordinates: Coordinates::Fixed(&["x1", "x2"]),
        route: Route::Energy,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let n = |k| a.number(k);
        Ok(Self::new(n("m1"), n("m2"), n("k1"), n("k2"), n("f1"), n("f2")).system())
    }
}

/// Masses on springs along a line: nothing to draw.
impl<U, R, Q> Drawn for System<TwoSprings, U, R, Q> {
    fn positions(&self, _t: &[f64], _q: &[f64]) -> Option<Positions> {
        None
    }
}
