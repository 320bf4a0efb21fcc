//! A [`Tape`]'s `f64` program compiled by Cranelift to one machine-code function,
//! [`NativeTape`], and a compiled tape bound to parameter values, [`NativeFunction`].
//!
//! The instructions are lowered through the same table as the interpreter (`ins.rs`, `emit`), so
//! an instruction is added in one place. Slots become SSA values (the code is straight-line, so
//! no variables are needed); constants are loaded from the constants array, so one compiled tape
//! serves every parameter set; the transcendental functions call `extern "C"` wrappers of the
//! same `f64` methods the interpreter calls, and `c op x` forms are evaluated as the interpreter
//! does (`c / x` as `(1 / x) · c`, `cˣ` as `exp(x ln c)`), so the results are bit-identical.
//!
//! Safety by construction: the compiler checks every slot, constant, input and output index
//! against the tape's sizes before emitting a load or store, and rejects a read of a slot never
//! written; [`NativeTape::eval`] checks the slices' lengths against those sizes. The stack is
//! probed inline, so a large frame cannot jump over the guard page. Anything the compiler cannot
//! handle is an [`Error::InvalidInput`], on which the caller keeps the interpreter.

use super::{BACKTRACKING_UP_TO, Code, declare, enter, fail, jit_module, link};
use crate::error::{Error, Result};
use crate::expr::functions::unary_functions;
use crate::program::compile::{Input, Out, Tape};
use crate::program::eval::Function;
use crate::program::ins::{Emit, emit};
use crate::scalar::with_buf;
use cranelift_codegen::ir::{self, AbiParam, InstBuilder, MemFlagsData, Value, types};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::{FuncId, Linkage, Module};
use std::sync::Arc;

/// The compiled function: constants, t, q, q̇, outputs.
type Entry = unsafe extern "C" fn(*const f64, f64, *const f64, *const f64, *mut f64);

/// A tape compiled to machine code. Evaluate it with [`NativeTape::eval`], or bind it to
/// parameter values with [`Function::compile_native`].
pub struct NativeTape {
    code: Code<Entry>,
    consts: usize,
    dof: usize,
    reads_q: bool,
    reads_qd: bool,
    outputs: usize,
}

impl std::fmt::Debug for NativeTape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NativeTape")
            .field("consts", &self.consts)
            .field("dof", &self.dof)
            .field("outputs", &self.outputs)
            .finish_non_exhaustive()
    }
}

/// Byte offset of element `i` of an `f64` array, if it fits an `i32`.
fn offset(i: usize) -> Result<i32> {
    i.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| fail(format!("index {i} too large")))
}

impl NativeTape {
    /// Compile `tape` to machine code for the host.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when Cranelift has no backend for the host, fails, or the tape is
    /// malformed (an index out of range, a slot read before it is written): fall back to the
    /// interpreter.
    pub fn compile(tape: &Tape) -> Result<Self> {
        let code = Code::new(
            jit_module(tape.code.len() <= BACKTRACKING_UP_TO, &[])?,
            |m| Self::define(m, tape),
        )?;
        Ok(Self {
            code,
            consts: tape.consts.len(),
            dof: tape.inputs.dof,
            reads_q: tape
                .input_slots
                .iter()
                .any(|(_, i)| matches!(i, Input::Coord(_))),
            reads_qd: tape
                .input_slots
                .iter()
                .any(|(_, i)| matches!(i, Input::Velocity(_))),
            outputs: tape.outputs.len(),
        })
    }

