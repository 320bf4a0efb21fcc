//! The Taylor recurrences ([`Op`]) as machine code (feature `jit`): one Cranelift function that
//! computes coefficient k ≥ 1 of every row that varies, for any order k and row width w given at
//! the call. Each convolution is a loop in the code (small programs) or a call of the
//! interpreter's own sum (large ones, [`INLINE_UP_TO`]), so the code grows with the graph and
//! not with the order.
//!
//! The operations and their order are those of [`Op::apply`] (the same four lanes per sum, no
//! fused multiply–add), so the coefficients are bit-identical to the interpreter's, which stays
//! the fallback and the reference. Safety by construction: every row an operation reads or
//! writes is checked against the table's row count before any code is emitted, and
//! [`SeriesKernel::run`] checks the table's length, the width and the order.

use super::native::{Code, fail, jit_module};
use super::taylor::{LANES, Op};

use crate::error::Result;
use cranelift_codegen::ir::{
    AbiParam, BlockArg, FuncRef, InstBuilder, MemFlagsData, Value, condcodes, types,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::{Linkage, Module};

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

/// The recurrences of one [`TaylorProgram`](super::TaylorProgram) as machine code.
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
fn rows_of(op: &Op) -> Vec<usize> {
    match *op {
        Op::Copy { out, a }
        | Op::Neg { out, a }
        | Op::Exp { out, a }
        | Op::Ln { out, a }
        | Op::Sqrt { out, a }
        | Op::Abs { out, a }
        | Op::Sign { out, a } => vec![out, a],
        Op::Recip { out, b } => vec![out, b],
        Op::Add { out, a, b }
        | Op::Sub { out, a, b }
        | Op::Mul { out, a, b }
        | Op::Div { out, a, b } => vec![out, a, b],
        Op::Scale { out, a, c } | Op::DivC { out, a, c } => vec![out, a, c],
        Op::SinCos { s, c, a, .. } => vec![s, c, a],
        Op::Tan { out, w, a, .. } => vec![out, w, a],
        Op::Atan2 { out, y, x, d, r } => vec![out, y, x, d, r],
    }
}

impl SeriesKernel {
    /// Compile `ops` (recurrences over a table of `rows` rows) for the host.
    ///
    /// # Errors
    /// [`Error::InvalidInput`](crate::Error::InvalidInput) when a row is out of range, Cranelift
    /// has no backend for the host or fails: the interpreter runs the recurrences instead.
    pub(crate) fn compile(ops: &[Op], rows: usize) -> Result<Self> {
        if let Some(r) = ops.iter().flat_map(rows_of).find(|&r| r >= rows) {
            return Err(fail(format!("row {r} of a table of {rows}")));
        }
        // About twenty instructions per operation and loop.
        // About twenty instructions per recurrence with its loops, four with calls.
        let inline = ops.len() <= INLINE_UP_TO;
        let module = jit_module(if inline { 20 } else { 4 } * ops.len())?;
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

/// Generate, compile and link the function.
fn define(module: &mut JITModule, ops: &[Op], inline: bool) -> Result<Entry> {
    let config = module.target_config();
    let ptr = config.pointer_type();
    let mut ctx = module.make_context();
    let sig = &mut ctx.func.signature;
    sig.params
        .extend([AbiParam::new(types::I64), AbiParam::new(types::I64)]);
    sig.params.push(AbiParam::new(ptr));
    let id = module
        .declare_function("series", Linkage::Local, &ctx.func.signature)
        .map_err(fail)?;
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let entry = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        b.seal_block(entry);
        let p = b.block_params(entry).to_vec();
        let (k, w, table) = (p[0], p[1], p[2]);
        let w8 = b.ins().ishl_imm_s(w, 3);
        let k8 = b.ins().ishl_imm_s(k, 3);
        let kf = b.ins().fcvt_from_sint(types::F64, k);
        let km1 = b.ins().iadd_imm_s(k, -1);
        let mut conv = module.make_signature();
        conv.params.extend([AbiParam::new(ptr), AbiParam::new(ptr)]);
        conv.params.extend([AbiParam::new(types::I64); 3]);
        conv.params.push(AbiParam::new(types::I32));
        conv.returns.push(AbiParam::new(types::F64));
        let conv = module
            .declare_function("lagrangian_conv", Linkage::Import, &conv)
            .map_err(fail)?;
        let conv_fn = module.declare_func_in_func(conv, b.func);
        let mut g = Gen {
            b,
            table,
            w8,
            k8,
            k,
            km1,
            kf,
            conv_fn,
            inline,
        };
        for op in ops {
            g.op(op);
        }
        g.b.ins().return_(&[]);
        g.b.finalize(config);
    }
    module.define_function(id, &mut ctx).map_err(fail)?;
    module.clear_context(&mut ctx);
    module.finalize_definitions().map_err(fail)?;
    let code = module.get_finalized_function(id);
    // SAFETY: `code` is the function just defined with the signature of `Entry` in the host's
    // default calling convention, which is `extern "C"`.
    Ok(unsafe { std::mem::transmute::<*const u8, Entry>(code) })
}

struct Gen<'a> {
    b: FunctionBuilder<'a>,
    table: Value,
    /// w·8, k·8 (bytes), k, k − 1, and k as a float.
    w8: Value,
    k8: Value,
    k: Value,
    km1: Value,
    kf: Value,
    /// `lagrangian_conv`, imported.
    conv_fn: FuncRef,
    /// Whether convolutions are loops in the code, else calls.
    inline: bool,
}

impl Gen<'_> {
    fn flags() -> MemFlagsData {
        MemFlagsData::trusted()
    }

    /// The address of row r's coefficient 0.
    fn row(&mut self, r: usize) -> Value {
        let off = self.b.ins().imul_imm_s(self.w8, r as i64);
        self.b.ins().iadd(self.table, off)
    }

    /// Row r's coefficient k.
    fn at_k(&mut self, r: usize) -> Value {
        let base = self.row(r);
        let addr = self.b.ins().iadd(base, self.k8);
        self.b.ins().load(types::F64, Self::flags(), addr, 0)
    }

    /// Row r's coefficient 0.
    fn at0(&mut self, r: usize) -> Value {
        let base = self.row(r);
        self.b.ins().load(types::F64, Self::flags(), base, 0)
    }

    /// Row r's coefficient at the index `j` (an integer value).
    fn store_at(&mut self, r: usize, j: Value, v: Value) {
        let base = self.row(r);
        let off = self.b.ins().ishl_imm_s(j, 3);
        let addr = self.b.ins().iadd(base, off);
        self.b.ins().store(Self::flags(), v, addr, 0);
    }

    fn store_k(&mut self, r: usize, v: Value) {
        let k = self.k;
        self.store_at(r, k, v);
    }

    fn f64(&mut self, x: f64) -> Value {
        self.b.ins().f64const(x)
    }

    /// Σⱼ₌ₗₒ..ₕᵢ [j] aⱼ b_(kk − j), in the lanes and order of `conv` in `taylor.rs`: a loop
    /// emitted here for small programs ([`INLINE_UP_TO`]), else a call of the interpreter's own
    /// sum, `lagrangian_conv`.
    fn conv(&mut self, a: usize, b: usize, lo: i64, hi: Value, kk: Value, weighted: bool) -> Value {
        if self.inline {
            return self.conv_loop(a, b, lo, hi, kk, weighted);
        }
        let (pa, pb) = (self.row(a), self.row(b));
        let lo = self.b.ins().iconst(types::I64, lo);
        let weighted = self.b.ins().iconst(types::I32, i64::from(weighted));
        let call = self
            .b
            .ins()
            .call(self.conv_fn, &[pa, pb, lo, hi, kk, weighted]);
        self.b.inst_results(call)[0]
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
            let t = self.term(p[1], p[2], p[3], i as i64, weighted);
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
        let t = self.term(p[1], p[2], p[3], 0, weighted);
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

    /// Term j + i of a convolution: [(j + i)] a_(j+i) b_(kk−j−i), with `pa` at aⱼ, `pb` at
    /// b_(kk−j) and `jf` = j.
    fn term(&mut self, pa: Value, pb: Value, jf: Value, i: i64, weighted: bool) -> Value {
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

    /// Coefficient k of `op`'s rows, as [`Op::apply`] computes it for k ≥ 1.
    fn op(&mut self, op: &Op) {
        let (k, km1, kf) = (self.k, self.km1, self.kf);
        let (out, value) = match *op {
            Op::Copy { out, a } => (out, self.at_k(a)),
            Op::Neg { out, a } => {
                let x = self.at_k(a);
                (out, self.b.ins().fneg(x))
            }
            Op::Add { out, a, b } => {
                let (x, y) = (self.at_k(a), self.at_k(b));
                (out, self.b.ins().fadd(x, y))
            }
            Op::Sub { out, a, b } => {
                let (x, y) = (self.at_k(a), self.at_k(b));
                (out, self.b.ins().fsub(x, y))
            }
            Op::Scale { out, a, c } => {
                let (x, y) = (self.at_k(a), self.at0(c));
                (out, self.b.ins().fmul(x, y))
            }
            Op::Mul { out, a, b } => (out, self.conv(a, b, 0, k, k, false)),
            Op::DivC { out, a, c } => {
                let (x, y) = (self.at_k(a), self.at0(c));
                (out, self.b.ins().fdiv(x, y))
            }
            Op::Div { out, a, b } => {
                let x = self.at_k(a);
                let s = self.conv(b, out, 1, k, k, false);
                let n = self.b.ins().fsub(x, s);
                let d = self.at0(b);
                (out, self.b.ins().fdiv(n, d))
            }
            Op::Recip { out, b } => {
                let s = self.conv(b, out, 1, k, k, false);
                let n = self.b.ins().fneg(s);
                let d = self.at0(b);
                (out, self.b.ins().fdiv(n, d))
            }
            Op::Exp { out, a } => {
                let s = self.conv(a, out, 1, k, k, true);
                (out, self.b.ins().fdiv(s, kf))
            }
            Op::Ln { out, a } => {
                let s = self.conv(out, a, 1, km1, k, true);
                let s = self.b.ins().fdiv(s, kf);
                let x = self.at_k(a);
                let n = self.b.ins().fsub(x, s);
                let d = self.at0(a);
                (out, self.b.ins().fdiv(n, d))
            }
            Op::Sqrt { out, a } => {
                let s = self.conv(out, out, 1, km1, k, false);
                let x = self.at_k(a);
                let n = self.b.ins().fsub(x, s);
                let two = self.f64(2.0);
                let r0 = self.at0(out);
                let d = self.b.ins().fmul(two, r0);
                (out, self.b.ins().fdiv(n, d))
            }
            Op::SinCos {
                s,
                c,
                a,
                hyperbolic,
            } => {
                let sv = self.conv(a, c, 1, k, k, true);
                let sv = self.b.ins().fdiv(sv, kf);
                let cv = self.conv(a, s, 1, k, k, true);
                let cv = self.b.ins().fdiv(cv, kf);
                let cv = if hyperbolic {
                    cv
                } else {
                    self.b.ins().fneg(cv)
                };
                self.store_k(s, sv);
                (c, cv)
            }
            Op::Tan {
                out,
                w,
                a,
                hyperbolic,
            } => {
                let t = self.conv(a, w, 1, k, k, true);
                let t = self.b.ins().fdiv(t, kf);
                self.store_k(out, t);
                let sq = self.conv(out, out, 0, k, k, false);
                let sq = if hyperbolic {
                    self.b.ins().fneg(sq)
                } else {
                    sq
                };
                (w, sq)
            }
            Op::Abs { out, a } => {
                let x = self.at_k(a);
                let x0 = self.at0(a);
                let zero = self.f64(0.0);
                let positive = self.b.ins().fcmp(condcodes::FloatCC::GreaterThan, x0, zero);
                let m = self.b.ins().fneg(x);
                (out, self.b.ins().select(positive, x, m))
            }
            Op::Sign { out, .. } => (out, self.f64(0.0)),
            Op::Atan2 { out, y, x, d, r } => {
                let xx = self.conv(x, x, 0, k, k, false);
                let yy = self.conv(y, y, 0, k, k, false);
                let dk = self.b.ins().fadd(xx, yy);
                self.store_k(d, dk);
                let yx = self.conv(y, x, 1, k, k, true);
                let xy = self.conv(x, y, 1, k, k, true);
                let n = self.b.ins().fsub(yx, xy);
                let dr = self.conv(d, r, 1, km1, km1, false);
                let n = self.b.ins().fsub(n, dr);
                let d0 = self.at0(d);
                let rk = self.b.ins().fdiv(n, d0);
                self.store_at(r, km1, rk);
                (out, self.b.ins().fdiv(rk, kf))
            }
        };
        self.store_k(out, value);
    }
}
