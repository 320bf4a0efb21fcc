//! The N-link pendulum stated in Cartesian coordinates under rod constraints (issue 41; the
//! chain of benches/cartesian_chain.rs) against the same chain in its angles: the same
//! accelerations and motion, and rod tensions from λ against the double pendulum's closed form.

use lagrangian::integrators::{Method, Options, Output, solve};
use lagrangian::scenes::{DoublePendulum, NPendulum};
use lagrangian::{Constrained, Constraints, Dynamics, KineticEnergy, Potential, Scalar, System};

const G: f64 = 9.81;

/// Point masses in the plane, coordinates (x₁, y₁, …): T = ½ Σ mᵢ |ẋᵢ|², U = Σ mᵢ g yᵢ.
struct Bobs {
    masses: Vec<f64>,
}

impl KineticEnergy for Bobs {
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        let mut twice = D::zero();
        for (v, &m) in qd.chunks(2).zip(&self.masses) {
            twice += (v[0] * v[0] + v[1] * v[1]) * m;
        }
        twice * 0.5
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

impl Potential for Bobs {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let mut u = D::zero();
        for (r, &m) in q.chunks(2).zip(&self.masses) {
            u += r[1] * (m * G);
        }
        u
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Row i: |xᵢ − xᵢ₋₁|² − lᵢ² = 0, x₀ the pivot at the origin.
struct Rods {
    lengths: Vec<f64>,
}

impl Constraints for Rods {
    fn holonomic_count(&self) -> usize {
        self.lengths.len()
    }
    fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        let (mut px, mut py) = (D::zero(), D::zero());
        for (i, (o, &l)) in out.iter_mut().zip(&self.lengths).enumerate() {
            let (x, y) = (q[2 * i], q[2 * i + 1]);
            *o = (x - px) * (x - px) + (y - py) * (y - py) - l * l;
            (px, py) = (x, y);
        }
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn name(&self, row: usize) -> String {
        format!("rod {}", row + 1)
    }
}

fn cartesian(masses: &[f64], lengths: &[f64]) -> Constrained<System<Bobs, Bobs>, Rods> {
    let bobs = |masses: &[f64]| Bobs {
        masses: masses.to_vec(),
    };
    let system = System::new(2 * masses.len(), bobs(masses)).with_potential(bobs(masses));
    Constrained::new(
        system,
        Rods {
            lengths: lengths.to_vec(),
        },
    )
}

/// Positions, velocities and (given θ̈) accelerations of the bobs of a chain at angles `th`
/// from the downward vertical: rᵢ = Σ_{k≤i} l_k (sin θ_k, −cos θ_k).
fn bobs_of_angles(
    lengths: &[f64],
    th: &[f64],
    w: &[f64],
    alpha: &[f64],
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut r, mut v, mut a) = ([0.0; 2], [0.0; 2], [0.0; 2]);
    let (mut q, mut qd, mut qdd) = (Vec::new(), Vec::new(), Vec::new());
    for (((&l, &t), &w), &al) in lengths.iter().zip(th).zip(w).zip(alpha) {
        let (s, c) = t.sin_cos();
        r = [r[0] + l * s, r[1] - l * c];
        v = [v[0] + l * c * w, v[1] + l * s * w];
        a = [
            a[0] + l * (c * al - s * w * w),
            a[1] + l * (s * al + c * w * w),
        ];
        q.extend(r);
        qd.extend(v);
        qdd.extend(a);
    }
    (q, qd, qdd)
}

/// The angles and angular velocities of a chain at bob positions `q` and velocities `qd`: each
/// link's d = rᵢ − rᵢ₋₁ = l (sin θ, −cos θ) gives θ = atan2(dx, −dy), θ̇ = (dx ḋy − dy ḋx)/|d|².
fn angles_of_bobs(q: &[f64], qd: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut p, mut pv) = ([0.0; 2], [0.0; 2]);
    let (mut th, mut w) = (Vec::new(), Vec::new());
    for (r, v) in q.chunks(2).zip(qd.chunks(2)) {
        let d = [r[0] - p[0], r[1] - p[1]];
        let dv = [v[0] - pv[0], v[1] - pv[1]];
        th.push(d[0].atan2(-d[1]));
        w.push((d[0] * dv[1] - d[1] * dv[0]) / (d[0] * d[0] + d[1] * d[1]));
        (p, pv) = ([r[0], r[1]], [v[0], v[1]]);
    }
    (th, w)
}

#[test]
fn cartesian_chain_accelerates_as_the_chain_in_its_angles() {
    // At states with every link moving, the constrained q̈ of the Cartesian chain is the bobs'
    // acceleration from the hand-derived θ̈ of the minimal chain (NPendulum's closed form).
    let (masses, lengths) = ([1.2, 0.8, 1.5], [0.9, 1.1, 0.7]);
    let minimal = NPendulum::new(masses.to_vec(), lengths.to_vec(), G);
    let cart = cartesian(&masses, &lengths);
    for (th, w) in [
        ([0.5, 0.5, 0.5], [0.0, 0.0, 0.0]),
        ([0.3, -0.8, 1.9], [1.1, -0.4, 2.3]),
        ([-2.5, 0.1, 3.0], [-3.0, 0.7, 0.2]),
    ] {
        let alpha = minimal.closed_form_accelerations(&th, &w);
        let (q, qd, expected) = bobs_of_angles(&lengths, &th, &w, &alpha);
        let got = cart.evaluate(0.0, &q, &qd).unwrap();
        let scale = expected.iter().fold(G, |m, a| m.max(a.abs()));
        for (a, b) in got.accelerations.iter().zip(&expected) {
            assert!(
                (a - b).abs() < 1e-12 * scale,
                "{a} against {b} at θ = {th:?}"
            );
        }
    }
}

