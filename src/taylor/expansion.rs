//! A lowered program ready to expand ([`TaylorProgram`]), and its expansions ([`Expansion`]):
//! the one place that chooses between the compiled kernels (feature `jit`) and the
//! interpreted recurrences, which give the same coefficients bit for bit.

use super::abi::StepRule;
#[cfg(feature = "jit")]
use super::abi::{Buffers, KernelStatus, StepArgs, StepControl};
#[cfg(feature = "jit")]
use super::kernel;
use super::lower::Recurrences;
#[cfg(feature = "jit")]
use super::series::MAX_TAYLOR_ORDER;
use super::series::{SeriesOp, conv_rows};
use crate::error::{Error, Result};
use crate::expr::graph::Graph;
use crate::linalg;
#[cfg(feature = "jit")]
use std::sync::OnceLock;
#[cfg(feature = "jit")]
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// Programs whose unrolled expansion to an order comes to at most this many estimated
/// instructions compile it at their first expansion to that order when they are run again and
/// again ([`TaylorProgram::unroll_small_early`]).
#[cfg(feature = "jit")]
pub(crate) const UNROLL_EARLY_UP_TO: usize = 16_000;

/// The part of a graph that M and f need, lowered to recurrences, ready to expand.
#[derive(Debug)]
pub struct TaylorProgram {
    /// The recurrences, lowered once.
    pub(crate) recurrences: Recurrences,
    /// The recurrences as machine code, compiled at the first expansion (`None`: not allowed,
    /// or Cranelift could not compile them, and the interpreter runs).
    #[cfg(feature = "jit")]
    native: OnceLock<Option<kernel::SeriesKernel>>,
    /// The whole expansion to order p unrolled into machine code, at index p, compiled after
    /// `UNROLL_AFTER` expansions to that order (`None`: too large to unroll, not allowed, or
    /// Cranelift failed), and the expansions to each order so far.
    #[cfg(feature = "jit")]
    unrolled: Box<[OnceLock<Option<kernel::ExpansionKernel>>]>,
    #[cfg(feature = "jit")]
    expansions: Box<[AtomicUsize]>,
    #[cfg(feature = "jit")]
    allow_native: bool,
    /// The highest order whose unrolled expansion is compiled at the first expansion to it
    /// rather than after `UNROLL_AFTER` ([`TaylorProgram::unroll_small_early`]; 0: none).
    #[cfg(feature = "jit")]
    early_up_to: usize,
    /// Work spaces of dropped expansions, for the next ones ([`Workspace`]).
    pub(crate) spares: Mutex<Vec<Workspace>>,
}

impl TaylorProgram {
    /// The nodes of `graph` that M (`mass_nodes`, its upper triangle by rows) and f
    /// (`force_nodes`) of a system of `dof` coordinates read, lowered to recurrences.
    pub fn new(graph: &Graph, dof: usize, mass_nodes: &[usize], force_nodes: &[usize]) -> Self {
        Self::of(Recurrences::new(graph, dof, mass_nodes, force_nodes), true)
    }

    /// A program of `recurrences`, compiled when `allow_native` (and the `jit` feature) allow.
    #[cfg_attr(not(feature = "jit"), allow(unused_variables))]
    fn of(recurrences: Recurrences, allow_native: bool) -> Self {
        #[cfg(feature = "jit")]
        let orders = if allow_native {
            MAX_TAYLOR_ORDER + 1
        } else {
            0
        };
        Self {
            recurrences,
            #[cfg(feature = "jit")]
            native: OnceLock::new(),
            #[cfg(feature = "jit")]
            unrolled: (0..orders).map(|_| OnceLock::new()).collect(),
            #[cfg(feature = "jit")]
            expansions: (0..orders).map(|_| AtomicUsize::new(0)).collect(),
            #[cfg(feature = "jit")]
            allow_native,
            #[cfg(feature = "jit")]
            early_up_to: 0,
            spares: Mutex::new(Vec::new()),
        }
    }

    /// Number of coordinates.
    pub fn dof(&self) -> usize {
        self.recurrences.dof
    }

    /// The same program, never compiled: the interpreter's reference (`backend="interpreter"`).
    pub(crate) fn interpreted(&self) -> Self {
        Self::of(self.recurrences.clone(), false)
    }

