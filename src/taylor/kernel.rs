//! The Taylor recurrences ([`SeriesOp`]) as machine code (feature `jit`), in two forms.
//!
//! - [`ExpansionKernel`]: for a small program, the whole expansion to one order p — every
//!   order's recurrences, fₖ − Σⱼ Mⱼ q̈ₖ₋ⱼ, the solve with M₀ and the coefficients of q and q̇
//!   — and the Taylor step from it, as straight-line code with every index a constant, its sums
//!   in two-lane vectors, compiled once per order a run asks for.
//! - [`SeriesKernel`]: for any program, coefficient k ≥ 1 of every row that varies, for any
//!   order k and row width w given at the call. Each convolution is a loop in the code (small
//!   programs) or a call of the interpreter's own sum (large ones, [`INLINE_UP_TO`]), so the
//!   code grows with the graph and not with the order.
//!
//! The operations and their order are those of [`SeriesOp::apply`] and `Expansion::expand` (the same
//! four lanes per sum, no fused multiply–add), so the coefficients are bit-identical to the
//! interpreter's, which stays the fallback and the reference. Safety by construction: every row
//! an operation reads or writes is checked against the table's row count before any code is
//! emitted, and the kernels' `run` check the buffers' lengths, the width and the order.

use super::abi::{Buffers, KernelStatus, StepArgs, StepControl};
use super::lower::Recurrences;
use super::series::{LANES, SeriesOp, fresh_ends};
use crate::native::{BACKTRACKING_UP_TO, Code, declare, enter, fail, jit_module, link};

use crate::error::Result;
use cranelift_codegen::ir::{
    AbiParam, BlockArg, FuncRef, InstBuilder, MemFlagsData, StackSlotData, StackSlotKind, Value,
    condcodes, types,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::{Linkage, Module};
use std::collections::{HashMap, HashSet};

/// The Taylor kernels' own functions, handed to the code generator by name.
fn symbols() -> [(&'static str, *const u8); 2] {
    [
        (
            "lagrangian_conv",
            super::series::lagrangian_conv as *const u8,
        ),
        ("lagrangian_ldlt", lagrangian_ldlt as *const u8),
    ]
}

/// Programs of up to this many recurrences get their convolutions as loops in the code, larger
/// ones as calls of the interpreter's sum (`lagrangian_conv`). Measured (release, 2-core
/// machine, `examples/taylor_timing.rs` and N-link chains): loops run the double pendulum's
/// steps 1.34× faster than calls (0.53 against 0.70 ms at 1e-9) and compile within the
/// backtracking register allocator's budget ([`jit_module`]); past it, the single-pass
/// allocator made the loops 5–9× slower than calls (the 8-link chain: 6.4 against 1.3 ms), and
/// calls compile in a fraction of the time (the 32-link chain: 84 ms against 4.3 s).
const INLINE_UP_TO: usize = 400;

/// The compiled function: order k, row width w, the table.
type Entry = unsafe extern "C" fn(i64, i64, *mut f64);

/// The recurrences of one [`Recurrences`](super::Recurrences) as machine code.
pub(crate) struct SeriesKernel {
    code: Code<Entry>,
    rows: usize,
}

impl std::fmt::Debug for SeriesKernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SeriesKernel")
            .field("rows", &self.rows)
            .finish_non_exhaustive()
    }
}

/// Every row an operation reads or writes.
fn rows_of(op: &SeriesOp) -> Vec<usize> {
    match *op {
        SeriesOp::Copy { out, a }
        | SeriesOp::Neg { out, a }
        | SeriesOp::Exp { out, a }
        | SeriesOp::Ln { out, a }
        | SeriesOp::Sqrt { out, a }
        | SeriesOp::Abs { out, a }
        | SeriesOp::Sign { out, a }
        | SeriesOp::Square { out, a } => vec![out, a],
        SeriesOp::Recip { out, b } => vec![out, b],
        SeriesOp::Add { out, a, b }
        | SeriesOp::Sub { out, a, b }
        | SeriesOp::Mul { out, a, b }
        | SeriesOp::Div { out, a, b } => vec![out, a, b],
        SeriesOp::Scale { out, a, c } | SeriesOp::DivC { out, a, c } => vec![out, a, c],
        SeriesOp::SinCos { s, c, a, da, .. } => [s, c, a].into_iter().chain(da).collect(),
        SeriesOp::Tan { out, w, a, .. } => vec![out, w, a],
        SeriesOp::Atan2 { out, y, x, d, r } => vec![out, y, x, d, r],
    }
}

impl SeriesKernel {
    /// Compile `ops` (recurrences over a table of `rows` rows) for the host.
    ///
    /// # Errors
    /// [`Error::InvalidInput`](crate::Error::InvalidInput) when a row is out of range, Cranelift
    /// has no backend for the host or fails: the interpreter runs the recurrences instead.
    pub(crate) fn compile(ops: &[SeriesOp], rows: usize) -> Result<Self> {
        if let Some(r) = ops.iter().flat_map(rows_of).find(|&r| r >= rows) {
            return Err(fail(format!("row {r} of a table of {rows}")));
        }
        // About twenty instructions per recurrence with its loops, four with calls.
        let inline = ops.len() <= INLINE_UP_TO;
        let module = jit_module(
            if inline { 20 } else { 4 } * ops.len() <= BACKTRACKING_UP_TO,
            &symbols(),
        )?;
        let code = Code::new(module, |m| define(m, ops, inline))?;
        Ok(Self { code, rows })
    }

    /// Coefficient k of every row the recurrences write, in the table `s` of row width `w`.
    ///
    /// # Panics
    /// If `s` has fewer than rows · w entries, or k is not in 1..w.
    pub(crate) fn run(&self, s: &mut [f64], w: usize, k: usize) {
        assert!(
            k >= 1 && k < w && s.len() >= self.rows * w,
            "order {k} of a table of {} rows of {w} in {} entries",
            self.rows,
            s.len()
        );
        // SAFETY: the code reads and writes entries r·w + j of rows r < `rows` (checked at
        // compilation) and j ≤ k < w, all inside `s` by the assert; `self` keeps the code alive.
        unsafe { (self.code.entry())(k as i64, w as i64, s.as_mut_ptr()) }
    }
}

/// Generate, compile and link the recurrences for any order (k and w read at run time).
fn define(module: &mut JITModule, ops: &[SeriesOp], inline: bool) -> Result<Entry> {
    let config = module.target_config();
    let ptr = config.pointer_type();
    let (id, mut ctx) = declare(module, "series", &[types::I64, types::I64, ptr])?;
    let calls = if inline {
        None
    } else {
        let mut conv = module.make_signature();
        conv.params.extend([AbiParam::new(ptr), AbiParam::new(ptr)]);
        conv.params.extend([AbiParam::new(types::I64); 4]);
        conv.params.push(AbiParam::new(types::I32));
        conv.returns.push(AbiParam::new(types::F64));
        Some(
            module
                .declare_function("lagrangian_conv", Linkage::Import, &conv)
                .map_err(fail)?,
        )
    };
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let p = enter(&mut b);
        let (k, w, table) = (p[0], p[1], p[2]);
        let calls = calls.map(|c| module.declare_func_in_func(c, b.func));
        let mut g = Gen::new(b, table, Ix::Var(w), calls);
        g.k = Ix::Var(k);
        let kf = g.b.ins().fcvt_from_sint(types::F64, k);
        let one = g.f64(1.0);
        g.inv_k = g.b.ins().fdiv(one, kf);
        for op in ops {
            g.op(op);
        }
        g.b.ins().return_(&[]);
        g.b.finalize(config);
    }
    let code = link(module, id, &mut ctx)?;
    // SAFETY: `code` is the function just defined with the signature of `Entry` in the host's
    // default calling convention, which is `extern "C"`.
    Ok(unsafe { std::mem::transmute::<*const u8, Entry>(code) })
}

/// Programs whose whole expansion ([`ExpansionKernel`]) comes to at most this many instructions
/// (estimated by [`Recurrences::expansion_instructions`]) may get it compiled, unrolled;
/// larger ones run the recurrences of [`SeriesKernel`] order by order, with the rest of the
/// expansion in Rust.
/// Compilation grows faster than the program (2-core machine, release, 2026-11-27): about
/// 0.4 s for 100 000 estimated instructions (the 4-link chain at order 22), 0.7 s for the
/// 8-link chain at order 14 (111 000: 46 against 21 µs per expansion, paid back after 28 000),
/// 1.9 s for it at order 18 (174 000: 117 against 83 µs, 57 000), 3.4 s for the 16-link chain at
/// order 11 (210 000: 109 against 54 µs, 61 000) and 8.8 s at order 14 (324 000: no faster). Up
/// to this size an expansion compiled after [`UNROLL_AFTER`] pays back within about 3× that.
const UNROLL_UP_TO: usize = 120_000;

/// Expansions to one order a program runs with [`SeriesKernel`] before its [`ExpansionKernel`]
/// for that order is compiled: about the break-even, as compiling and the time it saves per
/// expansion both grow with the program. Measured (2-core machine, release, 2026-11-27, at
/// order 13): the double pendulum compiles in 16–22 ms and expands in 0.64–0.67 against
/// 1.47–1.55 µs (break-even after 18 000–24 000 expansions), the 4-link chain in 0.15–0.25 s,
/// 4.8 against 13.6–13.8 µs (17 000–24 000), the forced two-mass in 3.2–3.7 ms, 0.13 against
/// 0.67 µs (6 000–6 500), Kepler in 10–14 ms, 0.40 against 1.12 µs (13 000–19 000; before its
/// squares summed half their terms, which took 6 % off the instructions of its unrolled step).
/// Waiting for the break-even keeps a short run from paying for code it would not repay (at
/// worst a run then costs about twice what the better choice in hindsight would have).
pub(crate) const UNROLL_AFTER: usize = 10_000;

/// The entry of an [`ExpansionKernel`]: the table, the coefficients of q and of q̇ (order k of
/// coordinate i at k·n + i), of q̈ (coordinate i's order k at i·w + k), M₀ factored, the work
/// space of reversed series ([`ExpansionKernel::reversed_len`]); then, for a step (a null
/// `StepControl` for the expansion alone), the step's control, the state y, the compensation
/// and the new state. It returns a [`KernelStatus`].
type ExpansionEntry = unsafe extern "C" fn(
    *mut f64,
    *mut f64,
    *mut f64,
    *mut f64,
    *const f64,
    *mut f64,
    *mut StepControl,
    *const f64,
    *mut f64,
    *mut f64,
) -> i32;

/// The entry of an [`ExpansionKernel`]'s order 0: the table, q₀ and q̇₀, and the coefficient
/// buffers of q and q̇ (their order 0 written there too).
type Order0Entry = unsafe extern "C" fn(*mut f64, *const f64, *const f64, *mut f64, *mut f64);

/// The entry of an [`ExpansionKernel`]'s row of steps ([`ExpansionKernel::steps`]): the
/// arguments of [`ExpansionEntry`] (M₀'s factor written, y read and written), then the most
/// steps to take and where to write how many were taken. It returns the [`KernelStatus`] of the step
/// that ended the row.
type StepsEntry = unsafe extern "C" fn(
    *mut f64,
    *mut f64,
    *mut f64,
    *mut f64,
    *mut f64,
    *mut f64,
    *mut StepControl,
    *mut f64,
    *mut f64,
    *mut f64,
    usize,
    *mut usize,
) -> i32;

