//! Time to a final error on the benchmark scenes: the hand-written closed forms
//! (`closed_forms/`) against the same systems built in Rust from a [`Graph`] and compiled
//! ([`EomProgram`] behind an [`EnergyModel`], what a Rust user of `tape` gets), both integrated
//! by [`solve`] with the same method. `benches/compiled_models.py` drives it to add the models
//! stated through the Python API and print the table of docs/site/python.rst.
//!
//! ```text
//! cargo bench -p lagrangian-benches --bench compiled --features jit -- \
//!     [--rounds R] [--scenes a,b,…] [--t-scale X]
//! cargo bench -p lagrangian-benches --bench compiled --features jit -- --serve
//! ```
//!
//! Without `--serve` it measures every scene (or those named) and prints one JSON object per
//! line: the scene (parameters, initial state, reference end state), then per side the
//! loosest tolerance of a ladder that reaches each target error and its best-of-R time, and the
//! graph model's build time; `--t-scale` multiplies every scene's span. With `--serve` it
//! answers one JSON line per request read from stdin, so that the Python script can alternate
//! its own rounds with these:
//!
//! - `scenes` — every scene as above, with closed-form accelerations at a few states for the
//!   caller to check its own model against;
//! - `run SCENE SIDE METHOD TOL INNER` — SIDE is `closed` or `graph`: the best of INNER runs at
//!   rtol = atol = TOL, with the statistics and the error of the end state;
//! - `call SCENE SIDE REPS` — one accelerations call at a check state, the best per-call time
//!   over five batches of REPS calls;
//! - `build SCENE INNER` — the best of INNER builds of the graph model (graph, derivation,
//!   compilation, binding);
//! - `quit`.
//!
//! The error of an end state y against the reference r is maxᵢ |yᵢ − rᵢ| / max(1, |rᵢ|) over
//! y = (q, q̇); the reference is DOP853 on the closed form at rtol = atol = 1e-14, and
//! `reference_spread` is its distance to the run at 1e-13.

use lagrangian::integrators::{Method, Options, Output, solve};
use lagrangian::scenes::{BallInSphere, DoublePendulum, ElasticPendulum, ForcedTwoMass, NPendulum};
use lagrangian::tape::{
    Binary, Energies, EnergyModel, EomProgram, Function, Graph, Inputs, Tape, Unary, models,
};
use lagrangian::{Dynamics, Error, Result};
use std::hint::black_box;
use std::io::{BufRead, Write};
use std::time::Instant;

mod closed_forms;
use closed_forms::{
    ClosedBallInSphere, ClosedDoublePendulum, ClosedForcedTwoMass, ClosedNPendulum,
    ClosedStiffSpring,
};

/// The target errors of the table.
const TARGETS: [f64; 2] = [1e-6, 1e-9];

/// The tolerance ladder 10^{-k/2}, 1e-4 … 1e-13, loosest first.
fn ladder() -> impl Iterator<Item = f64> {
    (8..=26).map(|k| 10f64.powf(-f64::from(k) / 2.0))
}

/// The systems measured.
#[derive(Debug, Clone)]
enum Kind {
    Double(DoublePendulum),
    Forced(ForcedTwoMass),
    Ball(BallInSphere),
    /// The spring pendulum and its radial damping c.
    Stiff(ElasticPendulum, f64),
    /// A chain of n uniform links (m = l = 1, g = 9.81).
    Chain(usize),
}

