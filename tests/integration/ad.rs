//! The AD machinery itself: the accelerations differentiated again by dual numbers agree with
//! finite differences; the chunked passes of large systems agree with the closed form; and the
//! energy function obeys its balance law dh/dt = −2Φ − ∂L/∂t (+ Q″·q̇) along the motion.

use approx::assert_relative_eq;
use lagrangian::Dynamics;
use lagrangian::num_dual::Dual64;
use lagrangian::scenes::{
    ChargedParticle, DampedOscillator, DoublePendulum, DrivenPendulum, ElasticPendulum, NPendulum,
};

/// ∂q̈/∂(q, q̇) column `k` by one `Dual64` pass.
fn jacobian_column<S: Dynamics>(s: &S, t: f64, q: &[f64], qd: &[f64], k: usize) -> Vec<f64> {
    let n = q.len();
    let lift = |x: &[f64], off: usize| -> Vec<Dual64> {
        x.iter()
            .enumerate()
            .map(|(i, &v)| Dual64::new(v, if i + off == k { 1.0 } else { 0.0 }))
            .collect()
    };
    let (qs, qds) = (lift(q, 0), lift(qd, n));
    let mut out = vec![Dual64::from(0.0); n];
    s.accelerations_into(Dual64::from(t), &qs, &qds, &mut out)
        .unwrap();
    out.iter().map(|x| x.eps).collect()
}

fn check_jacobian<S: Dynamics>(s: &S, t: f64, q: &[f64], qd: &[f64]) {
    let n = q.len();
    let h = 1e-6;
    for k in 0..2 * n {
        let ad = jacobian_column(s, t, q, qd, k);
        let shifted = |sign: f64| {
            let (mut q, mut qd) = (q.to_vec(), qd.to_vec());
            if k < n {
                q[k] += sign * h;
            } else {
                qd[k - n] += sign * h;
            }
            s.accelerations(t, &q, &qd).unwrap()
        };
        let (plus, minus) = (shifted(1.0), shifted(-1.0));
        for i in 0..n {
            let fd = (plus[i] - minus[i]) / (2.0 * h);
            assert_relative_eq!(ad[i], fd, epsilon = 2e-7 * (1.0 + fd.abs()));
        }
    }
}

#[test]
fn jacobian_double_pendulum_both_routes() {
    let dp = DoublePendulum::new(1.2, 0.8, 1.0, 0.6, 9.81);
    let (q, qd) = ([0.8, -1.3], [1.5, -0.4]);
    check_jacobian(&dp.system(), 0.0, &q, &qd);
    check_jacobian(&dp.particles(), 0.0, &q, &qd);
}

#[test]
fn jacobian_chunked_npendulum() {
    let chain = NPendulum::new(vec![1.0, 0.7, 0.9, 0.5, 1.1, 0.6], vec![0.5; 6], 9.81);
    let q: Vec<f64> = (0..6).map(|i| 0.4 * (i as f64).sin()).collect();
    let qd: Vec<f64> = (0..6).map(|i| 0.3 * (i as f64).cos()).collect();
    check_jacobian(&chain.clone().system(), 0.0, &q, &qd);
    check_jacobian(&chain.particles(), 0.0, &q, &qd);
}

#[test]
fn jacobian_velocity_dependent_and_rheonomic() {
    let charge = ChargedParticle::new(2.0, 0.5, 3.0).with_electric_field(0.2, -0.1);
    check_jacobian(&charge.system(), 0.0, &[0.3, -0.2], &[1.0, 0.5]);
    let driven = DrivenPendulum::new(1.0, 0.7, 9.81, 0.05, 30.0);
    check_jacobian(&driven.system(), 0.37, &[2.0], &[-1.0]);
    check_jacobian(&driven.particles(), 0.37, &[2.0], &[-1.0]);
}