    /// Compile the unrolled expansion to an order at the first expansion to it, rather than
    /// after `UNROLL_AFTER` expansions, where it is small (at most `UNROLL_EARLY_UP_TO`
    /// estimated instructions, a compile of a few milliseconds): then a model's first runs,
    /// each a few hundred steps, are not left order by order. For a program run again and
    /// again, as a Python model is (`lg.Model`, its scenes); the default, for a program run
    /// once, waits for the break-even.
    pub fn unroll_small_early(&mut self) {
        #[cfg(feature = "jit")]
        if self.allow_native {
            self.early_up_to = (1..=MAX_TAYLOR_ORDER)
                .take_while(|&p| self.recurrences.expansion_instructions(p) <= UNROLL_EARLY_UP_TO)
                .last()
                .unwrap_or(0);
        }
    }

    /// The recurrences as machine code, compiled on the first call (`None` without the `jit`
    /// feature, for an interpreted program, or where Cranelift failed).
    #[cfg(feature = "jit")]
    fn kernel(&self) -> Option<&kernel::SeriesKernel> {
        if !self.allow_native {
            return None;
        }
        self.native
            .get_or_init(|| kernel::SeriesKernel::compile(&self.recurrences).ok())
            .as_ref()
    }

    /// The expansion to `order` unrolled into machine code, once this program has expanded to
    /// that order `UNROLL_AFTER` times (compiled then); `None` before, without the `jit`
    /// feature, for an interpreted program, for one too large to unroll, or where Cranelift
    /// failed.
    #[cfg(feature = "jit")]
    fn unrolled(&self, order: usize) -> Option<&kernel::ExpansionKernel> {
        let cell = self.unrolled.get(order)?;
        if let Some(kernel) = cell.get() {
            return kernel.as_ref();
        }
        let count = self.expansions[order].fetch_add(1, Ordering::Relaxed);
        if count < kernel::UNROLL_AFTER && order > self.early_up_to {
            return None;
        }
        self.compile_unrolled(order)
    }

    /// A run about to expand to `order` about `more` times: compile the unrolled expansion now
    /// if the expansions counted so far and these reach `UNROLL_AFTER`, the count after which it
    /// would be compiled anyway (within this run, then): the run's steps before that count then
    /// run the unrolled code too. Whether expansions to `order` are unrolled from now on.
    #[cfg(feature = "jit")]
    fn plan(&self, order: usize, more: usize) -> bool {
        let Some(count) = self.expansions.get(order) else {
            return false;
        };
        if let Some(kernel) = self.unrolled[order].get() {
            return kernel.is_some();
        }
        if count.load(Ordering::Relaxed).saturating_add(more) < kernel::UNROLL_AFTER {
            return false;
        }
        self.compile_unrolled(order).is_some()
    }

    /// The expansion to `order` unrolled, if it is compiled (not counted as an expansion).
    #[cfg(feature = "jit")]
    fn compiled(&self, order: usize) -> Option<&kernel::ExpansionKernel> {
        self.unrolled.get(order)?.get()?.as_ref()
    }

    #[cfg(feature = "jit")]
    fn compile_unrolled(&self, order: usize) -> Option<&kernel::ExpansionKernel> {
        self.unrolled
            .get(order)?
            .get_or_init(|| kernel::ExpansionKernel::compile(&self.recurrences, order).ok())
            .as_ref()
    }

    /// Compile the expansion to `order` unrolled into machine code now, rather than after
    /// `UNROLL_AFTER` expansions (for a test or a benchmark of the steady state): whether
    /// expansions to `order` run it from now on (false without the `jit` feature, for an
    /// interpreted program, for one too large to unroll, or where Cranelift failed).
    pub fn unroll(&self, order: usize) -> bool {
        #[cfg(feature = "jit")]
        return self.compile_unrolled(order).is_some();
        #[cfg(not(feature = "jit"))]
        {
            let _ = order;
            false
        }
    }

    /// Whether expansions to `order` run the unrolled code now (compiled by [`Self::unroll`]
    /// or after `UNROLL_AFTER` expansions to that order).
    pub fn is_unrolled(&self, order: usize) -> bool {
        #[cfg(feature = "jit")]
        return self.compiled(order).is_some();
        #[cfg(not(feature = "jit"))]
        {
            let _ = order;
            false
        }
    }