    /// Generate, compile and link the function.
    fn define(module: &mut JITModule, tape: &Tape) -> Result<Entry> {
        let config = module.target_config();
        let ptr = config.pointer_type();
        let (id, mut ctx) = declare(module, "tape", &[ptr, types::F64, ptr, ptr, ptr])?;
        let mut fctx = FunctionBuilderContext::new();
        {
            let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
            let p = enter(&mut b);
            let (consts_ptr, t, q, qd, out) = (p[0], p[1], p[2], p[3], p[4]);
            let mut g = TapeEmitter {
                module,
                b,
                funcs: Vec::new(),
                consts_ptr,
                consts: vec![None; tape.consts.len()],
                slots: vec![None; tape.slots],
                acc: None,
                ptr,
                cos_slot: None,
                failed: None,
            };
            let dof = tape.inputs.dof;
            for &(slot, input) in &tape.input_slots {
                let v = match input {
                    Input::Time => t,
                    Input::Coord(k) | Input::Velocity(k) if k >= dof => {
                        return Err(fail(format!("input {k} beyond {dof} coordinates")));
                    }
                    Input::Coord(k) => g.load(q, k)?,
                    Input::Velocity(k) => g.load(qd, k)?,
                };
                // Not through `set`: as in the interpreter, inputs are not in the accumulator.
                *g.slots
                    .get_mut(slot as usize)
                    .ok_or_else(|| fail(format!("input slot {slot} out of range")))? = Some(v);
            }
            for ins in &tape.code {
                emit(ins, &mut g)?;
            }
            if let Some(e) = g.failed.take() {
                return Err(e);
            }
            for (k, o) in tape.outputs.iter().enumerate() {
                let v = match *o {
                    Out::Slot(i) => g.slot(i)?,
                    Out::Const(i) => g.constant(i)?,
                };
                let off = offset(k)?;
                g.b.ins().store(MemFlagsData::trusted(), v, out, off);
            }
            g.b.ins().return_(&[]);
            g.b.finalize(config);
        }
        let code = link(module, id, &mut ctx)?;
        // SAFETY: `code` is the function just defined with the signature of `Entry` in the
        // host's default calling convention, which is `extern "C"`.
        Ok(unsafe { std::mem::transmute::<*const u8, Entry>(code) })
    }

    /// Evaluate on (t, q, q̇) with `consts` (the constants of the compiled tape for some
    /// parameters, [`Function::constants`]) and write the outputs to `out`.
    ///
    /// # Panics
    /// If `consts` has not the tape's number of constants, `q` or `qd` is shorter than the
    /// tape's `dof` (when it reads them), or `out` is shorter than the number of outputs.
    #[inline]
    pub fn eval(&self, consts: &[f64], t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) {
        assert!(consts.len() == self.consts, "constants of another tape");
        assert!(
            (!self.reads_q || q.len() >= self.dof) && (!self.reads_qd || qd.len() >= self.dof),
            "a tape of {} coordinates evaluated with {} coordinates and {} velocities",
            self.dof,
            q.len(),
            qd.len()
        );
        assert!(
            out.len() >= self.outputs,
            "{} outputs written to {} values",
            self.outputs,
            out.len()
        );
        // SAFETY: the code reads `consts[i]` for i below the tape's constant count, `q[k]` and
        // `qd[k]` for k below its `dof` and only if it reads them, and writes `out[k]` for k
        // below its output count (all checked in `compile`), and the asserts above bound the
        // slices by these sizes. `self` keeps the code alive for the call.
        unsafe {
            (self.code.entry())(
                consts.as_ptr(),
                t,
                q.as_ptr(),
                qd.as_ptr(),
                out.as_mut_ptr(),
            )
        }
    }

    /// Number of outputs.
    pub fn outputs(&self) -> usize {
        self.outputs
    }
}

/// The code generator of one tape.
struct TapeEmitter<'a> {
    module: &'a mut JITModule,
    b: FunctionBuilder<'a>,
    /// The imported functions used so far.
    funcs: Vec<(&'static str, ir::FuncRef)>,
    consts_ptr: Value,
    /// Each constant, loaded at its first use.
    consts: Vec<Option<Value>>,
    slots: Vec<Option<Value>>,
    acc: Option<Value>,
    /// The pointer type, and the stack slot `sin_cos` returns the cosine in.
    ptr: ir::Type,
    cos_slot: Option<ir::StackSlot>,
    /// The first failure to declare a function.
    failed: Option<Error>,
}

