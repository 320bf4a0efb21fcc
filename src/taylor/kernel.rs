//! The Taylor recurrences ([`SeriesOp`]) as machine code (feature `jit`), in two forms.
//!
//! - [`ExpansionKernel`]: for a small program, the whole expansion to one order p — every
//!   order's recurrences, fₖ − Σⱼ Mⱼ q̈ₖ₋ⱼ, the solve with M₀ and the coefficients of q and q̇
//!   — and the Taylor step from it, as straight-line code with every index a constant, its sums
//!   in two-lane vectors, compiled once per order a run asks for.
//! - [`SeriesKernel`]: for any program, coefficient k ≥ 1 of every row that varies, for any
//!   order k and row width w given at the call. Each convolution is a loop in the code (small
//!   programs) or a call of the interpreter's own sum (large ones, [`INLINE_UP_TO`]), so the
//!   code grows with the graph and not with the order. For a small program the functions are
//!   order 0 and a whole order of the expansion (the recurrences, fₖ − Σⱼ Mⱼ q̈ₖ₋ⱼ, the solve
//!   with M₀, the coefficients of q and q̇): a model's first runs, before its
//!   [`ExpansionKernel`].
//!
//! The operations and their order are those of [`SeriesOp::apply`] and `Expansion::expand` (the same
//! four lanes per sum, no fused multiply–add), so the coefficients are bit-identical to the
//! interpreter's, which stays the fallback and the reference. Safety by construction: every row
//! an operation reads or writes is checked against the table's row count before any code is
//! emitted, and the kernels' `run` check the buffers' lengths, the width and the order.

use super::abi::{Buffers, KernelStatus, StepArgs, StepControl};
use super::emit::{Ix, Operand, SeriesEmitter};
use super::lower::Recurrences;
use super::series::SeriesOp;
use crate::native::{BACKTRACKING_UP_TO, Code, declare, enter, fail, jit_module, link};

use crate::error::Result;
use cranelift_codegen::ir::{AbiParam, BlockArg, FuncRef, InstBuilder, Value, condcodes, types};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::{Linkage, Module};
use std::collections::HashSet;

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

/// The compiled order ([`SeriesKernel::order`]): order k, row width w, the table, the
/// coefficients of q and of q̇ (order k of coordinate i at k·n + i), of q̈ (at i·w + k), M₀
/// factored.
type OrderEntry =
    unsafe extern "C" fn(i64, i64, *mut f64, *mut f64, *mut f64, *mut f64, *const f64);

/// A [`SeriesKernel`]'s order 0 ([`SeriesKernel::order0`]): row width w, the table, q₀, q̇₀.
type SeriesOrder0Entry = unsafe extern "C" fn(i64, *mut f64, *const f64, *const f64);

/// A small program's [`SeriesKernel`]: its order k and its order 0.
type WholeOrders = (OrderEntry, SeriesOrder0Entry);

/// The recurrences of one [`Recurrences`](super::Recurrences) as machine code, and for a small
/// program the whole of an order of the expansion around them.
pub(crate) struct SeriesKernel {
    /// The recurrences alone, or (small programs) the whole order around them: one of the two.
    code: Code<(Option<Entry>, Option<WholeOrders>)>,
    rows: usize,
    dof: usize,
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
    pub(crate) fn compile(program: &Recurrences) -> Result<Self> {
        let (ops, rows, n) = (&program.varying, program.rows, program.dof);
        if let Some(r) = ops.iter().flat_map(rows_of).find(|&r| r >= rows) {
            return Err(fail(format!("row {r} of a table of {rows}")));
        }
        // About twenty instructions per recurrence with its loops, four with calls.
        let inline = ops.len() <= INLINE_UP_TO;
        let module = jit_module(
            if inline { 20 } else { 4 } * ops.len() <= BACKTRACKING_UP_TO,
            &symbols(),
        )?;
        // The whole order in the code where the recurrences' sums are loops in it (the Rust
        // around each order's call was as long as the call: perf, the double pendulum), in
        // place of the recurrences alone (compiling both took half as long again).
        let read = (program.force.iter().chain(&program.mass_full))
            .chain(program.coords.iter().chain(&program.velocities).flatten());
        let fused = inline
            && read.copied().all(|r| r < rows)
            && program.order0.iter().flat_map(rows_of).all(|r| r < rows)
            && i32::try_from(8 * (n * n).max(2 * n + 2)).is_ok();
        let code = Code::new(module, |m| {
            if fused {
                let order = define_order(m, program)?;
                Ok((None, Some((order, define_series_order0(m, program)?))))
            } else {
                Ok((Some(define(m, ops, inline)?), None))
            }
        })?;
        Ok(Self { code, rows, dof: n })
    }