/// A scene: system, parameters by name (in the graph's parameter order), initial state, span
/// and method.
#[derive(Debug, Clone)]
struct Scene {
    name: String,
    kind: Kind,
    params: Vec<(&'static str, f64)>,
    q0: Vec<f64>,
    qd0: Vec<f64>,
    t_end: f64,
    method: Method,
}

/// The scenes, their spans multiplied by `t_scale`.
fn scenes(t_scale: f64) -> Vec<Scene> {
    let dp = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81);
    let forced = ForcedTwoMass::new(1.0, 0.5, 10.0, 5.0).with_forcing(1.0, 0.5, 2.0);
    let ball = BallInSphere::new(1.0, 0.016, 1.0, 0.2, 9.81);
    // Radial damping ratio 10: relaxation modes at −2e4 and −50 per second next to a swing of
    // about 3 rad/s — stiff (`Method::Auto` picks radau5).
    let (spring, c) = (ElasticPendulum::new(1.0, 1e6, 1.0, 9.81), 2e4);
    let double_pendulum = Scene {
        name: "double_pendulum".into(),
        kind: Kind::Double(dp),
        params: vec![
            ("m1", 1.0),
            ("m2", 1.0),
            ("l1", 1.0),
            ("l2", 1.0),
            ("g", 9.81),
        ],
        q0: vec![1.0, 0.5],
        qd0: vec![0.0, 0.0],
        t_end: 10.0,
        method: Method::Dop853,
    };
    let mut all = vec![
        double_pendulum.clone(),
        Scene {
            name: "double_pendulum_gauss4".into(),
            method: Method::Gauss4,
            ..double_pendulum
        },
        Scene {
            name: "forced_two_mass".into(),
            kind: Kind::Forced(forced),
            params: vec![
                ("m1", forced.m1),
                ("m2", forced.m2),
                ("k1", forced.k1),
                ("k2", forced.k2),
                ("f1", forced.f1),
                ("f2", forced.f2),
                ("omega", forced.omega),
            ],
            q0: vec![0.1, -0.05],
            qd0: vec![0.0, 0.3],
            t_end: 10.0,
            method: Method::Dop853,
        },
        Scene {
            name: "ball_in_sphere".into(),
            kind: Kind::Ball(ball),
            params: vec![
                ("m", ball.m),
                ("j", ball.j),
                ("r1", ball.r1),
                ("r2", ball.r2),
                ("g", ball.g),
            ],
            q0: vec![1.0],
            qd0: vec![0.0],
            t_end: 10.0,
            method: Method::Dop853,
        },
        Scene {
            name: "stiff_spring".into(),
            kind: Kind::Stiff(spring, c),
            params: vec![
                ("m", spring.m),
                ("k", spring.k),
                ("l0", spring.l0),
                ("g", spring.g),
                ("c", c),
            ],
            q0: vec![1.001, 0.5],
            qd0: vec![0.0, 0.0],
            t_end: 2.0,
            method: Method::Radau5,
        },
    ];
    for n in [2, 4, 8, 16, 32] {
        all.push(Scene {
            name: format!("n_pendulum_{n}"),
            kind: Kind::Chain(n),
            params: vec![("m", 1.0), ("l", 1.0), ("g", 9.81)],
            q0: (0..n).map(|i| 0.5 * (i as f64 * 0.7).sin()).collect(),
            qd0: (0..n).map(|i| 0.3 * (i as f64 * 1.3).cos()).collect(),
            t_end: 2.0,
            method: Method::Dop853,
        });
    }
    for s in &mut all {
        s.t_end *= t_scale;
    }
    all
}

/// The offset of the first coordinate in the check states: the spring's length stays near 2.
fn radius(kind: &Kind) -> f64 {
    if matches!(kind, Kind::Stiff(..)) {
        2.0
    } else {
        0.0
    }
}

/// Run `$body` with `$sys` bound to the scene's closed form.
macro_rules! with_closed {
    ($kind:expr, $sys:ident => $body:expr) => {
        match $kind {
            Kind::Double(dp) => {
                let $sys = ClosedDoublePendulum(*dp);
                $body
            }
            Kind::Forced(f) => {
                let $sys = ClosedForcedTwoMass(*f);
                $body
            }
            Kind::Ball(b) => {
                let $sys = ClosedBallInSphere(*b);
                $body
            }
            Kind::Stiff(spring, c) => {
                let $sys = ClosedStiffSpring {
                    spring: *spring,
                    c: *c,
                };
                $body
            }
            Kind::Chain(n) => {
                let $sys = ClosedNPendulum::new(NPendulum::uniform(*n, 1.0, 1.0, 9.81));
                $body
            }
        }
    };
}

// ---------------------------------------------------------------------------------------------
// The same systems stated on a graph

/// The few operations the graphs below are written with.
struct Ops<'a>(&'a mut Graph);