impl TapeEmitter<'_> {
    fn load(&mut self, base: Value, i: usize) -> Result<Value> {
        let off = offset(i)?;
        Ok(self.b.ins().load(
            types::F64,
            MemFlagsData::trusted().with_readonly(),
            base,
            off,
        ))
    }

    /// Call the `f64` function `name` on `args` (the signature follows their types).
    fn call(&mut self, name: &'static str, args: &[Value]) -> Value {
        let f = match self.funcs.iter().find(|(n, _)| *n == name) {
            Some(&(_, f)) => f,
            None => {
                let mut sig = self.module.make_signature();
                for &a in args {
                    sig.params
                        .push(AbiParam::new(self.b.func.dfg.value_type(a)));
                }
                sig.returns.push(AbiParam::new(types::F64));
                let id: FuncId = match self.module.declare_function(name, Linkage::Import, &sig) {
                    Ok(id) => id,
                    Err(e) => {
                        // Reported after the instructions (`Emit`'s arithmetic cannot fail).
                        self.failed.get_or_insert(fail(e));
                        return self.f64(f64::NAN);
                    }
                };
                let f = self.module.declare_func_in_func(id, self.b.func);
                self.funcs.push((name, f));
                f
            }
        };
        let call = self.b.ins().call(f, args);
        self.b.inst_results(call)[0]
    }

    fn f64(&mut self, x: f64) -> Value {
        self.b.ins().f64const(x)
    }
}

/// The [`Emit`] methods of the functions of one argument that call the maths library: a call
/// of the wrapper registered under the symbol of their entry in `expr/functions.rs`.
macro_rules! libm_calls {
    ($($name:ident {
        doc: $doc:expr,
        name: $($py:literal)?,
        value: |$x:ident| $value:expr,
        tangent: |$d:ident, $a:ident, $y:ident, $da:ident| $tangent:expr,
        num: |$nx:ident| $num:expr,
        jet: |$jx:ident| $jet:expr,
        series: $series:expr,
        libm: $($sym:ident = $f:ident)?,
        ins: $u:ident, $ua:ident: $m:ident,
        dual_num: $($dn:ident)?,
    })*) => {
        $($(
            fn $m(&mut self, a: Value) -> Value {
                self.call(stringify!($sym), &[a])
            }
        )?)*
    };
}

