//! Taylor steps of several runs at once, one run per lane ([`Lanes`]): the recurrences, the M₀
//! solves and the step's end evaluated over vectors of `LANES` runs, each lane with its own
//! state, parameters, step size and end (an ensemble's runs, as heyoka's batch mode takes
//! them). Every operation is the interpreter's ([`SeriesOp::apply`], the same code over
//! [`Coefficient`]) lane by lane, so a run gets the steps and the bits it gets alone; the
//! loops over the lanes are what the compiler vectorizes, with the widest vectors the machine
//! has (AVX-512 or AVX2, detected at run time).

use super::abi::StepRule;
use super::expansion::TaylorProgram;
use super::series::{Coefficient, Lanes, conv_rows};
use crate::linalg;
use std::sync::Arc;

/// Runs side by side: two AVX-512 registers of `f64`s (four AVX2 registers). Measured on the
/// double-pendulum ensemble of `benches/batch.py` (AMD EPYC, AVX-512): 16 lanes took 0.77× the
/// time of 8 (the fixed cost of each recurrence shared by more runs), 32 no less than 16.
pub(crate) const LANES: usize = 16;

/// The largest table of coefficients the lanes take (bytes; the double pendulum's at order 12
/// is 90 kB): beyond, a run alone with its compiled expansion keeps closer to the caches.
const TABLE_BUDGET: usize = 256 * 1024;

/// A coefficient of every lane.
type V = Lanes<LANES>;

/// How a lane's step ended ([`BatchExpansion::step`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LaneStep {
    /// A step, taken: the state moved to its end.
    Step,
    /// The last step of the run, taken (the state is at its end).
    Last,
    /// The step failed (M₀ did not factor, a coefficient or the new state is not finite, the
    /// step size is not above its floor): the state is as before; the run alone says why.
    Failed,
}

/// The runs in the lanes: time, state y = (q, q̇) and Kahan's compensation (as
/// [`super::Expansion::step`] keeps them), and each run's end, largest step and direction.
#[derive(Debug, Clone)]
pub(crate) struct LaneStates {
    pub t: V,
    pub y: Vec<V>,
    pub lost: Vec<V>,
    pub t_end: V,
    pub h_max: V,
    pub dir: V,
    /// The step's new state and compensation, moved in lane by lane where it succeeds.
    y_new: Vec<V>,
    lost_new: Vec<V>,
}

impl LaneStates {
    /// Lanes of `dof` coordinates, empty (every run at rest at t = 0, ending at t = 1).
    pub(crate) fn new(dof: usize) -> Self {
        let zeros = vec![V::default(); 2 * dof];
        Self {
            t: V::default(),
            y: zeros.clone(),
            lost: zeros.clone(),
            t_end: V::splat(1.0),
            h_max: V::splat(1.0),
            dir: V::splat(1.0),
            y_new: zeros.clone(),
            lost_new: zeros,
        }
    }

    /// Put a run in `lane`: its time, state y = (q, q̇), end, largest step and direction.
    pub(crate) fn load(&mut self, lane: usize, t: f64, y: &[f64], rule: &StepRule) {
        self.t.0[lane] = t;
        for (i, &x) in y.iter().enumerate() {
            self.y[i].0[lane] = x;
            self.lost[i].0[lane] = 0.0;
        }
        self.t_end.0[lane] = rule.t_end;
        self.h_max.0[lane] = rule.h_max;
        self.dir.0[lane] = rule.dir;
    }

    /// The state y = (q, q̇) of `lane`.
    pub(crate) fn state(&self, lane: usize) -> Vec<f64> {
        self.y.iter().map(|x| x.0[lane]).collect()
    }
}

