//! Constrained systems (issue 41, first slice): Lagrange's equations of the first kind at a
//! state, against closed forms.

use crate::common::Rng;
use lagrangian::{
    Constrained, Constraints, Error, GeneralizedForces, KineticEnergy, PROJECTION_TOLERANCE,
    Potential, Scalar, System,
};

const G: f64 = 9.81;

/// ½ Σ mᵢ q̇ᵢ².
pub(crate) struct Diagonal(pub(crate) Vec<f64>);
impl KineticEnergy for Diagonal {
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd.iter()
            .zip(&self.0)
            .fold(D::zero(), |s, (&v, &m)| s + v * v * (0.5 * m))
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

/// A linear potential Σ cᵢ qᵢ (uniform gravity, a slope).
pub(crate) struct Linear(pub(crate) Vec<f64>);
impl Potential for Linear {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q.iter()
            .zip(&self.0)
            .fold(D::zero(), |s, (&x, &c)| s + x * c)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Holonomic rows from a closure-free list of shapes (enough for the tests).
#[derive(Clone, Copy)]
pub(crate) enum Row {
    /// x² + y² − l².
    Circle(f64),
    /// x − r θ.
    Rolling(f64),
    /// y − c.
    Line(f64),
    /// −x sin ωt + y cos ωt (a wire through the origin turning at ω).
    Wire(f64),
    /// x − sin t.
    Driven,
    /// q₀² q₁ + sin(q₀ q₁ t) (for the AD checks).
    Mixed,
    /// x² + 1 (no real solution).
    Hopeless,
}

impl Row {
    fn eval<D: Scalar>(self, t: D, q: &[D]) -> D {
        match self {
            Row::Circle(l) => q[0] * q[0] + q[1] * q[1] - l * l,
            Row::Rolling(r) => q[0] - q[1] * r,
            Row::Line(c) => q[1] - c,
            Row::Wire(w) => -q[0] * (t * w).sin() + q[1] * (t * w).cos(),
            Row::Driven => q[0] - t.sin(),
            Row::Mixed => q[0] * q[0] * q[1] + (q[0] * q[1] * t).sin(),
            Row::Hopeless => q[0] * q[0] + 1.0,
        }
    }
}

/// Velocity rows.
#[derive(Clone, Copy)]
pub(crate) enum VRow {
    /// sin φ ẋ − cos φ ẏ (knife edge, q = (x, y, φ)).
    Knife,
    /// ẋ² + ẏ² − 1 (not linear in q̇).
    Speed,
    /// cos(t) ẋ + x ẏ + t q₀ (for the AD checks).
    Mixed,
}

impl VRow {
    fn eval<D: Scalar>(self, t: D, q: &[D], qd: &[D]) -> D {
        match self {
            VRow::Knife => q[2].sin() * qd[0] - q[2].cos() * qd[1],
            VRow::Speed => qd[0] * qd[0] + qd[1] * qd[1] - 1.0,
            VRow::Mixed => t.cos() * qd[0] + q[0] * qd[1] + t * q[0],
        }
    }
}

pub(crate) struct Rows {
    pub(crate) holonomic: Vec<Row>,
    pub(crate) velocity: Vec<VRow>,
}

impl Constraints for Rows {
    fn holonomic_count(&self) -> usize {
        self.holonomic.len()
    }
    fn holonomic<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
        for (o, r) in out.iter_mut().zip(&self.holonomic) {
            *o = r.eval(t, q);
        }
    }
    fn velocity_count(&self) -> usize {
        self.velocity.len()
    }
    fn velocity<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        for (o, r) in out.iter_mut().zip(&self.velocity) {
            *o = r.eval(t, q, qd);
        }
    }
    fn name(&self, row: usize) -> String {
        format!("row {row}")
    }
}