/// An [`ExpansionKernel`]'s functions.
#[derive(Clone, Copy)]
struct Entries {
    order0: Order0Entry,
    expansion: ExpansionEntry,
    steps: StepsEntry,
}

/// The whole expansion of a small [`Recurrences`] to one order p, and the Taylor step from it,
/// as straight-line machine code in two functions either side of the factorization of M₀
/// (which may fail, and is reported from Rust): order 0 of every row from q₀ and q̇₀ (the maths
/// library's functions called as the interpreter calls them), then, given M₀ factored, orders
/// k = 0, …, p − 1 of q̈ — the leaves' row coefficients, the recurrences, fₖ − Σⱼ Mⱼ q̈ₖ₋ⱼ, the
/// LDLᵀ solve — and orders 1, …, p of q and q̇, and with a [`StepControl`] the step of
/// `Expansion::step` (its size from the last two orders, the new state). Every index is a
/// constant: no loop, no bound to test at run time. A third function runs such steps in a row
/// ([`ExpansionKernel::steps`]), factoring M₀ itself. The operations and their order are those of
/// `Expansion::expand` and `Expansion::step` with the interpreter (the sums in the lanes of
/// `conv`, two at a time in two-lane vectors; the solve of `linalg::ldlt_solve`, or
/// `ldlt_solve_pattern` where M has zeros by structure), so the coefficients and the steps are
/// the same bits.
pub(crate) struct ExpansionKernel {
    code: Code<Entries>,
    rows: usize,
    dof: usize,
    order: usize,
    reversed_len: usize,
}

impl std::fmt::Debug for ExpansionKernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExpansionKernel")
            .field("order", &self.order)
            .finish_non_exhaustive()
    }
}

impl ExpansionKernel {
    /// Compile the expansion of `program` to `order` for the host, if it is small enough
    /// ([`UNROLL_UP_TO`]).
    ///
    /// # Errors
    /// [`Error::InvalidInput`](crate::Error::InvalidInput) when the expansion is too large to
    /// unroll, a row is out of range, or Cranelift has no backend for the host or fails: the
    /// recurrences then run order by order.
    pub(crate) fn compile(program: &Recurrences, order: usize) -> Result<Self> {
        let size = program.expansion_instructions(order);
        if order == 0 || size > UNROLL_UP_TO {
            return Err(fail(format!("{size} instructions to unroll")));
        }
        let rows = program.rows;
        let read = program
            .force
            .iter()
            .chain(&program.mass_full)
            .chain(program.coords.iter().chain(&program.velocities).flatten());
        if let Some(r) = program
            .varying
            .iter()
            .chain(&program.order0)
            .flat_map(rows_of)
            .chain(read.copied())
            .find(|&r| r >= rows)
        {
            return Err(fail(format!("row {r} of a table of {rows}")));
        }
        let w = order + 1;
        let n = program.dof;
        if i32::try_from(8 * (rows * w).max(n * (w + 1)).max(n * n)).is_err() {
            return Err(fail(format!("a table of {rows} rows of {w}")));
        }
        // Straight-line code: the backtracking allocator at any size (measured: the single-pass
        // allocator's code ran the double pendulum's expansion to order 19 2.2× slower, 5.3
        // against 2.4 µs, and the 4-link chain's to order 12 2.2× slower).
        let module = jit_module(true, &symbols())?;
        let mut reversed_len = 0;
        let code = Code::new(module, |m| {
            let (expansion, reversed) = define_expansion(m, program, order)?;
            reversed_len = reversed;
            let order0 = define_order0(m, program, order)?;
            Ok(Entries {
                order0,
                expansion,
                steps: define_steps(m, program, order, order0, expansion)?,
            })
        })?;
        Ok(Self {
            code,
            rows,
            dof: n,
            order,
            reversed_len,
        })
    }

    /// Order 0 of every row the state sets, from q₀ and q̇₀ (`table` holds t₀ in t's row and the
    /// rows fixed by the parameters); q₀ and q̇₀ into the coefficient buffers `q` and `v` too.
    ///
    /// # Panics
    /// If a buffer is shorter than the expansion's layout.
    pub(crate) fn order0(
        &self,
        table: &mut [f64],
        q0: &[f64],
        qd0: &[f64],
        q: &mut [f64],
        v: &mut [f64],
    ) {
        let (n, w) = (self.dof, self.order + 1);
        assert!(
            table.len() >= self.rows * w
                && q0.len() >= n
                && qd0.len() >= n
                && q.len() >= n
                && v.len() >= n,
            "buffers too short for an expansion of {n} coordinates to order {}",
            self.order
        );
        // SAFETY: the code writes and reads table entries r·w with rows r < `rows` (checked at
        // compilation), reads q₀ and q̇₀ entries below n and writes q and q̇ entries below n, all
        // inside the buffers by the assert; `self` keeps the code alive.
        unsafe {
            (self.code.entry().order0)(
                table.as_mut_ptr(),
                q0.as_ptr(),
                qd0.as_ptr(),
                q.as_mut_ptr(),
                v.as_mut_ptr(),
            )
        }
    }

    /// Entries of the work space [`run`](Self::run) mirrors series into (those it reads
    /// backwards, kept forwards too).
    pub(crate) fn reversed_len(&self) -> usize {
        self.reversed_len
    }

    /// Run the expansion: `table` holds order 0 of every row, q and q̇ their order 0, `m0` M₀'s
    /// LDLᵀ factor; `reversed` is work space of [`reversed_len`](Self::reversed_len) entries.
    /// [`KernelStatus::Expanded`], or [`KernelStatus::Coefficient`] when a coefficient of q̈ is not finite.
    ///
    /// # Panics
    /// If a buffer is shorter than the expansion's layout.
    pub(crate) fn run(&self, buffers: Buffers<'_>) -> KernelStatus {
        self.call(buffers, None)
    }

    /// Run the expansion and take the step `Expansion::step` takes from the state y with
    /// `control`, writing the new state and compensation into `lost` and `y_new` (see
    /// [`KernelStatus`] and [`StepControl`] for the outcome).
    ///
    /// # Panics
    /// If a buffer is shorter than the expansion's layout.
    pub(crate) fn step(&self, buffers: Buffers<'_>, step: StepArgs<'_>) -> KernelStatus {
        let n = self.dof;
        assert!(
            step.y.len() >= 2 * n && step.lost.len() >= 2 * n && step.y_new.len() >= 2 * n,
            "buffers too short for a step of {n} coordinates"
        );
        self.call(buffers, Some(step))
    }

    /// Take steps from the state y at `control.t` in a row, until one is the last of the run
    /// or fails, or `limit` have been taken: each one's order 0 (from y, t in its row), M₀'s
    /// factor (where M varies: otherwise `buffers.m0` holds M's factor for good), then
    /// [`step`](Self::step) from y; a step that is neither the last nor failed moves y to its
    /// new state and `control.t` to its time. The status of the step that ended the row
    /// ([`KernelStatus::Step`] when `limit` were taken, [`KernelStatus::Unfactored`] when M₀ did not
    /// factor), and how many steps were taken before it (all `limit` for [`KernelStatus::Step`]).
    /// The same steps, bit for bit, as that many calls of order 0, `Expansion`'s factor and
    /// [`step`](Self::step).
    ///
    /// # Panics
    /// If a buffer is shorter than the expansion's layout, or `limit` is 0.
    pub(crate) fn steps(
        &self,
        b: Buffers<'_>,
        control: &mut StepControl,
        [y, lost, y_new]: [&mut [f64]; 3],
        limit: usize,
    ) -> (KernelStatus, usize) {
        let n = self.dof;
        self.check(&b);
        assert!(
            y.len() >= 2 * n && lost.len() >= 2 * n && y_new.len() >= 2 * n && limit > 0,
            "buffers too short for a step of {n} coordinates, or no step to take"
        );
        let mut taken = 0;
        // SAFETY: as for `call`, and order 0 reads y's entries below 2n; the row writes M₀'s
        // entries below n² (copied from the table and factored), y's below 2n and `taken`, all
        // inside the buffers by the asserts.
        let code = unsafe {
            (self.code.entry().steps)(
                b.table.as_mut_ptr(),
                b.q.as_mut_ptr(),
                b.v.as_mut_ptr(),
                b.qdd.as_mut_ptr(),
                b.m0.as_mut_ptr(),
                b.reversed.as_mut_ptr(),
                control,
                y.as_mut_ptr(),
                lost.as_mut_ptr(),
                y_new.as_mut_ptr(),
                limit,
                &mut taken,
            )
        };
        (KernelStatus::from_code(code), taken)
    }

    /// That the buffers hold an expansion of this kernel's layout.
    fn check(&self, b: &Buffers<'_>) {
        let (n, w) = (self.dof, self.order + 1);
        assert!(
            b.table.len() >= self.rows * w
                && b.q.len() >= n * (w + 1)
                && b.v.len() >= n * (w + 1)
                && b.qdd.len() >= n * w
                && b.m0.len() >= n * n
                && b.reversed.len() >= self.reversed_len,
            "buffers too short for an expansion of {n} coordinates to order {}",
            self.order
        );
    }

    fn call(&self, b: Buffers<'_>, step: Option<StepArgs<'_>>) -> KernelStatus {
        self.check(&b);
        let (control, y, lost, y_new) = match step {
            Some(s) => (
                s.control as *mut StepControl,
                s.y.as_ptr(),
                s.lost.as_mut_ptr(),
                s.y_new.as_mut_ptr(),
            ),
            None => (
                std::ptr::null_mut(),
                std::ptr::null(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
            ),
        };
        // SAFETY: the code reads and writes table entries r·w + j with rows r < `rows` (checked
        // at compilation) and j < w, q and q̇ entries below n·(w + 1), q̈ entries below n·w, M₀
        // entries below n² and `reversed` entries below `reversed_len` (a slot of w entries per
        // series mirrored), all inside the buffers by the assert; with a control (not null) it
        // reads and writes its fields, reads y and reads and writes `lost` and `y_new` below 2n
        // (asserted by `step`); `self` keeps the code alive.
        let code = unsafe {
            (self.code.entry().expansion)(
                b.table.as_mut_ptr(),
                b.q.as_mut_ptr(),
                b.v.as_mut_ptr(),
                b.qdd.as_mut_ptr(),
                b.m0.as_ptr(),
                b.reversed.as_mut_ptr(),
                control,
                y,
                lost,
                y_new,
            )
        };
        KernelStatus::from_code(code)
    }
}

/// Generate, compile and link order 0 of the expansion: the leaves' rows, then `order0`'s
/// recurrences at k = 0.
fn define_order0(
    module: &mut JITModule,
    program: &Recurrences,
    order: usize,
) -> Result<Order0Entry> {
    let config = module.target_config();
    let ptr = config.pointer_type();
    let (id, mut ctx) = declare(module, "order0", &[ptr; 5])?;
    // The maths library's functions order 0 calls, imported.
    let mut names: Vec<&'static str> = program
        .order0
        .iter()
        .flat_map(|op| op.libm().iter().copied())
        .collect();
    names.sort_unstable();
    names.dedup();
    let mut imports = Vec::with_capacity(names.len());
    for name in names {
        let mut sig = module.make_signature();
        let second = match name {
            "lagrangian_atan2" => Some(types::F64),
            "lagrangian_sin_cos" => Some(ptr),
            _ => None,
        };
        sig.params.push(AbiParam::new(types::F64));
        sig.params.extend(second.map(AbiParam::new));
        sig.returns.push(AbiParam::new(types::F64));
        let id = module
            .declare_function(name, Linkage::Import, &sig)
            .map_err(fail)?;
        imports.push((name, module.declare_func_in_func(id, &mut ctx.func)));
    }
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let p = enter(&mut b);
        let (table, q0, qd0, qp, vp) = (p[0], p[1], p[2], p[3], p[4]);
        let mut g = Gen::new(b, table, Ix::Fixed(order + 1), None);
        g.libm = imports;
        for (from, to, leaf) in [(q0, qp, &program.coords), (qd0, vp, &program.velocities)] {
            for (i, r) in leaf.iter().enumerate() {
                let x = g.load_at(from, i);
                g.store_at(to, i, x);
                if let Some(r) = *r {
                    g.store(r, Ix::Fixed(0), x);
                }
            }
        }
        for op in &program.order0 {
            g.op0(op, ptr);
        }
        g.b.ins().return_(&[]);
        g.b.finalize(config);
    }
    let code = link(module, id, &mut ctx)?;
    // SAFETY: `code` is the function just defined with the signature of `Order0Entry` in the
    // host's default calling convention, which is `extern "C"`.
    Ok(unsafe { std::mem::transmute::<*const u8, Order0Entry>(code) })
}