    /// Recurrences run at each order ≥ 1 (the nodes that vary and their auxiliary rows).
    pub fn recurrences(&self) -> usize {
        self.recurrences.varying.len()
    }

    /// About the machine instructions of one expansion to `order` compiled unrolled (orders
    /// 1 to p − 1 of q̈; order 0 is evaluated as the accelerations are): three per term of a
    /// convolution (two loads and a product, and its sum) and a few per recurrence, per
    /// Σⱼ Mⱼ q̈ₖ₋ⱼ term and per entry of the solve, at each order. It decides which programs
    /// are small enough to unroll, and `Method::Auto`'s estimate of a Taylor step's cost.
    pub fn expansion_instructions(&self, order: usize) -> usize {
        self.recurrences.expansion_instructions(order)
    }

    /// Operations of order 0 (the rows of M and f at the expansion point, evaluated as the
    /// accelerations are), and how many of them call the maths library (eˣ, ln, sin and cos,
    /// tan, atan2): `Method::Auto` weighs a step's cost with them.
    pub fn order0_operations(&self) -> (usize, usize) {
        let calls = self
            .recurrences
            .order0
            .iter()
            .filter(|op| op.calls_libm())
            .count();
        (self.recurrences.order0.len(), calls)
    }

    /// Whether the motion has a Taylor series wherever the model is defined: no |x| or sign(x)
    /// of the state, whose series say nothing of the kink at 0 (a step would run past it).
    pub fn is_analytic(&self) -> bool {
        !self
            .recurrences
            .order0
            .iter()
            .any(|op| matches!(op, SeriesOp::Abs { .. } | SeriesOp::Sign { .. }))
    }

    /// Whether the expansions run machine code (compiling it now if it is not yet).
    pub fn is_native(&self) -> bool {
        #[cfg(feature = "jit")]
        return self.kernel().is_some();
        #[cfg(not(feature = "jit"))]
        false
    }

    /// Work space for expansions up to `order` with these parameter values: a spare one when
    /// an expansion to `order` was dropped before (rebound if its parameters differ).
    ///
    /// # Panics
    /// If `params` is shorter than the parameters the program reads.
    pub fn expansion(self: &Arc<Self>, params: &[f64], order: usize) -> Expansion {
        let same = |a: &[f64]| {
            a.len() == params.len()
                && a.iter()
                    .zip(params)
                    .all(|(x, y)| x.to_bits() == y.to_bits())
        };
        let spare = {
            let mut spares = self.spares.lock().unwrap_or_else(|p| p.into_inner());
            let at = (spares.iter())
                .position(|w| w.order == order && same(&w.params))
                .or_else(|| spares.iter().position(|w| w.order == order));
            at.map(|i| spares.swap_remove(i))
        };
        let work = match spare {
            Some(work) if same(&work.params) => work,
            Some(mut work) => {
                self.bind(&mut work, params);
                work
            }
            None => {
                let (n, w) = (self.recurrences.dof, order + 1);
                let mut work = Workspace {
                    order,
                    params: Vec::new(),
                    series: vec![0.0; self.recurrences.rows * w],
                    q: vec![0.0; n * (w + 1)],
                    v: vec![0.0; n * (w + 1)],
                    m0: vec![0.0; n * n],
                    m0_fixed: false,
                    qdd: vec![0.0; n * w],
                    rhs: vec![0.0; n],
                    #[cfg(feature = "jit")]
                    reversed: Vec::new(),
                };
                self.bind(&mut work, params);
                work
            }
        };
        Expansion {
            program: self.clone(),
            work,
        }
    }

    /// Order 0 of the rows of the numbers and parameters and of those fixed by them (and t's
    /// coefficient 1), into `work`'s table: no expansion writes them.
    fn bind(&self, work: &mut Workspace, params: &[f64]) {
        let w = work.order + 1;
        let series = &mut work.series;
        for &(r, x) in &self.recurrences.numbers {
            series[r * w] = x;
        }
        for &(r, p) in &self.recurrences.params {
            series[r * w] = params[p];
        }
        if let (Some(r), true) = (self.recurrences.time, work.order >= 1) {
            series[r * w + 1] = 1.0;
        }
        for op in &self.recurrences.fixed {
            op.apply(series, w, 0);
        }
        work.params.clear();
        work.params.extend_from_slice(params);
        work.m0_fixed = false;
    }
}

