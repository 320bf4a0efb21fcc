//! The energy route and the particle route give the same accelerations as the hand-derived
//! closed forms (seed §2: eq. 20 and eq. 2 are the same equations).

use approx::assert_relative_eq;
use lagrangian::num_dual::Dual64;
use lagrangian::scenes::{DoublePendulum, NPendulum};
use lagrangian::{Dynamics, KineticEnergy, Scalar, System};

fn states(n: usize, k: usize) -> (Vec<f64>, Vec<f64>) {
    let q = (0..n)
        .map(|i| 0.3 + 0.7 * ((i * 7 + k * 3) as f64).sin())
        .collect();
    let qd = (0..n)
        .map(|i| -0.4 + 1.1 * ((i * 5 + k * 11) as f64).cos())
        .collect();
    (q, qd)
}

#[test]
fn accelerations_double_pendulum_both_routes() {
    let dp = DoublePendulum::new(1.3, 0.7, 1.1, 0.8, 9.81);
    let energy = dp.system();
    let particles = dp.particles();
    for k in 0..20 {
        let (q, qd) = states(2, k);
        let exact = dp.closed_form_accelerations(&q, &qd);
        let a = energy.accelerations(0.0, &q, &qd).unwrap();
        let b = particles.accelerations(0.0, &q, &qd).unwrap();
        for i in 0..2 {
            assert_relative_eq!(a[i], exact[i], max_relative = 1e-12, epsilon = 1e-12);
            assert_relative_eq!(b[i], exact[i], max_relative = 1e-12, epsilon = 1e-12);
        }
    }
}

#[test]
fn accelerations_npendulum_both_routes() {
    for n in [1, 2, 3, 4, 5, 8, 13] {
        let masses: Vec<f64> = (0..n).map(|i| 0.5 + 0.1 * i as f64).collect();
        let lengths: Vec<f64> = (0..n).map(|i| 1.0 - 0.03 * i as f64).collect();
        let chain = NPendulum::new(masses, lengths, 9.81);
        let energy = chain.clone().system();
        let particles = chain.clone().particles();
        let mirror = particles.energy_route();
        for k in 0..4 {
            let (q, qd) = states(n, k);
            let exact = chain.closed_form_accelerations(&q, &qd);
            let a = energy.accelerations(0.0, &q, &qd).unwrap();
            let b = particles.accelerations(0.0, &q, &qd).unwrap();
            let c = mirror.accelerations(0.0, &q, &qd).unwrap();
            let scale = exact.iter().fold(1.0_f64, |s, x| s.max(x.abs()));
            for i in 0..n {
                assert_relative_eq!(a[i], exact[i], epsilon = 1e-11 * scale);
                assert_relative_eq!(b[i], exact[i], epsilon = 1e-11 * scale);
                assert_relative_eq!(c[i], exact[i], epsilon = 1e-11 * scale);
            }
        }
    }
}

/// A kinetic energy as `K` states it, with a chosen `FIXED_DOF` (`H`: 0 for none) instead of
/// `K`'s own, so that the same T runs with and without the compile-time choice of pass size.
#[derive(Clone)]
struct Hinted<K, const H: usize>(K);

impl<K: KineticEnergy, const H: usize> KineticEnergy for Hinted<K, H> {
    const FIXED_DOF: Option<usize> = if H == 0 { None } else { Some(H) };
    fn kinetic<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.0.kinetic(t, q, qd)
    }
    fn depends_on_time(&self) -> bool {
        self.0.depends_on_time()
    }
    fn depends_on_position(&self) -> bool {
        self.0.depends_on_position()
    }
    fn constant_mass_matrix(&self) -> bool {
        self.0.constant_mass_matrix()
    }
}

/// Every value the derivative passes give, at f64 and at a dual-number state.
fn pass_values<S: Dynamics>(s: &S, q: &[f64], qd: &[f64]) -> Vec<f64> {
    let n = q.len();
    let mut v = Vec::new();
    let mut out = vec![0.0; n];
    s.accelerations_into(0.3, q, qd, &mut out).unwrap();
    v.extend(&out);
    s.momenta_into(0.3, q, qd, &mut out);
    v.extend(&out);
    s.potential_gradient_into(0.3, q, &mut out);
    v.extend(&out);
    let mut m = vec![0.0; n * n];
    s.mass_matrix_into(0.3, q, qd, &mut m);
    v.extend(&m);
    let qd_dual: Vec<Dual64> = qd.iter().map(|&x| Dual64::new(x, 1.0)).collect();
    let q_dual: Vec<Dual64> = q.iter().map(|&x| Dual64::from_re(x)).collect();
    let mut a = vec![Dual64::from_re(0.0); n];
    s.accelerations_into(Dual64::from_re(0.3), &q_dual, &qd_dual, &mut a)
        .unwrap();
    v.extend(a.iter().flat_map(|x| [x.re, x.eps]));
    v
}

/// `FIXED_DOF` changes what is compiled, never a bit of the result: the double pendulum (which
/// states `Some(2)`) gives the same accelerations, momenta, ∂U/∂q, M and ∂q̈/∂q̇ with its hint
/// as without it. A wrong hint only picks another pass size: a 3-link chain hinted as 1 or 2
/// coordinates and a double pendulum hinted as 5 still match the closed forms (eq. 2).
#[test]
fn fixed_dof_changes_no_bits_and_a_wrong_one_stays_correct() {
    let dp = DoublePendulum::new(1.3, 0.7, 1.1, 0.8, 9.81);
    assert_eq!(<DoublePendulum as KineticEnergy>::FIXED_DOF, Some(2));
    assert_eq!(<NPendulum as KineticEnergy>::FIXED_DOF, None);
    let hinted = dp.system();
    let unhinted = System::new(2, Hinted::<_, 0>(dp)).with_potential(dp);
    let wrong = System::new(2, Hinted::<_, 5>(dp)).with_potential(dp);
    let chain = NPendulum::new(vec![0.5, 0.6, 0.7], vec![1.0, 0.9, 0.8], 9.81);
    let chain_system = chain.clone().system();
    let chain_as_1 = System::new(3, Hinted::<_, 1>(chain.clone())).with_potential(chain.clone());
    let chain_as_2 = System::new(3, Hinted::<_, 2>(chain.clone())).with_potential(chain.clone());
    for k in 0..10 {
        let (q, qd) = states(2, k);
        let bits = pass_values(&hinted, &q, &qd);
        assert_eq!(bits, pass_values(&unhinted, &q, &qd), "state {k}");
        let exact = dp.closed_form_accelerations(&q, &qd);
        for (w, e) in pass_values(&wrong, &q, &qd).iter().zip(&bits) {
            assert_relative_eq!(*w, *e, max_relative = 1e-13, epsilon = 1e-13);
        }
        for i in 0..2 {
            assert_relative_eq!(bits[i], exact[i], max_relative = 1e-12, epsilon = 1e-12);
        }
        let (q, qd) = states(3, k);
        let exact = chain.closed_form_accelerations(&q, &qd);
        let reference = pass_values(&chain_system, &q, &qd);
        for s in [
            pass_values(&chain_as_1, &q, &qd),
            pass_values(&chain_as_2, &q, &qd),
        ] {
            for (w, e) in s.iter().zip(&reference) {
                assert_relative_eq!(*w, *e, max_relative = 1e-12, epsilon = 1e-12);
            }
            for i in 0..3 {
                assert_relative_eq!(s[i], exact[i], max_relative = 1e-12, epsilon = 1e-12);
            }
        }
    }
}