/// The expansion of the runs in the lanes to one order, and its work space: the interpreted
/// expansion's table ([`super::Expansion`]) with a vector of lanes per entry.
#[derive(Debug)]
pub(crate) struct BatchExpansion {
    program: Arc<TaylorProgram>,
    order: usize,
    /// Row r's coefficient k at `r * (order + 1) + k`.
    series: Vec<V>,
    /// Coefficients of q and q̇: order k of coordinate i at `k * dof + i`.
    q: Vec<V>,
    v: Vec<V>,
    /// Coefficients of q̈: order k of coordinate i at `i * (order + 1) + k`.
    qdd: Vec<V>,
    /// M₀ factored, lane by lane.
    m0: Vec<V>,
    rhs: Vec<V>,
    /// Which entries of M₀'s factor are used (every one without a pattern).
    nonzero: Vec<bool>,
    /// Lanes whose M₀ is factored for good (a mass matrix fixed by the parameters).
    m0_kept: [bool; LANES],
    /// One lane's M₀, to factor.
    scratch: Vec<f64>,
}

impl BatchExpansion {
    /// Whether the lanes take `program`'s expansions to `order`: its table of coefficients
    /// within [`TABLE_BUDGET`].
    pub(crate) fn fits(program: &TaylorProgram, order: usize) -> bool {
        let bytes = program.recurrences.rows * (order + 1) * std::mem::size_of::<V>();
        bytes <= TABLE_BUDGET
    }

    /// Expansions of `program` to `order` in every lane (bind each lane's parameters with
    /// [`BatchExpansion::bind`] before its first step).
    pub(crate) fn new(program: Arc<TaylorProgram>, order: usize) -> Self {
        let p = &program.recurrences;
        let (n, w) = (p.dof, order + 1);
        let nonzero = p
            .factor_nonzero
            .clone()
            .unwrap_or_else(|| vec![true; n * n]);
        Self {
            series: vec![V::default(); p.rows * w],
            q: vec![V::default(); n * (w + 1)],
            v: vec![V::default(); n * (w + 1)],
            qdd: vec![V::default(); n * w],
            m0: vec![V::default(); n * n],
            rhs: vec![V::default(); n],
            nonzero,
            m0_kept: [false; LANES],
            scratch: vec![0.0; n * n],
            program,
            order,
        }
    }

    /// Bind `lane` to the parameter values `params`: order 0 of the rows of the numbers, the
    /// parameters and those they fix (as `TaylorProgram::expansion` binds one expansion).
    pub(crate) fn bind(&mut self, lane: usize, params: &[f64]) {
        let p = &self.program.recurrences;
        let w = self.order + 1;
        let s = &mut self.series;
        for &(r, x) in &p.numbers {
            s[r * w].0[lane] = x;
        }
        for &(r, i) in &p.params {
            s[r * w].0[lane] = params[i];
        }
        if let Some(r) = p.time {
            s[r * w + 1].0[lane] = 1.0;
        }
        // The fixed rows of every lane, from each lane's own numbers and parameters: the other
        // lanes' come out as they were.
        for op in &p.fixed {
            op.apply(s, w, 0);
        }
        self.m0_kept[lane] = false;
    }

