//! Explicit Runge–Kutta methods on y = (q, q̇): fixed steps, or Hairer's step-size control with
//! his error norms, initial-step estimate, dense output and stiffness test (Hairer, Nørsett &
//! Wanner, *Solving ODEs I*, 2nd ed., §II.4, §II.6, §II.10, §IV.2; codes `dopri5.f`,
//! `dop853.f`).

use super::dense::{Ends, Interpolant};
use super::run::{Flow, Integrator, Run, SegmentStepper, copy};
use super::tableau::{self, ErrorEstimate, Tableau};
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use std::marker::PhantomData;
use std::sync::LazyLock;

/// An explicit Runge–Kutta method given by its tableau.
pub(crate) struct ExplicitRk {
    tableau: &'static Tableau,
}

impl ExplicitRk {
    pub(crate) fn new(tableau: &'static Tableau) -> Self {
        Self { tableau }
    }
}

/// The registry's tableaux, built once. Built per call, DOP853's rows and their allocations
/// were 7 % of the time of a one-step `simulate` from Python.
pub(crate) static RK4: LazyLock<Tableau> = LazyLock::new(Tableau::rk4);
pub(crate) static DOPRI5: LazyLock<Tableau> = LazyLock::new(Tableau::dopri5);
pub(crate) static DOP853: LazyLock<Tableau> = LazyLock::new(Tableau::dop853);

/// Where the stepping loop reads a tableau's coefficients. A built-in tableau's are compile-time
/// constants ([`Rk4Consts`], [`Dopri5Consts`]): each stage's combination is then straight-line
/// code with its zero weights gone, as in a hand-written loop, where reading them from the
/// run-time [`Tableau`] cost a load and a branch per weight ([`RunTime`], any other tableau).
/// The same operations in the same order either way.
trait Coefficients: 'static {
    /// Whether the constants below are the tableau's (`false`: read the run-time tableau).
    const BUILTIN: bool;
    /// Number of stages (at most 12).
    const S: usize;
    /// Row i holds a_i0 … a_i,i−1.
    const A: &'static [&'static [f64]];
    const B: &'static [f64];
    const C: &'static [f64];
    const FSAL: bool;
    /// The stage whose argument the stiffness test compares.
    const PROBE: Option<usize>;
    /// The embedded pair's weights e = b − b̂ (empty: none).
    const E: &'static [f64];
}

/// Any tableau: the coefficients read at run time.
struct RunTime;
impl Coefficients for RunTime {
    const BUILTIN: bool = false;
    const S: usize = 0;
    const A: &'static [&'static [f64]] = &[];
    const B: &'static [f64] = &[];
    const C: &'static [f64] = &[];
    const FSAL: bool = false;
    const PROBE: Option<usize> = None;
    const E: &'static [f64] = &[];
}

/// [`RK4`]'s coefficients.
struct Rk4Consts;
impl Coefficients for Rk4Consts {
    const BUILTIN: bool = true;
    const S: usize = 4;
    const A: &'static [&'static [f64]] = tableau::RK4_A;
    const B: &'static [f64] = tableau::RK4_B;
    const C: &'static [f64] = tableau::RK4_C;
    const FSAL: bool = false;
    const PROBE: Option<usize> = None;
    const E: &'static [f64] = &[];
}

/// [`DOPRI5`]'s coefficients.
struct Dopri5Consts;
impl Coefficients for Dopri5Consts {
    const BUILTIN: bool = true;
    const S: usize = 7;
    const A: &'static [&'static [f64]] = tableau::DOPRI5_A;
    const B: &'static [f64] = tableau::DOPRI5_B;
    const C: &'static [f64] = tableau::DOPRI5_C;
    const FSAL: bool = true;
    const PROBE: Option<usize> = Some(5);
    const E: &'static [f64] = tableau::DOPRI5_E;
}

/// Whether `K`'s constants are `tab`'s (the tableau the stepper runs).
fn consts_match<K: Coefficients>(tab: &Tableau) -> bool {
    let e: &[f64] = match &tab.error {
        Some(ErrorEstimate::Embedded { e, .. }) => e,
        _ => &[],
    };
    K::BUILTIN
        && K::S == tab.stages()
        && K::A.iter().copied().eq(tab.a.iter().map(Vec::as_slice))
        && K::B == tab.b
        && K::C == tab.c
        && K::FSAL == tab.fsal
        && K::PROBE == tab.stiffness.map(|p| p.stage)
        && K::E == e
}