pub(crate) fn holonomic(rows: &[Row]) -> Rows {
    Rows {
        holonomic: rows.to_vec(),
        velocity: Vec::new(),
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

pub(crate) fn point(m: f64, gravity: bool) -> System<Diagonal, Linear> {
    System::new(2, Diagonal(vec![m, m]))
        .with_potential(Linear(vec![0.0, if gravity { m * G } else { 0.0 }]))
}

#[test]
fn cartesian_pendulum_matches_minimal_coordinates_and_rod_tension() {
    let (m, l) = (1.7, 0.8);
    let pendulum = Constrained::new(point(m, true), holonomic(&[Row::Circle(l)]));
    assert_eq!(pendulum.rows(), 1);
    let mut rng = Rng(41);
    for _ in 0..50 {
        let (th, w) = (rng.uniform(-3.1, 3.1), rng.uniform(-4.0, 4.0));
        let q = [l * th.sin(), -l * th.cos()];
        let qd = [l * th.cos() * w, l * th.sin() * w];
        let e = pendulum.evaluate(0.3, &q, &qd).unwrap();
        let thdd = -G / l * th.sin();
        let want = [
            l * (th.cos() * thdd - th.sin() * w * w),
            l * (th.sin() * thdd + th.cos() * w * w),
        ];
        for i in 0..2 {
            assert!(close(e.accelerations[i], want[i], 1e-13), "{e:?} {want:?}");
        }
        // R = Gᵀλ = 2λ (x, y); the rod pulls towards the pivot with the tension T: R = −T q/l.
        let tension = -2.0 * e.multipliers[0] * l;
        let v = l * w;
        assert!(close(tension, m * (v * v / l + G * th.cos()), 1e-13));
        for i in 0..2 {
            assert!(close(e.reaction_forces[i], -tension * q[i] / l, 1e-13));
        }
        // The reaction does no work on the motion (R·q̇ = 0) and the state is consistent.
        let power = e
            .reaction_forces
            .dot(&nalgebra::DVector::from_row_slice(&qd));
        assert!(power.abs() < 1e-12 * (1.0 + tension.abs() * v.abs()));
        assert!(pendulum.residuals(0.3, &q, &qd).unwrap().max_abs() < 1e-14);
    }
}

#[test]
fn rolling_cylinder_acceleration_and_friction() {
    // Seed eq. 45–48: (m + J/r²) ẍ = m g sin α, with x = rθ (x down the slope).
    let (m, r, alpha) = (2.0, 0.3, 0.4_f64);
    let j = 0.5 * m * r * r;
    let cylinder = System::new(2, Diagonal(vec![m, j]))
        .with_potential(Linear(vec![-m * G * alpha.sin(), 0.0]));
    let rolling = Constrained::new(cylinder, holonomic(&[Row::Rolling(r)]));
    let mut rng = Rng(45);
    for _ in 0..20 {
        let (x, v) = (rng.uniform(-2.0, 2.0), rng.uniform(-3.0, 3.0));
        let (q, qd) = ([x, x / r], [v, v / r]);
        let e = rolling.evaluate(0.0, &q, &qd).unwrap();
        let xdd = m * G * alpha.sin() / (m + j / (r * r));
        assert!(close(e.accelerations[0], xdd, 1e-14));
        assert!(close(e.accelerations[1], xdd / r, 1e-14));
        // G = (1, −r), R = (λ, −rλ); friction F up the slope at the contact: R = (−F, F r).
        let friction = -e.multipliers[0];
        assert!(close(friction, j * xdd / (r * r), 1e-14));
        assert!(close(e.reaction_forces[0], -friction, 1e-14));
        assert!(close(e.reaction_forces[1], friction * r, 1e-14));
    }
}

/// A force F along x.
pub(crate) struct PushX(pub(crate) f64);
impl GeneralizedForces for PushX {
    fn forces<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out[0] += self.0;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

#[test]
fn knife_edge_side_force() {
    let (m, inertia, f) = (1.3, 0.2, 0.7);
    let knife = |force: f64| {
        Constrained::new(
            System::new(3, Diagonal(vec![m, m, inertia])).with_forces(PushX(force)),
            Rows {
                holonomic: Vec::new(),
                velocity: vec![VRow::Knife],
            },
        )
    };
    let mut rng = Rng(7);
    for _ in 0..30 {
        let (phi, v, w) = (
            rng.uniform(-3.0, 3.0),
            rng.uniform(-2.0, 2.0),
            rng.uniform(-2.0, 2.0),
        );
        let q = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), phi];
        let qd = [v * phi.cos(), v * phi.sin(), w];
        let (s, c) = phi.sin_cos();
        // m ẍ = F + λ s, m ÿ = −λ c, sin φ ẍ − cos φ ÿ = −φ̇ v  ⇒  λ = −m φ̇ v − F s.
        let e = knife(f).evaluate(0.0, &q, &qd).unwrap();
        let lambda = -m * w * v - f * s;
        assert!(close(e.multipliers[0], lambda, 1e-14));
        let want = [(f + lambda * s) / m, -lambda * c / m, 0.0];
        for i in 0..3 {
            assert!(close(e.accelerations[i], want[i], 1e-14), "{e:?}");
            assert!(close(
                e.reaction_forces[i],
                [lambda * s, -lambda * c, 0.0][i],
                1e-14
            ));
        }
        // No force: uniform circular motion, centripetal side force of size m v ω along the
        // normal (−sin φ, cos φ) turned towards the centre.
        let e = knife(0.0).evaluate(0.0, &q, &qd).unwrap();
        let side = m * v * w;
        assert!(close(e.reaction_forces[0], -side * s, 1e-14));
        assert!(close(e.reaction_forces[1], side * c, 1e-14));
        let speed_change = e.accelerations[0] * c + e.accelerations[1] * s;
        assert!(speed_change.abs() < 1e-14);
        assert!(close(e.reaction_forces.norm(), side.abs(), 1e-14));
    }
}

#[test]
fn bead_on_a_rotating_wire() {
    // A wire through the origin at angle ωt; the bead at radius r: r̈ = ω² r, so
    // ẍ = −2 ṙ ω sin ωt, ÿ = 2 ṙ ω cos ωt, and the wire's push is m times that (Coriolis).
    let (m, w) = (0.9, 1.7);
    let bead = Constrained::new(point(m, false), holonomic(&[Row::Wire(w)]));
    let mut rng = Rng(3);
    for _ in 0..30 {
        let (t, r, rd) = (
            rng.uniform(-5.0, 5.0),
            rng.uniform(-2.0, 2.0),
            rng.uniform(-2.0, 2.0),
        );
        let (s, c) = (w * t).sin_cos();
        let q = [r * c, r * s];
        let qd = [rd * c - r * w * s, rd * s + r * w * c];
        // γ by hand: −2ω (ẋ cos ωt + ẏ sin ωt) + ω² (x sin ωt − y cos ωt).
        let gamma = bead.gamma(t, &q, &qd).unwrap();
        let want = -2.0 * w * (qd[0] * c + qd[1] * s) + w * w * (q[0] * s - q[1] * c);
        assert!(close(gamma[0], want, 1e-13), "{gamma} {want}");
        let e = bead.evaluate(t, &q, &qd).unwrap();
        let acc = [-2.0 * rd * w * s, 2.0 * rd * w * c];
        for i in 0..2 {
            assert!(close(e.accelerations[i], acc[i], 1e-13), "{e:?} {acc:?}");
            assert!(close(e.reaction_forces[i], m * acc[i], 1e-13));
        }
        assert!(bead.residuals(t, &q, &qd).unwrap().max_abs() < 1e-13);
    }
    // g = x − sin t: γ = sin t, ẍ = −sin t, ġ = ẋ − cos t.
    let driven = Constrained::new(point(1.0, true), holonomic(&[Row::Driven]));
    let (t, q, qd) = (0.7_f64, [0.2, 0.1], [0.3, -0.4]);
    assert!(close(driven.gamma(t, &q, &qd).unwrap()[0], t.sin(), 1e-15));
    let e = driven.evaluate(t, &q, &qd).unwrap();
    assert!(close(e.accelerations[0], -t.sin(), 1e-15));
    assert!(close(e.accelerations[1], -G, 1e-15));
    let res = driven.residuals(t, &q, &qd).unwrap();
    assert!(close(res.position[0], q[0] - t.sin(), 1e-15));
    assert!(close(res.velocity[0], qd[0] - t.cos(), 1e-15));
}

#[test]
fn jacobian_and_gamma_against_hand_derivations() {
    let c = Constrained::new(
        point(1.0, false),
        Rows {
            holonomic: vec![Row::Mixed, Row::Circle(1.0)],
            velocity: vec![VRow::Mixed],
        },
    );
    let mut rng = Rng(11);
    for _ in 0..40 {
        let t = rng.uniform(-2.0, 2.0);
        let (x, y) = (rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0));
        let (u, v) = (rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0));
        let g = c.constraint_jacobian(t, &[x, y], &[u, v]).unwrap();
        let gamma = c.gamma(t, &[x, y], &[u, v]).unwrap();
        // Row 0: g = x² y + sin(x y t), with p = x y t.
        let p = x * y * t;
        let (sp, cp) = p.sin_cos();
        let want_g = [
            [2.0 * x * y + cp * y * t, x * x + cp * x * t],
            [2.0 * x, 2.0 * y],
            [t.cos(), x],
        ];
        // ġ = 2xy u + x² v + cos p ṗ, ṗ = (u y + x v) t + x y;
        // g̈ (q̈ = 0) = 2y u² + 4x u v + cos p p̈ − sin p ṗ², p̈ = 2 (t u v + u y + x v).
        let pd = (u * y + x * v) * t + x * y;
        let pdd = 2.0 * (t * u * v + u * y + x * v);
        let want_gamma = [
            2.0 * y * u * u + 4.0 * x * u * v + cp * pdd - sp * pd * pd,
            2.0 * (u * u + v * v),
            // d/ds [cos(t + s) u + (x + s u) v + (t + s)(x + s u)]: −sin t u + u v + x + t u.
            -t.sin() * u + u * v + x + t * u,
        ];
        for i in 0..3 {
            for j in 0..2 {
                assert!(close(g[(i, j)], want_g[i][j], 1e-14), "G {g} row {i}");
            }
            assert!(
                close(gamma[i], want_gamma[i], 1e-13),
                "γ {gamma} {want_gamma:?}"
            );
        }
    }
}