/// Generate, compile and link the unrolled expansion and step; also the length of the buffer of
/// reversed rows it needs ([`Gen::mirror`]).
fn define_expansion(
    module: &mut JITModule,
    program: &Recurrences,
    order: usize,
) -> Result<(ExpansionEntry, usize)> {
    let config = module.target_config();
    let ptr = config.pointer_type();
    let (id, mut ctx) = declare(module, "expansion", &[ptr; 10])?;
    ctx.func.signature.returns.push(AbiParam::new(types::I32));
    // The step size is a logarithm and an exponential away from the last coefficients.
    let mut libm = Vec::new();
    for name in ["lagrangian_ln", "lagrangian_exp"] {
        let mut sig = module.make_signature();
        sig.params.push(AbiParam::new(types::F64));
        sig.returns.push(AbiParam::new(types::F64));
        let f = module
            .declare_function(name, Linkage::Import, &sig)
            .map_err(fail)?;
        libm.push((name, module.declare_func_in_func(f, &mut ctx.func)));
    }
    // A first pass, never compiled, finds the series the two-lane sums read backwards, so that
    // the second makes their mirrors at order 0, long before the first such read (made at the
    // first read, the copies were still on their way to memory when the loads came, and each
    // load waited for them).
    let mut first_pass = ctx.func.clone();
    let backwards = emit_expansion(&mut first_pass, config, program, order, &libm, &[]);
    let backwards = emit_expansion(&mut ctx.func, config, program, order, &libm, &backwards);
    let reversed_len = backwards.len() * (order + 1);
    let code = link(module, id, &mut ctx)?;
    // SAFETY: `code` is the function just defined with the signature of `ExpansionEntry` in the
    // host's default calling convention, which is `extern "C"`.
    let entry = unsafe { std::mem::transmute::<*const u8, ExpansionEntry>(code) };
    Ok((entry, reversed_len))
}

/// Generate, compile and link the row of steps ([`ExpansionKernel::steps`]): a loop that calls
/// the kernel's `order0` and `expansion` (linked before it) and, where M varies, copies M₀ out
/// of the table and factors it — in the code for up to two coordinates ([`factor_small`]), by
/// `linalg::ldlt_in_place` itself above (`lagrangian_ldlt`) — so the steps are those of the
/// calls made one by one from Rust, without the Rust around each.
fn define_steps(
    module: &mut JITModule,
    program: &Recurrences,
    order: usize,
    order0: Order0Entry,
    expansion: ExpansionEntry,
) -> Result<StepsEntry> {
    let config = module.target_config();
    let ptr = config.pointer_type();
    let (id, mut ctx) = declare(module, "steps", &[ptr; 12])?;
    ctx.func.signature.returns.push(AbiParam::new(types::I32));
    let mut order0_sig = module.make_signature();
    order0_sig.params = vec![AbiParam::new(ptr); 5];
    let mut expansion_sig = module.make_signature();
    expansion_sig.params = vec![AbiParam::new(ptr); 10];
    expansion_sig.returns.push(AbiParam::new(types::I32));
    let ldlt = if program.mass_constant {
        None
    } else {
        let mut sig = module.make_signature();
        sig.params = vec![AbiParam::new(ptr); 2];
        sig.returns.push(AbiParam::new(types::I32));
        let f = module
            .declare_function("lagrangian_ldlt", Linkage::Import, &sig)
            .map_err(fail)?;
        Some(module.declare_func_in_func(f, &mut ctx.func))
    };
    let order0_sig = ctx.func.import_signature(order0_sig);
    let expansion_sig = ctx.func.import_signature(expansion_sig);
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let p = enter(&mut b);
        let (table, m0, control, y, new, limit, taken) =
            (p[0], p[4], p[6], p[7], p[9], p[10], p[11]);
        let (n, w) = (program.dof, order + 1);
        let flags = Gen::flags();
        let f64_at = |i: usize| i32::try_from(8 * i).expect("checked at compilation");
        let (head, exit) = (b.create_block(), b.create_block());
        b.append_block_param(head, ptr);
        b.append_block_param(exit, types::I32);
        b.append_block_param(exit, ptr);
        let zero = b.ins().iconst(ptr, 0);
        b.ins().jump(head, &[BlockArg::Value(zero)]);
        b.switch_to_block(head);
        let count = b.block_params(head)[0];
        use std::mem::offset_of;
        let at_t = f64_at(offset_of!(StepControl, t) / 8);
        if let Some(r) = program.time {
            let t = b.ins().load(types::F64, flags, control, at_t);
            b.ins().store(flags, t, table, f64_at(r * w));
        }
        let qd0 = b.ins().iadd_imm_s(y, 8 * n as i64);
        let callee = b.ins().iconst(ptr, order0 as usize as i64);
        b.ins()
            .call_indirect(order0_sig, callee, &[table, y, qd0, p[1], p[2]]);
        if let Some(ldlt) = ldlt {
            for (e, &r) in program.mass_full.iter().enumerate() {
                let m = b.ins().load(types::F64, flags, table, f64_at(r * w));
                b.ins().store(flags, m, m0, f64_at(e));
            }
            let failed = if n <= 2 {
                factor_small(&mut b, m0, n)
            } else {
                let dof = b.ins().iconst(ptr, n as i64);
                let call = b.ins().call(ldlt, &[m0, dof]);
                b.inst_results(call)[0]
            };
            let factored = b.create_block();
            let unfactored = b.ins().iconst(types::I32, KernelStatus::Unfactored as i64);
            b.ins().brif(
                failed,
                exit,
                &[BlockArg::Value(unfactored), BlockArg::Value(count)],
                factored,
                &[],
            );
            b.switch_to_block(factored);
            b.seal_block(factored);
        }
        let callee = b.ins().iconst(ptr, expansion as usize as i64);
        let call = b.ins().call_indirect(expansion_sig, callee, &p[..10]);
        let status = b.inst_results(call)[0];
        let step = b
            .ins()
            .icmp_imm_s(condcodes::IntCC::Equal, status, KernelStatus::Step as i64);
        let commit = b.create_block();
        b.ins().brif(
            step,
            commit,
            &[],
            exit,
            &[BlockArg::Value(status), BlockArg::Value(count)],
        );
        // Neither the last step nor failed: y and t move on.
        b.switch_to_block(commit);
        b.seal_block(commit);
        for j in 0..2 * n {
            let x = b.ins().load(types::F64, flags, new, f64_at(j));
            b.ins().store(flags, x, y, f64_at(j));
        }
        let at_t_new = f64_at(offset_of!(StepControl, t_new) / 8);
        let t_new = b.ins().load(types::F64, flags, control, at_t_new);
        b.ins().store(flags, t_new, control, at_t);
        let count = b.ins().iadd_imm_s(count, 1);
        let more = b
            .ins()
            .icmp(condcodes::IntCC::UnsignedLessThan, count, limit);
        b.ins().brif(
            more,
            head,
            &[BlockArg::Value(count)],
            exit,
            &[BlockArg::Value(status), BlockArg::Value(count)],
        );
        b.seal_block(head);
        b.switch_to_block(exit);
        b.seal_block(exit);
        let (status, count) = (b.block_params(exit)[0], b.block_params(exit)[1]);
        b.ins().store(flags, count, taken, 0);
        b.ins().return_(&[status]);
        b.finalize(config);
    }
    let code = link(module, id, &mut ctx)?;
    // SAFETY: `code` is the function just defined with the signature of `StepsEntry` in the
    // host's default calling convention, which is `extern "C"`.
    Ok(unsafe { std::mem::transmute::<*const u8, StepsEntry>(code) })
}

/// `linalg::ldlt_in_place` for n ≤ 2 in the code, on the n × n matrix at `m`: the same factor,
/// bit for bit, where it succeeds (the call of the general one cost Kepler's orbit 123
/// instructions a step). A nonzero i32 where it does not: where `ldlt_in_place` fails, and
/// maybe where it does not (each test is one comparison that NaN fails), since the step is then
/// taken again through it.
fn factor_small(b: &mut FunctionBuilder<'_>, m: Value, n: usize) -> Value {
    use condcodes::FloatCC::{GreaterThan, LessThan};
    let flags = Gen::flags();
    let at = |i: usize| 8 * i as i32;
    let (one, infinity) = (b.ins().f64const(1.0), b.ins().f64const(f64::INFINITY));
    let a00 = b.ins().load(types::F64, flags, m, at(0));
    // For n = 1 it succeeds exactly where the pivot is finite and above 0; `ldlt_2x2` where a₀₀
    // and d₁ = det / a₀₀ are finite and above the floor relative to the larger diagonal entry.
    let (pivot, floor) = if n == 1 {
        (a00, b.ins().f64const(0.0))
    } else {
        let a10 = b.ins().load(types::F64, flags, m, at(2));
        let a11 = b.ins().load(types::F64, flags, m, at(3));
        let (x, y) = (b.ins().fabs(a00), b.ins().fabs(a11));
        let scale = b.ins().fmax(x, y);
        let relative = b.ins().f64const(crate::linalg::RELATIVE_PIVOT_FLOOR);
        let floor = b.ins().fmul(relative, scale);
        let (p, q) = (b.ins().fmul(a00, a11), b.ins().fmul(a10, a10));
        let det = b.ins().fsub(p, q);
        let d1 = b.ins().fdiv(det, a00);
        let r1 = b.ins().fdiv(a00, det);
        let r0 = b.ins().fdiv(one, a00);
        let l = b.ins().fmul(a10, r0);
        b.ins().store(flags, a10, m, at(1));
        b.ins().store(flags, l, m, at(2));
        b.ins().store(flags, r1, m, at(3));
        b.ins().store(flags, r0, m, at(0));
        let first = b.ins().fcmp(GreaterThan, a00, floor);
        let finite = b.ins().fcmp(LessThan, scale, infinity);
        let ok = b.ins().band(first, finite);
        return fails(b, ok, d1, floor, infinity);
    };
    let r0 = b.ins().fdiv(one, a00);
    b.ins().store(flags, r0, m, at(0));
    let ok = b.ins().iconst(types::I8, 1);
    fails(b, ok, pivot, floor, infinity)
}