/// Preallocated work space: nothing is allocated inside the step loop.
struct Cache {
    /// Stages 0..s, then f(t + h, y₁), then the extra stages of the dense output.
    k: Vec<Vec<f64>>,
    y: Vec<f64>,
    y_new: Vec<f64>,
    stage: Vec<f64>,
    /// Argument of the stage the stiffness test compares.
    probe: Vec<f64>,
    /// Error-estimate accumulators.
    err: Vec<f64>,
    err3: Vec<f64>,
    /// Dense-output coefficients F₀, F₁, ….
    f: Vec<Vec<f64>>,
}

impl Cache {
    fn new(tableau: &Tableau, y0: &[f64]) -> Self {
        let m = y0.len();
        let extra = tableau.dense.as_ref().map_or(0, |d| d.c.len());
        let rows = tableau.dense.as_ref().map_or(0, |d| 3 + d.d.len());
        Self {
            k: vec![vec![0.0; m]; tableau.stages() + 1 + extra],
            y: y0.to_vec(),
            y_new: vec![0.0; m],
            stage: vec![0.0; m],
            probe: vec![0.0; m],
            err: vec![0.0; m],
            err3: vec![0.0; m],
            f: vec![vec![0.0; m]; rows],
        }
    }
}

/// out = y + h Σⱼ wⱼ kⱼ, skipping zero weights.
fn combine(y: &[f64], h: f64, w: &[f64], k: &[Vec<f64>], out: &mut [f64]) {
    copy(y, out);
    accumulate(h, w, k, out);
}

/// out += h Σⱼ wⱼ kⱼ, skipping zero weights: over vectors of a length known at compile time for
/// the small systems (the loops unrolled, as over a hand-written `[f64; 4]`), of any length
/// otherwise; the same operations in the same order either way.
#[inline]
fn accumulate(h: f64, w: &[f64], k: &[Vec<f64>], out: &mut [f64]) {
    accumulate_inline(h, w, k, out);
}

/// [`accumulate`] inline, for weights known at compile time (folded into its code).
#[inline(always)]
fn accumulate_inline(h: f64, w: &[f64], k: &[Vec<f64>], out: &mut [f64]) {
    match out.len() {
        2 => accumulate_n::<2>(h, w, k, out),
        4 => accumulate_n::<4>(h, w, k, out),
        6 => accumulate_n::<6>(h, w, k, out),
        8 => accumulate_n::<8>(h, w, k, out),
        _ => accumulate_n::<0>(h, w, k, out),
    }
}

/// [`accumulate`] over `M` components (`M = 0`: as many as `out` has).
/// Over as many stages as weights (`k` has at least as many): weights known at compile time
/// ([`Coefficients`]) then unroll the loop and fold its branches away.
#[inline(always)]
fn accumulate_n<const M: usize>(h: f64, w: &[f64], k: &[Vec<f64>], out: &mut [f64]) {
    let k = &k[..w.len()];
    if M > 0 {
        let out: &mut [f64; M] = out.try_into().expect("M components");
        let mut acc = *out;
        for (wj, kj) in w.iter().zip(k) {
            if *wj != 0.0 {
                let hw = h * wj;
                let kj: &[f64; M] = kj[..M].try_into().expect("M components");
                for (o, v) in acc.iter_mut().zip(kj) {
                    *o += hw * v;
                }
            }
        }
        *out = acc;
    } else {
        for (wj, kj) in w.iter().zip(k) {
            if *wj != 0.0 {
                let hw = h * wj;
                for (o, v) in out.iter_mut().zip(kj) {
                    *o += hw * v;
                }
            }
        }
    }
}