#[test]
fn mass_matrix_chunked_npendulum() {
    // n = 9 exercises the block seeding (chunks of four, a partial last block).
    let n = 9;
    let masses: Vec<f64> = (0..n).map(|i| 0.3 + 0.1 * i as f64).collect();
    let lengths: Vec<f64> = (0..n).map(|i| 1.0 - 0.05 * i as f64).collect();
    let chain = NPendulum::new(masses.clone(), lengths.clone(), 9.81);
    let q: Vec<f64> = (0..n).map(|i| 0.9 * ((2 * i) as f64).cos()).collect();
    let qd = vec![0.1; n];
    let m = chain.clone().system().mass_matrix(0.0, &q, &qd).unwrap();
    let mp = chain.particles().mass_matrix(0.0, &q, &qd).unwrap();
    for i in 0..n {
        for k in 0..n {
            let mu: f64 = masses[i.max(k)..].iter().sum();
            let exact = mu * lengths[i] * lengths[k] * (q[i] - q[k]).cos();
            assert_relative_eq!(m[(i, k)], exact, epsilon = 1e-13);
            assert_relative_eq!(mp[(i, k)], exact, epsilon = 1e-13);
        }
    }
}

/// dh/dt along the motion, by one dual pass in the direction (q̇, q̈, 1).
fn energy_rate<S: Dynamics>(s: &S, t: f64, q: &[f64], qd: &[f64]) -> f64 {
    let qdd = s.accelerations(t, q, qd).unwrap();
    let tt = Dual64::new(t, 1.0);
    let qs: Vec<Dual64> = q.iter().zip(qd).map(|(&x, &v)| Dual64::new(x, v)).collect();
    let qds: Vec<Dual64> = qd
        .iter()
        .zip(qdd.iter())
        .map(|(&v, &a)| Dual64::new(v, a))
        .collect();
    let mut p = vec![Dual64::from(0.0); q.len()];
    s.momenta_into(tt, &qs, &qds, &mut p);
    let h = p.iter().zip(&qds).map(|(&p, &v)| p * v).sum::<Dual64>() - s.lagrangian(tt, &qs, &qds);
    h.eps
}

/// ∂L/∂t at fixed (q, q̇).
fn explicit_time_rate<S: Dynamics>(s: &S, t: f64, q: &[f64], qd: &[f64]) -> f64 {
    let c = |x: &[f64]| x.iter().map(|&v| Dual64::from(v)).collect::<Vec<_>>();
    s.lagrangian(Dual64::new(t, 1.0), &c(q), &c(qd)).eps
}

#[test]
fn energy_balance_conservative_scenes() {
    let dp = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81);
    let charge = ChargedParticle::new(1.0, 1.0, 2.0);
    let elastic = ElasticPendulum::new(1.0, 40.0, 1.0, 9.81);
    for (q, qd) in [([0.5, 2.0], [1.0, -3.0]), ([-2.0, 0.1], [0.2, 0.7])] {
        assert!(energy_rate(&dp.system(), 0.0, &q, &qd).abs() < 1e-12);
        assert!(energy_rate(&dp.particles(), 0.0, &q, &qd).abs() < 1e-12);
        assert!(energy_rate(&charge.system(), 0.0, &q, &qd).abs() < 1e-12);
        let r = [1.0 + 0.1 * q[0], q[1]];
        assert!(energy_rate(&elastic.system(), 0.0, &r, &qd).abs() < 1e-11);
    }
}

#[test]
fn energy_balance_dissipative_and_driven() {
    // dh/dt = −2Φ = −c ẋ² for the damped oscillator (Φ quadratic in ẋ).
    let osc = DampedOscillator::new(2.0, 30.0, 0.7);
    let (q, qd) = ([0.4], [-1.3]);
    assert_relative_eq!(
        energy_rate(&osc.system(), 0.0, &q, &qd),
        -0.7 * qd[0] * qd[0],
        epsilon = 1e-13
    );
    // dh/dt = −∂L/∂t for an explicitly time-dependent Lagrangian.
    let driven = DrivenPendulum::new(1.0, 0.7, 9.81, 0.05, 30.0);
    for t in [0.0, 0.1, 0.37] {
        let (q, qd) = ([1.1], [0.4]);
        let s = driven.system();
        assert_relative_eq!(
            energy_rate(&s, t, &q, &qd),
            -explicit_time_rate(&s, t, &q, &qd),
            epsilon = 1e-12
        );
        assert!(explicit_time_rate(&s, t, &q, &qd).abs() > 1e-3);
    }
}