#[test]
fn cartesian_chain_moves_as_the_chain_in_its_angles() {
    // N = 3, released from rest at 0.5 rad each: the Cartesian run's end state at t = 2, mapped
    // to angles, is the minimal run's (both DOP853 at 1e-12; the Cartesian one projected back
    // onto the rods after every step).
    let (masses, lengths) = ([1.0, 1.0, 1.0], [1.0, 1.0, 1.0]);
    let minimal = NPendulum::new(masses.to_vec(), lengths.to_vec(), G).system();
    let cart = cartesian(&masses, &lengths);
    let (th0, w0) = ([0.5; 3], [0.0; 3]);
    let (x0, v0, _) = bobs_of_angles(&lengths, &th0, &w0, &[0.0; 3]);
    cart.check_consistent(0.0, &x0, &v0, None).unwrap();
    let options = Options::adaptive(1e-12, 1e-12).with_output(Output::Final);
    let span = (0.0, 2.0);
    let a = solve(&minimal, &th0, &w0, span, Method::Dop853, &options).unwrap();
    let b = solve(&cart, &x0, &v0, span, Method::Dop853, &options).unwrap();
    let (_, th, w) = a.last().unwrap();
    let (_, x, v) = b.last().unwrap();
    let (th_c, w_c) = angles_of_bobs(x, v);
    for i in 0..3 {
        assert!((th_c[i] - th[i]).abs() < 1e-8, "θ: {th_c:?} against {th:?}");
        assert!((w_c[i] - w[i]).abs() < 1e-8, "θ̇: {w_c:?} against {w:?}");
    }
    // On the rods at the end, and the energy kept.
    assert!(cart.residuals(2.0, x, v).unwrap().max_abs() < 1e-11);
    let (e0, e1) = (
        cart.energy(0.0, &x0, &v0).unwrap(),
        cart.energy(2.0, x, v).unwrap(),
    );
    assert!((e1 - e0).abs() < 1e-9 * e0.abs(), "energy {e0} → {e1}");
}

#[test]
fn cartesian_double_pendulum_rod_tensions_from_the_multipliers() {
    // Rod i's row |xᵢ − xᵢ₋₁|² − lᵢ² has gradient ±2 (xᵢ − xᵢ₋₁), so the rod pulls bob i with
    // 2λᵢ (xᵢ − xᵢ₋₁) = 2λᵢ lᵢ uᵢ: its tension is Tᵢ = −2 λᵢ lᵢ. Newton along the rods with the
    // bobs' accelerations from the closed-form θ̈ gives, in the angles,
    //   T₂ = m₂ (g cos θ₂ + l₂ θ̇₂² + l₁ θ̇₁² cos(θ₁ − θ₂) + l₁ θ̈₁ sin(θ₁ − θ₂)),
    //   T₁ = m₁ (g cos θ₁ + l₁ θ̇₁²) + T₂ cos(θ₁ − θ₂).
    let (m1, m2, l1, l2) = (1.3, 0.7, 1.1, 0.8);
    let dp = DoublePendulum::new(m1, m2, l1, l2, G);
    let cart = cartesian(&[m1, m2], &[l1, l2]);
    for (th, w) in [
        ([0.0, 0.0], [0.0, 0.0]),
        ([0.4, -0.3], [1.2, -0.7]),
        ([2.0, 2.9], [-0.5, 3.1]),
        ([-1.3, 0.6], [2.2, 0.4]),
    ] {
        let alpha = dp.closed_form_accelerations(&th, &w);
        let (q, qd, _) = bobs_of_angles(&[l1, l2], &th, &w, &alpha);
        let e = cart.evaluate(0.0, &q, &qd).unwrap();
        let (s12, c12) = (th[0] - th[1]).sin_cos();
        let t2 = m2
            * (G * th[1].cos() + l2 * w[1] * w[1] + l1 * w[0] * w[0] * c12 + l1 * alpha[0] * s12);
        let t1 = m1 * (G * th[0].cos() + l1 * w[0] * w[0]) + t2 * c12;
        let tensions = [-2.0 * e.multipliers[0] * l1, -2.0 * e.multipliers[1] * l2];
        let scale = (m1 + m2) * G;
        for (got, want) in tensions.iter().zip([t1, t2]) {
            assert!(
                (got - want).abs() < 1e-12 * scale,
                "tensions {tensions:?} against {:?} at θ = {th:?}",
                [t1, t2]
            );
        }
        // The reactions do no work (Gᵀλ·q̇ = 0), and each bob obeys Newton's law
        // mᵢ ẍᵢ = mᵢ g + Rᵢ with the reactions Gᵀλ.
        let power: f64 = e.reaction_forces.iter().zip(&qd).map(|(r, v)| r * v).sum();
        assert!(power.abs() < 1e-12 * scale * (w[0].abs() + w[1].abs() + 1.0));
        for (i, m) in [m1, m1, m2, m2].into_iter().enumerate() {
            let gravity = if i % 2 == 1 { -m * G } else { 0.0 };
            let newton = m * e.accelerations[i] - gravity - e.reaction_forces[i];
            assert!(
                newton.abs() < 1e-12 * scale,
                "bob {}: {newton:e}",
                i / 2 + 1
            );
        }
    }
}