impl Ops<'_> {
    fn add(&mut self, a: usize, b: usize) -> Result<usize> {
        self.0.binary(Binary::Add, a, b)
    }
    fn sub(&mut self, a: usize, b: usize) -> Result<usize> {
        self.0.binary(Binary::Sub, a, b)
    }
    fn div(&mut self, a: usize, b: usize) -> Result<usize> {
        self.0.binary(Binary::Div, a, b)
    }
    /// The product of `factors` (at least one).
    fn mul(&mut self, factors: &[usize]) -> Result<usize> {
        let mut x = factors[0];
        for &f in &factors[1..] {
            x = self.0.binary(Binary::Mul, x, f)?;
        }
        Ok(x)
    }
    fn sq(&mut self, a: usize) -> Result<usize> {
        self.0.powi(a, 2)
    }
    fn cos(&mut self, a: usize) -> Result<usize> {
        self.0.unary(Unary::Cos, a)
    }
}

/// Seed eq. 41–44, parameters (m₁, m₂, k₁, k₂, F₁, F₂, Ω): T = ½ (m₁ ẋ₁² + m₂ ẋ₂²),
/// U = ½ (k₁ x₁² + k₂ (x₂ − x₁)²), Q″ = (F₁, F₂) cos Ω t.
fn forced_graph(g: &mut Graph) -> Result<Energies> {
    let [m1, m2, k1, k2, f1, f2, w] = [0, 1, 2, 3, 4, 5, 6].map(|i| g.param(i));
    let (x1, x2, v1, v2, t) = (
        g.coord(0),
        g.coord(1),
        g.velocity(0),
        g.velocity(1),
        g.time(),
    );
    let half = g.constant(0.5);
    let mut o = Ops(g);
    let (v1s, v2s) = (o.sq(v1)?, o.sq(v2)?);
    let a = o.mul(&[m1, v1s])?;
    let b = o.mul(&[m2, v2s])?;
    let s = o.add(a, b)?;
    let kinetic = o.mul(&[half, s])?;
    let stretch = o.sub(x2, x1)?;
    let (x1s, ss) = (o.sq(x1)?, o.sq(stretch)?);
    let a = o.mul(&[k1, x1s])?;
    let b = o.mul(&[k2, ss])?;
    let s = o.add(a, b)?;
    let potential = o.mul(&[half, s])?;
    let wt = o.mul(&[w, t])?;
    let c = o.cos(wt)?;
    let forces = vec![o.mul(&[f1, c])?, o.mul(&[f2, c])?];
    Ok(Energies {
        kinetic,
        potential: Some(potential),
        dissipation: None,
        forces: Some(forces),
    })
}

/// Seed eq. 49–53, parameters (m, J, r₁, r₂, g): T = ½ (m + J/r₂²)(r₁ − r₂)² θ̇²,
/// U = −m g (r₁ − r₂) cos θ.
fn ball_graph(g: &mut Graph) -> Result<Energies> {
    let [m, j, r1, r2, grav] = [0, 1, 2, 3, 4].map(|i| g.param(i));
    let (th, w) = (g.coord(0), g.velocity(0));
    let (half, minus) = (g.constant(0.5), g.constant(-1.0));
    let mut o = Ops(g);
    let r2s = o.sq(r2)?;
    let jr = o.div(j, r2s)?;
    let inertia = o.add(m, jr)?;
    let arm = o.sub(r1, r2)?;
    let (arms, ws) = (o.sq(arm)?, o.sq(w)?);
    let kinetic = o.mul(&[half, inertia, arms, ws])?;
    let c = o.cos(th)?;
    let potential = o.mul(&[minus, m, grav, arm, c])?;
    Ok(Energies {
        kinetic,
        potential: Some(potential),
        ..Energies::default()
    })
}

/// The spring pendulum with radial damping, parameters (m, k, l₀, g, c):
/// T = ½ m (ṙ² + r² θ̇²), U = ½ k (r − l₀)² − m g r cos θ, Φ = ½ c ṙ².
fn stiff_graph(g: &mut Graph) -> Result<Energies> {
    let [m, k, l0, grav, c] = [0, 1, 2, 3, 4].map(|i| g.param(i));
    let (r, th, rd, thd) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
    let half = g.constant(0.5);
    let mut o = Ops(g);
    let (rds, rs, thds) = (o.sq(rd)?, o.sq(r)?, o.sq(thd)?);
    let a = o.mul(&[rs, thds])?;
    let s = o.add(rds, a)?;
    let kinetic = o.mul(&[half, m, s])?;
    let stretch = o.sub(r, l0)?;
    let ss = o.sq(stretch)?;
    let spring = o.mul(&[half, k, ss])?;
    let cth = o.cos(th)?;
    let weight = o.mul(&[m, grav, r, cth])?;
    let potential = o.sub(spring, weight)?;
    let dissipation = o.mul(&[half, c, rds])?;
    Ok(Energies {
        kinetic,
        potential: Some(potential),
        dissipation: Some(dissipation),
        forces: None,
    })
}

