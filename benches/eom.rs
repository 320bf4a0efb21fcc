//! Cost of the AD-derived accelerations against a hand-written closed form.
//!
//! Groups: `double_pendulum` (closed form, energy route, particle route) and `n_pendulum/N` for
//! N = 2, 4, 8, 16, 32. `python3 benches/ratios.py` turns criterion's estimates into the table of
//! ratios that docs/site/crate.rst quotes.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lagrangian::Dynamics;
use lagrangian::scenes::{DoublePendulum, NPendulum};
use std::hint::black_box;

// The AD routes write into a black-boxed `out` rather than returning a copy of it: reading the
// two 8-byte stores back as one 16-byte value stalls store forwarding (~4 ns), a cost of the
// benchmark harness, not of the equations of motion. For the same reason the inputs are
// black-boxed as array references (one 8-byte pointer each): a black-boxed slice is a pointer and
// a length stored separately, and passing it on reloads them as one 16-byte value.
fn double_pendulum(c: &mut Criterion) {
    let dp = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81);
    let energy = dp.system();
    let particles = dp.particles();
    let (q, qd) = ([0.7, -0.4], [0.3, 1.2]);
    let mut g = c.benchmark_group("double_pendulum");
    g.bench_function("closed_form", |b| {
        b.iter(|| {
            let (q, qd): (&[f64; 2], &[f64; 2]) = (black_box(&q), black_box(&qd));
            dp.closed_form_accelerations(q, qd)
        })
    });
    g.bench_function("energy_route", |b| {
        let mut out = [0.0; 2];
        b.iter(|| {
            let (q, qd): (&[f64; 2], &[f64; 2]) = (black_box(&q), black_box(&qd));
            let out: &mut [f64; 2] = black_box(&mut out);
            energy.accelerations_into(0.0, q, qd, out).unwrap()
        })
    });
    g.bench_function("particle_route", |b| {
        let mut out = [0.0; 2];
        b.iter(|| {
            let (q, qd): (&[f64; 2], &[f64; 2]) = (black_box(&q), black_box(&qd));
            let out: &mut [f64; 2] = black_box(&mut out);
            particles.accelerations_into(0.0, q, qd, out).unwrap()
        })
    });
    g.finish();
}

fn n_pendulum(c: &mut Criterion) {
    let mut g = c.benchmark_group("n_pendulum");
    for n in [2, 4, 8, 16, 32] {
        let chain = NPendulum::uniform(n, 1.0, 1.0, 9.81);
        let energy = chain.clone().system();
        let particles = chain.clone().particles();
        let q: Vec<f64> = (0..n).map(|i| 0.5 * (i as f64 * 0.7).sin()).collect();
        let qd: Vec<f64> = (0..n).map(|i| 0.3 * (i as f64 * 1.3).cos()).collect();
        let mut out = vec![0.0; n];
        g.bench_with_input(BenchmarkId::new("closed_form", n), &n, |b, _| {
            b.iter(|| chain.closed_form_accelerations(black_box(&q), black_box(&qd)))
        });
        g.bench_with_input(BenchmarkId::new("energy_route", n), &n, |b, _| {
            b.iter(|| {
                energy
                    .accelerations_into(0.0, black_box(&q), black_box(&qd), &mut out)
                    .unwrap();
            })
        });
        g.bench_with_input(BenchmarkId::new("particle_route", n), &n, |b, _| {
            b.iter(|| {
                particles
                    .accelerations_into(0.0, black_box(&q), black_box(&qd), &mut out)
                    .unwrap();
            })
        });
    }
    g.finish();
}

criterion_group!(benches, double_pendulum, n_pendulum);
criterion_main!(benches);