/// out = y + h Σⱼ wⱼ kⱼ as [`combine`], over `M` components (`M = 0`: any number) read from y
/// straight into the sum rather than copied into `out` and read back: the same operations.
#[inline(always)]
fn combine_n<const M: usize>(y: &[f64], h: f64, w: &[f64], k: &[Vec<f64>], out: &mut [f64]) {
    if M > 0 {
        let y: &[f64; M] = y.try_into().expect("M components");
        let out: &mut [f64; M] = out.try_into().expect("M components");
        let mut acc = *y;
        let k = &k[..w.len()];
        for (wj, kj) in w.iter().zip(k) {
            if *wj != 0.0 {
                let hw = h * wj;
                let kj: &[f64; M] = kj[..M].try_into().expect("M components");
                for (o, v) in acc.iter_mut().zip(kj) {
                    *o += hw * v;
                }
            }
        }
        *out = acc;
    } else {
        copy(y, out);
        accumulate_n::<0>(h, w, k, out);
    }
}

/// Hairer's stiffness bookkeeping (`IASTI`, `NONSTI`).
#[derive(Default, Clone, Copy)]
struct StiffnessCounter {
    positive: usize,
    negative: usize,
}

impl ExplicitRk {
    /// Stages 1..s of a step of size `h` from (t, y) (stage 0 = f(t, y) is in place), then y₁
    /// and, for a FSAL tableau, f(t + h, y₁).
    fn stages<K: Coefficients, S: Dynamics + ?Sized>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
        t: f64,
        h: f64,
    ) -> Result<()> {
        // One instance per small length: its combinations unrolled inline.
        if K::BUILTIN {
            return match c.y.len() {
                2 => Self::stages_const::<K, S, 2>(run, c, t, h),
                4 => Self::stages_const::<K, S, 4>(run, c, t, h),
                6 => Self::stages_const::<K, S, 6>(run, c, t, h),
                8 => Self::stages_const::<K, S, 8>(run, c, t, h),
                _ => Self::stages_const::<K, S, 0>(run, c, t, h),
            };
        }
        match c.y.len() {
            2 => self.stages_n::<S, 2>(run, c, t, h),
            4 => self.stages_n::<S, 4>(run, c, t, h),
            6 => self.stages_n::<S, 6>(run, c, t, h),
            8 => self.stages_n::<S, 8>(run, c, t, h),
            _ => self.stages_n::<S, 0>(run, c, t, h),
        }
    }

    /// [`ExplicitRk::stages_n`] with `K`'s constant coefficients: the stages written out one
    /// after the other, each with its own index known at compile time. A function of its own
    /// per length: inlined into one, the lengths' copies of the stages together had made the
    /// compiler stop inlining the right-hand side into them.
    #[inline(never)]
    fn stages_const<K: Coefficients, S: Dynamics + ?Sized, const M: usize>(
        run: &mut Run<'_, S>,
        c: &mut Cache,
        t: f64,
        h: f64,
    ) -> Result<()> {
        const { assert!(K::S <= 12, "stages written out up to 12") };
        macro_rules! stages {
            ($($i:literal)*) => {
                $(if $i < K::S {
                    Self::stage_const::<K, S, M, $i>(run, c, t, h)?;
                })*
            };
        }
        stages!(1 2 3 4 5 6 7 8 9 10 11);
        let s = K::S;
        if K::FSAL {
            std::mem::swap(&mut c.y_new, &mut c.stage);
            let (lo, hi) = c.k.split_at_mut(s);
            copy(&lo[s - 1], &mut hi[0]);
        } else {
            combine_n::<M>(&c.y, h, K::B, &c.k[..s], &mut c.y_new);
        }
        Ok(())
    }

    /// Stage `I` of [`ExplicitRk::stages_const`].
    #[inline(always)]
    fn stage_const<K: Coefficients, S: Dynamics + ?Sized, const M: usize, const I: usize>(
        run: &mut Run<'_, S>,
        c: &mut Cache,
        t: f64,
        h: f64,
    ) -> Result<()> {
        combine_n::<M>(&c.y, h, K::A[I], &c.k[..I], &mut c.stage);
        if K::PROBE == Some(I) {
            copy(&c.stage, &mut c.probe);
        }
        let ti = if K::C[I] == 1.0 {
            t + h
        } else {
            t + K::C[I] * h
        };
        run.rhs_n::<M>(ti, &c.stage, &mut c.k[I])
    }

    /// [`ExplicitRk::stages`] over `M` components (`M = 0`: any number).
    fn stages_n<S: Dynamics + ?Sized, const M: usize>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
        t: f64,
        h: f64,
    ) -> Result<()> {
        let tab = &self.tableau;
        let s = tab.stages();
        let probe = tab.stiffness.map(|p| p.stage);
        for i in 1..s {
            copy(&c.y, &mut c.stage);
            accumulate_n::<M>(h, &tab.a[i], &c.k[..i], &mut c.stage);
            if probe == Some(i) {
                copy(&c.stage, &mut c.probe);
            }
            let ti = if tab.c[i] == 1.0 {
                t + h
            } else {
                t + tab.c[i] * h
            };
            run.rhs(ti, &c.stage, &mut c.k[i])?;
        }
        if tab.fsal {
            // The last stage's argument is y₁ (the stage buffer is free until the next step).
            std::mem::swap(&mut c.y_new, &mut c.stage);
            let (lo, hi) = c.k.split_at_mut(s);
            copy(&lo[s - 1], &mut hi[0]);
        } else {
            copy(&c.y, &mut c.y_new);
            accumulate_n::<M>(h, &tab.b, &c.k[..s], &mut c.y_new);
        }
        Ok(())
    }

    /// f(t + h, y₁) into stage `s`, unless the tableau already has it. Inline: RK4's fourth
    /// evaluation of a step, compiled into the loop as the other three.
    #[inline(always)]
    fn f_new<S: Dynamics + ?Sized>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
        t_new: f64,
    ) -> Result<()> {
        if !self.tableau.fsal {
            let s = self.tableau.stages();
            run.rhs(t_new, &c.y_new, &mut c.k[s])?;
        }
        Ok(())
    }

    /// Hairer's scaled error norm of the step (≤ 1: accept).
    /// `ranges`: the components the norm reads (`Options::error_ranges`).
    fn error_norm<K: Coefficients>(
        &self,
        c: &mut Cache,
        h: f64,
        (rtol, atol): (f64, f64),
        ranges: &[std::ops::Range<usize>; 2],
    ) -> f64 {
        let s = self.tableau.stages();
        let m = ranges.iter().map(ExactSizeIterator::len).sum::<usize>() as f64;
        let term = |(e, (a, b)): (&f64, (&f64, &f64))| {
            let sk = atol + rtol * a.abs().max(b.abs());
            (e / sk) * (e / sk)
        };
        // Ranges covering all of y: one plain loop, the same terms summed in the same order.
        let whole =
            ranges[0].start == 0 && ranges[0].end == ranges[1].start && ranges[1].end == c.y.len();
        // One sum in component order (the same rounding as a sum over all of y).
        let scaled = |e: &[f64], y: &[f64], y1: &[f64]| -> f64 {
            if whole {
                return e.iter().zip(y.iter().zip(y1)).map(term).sum::<f64>();
            }
            ranges
                .iter()
                .flat_map(|r| {
                    e[r.clone()]
                        .iter()
                        .zip(y[r.clone()].iter().zip(&y1[r.clone()]))
                })
                .map(term)
                .sum::<f64>()
        };
        match &self.tableau.error {
            Some(ErrorEstimate::Embedded { e, .. }) => {
                c.err.fill(0.0);
                if K::BUILTIN {
                    accumulate_inline(h, K::E, &c.k[..s], &mut c.err);
                } else {
                    accumulate(h, e, &c.k[..s], &mut c.err);
                }
                (scaled(&c.err, &c.y, &c.y_new) / m).sqrt()
            }
            Some(ErrorEstimate::Dop853 { e5, e3 }) => {
                c.err.fill(0.0);
                c.err3.fill(0.0);
                accumulate(1.0, e5, &c.k[..s], &mut c.err);
                accumulate(1.0, e3, &c.k[..s], &mut c.err3);
                let err5 = scaled(&c.err, &c.y, &c.y_new);
                let err3 = scaled(&c.err3, &c.y, &c.y_new);
                let deno = err5 + 0.01 * err3;
                if deno <= 0.0 {
                    0.0
                } else {
                    h.abs() * err5 / (m * deno).sqrt()
                }
            }
            None => 0.0,
        }
    }

    /// Accept the step (t, t + h): build its interpolant when the run needs it — Hairer's
    /// continuous extension when the tableau has one (its extra stages are evaluated here, only
    /// then), quintic Hermite in q otherwise — hand it to the run, and make y₁ the new y. A
    /// `quiet` step that does not end the span is only counted ([`Run::quiet_steps`]): inline,
    /// the rest of the acceptance in [`ExplicitRk::accept_step`].
    #[inline(always)]
    fn advance<S: Dynamics + ?Sized>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
        t: f64,
        t_new: f64,
        last: bool,
        quiet: bool,
    ) -> Result<Flow> {
        run.stats.accepted_steps += 1;
        let s = self.tableau.stages();
        if run.project(t_new, &mut c.y_new)? {
            // The end moved onto the constraints: its derivative anew (the interpolant's end
            // and, first same as last, the next step's first stage).
            run.rhs(t_new, &c.y_new, &mut c.k[s])?;
        }
        if quiet && !last {
            run.out.skip(1);
            std::mem::swap(&mut c.y, &mut c.y_new);
            c.k.swap(0, s);
            return Ok(Flow::Continue);
        }
        self.accept_step(run, c, t, t_new, last)
    }

    /// [`ExplicitRk::advance`] of a step that is not quiet.
    fn accept_step<S: Dynamics + ?Sized>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
        t: f64,
        t_new: f64,
        last: bool,
    ) -> Result<Flow> {
        let h = t_new - t;
        let s = self.tableau.stages();
        let n = run.n;
        let hermite = Interpolant::Hermite {
            t,
            h,
            ends: Ends {
                q0: &c.y[..n],
                v0: &c.y[n..],
                a0: &c.k[0][n..],
                q1: &c.y_new[..n],
                v1: &c.y_new[n..],
                a1: &c.k[s][n..],
            },
        };
        let quiet = match &self.tableau.dense {
            Some(_) => run.accept_if_quiet(t, t_new, &c.y_new, last, &hermite)?,
            None => None,
        };
        let flow = if let Some(flow) = quiet {
            flow
        } else if !run.needs_interpolant(t_new) {
            run.accept(t, t_new, &c.y_new, last, None)?
        } else if let Some(d) = &self.tableau.dense {
            for (i, (ci, row)) in d.c.iter().zip(&d.a).enumerate() {
                combine(&c.y, h, row, &c.k[..s + 1 + i], &mut c.stage);
                run.rhs(t + ci * h, &c.stage, &mut c.k[s + 1 + i])?;
            }
            let (f0, rest) = c.f.split_at_mut(1);
            let (f1, rest) = rest.split_at_mut(1);
            let (f2, fd) = rest.split_at_mut(1);
            for i in 0..c.y.len() {
                let dy = c.y_new[i] - c.y[i];
                f0[0][i] = dy;
                f1[0][i] = h * c.k[0][i] - dy;
                f2[0][i] = 2.0 * dy - h * (c.k[0][i] + c.k[s][i]);
            }
            for (row, fr) in d.d.iter().zip(fd.iter_mut()) {
                fr.fill(0.0);
                accumulate(h, row, &c.k, fr);
            }
            let step = Interpolant::Polynomial {
                t,
                h,
                y0: &c.y,
                f: &c.f,
                order: d.order,
            };
            run.accept(t, t_new, &c.y_new, last, Some(&step))?
        } else {
            run.accept(t, t_new, &c.y_new, last, Some(&hermite))?
        };
        std::mem::swap(&mut c.y, &mut c.y_new);
        c.k.swap(0, s);
        Ok(flow)
    }

    /// Step `i` of `steps` equal steps; `quiet` as in [`ExplicitRk::advance`].
    fn fixed_step<K: Coefficients, S: Dynamics + ?Sized>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
        i: usize,
        steps: usize,
        quiet: bool,
    ) -> Result<Flow> {
        let t = run.grid_time(i, steps);
        let t_new = run.grid_time(i + 1, steps);
        self.stages::<K, S>(run, c, t, t_new - t)?;
        if !c.y_new.iter().all(|v| v.is_finite()) {
            return Err(Error::NonFinite {
                what: "state",
                t: t_new,
            });
        }
        self.f_new(run, c, t_new)?;
        self.advance(run, c, t, t_new, i + 1 == steps, quiet)
    }

    /// Hairer's initial step (`HINIT`): h such that h^order · max(‖f₀‖, ‖f′‖) = 0.01 in the
    /// tolerance-scaled norm, from one explicit Euler step.
    fn initial_step<S: Dynamics + ?Sized>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
        h_max: f64,
    ) -> Result<f64> {
        let (rtol, atol) = (run.options.rtol, run.options.atol);
        let ranges = run.options.error_ranges(c.y.len());
        let m = ranges.iter().map(ExactSizeIterator::len).sum::<usize>() as f64;
        let norm = |v: &[f64], y: &[f64]| -> f64 {
            (ranges
                .iter()
                .flat_map(|r| v[r.clone()].iter().zip(&y[r.clone()]))
                .map(|(v, y)| {
                    let sk = atol + rtol * y.abs();
                    (v / sk) * (v / sk)
                })
                .sum::<f64>()
                / m)
                .sqrt()
        };
        let dnf = norm(&c.k[0], &c.y);
        let dny = norm(&c.y, &c.y);
        let mut h = if dnf <= 1e-5 || dny <= 1e-5 {
            1e-6
        } else {
            0.01 * dny / dnf
        };
        h = h.min(h_max);
        let dir = run.dir();
        for (s, (y, f)) in c.stage.iter_mut().zip(c.y.iter().zip(&c.k[0])) {
            *s = y + dir * h * f;
        }
        let t1 = run.t0 + dir * h;
        let s = self.tableau.stages();
        // Stage `s` is free until the first step is accepted.
        run.rhs(t1, &c.stage, &mut c.k[s])?;
        for (e, (f1, f0)) in c.err.iter_mut().zip(c.k[s].iter().zip(&c.k[0])) {
            *e = f1 - f0;
        }
        let der2 = norm(&c.err, &c.y) / h;
        let der12 = der2.abs().max(dnf);
        let h1 = if der12 <= 1e-15 {
            (h * 1e-3).max(1e-6)
        } else {
            (0.01 / der12).powf(1.0 / self.tableau.order as f64)
        };
        Ok((100.0 * h).min(h1).min(h_max))
    }

    /// The step-size control of a run starting at `run.t0`: the largest and the first step.
    fn control<S: Dynamics + ?Sized>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
    ) -> Result<Control> {
        let opts = run.options;
        let span = (run.t_end - run.t0).abs();
        let h_max = opts.max_step.unwrap_or(span).min(span);
        let h = match opts.initial_step {
            Some(h0) => h0.min(h_max),
            None => self.initial_step(run, c, h_max)?,
        } * run.dir();
        Ok(Control {
            t: run.t0,
            h,
            h_max,
            err_old: 1e-4,
            reject: false,
            stiff: StiffnessCounter::default(),
            non_finite: None,
        })
    }

    /// One accepted step of error-controlled size from `state.t`, rejected trials retried;
    /// `quiet` as in [`ExplicitRk::advance`].
    fn adaptive_step<K: Coefficients, S: Dynamics + ?Sized>(
        &self,
        run: &mut Run<'_, S>,
        c: &mut Cache,
        state: &mut Control,
        quiet: bool,
    ) -> Result<Flow> {
        let tab = &self.tableau;
        let ctl = tab.control;
        let opts = run.options;
        let tolerances = (opts.rtol, opts.atol);
        let ranges = opts.error_ranges(c.y.len());
        let dir = run.dir();
        let h_max = state.h_max;
        let mut h = state.h;
        let t = state.t;
        let mut err_old = state.err_old;
        let mut reject = state.reject;
        let mut stiff = state.stiff;
        let mut non_finite = state.non_finite.take();
        loop {
            let attempts = run.stats.accepted_steps + run.stats.rejected_steps;
            if attempts >= opts.max_steps {
                return Err(Error::TooManySteps {
                    t,
                    steps: attempts,
                    needed: None,
                });
            }
            let floor = opts.min_step.max(10.0 * f64::EPSILON * t.abs());
            if h.abs() <= floor || h == 0.0 {
                return Err(non_finite.unwrap_or(Error::StepSizeTooSmall { t, h: h.abs() }));
            }
            let mut last = false;
            if (t + 1.01 * h - run.t_end) * dir > 0.0 {
                h = run.t_end - t;
                last = true;
            }
            // A step that lands on t_end by rounding is the last one too.
            if !last && (t + h - run.t_end) * dir >= 0.0 {
                h = run.t_end - t;
                last = true;
            }
            let t_new = if last { run.t_end } else { t + h };
            let trial = self.stages::<K, S>(run, c, t, h);
            let (err, failure) = match trial {
                Ok(()) if c.y_new.iter().all(|v| v.is_finite()) => (
                    self.error_norm::<K>(c, h, tolerances, &ranges),
                    "error estimate",
                ),
                Ok(()) => (f64::NAN, "state"),
                // A trial stage far off (an unstable step of a stiff problem) can also make M
                // singular: that trial failed, not the run.
                Err(e @ (Error::NonFinite { .. } | Error::SingularMassMatrix { .. })) => {
                    non_finite = Some(e);
                    (f64::NAN, "")
                }
                Err(e) => return Err(e),
            };
            if !err.is_finite() {
                // A trial left the model's domain: retry with a much smaller step.
                if !failure.is_empty() {
                    non_finite = Some(Error::NonFinite {
                        what: failure,
                        t: t_new,
                    });
                }
                run.stats.rejected_steps += 1;
                h *= ctl.shrink;
                reject = true;
                continue;
            }
            let fac11 = err.powf(ctl.alpha);
            let fac = (fac11 / err_old.powf(ctl.beta) / ctl.safety)
                .clamp(1.0 / ctl.grow, 1.0 / ctl.shrink);
            let mut h_new = h / fac;
            if err <= 1.0 {
                match self.f_new(run, c, t_new) {
                    Ok(()) => {}
                    Err(e @ Error::NonFinite { .. }) => {
                        // The accepted point is on the edge of the model's domain: back off.
                        non_finite = Some(e);
                        run.stats.rejected_steps += 1;
                        h *= ctl.shrink;
                        reject = true;
                        continue;
                    }
                    Err(e) => return Err(e),
                }
                err_old = err.max(1e-4);
                if let (Some(test), Some(every)) = (tab.stiffness, opts.stiffness_check) {
                    let accepted = run.stats.accepted_steps + 1;
                    if accepted.is_multiple_of(every) || stiff.positive > 0 {
                        let s = tab.stages();
                        let (mut num, mut den) = (0.0, 0.0);
                        for i in 0..c.y.len() {
                            num += (c.k[s][i] - c.k[test.stage][i]).powi(2);
                            den += (c.y_new[i] - c.probe[i]).powi(2);
                        }
                        let h_lambda = if den > 0.0 {
                            h.abs() * (num / den).sqrt()
                        } else {
                            0.0
                        };
                        if h_lambda > test.bound {
                            stiff.negative = 0;
                            stiff.positive += 1;
                            if stiff.positive == 15 {
                                return Err(Error::Stiffness {
                                    t,
                                    method: tab.name,
                                    suggestion: "radau5",
                                    steps: accepted,
                                });
                            }
                        } else {
                            stiff.negative += 1;
                            if stiff.negative == 6 {
                                stiff.positive = 0;
                            }
                        }
                    }
                }
                let flow = self.advance(run, c, t, t_new, last, quiet)?;
                if h_new.abs() > h_max {
                    h_new = dir * h_max;
                }
                if reject {
                    h_new = dir * h_new.abs().min(h.abs());
                }
                *state = Control {
                    t: t_new,
                    h: h_new,
                    h_max,
                    err_old,
                    reject: false,
                    stiff,
                    non_finite: None,
                };
                return Ok(flow);
            } else {
                h_new = h / (1.0 / ctl.shrink).min(fac11 / ctl.safety);
                reject = true;
                run.stats.rejected_steps += 1;
            }
            h = h_new;
        }
    }
}