    /// Whether [`SeriesKernel::order`] runs (a small program's), and not
    /// [`SeriesKernel::run`].
    pub(crate) fn whole_orders(&self) -> bool {
        self.code.entry().1.is_some()
    }

    /// Order 0 of every row the state sets, from q₀ and q̇₀, as `Expansion::order0` computes
    /// it (`s` holds t₀ in t's row and the rows fixed by the parameters).
    ///
    /// # Panics
    /// If the kernel has no whole orders, w is 0, or a buffer is too short.
    pub(crate) fn order0(&self, s: &mut [f64], w: usize, q0: &[f64], qd0: &[f64]) {
        let n = self.dof;
        let (_, entry) = self.code.entry().1.expect("a kernel with whole orders");
        assert!(
            w >= 1 && s.len() >= self.rows * w && q0.len() >= n && qd0.len() >= n,
            "order 0 of {n} coordinates and {} rows of {w}",
            self.rows
        );
        // SAFETY: the code writes and reads table entries r·w with rows r < `rows` (checked at
        // compilation) and reads q₀ and q̇₀ entries below n, all inside the buffers by the
        // assert; `self` keeps the code alive.
        unsafe { entry(w as i64, s.as_mut_ptr(), q0.as_ptr(), qd0.as_ptr()) }
    }

    /// Order k of the expansion as `Expansion::orders` computes it, given order 0 of every row
    /// and M₀ factored (`m0`): for k ≥ 1 the leaves' coefficient k and the recurrences, then
    /// q̈ₖ (from fₖ − Σⱼ Mⱼ q̈ₖ₋ⱼ and the solve with M₀) and q and q̇'s coefficient k + 1, in
    /// the table `s` of row width `w` and the coefficient buffers `q`, `v` and `qdd`.
    ///
    /// # Panics
    /// If the kernel has no whole orders, k + 1 is not below w, or a buffer is shorter than
    /// the expansion's layout.
    pub(crate) fn order(&self, k: usize, w: usize, [s, q, v, qdd]: [&mut [f64]; 4], m0: &[f64]) {
        let n = self.dof;
        let (entry, _) = self.code.entry().1.expect("a kernel with whole orders");
        assert!(
            k + 1 < w
                && s.len() >= self.rows * w
                && q.len() >= n * (w + 1)
                && v.len() >= n * (w + 1)
                && qdd.len() >= n * w
                && m0.len() >= n * n,
            "order {k} of an expansion of {n} coordinates and {} rows of {w}",
            self.rows
        );
        // SAFETY: the code reads and writes table entries r·w + j of rows r < `rows` (checked
        // at compilation) and j ≤ k < w, q and q̇ entries below (k + 2)·n ≤ (w + 1)·n, q̈ entries
        // i·w + j with i < n and j ≤ k, and M₀'s n² entries, all inside the buffers by the
        // assert; `self` keeps the code alive.
        unsafe {
            entry(
                k as i64,
                w as i64,
                s.as_mut_ptr(),
                q.as_mut_ptr(),
                v.as_mut_ptr(),
                qdd.as_mut_ptr(),
                m0.as_ptr(),
            )
        }
    }