/// The scene as a Rust user of `tape` builds it: the graph, a tape per energy, eq. 55 derived
/// and compiled, all bound to the parameter values.
fn graph_model(scene: &Scene) -> Result<EnergyModel> {
    let mut g = Graph::new();
    let energies = match &scene.kind {
        Kind::Double(_) => models::double_pendulum(&mut g)?,
        Kind::Forced(_) => forced_graph(&mut g)?,
        Kind::Ball(_) => ball_graph(&mut g)?,
        Kind::Stiff(..) => stiff_graph(&mut g)?,
        Kind::Chain(n) => models::pendulum_chain(&mut g, *n)?,
    };
    let params: Vec<f64> = scene.params.iter().map(|p| p.1).collect();
    let (dof, np) = (scene.q0.len(), params.len());
    let bind = |g: &Graph, roots: &[usize], inputs: Inputs, what: &str| {
        Function::new(Tape::new(g, roots, inputs, what)?.into(), &params)
    };
    let all = Inputs::kinetic(dof, np);
    let kinetic = bind(&g, &[energies.kinetic], all, "kinetic energy")?;
    let potential = energies
        .potential
        .map(|u| bind(&g, &[u], Inputs::potential(dof, np), "potential"))
        .transpose()?;
    let dissipation = energies
        .dissipation
        .map(|r| bind(&g, &[r], all, "dissipation function"))
        .transpose()?;
    let forces = energies
        .forces
        .as_ref()
        .map(|f| bind(&g, f, all, "generalized forces"))
        .transpose()?;
    let program = EomProgram::new(&mut g, dof, np, &energies)?.bind(&params)?;
    EnergyModel::new(dof, kinetic, potential, dissipation, forces)?.with_program(program)
}

// ---------------------------------------------------------------------------------------------
// Measurements

/// A number as JSON (`null` when not finite).
fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:e}")
    } else {
        "null".into()
    }
}

fn nums(xs: &[f64]) -> String {
    let v: Vec<String> = xs.iter().map(|&x| num(x)).collect();
    format!("[{}]", v.join(", "))
}

/// The error of end state `y` against `reference` (see the module docs).
fn error(y: &[f64], reference: &[f64]) -> f64 {
    y.iter()
        .zip(reference)
        .map(|(a, b)| (a - b).abs() / b.abs().max(1.0))
        .fold(0.0, f64::max)
}

/// One timed configuration: the best wall time of its runs and the last run's statistics.
struct Run {
    seconds: f64,
    rhs: usize,
    jacobians: usize,
    steps: usize,
    rejected: usize,
    end: Vec<f64>,
}

impl Run {
    fn json(
        &self,
        scene: &Scene,
        side: &str,
        method: Method,
        tol: f64,
        reference: &[f64],
    ) -> String {
        format!(
            "{{\"kind\": \"run\", \"scene\": \"{}\", \"side\": \"{side}\", \"method\": \"{method}\", \
             \"tol\": {}, \"seconds\": {}, \"rhs\": {}, \"jacobians\": {}, \"steps\": {}, \
             \"rejected\": {}, \"error\": {}, \"end\": {}}}",
            scene.name,
            num(tol),
            num(self.seconds),
            self.rhs,
            self.jacobians,
            self.steps,
            self.rejected,
            num(error(&self.end, reference)),
            nums(&self.end)
        )
    }
}

/// The order p of a fixed-step method (`None` for an adaptive one).
fn fixed_order(method: Method) -> Option<usize> {
    method
        .order()
        .filter(|_| method.is_adaptive() == Some(false))
}