/// The Taylor coefficients of one expansion and their work space.
#[derive(Debug, Clone)]
pub struct Expansion {
    program: Arc<TaylorProgram>,
    pub(crate) work: Workspace,
}

/// An expansion's buffers: back to its program's spares when the expansion is dropped, for the
/// next one to the same order (a short run's fixed cost was mostly their allocation, zeroing
/// and binding).
#[derive(Debug, Clone, Default)]
pub(crate) struct Workspace {
    order: usize,
    /// The parameter values bound (order 0 of their rows and of the rows fixed by them).
    params: Vec<f64>,
    /// The table of series: row r's coefficient k at `r * (order + 1) + k`.
    series: Vec<f64>,
    /// Coefficients of q and q̇: order k of coordinate i at `k * dof + i`, k = 0..=order.
    pub(crate) q: Vec<f64>,
    pub(crate) v: Vec<f64>,
    /// M₀ factored (LDLᵀ).
    m0: Vec<f64>,
    /// Whether `m0` holds the factor of a mass matrix that depends on the parameters alone,
    /// factored at the first expansion and kept.
    m0_fixed: bool,
    /// Coefficients of q̈: order k of coordinate i at `i * (order + 1) + k`.
    qdd: Vec<f64>,
    rhs: Vec<f64>,
    /// Work space of the unrolled expansion (the series it reads backwards, mirrored), sized
    /// at its first run.
    #[cfg(feature = "jit")]
    reversed: Vec<f64>,
}

#[cfg(feature = "jit")]
impl Workspace {
    /// The buffers the compiled expansion reads and writes, the mirror work space grown to
    /// `reversed_len` entries first (sized at the first compiled run).
    fn buffers(&mut self, reversed_len: usize) -> Buffers<'_> {
        if self.reversed.len() < reversed_len {
            self.reversed.resize(reversed_len, 0.0);
        }
        Buffers {
            table: &mut self.series,
            q: &mut self.q,
            v: &mut self.v,
            qdd: &mut self.qdd,
            m0: &mut self.m0,
            reversed: &mut self.reversed,
        }
    }
}

/// Spare work spaces a program keeps at most (more than the threads of a parallel ensemble on
/// most machines, few enough to bound the memory they hold).
const SPARES: usize = 8;

impl Drop for Expansion {
    fn drop(&mut self) {
        let work = std::mem::take(&mut self.work);
        let mut spares = self
            .program
            .spares
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if spares.len() < SPARES {
            spares.push(work);
        }
    }
}

impl Expansion {
    /// The run expanding will expand about `more` times again: compile its unrolled expansion
    /// now if its program would compile it within those anyway (after `UNROLL_AFTER`
    /// expansions to this order). Whether the expansions are unrolled from now on (false
    /// without the `jit` feature).
    pub fn plan(&self, more: usize) -> bool {
        #[cfg(feature = "jit")]
        return self.program.plan(self.work.order, more);
        #[cfg(not(feature = "jit"))]
        {
            let _ = more;
            false
        }
    }

    /// The highest order computed.
    pub fn order(&self) -> usize {
        self.work.order
    }

    /// Coefficient k of q (k = 0..=order).
    pub fn q(&self, k: usize) -> &[f64] {
        let n = self.program.recurrences.dof;
        &self.work.q[k * n..(k + 1) * n]
    }

    /// Coefficient k of q̇ (k = 0..=order).
    pub fn qd(&self, k: usize) -> &[f64] {
        let n = self.program.recurrences.dof;
        &self.work.v[k * n..(k + 1) * n]
    }

    /// Write coefficient k of q's and q̇'s rows.
    fn leaves(&mut self, k: usize) {
        let (p, w, n) = (
            &self.program.recurrences,
            self.work.order + 1,
            self.program.recurrences.dof,
        );
        for (i, r) in p.coords.iter().enumerate() {
            if let Some(r) = *r {
                self.work.series[r * w + k] = self.work.q[k * n + i];
            }
        }
        for (i, r) in p.velocities.iter().enumerate() {
            if let Some(r) = *r {
                self.work.series[r * w + k] = self.work.v[k * n + i];
            }
        }
    }

