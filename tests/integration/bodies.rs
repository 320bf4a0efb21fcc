//! The rigid-body route against closed forms and independent references: the compound pendulum,
//! Euler's equations of a free asymmetric body (and its intermediate-axis flip), the heavy
//! symmetric top's nutation between the roots of its cubic, the energy route of the same T, the
//! particle route of point masses, and the typed errors.

use lagrangian::integrators::{Method, Options, Output, solve};
use lagrangian::rigid::{Axis, Pose, Quaternion, Rotation};
use lagrangian::scenes::{DoublePendulum, SpatialChain};
use lagrangian::{
    BodySystem, Dynamics, Error, KineticEnergy, Potential, RigidBodies, Scalar, System,
};

fn states(n: usize, k: usize) -> (Vec<f64>, Vec<f64>) {
    let q = (0..n)
        .map(|i| 0.3 + 0.7 * ((i * 7 + k * 3) as f64).sin())
        .collect();
    let qd = (0..n)
        .map(|i| -0.4 + 1.1 * ((i * 5 + k * 11) as f64).cos())
        .collect();
    (q, qd)
}

fn close(what: &str, got: &[f64], want: &[f64], tol: f64) {
    let scale = want.iter().fold(1.0_f64, |s, x| s.max(x.abs()));
    for (g, w) in got.iter().zip(want) {
        assert!(
            (g - w).abs() <= tol * scale,
            "{what}: got {got:?}, want {want:?}"
        );
    }
}

/// A uniform box a × b × c hinged about the world axis `axis` through a point at distance `d`
/// from its centre (along the body's −z axis), in gravity along −z.
struct Compound {
    m: f64,
    inertia: [f64; 3],
    d: f64,
    axis: Axis,
}

impl RigidBodies for Compound {
    const FIXED_DOF: Option<usize> = Some(1);
    fn dof(&self) -> usize {
        1
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        self.m
    }
    fn inertia(&self, _j: usize) -> [[f64; 3]; 3] {
        let i = self.inertia;
        [[i[0], 0.0, 0.0], [0.0, i[1], 0.0], [0.0, 0.0, i[2]]]
    }
    fn poses<D: Scalar>(&self, _t: D, q: &[D], out: &mut [Pose<D>]) {
        let r = Rotation::about(self.axis, q[0]);
        let centre = r.apply([D::zero(), D::zero(), D::from(-self.d)]);
        out[0] = Pose::new(centre, r);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// T = ½ J θ̇², U = −m g d cos θ: the compound pendulum by hand.
struct ByHand {
    j: f64,
    mgd: f64,
}

impl KineticEnergy for ByHand {
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd[0] * qd[0] * (0.5 * self.j)
    }
}

impl Potential for ByHand {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].cos() * self.mgd
    }
}

#[test]
fn compound_pendulum_equals_the_energy_route() {
    let g = 9.81;
    for (axis, k) in [(Axis::X, 0), (Axis::Y, 1)] {
        let body = Compound {
            m: 1.7,
            inertia: [0.31, 0.23, 0.05],
            d: 0.45,
            axis,
        };
        // About x the hinge sees I_xx, about y I_yy; plus m d² (Steiner).
        let j = body.inertia[k] + body.m * body.d * body.d;
        let mgd = body.m * g * body.d;
        let hand = System::new(1, ByHand { j, mgd }).with_potential(ByHand { j, mgd });
        let sys = BodySystem::new(body).with_gravity([0.0, 0.0, -g]);
        for s in 0..10 {
            let (q, qd) = states(1, s);
            let a = sys.accelerations(0.0, &q, &qd).unwrap();
            let b = hand.accelerations(0.0, &q, &qd).unwrap();
            assert!((a[0] - b[0]).abs() <= 1e-13, "{a} vs {b}");
            assert!((a[0] + mgd / j * q[0].sin()).abs() <= 1e-13);
            let (ea, eb) = (
                sys.energy(0.0, &q, &qd).unwrap(),
                hand.energy(0.0, &q, &qd).unwrap(),
            );
            assert!((ea - eb).abs() <= 1e-13 * eb.abs().max(1.0), "{ea} vs {eb}");
            let m = sys.mass_matrix(0.0, &q, &qd).unwrap();
            assert!((m[(0, 0)] - j).abs() <= 1e-14);
        }
    }
}