    /// One Taylor step of every lane from its state in `runs` ([`super::Expansion::step`] lane
    /// by lane, bit for bit), `rule` giving the tolerances, the floor of the step and the
    /// components controlled (each lane's end, largest step and direction are in `runs`).
    /// A lane that steps moves its state to the step's end; a lane that fails keeps its own.
    pub(crate) fn step(&mut self, runs: &mut LaneStates, rule: &StepRule) -> [LaneStep; LANES] {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F, checked above.
                return unsafe { self.step_avx512(runs, rule) };
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2, checked above.
                return unsafe { self.step_avx2(runs, rule) };
            }
        }
        self.step_lanes(runs, rule)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn step_avx512(&mut self, runs: &mut LaneStates, rule: &StepRule) -> [LaneStep; LANES] {
        self.step_lanes(runs, rule)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn step_avx2(&mut self, runs: &mut LaneStates, rule: &StepRule) -> [LaneStep; LANES] {
        self.step_lanes(runs, rule)
    }

    /// [`BatchExpansion::step`], inlined into each instruction set's copy.
    #[inline(always)]
    fn step_lanes(&mut self, runs: &mut LaneStates, rule: &StepRule) -> [LaneStep; LANES] {
        let mut ok = self.expand(runs);
        let (n, p) = (self.program.recurrences.dof, self.order);
        // Every coefficient of q̈ finite (`Expansion::check`).
        for x in &self.qdd {
            for (ok, x) in ok.iter_mut().zip(x.0) {
                *ok &= x.is_finite();
            }
        }
        let (below, top) = self.norms(&runs.y, rule);
        let mut out = [LaneStep::Failed; LANES];
        let (mut h, mut t_new) = (V::default(), V::default());
        let (p1, pf) = ((p - 1) as f64, p as f64);
        for l in 0..LANES {
            let ln_rho = (-below.0[l].ln() / p1).min(-top.0[l].ln() / pf);
            let hl = (ln_rho - 2.0 - 0.7 / p1).exp().min(runs.h_max.0[l]);
            let t = runs.t.0[l];
            let floor = rule.min_step.max(10.0 * f64::EPSILON * t.abs());
            if hl.partial_cmp(&floor) != Some(std::cmp::Ordering::Greater) {
                ok[l] = false;
            }
            let dir = runs.dir.0[l];
            let last = (t + dir * 1.01 * hl - runs.t_end.0[l]) * dir >= 0.0;
            t_new.0[l] = if last { runs.t_end.0[l] } else { t + dir * hl };
            h.0[l] = t_new.0[l] - t;
            out[l] = if last { LaneStep::Last } else { LaneStep::Step };
        }
        // The new state by Horner's rule, added with Kahan's compensation (`Expansion::advance`).
        let coefficient = |k: usize, j: usize| {
            if j < n {
                self.q[k * n + j]
            } else {
                self.v[k * n + j - n]
            }
        };
        let mut finite = [true; LANES];
        for j in 0..2 * n {
            let mut sum = coefficient(p, j);
            for k in (1..p).rev() {
                sum = sum * h + coefficient(k, j);
            }
            let (y, lost) = (runs.y[j], runs.lost[j]);
            let increment = sum * h - lost;
            let y_new = y + increment;
            runs.y_new[j] = y_new;
            let lost_new = (y_new - y) - increment;
            for l in 0..LANES {
                finite[l] &= y_new.0[l].is_finite();
            }
            runs.lost_new[j] = lost_new;
        }
        for l in 0..LANES {
            if !(ok[l] && finite[l]) {
                out[l] = LaneStep::Failed;
                continue;
            }
            runs.t.0[l] = t_new.0[l];
            for j in 0..2 * n {
                runs.y[j].0[l] = runs.y_new[j].0[l];
                runs.lost[j].0[l] = runs.lost_new[j].0[l];
            }
        }
        out
    }

    /// y(t₀ + h) of `lane`'s last step by Horner's rule into `out` = (q, q̇) (as
    /// `Expansion::eval`: the step's dense output).
    pub(crate) fn eval(&self, lane: usize, h: f64, out: &mut [f64]) {
        let n = self.program.recurrences.dof;
        for i in 0..n {
            let (mut q, mut v) = (0.0, 0.0);
            for k in (0..=self.order).rev() {
                q = q * h + self.q[k * n + i].0[lane];
                v = v * h + self.v[k * n + i].0[lane];
            }
            out[i] = q;
            out[n + i] = v;
        }
    }

    /// Expand every lane about its state (`Expansion::expand_interpreted`): order 0, M₀
    /// factored, then the orders. Which lanes' M₀ factored.
    #[inline(always)]
    fn expand(&mut self, runs: &LaneStates) -> [bool; LANES] {
        let program = self.program.clone();
        let p = &program.recurrences;
        let (n, w) = (p.dof, self.order + 1);
        self.q[..n].copy_from_slice(&runs.y[..n]);
        self.v[..n].copy_from_slice(&runs.y[n..2 * n]);
        if let Some(r) = p.time {
            self.series[r * w] = runs.t;
        }
        self.leaves(0);
        for op in &p.order0 {
            op.apply(&mut self.series, w, 0);
        }
        let ok = self.factor_m0();
        self.orders();
        ok
    }

    /// Coefficient k of q's and q̇'s rows.
    #[inline(always)]
    fn leaves(&mut self, k: usize) {
        let p = &self.program.recurrences;
        let (n, w) = (p.dof, self.order + 1);
        for (i, r) in p.coords.iter().enumerate() {
            if let Some(r) = *r {
                self.series[r * w + k] = self.q[k * n + i];
            }
        }
        for (i, r) in p.velocities.iter().enumerate() {
            if let Some(r) = *r {
                self.series[r * w + k] = self.v[k * n + i];
            }
        }
    }

    /// M₀ of each lane factored (`expansion::factor_m0`, lane by lane; kept for good where M
    /// is fixed by the parameters): which lanes' factored.
    fn factor_m0(&mut self) -> [bool; LANES] {
        let p = &self.program.recurrences;
        let (n, w) = (p.dof, self.order + 1);
        let mut ok = [true; LANES];
        for (l, ok) in ok.iter_mut().enumerate() {
            if self.m0_kept[l] {
                continue;
            }
            for (m, &row) in self.scratch.iter_mut().zip(&p.mass_full) {
                *m = self.series[row * w].0[l];
            }
            *ok = linalg::ldlt_in_place(&mut self.scratch, n).is_ok();
            for (m, &x) in self.m0.iter_mut().zip(&self.scratch) {
                m.0[l] = x;
            }
            self.m0_kept[l] = *ok && p.mass_constant;
        }
        ok
    }

    /// Orders 0, …, p − 1 of q̈ (and 1, …, p of q and q̇), as `Expansion::orders` computes them.
    #[inline(always)]
    fn orders(&mut self) {
        let program = self.program.clone();
        let p = &program.recurrences;
        let (n, w) = (p.dof, self.order + 1);
        for k in 0..self.order {
            if k > 0 {
                self.leaves(k);
                for op in &p.varying {
                    op.apply(&mut self.series, w, k);
                }
            }
            // M₀ q̈ₖ = fₖ − Σ_c Σⱼ₌₁..ₖ M_rc,ⱼ q̈_c,ₖ₋ⱼ.
            for r in 0..n {
                let f = self.series[p.force[r] * w + k];
                let varying = &p.mass_varying[r * n..(r + 1) * n];
                self.rhs[r] = if k > 0 && varying.contains(&true) {
                    let mut s = V::splat(0.0);
                    for c in (0..n).filter(|&c| varying[c]) {
                        let m = &self.series[p.mass_full[r * n + c] * w..][..w];
                        s += conv_rows(m, &self.qdd[c * w..][..w], 1, k, k, k, false);
                    }
                    f - s
                } else {
                    f
                };
            }
            linalg::ldlt_solve_pattern(&self.m0, n, &self.nonzero, &mut self.rhs);
            let next = V::splat(1.0 / (k + 1) as f64);
            for i in 0..n {
                self.qdd[i * w + k] = self.rhs[i];
                self.q[(k + 1) * n + i] = self.v[k * n + i] * next;
                self.v[(k + 1) * n + i] = self.rhs[i] * next;
            }
        }
    }

    /// `Expansion::norms` lane by lane.
    #[inline(always)]
    fn norms(&self, y: &[V], rule: &StepRule) -> (V, V) {
        let (n, p) = (self.program.recurrences.dof, self.order);
        let (rtol, atol) = (V::splat(rule.rtol), V::splat(rule.atol));
        let eps = V::splat(rule.rtol.min(rule.atol));
        let (mut below, mut top) = (V::splat(0.0), V::splat(0.0));
        for (offset, c) in [(0, &self.q), (n, &self.v)] {
            for i in (0..n).take_while(|&i| (i as f64) < rule.controlled) {
                let scale = eps / (atol + rtol * y[offset + i].map(f64::abs));
                let x = c[(p - 1) * n + i].map(f64::abs) * scale;
                let z = c[p * n + i].map(f64::abs) * scale;
                below = below.zip_map(x, f64::max);
                top = top.zip_map(z, f64::max);
            }
        }
        (below, top)
    }
}