    /// Coefficient k ≥ 1 of every row that varies.
    fn recurrences(&mut self, k: usize) {
        let w = self.work.order + 1;
        #[cfg(feature = "jit")]
        if let Some(kernel) = self.program.kernel()
            && !kernel.whole_orders()
        {
            kernel.run(&mut self.work.series, w, k);
            return;
        }
        for op in &self.program.recurrences.varying {
            op.apply(&mut self.work.series, w, k);
        }
    }

    /// Expand the motion through (t₀, q₀, q̇₀) to `order` (given at creation).
    ///
    /// # Errors
    /// [`Error::SingularMassMatrix`] when M(t₀, q₀) cannot be factored, [`Error::NonFinite`]
    /// when a coefficient is not finite (a singularity of the model within reach, or a
    /// function at a point where its series does not exist, such as √x at x = 0).
    pub fn expand(&mut self, t0: f64, q0: &[f64], qd0: &[f64]) -> Result<()> {
        #[cfg(feature = "jit")]
        if let Some(status) = self.run_unrolled(t0, q0, qd0, None) {
            return match status? {
                KernelStatus::Expanded => Ok(()),
                _ => Err(non_finite(t0)),
            };
        }
        self.expand_interpreted(t0, q0, qd0)
    }

    /// [`Expansion::expand`] order by order (the interpreter or [`SeriesKernel`]'s
    /// recurrences).
    fn expand_interpreted(&mut self, t0: f64, q0: &[f64], qd0: &[f64]) -> Result<()> {
        let n = self.program.recurrences.dof;
        let w = self.work.order + 1;
        self.work.q[..n].copy_from_slice(q0);
        self.work.v[..n].copy_from_slice(qd0);
        if let Some(r) = self.program.recurrences.time {
            // t's coefficients beyond 0 are fixed at creation.
            self.work.series[r * w] = t0;
        }
        self.order0();
        let Workspace {
            series,
            m0,
            m0_fixed,
            ..
        } = &mut self.work;
        factor_m0(&self.program, series, w, m0, m0_fixed, t0, q0)?;
        self.orders();
        self.check(t0)
    }

    /// The expansion through (t₀, q₀, q̇₀) unrolled (and the step with `step`): order 0, M₀, then
    /// the rest in one call of the compiled code; `None` when the program has no unrolled
    /// expansion to this order (yet: this counts as an expansion towards it).
    #[cfg(feature = "jit")]
    fn run_unrolled(
        &mut self,
        t0: f64,
        q0: &[f64],
        qd0: &[f64],
        step: Option<StepArgs<'_>>,
    ) -> Option<Result<KernelStatus>> {
        let Self { program, work } = self;
        let kernel = program.unrolled(work.order)?;
        let w = work.order + 1;
        if let Some(r) = program.recurrences.time {
            // t's coefficients beyond 0 are fixed at creation.
            work.series[r * w] = t0;
        }
        kernel.order0(&mut work.series, q0, qd0, &mut work.q, &mut work.v);
        let (series, m0, m0_fixed) = (&work.series, &mut work.m0, &mut work.m0_fixed);
        if let Err(e) = factor_m0(program, series, w, m0, m0_fixed, t0, q0) {
            return Some(Err(e));
        }
        let buffers = work.buffers(kernel.reversed_len());
        Some(Ok(match step {
            None => kernel.run(buffers),
            Some(step) => kernel.step(buffers, step),
        }))
    }