/// 0 where `ok` holds and the pivot d is finite and above the floor, else 1.
fn fails(b: &mut FunctionBuilder<'_>, ok: Value, d: Value, floor: Value, infinity: Value) -> Value {
    use condcodes::FloatCC::{GreaterThan, LessThan};
    let above = b.ins().fcmp(GreaterThan, d, floor);
    let finite = b.ins().fcmp(LessThan, d, infinity);
    let ok = b.ins().band(ok, above);
    let ok = b.ins().band(ok, finite);
    let failed = b.ins().bxor_imm_s(ok, 1);
    b.ins().uextend(types::I32, failed)
}

/// `linalg::ldlt_in_place` on the n × n matrix at `m`, for the compiled row of steps: 0 when it
/// factored, 1 when it did not (`Expansion::step` then takes the step again, and names why).
///
/// # Safety
/// `m` is valid for reads and writes of n² `f64`.
pub(crate) unsafe extern "C" fn lagrangian_ldlt(m: *mut f64, n: usize) -> i32 {
    // SAFETY: by the caller's contract.
    let m = unsafe { std::slice::from_raw_parts_mut(m, n * n) };
    i32::from(crate::linalg::ldlt_in_place(m, n).is_err())
}

/// The unrolled expansion and step's code, in `func`; the series mirrored backwards
/// ([`Gen::mirror`]), in the order of their slots, each with whether the code computes its
/// coefficients beyond 0 (not so for t and the rows fixed at order 0). `backwards` are made at
/// order 0 (the rest where first read): their coefficient 0, or every coefficient of a series
/// the code does not compute.
fn emit_expansion(
    func: &mut cranelift_codegen::ir::Function,
    config: cranelift_codegen::isa::TargetFrontendConfig,
    program: &Recurrences,
    order: usize,
    libm: &[(&'static str, FuncRef)],
    backwards: &[(Operand, bool)],
) -> Vec<(Operand, bool)> {
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(func, &mut fctx);
        let p = enter(&mut b);
        let (table, qp, vp, qddp, m0p, rev) = (p[0], p[1], p[2], p[3], p[4], p[5]);
        let step = [p[6], p[7], p[8], p[9]];
        let (n, w) = (program.dof, order + 1);
        let mut g = Gen::new(b, table, Ix::Fixed(w), None);
        g.libm = libm.to_vec();
        g.reversed = Some(rev);
        g.qdd = Some(qddp);
        for &(x, computed) in backwards {
            g.mirror(x, if computed { 0 } else { order });
        }
        // Only the coefficients read at later orders are stored (the others are forwarded
        // within their order): the rows the sums read, and the entries of M that vary.
        let mut history: HashSet<usize> =
            program.varying.iter().flat_map(SeriesOp::history).collect();
        for (e, &m) in program.mass_full.iter().enumerate() {
            if program.mass_varying[e] {
                history.insert(m);
            }
        }
        g.history = Some(history);
        // Σ (q̈ₖ − q̈ₖ) over the coefficients: 0 when they are finite, NaN otherwise.
        let mut check = g.f64(0.0);
        for k in 0..order {
            if k >= 1 {
                // The leaves: coefficient k of q and q̇ into their rows.
                for (base, leaf) in [(qp, &program.coords), (vp, &program.velocities)] {
                    for (i, r) in leaf.iter().enumerate() {
                        if let Some(r) = *r {
                            let x = g.load_at(base, k * n + i);
                            g.store(r, Ix::Fixed(k), x);
                        }
                    }
                }
                g.k = Ix::Fixed(k);
                g.inv_k = g.f64(1.0 / k as f64);
                for op in &program.varying {
                    g.op(op);
                }
            }
            // fₖ − Σ_c Σⱼ₌₁..ₖ M_rc,ⱼ q̈_c,ₖ₋ⱼ over the entries of M that vary.
            let mut rhs = Vec::with_capacity(n);
            for r in 0..n {
                let f = g.load(program.force[r], Ix::Fixed(k));
                let varying = &program.mass_varying[r * n..(r + 1) * n];
                rhs.push(if k >= 1 && varying.contains(&true) {
                    // From +0 as `Expansion::orders` sums: a sum of lanes is never −0, so the
                    // first is added to nothing.
                    let mut s = None;
                    for c in (0..n).filter(|&c| varying[c]) {
                        let m = program.mass_full[r * n + c];
                        let t = g.sum(Operand::Row(m), Operand::Qdd(c), 1, k, k, false);
                        s = Some(s.map_or(t, |s| g.b.ins().fadd(s, t)));
                    }
                    let s = s.expect("a row with an entry that varies");
                    g.b.ins().fsub(f, s)
                } else {
                    f
                });
            }
            // M₀ q̈ₖ = rhs as `linalg::ldlt_solve` (`ldlt_solve_pattern` without the entries of
            // L that are zero by structure): L y = b, D z = y, Lᵀ x = z.
            let nonzero = |e: usize| program.factor_nonzero.as_ref().is_none_or(|p| p[e]);
            for i in 1..n {
                let terms: Vec<Value> = (0..i)
                    .filter(|&j| nonzero(i * n + j))
                    .map(|j| {
                        let l = g.load_at(m0p, i * n + j);
                        g.b.ins().fmul(rhs[j], l)
                    })
                    .collect();
                if !terms.is_empty() {
                    let d = g.lanes(terms);
                    rhs[i] = g.b.ins().fsub(rhs[i], d);
                }
            }
            for i in 0..n {
                let d = g.load_at(m0p, i * n + i);
                rhs[i] = g.b.ins().fmul(rhs[i], d);
            }
            for i in (1..n).rev() {
                let x = rhs[i];
                for j in (0..i).filter(|&j| nonzero(i * n + j)) {
                    let l = g.load_at(m0p, i * n + j);
                    let xl = g.b.ins().fmul(x, l);
                    rhs[j] = g.b.ins().fsub(rhs[j], xl);
                }
            }
            // This order's values are read from memory by later orders (forwarded to all of
            // them, they ran the double pendulum 1.2× slower: the registers ran out); what the
            // next order starts from is forwarded.
            g.memory.clear();
            g.weighted.clear();
            g.stored[0] = std::mem::take(&mut g.stored[1]);
            g.carried = 0;
            // q̈ₖ; qₖ₊₁ = q̇ₖ · 1/(k + 1), q̇ₖ₊₁ = q̈ₖ · 1/(k + 1).
            let next = g.f64(1.0 / (k + 1) as f64);
            for (i, &a) in rhs.iter().enumerate() {
                g.store_qdd(i, k, a);
                let nothing = g.b.ins().fsub(a, a);
                check = g.b.ins().fadd(check, nothing);
                let vk = g.load_at(vp, k * n + i);
                let qn = g.b.ins().fmul(vk, next);
                g.store_at(qp, (k + 1) * n + i, qn);
                let vn = g.b.ins().fmul(a, next);
                g.store_at(vp, (k + 1) * n + i, vn);
            }
        }
        g.finish_step(check, step, (qp, vp), n, order);
        let mut slots: Vec<(Operand, usize)> = g.slots.into_iter().collect();
        slots.sort_by_key(|&(_, slot)| slot);
        g.b.finalize(config);
        let computed = |x| matches!(x, Operand::Qdd(_)) || g.computed.contains(&x);
        slots.into_iter().map(|(x, _)| (x, computed(x))).collect()
    }
}

/// The most values an order of the unrolled expansion takes from the registers rather than
/// from a two-lane load ([`Gen::pair`]).
const CARRIED: usize = 4;

/// An index the code knows at compilation, or reads at run time.
#[derive(Clone, Copy, PartialEq)]
enum Ix {
    Fixed(usize),
    Var(Value),
}

/// The last index of a convolution's sum, from the order k being computed.
#[derive(Clone, Copy)]
enum Top {
    /// k: its last term reads a coefficient of order k.
    K,
    /// k − 1.
    Below,
    /// min(k, d): the sum over a polynomial of degree d (its last term reads order k while k ≤ d).
    Degree(usize),
    /// min(k − 1, d): a sum over a polynomial of degree d up to k − 1.
    BelowDegree(usize),
    /// ⌊(k − 1)/2⌋: the first half of a square's sum ([`SeriesOp::Square`]).
    Half,
}

/// A series a sum reads: a row of the table, or coordinate c's q̈ (in the unrolled expansion).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Operand {
    Row(usize),
    Qdd(usize),
}

struct Gen<'a> {
    b: FunctionBuilder<'a>,
    table: Value,
    /// The row width, and w·8 (bytes).
    w: Ix,
    w8: Value,
    /// The order being computed, and 1/k.
    k: Ix,
    inv_k: Value,
    /// `lagrangian_conv`, imported, when convolutions with an index read at run time are calls
    /// of it; `None`: loops in the code.
    calls: Option<FuncRef>,
    /// The maths library's functions order 0 calls, imported ([`SeriesOp::libm`]).
    libm: Vec<(&'static str, FuncRef)>,
    /// Straight-line code (every index fixed, one block): each constant is made once, and an
    /// entry stored in the order at hand is read from the value stored, not from memory (the
    /// chain from qₖ through the recurrences and the solve to qₖ₊₁ then runs in registers, not
    /// through a store and a load at every step: measured 0.70–0.90× the time of a step).
    straight: bool,
    constants: HashMap<u64, Value>,
    memory: HashMap<(Value, i32), Value>,
    /// The unrolled expansion's coefficients of q̈ (coordinate c's order j at c·w + j).
    qdd: Option<Value>,
    /// The unrolled expansion's buffer of reversed series and their slots ([`Gen::mirror`]).
    reversed: Option<Value>,
    slots: HashMap<Operand, usize>,
    /// The series whose coefficients beyond 0 the unrolled expansion computes.
    computed: HashSet<Operand>,
    /// The weighted operands j aⱼ of this order's sums (a pair for two lanes, or one), by their
    /// place in the table: sin and cos of one argument both weigh its coefficients, once.
    weighted: HashMap<(Value, i32, bool), Value>,
    /// In the unrolled expansion, the rows whose coefficients are read at later orders: only
    /// those are stored at orders k ≥ 1 (the others are forwarded within their order).
    history: Option<HashSet<usize>>,
    /// In straight-line code, the values stored by the previous order and by this one, by
    /// place, and how many of them this order's two-lane reads have taken from the registers
    /// ([`Gen::pair`]).
    stored: [HashMap<(Value, i32), Value>; 2],
    carried: usize,
}

