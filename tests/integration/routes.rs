//! The energy route and the particle route give the same accelerations as the hand-derived
//! closed forms (seed §2: eq. 20 and eq. 2 are the same equations).

use approx::assert_relative_eq;
use lagrangian::Dynamics;
use lagrangian::scenes::{DoublePendulum, NPendulum};

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