    /// Expand about the state y = (q, q̇) at t and take Jorba and Zou's step from it (the Taylor
    /// method's step, `integrators::taylor`): h = ρ e^(−2 − 0.7/(p−1)) with ln ρ =
    /// min(−ln ‖xₚ₋₁‖ / (p − 1), −ln ‖xₚ‖ / p) from [`Expansion::norms`], at most `rule.h_max`;
    /// a step that would end within 1 % of `rule.t_end` ends on it; the new state by
    /// [`Expansion::advance`]. The time reached, and whether it is t_end. Compiled with the
    /// expansion once it is unrolled, the whole step is one call of machine code.
    ///
    /// # Errors
    /// Those of [`Expansion::expand`]; [`Error::StepSizeTooSmall`] when h is not above
    /// max(`rule.min_step`, 10 ε |t|) (a vanishing radius of convergence: a singularity of the
    /// solution within reach); [`Error::NonFinite`] when a value of the new state is not finite.
    ///
    /// # Panics
    /// If a buffer has fewer than 2 · dof entries.
    pub fn step(
        &mut self,
        t: f64,
        y: &[f64],
        rule: &StepRule,
        lost: &mut [f64],
        y_new: &mut [f64],
    ) -> Result<(f64, bool)> {
        let n = self.program.recurrences.dof;
        let (q0, qd0) = y[..2 * n].split_at(n);
        #[cfg(feature = "jit")]
        {
            let mut control = StepControl {
                t,
                rule: *rule,
                ..StepControl::default()
            };
            let step = StepArgs {
                control: &mut control,
                y: &y[..2 * n],
                lost: &mut *lost,
                y_new: &mut *y_new,
            };
            if let Some(status) = self.run_unrolled(t, q0, qd0, Some(step)) {
                return stepped(status?, &control);
            }
        }
        self.expand_interpreted(t, q0, qd0)?;
        let p = self.work.order;
        let (below, top) = self.norms(y, rule);
        // ln ρ = min(−ln ‖xₚ₋₁‖ / (p − 1), −ln ‖xₚ‖ / p), and h = ρ e^(−2 − 0.7/(p−1)) as one
        // exponential (a zero norm gives ρ = ∞: a polynomial solution, capped by h_max).
        let (p1, p) = ((p - 1) as f64, p as f64);
        let ln_rho = (-below.ln() / p1).min(-top.ln() / p);
        let h = (ln_rho - 2.0 - 0.7 / p1).exp().min(rule.h_max);
        let floor = rule.min_step.max(10.0 * f64::EPSILON * t.abs());
        // A vanishing ρ is a singularity of the solution within reach (NaN is refused with it).
        if h.partial_cmp(&floor) != Some(std::cmp::Ordering::Greater) {
            return Err(Error::StepSizeTooSmall { t, h });
        }
        let dir = rule.dir;
        let last = (t + dir * 1.01 * h - rule.t_end) * dir >= 0.0;
        let t_new = if last { rule.t_end } else { t + dir * h };
        if !self.advance(t_new - t, y, lost, y_new) {
            return Err(Error::NonFinite {
                what: "state",
                t: t_new,
            });
        }
        Ok((t_new, last))
    }

    /// Steps from (t, y) as [`Expansion::step`] takes them, in a row, by one call of the
    /// compiled code: at most `limit`, until one is the last of the run or fails. Each step
    /// of the row that is neither moves (t, y) to its end (`y_new` and `lost` as
    /// [`Expansion::step`] leaves them). `None` when the expansion is not compiled unrolled
    /// (or a mass matrix fixed by the parameters is yet to be factored): take the step with
    /// [`Expansion::step`]. Otherwise how many steps moved (t, y), and what ended the row.
    ///
    /// # Panics
    /// If a buffer has fewer than 2 · dof entries, or `limit` is 0.
    #[cfg(feature = "jit")]
    pub(crate) fn steps(
        &mut self,
        (t, y): (&mut f64, &mut [f64]),
        rule: &StepRule,
        lost: &mut [f64],
        y_new: &mut [f64],
        limit: usize,
    ) -> Option<(usize, RowEnd)> {
        let Self { program, work } = self;
        let kernel = program.compiled(work.order)?;
        if program.recurrences.mass_constant && !work.m0_fixed {
            return None;
        }
        let mut control = StepControl {
            t: *t,
            rule: *rule,
            ..StepControl::default()
        };
        let buffers = work.buffers(kernel.reversed_len());
        let (status, taken) = kernel.steps(buffers, &mut control, [y, lost, y_new], limit);
        *t = control.t;
        let end = match status {
            KernelStatus::Step => RowEnd::Limit,
            KernelStatus::Unfactored => RowEnd::Unfactored,
            status => RowEnd::Next(stepped(status, &control)),
        };
        Some((taken, end))
    }

    /// [`Error::NonFinite`] when a coefficient of q̈ is not finite.
    fn check(&self, t0: f64) -> Result<()> {
        match self.work.qdd.iter().all(|x| x.is_finite()) {
            true => Ok(()),
            false => Err(non_finite(t0)),
        }
    }