#[test]
fn many_coordinates_cross_the_chunks() {
    // n = 9 point masses on a line, chained: qᵢ₊₁ − qᵢ − 1 = 0 (8 rows): rigid, so all move with
    // the mean force; G's chunks of four columns meet in the middle.
    struct Chain;
    impl Constraints for Chain {
        fn holonomic_count(&self) -> usize {
            8
        }
        fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
            for i in 0..8 {
                out[i] = q[i + 1] - q[i] - 1.0;
            }
        }
        fn depends_on_time(&self) -> bool {
            false
        }
    }
    let masses: Vec<f64> = (0..9).map(|i| 1.0 + i as f64 * 0.1).collect();
    let slopes: Vec<f64> = (0..9).map(|i| (i as f64 - 3.0) * 0.5).collect();
    let total: f64 = masses.iter().sum();
    let push: f64 = -slopes.iter().sum::<f64>();
    let chain = Constrained::new(
        System::new(9, Diagonal(masses)).with_potential(Linear(slopes)),
        Chain,
    );
    let q: Vec<f64> = (0..9).map(|i| i as f64).collect();
    let e = chain.evaluate(0.0, &q, &[0.5; 9]).unwrap();
    for a in e.accelerations.iter() {
        assert!(close(*a, push / total, 1e-14), "{}", e.accelerations);
    }
    let g = chain.constraint_jacobian(0.0, &q, &[0.5; 9]).unwrap();
    assert_eq!(
        (g[(3, 3)], g[(3, 4)], g[(4, 4)], g[(4, 5)]),
        (-1.0, 1.0, -1.0, 1.0)
    );
}

