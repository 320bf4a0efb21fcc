//! Issue 50: the rigid-body route's accelerations per call on the spatial arm
//! (`scenes::SpatialChain`, revolute joints about alternating axes, gravity) at N = 2 … 32 links,
//! against the same T through the energy route. `docs/site/crate.rst` quotes the numbers, next
//! to Pinocchio's ABA on the same arm (`python3 benches/bodies_pinocchio.py`).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lagrangian::Dynamics;
use lagrangian::scenes::SpatialChain;
use std::hint::black_box;
use std::time::Duration;

fn spatial_chain(c: &mut Criterion) {
    let mut g = c.benchmark_group("spatial_chain");
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for n in [2, 4, 8, 16, 32] {
        let bodies = SpatialChain::uniform(n, 1.0, 0.5, 0.05, 9.81).system();
        let q: Vec<f64> = (0..n).map(|i| 0.5 * (i as f64 * 0.7).sin()).collect();
        let qd: Vec<f64> = (0..n).map(|i| 0.3 * (i as f64 * 1.3).cos()).collect();
        let mut out = vec![0.0; n];
        g.bench_with_input(BenchmarkId::new("body_route", n), &n, |b, _| {
            b.iter(|| {
                bodies
                    .accelerations_into(0.0, black_box(&q), black_box(&qd), &mut out)
                    .unwrap();
            })
        });
        let energy = bodies.energy_route();
        g.bench_with_input(BenchmarkId::new("energy_route", n), &n, |b, _| {
            b.iter(|| {
                energy
                    .accelerations_into(0.0, black_box(&q), black_box(&qd), &mut out)
                    .unwrap();
            })
        });
    }
    g.finish();
}

criterion_group!(benches, spatial_chain);
criterion_main!(benches);