impl<'a> Gen<'a> {
    fn new(mut b: FunctionBuilder<'a>, table: Value, w: Ix, calls: Option<FuncRef>) -> Self {
        let w8 = match w {
            Ix::Fixed(w) => b.ins().iconst(types::I64, 8 * w as i64),
            Ix::Var(w) => b.ins().ishl_imm_s(w, 3),
        };
        let inv_k = b.ins().f64const(0.0);
        Self {
            b,
            table,
            w,
            w8,
            k: Ix::Fixed(0),
            inv_k,
            calls,
            libm: Vec::new(),
            straight: matches!(w, Ix::Fixed(_)),
            constants: HashMap::new(),
            memory: HashMap::new(),
            qdd: None,
            reversed: None,
            slots: HashMap::new(),
            computed: HashSet::new(),
            weighted: HashMap::new(),
            history: None,
            stored: [HashMap::new(), HashMap::new()],
            carried: 0,
        }
    }

    fn flags() -> MemFlagsData {
        MemFlagsData::trusted()
    }

    fn f64(&mut self, x: f64) -> Value {
        if !self.straight {
            return self.b.ins().f64const(x);
        }
        if let Some(&v) = self.constants.get(&x.to_bits()) {
            return v;
        }
        let v = self.b.ins().f64const(x);
        self.constants.insert(x.to_bits(), v);
        v
    }

    fn int(&mut self, i: Ix) -> Value {
        match i {
            Ix::Fixed(x) => self.b.ins().iconst(types::I64, x as i64),
            Ix::Var(v) => v,
        }
    }

    /// k − 1.
    fn km1(&mut self) -> Ix {
        match self.k {
            Ix::Fixed(k) => Ix::Fixed(k - 1),
            Ix::Var(k) => Ix::Var(self.b.ins().iadd_imm_s(k, -1)),
        }
    }

    /// The byte offset of entry `i` of an `f64` buffer (its bounds checked at compilation).
    fn offset(i: usize) -> i32 {
        i32::try_from(8 * i).expect("buffer sizes are checked before code is generated")
    }

    /// The address of row r's coefficient 0.
    fn row(&mut self, r: usize) -> Value {
        match self.w {
            Ix::Fixed(w) => self.b.ins().iadd_imm_s(self.table, 8 * (r * w) as i64),
            Ix::Var(_) => {
                let off = self.b.ins().imul_imm_s(self.w8, r as i64);
                self.b.ins().iadd(self.table, off)
            }
        }
    }

    /// Base and byte offset of row r's coefficient j.
    fn slot(&mut self, r: usize, j: Ix) -> (Value, i32) {
        match (self.w, j) {
            (Ix::Fixed(w), Ix::Fixed(j)) => (self.table, Self::offset(r * w + j)),
            (_, Ix::Fixed(j)) => (self.row(r), Self::offset(j)),
            (_, Ix::Var(j)) => {
                let base = self.row(r);
                let off = self.b.ins().ishl_imm_s(j, 3);
                (self.b.ins().iadd(base, off), 0)
            }
        }
    }

    /// Row r's coefficient j.
    fn load(&mut self, r: usize, j: Ix) -> Value {
        let (base, off) = self.slot(r, j);
        self.load_from(base, off)
    }

    fn store(&mut self, r: usize, j: Ix, v: Value) {
        if let Ix::Fixed(1..) = j {
            self.computed.insert(Operand::Row(r));
        }
        let (base, off) = self.slot(r, j);
        if let (Some(history), Ix::Fixed(1..)) = (&self.history, j)
            && !history.contains(&r)
        {
            self.memory.insert((base, off), v);
            return;
        }
        self.store_to(base, off, v);
        if let Ix::Fixed(j) = j {
            self.store_mirror(Operand::Row(r), j, v);
        }
    }

    /// Coordinate c's q̈ₖ, into the unrolled expansion's buffer (and its mirror).
    fn store_qdd(&mut self, c: usize, k: usize, v: Value) {
        let (Some(qdd), Ix::Fixed(w)) = (self.qdd, self.w) else {
            unreachable!("q̈ is stored by the unrolled expansion only")
        };
        self.store_at(qdd, c * w + k, v);
        self.store_mirror(Operand::Qdd(c), k, v);
    }

    /// Coefficient j of a series, in straight-line code.
    fn coefficient(&mut self, x: Operand, j: usize) -> Value {
        match (x, self.qdd, self.w) {
            (Operand::Row(r), ..) => self.load(r, Ix::Fixed(j)),
            (Operand::Qdd(c), Some(qdd), Ix::Fixed(w)) => self.load_at(qdd, c * w + j),
            (Operand::Qdd(_), ..) => unreachable!("q̈ is read by the unrolled expansion only"),
        }
    }

    /// Coefficient j of `x` into its mirror, if it has one.
    fn store_mirror(&mut self, x: Operand, j: usize, v: Value) {
        if let (Some(&slot), Some(reversed), Ix::Fixed(w)) =
            (self.slots.get(&x), self.reversed, self.w)
        {
            let at = Self::offset(slot * w + w - 1 - j);
            self.b.ins().store(Self::flags(), v, reversed, at);
            self.stored[1].insert((reversed, at), v);
        }
    }

    /// The slot of `x`'s mirror in the buffer of reversed series, coefficient j at slot·w + w −
    /// 1 − j: the second operand of a convolution, b in Σ aⱼ b_(kk − j), is read backwards, and
    /// its mirror forwards, two coefficients at a time like a's (a load of two lanes, not two
    /// loads and a shuffle). Made at the first sum that reads it, at order k: coefficients 0
    /// to k are copied then (the expansion runs every order every time, so it is there from
    /// order k on in every run), and every coefficient stored after is mirrored as it is.
    fn mirror(&mut self, x: Operand, k: usize) -> Option<(Value, usize)> {
        let reversed = self.reversed?;
        if let Some(&slot) = self.slots.get(&x) {
            return Some((reversed, slot));
        }
        let slot = self.slots.len();
        self.slots.insert(x, slot);
        for j in 0..=k {
            let v = self.coefficient(x, j);
            self.store_mirror(x, j, v);
        }
        Some((reversed, slot))
    }

    /// Σⱼ₌ₗₒ..ₕᵢ [j] aⱼ b_(kk − j) at order k with every index known at compilation, in the order
    /// of `conv` in `taylor.rs`: the terms that read no coefficient of order k in the lanes
    /// (four or more of them in two two-lane vectors, [`Gen::vector_lanes`]), then the j = 0 term
    /// reading b_k, then the j = k term reading a_k.
    fn sum(
        &mut self,
        a: Operand,
        b: Operand,
        lo: usize,
        hi: usize,
        kk: usize,
        weighted: bool,
    ) -> Value {
        let k = match self.k {
            Ix::Fixed(k) => k,
            Ix::Var(_) => unreachable!("sums with fixed indices are straight-line code"),
        };
        let (first, last) = fresh_ends(lo, hi, kk, k);
        let (from, to) = (
            lo + usize::from(first),
            (hi + 1).saturating_sub(usize::from(last)),
        );
        let count = to.saturating_sub(from);
        let mut sum = match (count >= LANES, a, self.mirror_if(b, count, k)) {
            (true, Operand::Row(a), Some((reversed, slot))) => {
                let w = self.fixed_width();
                let (table, weights) = (self.table, weighted.then_some(from));
                // b_(kk − j) at slot·w + w − 1 − (kk − j): ascending in j.
                let b_at = slot * w + w - 1 - (kk - from);
                self.vector_lanes((table, a * w + from), (reversed, b_at), count, weights)
            }
            _ => {
                let terms = (from..to)
                    .map(|j| self.term(a, b, j, kk, weighted))
                    .collect();
                self.lanes(terms)
            }
        };
        for j in [first.then_some(0), last.then_some(k)]
            .into_iter()
            .flatten()
        {
            let t = self.term(a, b, j, kk, weighted);
            sum = self.b.ins().fadd(sum, t);
        }
        sum
    }

    /// The mirror of `b` when a sum of `count` terms reads it in vectors.
    fn mirror_if(&mut self, b: Operand, count: usize, k: usize) -> Option<(Value, usize)> {
        if count >= LANES {
            self.mirror(b, k)
        } else {
            None
        }
    }

    /// The row width of straight-line code.
    fn fixed_width(&self) -> usize {
        match self.w {
            Ix::Fixed(w) => w,
            Ix::Var(_) => unreachable!("straight-line code knows the row width"),
        }
    }

    /// [j] aⱼ b_(kk − j), in straight-line code (1 · x is x, bit for bit).
    fn term(&mut self, a: Operand, b: Operand, j: usize, kk: usize, weighted: bool) -> Value {
        let key = match (a, self.w) {
            (Operand::Row(r), Ix::Fixed(w)) => Some((self.table, Self::offset(r * w + j), false)),
            _ => None,
        };
        let x = match key.and_then(|key| self.weighted.get(&key)) {
            Some(&x) if weighted && j != 1 => x,
            _ => {
                let x = self.coefficient(a, j);
                if weighted && j != 1 {
                    let jf = self.f64(j as f64);
                    let x = self.b.ins().fmul(jf, x);
                    if let Some(key) = key {
                        self.weighted.insert(key, x);
                    }
                    x
                } else {
                    x
                }
            }
        };
        let y = self.coefficient(b, kk - j);
        self.b.ins().fmul(x, y)
    }

    /// The sum of `count` ≥ 4 terms [j₀ + i] a[i] b[i] (entries i of two buffers read forwards
    /// from the given entries, `weights` = Some(j₀) for a weighted sum) in the lanes of
    /// [`Gen::lanes`]: lanes 0, 1 and lanes 2, 3 in two two-lane vectors (F64X2) through the
    /// groups of four, the rest into lane 0, then (l₀ + l₁) + (l₂ + l₃) — the same operations,
    /// two at a time.
    fn vector_lanes(
        &mut self,
        (a_base, a_at): (Value, usize),
        (b_base, b_at): (Value, usize),
        count: usize,
        weights: Option<usize>,
    ) -> Value {
        debug_assert!(count >= LANES);
        let zero = self.f64(0.0);
        let zeros = self.b.ins().splat(types::F64X2, zero);
        let mut pair = [zeros; 2];
        let full = count / LANES * LANES;
        for i in (0..full).step_by(2) {
            let key = (a_base, Self::offset(a_at + i), true);
            let x = match (weights, self.weighted.get(&key)) {
                (Some(_), Some(&x)) => x,
                _ => {
                    let x = self.pair(a_base, Self::offset(a_at + i));
                    match weights {
                        Some(j0) => {
                            let j = (j0 + i) as f64;
                            let bytes: Vec<u8> =
                                [j, j + 1.0].iter().flat_map(|x| x.to_le_bytes()).collect();
                            let c = self.b.func.dfg.constants.insert(bytes.into());
                            let j = self.b.ins().vconst(types::F64X2, c);
                            let x = self.b.ins().fmul(j, x);
                            self.weighted.insert(key, x);
                            x
                        }
                        None => x,
                    }
                }
            };
            let y = self.pair(b_base, Self::offset(b_at + i));
            let t = self.b.ins().fmul(x, y);
            let h = (i / 2) % 2;
            pair[h] = self.b.ins().fadd(pair[h], t);
        }
        let mut l = [
            self.b.ins().extractlane(pair[0], 0),
            self.b.ins().extractlane(pair[0], 1),
            self.b.ins().extractlane(pair[1], 0),
            self.b.ins().extractlane(pair[1], 1),
        ];
        for i in full..count {
            let x = self
                .b
                .ins()
                .load(types::F64, Self::flags(), a_base, Self::offset(a_at + i));
            let x = match weights {
                Some(j0) if j0 + i != 1 => {
                    let j = self.f64((j0 + i) as f64);
                    self.b.ins().fmul(j, x)
                }
                _ => x,
            };
            let y = self
                .b
                .ins()
                .load(types::F64, Self::flags(), b_base, Self::offset(b_at + i));
            let t = self.b.ins().fmul(x, y);
            l[0] = self.b.ins().fadd(l[0], t);
        }
        let low = self.b.ins().fadd(l[0], l[1]);
        let high = self.b.ins().fadd(l[2], l[3]);
        self.b.ins().fadd(low, high)
    }

