//! Ensembles ([`solve_many`], feature `parallel`): every run bit for bit the serial
//! [`solve_partial`] of the same problem with 1 and 2 threads, in input order; parameter sweeps
//! against closed forms; failed runs keep their typed error and do not disturb the others;
//! [`Output::Final`] keeps the last state only; events of each run's own.
// `Failed` is returned once per run, as in the library.
#![allow(clippy::result_large_err)]

use lagrangian::integrators::{
    Event, Method, Options, Output, RunResult, Status, Systems, solve_many, solve_partial,
};
use lagrangian::scenes::{DampedOscillator, SimplePendulum, elliptic_k};
use lagrangian::tape::{
    Binary, EnergyModel, EomProgram, Function, Graph, Inputs, Tape, Unary, models,
};
use lagrangian::{Error, Result};
use std::sync::Arc;

const G: f64 = 9.81;

/// `k` initial states (θ₀, 0) with amplitudes spread over (0.1, 3.0).
fn amplitudes(k: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
    (0..k)
        .map(|i| (vec![0.1 + 2.9 * (i as f64 + 0.5) / k as f64], vec![0.0]))
        .collect()
}

fn slices(states: &[(Vec<f64>, Vec<f64>)]) -> Vec<(&[f64], &[f64])> {
    states.iter().map(|(q, qd)| (&q[..], &qd[..])).collect()
}

#[test]
fn every_run_is_the_serial_run_bit_for_bit() {
    let pendulum = SimplePendulum::new(1.0, 1.3, G).system();
    let states = amplitudes(100);
    let initial = slices(&states);
    let span = (0.0, 7.0);
    let times: Vec<f64> = (0..=70).map(|i| 0.1 * i as f64).collect();
    for (method, options) in [
        (Method::Dop853, Options::adaptive(1e-10, 1e-12)),
        (
            Method::Dopri5,
            Options::adaptive(1e-8, 1e-10).with_output(Output::Times(times.clone())),
        ),
        (
            Method::Gauss4,
            Options::fixed(0.01).with_output(Output::Final),
        ),
        (Method::Auto, Options::adaptive(1e-6, 1e-9)),
    ] {
        let serial: Vec<RunResult> = initial
            .iter()
            .map(|(q0, qd0)| solve_partial(&pendulum, q0, qd0, span, method, &options, None))
            .collect();
        assert!(serial.iter().all(|r| r.is_ok()), "{method}");
        for workers in [1, 2] {
            let runs = solve_many(
                Systems::One(&pendulum),
                &initial,
                span,
                method,
                &options,
                workers,
                None,
            )
            .unwrap();
            assert_eq!(runs, serial, "{method} on {workers} threads");
        }
    }
}

/// Events that depend on the run ([`Systems::EachWithEvents`]): pendulums of lengths lᵢ
/// released at rest from θ₀ = 1 stop where θ falls through 0.5/√lᵢ (terminal), before the
/// bottom, which every run also watches for (an event shared through the options). By energy
/// the speed there is √(2 g (cos θ − cos θ₀) / l); each run is the serial run with the same
/// events, bit for bit.
#[test]
fn events_of_each_run_stop_it_where_its_own_condition_holds() {
    let lengths: [f64; 4] = [0.5, 1.0, 2.0, 4.0];
    let states: Vec<_> = lengths.iter().map(|_| (vec![1.0], vec![0.0])).collect();
    let initial = slices(&states);
    let bottom = Event::new("bottom", |_, q, _| q[0]).falling();
    // Run i stops at θ = 0.5/√lᵢ: a threshold of its own.
    let threshold = |i: usize| {
        let at = 0.5 / lengths[i].sqrt();
        Event::new("threshold", move |_, q, _| q[0] - at)
            .falling()
            .terminal(1)
    };
    let build = |i: usize| {
        Ok((
            SimplePendulum::new(1.0, lengths[i], G).system(),
            vec![threshold(i)],
        ))
    };
    let options = Options::adaptive(1e-12, 1e-12)
        .with_output(Output::Final)
        .with_event(bottom.clone());
    let runs = solve_many(
        Systems::EachWithEvents(&build),
        &initial,
        (0.0, 10.0),
        Method::Dop853,
        &options,
        2,
        None,
    )
    .unwrap();
    for (i, run) in runs.iter().enumerate() {
        let sol = run.as_ref().unwrap();
        let at = 0.5 / lengths[i].sqrt();
        assert!(
            matches!(sol.status, Status::Terminated { event: 1, .. }),
            "run {i}: {:?}",
            sol.status
        );
        assert_eq!(sol.events.len(), 2);
        assert!(
            sol.events[0].t.is_empty(),
            "the threshold before the bottom"
        );
        let (t, q, qd) = sol.last().unwrap();
        assert!((q[0] - at).abs() < 1e-12, "run {i}: θ = {}", q[0]);
        let speed = (2.0 * G * (at.cos() - 1f64.cos()) / lengths[i]).sqrt();
        assert!(
            (qd[0] + speed).abs() < 1e-10 * speed,
            "run {i}: θ̇ = {}",
            qd[0]
        );
        assert_eq!(sol.events[1].t, vec![t]);
        // The same run alone, with the options' events then its own.
        let alone = solve_partial(
            &SimplePendulum::new(1.0, lengths[i], G).system(),
            &[1.0],
            &[0.0],
            (0.0, 10.0),
            Method::Dop853,
            &options.clone().with_event(threshold(i)),
            None,
        );
        assert_eq!(run, &alone, "run {i}");
    }
}