    /// Order 0 of every row the state sets: what the unrolled kernel's order 0 computes.
    fn order0(&mut self) {
        #[cfg(feature = "jit")]
        if let Some(kernel) = self.program.kernel()
            && kernel.whole_orders()
        {
            let (n, w) = (self.program.recurrences.dof, self.work.order + 1);
            let Workspace { series, q, v, .. } = &mut self.work;
            kernel.order0(series, w, &q[..n], &v[..n]);
            return;
        }
        self.leaves(0);
        let w = self.work.order + 1;
        for op in &self.program.recurrences.order0 {
            op.apply(&mut self.work.series, w, 0);
        }
    }

    /// Orders 0, …, p − 1 of q̈ (and 1, …, p of q and q̇) given order 0 of every row and M₀
    /// factored, order by order: what the unrolled kernel computes, in the same operations and
    /// order.
    fn orders(&mut self) {
        #[cfg(feature = "jit")]
        if let Some(kernel) = self.program.kernel()
            && kernel.whole_orders()
        {
            let (order, w) = (self.work.order, self.work.order + 1);
            let Workspace {
                series,
                q,
                v,
                qdd,
                m0,
                ..
            } = &mut self.work;
            for k in 0..order {
                kernel.order(k, w, [series, q, v, qdd], m0);
            }
            return;
        }
        let program = self.program.clone();
        let (n, w) = (program.recurrences.dof, self.work.order + 1);
        for k in 0..self.work.order {
            if k > 0 {
                self.leaves(k);
                self.recurrences(k);
            }
            // M₀ q̈ₖ = fₖ − Σ_c Σⱼ₌₁..ₖ M_rc,ⱼ q̈_c,ₖ₋ⱼ: a convolution per entry of M that varies.
            for r in 0..n {
                let f = self.work.series[program.recurrences.force[r] * w + k];
                let varying = &program.recurrences.mass_varying[r * n..(r + 1) * n];
                self.work.rhs[r] = if k > 0 && varying.contains(&true) {
                    let mut s = 0.0;
                    for c in (0..n).filter(|&c| varying[c]) {
                        let m =
                            &self.work.series[program.recurrences.mass_full[r * n + c] * w..][..w];
                        s += conv_rows(m, &self.work.qdd[c * w..][..w], 1, k, k, k, false);
                    }
                    f - s
                } else {
                    f
                };
            }
            match &program.recurrences.factor_nonzero {
                Some(nonzero) => {
                    linalg::ldlt_solve_pattern(&self.work.m0, n, nonzero, &mut self.work.rhs)
                }
                None => linalg::ldlt_solve(&self.work.m0, n, &mut self.work.rhs),
            }
            let next = 1.0 / (k + 1) as f64;
            for i in 0..n {
                self.work.qdd[i * w + k] = self.work.rhs[i];
                self.work.q[(k + 1) * n + i] = self.work.v[k * n + i] * next;
                self.work.v[(k + 1) * n + i] = self.work.rhs[i] * next;
            }
        }
    }

    /// The scaled sup norms of the last two coefficients that Jorba and Zou's step size reads:
    /// (maxᵢ |xₚ₋₁,ᵢ| sᵢ, maxᵢ |xₚ,ᵢ| sᵢ) over the components i of y = (q, q̇) that `rule`
    /// controls (`StepRule::controlled`), with sᵢ = ε / (atol + rtol |yᵢ|) and
    /// ε = min(rtol, atol), the tolerance the order is chosen for (each component measured
    /// against its own tolerance).
    ///
    /// # Panics
    /// If `y` has fewer than 2 · dof entries.
    pub fn norms(&self, y: &[f64], rule: &StepRule) -> (f64, f64) {
        let (n, p) = (self.program.recurrences.dof, self.work.order);
        let (rtol, atol) = (rule.rtol, rule.atol);
        let eps = rtol.min(atol);
        let (mut below, mut top) = (0.0_f64, 0.0_f64);
        let (q, qd) = y[..2 * n].split_at(n);
        for (y, x, z) in [
            (q, self.q(p - 1), self.q(p)),
            (qd, self.qd(p - 1), self.qd(p)),
        ] {
            for i in (0..n).take_while(|&i| (i as f64) < rule.controlled) {
                let scale = eps / (atol + rtol * y[i].abs());
                below = below.max(x[i].abs() * scale);
                top = top.max(z[i].abs() * scale);
            }
        }
        (below, top)
    }