impl Integrator for ExplicitRk {
    fn order(&self) -> usize {
        self.tableau.order
    }

    fn adaptive(&self) -> bool {
        self.tableau.error.is_some()
    }

    fn explicit(&self) -> bool {
        true
    }

    fn start<S: Dynamics + ?Sized>(
        self,
        run: &mut Run<'_, S>,
    ) -> Result<Box<dyn SegmentStepper<S>>> {
        let mut c = Cache::new(self.tableau, &run.y0);
        let (t0, y0) = (run.t0, run.y0.clone());
        run.rhs(t0, &y0, &mut c.k[0])?;
        let mode = match run.options.dt {
            Some(dt) => Mode::Fixed {
                i: 0,
                steps: run.fixed_steps(dt)?,
            },
            None => Mode::Adaptive(self.control(run, &mut c)?),
        };
        // The coefficients as constants for the built-in tableaux, chosen once per run.
        if consts_match::<Rk4Consts>(self.tableau) {
            Ok(Box::new(RkStepper::<Rk4Consts>::new(self, c, mode)))
        } else if consts_match::<Dopri5Consts>(self.tableau) {
            Ok(Box::new(RkStepper::<Dopri5Consts>::new(self, c, mode)))
        } else {
            Ok(Box::new(RkStepper::<RunTime>::new(self, c, mode)))
        }
    }
}