/// A sweep over the pendulum's length: with l = g / K(sin(θ₀/2))², a quarter period
/// √(l/g) K(sin(θ₀/2)) is 1, so every pendulum released at rest from θ₀ passes θ = 0 at t = 1
/// with θ̇ = −√(2 g (1 − cos θ₀) / l) (energy).
#[test]
fn length_sweep_passes_the_bottom_at_the_quarter_period() {
    let states = amplitudes(200);
    let initial = slices(&states);
    let length = |i: usize| -> Result<f64> {
        let k = elliptic_k((states[i].0[0] / 2.0).sin())?;
        Ok(G / (k * k))
    };
    let build = |i: usize| Ok(SimplePendulum::new(1.0, length(i)?, G).system());
    let options = Options::adaptive(1e-12, 1e-12).with_output(Output::Final);
    let runs = solve_many(
        Systems::Each(&build),
        &initial,
        (0.0, 1.0),
        Method::Dop853,
        &options,
        2,
        None,
    )
    .unwrap();
    assert_eq!(runs.len(), 200);
    for (i, run) in runs.iter().enumerate() {
        let sol = run.as_ref().unwrap();
        assert_eq!(sol.len(), 1, "final only");
        let (t, q, qd) = sol.last().unwrap();
        assert_eq!(t, 1.0);
        let (theta0, l) = (states[i].0[0], length(i).unwrap());
        let speed = (2.0 * G * (1.0 - theta0.cos()) / l).sqrt();
        assert!(q[0].abs() < 1e-9 * speed, "run {i}: θ(T/4) = {}", q[0]);
        assert!(
            (qd[0] + speed).abs() < 1e-9 * speed,
            "run {i}: θ̇ = {} against {}",
            qd[0],
            -speed
        );
    }
}

/// A sweep over the mass with some zero masses: those runs fail with the typed singular-M
/// error at the start, keeping the initial state; the others match the closed form.
#[test]
fn failed_runs_are_kept_and_do_not_disturb_the_others() {
    let masses: Vec<f64> = (0..40)
        .map(|i| {
            if i % 7 == 3 {
                0.0
            } else {
                0.5 + 0.1 * i as f64
            }
        })
        .collect();
    let states = vec![(vec![1.0], vec![0.5]); masses.len()];
    let initial = slices(&states);
    let build = |i: usize| Ok(DampedOscillator::new(masses[i], 4.0, 0.3).system());
    let options = Options::adaptive(1e-11, 1e-12).with_output(Output::Final);
    let runs = solve_many(
        Systems::Each(&build),
        &initial,
        (0.0, 3.0),
        Method::Dop853,
        &options,
        2,
        None,
    )
    .unwrap();
    for (i, run) in runs.iter().enumerate() {
        let oscillator = DampedOscillator::new(masses[i], 4.0, 0.3);
        match run {
            Ok(sol) => {
                assert!(masses[i] > 0.0);
                let (x, v) = oscillator.exact_solution(1.0, 0.5, 3.0).unwrap();
                let (_, q, qd) = sol.last().unwrap();
                assert!(
                    (q[0] - x).abs() < 1e-9 && (qd[0] - v).abs() < 1e-9,
                    "run {i}"
                );
            }
            Err(failed) => {
                assert_eq!(masses[i], 0.0, "run {i}: {}", failed.error);
                assert!(
                    matches!(failed.error, Error::SingularMassMatrix { t, .. } if t == 0.0),
                    "{}",
                    failed.error
                );
                let partial = failed.partial.as_ref().unwrap();
                assert_eq!(
                    (partial.t.as_slice(), partial.q.as_slice()),
                    (&[0.0][..], &[1.0][..])
                );
            }
        }
    }
    assert_eq!(runs.iter().filter(|r| r.is_err()).count(), 6);
}