    /// The two `f64` at byte `off` from `base`, as a two-lane vector: an unaligned load, or
    /// built in the registers when one of them was stored since the previous order's solve and
    /// this order's values so taken stay within [`CARRIED`].
    ///
    /// Why: the stores are of one `f64` each, and a load of two cannot be forwarded from them
    /// while they are on their way to the cache; it waits for them. Where an order is short (the
    /// ball in a sphere: a sine and cosine and a scaling) that wait was the step's critical
    /// path: measured at 1e-9, 242 against 197 ns per step taking them from the registers. More
    /// values carried from one order into the next cost spills: all of them ran the double
    /// pendulum 10 % slower (12 % more instructions); at most 4 cost Kepler's and the 4-link
    /// chain's steps about 2 %, and moved the double pendulum's and the forced two-mass's by
    /// less than the noise (±3 %).
    fn pair(&mut self, base: Value, off: i32) -> Value {
        let held = |g: &Self, o: i32| {
            g.stored[1]
                .get(&(base, o))
                .or_else(|| g.stored[0].get(&(base, o)))
                .copied()
        };
        let lanes = [held(self, off), held(self, off + 8)];
        let fresh = lanes.iter().flatten().count();
        if fresh == 0 || self.carried + fresh > CARRIED {
            // Unaligned.
            let flags = MemFlagsData::new().with_notrap();
            return self.b.ins().load(types::F64X2, flags, base, off);
        }
        self.carried += fresh;
        let [low, high] = [(lanes[0], off), (lanes[1], off + 8)].map(|(v, o)| {
            v.unwrap_or_else(|| self.b.ins().load(types::F64, Self::flags(), base, o))
        });
        let v = self.b.ins().scalar_to_vector(types::F64X2, low);
        self.b.ins().insertlane(v, high, 1)
    }

    /// Entry i of the buffer at `base`.
    fn load_at(&mut self, base: Value, i: usize) -> Value {
        self.load_from(base, Self::offset(i))
    }

    fn store_at(&mut self, base: Value, i: usize, v: Value) {
        self.store_to(base, Self::offset(i), v);
    }

    /// The `f64` at byte `off` from `base`: in straight-line code, the value stored there
    /// since `memory` was last cleared, if any (the buffers do not overlap, and nothing else
    /// writes them while the code runs).
    fn load_from(&mut self, base: Value, off: i32) -> Value {
        match self.memory.get(&(base, off)) {
            Some(&v) => v,
            None => self.b.ins().load(types::F64, Self::flags(), base, off),
        }
    }

    fn store_to(&mut self, base: Value, off: i32, v: Value) {
        self.b.ins().store(Self::flags(), v, base, off);
        if self.straight {
            self.memory.insert((base, off), v);
            self.stored[1].insert((base, off), v);
        }
    }