    /// Coefficient k of every row the recurrences write, in the table `s` of row width `w`.
    ///
    /// # Panics
    /// If `s` has fewer than rows · w entries, k is not in 1..w, or the kernel has whole orders
    /// instead.
    pub(crate) fn run(&self, s: &mut [f64], w: usize, k: usize) {
        let entry = self
            .code
            .entry()
            .0
            .expect("a kernel of the recurrences alone");
        assert!(
            k >= 1 && k < w && s.len() >= self.rows * w,
            "order {k} of a table of {} rows of {w} in {} entries",
            self.rows,
            s.len()
        );
        // SAFETY: the code reads and writes entries r·w + j of rows r < `rows` (checked at
        // compilation) and j ≤ k < w, all inside `s` by the assert; `self` keeps the code alive.
        unsafe { entry(k as i64, w as i64, s.as_mut_ptr()) }
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
        let mut g = SeriesEmitter::new(b, table, Ix::Var(w), calls);
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

/// Generate, compile and link one whole order of the expansion for any order k and row width
/// w (read at run time): `Expansion::orders`' body, in its operations and order — for k ≥ 1
/// the leaves and the recurrences; fₖ − Σ_c (Σⱼ₌₁..ₖ₋₁ M_rc,ⱼ q̈_c,ₖ₋ⱼ in the lanes, then j = k)
/// from +0 over the entries of M that vary (as `conv_rows`; fₖ alone at k = 0); the solve
/// with M₀ as the unrolled expansion emits it; q̈ₖ, qₖ₊₁ = q̇ₖ · 1/(k + 1) and q̇ₖ₊₁ = q̈ₖ ·
/// 1/(k + 1).
fn define_order(module: &mut JITModule, program: &Recurrences) -> Result<OrderEntry> {
    let config = module.target_config();
    let ptr = config.pointer_type();
    let params = [types::I64, types::I64, ptr, ptr, ptr, ptr, ptr];
    let (id, mut ctx) = declare(module, "order", &params)?;
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let p = enter(&mut b);
        let (k, w, table, qp, vp, qddp, m0p) = (p[0], p[1], p[2], p[3], p[4], p[5], p[6]);
        let n = program.dof;
        let mut g = SeriesEmitter::new(b, table, Ix::Var(w), None);
        g.k = Ix::Var(k);
        // q's and q̇'s coefficient k, at k·n.
        let kn8 = g.b.ins().imul_imm_s(k, 8 * n as i64);
        let qk = g.b.ins().iadd(qp, kn8);
        let vk = g.b.ins().iadd(vp, kn8);
        let one = g.f64(1.0);
        // Orders k ≥ 1: the leaves and the recurrences (order 0 is set before the first call).
        let (recurrences, after) = (g.b.create_block(), g.b.create_block());
        g.b.ins().brif(k, recurrences, &[], after, &[]);
        g.b.switch_to_block(recurrences);
        g.b.seal_block(recurrences);
        for (base, leaf) in [(qk, &program.coords), (vk, &program.velocities)] {
            for (i, r) in leaf.iter().enumerate() {
                if let Some(r) = *r {
                    let x = g.load_at(base, i);
                    g.store(r, Ix::Var(k), x);
                }
            }
        }
        let kf = g.b.ins().fcvt_from_sint(types::F64, k);
        g.inv_k = g.b.ins().fdiv(one, kf);
        for op in &program.varying {
            g.op(op);
        }
        g.b.ins().jump(after, &[]);
        g.b.switch_to_block(after);
        g.b.seal_block(after);
        let first = g.b.ins().icmp_imm_s(condcodes::IntCC::Equal, k, 0);
        let km1 = g.b.ins().iadd_imm_s(k, -1);
        let w8 = g.w8;
        let mut rhs = Vec::with_capacity(n);
        for r in 0..n {
            let f = g.load(program.force[r], Ix::Var(k));
            let varying = &program.mass_varying[r * n..(r + 1) * n];
            if !varying.contains(&true) {
                rhs.push(f);
                continue;
            }
            let mut s = g.f64(0.0);
            for c in (0..n).filter(|&c| varying[c]) {
                let m = program.mass_full[r * n + c];
                let off = g.b.ins().imul_imm_s(w8, c as i64);
                let qdd_c = g.b.ins().iadd(qddp, off);
                let pm = g.row(m);
                let t = g.conv_loop_at(pm, qdd_c, 1, km1, k, false);
                let (mk, q0) = (g.load(m, Ix::Var(k)), g.load_at(qdd_c, 0));
                let last = g.b.ins().fmul(mk, q0);
                let t = g.b.ins().fadd(t, last);
                s = g.b.ins().fadd(s, t);
            }
            // At k = 0 the sums read q̈ of the last expansion: fₖ alone.
            let d = g.b.ins().fsub(f, s);
            rhs.push(g.b.ins().select(first, f, d));
        }
        // M₀ q̈ₖ = rhs as `emit_expansion` solves it (`linalg::ldlt_solve`'s operations).
        emit_solve(&mut g, program, m0p, &mut rhs);
        let k1 = g.b.ins().iadd_imm_s(k, 1);
        let k1f = g.b.ins().fcvt_from_sint(types::F64, k1);
        let next = g.b.ins().fdiv(one, k1f);
        let k8 = g.b.ins().ishl_imm_s(k, 3);
        for (i, &a) in rhs.iter().enumerate() {
            let off = g.b.ins().imul_imm_s(w8, i as i64);
            let row = g.b.ins().iadd(qddp, off);
            let at = g.b.ins().iadd(row, k8);
            g.store_at(at, 0, a);
            let vki = g.load_at(vk, i);
            let qn = g.b.ins().fmul(vki, next);
            g.store_at(qk, n + i, qn);
            let vn = g.b.ins().fmul(a, next);
            g.store_at(vk, n + i, vn);
        }
        g.b.ins().return_(&[]);
        g.b.finalize(config);
    }
    let code = link(module, id, &mut ctx)?;
    // SAFETY: `code` is the function just defined with the signature of `OrderEntry` in the
    // host's default calling convention, which is `extern "C"`.
    Ok(unsafe { std::mem::transmute::<*const u8, OrderEntry>(code) })
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
/// worst a run then costs about twice what the better choice in hindsight would have). A run
/// whose first step says it will take the count past this compiles at its start instead
/// (`Expansion::plan`): the compile is paid within the run either way. Measured again through
/// Python (`benches/taylor_first.py`, ci wheel, 2026-11-28, runs of 110–310 steps): the double
/// pendulum's compile 21 ms at order 15 (1e-12) and 14 ms at 12, repaid after 23 000–25 000
/// expansions; the forced two-mass's 4.1 ms at order 12, after 10 600.
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

/// Order 0 as the two kernels take it.
#[derive(Clone, Copy)]
enum Order0Form {
    /// The unrolled expansion's ([`Order0Entry`]): row width `order + 1`, q₀ and q̇₀ copied into
    /// the coefficient buffers too.
    Unrolled { order: usize },
    /// The order-by-order kernel's ([`SeriesOrder0Entry`]): row width read at run time, the
    /// coefficient buffers the caller's to fill.
    Series,
}

/// Generate, compile and link order 0 of the expansion in `form`: the leaves' rows from q₀
/// and q̇₀, then `order0`'s recurrences at k = 0; the address of the function, whose
/// signature is `form`'s entry.
fn define_order0_code(
    module: &mut JITModule,
    program: &Recurrences,
    form: Order0Form,
) -> Result<*const u8> {
    let config = module.target_config();
    let ptr = config.pointer_type();
    let params = match form {
        Order0Form::Unrolled { .. } => vec![ptr; 5],
        Order0Form::Series => vec![types::I64, ptr, ptr, ptr],
    };
    let (id, mut ctx) = declare(module, "order0", &params)?;
    let imports = import_libm(module, program, &mut ctx.func)?;
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let p = enter(&mut b);
        // The table, q₀, q̇₀, the row width and the coefficient buffers of q and q̇ (if written).
        let (table, q0, qd0, width, qp, vp) = match form {
            Order0Form::Unrolled { order } => {
                let w = Ix::Fixed(order + 1);
                (p[0], p[1], p[2], w, Some(p[3]), Some(p[4]))
            }
            Order0Form::Series => (p[1], p[2], p[3], Ix::Var(p[0]), None, None),
        };
        let mut g = SeriesEmitter::new(b, table, width, None);
        g.libm = imports;
        for (from, to, leaf) in [(q0, qp, &program.coords), (qd0, vp, &program.velocities)] {
            for (i, r) in leaf.iter().enumerate() {
                // Without buffers, only the leaves with a row are read.
                if to.is_none() && r.is_none() {
                    continue;
                }
                let x = g.load_at(from, i);
                if let Some(to) = to {
                    g.store_at(to, i, x);
                }
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
    link(module, id, &mut ctx)
}

/// [`define_order0_code`] for the unrolled expansion.
fn define_order0(m: &mut JITModule, program: &Recurrences, order: usize) -> Result<Order0Entry> {
    let code = define_order0_code(m, program, Order0Form::Unrolled { order })?;
    // SAFETY: `code` is the function just defined with the signature of `Order0Entry` in the
    // host's default calling convention, which is `extern "C"`.
    Ok(unsafe { std::mem::transmute::<*const u8, Order0Entry>(code) })
}

/// [`define_order0_code`] for the order-by-order kernel: its entry takes w, the table, q₀, q̇₀.
fn define_series_order0(m: &mut JITModule, program: &Recurrences) -> Result<SeriesOrder0Entry> {
    let code = define_order0_code(m, program, Order0Form::Series)?;
    // SAFETY: `code` is the function just defined with the signature of `SeriesOrder0Entry` in
    // the host's default calling convention, which is `extern "C"`.
    Ok(unsafe { std::mem::transmute::<*const u8, SeriesOrder0Entry>(code) })
}

/// The maths library's functions `program`'s order 0 calls, imported into `module` for `func`.
fn import_libm(
    module: &mut JITModule,
    program: &Recurrences,
    func: &mut cranelift_codegen::ir::Function,
) -> Result<Vec<(&'static str, FuncRef)>> {
    let ptr = module.target_config().pointer_type();
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
        imports.push((name, module.declare_func_in_func(id, func)));
    }
    Ok(imports)
}

/// Generate, compile and link the unrolled expansion and step; also the length of the buffer of
/// reversed rows it needs ([`SeriesEmitter::mirror`]).
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
        let flags = SeriesEmitter::flags();
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
    let flags = SeriesEmitter::flags();
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
/// ([`SeriesEmitter::mirror`]), in the order of their slots, each with whether the code computes its
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
        let mut g = SeriesEmitter::new(b, table, Ix::Fixed(w), None);
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
            // M₀ q̈ₖ = rhs (see `emit_solve`).
            emit_solve(&mut g, program, m0p, &mut rhs);
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

/// M₀ q̈ₖ = `rhs` in place, with M₀'s LDLᵀ factors at `m0p` (L below the diagonal, D's
/// reciprocals on it), as `linalg::ldlt_solve` (`ldlt_solve_pattern` without the entries of L
/// that are zero by structure): L y = b, D z = y, Lᵀ x = z — the one solve of the order-by-order
/// kernel and the unrolled expansion.
fn emit_solve(g: &mut SeriesEmitter<'_>, program: &Recurrences, m0p: Value, rhs: &mut [Value]) {
    let n = rhs.len();
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
}