/// A build that fails fails its run only, with its error and nothing computed.
#[test]
fn a_failed_build_fails_its_run() {
    let states = amplitudes(5);
    let initial = slices(&states);
    let build = |i: usize| -> Result<_> {
        if i == 2 {
            return Err(Error::InvalidInput {
                what: "length",
                why: "run 2".into(),
            });
        }
        Ok(SimplePendulum::new(1.0, 1.0, G).system())
    };
    let options = Options::default();
    let runs = solve_many(
        Systems::Each(&build),
        &initial,
        (0.0, 1.0),
        Method::Dop853,
        &options,
        2,
        None,
    )
    .unwrap();
    let failed = runs[2].as_ref().unwrap_err();
    assert!(matches!(
        failed.error,
        Error::InvalidInput { what: "length", .. }
    ));
    assert!(failed.partial.is_none() && failed.last.is_none());
    assert!(runs.iter().enumerate().all(|(i, r)| i == 2 || r.is_ok()));
}

/// [`Output::Final`]: the last row of the every-step run, alone; a failure keeps the last
/// accepted state.
#[test]
fn final_only_is_the_last_row() {
    let pendulum = SimplePendulum::new(1.0, 1.0, G).system();
    let run = |output: Output, max_steps: usize| {
        let options = Options::adaptive(1e-9, 1e-11)
            .with_output(output)
            .with_max_steps(max_steps);
        solve_partial(
            &pendulum,
            &[2.0],
            &[0.0],
            (0.0, 10.0),
            Method::Dop853,
            &options,
            None,
        )
    };
    let steps = run(Output::Steps, 100_000).unwrap();
    let last = run(Output::Final, 100_000).unwrap();
    let (t, q, qd) = steps.last().unwrap();
    assert_eq!(
        (last.t.as_slice(), last.q.as_slice(), last.qd.as_slice()),
        (&[t][..], q, qd)
    );
    assert_eq!(last.stats, steps.stats);
    let failed = run(Output::Final, 20).unwrap_err();
    let partial = failed.partial.unwrap();
    let (t, q, qd) = failed.last.unwrap();
    assert_eq!(
        (partial.t, partial.q, partial.qd),
        (vec![t], q.clone(), qd.clone())
    );
    assert!(t > 0.0 && t < 10.0);
}

/// An interrupt stops every run, started or not.
#[test]
fn interrupt_stops_every_run() {
    let pendulum = SimplePendulum::new(1.0, 1.0, G).system();
    let states = amplitudes(50);
    let stop = |_t: f64| true;
    let runs = solve_many(
        Systems::One(&pendulum),
        &slices(&states),
        (0.0, 10.0),
        Method::Dop853,
        &Options::default(),
        2,
        Some(&stop),
    )
    .unwrap();
    assert!(
        runs.iter()
            .all(|r| matches!(r, Err(f) if matches!(f.error, Error::Interrupted { .. })))
    );
}

/// The double pendulum's energies on a graph ([`models::double_pendulum`]), with the
/// forcing `forcing` cos(t) on θ₁ when it is not 0 (a time-dependent model): its tapes and its
/// compiled program, unbound, and a model of them bound to `params` (m₁, m₂, l₁, l₂, g).
struct Pendulums {
    dof: usize,
    tapes: (Arc<Tape>, Arc<Tape>, Option<Arc<Tape>>),
    program: EomProgram,
}

impl Pendulums {
    fn new(forcing: f64) -> Self {
        let mut g = Graph::new();
        let mut parts = models::double_pendulum(&mut g).unwrap();
        if forcing != 0.0 {
            let (f, t, zero) = (g.constant(forcing), g.time(), g.constant(0.0));
            let cos = g.unary(Unary::Cos, t).unwrap();
            let q1 = g.binary(Binary::Mul, f, cos).unwrap();
            parts.forces = Some(vec![q1, zero]);
        }
        let program = EomProgram::new(&mut g, 2, 5, &parts).unwrap();
        let all = Inputs::kinetic(2, 5);
        let tape =
            |nodes: &[usize], inputs| Arc::new(Tape::new(&g, nodes, inputs, "part").unwrap());
        let tapes = (
            tape(&[parts.kinetic], all),
            tape(&[parts.potential.unwrap()], Inputs::potential(2, 5)),
            parts.forces.as_ref().map(|q| tape(q, all)),
        );
        Self {
            dof: 2,
            tapes,
            program,
        }
    }