    /// A step of h from the state y = (q, q̇) the expansion is about: `y_new` = y + Σₖ₌₁..ₚ
    /// (q, q̇)ₖ hᵏ, the increment summed by Horner's rule and added to y with Kahan's
    /// compensated summation (`lost` holds what rounding took off the state in the last step,
    /// and is updated: the state's rounding errors do not pile up step after step). False when
    /// a new value is not finite.
    ///
    /// # Panics
    /// If a buffer has fewer than 2 · dof entries.
    pub fn advance(&self, h: f64, y: &[f64], lost: &mut [f64], y_new: &mut [f64]) -> bool {
        let (n, p) = (self.program.recurrences.dof, self.work.order);
        let coefficients = |k: usize, j: usize| {
            if j < n {
                self.work.q[k * n + j]
            } else {
                self.work.v[k * n + j - n]
            }
        };
        let mut finite = true;
        for j in 0..2 * n {
            let mut sum = coefficients(p, j);
            for k in (1..p).rev() {
                sum = sum * h + coefficients(k, j);
            }
            let increment = sum * h - lost[j];
            y_new[j] = y[j] + increment;
            lost[j] = (y_new[j] - y[j]) - increment;
            finite &= y_new[j].is_finite();
        }
        finite
    }

    /// y(t₀ + h) = Σₖ (q, q̇)ₖ hᵏ by Horner's rule, into `out` = (q, q̇).
    pub fn eval(&self, h: f64, out: &mut [f64]) {
        let n = self.program.recurrences.dof;
        for i in 0..n {
            let (mut q, mut v) = (0.0, 0.0);
            for k in (0..=self.work.order).rev() {
                q = q * h + self.work.q[k * n + i];
                v = v * h + self.work.v[k * n + i];
            }
            out[i] = q;
            out[n + i] = v;
        }
    }
}

/// What ended a row of steps ([`Expansion::steps`]).
#[cfg(feature = "jit")]
#[derive(Debug)]
pub(crate) enum RowEnd {
    /// The row's `limit` of steps, taken.
    Limit,
    /// The next step: the last of the run (its time), or its failure.
    Next(Result<(f64, bool)>),
    /// M₀ did not factor at the next step: take it with [`Expansion::step`], whose error says
    /// why.
    Unfactored,
}

/// The outcome of the compiled step from t that ended with `status` and `control`.
#[cfg(feature = "jit")]
fn stepped(status: KernelStatus, control: &StepControl) -> Result<(f64, bool)> {
    let t = control.t;
    match status {
        KernelStatus::Step => Ok((control.t_new, false)),
        KernelStatus::Last => Ok((control.t_new, true)),
        KernelStatus::Coefficient => Err(non_finite(t)),
        KernelStatus::TooSmall => Err(Error::StepSizeTooSmall { t, h: control.h }),
        KernelStatus::State => Err(Error::NonFinite {
            what: "state",
            t: control.t_new,
        }),
        KernelStatus::Expanded | KernelStatus::Unfactored => {
            unreachable!("a step's status, not an expansion's or a factor's")
        }
    }
}

/// The error of an expansion at t₀ with a coefficient that is not finite.
fn non_finite(t0: f64) -> Error {
    Error::NonFinite {
        what: "Taylor coefficient",
        t: t0,
    }
}

/// M₀ = M(t₀, q₀) from order 0 of its rows in `series` (row width w), factored into `m0`;
/// `m0_fixed` keeps a mass matrix that depends on the parameters alone factored for good.
fn factor_m0(
    program: &TaylorProgram,
    series: &[f64],
    w: usize,
    m0: &mut [f64],
    m0_fixed: &mut bool,
    t0: f64,
    q0: &[f64],
) -> Result<()> {
    if *m0_fixed {
        return Ok(());
    }
    for (m, &row) in m0.iter_mut().zip(&program.recurrences.mass_full) {
        *m = series[row * w];
    }
    crate::linalg::factor_mass(m0, program.recurrences.dof, t0, q0)?;
    *m0_fixed = program.recurrences.mass_constant;
    Ok(())
}