#[test]
fn redundant_constraints_are_a_typed_error() {
    let twice = Constrained::new(
        point(1.0, true),
        holonomic(&[Row::Circle(1.0), Row::Circle(1.0)]),
    );
    let err = twice.evaluate(0.0, &[0.6, -0.8], &[0.8, 0.6]).unwrap_err();
    match &err {
        Error::DependentConstraints { t, row, others, .. } => {
            assert_eq!(*t, 0.0);
            assert_eq!(row, "row 1");
            assert_eq!(others, &["row 0".to_string()]);
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("remove a redundant constraint"));
}

#[test]
fn a_dead_point_is_a_typed_error() {
    // A circle and its tangent line y = 1 meet at (0, 1), where their normals are parallel.
    let tangent = Constrained::new(
        point(1.0, true),
        holonomic(&[Row::Circle(1.0), Row::Line(1.0)]),
    );
    let err = tangent.evaluate(2.5, &[0.0, 1.0], &[0.0, 0.0]).unwrap_err();
    assert!(
        matches!(&err, Error::DependentConstraints { t, row, others, .. }
            if *t == 2.5 && row == "row 1" && others == &["row 0".to_string()]),
        "{err:?}"
    );
    // Away from it the normals differ, and the two rows fix the point: at rest, no motion.
    let e = tangent.evaluate(0.0, &[0.1, 0.99], &[0.0, 0.0]).unwrap();
    assert!(e.accelerations.norm() < 1e-14, "{e:?}");
    assert!(close(e.reaction_forces[1], G, 1e-14));
    // A row whose gradient vanishes (x² + y² − 0 at the origin) is dependent on nothing.
    let degenerate = Constrained::new(point(1.0, true), holonomic(&[Row::Circle(0.0)]));
    let err = degenerate
        .evaluate(0.0, &[0.0, 0.0], &[0.0, 0.0])
        .unwrap_err();
    assert!(
        matches!(&err, Error::DependentConstraints { row, others, .. }
            if row == "row 0" && others.is_empty()),
        "{err:?}"
    );
}

#[test]
fn a_velocity_constraint_quadratic_in_the_velocities_is_refused() {
    let c = Constrained::new(
        System::new(3, Diagonal(vec![1.0; 3])),
        Rows {
            holonomic: vec![Row::Circle(1.0)],
            velocity: vec![VRow::Knife, VRow::Speed],
        },
    );
    let err = c
        .evaluate(0.0, &[0.6, 0.8, 0.1], &[0.0, 0.0, 0.0])
        .unwrap_err();
    match &err {
        Error::NonlinearVelocityConstraint {
            row,
            second_derivative,
            ..
        } => {
            assert_eq!(row, "row 2");
            assert_eq!(*second_derivative, 2.0);
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        c.constraint_jacobian(0.0, &[0.6, 0.8, 0.1], &[1.0, 0.0, 0.0]),
        Err(Error::NonlinearVelocityConstraint { .. })
    ));
}

#[test]
fn wrong_lengths_and_bad_values_are_typed_errors() {
    let c = Constrained::new(point(1.0, true), holonomic(&[Row::Circle(1.0)]));
    let dim = |r: lagrangian::Result<()>| -> (&'static str, usize, usize) {
        match r {
            Err(Error::DimensionMismatch {
                what,
                expected,
                got,
            }) => (what, expected, got),
            other => panic!("{other:?}"),
        }
    };
    let (q, qd) = ([0.0, -1.0], [1.0, 0.0]);
    let (mut a, mut l, mut r) = (vec![0.0; 2], vec![0.0; 1], vec![0.0; 2]);
    assert_eq!(
        dim(c.evaluate_into(0.0, &q, &qd, &mut [0.0; 3], &mut l, &mut r)),
        ("accelerations", 2, 3)
    );
    assert_eq!(
        dim(c.evaluate_into(0.0, &q, &qd, &mut a, &mut [0.0; 2], &mut r)),
        ("multipliers", 1, 2)
    );
    assert_eq!(
        dim(c.evaluate_into(0.0, &q, &qd, &mut a, &mut l, &mut [0.0; 1])),
        ("reaction forces", 2, 1)
    );
    assert_eq!(dim(c.evaluate(0.0, &[0.0], &qd).map(drop)), ("q", 2, 1));
    assert_eq!(dim(c.residuals(0.0, &q, &[1.0]).map(drop)), ("qd", 2, 1));
    assert!(matches!(
        c.evaluate(f64::NAN, &q, &qd),
        Err(Error::NonFinite { .. })
    ));
    c.evaluate_into(0.0, &q, &qd, &mut a, &mut l, &mut r)
        .unwrap();
    assert!(a.iter().chain(&l).chain(&r).all(|v| v.is_finite()));
    // A massless coordinate is the mass matrix's typed error, not a NaN.
    let massless = Constrained::new(
        System::new(2, Diagonal(vec![1.0, 0.0])),
        holonomic(&[Row::Circle(1.0)]),
    );
    assert!(matches!(
        massless.evaluate(0.0, &q, &qd),
        Err(Error::SingularMassMatrix { .. })
    ));
}

#[test]
fn no_constraints_is_the_wrapped_system() {
    use lagrangian::Dynamics;
    let free = point(2.0, true);
    let c = Constrained::new(point(2.0, true), ());
    assert_eq!(c.rows(), 0);
    let (q, qd) = ([0.3, 0.4], [1.0, -1.0]);
    let e = c.evaluate(0.0, &q, &qd).unwrap();
    assert_eq!(e.accelerations, free.accelerations(0.0, &q, &qd).unwrap());
    assert_eq!(e.multipliers.len(), 0);
    assert_eq!(e.reaction_forces.norm(), 0.0);
    assert_eq!(c.residuals(0.0, &q, &qd).unwrap().max_abs(), 0.0);
}

// Consistent states (issue 41, item 5): `project` and `check_consistent`.

#[test]
fn a_pendulum_state_off_the_circle_projects_back_radially() {
    let (m, l) = (1.7, 0.8);
    let pendulum = Constrained::new(point(m, true), holonomic(&[Row::Circle(l)]));
    let mut rng = Rng(41);
    for _ in 0..20 {
        let a = rng.uniform(-3.0, 3.0);
        let (c, s) = (a.cos(), a.sin());
        let stretch = 1.0 + rng.uniform(-0.05, 0.05);
        let q0 = [l * stretch * c, l * stretch * s];
        // Tangential speed w, radial speed u.
        let (w, u) = (rng.uniform(-2.0, 2.0), rng.uniform(-1.0, 1.0));
        let qd0 = [-w * s + u * c, w * c + u * s];
        let (q, qd) = pendulum.project(0.0, &q0, &qd0, None).unwrap();
        assert!((q[0].hypot(q[1]) - l).abs() < 1e-14, "{q:?}");
        assert!((qd[0] * q[0] + qd[1] * q[1]).abs() < 1e-14);
        // Equal masses: M⁻¹Gᵀ is radial, so the correction is along q0.
        assert!((q[0] * q0[1] - q[1] * q0[0]).abs() < 1e-15);
        assert!(q[0] * q0[0] + q[1] * q0[1] > 0.0);
        // The tangential speed is kept.
        assert!(close(-qd[0] * s + qd[1] * c, w, 1e-14));
        pendulum.check_consistent(0.0, &q, &qd, None).unwrap();
    }
}

#[test]
fn a_consistent_state_is_left_unchanged_and_passes() {
    let (m, l) = (1.7, 0.8);
    let pendulum = Constrained::new(point(m, true), holonomic(&[Row::Circle(l)]));
    let a = 0.3_f64;
    let q0 = [l * a.cos(), l * a.sin()];
    let qd0 = [-1.1 * a.sin(), 1.1 * a.cos()];
    let (q, qd) = pendulum.project(0.0, &q0, &qd0, None).unwrap();
    assert_eq!(q, q0);
    assert_eq!(qd, qd0);
    pendulum.check_consistent(0.0, &q0, &qd0, None).unwrap();
    pendulum
        .check_consistent(0.0, &q0, &qd0, Some(PROJECTION_TOLERANCE))
        .unwrap();
    // Off the circle: refused at the position level, naming the row.
    match pendulum.check_consistent(0.0, &[q0[0] * 1.001, q0[1] * 1.001], &qd0, None) {
        Err(Error::InconsistentState {
            constraint,
            level,
            residual,
            ..
        }) => {
            assert_eq!(constraint, "row 0");
            assert_eq!(level, "position");
            assert!(close(residual, l * l * (1.001_f64.powi(2) - 1.0), 1e-12));
        }
        other => panic!("{other:?}"),
    }
    // On the circle with a radial velocity: refused at the velocity level.
    let radial = [0.5 * a.cos(), 0.5 * a.sin()];
    match pendulum.check_consistent(0.0, &q0, &radial, None) {
        Err(e @ Error::InconsistentState { .. }) => {
            let Error::InconsistentState {
                level, residual, ..
            } = &e
            else {
                unreachable!()
            };
            assert_eq!(*level, "velocity");
            assert!(close(*residual, 2.0 * l * 0.5, 1e-14));
            assert!(e.to_string().contains("project"), "{e}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn velocity_rows_project_velocities_only() {
    // Knife edge: sin φ ẋ − cos φ ẏ = 0; the positions are free.
    let (m, inertia) = (1.3, 0.2);
    let knife = Constrained::new(
        System::new(3, Diagonal(vec![m, m, inertia])),
        Rows {
            holonomic: Vec::new(),
            velocity: vec![VRow::Knife],
        },
    );
    let mut rng = Rng(11);
    for _ in 0..20 {
        let q0 = [
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-3.0, 3.0),
        ];
        let qd0 = [
            rng.uniform(-2.0, 2.0),
            rng.uniform(-2.0, 2.0),
            rng.uniform(-2.0, 2.0),
        ];
        let (q, qd) = knife.project(0.0, &q0, &qd0, None).unwrap();
        assert_eq!(q, q0);
        let (s, c) = q0[2].sin_cos();
        // The sideways speed is removed, the speed along the blade and the turning rate kept.
        assert!((s * qd[0] - c * qd[1]).abs() < 1e-15);
        assert!(close(c * qd[0] + s * qd[1], c * qd0[0] + s * qd0[1], 1e-14));
        assert_eq!(qd[2], qd0[2]);
        knife.check_consistent(0.0, &q, &qd, None).unwrap();
    }
    // Rolling cylinder (x = rθ): ẋ − r θ̇ = 0, corrected in the metric diag(m, J).
    let (m, r) = (2.0, 0.3);
    let j = 0.5 * m * r * r;
    let rolling = Constrained::new(
        System::new(2, Diagonal(vec![m, j])),
        holonomic(&[Row::Rolling(r)]),
    );
    let (q, qd) = rolling
        .project(0.0, &[0.6, 2.0], &[1.0, 0.0], None)
        .unwrap();
    assert!((q[0] - r * q[1]).abs() < 1e-15);
    assert!((qd[0] - r * qd[1]).abs() < 1e-15);
    // Momentum-like balance: the correction is M⁻¹Gᵀμ with G = (1, −r), so
    // m Δẋ / 1 = J Δθ̇ / (−r).
    assert!(close(m * (qd[0] - 1.0), -j * qd[1] / r, 1e-14));
}

#[test]
fn a_moving_constraint_uses_its_time_derivative() {
    // x − sin t = 0: x = sin t, ẋ = cos t; y is free and kept.
    let driven = Constrained::new(point(1.0, true), holonomic(&[Row::Driven]));
    let t = 0.7_f64;
    let (q, qd) = driven.project(t, &[0.5, 0.3], &[0.0, 0.2], None).unwrap();
    assert!((q[0] - t.sin()).abs() < 1e-15);
    assert_eq!(q[1], 0.3);
    assert!((qd[0] - t.cos()).abs() < 1e-15);
    assert_eq!(qd[1], 0.2);
    driven.check_consistent(t, &q, &qd, None).unwrap();
    // At rest on the moving point is inconsistent at the velocity level.
    assert!(matches!(
        driven.check_consistent(t, &q, &[0.0, 0.2], None),
        Err(Error::InconsistentState {
            level: "velocity",
            ..
        })
    ));
}

#[test]
fn the_projection_is_m_orthogonal_with_unequal_masses() {
    let l = 1.3;
    let masses = [1.0, 4.0];
    let system = System::new(2, Diagonal(masses.to_vec())).with_potential(Linear(vec![0.0, 0.0]));
    let pendulum = Constrained::new(system, holonomic(&[Row::Circle(l)]));
    let mut rng = Rng(5);
    for _ in 0..20 {
        let a = rng.uniform(-3.0, 3.0);
        let offset = 1e-4 * rng.uniform(-1.0, 1.0);
        let q0 = [(l + offset) * a.cos(), (l + offset) * a.sin()];
        let qd0 = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)];
        let (q, qd) = pendulum.project(0.0, &q0, &qd0, None).unwrap();
        assert!((q[0].hypot(q[1]) - l).abs() < 1e-14);
        // Tangent at the projected point.
        let tangent = [-q[1], q[0]];
        let m_dot = |d: [f64; 2]| masses[0] * d[0] * tangent[0] + masses[1] * d[1] * tangent[1];
        let dq = [q[0] - q0[0], q[1] - q0[1]];
        let size = dq[0].hypot(dq[1]) * masses[1] * l;
        // Gauss–Newton: M-orthogonal up to O(|Δq|²).
        assert!(
            m_dot(dq).abs() <= 10.0 * size * dq[0].hypot(dq[1]) / l + 1e-15,
            "{dq:?}"
        );
        // The velocity correction is M-orthogonal to round-off (G fixed at the projected q).
        let dv = [qd[0] - qd0[0], qd[1] - qd0[1]];
        assert!(m_dot(dv).abs() < 1e-14);
        assert!((qd[0] * q[0] + qd[1] * q[1]).abs() < 1e-14);
    }
}

#[test]
fn a_hopeless_projection_is_a_typed_error() {
    // x² + 1 = 0 has no real solution: Newton wanders and gives up within its iterations.
    let hopeless = Constrained::new(point(1.0, false), holonomic(&[Row::Hopeless]));
    match hopeless.project(0.0, &[0.3, 0.0], &[0.0, 0.0], None) {
        Err(Error::ProjectionFailed {
            constraint,
            iterations,
            residual,
            ..
        }) => {
            assert_eq!(constraint, "row 0");
            assert_eq!(iterations, 50);
            assert!(residual >= 1.0);
        }
        other => panic!("{other:?}"),
    }
    // A rank-deficient G (a row stated twice) is refused as in `evaluate`.
    let twice = Constrained::new(
        point(1.0, false),
        holonomic(&[Row::Circle(1.0), Row::Circle(1.0)]),
    );
    assert!(matches!(
        twice.project(0.0, &[1.1, 0.2], &[0.0, 0.0], None),
        Err(Error::DependentConstraints { .. })
    ));
}

#[test]
fn bad_input_to_the_projection_is_a_typed_error() {
    let pendulum = Constrained::new(point(1.0, true), holonomic(&[Row::Circle(1.0)]));
    for (q, qd) in [
        ([f64::NAN, 1.0], [0.0, 0.0]),
        ([1.0, 0.0], [0.0, f64::INFINITY]),
    ] {
        assert!(matches!(
            pendulum.project(0.0, &q, &qd, None),
            Err(Error::NonFinite { .. })
        ));
        assert!(matches!(
            pendulum.check_consistent(0.0, &q, &qd, None),
            Err(Error::NonFinite { .. })
        ));
    }
    assert!(matches!(
        pendulum.project(f64::NAN, &[1.0, 0.0], &[0.0, 0.0], None),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        pendulum.project(0.0, &[1.0], &[0.0, 0.0], None),
        Err(Error::DimensionMismatch { .. })
    ));
    for tol in [0.0, -1.0, f64::NAN] {
        assert!(matches!(
            pendulum.project(0.0, &[1.0, 0.0], &[0.0, 0.0], Some(tol)),
            Err(Error::InvalidInput { .. })
        ));
    }
}