impl Emit for TapeEmitter<'_> {
    type V = Value;

    unary_functions!(libm_calls);

    fn slot(&mut self, i: u32) -> Result<Value> {
        self.slots
            .get(i as usize)
            .copied()
            .flatten()
            .ok_or_else(|| fail(format!("slot {i} read before it is written")))
    }
    fn acc(&mut self) -> Result<Value> {
        self.acc
            .ok_or_else(|| fail("accumulator read before it is written"))
    }
    fn constant(&mut self, i: u32) -> Result<Value> {
        let i = i as usize;
        match self.consts.get(i) {
            None => Err(fail(format!("constant {i} out of range"))),
            Some(&Some(v)) => Ok(v),
            Some(None) => {
                let v = self.load(self.consts_ptr, i)?;
                self.consts[i] = Some(v);
                Ok(v)
            }
        }
    }
    fn set(&mut self, d: u32, v: Value) -> Result<()> {
        let slot = self
            .slots
            .get_mut(d as usize)
            .ok_or_else(|| fail(format!("slot {d} out of range")))?;
        *slot = Some(v);
        self.acc = Some(v);
        Ok(())
    }
    fn add(&mut self, a: Value, b: Value) -> Value {
        self.b.ins().fadd(a, b)
    }
    fn sub(&mut self, a: Value, b: Value) -> Value {
        self.b.ins().fsub(a, b)
    }
    fn mul(&mut self, a: Value, b: Value) -> Value {
        self.b.ins().fmul(a, b)
    }
    fn div(&mut self, a: Value, b: Value) -> Value {
        self.b.ins().fdiv(a, b)
    }
    fn neg(&mut self, a: Value) -> Value {
        self.b.ins().fneg(a)
    }
    fn add_c(&mut self, a: Value, c: Value) -> Value {
        self.add(a, c)
    }
    fn sub_c(&mut self, a: Value, c: Value) -> Value {
        self.sub(a, c)
    }
    fn c_sub(&mut self, a: Value, c: Value) -> Value {
        // −x + c, as the interpreter.
        let m = self.neg(a);
        self.add(m, c)
    }
    fn mul_c(&mut self, a: Value, c: Value) -> Value {
        self.mul(a, c)
    }
    fn div_c(&mut self, a: Value, c: Value) -> Value {
        self.div(a, c)
    }
    fn c_div(&mut self, a: Value, c: Value) -> Value {
        // (1 / x) · c, as the interpreter.
        let one = self.f64(1.0);
        let r = self.div(one, a);
        self.mul(r, c)
    }
    fn pow_c(&mut self, a: Value, c: Value) -> Value {
        self.call("lagrangian_powf", &[a, c])
    }
    fn c_pow(&mut self, a: Value, c: Value) -> Value {
        // exp(x ln c), as the interpreter.
        let l = self.ln(c);
        let p = self.mul(a, l);
        self.exp(p)
    }
    fn powd(&mut self, a: Value, b: Value) -> Value {
        self.call("lagrangian_powf", &[a, b])
    }
    fn atan2(&mut self, a: Value, b: Value) -> Value {
        self.call("lagrangian_atan2", &[a, b])
    }
    fn atan2_c(&mut self, a: Value, c: Value) -> Value {
        self.atan2(a, c)
    }
    fn c_atan2(&mut self, a: Value, c: Value) -> Value {
        self.atan2(c, a)
    }
    fn sin_cos(&mut self, a: Value) -> (Value, Value) {
        // One call: the cosine comes back through an 8-byte slot of this function's frame.
        let slot = *self.cos_slot.get_or_insert_with(|| {
            self.b.create_sized_stack_slot(ir::StackSlotData::new(
                ir::StackSlotKind::ExplicitSlot,
                8,
                3,
            ))
        });
        let addr = self.b.ins().stack_addr(self.ptr, slot, 0);
        let s = self.call("lagrangian_sin_cos", &[a, addr]);
        let c = self.b.ins().stack_load(self.ptr, types::F64, slot, 0);
        (s, c)
    }
    fn sqrt(&mut self, a: Value) -> Value {
        self.b.ins().sqrt(a)
    }
    fn abs(&mut self, a: Value) -> Value {
        self.b.ins().fabs(a)
    }
    fn sign(&mut self, a: Value) -> Value {
        // 1 for a > 0, −1 otherwise (NaN included), as `graph::sign`.
        let zero = self.b.ins().f64const(0.0);
        let positive = self
            .b
            .ins()
            .fcmp(ir::condcodes::FloatCC::GreaterThan, a, zero);
        let (one, minus_one) = (self.b.ins().f64const(1.0), self.b.ins().f64const(-1.0));
        self.b.ins().select(positive, one, minus_one)
    }
    fn sqr(&mut self, a: Value) -> Value {
        self.mul(a, a)
    }
    fn powi(&mut self, a: Value, n: i32) -> Value {
        let n = self.b.ins().iconst(types::I32, i64::from(n));
        self.call("lagrangian_powi", &[a, n])
    }
}

/// A [`NativeTape`] bound to parameter values: the native twin of a [`Function`] at `f64`.
/// Cloning shares the code.
#[derive(Debug, Clone)]
pub struct NativeFunction {
    tape: Arc<Tape>,
    native: Arc<NativeTape>,
    consts: Arc<[f64]>,
}

impl Function {
    /// Compile this function's tape to machine code, bound to the same parameter values.
    ///
    /// # Errors
    /// As [`NativeTape::compile`]: keep evaluating `self` then.
    pub fn compile_native(&self) -> Result<NativeFunction> {
        Ok(NativeFunction {
            tape: self.tape.clone(),
            native: Arc::new(NativeTape::compile(&self.tape)?),
            consts: self.consts.clone(),
        })
    }

    /// The constants of the tape for this function's parameters (the `consts` of
    /// [`NativeTape::eval`]).
    pub fn constants(&self) -> &[f64] {
        &self.consts
    }
}