    fn bind(&self, params: &[f64]) -> Result<EnergyModel> {
        let f = |tape: &Arc<Tape>| Function::new(tape.clone(), params);
        EnergyModel::new(
            self.dof,
            f(&self.tapes.0)?,
            Some(f(&self.tapes.1)?),
            None,
            self.tapes.2.as_ref().map(f).transpose()?,
        )?
        .with_program(self.program.bind(params)?)
    }
}

/// Taylor ensembles to their final states or to states at given times run in the lanes of the
/// machine's vectors (`integrators/batch.rs`): each run is still the serial run bit for bit —
/// its states, counters and status — on 1 and 2 threads, with a number of runs that leaves lanes empty at
/// the end; for one model, for one model bound to each run's parameters (lanes of different
/// g, masses and lengths side by side), and for a forced (time-dependent) model. Runs the lanes
/// give up run alone and fail as they fail alone: one that passes `max_steps`, one whose
/// initial state is not finite.
#[test]
fn taylor_runs_in_lanes_are_the_serial_runs_bit_for_bit() {
    let pendulums = Pendulums::new(0.0);
    let forced = Pendulums::new(0.7);
    let nominal = [1.0, 1.5, 1.0, 0.8, G];
    let model = pendulums.bind(&nominal).unwrap();
    let forced_model = forced.bind(&nominal).unwrap();
    let k = 37;
    let mut states: Vec<_> = (0..k)
        .map(|i| {
            let a = -2.0 + 4.0 * (i as f64 + 0.5) / k as f64;
            (vec![a, 0.5 * a], vec![0.1 * a, 0.0])
        })
        .collect();
    states[5].0[1] = f64::NAN;
    let initial = slices(&states);
    let params: Vec<[f64; 5]> = (0..k)
        .map(|i| {
            let s = 1.0 + 0.02 * i as f64;
            [1.0, 1.5 * s, 1.0 / s, 0.8, G * s]
        })
        .collect();
    let build = |i: usize| pendulums.bind(&params[i]);
    let span = (0.0, 6.0);
    let options = Options::adaptive(1e-10, 1e-10).with_output(Output::Final);
    let serial = |system: &dyn Fn(usize) -> EnergyModel, options: &Options| -> Vec<RunResult> {
        (initial.iter().enumerate())
            .map(|(i, (q0, qd0))| {
                solve_partial(&system(i), q0, qd0, span, Method::Taylor, options, None)
            })
            .collect()
    };
    let one = |_: usize| model.clone();
    // The median run's steps: the longer runs fail with TooManySteps.
    let mut steps: Vec<usize> = (serial(&one, &options).iter().flatten())
        .map(|s| s.stats.accepted_steps)
        .collect();
    steps.sort();
    let mut limited = options.clone();
    limited.max_steps = steps[steps.len() / 2];
    // States at times, from each step's polynomial: t₀ itself, the end, and between.
    let times: Vec<f64> = (0..=24).map(|i| 0.25 * i as f64).collect();
    let timed = options.clone().with_output(Output::Times(times));
    let each = |i: usize| build(i).unwrap();
    let forced_one = |_: usize| forced_model.clone();
    for (name, systems, alone, options) in [
        (
            "one model",
            Systems::One(&model),
            &one as &dyn Fn(usize) -> _,
            &options,
        ),
        ("one model, max_steps", Systems::One(&model), &one, &limited),
        ("a parameter sweep", Systems::Each(&build), &each, &options),
        ("forced", Systems::One(&forced_model), &forced_one, &options),
        ("at times", Systems::One(&model), &one, &timed),
        ("a sweep at times", Systems::Each(&build), &each, &timed),
    ] {
        let want = serial(alone, options);
        let failed = want.iter().filter(|r| r.is_err()).count();
        assert!(failed >= 1 && failed < k / 2 + 2, "{name}: {failed} failed");
        for workers in [1, 2] {
            let runs = solve_many(
                systems,
                &initial,
                span,
                Method::Taylor,
                options,
                workers,
                None,
            )
            .unwrap();
            assert_eq!(runs, want, "{name} on {workers} threads");
        }
    }
    let too_many =
        |r: &RunResult| matches!(r, Err(f) if matches!(f.error, Error::TooManySteps { .. }));
    assert!(
        serial(&one, &limited)
            .iter()
            .filter(|r| too_many(r))
            .count()
            >= k / 3
    );
}