#[test]
fn spatial_chain_equals_its_energy_route() {
    for n in [1, 2, 3, 5, 6] {
        let masses: Vec<f64> = (0..n).map(|i| 0.5 + 0.2 * i as f64).collect();
        let lengths: Vec<f64> = (0..n).map(|i| 1.0 - 0.07 * i as f64).collect();
        let sys = SpatialChain::new(masses, lengths, 0.08, 9.81).system();
        let mirror = sys.energy_route();
        for k in 0..4 {
            let (q, qd) = states(n, k);
            let a = sys.accelerations(0.0, &q, &qd).unwrap();
            let b = mirror.accelerations(0.0, &q, &qd).unwrap();
            close("q̈", a.as_slice(), b.as_slice(), 1e-12);
            let (pa, pb) = (
                sys.momenta(0.0, &q, &qd).unwrap(),
                mirror.momenta(0.0, &q, &qd).unwrap(),
            );
            close("p", pa.as_slice(), pb.as_slice(), 1e-13);
            let (ma, mb) = (
                sys.mass_matrix(0.0, &q, &qd).unwrap(),
                mirror.mass_matrix(0.0, &q, &qd).unwrap(),
            );
            close("M", ma.as_slice(), mb.as_slice(), 1e-13);
            let mut ga = vec![0.0; n];
            let mut gb = vec![0.0; n];
            sys.potential_gradient_into(0.0, &q, &mut ga);
            mirror.potential_gradient_into(0.0, &q, &mut gb);
            close("∂U/∂q", &ga, &gb, 1e-13);
        }
    }
}

/// One free body turning about its fixed centre, oriented by a quaternion (4 coordinates).
struct Free {
    inertia: [f64; 3],
}

impl RigidBodies for Free {
    fn dof(&self) -> usize {
        4
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        1.0
    }
    fn inertia(&self, _j: usize) -> [[f64; 3]; 3] {
        let i = self.inertia;
        [[i[0], 0.0, 0.0], [0.0, i[1], 0.0], [0.0, 0.0, i[2]]]
    }
    fn poses<D: Scalar>(&self, _t: D, q: &[D], out: &mut [Pose<D>]) {
        out[0] = Pose::from_quaternion([D::zero(); 3], Quaternion::from_slice(q));
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Ω in body axes from a quaternion state: Ω = 2 conj(q) ⊗ q̇ (vector part), for unit q.
fn body_rate(q: &[f64], qd: &[f64]) -> [f64; 3] {
    let p = Quaternion::from_slice(q).conjugate() * Quaternion::from_slice(qd);
    [2.0 * p.x, 2.0 * p.y, 2.0 * p.z]
}

/// Euler's equations I Ω̇ = −Ω × IΩ, integrated by classical RK4 with `steps` steps.
fn euler_equations(i: [f64; 3], w0: [f64; 3], t: f64, steps: usize) -> [f64; 3] {
    let f = |w: [f64; 3]| {
        [
            (i[1] - i[2]) / i[0] * w[1] * w[2],
            (i[2] - i[0]) / i[1] * w[2] * w[0],
            (i[0] - i[1]) / i[2] * w[0] * w[1],
        ]
    };
    let h = t / steps as f64;
    let mut w = w0;
    for _ in 0..steps {
        let add = |a: [f64; 3], b: [f64; 3], s: f64| [0, 1, 2].map(|k| a[k] + s * b[k]);
        let k1 = f(w);
        let k2 = f(add(w, k1, h / 2.0));
        let k3 = f(add(w, k2, h / 2.0));
        let k4 = f(add(w, k3, h));
        w = [0, 1, 2].map(|k| w[k] + h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k]));
    }
    w
}

/// The state (q, q̇) of a body at orientation `q` turning at Ω (body axes): q̇ = ½ q ⊗ (0, Ω).
fn quaternion_state(q: Quaternion<f64>, w: [f64; 3]) -> (Vec<f64>, Vec<f64>) {
    let qd = q * Quaternion::new(0.0, 0.5 * w[0], 0.5 * w[1], 0.5 * w[2]);
    (vec![q.w, q.x, q.y, q.z], vec![qd.w, qd.x, qd.y, qd.z])
}

