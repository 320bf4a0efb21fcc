//! Which route each method takes on a ready-made scene: the Rust system alone (the dual-number
//! Jacobians, as before scenes were traced) against the same system with its traced eq. 55
//! program (`trace::WithProgram`, what `lg.scenes` holds), per method, best of REPEAT (default 5)
//! runs; and the one-off cost of tracing and compiling each scene. Run with
//! `cargo run --profile ci --features jit --example scene_routes`.
use lagrangian::Dynamics;
use lagrangian::integrators::{Method, Options, solve};
use lagrangian::scenes::registry::{Arguments, Scene};
use lagrangian::scenes::{DampedOscillator, DoublePendulum, Kepler, NPendulum};
use lagrangian::trace::{TraceEnergies, WithProgram};
use std::time::Instant;

/// Best wall time in microseconds of `f` over `repeat` runs.
fn best(repeat: usize, mut f: impl FnMut()) -> f64 {
    (0..repeat)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e6
        })
        .fold(f64::INFINITY, f64::min)
}

fn compare<S: Scene>(q0: &[f64], v0: &[f64], t_end: f64, repeat: usize)
where
    S::System: TraceEnergies,
{
    let args = Arguments::new(&S::INFO, vec![]).unwrap();
    let name = S::INFO.name;
    let trace = best(repeat, || {
        let model = WithProgram::new(S::build(&args).unwrap(), name);
        model.program().unwrap();
    });
    let traced = WithProgram::new(S::build(&args).unwrap(), name);
    traced.program().unwrap();
    let plain = S::build(&args).unwrap();
    println!("{name}: trace and compile {trace:.0} us");
    let runs = [
        (Method::Dop853, Options::adaptive(1e-9, 1e-9)),
        (Method::Radau5, Options::adaptive(1e-9, 1e-9)),
        (Method::Gauss6, Options::fixed(1e-2)),
        (Method::Taylor, Options::adaptive(1e-9, 1e-9)),
        (Method::Auto, Options::adaptive(1e-9, 1e-9)),
    ];
    for (method, options) in runs {
        let span = (0.0, t_end);
        let with = best(repeat, || {
            solve(&traced, q0, v0, span, method, &options).unwrap();
        });
        let chosen = solve(&traced, q0, v0, span, method, &options)
            .unwrap()
            .stats
            .method;
        let without = match method.check_fits(&plain, 0.0, q0, v0) {
            Ok(()) => {
                let us = best(repeat, || {
                    solve(&plain, q0, v0, span, method, &options).unwrap();
                });
                format!("{us:10.0} us")
            }
            Err(_) => format!("{:>13}", "n/a"),
        };
        let plain_chosen = solve(&plain, q0, v0, span, method, &options)
            .map(|s| s.stats.method.name())
            .unwrap_or("-");
        println!(
            "  {:8} Rust only {without} ({plain_chosen:7}) | with program {with:10.0} us ({})",
            method.name(),
            chosen.name()
        );
    }
    let _ = plain.dof();
}

fn main() {
    let repeat = std::env::var("REPEAT")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(5);
    compare::<DoublePendulum>(&[1.0, 0.5], &[0.0, 0.0], 10.0, repeat);
    compare::<NPendulum>(&[0.5, 0.3, 0.1], &[0.0, 0.0, 0.0], 10.0, repeat);
    compare::<Kepler>(&[1.0, 0.0], &[0.0, 1.25], 20.0, repeat);
    compare::<DampedOscillator>(&[1.0], &[0.0], 20.0, repeat);
}