/// The options a ladder tolerance τ stands for: rtol = atol = τ, or for a fixed-step method of
/// order p the step τ^(1/p) (so that its error scales like τ), shortened so that whole steps
/// end at t_end. `benches/compiled_models.py` (`options`) computes the same.
fn options(scene: &Scene, method: Method, tol: f64) -> Options {
    match fixed_order(method) {
        Some(p) => {
            let steps = (scene.t_end / tol.powf(1.0 / p as f64)).ceil();
            Options::fixed(scene.t_end / steps)
        }
        None => Options::adaptive(tol, tol),
    }
}

/// The best of `inner` runs of `sys` over the scene at the ladder tolerance `tol` (see
/// [`options`]), keeping only the initial and final states.
fn run<S: Dynamics>(sys: &S, scene: &Scene, method: Method, tol: f64, inner: usize) -> Result<Run> {
    let opts = options(scene, method, tol).with_output(Output::Every(usize::MAX));
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..inner.max(1) {
        let start = Instant::now();
        let sol = solve(
            sys,
            &scene.q0,
            &scene.qd0,
            (0.0, scene.t_end),
            method,
            &opts,
        )?;
        best = best.min(start.elapsed().as_secs_f64());
        last = Some(sol);
    }
    let sol = last.expect("at least one run");
    let (_, q, qd) = sol.last().expect("an end state");
    let s = &sol.stats;
    Ok(Run {
        seconds: best,
        rhs: s.rhs_evaluations,
        jacobians: s.jacobian_evaluations,
        steps: s.accepted_steps,
        rejected: s.rejected_steps,
        end: q.iter().chain(qd.iter()).copied().collect(),
    })
}

/// The best over five batches of `reps` calls of the accelerations at `state`, per call.
fn call_seconds<S: Dynamics>(
    sys: &S,
    state: &(f64, Vec<f64>, Vec<f64>),
    reps: usize,
) -> Result<f64> {
    let (t, q, qd) = state;
    let mut out = vec![0.0; q.len()];
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let start = Instant::now();
        for _ in 0..reps.max(1) {
            sys.accelerations_into(black_box(*t), black_box(q), black_box(qd), &mut out)?;
            black_box(&out);
        }
        best = best.min(start.elapsed().as_secs_f64() / reps.max(1) as f64);
    }
    Ok(best)
}

fn bad_side(side: &str) -> Error {
    Error::InvalidInput {
        what: "side",
        why: format!("{side:?} is neither \"closed\" nor \"graph\""),
    }
}

/// A scene ready to measure: its graph model and reference end state.
struct Prepared {
    scene: Scene,
    model: EnergyModel,
    reference: Vec<f64>,
    spread: f64,
}

impl Prepared {
    /// Build the graph model, check both it and the closed form against the library's model,
    /// and integrate the reference.
    fn new(scene: Scene) -> Result<Self> {
        let model = graph_model(&scene)?;
        let n = scene.q0.len();
        let states = closed_forms::states(n, radius(&scene.kind));
        let name = scene.name.as_str();
        with_closed!(&scene.kind, closed => closed_forms::check(name, &closed, &model, &states));
        match &scene.kind {
            Kind::Double(dp) => {
                closed_forms::check(name, &ClosedDoublePendulum(*dp), &dp.system(), &states)
            }
            Kind::Forced(f) => {
                closed_forms::check(name, &ClosedForcedTwoMass(*f), &f.system(), &states)
            }
            Kind::Ball(b) => {
                closed_forms::check(name, &ClosedBallInSphere(*b), &b.system(), &states)
            }
            Kind::Stiff(spring, c) => {
                let closed = ClosedStiffSpring {
                    spring: *spring,
                    c: *c,
                };
                closed_forms::check(name, &closed, &spring.damped(*c), &states)
            }
            Kind::Chain(n) => {
                let chain = NPendulum::uniform(*n, 1.0, 1.0, 9.81);
                let closed = ClosedNPendulum::new(chain.clone());
                closed_forms::check(name, &closed, &chain.system(), &states)
            }
        }
        let end = |tol: f64| -> Result<Vec<f64>> {
            let opts = Options::adaptive(tol, tol)
                .with_output(Output::Every(usize::MAX))
                .with_stiffness_check(None)
                .with_max_steps(100_000_000);
            let sol = with_closed!(&scene.kind, closed => solve(
                &closed, &scene.q0, &scene.qd0, (0.0, scene.t_end), Method::Dop853, &opts
            )?);
            let (_, q, qd) = sol.last().expect("an end state");
            Ok(q.iter().chain(qd.iter()).copied().collect())
        };
        let reference = end(1e-14)?;
        let spread = error(&end(1e-13)?, &reference);
        Ok(Self {
            scene,
            model,
            reference,
            spread,
        })
    }