/// Where an explicit Runge–Kutta run stands between steps; `K`: where its coefficients are read.
struct RkStepper<K> {
    rk: ExplicitRk,
    c: Cache,
    mode: Mode,
    coefficients: PhantomData<K>,
}

impl<K> RkStepper<K> {
    fn new(rk: ExplicitRk, c: Cache, mode: Mode) -> Self {
        Self {
            rk,
            c,
            mode,
            coefficients: PhantomData,
        }
    }
}

enum Mode {
    /// Step `i` of `steps` equal steps is next.
    Fixed {
        i: usize,
        steps: usize,
    },
    Adaptive(Control),
}

/// The state of the step-size control between accepted steps (Hairer's `DOP853` loop).
struct Control {
    /// Time of the current state.
    t: f64,
    /// Next trial step, signed.
    h: f64,
    h_max: f64,
    err_old: f64,
    /// Whether the last trial was rejected.
    reject: bool,
    stiff: StiffnessCounter,
    /// The last trial that produced a non-finite value, reported if the step cannot shrink past
    /// it.
    non_finite: Option<Error>,
}

impl<K: Coefficients, S: Dynamics + ?Sized> SegmentStepper<S> for RkStepper<K> {
    /// The steps that nothing watches go in a row inside one call, only counted: without the
    /// solver's round trip, the recorder and the interpolant per step, as a hand-written loop.
    fn step(&mut self, run: &mut Run<'_, S>) -> Result<Flow> {
        let mut quiet = run.quiet_steps();
        let mut stepped = false;
        loop {
            let flow = match &mut self.mode {
                Mode::Fixed { i, steps } => {
                    let flow = self
                        .rk
                        .fixed_step::<K, S>(run, &mut self.c, *i, *steps, quiet > 0);
                    if flow.is_ok() {
                        *i += 1;
                    }
                    flow
                }
                Mode::Adaptive(control) => {
                    self.rk
                        .adaptive_step::<K, S>(run, &mut self.c, control, quiet > 0)
                }
            };
            match flow {
                // A quiet step (a step that ends the span is not).
                Ok(Flow::Continue) if quiet > 0 => {
                    quiet -= 1;
                    stepped = true;
                }
                Err(e) if stepped => {
                    // The failure names the last accepted state, from which this step started.
                    run.out.reached(self.t(run), &self.c.y);
                    return Err(e);
                }
                flow => return flow,
            }
        }
    }
}

impl<K> RkStepper<K> {
    /// The time of the current state.
    fn t<S: Dynamics + ?Sized>(&self, run: &Run<'_, S>) -> f64 {
        match &self.mode {
            Mode::Fixed { i, steps } => run.grid_time(*i, *steps),
            Mode::Adaptive(control) => control.t,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The built-in tableaux run on their constants (a constructor and its constants that
    /// drifted apart would quietly fall back to the run-time path).
    #[test]
    fn builtin_tableaux_match_their_constants() {
        assert!(consts_match::<Rk4Consts>(&RK4));
        assert!(consts_match::<Dopri5Consts>(&DOPRI5));
        assert!(!consts_match::<Rk4Consts>(&DOPRI5));
        assert!(!consts_match::<Dopri5Consts>(&DOP853));
        assert!(!consts_match::<RunTime>(&RK4));
    }
}