#[test]
fn free_asymmetric_body_follows_eulers_equations_and_flips() {
    let inertia = [1.0, 2.0, 3.0];
    let sys = BodySystem::new(Free { inertia });
    // Near the intermediate axis: the spin turns over (Dzhanibekov's flip) and back.
    let w0 = [1e-3, 2.0, 1e-3];
    let q0 = Quaternion::about_axis([1.0, 2.0, -0.5], 0.8);
    let (q, qd) = quaternion_state(q0, w0);
    let times: Vec<f64> = (1..=40).map(|k| 0.25 * k as f64).collect();
    let options = Options::adaptive(1e-13, 1e-13).with_output(Output::Times(times.clone()));
    let run = solve(&sys, &q, &qd, (0.0, 10.0), Method::Dop853, &options).unwrap();
    let mut signs = vec![];
    for (k, &t) in times.iter().enumerate() {
        let got = body_rate(run.q_at(k), run.qd_at(k));
        let want = euler_equations(inertia, w0, t, 4000 * (k + 1));
        close(&format!("Ω at t = {t}"), &got, &want, 1e-9);
        // The quaternion stays on the unit sphere (the regularizing term does not move it off).
        let n: f64 = run.q_at(k).iter().map(|x| x * x).sum();
        assert!((n - 1.0).abs() < 1e-10, "‖q‖² = {n} at t = {t}");
        signs.push(got[1].signum());
    }
    assert!(
        signs.contains(&-1.0) && signs.contains(&1.0),
        "no flip: {signs:?}"
    );
    // About the largest axis the spin stays put: Ω₃ keeps its sign and size.
    let (q, qd) = quaternion_state(q0, [1e-3, 1e-3, 2.0]);
    let run = solve(&sys, &q, &qd, (0.0, 10.0), Method::Dop853, &options).unwrap();
    for k in 0..times.len() {
        let w = body_rate(run.q_at(k), run.qd_at(k));
        assert!((w[2] - 2.0).abs() < 1e-5, "{w:?}");
    }
}

/// A symmetric top on a fixed tip, centre of mass at distance l on its axis, in Euler angles
/// (φ, θ, ψ) of the sequence z-x-z.
struct Top {
    m: f64,
    l: f64,
    i1: f64,
    i3: f64,
}