    fn run(&self, side: &str, method: Method, tol: f64, inner: usize) -> Result<Run> {
        let s = &self.scene;
        match side {
            "closed" => with_closed!(&s.kind, closed => run(&closed, s, method, tol, inner)),
            "graph" => run(&self.model, s, method, tol, inner),
            _ => Err(bad_side(side)),
        }
    }

    /// One accelerations call of `side` at the second check state, best per-call time.
    fn call(&self, side: &str, reps: usize) -> Result<f64> {
        let s = &self.scene;
        let state = &closed_forms::states(s.q0.len(), radius(&s.kind))[1];
        match side {
            "closed" => with_closed!(&s.kind, closed => call_seconds(&closed, state, reps)),
            "graph" => call_seconds(&self.model, state, reps),
            _ => Err(bad_side(side)),
        }
    }

    /// The best of `inner` builds of the graph model.
    fn build_seconds(&self, inner: usize) -> Result<f64> {
        let mut best = f64::INFINITY;
        for _ in 0..inner.max(1) {
            let start = Instant::now();
            black_box(graph_model(&self.scene)?);
            best = best.min(start.elapsed().as_secs_f64());
        }
        Ok(best)
    }

    /// The scene as JSON, with closed-form accelerations at a few states.
    fn json(&self) -> String {
        let s = &self.scene;
        let params: Vec<String> = s
            .params
            .iter()
            .map(|(k, v)| format!("\"{k}\": {}", num(*v)))
            .collect();
        let checks: Vec<String> = closed_forms::states(s.q0.len(), radius(&s.kind))
            .iter()
            .map(|(t, q, qd)| {
                let a = with_closed!(&s.kind, closed => closed.accelerations(*t, q, qd))
                    .expect("closed-form accelerations");
                format!(
                    "{{\"t\": {}, \"q\": {}, \"qd\": {}, \"accelerations\": {}}}",
                    num(*t),
                    nums(q),
                    nums(qd),
                    nums(a.as_slice())
                )
            })
            .collect();
        format!(
            "{{\"kind\": \"scene\", \"scene\": \"{}\", \"dof\": {}, \"params\": {{{}}}, \
             \"q0\": {}, \"qd0\": {}, \"t_end\": {}, \"method\": \"{}\", \"fixed_order\": {}, \
             \"reference\": {}, \"reference_spread\": {}, \"backend\": \"{}\", \"checks\": [{}]}}",
            s.name,
            s.q0.len(),
            params.join(", "),
            nums(&s.q0),
            nums(&s.qd0),
            num(s.t_end),
            s.method,
            fixed_order(s.method).map_or("null".into(), |p| p.to_string()),
            nums(&self.reference),
            num(self.spread),
            self.model
                .program()
                .map_or("none", |p| p.program().backend()),
            checks.join(", ")
        )
    }
}