/// atan2 over dual numbers (the tapes' generic path, the integrators' Jacobians) has finite
/// derivatives at x = 0, where num-dual's atan(y/x) gives NaN.
#[test]
fn atan2_dual_at_zero() {
    use lagrangian::tape::{Binary, EnergyModel, Function, Graph, Inputs, Tape};
    use std::sync::Arc;
    // T = ½ q̇², U = atan2(1, q) or atan2(q, 1): the force −∂U/∂q = ±1/(1+q²).
    for swap in [false, true] {
        let mut g = Graph::new();
        let (q, v) = (g.coord(0), g.velocity(0));
        let one = g.constant(1.0);
        let v2 = g.powi(v, 2).unwrap();
        let h = g.constant(0.5);
        let t = g.binary(Binary::Mul, h, v2).unwrap();
        let (a, b) = if swap { (q, one) } else { (one, q) };
        let u = g.binary(Binary::Atan2, a, b).unwrap();
        let tape = |root, inputs| {
            Function::new(
                Arc::new(Tape::new(&g, &[root], inputs, "part").unwrap()),
                &[],
            )
            .unwrap()
        };
        let m = EnergyModel::new(
            1,
            tape(t, Inputs::kinetic(1, 0)),
            Some(tape(u, Inputs::potential(1, 0))),
            None,
            None,
        )
        .unwrap();
        for x in [0.0, 0.3, -2.0] {
            let mut out = [Dual64::from_re(0.0)];
            m.accelerations_into(
                Dual64::from_re(0.0),
                &[Dual64::new(x, 1.0)],
                &[Dual64::from_re(0.0)],
                &mut out,
            )
            .unwrap();
            let s = if swap { -1.0 } else { 1.0 };
            let want = (s / (1.0 + x * x), -s * 2.0 * x / (1.0 + x * x).powi(2));
            assert!(
                (out[0].re - want.0).abs() < 1e-15 && (out[0].eps - want.1).abs() < 1e-15,
                "{swap} {x}: {out:?} {want:?}"
            );
        }
    }
}

/// tanh over dual numbers (the tapes' generic path, the integrators' Jacobians) is finite at
/// large arguments, where num-dual's sinh/cosh is ∞/∞ = NaN, and exact near 0.
#[test]
fn tanh_dual_at_large_and_small_arguments() {
    use lagrangian::tape::{Function, Graph, Inputs, Tape, Unary};
    use std::sync::Arc;
    let mut g = Graph::new();
    let q = g.coord(0);
    let u = g.unary(Unary::Tanh, q).unwrap();
    let tape = Arc::new(Tape::new(&g, &[u], Inputs::potential(1, 0), "tanh").unwrap());
    let f = Function::new(tape, &[]).unwrap();
    for x in [0.0_f64, 1e-9, -3e-5, 0.4, -2.5, 30.0, 800.0, -1e4] {
        let mut out = [Dual64::from_re(0.0)];
        f.eval_into(Dual64::from_re(0.0), &[Dual64::new(x, 1.0)], &[], &mut out);
        let sech2 = 1.0 / x.cosh().powi(2);
        assert_eq!(out[0].re, x.tanh(), "value at {x}");
        assert!(
            (out[0].eps - sech2).abs() <= 4.0 * f64::EPSILON * sech2,
            "derivative at {x}: {} vs {sech2}",
            out[0].eps
        );
    }
}