impl NativeFunction {
    /// The same code with other parameter values (only the constants are recomputed).
    ///
    /// # Errors
    /// As [`Function::new`].
    pub fn with_parameters(&self, params: &[f64]) -> Result<Self> {
        Ok(Self {
            tape: self.tape.clone(),
            native: self.native.clone(),
            consts: self.tape.constants(params)?.into(),
        })
    }

    /// The compiled tape.
    pub fn native(&self) -> &NativeTape {
        &self.native
    }

    /// Write the outputs at (t, q, q̇) to `out`.
    ///
    /// # Panics
    /// As [`NativeTape::eval`].
    #[inline]
    pub fn eval_into(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) {
        self.native.eval(&self.consts, t, q, qd, out)
    }

    /// The first output at (t, q, q̇).
    #[inline]
    pub fn eval(&self, t: f64, q: &[f64], qd: &[f64]) -> f64 {
        with_buf::<f64, 16, _>(self.native.outputs.max(1), 0.0, |out| {
            self.eval_into(t, q, qd, out);
            out[0]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::graph::{Binary, Graph, Unary};
    use crate::program::inputs::Inputs;
    use crate::program::ins::Ins;
    use std::collections::BTreeSet;
    use std::time::Instant;

    const UNARY: [Unary; Unary::ALL.len()] = Unary::ALL;
    const BINARY: [Binary; 6] = Binary::ALL;

    /// A deterministic generator (xorshift64*).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
        /// A number in (−r, r).
        fn uniform(&mut self, r: f64) -> f64 {
            ((self.next() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * r
        }
    }

    /// Equal bits, or both NaN.
    fn same(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    /// The kinds of instruction (`Ins` variant names) of a tape.
    fn kinds(tape: &Tape) -> BTreeSet<String> {
        tape.code
            .iter()
            .map(|i| format!("{i:?}").split('(').next().unwrap().to_string())
            .collect()
    }

    /// Compile `f` and check it against the interpreter at (t, q, q̇), bit for bit.
    fn check(f: &Function, native: &NativeFunction, t: f64, q: &[f64], qd: &[f64]) {
        let n = f.tape().outputs();
        let (mut want, mut got) = (vec![0.0; n], vec![f64::MAX; n]);
        f.eval_into(t, q, qd, &mut want);
        native.eval_into(t, q, qd, &mut got);
        for k in 0..n {
            assert!(
                same(want[k], got[k]),
                "output {k} at t = {t}, q = {q:?}, q̇ = {qd:?}: interpreter {}, native {}\n{:?}",
                want[k],
                got[k],
                f.tape().code
            );
        }
    }

    /// f(x, y) for every function, in every form (variable operands, a constant operand on
    /// either side, the operand in the accumulator or not).
    fn every_form(g: &mut Graph) -> Vec<usize> {
        let (x, y, t) = (g.coord(0), g.velocity(0), g.time());
        let c = g.param(0);
        let mut outs = Vec::new();
        for f in UNARY {
            outs.push(g.unary(f, x).unwrap());
            // The operand is the previous result.
            let s = g.binary(Binary::Add, x, y).unwrap();
            outs.push(g.unary(f, s).unwrap());
        }
        for f in BINARY {
            outs.push(g.binary(f, x, y).unwrap());
            outs.push(g.binary(f, x, c).unwrap());
            outs.push(g.binary(f, c, x).unwrap());
            for (a, b) in [(0, 1), (1, 0)] {
                let s = g.binary(Binary::Mul, x, t).unwrap();
                let ops = [s, y];
                outs.push(g.binary(f, ops[a], ops[b]).unwrap());
                let s = g.binary(Binary::Sub, y, t).unwrap();
                let ops = [s, c];
                outs.push(g.binary(f, ops[a], ops[b]).unwrap());
            }
        }
        for k in [-3, -1, 0, 1, 2, 3, 7] {
            outs.push(g.powi(x, k).unwrap());
            let s = g.binary(Binary::Add, x, t).unwrap();
            outs.push(g.powi(s, k).unwrap());
        }
        let s = g.unary(Unary::Sin, y).unwrap();
        let c = g.unary(Unary::Cos, y).unwrap();
        outs.push(g.binary(Binary::Mul, s, c).unwrap());
        let d = g.binary(Binary::Sub, y, x).unwrap();
        let s = g.unary(Unary::Sin, d).unwrap();
        let c = g.unary(Unary::Cos, d).unwrap();
        outs.push(g.binary(Binary::Add, s, c).unwrap());
        outs
    }

    #[test]
    fn compile_matches_interpreter_on_every_instruction() {
        let mut g = Graph::new();
        let outs = every_form(&mut g);
        let tape = Tape::new(&g, &outs, Inputs::kinetic(1, 1), "every form").unwrap();
        let kinds = kinds(&tape);
        // The random graphs below reach the other kinds.
        assert!(kinds.len() >= 33, "{} kinds: {kinds:?}", kinds.len());
        let f = Function::new(tape.into(), &[1.7]).unwrap();
        let native = f.compile_native().unwrap();
        let mut rng = Rng(7);
        let special = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            1e300,
            -1e-300,
            f64::INFINITY,
            f64::NAN,
        ];
        for &x in &special {
            for &y in &special {
                check(&f, &native, 0.25, &[x], &[y]);
            }
        }
        for _ in 0..200 {
            let (x, y, t) = (rng.uniform(3.0), rng.uniform(3.0), rng.uniform(2.0));
            check(&f, &native, t, &[x], &[y]);
        }
        for p in [-2.0, 0.0, 0.3] {
            let (f, native) = (
                f.with_parameters(&[p]).unwrap(),
                native.with_parameters(&[p]).unwrap(),
            );
            check(&f, &native, 0.5, &[-0.7], &[1.3]);
        }
    }

    /// A random graph of `size` nodes over t, q₀, q₁, q̇₀, q̇₁ and two parameters; its outputs
    /// are its last `outputs` nodes.
    fn random_graph(rng: &mut Rng, size: usize, outputs: usize) -> (Graph, Vec<usize>) {
        let mut g = Graph::new();
        let mut nodes = vec![
            g.time(),
            g.coord(0),
            g.coord(1),
            g.velocity(0),
            g.velocity(1),
            g.param(0),
            g.param(1),
            g.constant(2.5),
        ];
        while nodes.len() < size {
            let a = nodes[rng.below(nodes.len())];
            // Prefer recent nodes so that the graph is deep, not wide.
            let recent = nodes.len() - 1 - rng.below(nodes.len().min(6));
            let b = nodes[recent];
            let node = match rng.below(10) {
                0..=2 => g.unary(UNARY[rng.below(UNARY.len())], b),
                3 => g.powi(b, rng.below(9) as i32 - 4),
                _ => {
                    let f = BINARY[rng.below(BINARY.len())];
                    if rng.below(2) == 0 {
                        g.binary(f, a, b)
                    } else {
                        g.binary(f, b, a)
                    }
                }
            };
            if let Ok(n) = node {
                nodes.push(n);
            }
        }
        let outs = nodes[nodes.len() - outputs..].to_vec();
        (g, outs)
    }

    #[test]
    fn compile_matches_interpreter_on_random_graphs() {
        let mut rng = Rng(0x5eed);
        let mut kinds_seen = BTreeSet::new();
        let (mut compiled, mut non_finite) = (0, 0);
        for case in 0..150 {
            let (g, outs) = random_graph(&mut rng, 10 + case % 40, 1 + case % 4);
            let tape = Tape::new(&g, &outs, Inputs::kinetic(2, 2), "random").unwrap();
            kinds_seen.extend(kinds(&tape));
            let params = [rng.uniform(2.0), rng.uniform(2.0)];
            // Parameters whose constant subexpressions are not finite are rejected before any
            // evaluation, by both.
            let Ok(f) = Function::new(tape.into(), &params) else {
                continue;
            };
            let native = f.compile_native().unwrap();
            compiled += 1;
            for _ in 0..20 {
                let scale = [0.5, 2.0, 50.0][rng.below(3)];
                let q = [rng.uniform(scale), rng.uniform(scale)];
                let qd = [rng.uniform(scale), rng.uniform(scale)];
                let t = rng.uniform(scale);
                check(&f, &native, t, &q, &qd);
                let mut out = vec![0.0; f.tape().outputs()];
                f.eval_into(t, &q, &qd, &mut out);
                non_finite += out.iter().filter(|x| !x.is_finite()).count();
            }
        }
        println!(
            "{compiled} graphs compiled, {non_finite} non-finite outputs, {} instruction kinds: \
             {kinds_seen:?}",
            kinds_seen.len()
        );
        assert!(compiled >= 100 && non_finite > 0);
        // Every kind of instruction (64) but two of the rarest.
        assert!(kinds_seen.len() >= 62);
    }

    /// T and U of the equal double pendulum (parameters m, l, g), as
    /// `models::double_pendulum_equal` builds them (written out here: the models are a floor
    /// above the code generator).
    fn double_pendulum(g: &mut Graph) -> (usize, usize) {
        let (m, l, grav) = (g.param(0), g.param(1), g.param(2));
        let (th1, th2, w1, w2) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
        let (half, two) = (g.constant(0.5), g.constant(2.0));
        let l2 = g.powi(l, 2).unwrap();
        let k = g.binary(Binary::Mul, half, m).unwrap();
        let k = g.binary(Binary::Mul, k, l2).unwrap();
        let w1s = g.powi(w1, 2).unwrap();
        let w2s = g.powi(w2, 2).unwrap();
        let a = g.binary(Binary::Mul, two, w1s).unwrap();
        let a = g.binary(Binary::Add, a, w2s).unwrap();
        let d = g.binary(Binary::Sub, th1, th2).unwrap();
        let c = g.unary(Unary::Cos, d).unwrap();
        let x = g.binary(Binary::Mul, two, w1).unwrap();
        let x = g.binary(Binary::Mul, x, w2).unwrap();
        let x = g.binary(Binary::Mul, x, c).unwrap();
        let a = g.binary(Binary::Add, a, x).unwrap();
        let kinetic = g.binary(Binary::Mul, k, a).unwrap();
        let mgl = g.binary(Binary::Mul, m, grav).unwrap();
        let mgl = g.binary(Binary::Mul, mgl, l).unwrap();
        let c1 = g.unary(Unary::Cos, th1).unwrap();
        let c2 = g.unary(Unary::Cos, th2).unwrap();
        let c1 = g.binary(Binary::Mul, two, c1).unwrap();
        let s = g.binary(Binary::Add, c1, c2).unwrap();
        let u = g.binary(Binary::Mul, mgl, s).unwrap();
        let potential = g.unary(Unary::Neg, u).unwrap();
        (kinetic, potential)
    }

    #[test]
    fn compile_double_pendulum() {
        let mut g = Graph::new();
        let (k, u) = double_pendulum(&mut g);
        let params = [1.3, 0.7, 9.81];
        let t = Tape::new(&g, &[k], Inputs::kinetic(2, 3), "T").unwrap();
        let both = Tape::new(&g, &[k, u], Inputs::kinetic(2, 3), "T, U").unwrap();
        let u = Tape::new(&g, &[u], Inputs::potential(2, 3), "U").unwrap();
        let mut rng = Rng(3);
        for tape in [t, u, both] {
            let f = Function::new(tape.into(), &params).unwrap();
            let native = f.compile_native().unwrap();
            for _ in 0..50 {
                let q = [rng.uniform(3.0), rng.uniform(3.0)];
                let qd = [rng.uniform(5.0), rng.uniform(5.0)];
                check(&f, &native, 0.0, &q, &qd);
            }
        }
        // Against the closed form.
        let t = Tape::new(&g, &[k], Inputs::kinetic(2, 3), "T").unwrap();
        let native = Function::new(t.into(), &params)
            .unwrap()
            .compile_native()
            .unwrap();
        let (q, qd): ([f64; 2], [f64; 2]) = ([0.3, -1.1], [0.8, -0.4]);
        let (m, l) = (params[0], params[1]);
        let want = 0.5
            * m
            * l
            * l
            * (2.0 * qd[0] * qd[0] + qd[1] * qd[1] + 2.0 * qd[0] * qd[1] * (q[0] - q[1]).cos());
        assert!((native.eval(0.0, &q, &qd) - want).abs() <= 1e-15 * want.abs());
    }

    #[test]
    fn compile_rejects_malformed_tapes() {
        let mut g = Graph::new();
        let x = g.coord(0);
        let s = g.unary(Unary::Sin, x).unwrap();
        let tape = Tape::new(&g, &[s], Inputs::potential(1, 0), "U").unwrap();
        let bad = |edit: &dyn Fn(&mut Tape)| {
            let mut t = tape.clone();
            edit(&mut t);
            let err = NativeTape::compile(&t).unwrap_err();
            assert!(matches!(err, Error::InvalidInput { .. }), "{err}");
        };
        bad(&|t| t.code.push(Ins::Neg(0, 99)));
        bad(&|t| t.code.push(Ins::Neg(99, 0)));
        bad(&|t| t.code.push(Ins::AddC(0, 0, 5)));
        bad(&|t| t.outputs.push(Out::Slot(42)));
        bad(&|t| t.input_slots.push((0, Input::Coord(1))));
        bad(&|t| t.code.insert(0, Ins::NegA(0)));
        // An unwritten slot in range.
        bad(&|t| {
            t.slots += 1;
            t.outputs.push(Out::Slot(t.slots as u32 - 1));
        });
        assert!(NativeTape::compile(&tape).is_ok());
    }

    #[test]
    #[should_panic(expected = "coordinates")]
    fn eval_checks_lengths() {
        let mut g = Graph::new();
        let x = g.coord(1);
        let tape = Tape::new(&g, &[x], Inputs::potential(2, 0), "U").unwrap();
        let native = NativeTape::compile(&tape).unwrap();
        native.eval(&[], 0.0, &[1.0], &[], &mut [0.0]);
    }

    #[test]
    fn compile_shares_code_across_threads() {
        fn is_send_sync<T: Send + Sync>() {}
        is_send_sync::<NativeTape>();
        is_send_sync::<NativeFunction>();
        let mut g = Graph::new();
        let (k, _) = double_pendulum(&mut g);
        let t = Tape::new(&g, &[k], Inputs::kinetic(2, 3), "T").unwrap();
        let f = Function::new(t.into(), &[1.0, 1.0, 9.81]).unwrap();
        let native = f.compile_native().unwrap();
        let want = f.eval(0.0, &[0.1, 0.2], &[0.3, 0.4]);
        std::thread::scope(|s| {
            for _ in 0..2 {
                s.spawn(|| assert_eq!(native.eval(0.0, &[0.1, 0.2], &[0.3, 0.4]), want));
            }
        });
    }

    #[test]
    fn compile_large_tape() {
        // About 10 000 instructions: a long random program, several outputs.
        let mut rng = Rng(11);
        let mut g = Graph::new();
        let (x, y) = (g.coord(0), g.velocity(0));
        let mut acc = vec![x, y];
        let mut outs = Vec::new();
        for k in 0..3400 {
            // Everything is reachable from the last output.
            let last = *acc.last().unwrap();
            let c = g.constant(1.0 + (k % 97) as f64 / 97.0);
            let p = g.binary(BINARY[k % 4], last, c).unwrap();
            let n = g
                .unary([Unary::Sin, Unary::Cos, Unary::Abs][k % 3], p)
                .unwrap();
            let b = acc[acc.len() - 1 - rng.below(acc.len().min(8))];
            let n = g.binary(BINARY[(k / 4) % 3], n, b).unwrap();
            acc.push(n);
            if k % 1000 == 999 || k == 3399 {
                outs.push(n);
            }
        }
        let tape = Tape::new(&g, &outs, Inputs::kinetic(1, 0), "large").unwrap();
        let start = Instant::now();
        let f = Function::new(tape.into(), &[]).unwrap();
        let native = f.compile_native().unwrap();
        println!(
            "{} instructions compiled in {:.1} ms",
            f.tape().instructions(),
            start.elapsed().as_secs_f64() * 1e3
        );
        assert!(f.tape().instructions() >= 9000);
        check(&f, &native, 0.0, &[0.4], &[-0.2]);
    }
}