    /// The end of the unrolled expansion: the status [`KernelStatus::Coefficient`] when `check` (the
    /// sum of q̈ₖ − q̈ₖ) is not 0, else [`KernelStatus::Expanded`] without a step control (a null
    /// `control`), else the step `Expansion::step` takes, with its operations in its order:
    /// the norms of `Expansion::norms`, Jorba and Zou's step size, the floor and the end of the
    /// span, then `Expansion::advance` from y into `y_new` and `lost`.
    fn finish_step(
        &mut self,
        check: Value,
        [control, yp, lostp, newp]: [Value; 4],
        (qp, vp): (Value, Value),
        n: usize,
        order: usize,
    ) {
        use std::mem::offset_of;
        let status = |g: &mut Self, s: KernelStatus| g.b.ins().iconst(types::I32, s as i64);
        let done = self.b.create_block();
        self.b.append_block_param(done, types::I32);
        // A coefficient that is not finite, or the expansion alone.
        let finite = self.b.ins().fcmp(condcodes::FloatCC::Equal, check, check);
        let (expanded, stepping) = (self.b.create_block(), self.b.create_block());
        let failed = status(self, KernelStatus::Coefficient);
        self.b
            .ins()
            .brif(finite, expanded, &[], done, &[BlockArg::Value(failed)]);
        self.b.switch_to_block(expanded);
        self.b.seal_block(expanded);
        let alone = status(self, KernelStatus::Expanded);
        self.b
            .ins()
            .brif(control, stepping, &[], done, &[BlockArg::Value(alone)]);
        self.b.switch_to_block(stepping);
        self.b.seal_block(stepping);
        let field = |offset: usize| Self::offset(offset / 8);
        let get = |g: &mut Self, offset: usize| g.load_from(control, field(offset));
        let t = get(self, offset_of!(StepControl, t));
        let rtol = get(self, offset_of!(StepControl, rule.rtol));
        let atol = get(self, offset_of!(StepControl, rule.atol));
        let h_max = get(self, offset_of!(StepControl, rule.h_max));
        let min_step = get(self, offset_of!(StepControl, rule.min_step));
        let t_end = get(self, offset_of!(StepControl, rule.t_end));
        let dir = get(self, offset_of!(StepControl, rule.dir));
        // The norms: each component's coefficients p − 1 and p over its tolerance.
        let eps = self.min(rtol, atol);
        let zero = self.f64(0.0);
        let (mut below, mut top) = (zero, zero);
        for (half, base) in [(0, qp), (1, vp)] {
            for i in 0..n {
                let y = self.load_at(yp, half * n + i);
                let y = self.b.ins().fabs(y);
                let d = self.b.ins().fmul(rtol, y);
                let d = self.b.ins().fadd(atol, d);
                let scale = self.b.ins().fdiv(eps, d);
                for (k, norm) in [(order - 1, &mut below), (order, &mut top)] {
                    let x = self.load_at(base, k * n + i);
                    let x = self.b.ins().fabs(x);
                    let x = self.b.ins().fmul(x, scale);
                    *norm = self.max(*norm, x);
                }
            }
        }
        // h = exp(min(−ln ‖xₚ₋₁‖ / (p − 1), −ln ‖xₚ‖ / p) − 2 − 0.7 / (p − 1)), at most h_max.
        let (p1, p) = ((order - 1) as f64, order as f64);
        let rho = [(below, p1), (top, p)].map(|(norm, d)| {
            let ln = self.call("lagrangian_ln", &[norm]);
            let ln = self.b.ins().fneg(ln);
            let d = self.f64(d);
            self.b.ins().fdiv(ln, d)
        });
        let ln_rho = self.min(rho[0], rho[1]);
        let two = self.f64(2.0);
        let x = self.b.ins().fsub(ln_rho, two);
        let c = self.f64(0.7 / p1);
        let x = self.b.ins().fsub(x, c);
        let h = self.call("lagrangian_exp", &[x]);
        let h = self.min(h, h_max);
        // Above the floor max(min_step, 10 ε |t|), or refused.
        let tiny = self.f64(10.0 * f64::EPSILON);
        let at = self.b.ins().fabs(t);
        let at = self.b.ins().fmul(tiny, at);
        let floor = self.max(min_step, at);
        let above = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, h, floor);
        let (ahead, refused) = (self.b.create_block(), self.b.create_block());
        self.b.ins().brif(above, ahead, &[], refused, &[]);
        self.b.switch_to_block(refused);
        self.b.seal_block(refused);
        let at_h = field(offset_of!(StepControl, h));
        self.b.ins().store(Self::flags(), h, control, at_h);
        let s = status(self, KernelStatus::TooSmall);
        self.b.ins().jump(done, &[BlockArg::Value(s)]);
        self.b.switch_to_block(ahead);
        self.b.seal_block(ahead);
        // The last step ends on t_end: (t + dir 1.01 h − t_end) dir ≥ 0.
        let onward = self.f64(1.01);
        let x = self.b.ins().fmul(dir, onward);
        let x = self.b.ins().fmul(x, h);
        let x = self.b.ins().fadd(t, x);
        let x = self.b.ins().fsub(x, t_end);
        let x = self.b.ins().fmul(x, dir);
        let last = self
            .b
            .ins()
            .fcmp(condcodes::FloatCC::GreaterThanOrEqual, x, zero);
        let x = self.b.ins().fmul(dir, h);
        let x = self.b.ins().fadd(t, x);
        let t_new = self.b.ins().select(last, t_end, x);
        let at_t_new = field(offset_of!(StepControl, t_new));
        self.b.ins().store(Self::flags(), t_new, control, at_t_new);
        let h = self.b.ins().fsub(t_new, t);
        // y + Σₖ₌₁..ₚ (q, q̇)ₖ hᵏ, the 2n sums of Horner's rule side by side, with Kahan's
        // compensation; Σ (yᵢ − yᵢ) is 0 when every new value is finite.
        let components: Vec<(Value, usize)> = (0..n)
            .map(|i| (qp, i))
            .chain((0..n).map(|i| (vp, i)))
            .collect();
        let mut sums: Vec<Value> = components
            .iter()
            .map(|&(base, i)| self.load_at(base, order * n + i))
            .collect();
        for k in (1..order).rev() {
            for (sum, &(base, i)) in sums.iter_mut().zip(&components) {
                let c = self.load_at(base, k * n + i);
                let x = self.b.ins().fmul(*sum, h);
                *sum = self.b.ins().fadd(x, c);
            }
        }
        let mut check = zero;
        for (j, sum) in sums.into_iter().enumerate() {
            let increment = self.b.ins().fmul(sum, h);
            let (y, lost) = (self.load_at(yp, j), self.load_at(lostp, j));
            let increment = self.b.ins().fsub(increment, lost);
            let new = self.b.ins().fadd(y, increment);
            let moved = self.b.ins().fsub(new, y);
            let lost = self.b.ins().fsub(moved, increment);
            self.store_at(newp, j, new);
            self.store_at(lostp, j, lost);
            let nothing = self.b.ins().fsub(new, new);
            check = self.b.ins().fadd(check, nothing);
        }
        let finite = self.b.ins().fcmp(condcodes::FloatCC::Equal, check, check);
        let (step, last_step, state) = (
            status(self, KernelStatus::Step),
            status(self, KernelStatus::Last),
            status(self, KernelStatus::State),
        );
        let taken = self.b.ins().select(last, last_step, step);
        let s = self.b.ins().select(finite, taken, state);
        self.b.ins().jump(done, &[BlockArg::Value(s)]);
        self.b.switch_to_block(done);
        self.b.seal_block(done);
        let s = self.b.block_params(done)[0];
        self.b.ins().return_(&[s]);
    }

    /// `f64::min(a, b)` for a and b that are not NaN: b where b < a, else a.
    fn min(&mut self, a: Value, b: Value) -> Value {
        let less = self.b.ins().fcmp(condcodes::FloatCC::LessThan, b, a);
        self.b.ins().select(less, b, a)
    }

    /// `f64::max(m, x)` for an m that is not NaN: x where x > m, else m (so a NaN x is passed
    /// over, as `f64::max` passes it over).
    fn max(&mut self, m: Value, x: Value) -> Value {
        let greater = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, x, m);
        self.b.ins().select(greater, x, m)
    }

    /// Row r's coefficient k, and its coefficient 0.
    fn at_k(&mut self, r: usize) -> Value {
        let k = self.k;
        self.load(r, k)
    }

    fn at0(&mut self, r: usize) -> Value {
        self.load(r, Ix::Fixed(0))
    }

    fn store_k(&mut self, r: usize, v: Value) {
        let k = self.k;
        self.store(r, k, v);
    }

    /// The sum of `terms` in the lanes and order of `conv` in `taylor.rs` (and of
    /// `linalg::dot`): term i into lane i mod 4 while four are left, the rest into lane 0, then
    /// (l₀ + l₁) + (l₂ + l₃), each lane from +0. A lane no term reached stays +0 and is left
    /// out of the last sums: a lane that did start from +0 is never −0 (a sum is −0 only when
    /// both terms are), so adding +0 to it changes no bit.
    fn lanes(&mut self, terms: Vec<Value>) -> Value {
        let zero = self.f64(0.0);
        let mut l: [Option<Value>; LANES] = [None; LANES];
        let full = terms.len() / LANES * LANES;
        for (i, &t) in terms.iter().enumerate() {
            let lane = if i < full { i % LANES } else { 0 };
            let sum = l[lane].unwrap_or(zero);
            l[lane] = Some(self.b.ins().fadd(sum, t));
        }
        let mut add = |x: Option<Value>, y: Option<Value>| match (x, y) {
            (Some(x), Some(y)) => Some(self.b.ins().fadd(x, y)),
            (x, None) => x,
            (None, y) => y,
        };
        let low = add(l[0], l[1]);
        let high = add(l[2], l[3]);
        add(low, high).unwrap_or(zero)
    }

    /// Σⱼ₌ₗₒ..ₕᵢ [j] aⱼ b_(kk − j) of rows a and b, hi given by `top`, as `conv` in `taylor.rs`
    /// sums it: straight-line code when the order is known at compilation ([`Gen::sum`]); else
    /// a call of `lagrangian_conv` (large programs), or the terms that read no coefficient of
    /// order k in a loop in the code and then the others.
    fn conv(&mut self, a: usize, b: usize, lo: usize, top: Top, kk: Ix, weighted: bool) -> Value {
        if let (Ix::Fixed(k), Ix::Fixed(kk)) = (self.k, kk) {
            let hi = match top {
                Top::K => k,
                Top::Below => k - 1,
                Top::Degree(d) => d.min(k),
                Top::BelowDegree(d) => d.min(k - 1),
                Top::Half => (k - 1) / 2,
            };
            return self.sum(Operand::Row(a), Operand::Row(b), lo, hi, kk, weighted);
        }
        let Ix::Var(k) = self.k else {
            unreachable!("a run-time index belongs to code for any order")
        };
        let kkv = self.int(kk);
        if let Some(conv_fn) = self.calls {
            let hi = match top {
                Top::K => k,
                Top::Below => self.b.ins().iadd_imm_s(k, -1),
                Top::Degree(d) => {
                    let d = self.b.ins().iconst(types::I64, d as i64);
                    self.b.ins().umin(k, d)
                }
                Top::BelowDegree(d) => {
                    let km1 = self.b.ins().iadd_imm_s(k, -1);
                    let d = self.b.ins().iconst(types::I64, d as i64);
                    self.b.ins().umin(km1, d)
                }
                Top::Half => {
                    let km1 = self.b.ins().iadd_imm_s(k, -1);
                    self.b.ins().ushr_imm_s(km1, 1)
                }
            };
            let (pa, pb) = (self.row(a), self.row(b));
            let lo = self.b.ins().iconst(types::I64, lo as i64);
            let weighted = self.b.ins().iconst(types::I32, i64::from(weighted));
            let call = self
                .b
                .ins()
                .call(conv_fn, &[pa, pb, lo, hi, kkv, k, weighted]);
            return self.b.inst_results(call)[0];
        }
        // Orders k ≥ 1 here: the j = 0 term of a sum from 0 with kk = k reads b_k, and the
        // j = k term of a sum up to k reads a_k.
        debug_assert!(lo > 0 || !weighted);
        let first = lo == 0 && kk == self.k;
        let km1 = self.b.ins().iadd_imm_s(k, -1);
        let old_hi = match top {
            Top::K | Top::Below => km1,
            Top::Degree(d) | Top::BelowDegree(d) => {
                let d = self.b.ins().iconst(types::I64, d as i64);
                self.b.ins().umin(km1, d)
            }
            // Below k for k ≥ 1: no term of it reads order k but j = 0's.
            Top::Half => self.b.ins().ushr_imm_s(km1, 1),
        };
        let from = lo as i64 + i64::from(first);
        let mut sum = self.conv_loop(a, b, from, old_hi, kkv, weighted);
        if first {
            let (x, y) = (self.at0(a), self.load(b, kk));
            let t = self.b.ins().fmul(x, y);
            sum = self.b.ins().fadd(sum, t);
        }
        if let Top::K | Top::Degree(_) = top {
            debug_assert!(kk == self.k);
            let x = self.at_k(a);
            let x = if weighted {
                let kf = self.b.ins().fcvt_from_sint(types::F64, k);
                self.b.ins().fmul(kf, x)
            } else {
                x
            };
            let y = self.at0(b);
            let t = self.b.ins().fmul(x, y);
            let with = self.b.ins().fadd(sum, t);
            sum = match top {
                Top::Degree(d) => {
                    let reached = self.b.ins().icmp_imm_s(
                        condcodes::IntCC::UnsignedLessThanOrEqual,
                        k,
                        d as i64,
                    );
                    self.b.ins().select(reached, with, sum)
                }
                _ => with,
            };
        }
        sum
    }

    /// Σⱼ₌ₗₒ..ₕᵢ [j] aⱼ b_(kk − j) in the lanes and order of [`conv`](super::taylor): a loop
    /// over four terms at a time, then one at a time into lane 0, each block carrying (count,
    /// &aⱼ, &b_(kk−j), j as a float, the lanes).
    fn conv_loop(
        &mut self,
        a: usize,
        b: usize,
        lo: i64,
        hi: Value,
        kk: Value,
        weighted: bool,
    ) -> Value {
        let (pa, pb) = (self.row(a), self.row(b));
        let pa = self.b.ins().iadd_imm_s(pa, 8 * lo);
        let kk8 = self.b.ins().ishl_imm_s(kk, 3);
        let pb = self.b.ins().iadd(pb, kk8);
        let pb = self.b.ins().iadd_imm_s(pb, -8 * lo);
        let count = self.b.ins().iadd_imm_s(hi, 1 - lo);
        let zero = self.f64(0.0);
        let jf = self.f64(lo as f64);
        let blocks = [(); 4].map(|_| self.b.create_block());
        let [quad, quad_body, single, single_body] = blocks;
        for block in blocks {
            for t in [types::I64, types::I64, types::I64, types::F64] {
                self.b.append_block_param(block, t);
            }
            for _ in 0..LANES {
                self.b.append_block_param(block, types::F64);
            }
        }
        let exit = self.b.create_block();
        for _ in 0..LANES {
            self.b.append_block_param(exit, types::F64);
        }
        let args = |v: &[Value]| v.iter().map(|&x| BlockArg::Value(x)).collect::<Vec<_>>();
        let start = [count, pa, pb, jf, zero, zero, zero, zero];
        self.b.ins().jump(quad, &args(&start));
        // Four terms at a time while four are left.
        self.b.switch_to_block(quad);
        let p = self.b.block_params(quad).to_vec();
        let more = self.b.ins().icmp_imm_s(
            condcodes::IntCC::SignedGreaterThanOrEqual,
            p[0],
            LANES as i64,
        );
        self.b
            .ins()
            .brif(more, quad_body, &args(&p), single, &args(&p));
        self.b.switch_to_block(quad_body);
        self.b.seal_block(quad_body);
        let mut p = self.b.block_params(quad_body).to_vec();
        for i in 0..LANES {
            let t = self.loop_term(p[1], p[2], p[3], i as i64, weighted);
            p[4 + i] = self.b.ins().fadd(p[4 + i], t);
        }
        p[0] = self.b.ins().iadd_imm_s(p[0], -(LANES as i64));
        p[1] = self.b.ins().iadd_imm_s(p[1], 8 * LANES as i64);
        p[2] = self.b.ins().iadd_imm_s(p[2], -8 * LANES as i64);
        let step = self.f64(LANES as f64);
        p[3] = self.b.ins().fadd(p[3], step);
        self.b.ins().jump(quad, &args(&p));
        self.b.seal_block(quad);
        // The rest one at a time, into lane 0.
        self.b.switch_to_block(single);
        let p = self.b.block_params(single).to_vec();
        let more = self
            .b
            .ins()
            .icmp_imm_s(condcodes::IntCC::SignedGreaterThan, p[0], 0);
        self.b
            .ins()
            .brif(more, single_body, &args(&p), exit, &args(&p[4..]));
        self.b.switch_to_block(single_body);
        self.b.seal_block(single_body);
        let mut p = self.b.block_params(single_body).to_vec();
        let t = self.loop_term(p[1], p[2], p[3], 0, weighted);
        p[4] = self.b.ins().fadd(p[4], t);
        p[0] = self.b.ins().iadd_imm_s(p[0], -1);
        p[1] = self.b.ins().iadd_imm_s(p[1], 8);
        p[2] = self.b.ins().iadd_imm_s(p[2], -8);
        let one = self.f64(1.0);
        p[3] = self.b.ins().fadd(p[3], one);
        self.b.ins().jump(single, &args(&p));
        self.b.seal_block(single);
        self.b.switch_to_block(exit);
        self.b.seal_block(exit);
        let l = self.b.block_params(exit).to_vec();
        let low = self.b.ins().fadd(l[0], l[1]);
        let high = self.b.ins().fadd(l[2], l[3]);
        self.b.ins().fadd(low, high)
    }

    /// A square's coefficient k from twice its half sum ([`SeriesOp::Square`]): plus a²ₖ/₂ where k is
    /// even.
    fn square_middle(&mut self, a: usize, twice: Value) -> Value {
        match self.k {
            Ix::Fixed(k) if k.is_multiple_of(2) => {
                let mid = self.load(a, Ix::Fixed(k / 2));
                let sq = self.b.ins().fmul(mid, mid);
                self.b.ins().fadd(twice, sq)
            }
            Ix::Fixed(_) => twice,
            Ix::Var(k) => {
                let m = self.b.ins().ushr_imm_s(k, 1);
                let mid = self.load(a, Ix::Var(m));
                let sq = self.b.ins().fmul(mid, mid);
                let with = self.b.ins().fadd(twice, sq);
                let odd = self.b.ins().band_imm_s(k, 1);
                self.b.ins().select(odd, twice, with)
            }
        }
    }

    /// Term j + i of a convolution: [(j + i)] a_(j+i) b_(kk−j−i), with `pa` at aⱼ, `pb` at
    /// b_(kk−j) and `jf` = j.
    fn loop_term(&mut self, pa: Value, pb: Value, jf: Value, i: i64, weighted: bool) -> Value {
        let x = self
            .b
            .ins()
            .load(types::F64, Self::flags(), pa, (8 * i) as i32);
        let x = if weighted {
            let di = self.f64(i as f64);
            let j = if i == 0 {
                jf
            } else {
                self.b.ins().fadd(jf, di)
            };
            self.b.ins().fmul(j, x)
        } else {
            x
        };
        let y = self
            .b
            .ins()
            .load(types::F64, Self::flags(), pb, (-8 * i) as i32);
        self.b.ins().fmul(x, y)
    }

    /// Call the imported maths function `name` on `args`.
    fn call(&mut self, name: &str, args: &[Value]) -> Value {
        let f = self
            .libm
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, f)| f)
            .expect("order 0's functions are imported before its code is generated");
        let call = self.b.ins().call(f, args);
        self.b.inst_results(call)[0]
    }

    /// Coefficient 0 of `op`'s rows, as [`SeriesOp::apply`] computes it for k = 0; `ptr` is the
    /// pointer type.
    fn op0(&mut self, op: &SeriesOp, ptr: types::Type) {
        self.k = Ix::Fixed(0);
        let unary = |g: &mut Self, out: usize, a: usize, name: &str| {
            let x = g.at0(a);
            let y = g.call(name, &[x]);
            g.store_k(out, y);
        };
        match *op {
            SeriesOp::Recip { out, b } => {
                let (one, x) = (self.f64(1.0), self.at0(b));
                let y = self.b.ins().fdiv(one, x);
                self.store_k(out, y);
            }
            SeriesOp::Exp { out, a } => unary(self, out, a, "lagrangian_exp"),
            SeriesOp::Ln { out, a } => unary(self, out, a, "lagrangian_ln"),
            SeriesOp::Sqrt { out, a } => {
                let x = self.at0(a);
                let y = self.b.ins().sqrt(x);
                self.store_k(out, y);
            }
            SeriesOp::SinCos {
                s,
                c,
                a,
                hyperbolic: true,
                ..
            } => {
                unary(self, s, a, "lagrangian_sinh");
                unary(self, c, a, "lagrangian_cosh");
            }
            SeriesOp::SinCos { s, c, a, .. } => {
                // One call: the cosine comes back through an 8-byte slot of the frame.
                let slot = self.b.create_sized_stack_slot(StackSlotData::new(
                    StackSlotKind::ExplicitSlot,
                    8,
                    3,
                ));
                let addr = self.b.ins().stack_addr(ptr, slot, 0);
                let x = self.at0(a);
                let sv = self.call("lagrangian_sin_cos", &[x, addr]);
                let cv = self.b.ins().stack_load(ptr, types::F64, slot, 0);
                self.store_k(s, sv);
                self.store_k(c, cv);
            }
            SeriesOp::Tan {
                out,
                w,
                a,
                hyperbolic,
            } => {
                let name = if hyperbolic {
                    "lagrangian_tanh"
                } else {
                    "lagrangian_tan"
                };
                unary(self, out, a, name);
                let sq = self.conv(out, out, 0, Top::K, Ix::Fixed(0), false);
                let sq = if hyperbolic {
                    self.b.ins().fneg(sq)
                } else {
                    sq
                };
                let one = self.f64(1.0);
                let wv = self.b.ins().fadd(one, sq);
                self.store_k(w, wv);
            }
            SeriesOp::Abs { out, a } => {
                let x = self.at0(a);
                let y = self.b.ins().fabs(x);
                self.store_k(out, y);
            }
            SeriesOp::Sign { out, a } => {
                // 1 for a > 0, −1 otherwise (NaN included), as `graph::sign`.
                let x = self.at0(a);
                let zero = self.f64(0.0);
                let positive = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, x, zero);
                let (one, minus_one) = (self.f64(1.0), self.f64(-1.0));
                let y = self.b.ins().select(positive, one, minus_one);
                self.store_k(out, y);
            }
            SeriesOp::Atan2 { out, y, x, d, .. } => {
                let xx = self.conv(x, x, 0, Top::K, Ix::Fixed(0), false);
                let yy = self.conv(y, y, 0, Top::K, Ix::Fixed(0), false);
                let d0 = self.b.ins().fadd(xx, yy);
                self.store_k(d, d0);
                let (y0, x0) = (self.at0(y), self.at0(x));
                let theta = self.call("lagrangian_atan2", &[y0, x0]);
                self.store_k(out, theta);
            }
            // The same formula at every order.
            SeriesOp::Copy { .. }
            | SeriesOp::Neg { .. }
            | SeriesOp::Add { .. }
            | SeriesOp::Sub { .. }
            | SeriesOp::Scale { .. }
            | SeriesOp::Mul { .. }
            | SeriesOp::Square { .. }
            | SeriesOp::DivC { .. }
            | SeriesOp::Div { .. } => self.op(op),
        }
    }

    /// Coefficient k of `op`'s rows, as [`SeriesOp::apply`] computes it for k ≥ 1.
    fn op(&mut self, op: &SeriesOp) {
        let (k, inv_k) = (self.k, self.inv_k);
        let (out, value) = match *op {
            SeriesOp::Copy { out, a } => (out, self.at_k(a)),
            SeriesOp::Neg { out, a } => {
                let x = self.at_k(a);
                (out, self.b.ins().fneg(x))
            }
            SeriesOp::Add { out, a, b } => {
                let (x, y) = (self.at_k(a), self.at_k(b));
                (out, self.b.ins().fadd(x, y))
            }
            SeriesOp::Sub { out, a, b } => {
                let (x, y) = (self.at_k(a), self.at_k(b));
                (out, self.b.ins().fsub(x, y))
            }
            SeriesOp::Scale { out, a, c } => {
                let (x, y) = (self.at_k(a), self.at0(c));
                (out, self.b.ins().fmul(x, y))
            }
            SeriesOp::Mul { out, a, b } => (out, self.conv(a, b, 0, Top::K, k, false)),
            SeriesOp::Square { out, a } if k == Ix::Fixed(0) => {
                (out, self.conv(a, a, 0, Top::K, k, false))
            }
            SeriesOp::Square { out, a } => {
                let half = self.conv(a, a, 0, Top::Half, k, false);
                let twice = self.b.ins().fadd(half, half);
                (out, self.square_middle(a, twice))
            }
            SeriesOp::DivC { out, a, c } => {
                let (x, y) = (self.at_k(a), self.at0(c));
                (out, self.b.ins().fdiv(x, y))
            }
            SeriesOp::Div { out, a, b } => {
                let x = self.at_k(a);
                let s = self.conv(b, out, 1, Top::K, k, false);
                let n = self.b.ins().fsub(x, s);
                let d = self.at0(b);
                (out, self.b.ins().fdiv(n, d))
            }
            SeriesOp::Recip { out, b } => {
                let s = self.conv(b, out, 1, Top::K, k, false);
                let n = self.b.ins().fneg(s);
                let d = self.at0(b);
                (out, self.b.ins().fdiv(n, d))
            }
            SeriesOp::Exp { out, a } => {
                let s = self.conv(a, out, 1, Top::K, k, true);
                (out, self.b.ins().fmul(s, inv_k))
            }
            SeriesOp::Ln { out, a } => {
                let s = self.conv(out, a, 1, Top::Below, k, true);
                let s = self.b.ins().fmul(s, inv_k);
                let x = self.at_k(a);
                let n = self.b.ins().fsub(x, s);
                let d = self.at0(a);
                (out, self.b.ins().fdiv(n, d))
            }
            SeriesOp::Sqrt { out, a } => {
                let s = self.conv(out, out, 1, Top::Below, k, false);
                let x = self.at_k(a);
                let n = self.b.ins().fsub(x, s);
                let two = self.f64(2.0);
                let r0 = self.at0(out);
                let d = self.b.ins().fmul(two, r0);
                (out, self.b.ins().fdiv(n, d))
            }
            SeriesOp::SinCos {
                s,
                c,
                a,
                hyperbolic,
                degree,
                da,
            } => {
                // j ≤ min(k, degree): a polynomial argument's series ends at its degree; with a′
                // a row, Σₘ₌₀..ₖ₋₁ a′ₘ cₖ₋₁₋ₘ (up to its degree, one less).
                let (sv, cv) = match da {
                    Some(da) => {
                        let top = degree.map_or(Top::Below, |d| Top::BelowDegree(d - 1));
                        let km1 = self.km1();
                        (
                            self.conv(da, c, 0, top, km1, false),
                            self.conv(da, s, 0, top, km1, false),
                        )
                    }
                    None => {
                        let top = degree.map_or(Top::K, Top::Degree);
                        (
                            self.conv(a, c, 1, top, k, true),
                            self.conv(a, s, 1, top, k, true),
                        )
                    }
                };
                let sv = self.b.ins().fmul(sv, inv_k);
                // −(x · 1/k) is x · (−1/k), bit for bit: where k is a constant, one product
                // (a negation is a sign mask made in a register, three instructions).
                let cv = match (hyperbolic, self.k) {
                    (true, _) => self.b.ins().fmul(cv, inv_k),
                    (false, Ix::Fixed(k)) => {
                        let c = self.f64(-1.0 / k as f64);
                        self.b.ins().fmul(cv, c)
                    }
                    (false, _) => {
                        let cv = self.b.ins().fmul(cv, inv_k);
                        self.b.ins().fneg(cv)
                    }
                };
                self.store_k(s, sv);
                (c, cv)
            }
            SeriesOp::Tan {
                out,
                w,
                a,
                hyperbolic,
            } => {
                let t = self.conv(a, w, 1, Top::K, k, true);
                let t = self.b.ins().fmul(t, inv_k);
                self.store_k(out, t);
                let sq = self.conv(out, out, 0, Top::K, k, false);
                let sq = if hyperbolic {
                    self.b.ins().fneg(sq)
                } else {
                    sq
                };
                (w, sq)
            }
            SeriesOp::Abs { out, a } => {
                let x = self.at_k(a);
                let x0 = self.at0(a);
                let zero = self.f64(0.0);
                let positive = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, x0, zero);
                let m = self.b.ins().fneg(x);
                (out, self.b.ins().select(positive, x, m))
            }
            SeriesOp::Sign { out, .. } => (out, self.f64(0.0)),
            SeriesOp::Atan2 { out, y, x, d, r } => {
                let xx = self.conv(x, x, 0, Top::K, k, false);
                let yy = self.conv(y, y, 0, Top::K, k, false);
                let dk = self.b.ins().fadd(xx, yy);
                self.store_k(d, dk);
                let yx = self.conv(y, x, 1, Top::K, k, true);
                let xy = self.conv(x, y, 1, Top::K, k, true);
                let n = self.b.ins().fsub(yx, xy);
                let km1 = self.km1();
                let dr = self.conv(d, r, 1, Top::Below, km1, false);
                let n = self.b.ins().fsub(n, dr);
                let d0 = self.at0(d);
                let rk = self.b.ins().fdiv(n, d0);
                self.store(r, km1, rk);
                (out, self.b.ins().fmul(rk, inv_k))
            }
        };
        self.store_k(out, value);
    }
}