/// The standalone measurement of one scene: per side the loosest tolerance of the ladder
/// reaching each target, then `rounds` alternating timings of the two sides there.
fn measure(p: &Prepared, rounds: usize) -> Result<()> {
    let method = p.scene.method;
    println!("{}", p.json());
    for target in TARGETS {
        let mut found = Vec::new();
        for side in ["closed", "graph"] {
            let mut tol = None;
            for t in ladder() {
                if error(&p.run(side, method, t, 1)?.end, &p.reference) <= target {
                    tol = Some(t);
                    break;
                }
            }
            found.push((side, tol));
        }
        let mut best: Vec<Option<Run>> = vec![None, None];
        for _ in 0..rounds.max(1) {
            for (k, (side, tol)) in found.iter().enumerate() {
                let Some(tol) = tol else { continue };
                let r = p.run(side, method, *tol, 1)?;
                if best[k].as_ref().is_none_or(|b| r.seconds < b.seconds) {
                    best[k] = Some(r);
                }
            }
        }
        for ((side, tol), r) in found.iter().zip(&best) {
            match (tol, r) {
                (Some(tol), Some(r)) => {
                    let line = r.json(&p.scene, side, method, *tol, &p.reference);
                    println!("{{\"target\": {}, {}", num(target), &line[1..]);
                }
                _ => println!(
                    "{{\"kind\": \"unreached\", \"scene\": \"{}\", \"side\": \"{side}\", \
                     \"target\": {}}}",
                    p.scene.name,
                    num(target)
                ),
            }
        }
    }
    for side in ["closed", "graph"] {
        println!(
            "{{\"kind\": \"call\", \"scene\": \"{}\", \"side\": \"{side}\", \"seconds\": {}}}",
            p.scene.name,
            num(p.call(side, 10_000)?)
        );
    }
    println!(
        "{{\"kind\": \"build\", \"scene\": \"{}\", \"seconds\": {}}}",
        p.scene.name,
        num(p.build_seconds(rounds)?)
    );
    Ok(())
}

/// Answer requests from stdin (see the module docs).
fn serve(prepared: &[Prepared]) -> Result<()> {
    let stdin = std::io::stdin();
    let mut out = std::io::stdout().lock();
    for line in stdin.lock().lines() {
        let line = line.unwrap_or_default();
        let words: Vec<&str> = line.split_whitespace().collect();
        let find = |name: &str| prepared.iter().find(|p| p.scene.name == name);
        let answer = match words.as_slice() {
            [] => continue,
            ["quit"] => break,
            ["scenes"] => {
                let all: Vec<String> = prepared.iter().map(Prepared::json).collect();
                format!("{{\"kind\": \"scenes\", \"scenes\": [{}]}}", all.join(", "))
            }
            ["run", name, side, method, tol, inner] => {
                match (
                    find(name),
                    method.parse::<Method>(),
                    tol.parse(),
                    inner.parse(),
                ) {
                    (Some(p), Ok(m), Ok(tol), Ok(inner)) => match p.run(side, m, tol, inner) {
                        Ok(r) => r.json(&p.scene, side, m, tol, &p.reference),
                        Err(e) => failure(&e.to_string()),
                    },
                    _ => failure(&format!("bad request {line:?}")),
                }
            }
            ["call", name, side, reps] => match (find(name), reps.parse()) {
                (Some(p), Ok(reps)) => match p.call(side, reps) {
                    Ok(s) => format!(
                        "{{\"kind\": \"call\", \"scene\": \"{name}\", \"side\": \"{side}\", \
                         \"seconds\": {}}}",
                        num(s)
                    ),
                    Err(e) => failure(&e.to_string()),
                },
                _ => failure(&format!("bad request {line:?}")),
            },
            ["build", name, inner] => match (find(name), inner.parse()) {
                (Some(p), Ok(inner)) => match p.build_seconds(inner) {
                    Ok(s) => format!(
                        "{{\"kind\": \"build\", \"scene\": \"{name}\", \"seconds\": {}}}",
                        num(s)
                    ),
                    Err(e) => failure(&e.to_string()),
                },
                _ => failure(&format!("bad request {line:?}")),
            },
            _ => failure(&format!("unknown request {line:?}")),
        };
        writeln!(out, "{answer}").expect("stdout");
        out.flush().expect("stdout");
    }
    Ok(())
}

fn failure(why: &str) -> String {
    format!("{{\"kind\": \"error\", \"error\": {why:?}}}")
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
    };
    let rounds = value("--rounds").and_then(|r| r.parse().ok()).unwrap_or(5);
    let t_scale = value("--t-scale")
        .and_then(|r| r.parse().ok())
        .unwrap_or(1.0);
    let wanted: Option<Vec<&str>> = value("--scenes").map(|s| s.split(',').collect());
    let mut prepared = Vec::new();
    for scene in scenes(t_scale) {
        if wanted
            .as_ref()
            .is_none_or(|w| w.contains(&scene.name.as_str()))
        {
            prepared.push(Prepared::new(scene)?);
        }
    }
    if args.iter().any(|a| a == "--serve") {
        serve(&prepared)
    } else {
        prepared.iter().try_for_each(|p| measure(p, rounds))
    }
}