impl RigidBodies for Top {
    const FIXED_DOF: Option<usize> = Some(3);
    fn dof(&self) -> usize {
        3
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        self.m
    }
    fn inertia(&self, _j: usize) -> [[f64; 3]; 3] {
        [
            [self.i1, 0.0, 0.0],
            [0.0, self.i1, 0.0],
            [0.0, 0.0, self.i3],
        ]
    }
    fn poses<D: Scalar>(&self, _t: D, q: &[D], out: &mut [Pose<D>]) {
        let r = Rotation::from_euler([Axis::Z, Axis::X, Axis::Z], [q[0], q[1], q[2]]);
        let c = r.column(2).map(|x| x * self.l);
        out[0] = Pose::new(c, r);
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

#[test]
fn heavy_top_nutates_between_the_roots_of_its_cubic() {
    let (m, l, g) = (1.0, 0.4, 9.81);
    let top = Top {
        m,
        l,
        i1: 0.05,
        i3: 0.08,
    };
    let ip = top.i1 + m * l * l; // about the tip
    let (phid, theta0, psid) = (1.5, 0.5_f64, 30.0);
    let sys = BodySystem::new(top).with_gravity([0.0, 0.0, -g]);
    // The constants of the motion and the cubic f(u) = (α − βu)(1 − u²) − (b − au)², u = cos θ.
    let w3 = psid + phid * theta0.cos();
    let (a, b) = (
        0.08 * w3 / ip,
        (ip * phid * theta0.sin().powi(2) + 0.08 * w3 * theta0.cos()) / ip,
    );
    let e = 0.5 * ip * (phid * theta0.sin()).powi(2) + m * g * l * theta0.cos();
    let (alpha, beta) = (2.0 * e / ip, 2.0 * m * g * l / ip);
    let (c3, c2, c1) = (beta, -alpha - a * a, -beta + 2.0 * a * b);
    let u0 = theta0.cos();
    // f(u) / (u − u0) = c3 u² + d1 u + d0 (u0 is a root: θ̇ = 0 at the start).
    let d1 = c2 + c3 * u0;
    let d0 = c1 + d1 * u0;
    let disc = (d1 * d1 - 4.0 * c3 * d0).sqrt();
    let u1 = [(-d1 - disc) / (2.0 * c3), (-d1 + disc) / (2.0 * c3)]
        .into_iter()
        .find(|u| (-1.0..1.0).contains(u))
        .unwrap();
    let theta1 = u1.acos();
    assert!(theta1 > theta0 + 1e-3, "the top falls: θ₁ = {theta1}");
    let q = [0.0, theta0, 0.0];
    let qd = [phid, 0.0, psid];
    let times: Vec<f64> = (1..=8000).map(|k| 2.5e-4 * k as f64).collect();
    let options = Options::adaptive(1e-12, 1e-12).with_output(Output::Times(times.clone()));
    let run = solve(&sys, &q, &qd, (0.0, 2.0), Method::Dop853, &options).unwrap();
    let h0 = sys.energy(0.0, &q, &qd).unwrap();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..times.len() {
        let th = run.q_at(k)[1];
        (lo, hi) = (lo.min(th), hi.max(th));
        // The conserved p_φ, p_ψ and energy.
        let p = sys.momenta(0.0, run.q_at(k), run.qd_at(k)).unwrap();
        assert!((p[0] - ip * b).abs() < 1e-9, "p_φ {} vs {}", p[0], ip * b);
        assert!((p[2] - 0.08 * w3).abs() < 1e-9);
        let h = sys.energy(0.0, run.q_at(k), run.qd_at(k)).unwrap();
        assert!((h - h0).abs() < 1e-9 * h0.abs(), "{h} vs {h0}");
    }
    assert!(lo >= theta0 - 1e-9, "below θ₀: {lo} < {theta0}");
    assert!(hi <= theta1 + 1e-9, "beyond θ₁: {hi} > {theta1}");
    // Sampled every 2.5e-4: the turning points are found to ½ θ̈ Δt² ≲ 1e-6.
    assert!(
        (hi - theta1).abs() < 2e-6,
        "θ max {hi} vs the root {theta1}"
    );
}

#[test]
fn spatial_chain_conserves_energy() {
    let sys = SpatialChain::uniform(4, 1.0, 0.8, 0.05, 9.81).system();
    let (q, qd) = states(4, 2);
    let h0 = sys.energy(0.0, &q, &qd).unwrap();
    let options = Options::adaptive(1e-12, 1e-12).with_output(Output::Every(50));
    let run = solve(&sys, &q, &qd, (0.0, 5.0), Method::Dop853, &options).unwrap();
    for k in 0..run.len() {
        let h = sys.energy(run.t[k], run.q_at(k), run.qd_at(k)).unwrap();
        assert!(
            (h - h0).abs() < 1e-9 * h0.abs(),
            "h {h} vs {h0} at {}",
            run.t[k]
        );
    }
    // Hanging straight down is a stable equilibrium: no force at rest.
    let a = sys.accelerations(0.0, &[0.0; 4], &[0.0; 4]).unwrap();
    assert!(a.iter().all(|x| x.abs() < 1e-14), "{a}");
}

/// The double pendulum's bobs as bodies of zero inertia in the plane z = 0.
struct Bobs(DoublePendulum);

impl RigidBodies for Bobs {
    fn dof(&self) -> usize {
        2
    }
    fn count(&self) -> usize {
        2
    }
    fn mass(&self, j: usize) -> f64 {
        [self.0.m1, self.0.m2][j]
    }
    fn inertia(&self, _j: usize) -> [[f64; 3]; 3] {
        [[0.0; 3]; 3]
    }
    fn poses<D: Scalar>(&self, t: D, q: &[D], out: &mut [Pose<D>]) {
        let mut r = [D::zero(); 4];
        lagrangian::Particles::positions(&self.0, t, q, &mut r);
        for (j, o) in out.iter_mut().enumerate() {
            // Any rotation: with zero inertia it carries no energy.
            let rot = Rotation::about_z(q[j]);
            *o = Pose::new([r[2 * j], r[2 * j + 1], D::zero()], rot);
        }
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

#[test]
fn point_masses_equal_the_particle_route() {
    let dp = DoublePendulum::new(1.3, 0.7, 1.1, 0.8, 9.81);
    let bodies = BodySystem::new(Bobs(dp)).with_gravity([0.0, -9.81, 0.0]);
    let particles = dp.particles();
    for k in 0..20 {
        let (q, qd) = states(2, k);
        let a = bodies.accelerations(0.0, &q, &qd).unwrap();
        let b = particles.accelerations(0.0, &q, &qd).unwrap();
        close("q̈", a.as_slice(), b.as_slice(), 1e-14);
        let exact = dp.closed_form_accelerations(&q, &qd);
        close("closed form", a.as_slice(), &exact, 1e-12);
    }
}

/// A body whose orientation is a shear, or not finite.
struct Broken(f64);

impl RigidBodies for Broken {
    fn dof(&self) -> usize {
        1
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        1.0
    }
    fn inertia(&self, _j: usize) -> [[f64; 3]; 3] {
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    }
    fn poses<D: Scalar>(&self, _t: D, q: &[D], out: &mut [Pose<D>]) {
        let (o, l) = (D::zero(), D::one());
        let r = if self.0.is_finite() {
            Rotation::from_matrix([[l, q[0] * self.0, o], [o, l, o], [o, o, l]])
        } else {
            Rotation::about_axis([0.0; 3], q[0])
        };
        out[0] = Pose::new([q[0], o, o], r);
    }
}

#[test]
fn errors_are_typed() {
    let shear = BodySystem::new(Broken(0.5));
    match shear.accelerations(0.0, &[0.2], &[0.1]) {
        Err(Error::InvalidInput { what, why }) => {
            assert_eq!(what, "rigid body orientation");
            assert!(
                why.contains("body 0") && why.contains("not a rotation"),
                "{why}"
            );
        }
        other => panic!("{other:?}"),
    }
    // At q = 0 the shear vanishes: a rotation, accepted.
    assert!(shear.accelerations(0.0, &[0.0], &[0.1]).is_ok());
    let nan = BodySystem::new(Broken(f64::NAN));
    assert!(matches!(
        nan.accelerations(0.0, &[0.2], &[0.1]),
        Err(Error::NonFinite { .. })
    ));
    let chain = SpatialChain::uniform(2, 1.0, 1.0, 0.05, 9.81).system();
    assert!(matches!(
        chain.accelerations(0.0, &[f64::NAN, 0.0], &[0.0, 0.0]),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        chain.accelerations(0.0, &[0.0], &[0.0]),
        Err(Error::DimensionMismatch { .. })
    ));
}

/// A hinged body whose inertia tensor (or mass) is not one.
struct BadInertia([[f64; 3]; 3], f64);

impl RigidBodies for BadInertia {
    fn dof(&self) -> usize {
        1
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        self.1
    }
    fn inertia(&self, _j: usize) -> [[f64; 3]; 3] {
        self.0
    }
    fn poses<D: Scalar>(&self, _t: D, q: &[D], out: &mut [Pose<D>]) {
        out[0] = Pose::new([D::zero(); 3], Rotation::about_x(q[0]));
    }
}

#[test]
fn bad_masses_and_inertia_are_typed_errors() {
    let good = [[1.0, 0.1, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 2.5]];
    assert!(
        BodySystem::new(BadInertia(good, 1.0))
            .accelerations(0.0, &[0.3], &[0.1])
            .is_ok()
    );
    let asymmetric = [[1.0, 0.1, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.5]];
    let negative = [[-1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.5]];
    let nan = [[f64::NAN, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.5]];
    for (inertia, mass) in [(asymmetric, 1.0), (negative, 1.0), (nan, 1.0), (good, -1.0)] {
        match BodySystem::new(BadInertia(inertia, mass)).accelerations(0.0, &[0.3], &[0.1]) {
            Err(Error::InvalidInput { what, why }) => {
                assert_eq!(what, "rigid body");
                assert!(why.contains("body 0"), "{why}");
            }
            other => panic!("{inertia:?}, {mass}: {other:?}"),
        }
    }
}

#[test]
fn two_link_arm_modes_are_two_compound_pendulums() {
    // Hanging at rest, joint 1 (about x) and joint 2 (about y) decouple to first order: the
    // whole arm swings about x as one body, and link 2 about y on a fixed hinge.
    let (m1, m2, l1, l2, a, g) = (1.3, 0.7, 0.9, 0.6, 0.08, 9.81);
    let arm = SpatialChain::new(vec![m1, m2], vec![l1, l2], a, g);
    let side = |m: f64, l: f64| m * (3.0 * a * a + l * l) / 12.0;
    let whole = (g * (m1 * l1 / 2.0 + m2 * (l1 + l2 / 2.0)))
        / (side(m1, l1) + m1 * l1 * l1 / 4.0 + side(m2, l2) + m2 * (l1 + l2 / 2.0).powi(2));
    let lower = (m2 * g * l2 / 2.0) / (side(m2, l2) + m2 * l2 * l2 / 4.0);
    let modes = lagrangian::modes(&arm.system(), 0.0, &[0.0, 0.0]).unwrap();
    let mut want = [whole, lower];
    want.sort_by(f64::total_cmp);
    for (got, want) in modes.omega_squared.iter().zip(want) {
        assert!((got - want).abs() < 1e-12 * want, "ω² {got} vs {want}");
    }
    assert_eq!(modes.stability, lagrangian::Stability::Stable);
}
